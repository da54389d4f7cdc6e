//! `crossaudit score DIR`: the predictions of external models scored with
//! the built-in rollouts' code, the built-in models run, then cells.csv,
//! the analysis and the report written as `run` writes them.
//!
//! Nothing is scored until the export in `DIR/export/` is found to be,
//! byte for byte, what the design and the data give now. Each predictions
//! file is checked (NumPy format, `<f8`, C order, shape) and must be
//! described by `MODEL__ARM__SEED.json` naming its job and the export's
//! SHA-256. A scored job's record hashes its predictions, so a later
//! change to them is refused; a rerun scores only what is new.

use std::collections::BTreeSet;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{build, external_jobs, npy, Built, ExportIndex, ExportJob, ExportSource, EXPORT_DIR, PREDICTIONS_DIR};
use crate::cells::write_cells_atomic;
use crate::design::{self, lock, DesignFile};
use crate::io::{create_dir_all, sha256_hex};
use crate::model::State;
use crate::plan::{Plan, TrainingJob};
use crate::rollout;
use crate::run::record::JobRecord;
use crate::run::{Opened, RunError, RunObserver, RunOutcome, RunRecord};
use crate::split::Prepared;

/// `predictions/MODEL__ARM__SEED.json`: which job and which export a
/// predictions file belongs to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Description {
    /// SHA-256 of the `export/export.json` the predictions were made from.
    pub export_sha256: String,
    /// The model.
    pub model: String,
    /// The arm it was fitted on.
    pub arm: String,
    /// The seed it was trained with.
    pub seed: u64,
}

/// What `score` did.
#[derive(Debug)]
pub struct ScoreOutcome {
    /// cells.csv, the report and the analysis, as `run` returns them.
    pub run: RunOutcome,
    /// External jobs scored now.
    pub scored: usize,
    /// External jobs scored by an earlier `score` (verified, not redone).
    pub resumed: usize,
    /// Per external job with any: (`model/arm/seed`, trajectories with a
    /// non-finite predicted state, trajectories).
    pub non_finite: Vec<(String, usize, usize)>,
}

/// The run directory `dir` reopened from its export: the design copy, the
/// plan, the prepared split rebuilt from the recorded data, and the export
/// rebuilt in memory.
pub(super) struct Reopened {
    pub(super) source: ExportSource,
    pub(super) file: DesignFile,
    pub(super) plan: Plan,
    pub(super) run: RunRecord,
    prepared: Prepared,
    pub(super) built: Built,
}

/// What the predictions of one run directory gave: jobs scored now and
/// before, trajectories with a non-finite state, and the predictions
/// refused or missing (each a line naming the job and why).
#[derive(Default)]
pub(super) struct Predictions {
    pub(super) scored: usize,
    pub(super) resumed: usize,
    pub(super) non_finite: Vec<(String, usize, usize)>,
    pub(super) refused: Vec<String>,
    pub(super) missing: Vec<String>,
    pub(super) jobs: usize,
}

impl Predictions {
    /// The refusal when any prediction was refused or is missing.
    pub(super) fn check(&self, dir: &Path) -> Result<(), RunError> {
        let (refused, missing) = (&self.refused, &self.missing);
        if !refused.is_empty() {
            let summary = if missing.is_empty() { String::new() } else { format!(", and {} have none", missing.len()) };
            let mut list = refused.clone();
            list.extend(missing.iter().map(|m| format!("{m}: no predictions")));
            return Err(RunError::PredictionsRefused {
                refused: refused.len(),
                jobs: self.jobs,
                scored: self.scored + self.resumed,
                summary,
                list: list.join("\n"),
            });
        }
        if !missing.is_empty() {
            return Err(RunError::PredictionsMissing {
                dir: dir.display().to_string(),
                missing: missing.len(),
                jobs: self.jobs,
                scored: self.scored + self.resumed,
                list: missing.join("\n"),
            });
        }
        Ok(())
    }
}

