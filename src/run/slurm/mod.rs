//! The bridge to a cluster scheduler: a study as a Slurm job array.
//!
//! [`prepare`] does once, on the submitting machine, everything before the
//! first job (the same `super::open` as a local run: audit, manifests,
//! invariants, `run.json`), then writes under `DIR/slurm/`:
//!
//! - `design.design`: a verbatim copy of the design, which every task runs;
//! - `array.json`: the [`ArrayRecord`], with the job list (array index ->
//!   job), the absolute data directory and the lock state;
//! - `array.sbatch` (one array task per job, or per `--jobs-per-task`
//!   jobs: `crossaudit job DIR --index $SLURM_ARRAY_TASK_ID`),
//!   `gather.sbatch` (`crossaudit gather DIR`) and
//!   `submit.sh`, which submits the array, then the gather job with
//!   `--dependency=afterok:ARRAY`.
//!
//! Every value taken from a design or a path is either checked against a
//! narrow alphabet (job names, resources) or single-quoted for the shell
//! (paths), so no name can run a command; paths with a newline or with `%`
//! (Slurm's file-name patterns) are refused.
//!
//! [`run_task`] runs its task's jobs exactly as a local run does (same
//! functions, one thread; on a GPU their networks trained together first,
//! `task`), after verifying that the design copy, the data and the
//! rebuilt manifests are those the run was prepared with; a finished job is
//! skipped. [`gather`] refuses while any job has no record, naming each
//! with its Slurm log, then writes `cells.csv` and the report with the same
//! code as a local run, so the bytes are the same.
//!
//! A study with outer factors (splits, specifications, draws) is one array
//! over every level's jobs: each level that trains is opened in its own
//! directory (`DIR/split-s`, `DIR/spec-s2`, ...) exactly as a local run
//! opens it (its own audit, manifests, invariants and run.json), a task
//! runs its job in its level's directory, and the gather step finishes each
//! level, then combines them by their role ([`super::outer::LevelRole`]) into
//! the report a local run writes.
//!
//! Shared-filesystem assumption: DIR, the data directory and the crossaudit
//! binary are visible at the same absolute paths from every node. Nothing
//! else is read or written outside DIR.

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

mod scripts;
mod task;

use super::outer;
use super::{finish, open, pending, Data, DataOrigin, Opened, RunError, RunOutcome, RunRecord};
use crate::design::{self, DesignFile, LockStatus};
use crate::io::{create_dir_all, pretty_json, sha256_hex, write_atomic};
use crate::plan::{Plan, StudyPlan, TrainingJob};
pub use scripts::*;
pub use task::{run_task, TaskOutcome, TaskRun};

/// `DIR/slurm`: everything the scheduler reads.
pub const SLURM_DIR: &str = "slurm";

/// `DIR/slurm/array.json`: what every array task and the gather step read.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ArrayRecord {
    /// The design as the user named it (the report quotes it).
    pub design_path: String,
    /// The design file's absolute path: a `split published` file in it is
    /// read relative to its directory.
    pub design_file: PathBuf,
    /// SHA-256 of the design (and of `slurm/design.design`).
    pub design_sha256: String,
    /// The design's lock state when the run was prepared; informational:
    /// the gather step recomputes it from the design copy and the lock.
    pub lock: LockStatus,
    /// The flight-log directory every task loads, absolute.
    pub data_dir: PathBuf,
    /// Where the logs came from, as run.json says.
    pub data: DataOrigin,
    /// The training jobs, by array index (`SLURM_ARRAY_TASK_ID`).
    pub jobs: Vec<String>,
    /// The build that prepared the run.
    pub crossaudit: String,
    /// Training jobs per array task: task t runs jobs t x N to
    /// t x N + N - 1 (1 in an array prepared before tasks held several).
    #[serde(default = "one_job")]
    pub per_task: usize,
    /// Where each task trains, resolved on its node.
    #[serde(default)]
    pub device: crate::model::DeviceChoice,
}

/// An array record's jobs per task when it names none.
fn one_job() -> usize {
    1
}

