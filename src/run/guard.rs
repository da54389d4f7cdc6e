//! Which folders a command may write into: none holding a run of another
//! design, checked at the folder, up its resolved path and in the level
//! folders of a run with outer levels.

use std::path::{Path, PathBuf};

use super::{RunError, RunRecord};
use crate::plan::Plan;

/// The record of the run in `out`, if any, refusing a run of a design other
/// than the one hashing to `design_sha256`, and a folder with no run yet
/// whose `report/` holds someone's files (`refuse_others_report`; not
/// the top of a study of levels, a multiverse's, whose report is its
/// levels' pooled one): what every command that writes into a run
/// directory calls first, before anything (simulated data included) is
/// written there.
pub fn check_out(out: &Path, design_sha256: &str) -> Result<Option<RunRecord>, RunError> {
    let previous = RunRecord::read(out)?;
    match &previous {
        Some(p) if p.design_sha256 != design_sha256 => {
            Err(RunError::OtherDesign { dir: out.display().to_string(), sha256: p.design_sha256.clone() })
        }
        None if level_runs(out).is_empty() => refuse_others_report(out).map(|()| None),
        _ => Ok(previous),
    }
}

/// [`check_out`] for a plan: a multi-split study's folder, or a per-seed
/// draws study's, holds no `run.json` of its own (its `cells.csv` and
/// report pool the splits or the seeds' draws), so each split's or draw's
/// folder is checked instead, and a single-split run at the top is
/// refused as another run.
pub fn check_out_plan(out: &Path, plan: &Plan, design_sha256: &str) -> Result<(), RunError> {
    let level = |dir: &Path| check_out(dir, design_sha256).map(|_| ());
    if plan.splits.is_empty() && plan.seed_draws.is_empty() {
        return level(out);
    }
    refuse_single_run(out)?;
    for &s in &plan.splits {
        level(&out.join(crate::plan::split_dir(s)))?;
    }
    for &(_, draw) in &plan.seed_draws {
        level(&out.join(format!("draw-{draw}")))?;
    }
    Ok(())
}

/// Refuses a folder with no run in it whose `report/` holds files: a run
/// would write its report over them (someone's own report, or another
/// tool's), and a run writes `run.json` before its report, so they are no
/// run's.
fn refuse_others_report(out: &Path) -> Result<(), RunError> {
    let report = out.join("report");
    if std::fs::read_dir(&report).is_ok_and(|mut files| files.next().is_some()) {
        return Err(RunError::BadRunRecord {
            path: out.join("run.json").display().to_string(),
            dir: out.display().to_string(),
            reason: format!(
                "it is missing, but {} holds files, which a run would write its report over",
                report.display()
            ),
        });
    }
    Ok(())
}

/// Refuses to write a report, plan or any other output of `design_sha256`
/// into `dir` when `dir` or any folder above it holds a run of another
/// design (`analyze --out`, whose default is the `report/` beside the
/// per-cell file, `plan --out`, ...): a folder with a `run.json`, or the
/// top of a multiverse, draw-replicated or multi-split run, whose level
/// folders (`spec-*`, `draw-*`, `split-*`) hold them. The path is resolved
/// first (`..`, symbolic links), so no spelling of it gets past.
pub fn check_output_dir(dir: &Path, design_sha256: &str) -> Result<(), RunError> {
    for d in resolved(dir).ancestors() {
        if d.join("run.json").is_file() {
            check_out(d, design_sha256)?;
            continue;
        }
        for run in level_runs(d) {
            if let Some(p) = RunRecord::read(&run).ok().flatten() {
                if p.design_sha256 != design_sha256 {
                    return Err(RunError::OtherDesign { dir: d.display().to_string(), sha256: p.design_sha256 });
                }
            }
        }
    }
    Ok(())
}

/// The folders a run writes inside its own directory.
const RUN_OWNED: [&str; 15] = [
    "report",
    "audit",
    "cells",
    "curves",
    "jobs",
    "locks",
    "logs",
    "manifests",
    "models",
    "simulated_data",
    "slurm",
    "sbatch",
    "export",
    "predictions",
    "split",
];

/// Whether `name` is an outer level's folder (`spec-*`, `draw-*`, `split-*`).
fn is_level(name: &str) -> bool {
    ["spec-", "draw-", "split-"].iter().any(|p| name.starts_with(p))
}

/// The run folders of the outer levels in `dir`: each level folder
/// (`spec-*`, `draw-*`, `split-*`) with a run.json, and for a specification
/// of per-seed draws, the `draw-*` folders inside it that have one.
fn level_runs(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut runs = Vec::new();
    for e in entries.flatten().take(100_000) {
        if !is_level(&e.file_name().to_string_lossy()) {
            continue;
        }
        if e.path().join("run.json").is_file() {
            runs.push(e.path());
            continue;
        }
        let inner = std::fs::read_dir(e.path()).into_iter().flatten().flatten().take(100_000);
        runs.extend(
            inner
                .filter(|i| i.file_name().to_string_lossy().starts_with("draw-"))
                .map(|i| i.path())
                .filter(|p| p.join("run.json").is_file()),
        );
    }
    runs
}