/// [`super::score`] of an export of one run (not of a study's levels).
pub(super) fn score_run(
    dir: &Path,
    workers: usize,
    observer: &dyn RunObserver,
    say: &mut dyn FnMut(&str),
    started: std::time::Instant,
) -> Result<ScoreOutcome, RunError> {
    let r = reopen(dir)?;
    if let Some(level) = &r.source.level {
        return Err(not_exported(
            dir,
            format!(
                "it holds level {level} of a study with outer levels: score the study's folder, {}",
                dir.parent().unwrap_or(dir).display()
            ),
        ));
    }
    let status = lock::status(&r.file)?;
    if status.changed() && !r.run.exploratory {
        return Err(RunError::LockChanged { path: r.source.design_path.clone(), reason: status.reason() });
    }
    let _folder = crate::run::lock_folder(dir, false)?;
    check_export(dir, &r.built)?;
    let export_sha = r.built.sha256();
    let p = score_predictions(dir, &r, say)?;
    p.check(dir)?;
    let Predictions { scored, resumed, non_finite, .. } = p;

    // The built-in models, trained and rolled out as `run` does.
    let (todo, builds) = crate::run::pending(&r.plan, dir, &r.file.sha256)?;
    let todo: std::collections::VecDeque<TrainingJob> = todo.into_iter().filter(|j| !j.kind.is_external()).collect();
    observer.start(r.plan.jobs.len(), r.plan.jobs.len() - todo.len());
    let trained = todo.len();
    let workers = (workers, &crate::model::Device::Cpu);
    crate::run::grid::run_grid(&r.file.sha256, &r.plan, &r.prepared, dir, todo, workers, observer)?;

    let mut warnings = vec![external_warning(&r.plan, &export_sha)];
    for (label, n, of) in &non_finite {
        warnings.push(non_finite_warning(label, *n, *of));
    }
    let opened = Opened { status, prepared: r.prepared, record: r.run, notes: warnings };
    let mut outcome = crate::run::finish(
        crate::analysis::record::DesignLabel {
            path: r.source.design_path.clone(),
            ..crate::analysis::record::DesignLabel::new(&r.file, opened.status.clone())
        },
        &r.plan,
        &opened,
        dir,
        builds,
    )?;
    outcome.trained = trained;
    outcome.skipped = r.plan.jobs.len() - trained;
    outcome.seconds = started.elapsed().as_secs_f64();
    Ok(ScoreOutcome { run: outcome, scored, resumed, non_finite })
}

/// The report's note on where the external models' rollouts came from.
pub(super) fn external_warning(plan: &Plan, export_sha: &str) -> String {
    format!(
        "models {} were fitted outside crossaudit; their rollouts were read from {PREDICTIONS_DIR}/ (made from export sha256 {export_sha}) and scored with the built-in rollouts' code",
        super::external_names(plan).unwrap_or_default()
    )
}

/// The report's note on an external job's non-finite trajectories.
pub(super) fn non_finite_warning(label: &str, n: usize, of: usize) -> String {
    format!(
        "external job {label}: {n} of {of} predicted trajectories have a non-finite state; each is divergent from its first non-finite step (counted in n_divergent)"
    )
}

/// Scores every present predictions file of the reopened directory `dir`
/// that no earlier `score` scored (those are verified); names each refused
/// and each missing one (the caller refuses then: [`Predictions::check`]).
pub(super) fn score_predictions(dir: &Path, r: &Reopened, say: &mut dyn FnMut(&str)) -> Result<Predictions, RunError> {
    let export_sha = r.built.sha256();
    let index = &r.built.index;
    check_prediction_names(dir, index)?;
    let jobs: Vec<&TrainingJob> = external_jobs(&r.plan);
    let (mut scored, mut resumed, mut missing) = (0, 0, Vec::new());
    let mut non_finite = Vec::new();
    // Every refused predictions file is named, not only the first.
    let mut refused: Vec<String> = Vec::new();
    for (job, ej) in jobs.iter().zip(&index.jobs) {
        let counted = match JobRecord::read(dir, job)? {
            Some(rec) => {
                rec.verify(dir, job, &r.file.sha256)?;
                resumed += 1;
                rec.non_finite_starts.unwrap_or(0)
            }
            None if dir.join(&ej.predictions).exists() || dir.join(&ej.description).exists() => {
                let n = match score_job(dir, r, job, ej, &export_sha) {
                    Ok(n) => n,
                    Err(e @ RunError::BadPredictions { .. }) => {
                        refused.push(format!("  {}: {e}", job.label()));
                        continue;
                    }
                    Err(e) => return Err(e),
                };
                scored += 1;
                say(&format!(
                    "scored {} ({} starts x {} steps{})",
                    job.label(),
                    ej.shape[0],
                    ej.shape[1],
                    if n > 0 { format!("; {n} with a non-finite state, divergent from there") } else { String::new() }
                ));
                n
            }
            None => {
                missing.push(format!("  {} ({})", job.label(), dir.join(&ej.predictions).display()));
                continue;
            }
        };
        if counted > 0 {
            non_finite.push((job.label(), counted, ej.shape[0]));
        }
    }
    Ok(Predictions { scored, resumed, non_finite, refused, missing, jobs: jobs.len() })
}