impl ArrayRecord {
    /// Reads `DIR/slurm/array.json`.
    pub fn read(dir: &Path) -> Result<ArrayRecord, RunError> {
        let path = dir.join(SLURM_DIR).join("array.json");
        let bad = |reason: String| RunError::NotPrepared { dir: dir.display().to_string(), reason };
        let bytes = crate::io::read_own(&path).map_err(|e| bad(format!("{}: {e}", path.display())))?;
        let record: ArrayRecord =
            serde_json::from_slice(&bytes).map_err(|e| bad(format!("{}: {e}", path.display())))?;
        if record.per_task == 0 {
            return Err(bad(format!("{}: per_task is 0; a task runs at least one job", path.display())));
        }
        Ok(record)
    }

    /// The array's tasks: each a run of at most `per_task` jobs.
    pub fn tasks(&self) -> usize {
        self.jobs.len().div_ceil(self.per_task)
    }

    /// The array task that runs job `job` (an index into `jobs`).
    pub fn task_of(&self, job: usize) -> usize {
        job / self.per_task
    }

    /// The jobs (indices into `jobs`) that array task `task` runs.
    pub fn jobs_of(&self, task: usize) -> std::ops::Range<usize> {
        let start = task.saturating_mul(self.per_task).min(self.jobs.len());
        start..start.saturating_add(self.per_task).min(self.jobs.len())
    }
}

/// What [`prepare`] wrote.
#[derive(Debug, Clone)]
pub struct PreparedArray {
    /// The run directory, absolute.
    pub dir: PathBuf,
    /// `DIR/slurm/submit.sh`.
    pub submit: PathBuf,
    /// Its text.
    pub submit_text: String,
    /// Jobs in the study.
    pub jobs: usize,
    /// Jobs without a record, which the array runs.
    pub pending: usize,
}

/// One run directory of a prepared array: the study's own, or one level's
/// of a study with outer factors (`DIR/split-s`, `DIR/spec-s2`, ...: the
/// level's design, plan and run.json).
struct Part {
    /// The level's directory name; None for a study of one run.
    level: Option<String>,
    file: DesignFile,
    plan: Plan,
    dir: PathBuf,
}

impl Part {
    /// `model__arm__seed`, or `LEVEL/model__arm__seed`: a job's entry in
    /// `array.json`.
    fn key(&self, job: &TrainingJob) -> String {
        match &self.level {
            None => job.stem(),
            Some(l) => format!("{l}/{}", job.stem()),
        }
    }

    /// `model/arm/seed`, or `LEVEL model/arm/seed`.
    fn label(&self, job: &TrainingJob) -> String {
        match &self.level {
            None => job.label(),
            Some(l) => format!("{l} {}", job.label()),
        }
    }
}

/// The run directories of the study in `dir`: itself, or one per outer
/// level that trains (a level sharing another's run has none), with the
/// levels and their role.
fn parts(file: &DesignFile, study: &StudyPlan, dir: &Path) -> Vec<Part> {
    let Some(outer) = &study.outer else {
        return vec![Part { level: None, file: file.clone(), plan: study.plan.clone(), dir: dir.to_path_buf() }];
    };
    outer
        .levels
        .iter()
        .filter(|l| l.shares.is_none())
        .map(|l| Part {
            level: Some(l.id.clone()),
            file: DesignFile { design: l.design.clone(), ..file.clone() },
            plan: l.plan.clone(),
            dir: dir.join(&l.id),
        })
        .collect()
}

/// Every job of the study by array index: (part, the job as its run
/// directory knows it). In a multi-split study the order is the plan's.
fn study_jobs(parts: &[Part]) -> Vec<(usize, &TrainingJob)> {
    parts.iter().enumerate().flat_map(|(k, p)| p.plan.jobs.iter().map(move |j| (k, j))).collect()
}

/// The array indices of the jobs without a record, and for each run
/// directory the builds that ran its finished jobs (see [`pending`]).
fn unfinished<'a>(parts: impl IntoIterator<Item = &'a Part>) -> Result<(Vec<usize>, Vec<BTreeSet<String>>), RunError> {
    let mut indices = Vec::new();
    let mut builds = Vec::new();
    let mut index = 0;
    for part in parts {
        let (jobs, done) = pending(&part.plan, &part.dir, &part.file.sha256)?;
        for j in &part.plan.jobs {
            if jobs.contains(j) {
                indices.push(index);
            }
            index += 1;
        }
        builds.push(done);
    }
    Ok((indices, builds))
}

