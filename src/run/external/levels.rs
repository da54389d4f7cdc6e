//! External models in a study with outer levels (a multiverse's
//! specifications, replicate or per-seed draws, whole splits): `export`
//! opens every level's folder as `run` does and writes its export in
//! `OUT/LEVEL/export/`, listed by `OUT/export/levels.json`; `score` scores
//! each level's predictions, then runs the built-in models of every level
//! and combines the levels as `run` does.
//!
//! A level that shares another's run (its jobs would be the same) is not
//! exported: the one it shares is.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::score::{external_warning, non_finite_warning, reopen, score_predictions, Predictions, ScoreOutcome};
use super::{external_jobs, write_export, ExportOutcome, EXPORT_DIR};
use crate::design::{lock, DesignFile};
use crate::io::{create_dir_all, pretty_json, sha256_hex, write_atomic};
use crate::plan::study::Level;
use crate::plan::Plan;
use crate::run::{open, Data, RunError, RunObserver, RunOptions};

/// `OUT/export/levels.json`: the levels exported, in the study's order.
pub const LEVELS_FILE: &str = "levels.json";

/// The index of a study's exports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LevelsIndex {
    /// [`super::FORMAT`].
    pub format: String,
    /// The study's name.
    pub study: String,
    /// SHA-256 of the design.
    pub design_sha256: String,
    /// One entry per exported level.
    pub levels: Vec<LevelExport>,
}

/// One level's export.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LevelExport {
    /// Its folder under the study's, e.g. `spec-1` or `draw-2`.
    pub level: String,
    /// SHA-256 of its `export/export.json`.
    pub export_sha256: String,
    /// Its external jobs.
    pub jobs: usize,
}

/// Exports every level of `levels` that has its own run (see the module
/// note), then writes the index.
pub(super) fn export_levels(
    file: &DesignFile,
    levels: &[Level],
    data: &Data,
    out: &Path,
    exploratory: bool,
) -> Result<ExportOutcome, RunError> {
    crate::run::guard::refuse_single_run(out)?;
    let (mut jobs, mut bytes, mut listed) = (0, 0, Vec::new());
    for level in levels.iter().filter(|l| l.shares.is_none()) {
        let in_level = |e: RunError| RunError::InLevel { level: level.id.clone(), source: Box::new(e) };
        let level_file = DesignFile { design: level.design.clone(), ..file.clone() };
        let lplan = &level.plan;
        if external_jobs(lplan).is_empty() {
            continue;
        }
        let dir = out.join(&level.id);
        let opened = open(&level_file, lplan, data, &dir, exploratory, Some(&level.id)).map_err(in_level)?;
        let o = write_export(&level_file, lplan, &opened.prepared, data, &dir, Some(&level.id)).map_err(in_level)?;
        jobs += o.jobs;
        bytes += o.bytes;
        listed.push(LevelExport { level: level.id.clone(), export_sha256: o.sha256, jobs: o.jobs });
    }
    let index = LevelsIndex {
        format: super::FORMAT.to_string(),
        study: file.design.study.clone(),
        design_sha256: file.sha256.clone(),
        levels: listed,
    };
    let dir = out.join(EXPORT_DIR);
    create_dir_all(&dir)?;
    let text = pretty_json(&index);
    write_atomic(&dir.join(LEVELS_FILE), text.as_bytes())?;
    let levels = index.levels.len();
    Ok(ExportOutcome { dir, sha256: sha256_hex(text.as_bytes()), jobs, bytes: bytes + text.len() as u64, levels })
}

