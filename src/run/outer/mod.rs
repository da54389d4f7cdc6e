//! Outer factors of a study: a multiverse's specifications, draw
//! replication and whole splits. A study is the product of its outer
//! factors; each level (a specification, a draw, a split, or one of each)
//! is a complete single run in its own directory named by its factors'
//! values, `out/spec-ID`, `out/draw-K`, `out/spec-ID_draw-K` or
//! `out/split-S`, all run by one loop. A level whose trained part (data,
//! split, arms, models, training, endpoints) is identical to an earlier
//! one's (a choice that changes only the analysis) trains nothing and is
//! analysed on that level's cells, and a job whose inputs equal an earlier
//! one's is copied by content hash. What follows depends on the factors'
//! role, not on their names ([`LevelRole`]): whole redraws (splits) are pooled
//! by the family analysis into `out/cells.csv` and `out/report`;
//! specifications and replicate draws are combined by the multiverse
//! analysis into `out/multiverse_cells.csv` and `out/report`.

use std::collections::BTreeSet;
use std::path::Path;
use std::time::Instant;

mod folders;
mod per_seed;
mod queue;
pub(crate) use per_seed::{finish_per_seed, finish_specs};
mod read;
mod verify;

use crate::analysis::multiverse::{MultiverseAnalysis, SharedDraws};
use crate::analysis::record::DesignLabel;
use crate::analysis::StudyAnalysis;
use crate::cells::CellsError;
use crate::design::Design;
use crate::design::{lock, DesignFile, LockStatus};
use crate::io::create_dir_all;
use crate::io::write_atomic;
pub use crate::plan::study::{Level, LevelRole, Outer, Unit};
use crate::plan::Plan;
use crate::plan::StudyPlan;
use crate::run::guard::refuse_single_run;
use crate::run::{grid, Data, RunError, RunObserver, RunOptions, RunOutcome, StudyRecord};
pub(crate) use folders::{copy_job, note_unread, run_dir, ExternalNotes};

/// Runs (or resumes) every level, then combines them by their role.
#[allow(clippy::too_many_arguments)]
pub(super) fn run_levels(
    file: &DesignFile,
    study: &Plan,
    outer: &Outer,
    data: &Data,
    out: &Path,
    options: RunOptions,
    observer: &dyn RunObserver,
    started: Instant,
) -> Result<RunOutcome, RunError> {
    run_levels_with(file, study, outer, data, out, options, observer, started, &ExternalNotes::default())
}

/// As [`run_levels`], after `score` scored the external models' jobs of
/// every level: their notes go into each level's report and the combined one.
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_levels_with(
    file: &DesignFile,
    study: &Plan,
    outer: &Outer,
    data: &Data,
    out: &Path,
    options: RunOptions,
    observer: &dyn RunObserver,
    started: Instant,
    external: &ExternalNotes,
) -> Result<RunOutcome, RunError> {
    refuse_single_run(out)?;
    // Every level is opened first and its jobs queued; then one queue of
    // every level's jobs runs on the workers (no worker waits while a level
    // is opened or finished); then each level is finished in order.
    let queued = queue::open_levels(file, outer, data, out, &options, observer, external)?;
    let total: usize = queued.levels.iter().map(|(_, o)| o.plan.jobs.len()).sum();
    observer.start(total, total - queued.queue.len());
    let contexts: Vec<grid::LevelContext> =
        queued.levels.iter().map(|(_, o)| (&o.plan, &o.opened.prepared, o.dir.as_path())).collect();
    let (levels, role) = (&outer.levels, outer.role);
    grid::run_queue(&file.sha256, &contexts, queued.queue, (options.workers, &options.device), observer)
        .map_err(|(at, e)| RunError::InLevel { level: queued.levels[at].1.label.clone(), source: Box::new(e) })?;
    let per_seed = role == LevelRole::PerSeed || file.design.per_seed_draws;
    let finished = queue::finish_opened(file, &queued.levels, levels.len(), per_seed)?;
    let counts = |mut o: RunOutcome| {
        (o.trained, o.skipped, o.seconds) = (queued.trained, queued.skipped, started.elapsed().as_secs_f64());
        o
    };
    let status = &finished.status;
    if role == LevelRole::PerSeed {
        return Ok(counts(per_seed::finish_per_seed(file, study, outer, out, status, &queued.reused)?));
    }
    if role == LevelRole::Redraw {
        let design = DesignLabel::new(file, status.clone());
        return Ok(counts(super::finish_splits(design, study, outer, out, &queued.reused)?));
    }
    if file.design.per_seed_draws {
        per_seed::finish_specs(file, outer, out, status)?;
    }
    Ok(counts(finish_levels(file, outer, out, status, &finished.splits, &queued.reused)?))
}

/// Every unit's cells in one file, `spec` and `draw` columns first (under
/// per-seed draws, each seed's row its own draw).
fn write_all_cells(path: &Path, design: &Design, out: &Path, levels: &[Level]) -> Result<(), RunError> {
    let mut text = String::new();
    let spec_id = |k: usize| -> String {
        match (&design.multiverse, levels[k].spec) {
            (Some(m), Some(s)) => m.specs[s].id.clone(),
            _ => String::new(),
        }
    };
    for k in 0..levels.len() {
        let source = run_dir(out, levels, k).join("cells.csv");
        let body = std::fs::read_to_string(&source)
            .map_err(|e| RunError::Cells(CellsError::Io { path: source.display().to_string(), source: e }))?;
        let mut lines = body.lines();
        let header = lines.next().unwrap_or("");
        if k == 0 {
            text.push_str(&format!("spec,draw,{header}\n"));
        }
        let (spec, draw) = (spec_id(k), levels[k].draw.map(|d| d.to_string()).unwrap_or_default());
        for l in lines {
            text.push_str(&format!("{spec},{draw},{l}\n"));
        }
    }
    Ok(write_atomic(path, text.as_bytes())?)
}