/// Whether `dir` is the top of a run with outer levels.
fn is_outer_top(dir: &Path) -> bool {
    !level_runs(dir).is_empty()
}

/// Refuses to write an analysis or a plan into a folder a run wrote: the
/// run's directory, its `report/`, `cells/`, `audit/` or any other folder
/// of `RUN_OWNED`, or anything inside an outer level's folder, at any
/// depth and however spelled (the path is resolved first). Only the run
/// writes there: a reanalysis of its per-cell file has neither its
/// warnings nor its audits, and replacing the run's report with it made
/// report.md and results.json disagree. `analyzing_run` is the run
/// directory an analysis of outer levels reads (`analyze --cells RUN`): its
/// top `report/` is what the run itself writes from its level folders, so
/// that one is allowed.
pub fn check_not_runs_own(dir: &Path, analyzing_run: Option<&Path>) -> Result<(), RunError> {
    let d = resolved(dir);
    if analyzing_run.is_some_and(|run| resolved(run).join("report") == d) {
        return Ok(());
    }
    // Suggested: beside the outermost run's own folders.
    runs_own(dir, &d, |outermost| outermost.join("reanalysis"))
}

/// [`check_not_runs_own`] for a command whose output is no run's nor an
/// analysis of one (`data audit`, `simsum`, `combine`, ...): the folder
/// suggested lies beside the outermost run, named after it and `what`
/// (`RUN-simsum`).
pub fn check_not_in_run(dir: &Path, what: &str) -> Result<(), RunError> {
    runs_own(dir, &resolved(dir), |outermost| {
        let name = outermost.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        outermost.with_file_name(format!("{name}-{what}"))
    })
}

/// Refuses a run's output folder `out` (`run`, `split`, `train`,
/// `export`) that lies below another run's folder (one with a run.json, or
/// the top of a study of level folders), however spelled; `out` itself may
/// be a run (a resume checks it is of this design, [`check_out`]).
pub fn check_not_inside_run(out: &Path) -> Result<(), RunError> {
    if std::fs::metadata(out).is_ok_and(|m| !m.is_dir()) {
        let why = std::io::Error::other("it is a file, not a folder (--out names the run's folder)");
        return Err(RunError::Write(crate::io::WriteError::new(out, why)));
    }
    let d = resolved(out);
    let runs: Vec<&Path> = d.ancestors().skip(1).filter(|a| a.join("run.json").is_file() || is_outer_top(a)).collect();
    let (Some(run), Some(outermost)) = (runs.first(), runs.last()) else { return Ok(()) };
    let name = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    Err(RunError::RunInsideRun {
        dir: out.display().to_string(),
        run: run.display().to_string(),
        suggest: outermost.with_file_name(format!("{}-{}", name(outermost), name(&d))).display().to_string(),
    })
}

/// Refuses `dir` (resolved: `d`) where it lies in a folder a run wrote,
/// suggesting `suggest` of the outermost run's folder instead.
fn runs_own(dir: &Path, d: &Path, suggest: impl Fn(&Path) -> PathBuf) -> Result<(), RunError> {
    let runs: Vec<&Path> = d.ancestors().filter(|a| a.join("run.json").is_file() || is_outer_top(a)).collect();
    for a in &runs {
        let first = d.strip_prefix(a).ok().and_then(|r| r.components().next());
        let what = match first {
            None => "the folder",
            Some(c) => {
                let name = c.as_os_str().to_string_lossy();
                if RUN_OWNED.contains(&name.as_ref()) || is_level(&name) {
                    "a folder"
                } else {
                    continue;
                }
            }
        };
        let outermost = runs.last().unwrap_or(a);
        return Err(RunError::RunsOwnFolder {
            dir: dir.display().to_string(),
            what,
            run: a.display().to_string(),
            suggest: suggest(outermost).display().to_string(),
        });
    }
    Ok(())
}

/// `path` made absolute with `..` and symbolic links resolved: the longest
/// part that exists canonicalized, the rest appended.
fn resolved(path: &Path) -> PathBuf {
    let absolute = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir().map(|c| c.join(path)).unwrap_or_else(|_| path.to_path_buf())
    };
    let mut rest: Vec<std::ffi::OsString> = Vec::new();
    let mut head = absolute.as_path();
    loop {
        if let Ok(c) = head.canonicalize() {
            let mut out = c;
            for part in rest.iter().rev() {
                if part == ".." {
                    out.pop();
                } else if part != "." {
                    out.push(part);
                }
            }
            return out;
        }
        match (head.parent(), head.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                head = parent;
            }
            (Some(parent), None) => {
                rest.push("..".into());
                head = parent;
            }
            _ => return absolute,
        }
    }
}

/// A multi-split study's directory must not hold a single-split run.
pub(super) fn refuse_single_run(out: &Path) -> Result<(), RunError> {
    if out.join("run.json").exists() {
        if let Some(r) = RunRecord::read(out)? {
            return Err(RunError::OtherDesign { dir: out.display().to_string(), sha256: r.design_sha256 });
        }
    }
    Ok(())
}