fn not_exported(dir: &Path, reason: String) -> RunError {
    RunError::NotExported { dir: dir.display().to_string(), reason }
}

pub(super) fn reopen(dir: &Path) -> Result<Reopened, RunError> {
    let export = dir.join(EXPORT_DIR);
    if !export.is_dir() {
        let what = if dir.join("run.json").is_file() {
            "it holds a run of built-in models, made by `crossaudit run`, and no export/ folder"
        } else if dir.is_dir() {
            "it has no export/ folder"
        } else {
            "no such folder"
        };
        return Err(not_exported(dir, what.to_string()));
    }
    let source_path = export.join("source.json");
    let bytes =
        crate::io::read_own(&source_path).map_err(|e| not_exported(dir, format!("{}: {e}", source_path.display())))?;
    let source: ExportSource =
        serde_json::from_slice(&bytes).map_err(|e| not_exported(dir, format!("{}: {e}", source_path.display())))?;
    let copy = export.join("design.design");
    let file = design::load_copy(&copy, &source.design_file).map_err(|e| not_exported(dir, e.to_string()))?;
    // The exported design copy, compiled once.
    let study = crate::plan::compile_study(&file.design);
    let (file, plan) = match (&source.level, study.outer) {
        (None, None) => (file, study.plan),
        (Some(id), Some(outer)) => {
            let level = outer.levels.into_iter().find(|l| l.id == *id && l.shares.is_none()).ok_or_else(|| {
                not_exported(dir, format!("{} names level {id}, which the design has not", source_path.display()))
            })?;
            (DesignFile { design: level.design, ..file }, level.plan)
        }
        (None, Some(_)) => {
            return Err(not_exported(
                dir,
                "the design has outer levels: score the study's folder, which holds one folder per level".into(),
            ))
        }
        (Some(id), None) => {
            return Err(not_exported(
                dir,
                format!("{} names level {id}, but the design has no outer levels", source_path.display()),
            ))
        }
    };
    super::check_exportable(&file, &plan)?;
    let run_json = dir.join("run.json");
    let run = RunRecord::read(dir)?.ok_or_else(|| not_exported(dir, format!("{} is missing", run_json.display())))?;
    if run.design_sha256 != file.sha256 {
        return Err(RunError::ExportChanged {
            path: copy.display().to_string(),
            reason: format!("design sha256 {}, run.json records {}", file.sha256, run.design_sha256),
        });
    }
    let prepared = crate::run::rebuild::rebuild_from(&source.data_dir, &source.data, &file, &plan, dir, &run)?;
    let built = build(&file.sha256, &plan, &prepared)?;
    Ok(Reopened { source, file, plan, run, prepared, built })
}

/// Refuses an export directory that is not exactly `built`: a missing,
/// changed or extra file is named.
pub(super) fn check_export(dir: &Path, built: &Built) -> Result<(), RunError> {
    let export = dir.join(EXPORT_DIR);
    let mut expected: Vec<(&str, &[u8])> = built.files.iter().map(|(n, b)| (n.as_str(), b.as_slice())).collect();
    expected.push(("export.json", &built.index_bytes));
    for (name, bytes) in &expected {
        let path = export.join(name);
        let changed = |reason: String| RunError::ExportChanged { path: path.display().to_string(), reason };
        let now = crate::io::read_own(&path).map_err(|e| changed(e.to_string()))?;
        if now != *bytes {
            return Err(changed(format!(
                "sha256 {}, the export of this design and data has {}",
                sha256_hex(&now),
                sha256_hex(bytes)
            )));
        }
    }
    let known: BTreeSet<&str> = expected.iter().map(|(n, _)| *n).chain(["design.design", "source.json"]).collect();
    let entries = std::fs::read_dir(&export).map_err(|e| RunError::Write(crate::io::WriteError::new(&export, e)))?;
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if !known.contains(name.as_str()) && !name.starts_with('.') {
            return Err(RunError::ExportChanged {
                path: entry.path().display().to_string(),
                reason: "the export has no such file".into(),
            });
        }
    }
    Ok(())
}