/// Prepares `out` for Slurm: everything a local run does before its first
/// job, then the design copy, `slurm/array.json` and the three scripts.
/// Finished jobs (from an earlier run, local or not) are verified and left
/// out of the array.
pub fn prepare(
    file: &DesignFile,
    study: &StudyPlan,
    data: &Data,
    out: &Path,
    exploratory: bool,
    options: &SlurmOptions,
) -> Result<PreparedArray, RunError> {
    options.validate()?;
    let plan = &study.plan;
    // External models' jobs are scored from the folder's predictions here;
    // only the built-in models' jobs go into the array.
    if super::external::external_names(plan).is_some() {
        if !out.join(super::external::EXPORT_DIR).is_dir() {
            super::refuse_external(plan)?;
        }
        super::external::score_predictions_in(out, &mut |_| {})?;
    }
    check_dir(out)?;
    create_dir_all(out)?;
    let absolute = |p: &Path| p.canonicalize().map_err(|e| RunError::Write(crate::io::WriteError::new(p, e)));
    let dir = absolute(out)?;
    let binary = absolute(&options.binary)?;
    path_word(&binary)?;
    // Each split of a multi-split study is opened in its own directory, as a
    // local run opens it.
    let parts = parts(file, study, &dir);
    if study.outer.is_some() {
        super::refuse_single_run(&dir)?;
    }
    let mut lock = LockStatus::Unlocked;
    for part in &parts {
        lock = open(&part.file, &part.plan, data, &part.dir, exploratory, part.level.as_deref())?.status;
    }
    let (indices, _) = unfinished(&parts)?;
    let keys: Vec<String> = study_jobs(&parts).into_iter().map(|(k, j)| parts[k].key(j)).collect();

    let bytes =
        crate::io::read_own(&file.path).map_err(|e| RunError::Write(crate::io::WriteError::new(&file.path, e)))?;
    if sha256_hex(&bytes) != file.sha256 {
        return Err(RunError::NotPrepared {
            dir: dir.display().to_string(),
            reason: format!("{} changed while the run was being prepared", file.path.display()),
        });
    }
    let slurm = dir.join(SLURM_DIR);
    create_dir_all(&slurm.join("logs"))?;
    create_dir_all(&slurm.join("locks"))?;
    write_atomic(&slurm.join("design.design"), &bytes)?;
    let record = ArrayRecord {
        design_path: file.path.display().to_string(),
        design_file: absolute(&file.path)?,
        design_sha256: file.sha256.clone(),
        lock,
        data_dir: absolute(&data.dir)?,
        data: data.origin.clone(),
        jobs: keys.clone(),
        crossaudit: crate::io::BUILD.to_string(),
        per_task: options.per_task,
        device: options.device,
    };
    write_atomic(&slurm.join("array.json"), pretty_json(&record).as_bytes())?;

    // The tasks that hold a pending job.
    let mut tasks: Vec<usize> = indices.iter().map(|&i| record.task_of(i)).collect();
    tasks.dedup();
    let submit = write_scripts(&slurm, &dir, &binary, &plan.study, &tasks, options)?;
    let submit_path = slurm.join("submit.sh");
    write_atomic(&submit_path, submit.as_bytes())?;
    Ok(PreparedArray { dir, submit: submit_path, submit_text: submit, jobs: keys.len(), pending: indices.len() })
}

/// The run directory of a prepared array, opened for a task or the gather
/// step: its records, the design copy and the plan, each checked against
/// what `prepare` recorded, and its run directories (one per split in a
/// multi-split study) with their run.json.
struct OpenedArray {
    array: ArrayRecord,
    file: DesignFile,
    /// The design copy compiled, with its outer levels.
    study: StudyPlan,
    parts: Vec<(Part, RunRecord)>,
}

impl OpenedArray {
    /// Every job by array index: (part, job).
    fn jobs(&self) -> Vec<(usize, &TrainingJob)> {
        self.parts.iter().enumerate().flat_map(|(k, (p, _))| p.plan.jobs.iter().map(move |j| (k, j))).collect()
    }
}