/// `crossaudit score DIR` of a study with outer levels: every level's
/// predictions scored (every refused or missing one named, by level, before
/// anything else runs), then the study run as `run` runs it, which trains
/// only the built-in models' jobs (the external ones are finished).
pub(super) fn score_levels(
    dir: &Path,
    workers: usize,
    observer: &dyn RunObserver,
    say: &mut dyn FnMut(&str),
    started: std::time::Instant,
) -> Result<ScoreOutcome, RunError> {
    let path = dir.join(EXPORT_DIR).join(LEVELS_FILE);
    let bad = |reason: String| RunError::NotExported { dir: dir.display().to_string(), reason };
    let bytes = crate::io::read_own(&path).map_err(|e| bad(format!("{}: {e}", path.display())))?;
    let index: LevelsIndex = serde_json::from_slice(&bytes).map_err(|e| bad(format!("{}: {e}", path.display())))?;
    let _folder = crate::run::lock_folder(dir, false)?;
    let mut all = Predictions::default();
    let mut study: Option<(super::ExportSource, crate::run::RunRecord)> = None;
    let mut warnings: Vec<(String, Vec<String>)> = Vec::new();
    let mut status = None;
    for entry in &index.levels {
        let ldir = dir.join(&entry.level);
        let in_level = |e: RunError| RunError::InLevel { level: entry.level.clone(), source: Box::new(e) };
        let r = reopen(&ldir).map_err(in_level)?;
        if r.file.sha256 != index.design_sha256 || r.source.level.as_deref() != Some(entry.level.as_str()) {
            return Err(bad(format!(
                "{} lists level {}, whose export is of another design or level",
                path.display(),
                entry.level
            )));
        }
        let s = lock::status(&r.file)?;
        if s.changed() && !r.run.exploratory {
            return Err(RunError::LockChanged { path: r.source.design_path.clone(), reason: s.reason() });
        }
        super::score::check_export(&ldir, &r.built).map_err(in_level)?;
        let p = score_predictions(&ldir, &r, &mut |line| say(&format!("{}: {line}", entry.level))).map_err(in_level)?;
        let mut notes = vec![external_warning(&r.plan, &r.built.sha256())];
        notes.extend(p.non_finite.iter().map(|(label, n, of)| non_finite_warning(label, *n, *of)));
        warnings.push((entry.level.clone(), notes));
        let label = |l: &String| format!("  {}/{}", entry.level, l.trim_start());
        all.refused.extend(p.refused.iter().map(label));
        all.missing.extend(p.missing.iter().map(label));
        all.non_finite.extend(p.non_finite.iter().map(|(l, n, of)| (format!("{}/{l}", entry.level), *n, *of)));
        (all.scored, all.resumed, all.jobs) = (all.scored + p.scored, all.resumed + p.resumed, all.jobs + p.jobs);
        status.get_or_insert(s);
        study.get_or_insert((r.source, r.run));
    }
    all.check(dir)?;
    let (source, run) = study.ok_or_else(|| bad(format!("{} lists no level", path.display())))?;
    let file = crate::design::load_copy(
        &dir.join(&index.levels[0].level).join(EXPORT_DIR).join("design.design"),
        &source.design_file,
    )
    .map_err(|e| bad(e.to_string()))?;
    // The exported design copy, compiled once.
    let study = crate::plan::compile_study(&file.design);
    let outer = study.outer.as_ref().ok_or_else(|| bad("the exported design has no outer levels".into()))?;
    let data = Data { dir: source.data_dir.clone(), origin: source.data.clone() };
    let exploratory = run.exploratory || status.is_some_and(|s| s.changed());
    let options = RunOptions { workers, exploratory, reuse: None, device: Default::default() };
    let external = crate::run::outer::ExternalNotes(warnings);
    let mut outcome = crate::run::outer::run_levels_with(
        &file,
        &study.plan,
        outer,
        &data,
        dir,
        options,
        observer,
        started,
        &external,
    )?;
    outcome.seconds = started.elapsed().as_secs_f64();
    Ok(ScoreOutcome { run: outcome, scored: all.scored, resumed: all.resumed, non_finite: all.non_finite })
}

/// Scores the predictions in `out` without running anything else: for
/// `run --slurm` on a folder that holds an export (a study's levels, or a
/// single run) and its predictions, before the built-in models' array is
/// prepared. Every refused or missing prediction is named, by level, and
/// nothing is prepared then. Returns the external jobs scored now.
pub fn score_predictions_in(out: &Path, say: &mut dyn FnMut(&str)) -> Result<usize, RunError> {
    let index = out.join(EXPORT_DIR).join(LEVELS_FILE);
    let dirs: Vec<(Option<String>, std::path::PathBuf)> = if index.is_file() {
        let bytes = crate::io::read_own(&index).map_err(|e| RunError::NotExported {
            dir: out.display().to_string(),
            reason: format!("{}: {e}", index.display()),
        })?;
        let listed: LevelsIndex = serde_json::from_slice(&bytes).map_err(|e| RunError::NotExported {
            dir: out.display().to_string(),
            reason: format!("{}: {e}", index.display()),
        })?;
        listed.levels.iter().map(|l| (Some(l.level.clone()), out.join(&l.level))).collect()
    } else {
        vec![(None, out.to_path_buf())]
    };
    let mut all = Predictions::default();
    for (level, dir) in &dirs {
        let name = level.clone().unwrap_or_default();
        let in_level = |e: RunError| match level {
            Some(l) => RunError::InLevel { level: l.clone(), source: Box::new(e) },
            None => e,
        };
        let r = reopen(dir).map_err(in_level)?;
        super::score::check_export(dir, &r.built).map_err(in_level)?;
        let prefix = if name.is_empty() { String::new() } else { format!("{name}: ") };
        let p = score_predictions(dir, &r, &mut |line| say(&format!("{prefix}{line}"))).map_err(in_level)?;
        let label = |l: &String| if name.is_empty() { l.clone() } else { format!("  {name}/{}", l.trim_start()) };
        all.refused.extend(p.refused.iter().map(label));
        all.missing.extend(p.missing.iter().map(label));
        (all.scored, all.resumed, all.jobs) = (all.scored + p.scored, all.resumed + p.resumed, all.jobs + p.jobs);
    }
    all.check(out)?;
    Ok(all.scored)
}

/// The reports' notes of a run directory whose external jobs were scored
/// from `dir/export` (none without an export).
pub fn notes_for(dir: &Path, plan: &Plan) -> Vec<String> {
    if external_jobs(plan).is_empty() {
        return Vec::new();
    }
    match crate::io::read_own(&dir.join(EXPORT_DIR).join("export.json")) {
        Ok(bytes) => vec![external_warning(plan, &sha256_hex(&bytes))],
        Err(_) => Vec::new(),
    }
}