/// Every file in `predictions/` must be `STEM.npy` or `STEM.json` of an
/// external job, spelled as the export spells it (one file per job).
fn check_prediction_names(dir: &Path, index: &ExportIndex) -> Result<(), RunError> {
    let pdir = dir.join(PREDICTIONS_DIR);
    let Ok(entries) = std::fs::read_dir(&pdir) else { return Ok(()) };
    let stems: BTreeSet<String> = index.jobs.iter().map(ExportJob::stem).collect();
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') {
            continue;
        }
        let bad = |reason: String| RunError::BadPredictions { path: path.display().to_string(), reason };
        if !path.is_file() {
            return Err(bad("not a regular file; predictions/ holds only MODEL__ARM__SEED.npy and .json files".into()));
        }
        let stem = name.strip_suffix(".npy").or_else(|| name.strip_suffix(".json"));
        let Some(stem) = stem else {
            return Err(bad("predictions/ holds only MODEL__ARM__SEED.npy files and their .json descriptions".into()));
        };
        if stems.contains(stem) {
            continue;
        }
        let same_job = index.jobs.iter().find(|j| {
            let parts: Vec<&str> = stem.split("__").collect();
            parts.len() == 3 && parts[0] == j.model && parts[1] == j.arm && parts[2].parse::<u64>().ok() == Some(j.seed)
        });
        return Err(bad(match same_job {
            Some(j) => format!(
                "names job {}/{}/{} again, whose file is {}: one file per job, named as export.json names it",
                j.model, j.arm, j.seed, j.predictions
            ),
            None => format!(
                "names no external job of this export (export/export.json lists {} jobs, e.g. {})",
                index.jobs.len(),
                index.jobs.first().map(|j| j.predictions.as_str()).unwrap_or("none")
            ),
        }));
    }
    Ok(())
}