impl OpenedArray {
    /// The error of a gather with unfinished tasks (`todo`, by array
    /// index): each task with the last line of its Slurm log.
    fn jobs_missing(&self, dir: &Path, todo: &[usize]) -> RunError {
        let jobs = self.jobs();
        let logs = dir.join(SLURM_DIR).join("logs");
        let mut list = String::new();
        for &index in todo {
            let (k, job) = jobs[index];
            // The job's array task, whose log it is in.
            let index = self.array.task_of(index);
            let log = logs.join(format!("task-{index}.out"));
            let last = std::fs::read_to_string(&log).ok().and_then(|t| {
                t.lines().rev().find(|l| !l.trim().is_empty()).map(|l| l.chars().take(300).collect::<String>())
            });
            let status = match last {
                Some(line) => format!("Slurm log {} (last line: {line})", log.display()),
                None if log.exists() => format!("Slurm log {} (empty)", log.display()),
                None => format!("no Slurm log at {}: the task never started", log.display()),
            };
            writeln!(list, "  task {index} ({}): {status}", self.parts[k].0.label(job)).ok();
        }
        RunError::JobsMissing { dir: dir.display().to_string(), missing: todo.len(), jobs: jobs.len(), list }
    }

    /// The design's lock state now: the design copy (with the files it
    /// refers to) against the lock beside the original design.
    fn lock_now(&self) -> Result<LockStatus, RunError> {
        Ok(design::lock::status(&self.file)?)
    }

    /// The lock state a gather reports: the state now, unless the state
    /// recorded when the run was prepared was less preregistered (a design
    /// locked after its run was prepared is not preregistered for that run;
    /// an edit of array.json can only lower the label, never raise it).
    fn lock_for_gather(&self) -> Result<LockStatus, RunError> {
        let now = self.lock_now()?;
        Ok(if self.array.lock.rank() < now.rank() { self.array.lock.clone() } else { now })
    }
}

fn reopen(dir: &Path) -> Result<OpenedArray, RunError> {
    let array = ArrayRecord::read(dir)?;
    let not_prepared = |reason: String| RunError::NotPrepared { dir: dir.display().to_string(), reason };
    let copy = dir.join(SLURM_DIR).join("design.design");
    let file = design::load_copy(&copy, &array.design_file).map_err(|e| not_prepared(e.to_string()))?;
    if file.sha256 != array.design_sha256 {
        return Err(not_prepared(format!(
            "slurm/design.design records design sha256 {}, slurm/array.json {}",
            file.sha256, array.design_sha256
        )));
    }
    // The array's own entry point: the design copy compiled once.
    let study = crate::plan::compile_study(&file.design);
    let parts = parts(&file, &study, dir);
    let keys: Vec<String> = study_jobs(&parts).into_iter().map(|(k, j)| parts[k].key(j)).collect();
    if keys != array.jobs {
        return Err(not_prepared("the design copy compiles to another job list than slurm/array.json".into()));
    }
    let mut opened = Vec::new();
    for part in parts {
        let run_json = part.dir.join("run.json");
        let run =
            RunRecord::read(&part.dir)?.ok_or_else(|| not_prepared(format!("{} is missing", run_json.display())))?;
        if run.design_sha256 != array.design_sha256 {
            return Err(not_prepared(format!(
                "{} records design sha256 {}, slurm/array.json {}",
                run_json.display(),
                run.design_sha256,
                array.design_sha256
            )));
        }
        opened.push((part, run));
    }
    Ok(OpenedArray { array, file, study, parts: opened })
}

/// The split of one run directory rebuilt in memory from the recorded data
/// directory, refused unless its audit and manifests are those of its
/// run.json.
fn rebuild(array: &ArrayRecord, part: &Part, run: &RunRecord) -> Result<crate::split::Prepared, RunError> {
    super::rebuild::rebuild_from(&array.data_dir, &array.data, &part.file, &part.plan, &part.dir, run)
}

/// The design as the array names it, in lock state `lock`.
fn design_label(array: &ArrayRecord, file: &DesignFile, lock: &LockStatus) -> crate::analysis::record::DesignLabel {
    crate::analysis::record::DesignLabel {
        path: array.design_path.clone(),
        ..crate::analysis::record::DesignLabel::new(file, lock.clone())
    }
}