/// After every level finished: the combined cells and `study.json` (the
/// run's notes `reused`, what the specifications' splits share), then the
/// folder read back as a record, analysed and reported, exactly as
/// `crossaudit analyze DESIGN --cells OUT` does; a level that shares
/// another's run gets its own report of its own analysis.
pub(crate) fn finish_levels(
    file: &DesignFile,
    outer: &Outer,
    out: &Path,
    status: &LockStatus,
    splits: &[Option<crate::split::Split>],
    reused: &[String],
) -> Result<RunOutcome, RunError> {
    let started = Instant::now();
    let levels = &outer.levels;
    let cells_csv = out.join("multiverse_cells.csv");
    write_all_cells(&cells_csv, &file.design, out, levels)?;
    StudyRecord {
        study: file.design.study.clone(),
        design_sha256: file.sha256.clone(),
        crossaudit: crate::io::BUILD.to_string(),
        levels: levels.iter().map(|l| l.id.clone()).collect(),
        cells_sha256: crate::cells::file_sha256(&cells_csv)?,
        notes: reused.to_vec(),
        shared: shared_draws(levels, splits),
    }
    .write(out)?;
    let design = DesignLabel::new(file, status.clone());
    let record = read::read_multiverse(design, file, outer, out)?;
    let a = read::analyze(&file.design, outer, &record)?;
    for (k, u) in outer.units.iter().enumerate() {
        // A level that shares another's run gets its own report of its own
        // analysis (a specification of per-seed draws has had its own).
        if let (Some(_), false) = (&u.shares, file.design.per_seed_draws) {
            let dir = out.join(&u.id);
            create_dir_all(&dir)?;
            crate::report::write_all(&a.levels[k].1, &dir.join("report"))?;
        }
    }
    let report_dir = out.join("report");
    let analysis = StudyAnalysis::Multiverse(Box::new(a));
    crate::report::write_study(&analysis, &report_dir)?;
    Ok(RunOutcome {
        cells_csv,
        report_dir,
        analysis,
        trained: 0,
        skipped: 0,
        copied: 0,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// For each pair of levels with a split of their own (at the first draw):
/// evaluation recordings, starts and reference-arm fit windows in common,
/// by recording name and row.
fn shared_draws(levels: &[Level], splits: &[Option<crate::split::Split>]) -> Vec<SharedDraws> {
    type Sets = (BTreeSet<String>, BTreeSet<(String, usize)>, BTreeSet<(String, usize)>);
    let sets = |s: &crate::split::Split, reference: &str| -> Sets {
        let name = |r: usize| s.recordings[r].name.clone();
        let fit = s.fit(reference).unwrap_or(&[]);
        (
            s.evaluation.iter().map(|&r| name(r)).collect(),
            s.starts.iter().map(|w| (name(w.recording), w.t)).collect(),
            fit.iter().map(|w| (name(w.recording), w.t)).collect(),
        )
    };
    let first_draw = levels.iter().filter_map(|l| l.draw).min();
    let own: Vec<(usize, Sets)> = (0..levels.len())
        .filter(|&k| levels[k].draw == first_draw)
        .filter_map(|k| splits[k].as_ref().map(|s| (k, sets(s, &levels[k].design.contrast.reference))))
        .collect();
    let mut out = Vec::new();
    for (a, (ka, sa)) in own.iter().enumerate() {
        for (kb, sb) in own.iter().skip(a + 1) {
            out.push(SharedDraws {
                left: levels[*ka].id.clone(),
                right: levels[*kb].id.clone(),
                recordings: (sa.0.intersection(&sb.0).count(), sa.0.len()),
                starts: (sa.1.intersection(&sb.1).count(), sa.1.len()),
                fit_windows: (sa.2.intersection(&sb.2).count(), sa.2.len()),
            });
        }
    }
    out
}

/// The analysis of a finished multiverse or draw-replicated run directory
/// `dir` (what `crossaudit analyze DESIGN --cells DIR` reads): the folder
/// read back as a record (`read::read_multiverse`: each level's plan
/// from `file`, its cells from `DIR/LEVEL/cells.csv`, a level sharing
/// another's run from that one's), labelled with the design's lock state
/// now. Errors name the file and line.
pub fn analyze_dir(file: &DesignFile, study: &StudyPlan, dir: &Path) -> Result<MultiverseAnalysis, RunError> {
    let not_outer = || RunError::NotOuter { design: file.path.display().to_string() };
    let outer = study.outer.as_ref().filter(|_| study.combines_levels()).ok_or_else(not_outer)?;
    if !dir.is_dir() {
        return Err(not_outer());
    }
    let design = DesignLabel::new(file, lock::status(file)?);
    let record = read::read_multiverse(design, file, outer, dir)?;
    read::analyze(&file.design, outer, &record)
}