/// Scores one external job's predictions: checks, per-cell rows and the
/// job record (written last). Returns the trajectories with a non-finite
/// predicted state.
fn score_job(dir: &Path, r: &Reopened, job: &TrainingJob, ej: &ExportJob, export_sha: &str) -> Result<usize, RunError> {
    let path = dir.join(&ej.predictions);
    let bad = |p: &Path, reason: String| RunError::BadPredictions { path: p.display().to_string(), reason };
    let bytes = crate::io::read_own(&path)
        .map_err(|e| bad(&path, format!("{e} (its description {} exists)", ej.description)))?;
    let arr = npy::read(&bytes, &ej.shape).map_err(|reason| bad(&path, reason))?;
    let dpath = dir.join(&ej.description);
    let dbytes = crate::io::read_own(&dpath).map_err(|e| {
        bad(&dpath, format!("{e}: every predictions file needs its description {{\"export_sha256\", \"model\", \"arm\", \"seed\"}} beside it"))
    })?;
    let d: Description =
        serde_json::from_slice(&dbytes).map_err(|e| bad(&dpath, format!("not a predictions description: {e}")))?;
    if d.export_sha256 != export_sha {
        return Err(bad(
            &dpath,
            format!("made from export sha256 {}, but this directory's export is {export_sha}: predictions from another export", d.export_sha256),
        ));
    }
    if (d.model.as_str(), d.arm.as_str(), d.seed) != (job.model.as_str(), job.arm.as_str(), job.seed.0) {
        return Err(bad(
            &dpath,
            format!("describes job {}/{}/{}, but the file is that of {}", d.model, d.arm, d.seed, job.label()),
        ));
    }
    let (steps, width) = (ej.shape[1], ej.shape[2]);
    let predicted = |i: usize, k: usize| -> State {
        let off = (i * steps + (k - 1)) * width;
        arr.data[off..off + width].to_vec()
    };
    // Trajectories with a non-finite predicted state (the exogenous state
    // is overwritten, so its values do not count).
    let exogenous = r.plan.slots.predicted;
    let non_finite = arr
        .data
        .chunks((steps * width).max(1))
        .filter(|t| t.chunks(width).any(|x| x[..exogenous].iter().any(|v| !v.is_finite())))
        .count();
    if let Some(q) = r.plan.slots.quaternion_slots() {
        check_quaternions(&arr.data, steps, width, q).map_err(|reason| bad(&path, reason))?;
    }
    let (p, plan) = (&r.prepared, &r.plan);
    let horizon_steps = rollout::horizon_steps(&job.horizons_s, plan.rate_hz);
    let traces = rollout::replay(&predicted, &p.recordings, &p.split.starts, steps, &horizon_steps);
    let cells =
        rollout::cells(&job.model, &job.arm, job.seed.0, &p.split, &traces, &job.horizons_s, plan.rate_hz, plan.cap.0);
    let cells_name = format!("cells/{}.csv", job.stem());
    create_dir_all(&dir.join("cells"))?;
    write_cells_atomic(&dir.join(&cells_name), &cells)?;
    let files = [cells_name, ej.description.clone(), ej.predictions.clone()];
    let record = JobRecord {
        model: job.model.clone(),
        arm: job.arm.clone(),
        seed: job.seed.0,
        design_sha256: r.file.sha256.clone(),
        manifests: crate::run::job::job_manifests(p, job),
        standardizers: Some(ej.standardizers.clone()),
        files: JobRecord::hash_files(dir, &files)?,
        crossaudit: crate::io::BUILD.to_string(),
        non_finite_starts: Some(non_finite),
        key: None,
        reused_from: None,
        device: None,
    };
    // The predictions were hashed after they were read and checked: a file
    // replaced in between would be recorded with a hash it was not scored
    // with, so compare.
    if record.files.get(&ej.predictions).map(String::as_str) != Some(sha256_hex(&bytes).as_str()) {
        return Err(bad(&path, "changed while it was being scored".into()));
    }
    record.write(dir, job)?;
    Ok(non_finite)
}

/// How far a predicted quaternion's length may be from 1 and still be
/// renormalised: 10%. A model that predicts a quaternion (w, x, y, z)
/// keeps it near unit length; one of length 0 (all zeros) or one whose
/// components overflow when squared cannot be turned into an attitude, and
/// renormalising it would score an arbitrary angle (180 degrees for zeros,
/// 0 for components of 1e308).
pub const QUATERNION_TOLERANCE: f64 = 0.1;

/// Refuses predictions with a finite quaternion (in the state slots `at`)
/// whose length is off 1 by more than [`QUATERNION_TOLERANCE`], naming
/// the first few (start, step) and how many there are in all. Non-finite
/// states are divergence, not checked here.
fn check_quaternions(data: &[f64], steps: usize, width: usize, at: std::ops::Range<usize>) -> Result<(), String> {
    let mut bad: Vec<String> = Vec::new();
    let mut count = 0usize;
    let columns = format!("columns {}..{}", at.start, at.end - 1);
    for (k, x) in data.chunks(width.max(at.end)).enumerate() {
        let Some(q) = x.get(at.clone()) else { continue };
        if q.iter().any(|v| !v.is_finite()) {
            continue;
        }
        // The length without overflow: scaled by the largest component.
        let big = q.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let norm = if big == 0.0 { 0.0 } else { big * q.iter().map(|v| (v / big).powi(2)).sum::<f64>().sqrt() };
        if (norm - 1.0).abs() > QUATERNION_TOLERANCE {
            count += 1;
            if bad.len() < 5 {
                let (start, step) = (k / steps.max(1), k % steps.max(1) + 1);
                bad.push(format!("start {start}, step {step}: length {norm:e}"));
            }
        }
    }
    if count == 0 {
        return Ok(());
    }
    Err(format!(
        "{count} predicted state(s) have a quaternion ({columns}, w x y z) whose length is off 1 by more than {QUATERNION_TOLERANCE} ({}{}); predict unit quaternions (within that tolerance they are renormalised, as crossaudit renormalises its own rollouts)",
        bad.join("; "),
        if count > bad.len() { "; ..." } else { "" }
    ))
}