/// The gather step: refuses while any job has no record (naming each with
/// its array index and Slurm log), then writes cells.csv and the report
/// with the code a local run uses.
pub fn gather(dir: &Path) -> Result<RunOutcome, RunError> {
    let started = std::time::Instant::now();
    let p = reopen(dir)?;
    let (todo, builds) = unfinished(p.parts.iter().map(|(part, _)| part))?;
    let total_jobs = p.jobs().len();
    if !todo.is_empty() {
        return Err(p.jobs_missing(dir, &todo));
    }
    // Each run directory is finished as a local run finishes it; a
    // multi-split study then pools its splits, as a local run does.
    // The lock state is recomputed from the design copy and the lock beside
    // the original design; array.json's (the state when the run was
    // prepared), which anyone can edit, can only lower it.
    let lock = p.lock_for_gather()?;
    let mut all_builds = BTreeSet::new();
    let mut last = None;
    let mut splits: Vec<(String, crate::split::Split)> = Vec::new();
    // Per-seed draws: each seed's level is no crossed study of its own; its
    // cells are gathered and analysed with every other seed's below, as a
    // local run does (with the same notes: each unreadable-file warning once).
    let per_seed = p.file.design.per_seed_draws;
    let mut notes: Vec<String> = Vec::new();
    let mut last_record = None;
    for ((part, run), builds) in p.parts.into_iter().zip(builds) {
        all_builds.extend(builds.iter().cloned());
        let prepared = rebuild(&p.array, &part, &run)?;
        let warnings = super::external::notes_for(&part.dir, &part.plan);
        let opened = Opened { status: lock.clone(), prepared, record: run, notes: warnings };
        // Every record with its content key, as a local run leaves it.
        let keys = super::reuse::keys(&part.file.design, &part.plan, &opened.prepared.manifests, &opened.record);
        super::reuse::stamp(&part.dir, &keys)?;
        if let Some(level) = &part.level {
            splits.push((level.clone(), opened.prepared.split.clone()));
        }
        if per_seed {
            outer::note_unread(&mut notes, &opened.prepared.audit);
            super::gather_recorded(&part.plan, &opened, &part.dir, &builds)?;
        } else {
            last = Some(finish(design_label(&p.array, &p.file, &lock), &part.plan, &opened, &part.dir, builds)?);
        }
        last_record = Some(opened.record);
    }
    last_record.ok_or(RunError::NoWorkers)?;
    let plan = &p.study.plan;
    if let Some(o @ outer::Outer { role: outer::LevelRole::PerSeed, .. }) = &p.study.outer {
        let mut outcome = outer::finish_per_seed(&p.file, plan, o, dir, &lock, &notes)?;
        (outcome.skipped, outcome.seconds) = (total_jobs, started.elapsed().as_secs_f64());
        return Ok(outcome);
    }
    if let (Some(o), true) = (&p.study.outer, per_seed) {
        outer::finish_specs(&p.file, o, dir, &lock)?;
    }
    let mut outcome = match (&p.study.outer, last) {
        (None, Some(outcome)) => outcome,
        (None, None) => return Err(RunError::NoWorkers),
        (Some(o @ outer::Outer { role: outer::LevelRole::Redraw, .. }), _) => {
            super::finish_splits(design_label(&p.array, &p.file, &lock), plan, o, dir, &notes)?
        }
        (Some(o), _) => {
            // The same combined analysis a local run writes.
            let by_level: Vec<Option<crate::split::Split>> =
                o.levels.iter().map(|l| splits.iter().find(|(id, _)| *id == l.id).map(|(_, s)| s.clone())).collect();
            outer::finish_levels(&p.file, o, dir, &lock, &by_level, &notes)?
        }
    };
    outcome.seconds = started.elapsed().as_secs_f64();
    Ok(outcome)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn array_specs_and_quoting() {
        assert_eq!(array_spec(&[0, 1, 2, 3, 4, 7, 9, 10, 11, 12]), "0-4,7,9-12");
        assert_eq!(array_spec(&[5]), "5");
        assert_eq!(shell_quote("x\"; rm -rf ~; \""), "'x\"; rm -rf ~; \"'");
        assert_eq!(shell_quote("it's"), "'it'\\''s'");
        assert_eq!(job_name("x\"; rm -rf ~; \"$(touch pwned)"), "crossaudit-x___rm_-rf_______touch_pwned_");
        for ok in ["30", "2:00:00", "1-12", "1-12:00", "1-12:00:00", "45:00"] {
            assert!(slurm_time(ok), "{ok}");
        }
        for bad in ["", "1:2:3:4", "a", "1-", "-1", "1-2-3", "1;2"] {
            assert!(!slurm_time(bad), "{bad}");
        }
    }
}
