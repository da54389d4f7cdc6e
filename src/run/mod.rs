//! Stage: a locked design from raw logs to decision. Audit, manifests and
//! invariants, then the grid of training jobs on N workers (each a
//! single-threaded rayon pool), then cells.csv, the analysis and the report.
//!
//! A job's per-cell CSV is written atomically when it finishes and marks it
//! done; a rerun on the same directory verifies the design hash and the
//! manifests and skips finished jobs. Each job depends only on the design,
//! the data and its seed, so results do not depend on the number of workers
//! or on interruptions.
//!
//! Architecture Invariant: `run` is the only stage that calls the stages
//! below it in sequence; nothing below imports `run`.

mod check_data;
pub mod combine;
mod error;
pub mod external;
mod finish;
mod folder;
mod gathered;
mod gpu;
mod grid;
mod guard;
pub mod job;
mod open;
pub mod outer;
mod read;
mod reader;
mod rebuild;
mod record;
pub mod reuse;
pub mod slurm;
mod source;
mod trained_invariants;

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::design::DesignFile;
use crate::plan::{Plan, StudyPlan, TrainingJob};

pub use check_data::{check_data, DataChecked};
pub use error::RunError;
pub(crate) use finish::{finish, finish_combined, finish_splits, gather_recorded};
pub use folder::{check_out_dir, lock_folder, FolderLock};
pub use gathered::job_cells;
pub use grid::{Quiet, RunObserver};
use guard::refuse_single_run;
pub use guard::{
    check_not_in_run, check_not_inside_run, check_not_runs_own, check_out, check_out_plan, check_output_dir,
};
pub use job::{run_job, run_job_with, JobOutcome};
pub use open::{check_lock, check_workers, RunOptions, RunOutcome, MAX_WORKERS};
pub(crate) use open::{open, pending, Opened};
pub use read::{read_folder, read_levels, LevelFolder};
pub use reader::read_record;
pub use record::{job_record_path, ContentHashes, JobRecord, RunRecord, StudyRecord};
pub use source::{data_dir, design_data_path, Data, DataOrigin};
pub use trained_invariants::check as check_trained_invariants;

/// Runs (or resumes) the whole study into `out`.
///
/// ```
/// use std::path::Path;
/// use crossaudit::run::{data_dir, run, Quiet, RunOptions};
/// // A small study on the built-in simulator (its logs are generated into `out`).
/// let file = crossaudit::design::load(Path::new("tests/designs/sim_small.design")).unwrap();
/// let study = crossaudit::plan::compile_study(&file.design);
/// let out = tempfile::tempdir().unwrap();
/// let data = data_dir(&file.design, &file.path, None, out.path()).unwrap();
/// let options = RunOptions { workers: 2, ..Default::default() };
/// let done = run(&file, &study, &data, out.path(), options, &Quiet).unwrap();
/// assert_eq!(done.trained, study.plan.jobs.iter().filter(|j| j.trains()).count());
/// assert!(done.cells_csv.exists() && done.report_dir.join("report.md").exists());
/// ```
pub fn run(
    file: &DesignFile,
    study: &StudyPlan,
    data: &Data,
    out: &Path,
    options: RunOptions,
    observer: &dyn RunObserver,
) -> Result<RunOutcome, RunError> {
    let started = Instant::now();
    let plan = &study.plan;
    check_workers(options.workers)?;
    refuse_external(plan)?;
    if let Some(outer) = &study.outer {
        return outer::run_levels(file, plan, outer, data, out, options, observer, started);
    }
    let index = options.reuse.as_deref().map(reuse::ReuseIndex::read).transpose()?;
    let mut opened = open(file, plan, data, out, options.exploratory, None)?;
    opened.record_device(&options.device, out)?;
    let (mut todo, builds) = pending(plan, out, &file.sha256)?;
    let keys = reuse::keys(&file.design, plan, &opened.prepared.manifests, &opened.record);
    let mut copied = 0;
    if let Some(index) = &index {
        for (j, key) in &keys {
            if todo.contains(j) && index.take(key, out, j, &file.sha256)? {
                todo.retain(|t| t != j);
                copied += 1;
            }
        }
        if copied > 0 {
            opened.notes.push(reuse::reused_note(copied, plan.jobs.len(), index.from()));
            observer.reused(copied, plan.jobs.len(), index.from());
        }
    }
    let skipped = plan.jobs.len() - todo.len();
    observer.start(plan.jobs.len(), skipped);
    let trained = todo.len();
    let workers = (options.workers, &options.device);
    grid::run_grid(&file.sha256, plan, &opened.prepared, out, todo, workers, observer)?;
    reuse::stamp(out, &keys)?;
    let mut outcome =
        finish(crate::analysis::record::DesignLabel::new(file, opened.status.clone()), plan, &opened, out, builds)?;
    (outcome.trained, outcome.skipped, outcome.seconds) = (trained, skipped - copied, started.elapsed().as_secs_f64());
    outcome.copied = copied;
    Ok(outcome)
}

/// `crossaudit run DESIGN [--data DIR] --out OUT` as the command line and
/// the Python package make it: every check that can refuse the run (external
/// models, workers, a folder holding another design's run) before anything
/// is written (simulated data included), the folder locked, the data found,
/// then [`run`].
pub fn run_into(
    file: &DesignFile,
    study: &StudyPlan,
    data: Option<PathBuf>,
    out: &Path,
    options: RunOptions,
    observer: &dyn RunObserver,
) -> Result<RunOutcome, RunError> {
    refuse_external(&study.plan)?;
    check_workers(options.workers)?;
    check_lock(file, options.exploratory)?;
    check_out_plan(out, &study.plan, &file.sha256)?;
    let _lock = lock_folder(out, false)?;
    let data = data_dir(&file.design, &file.path, data, out)?;
    run(file, study, &data, out, options, observer)
}

/// `run`, `train` and Slurm fit only the models crossaudit trains.
pub fn refuse_external(plan: &Plan) -> Result<(), RunError> {
    match external::external_names(plan) {
        Some(models) => Err(RunError::ExternalModels { models }),
        None => Ok(()),
    }
}

/// What [`train_job`] did.
#[derive(Debug)]
pub enum TrainOutcome {
    /// The job had finished in this directory: its files were verified and
    /// nothing was run.
    AlreadyFinished,
    /// The job ran.
    Ran(Box<JobOutcome>),
}

/// `crossaudit train`: one job of `plan` into the run directory `out`,
/// opened exactly as [`run`] opens it (lock, design, data and manifests
/// checked against `run.json`), so that a later `run` of the same design
/// reuses the job and a run of another design is never overwritten. A job
/// that finished there is verified and left as it is.
pub fn train_job(
    file: &DesignFile,
    plan: &Plan,
    data: &Data,
    out: &Path,
    job: &TrainingJob,
    (engine, exploratory): (crate::model::Engine, bool),
    on_epoch: &mut dyn FnMut(&crate::model::EpochLog),
) -> Result<TrainOutcome, RunError> {
    if !plan.splits.is_empty() {
        return Err(RunError::Split(crate::split::SplitError::SeveralSplits { splits: plan.splits.len() }));
    }
    refuse_external(plan)?;
    let opened = open(file, plan, data, out, exploratory, None)?;
    if let Some(r) = JobRecord::read(out, job)? {
        r.verify(out, job, &file.sha256)?;
        return Ok(TrainOutcome::AlreadyFinished);
    }
    let outcome = run_job_with(engine, &file.sha256, plan, job, &opened.prepared, out, on_epoch)?;
    Ok(TrainOutcome::Ran(Box::new(outcome)))
}

/// `crossaudit split`: the audit, manifests and invariants of `file` written
/// into `out`, refused when `out` holds a run of another design or of other
/// data (a run directory's manifests are never replaced by another's).
pub fn split_into(file: &DesignFile, plan: &Plan, data: &Data, out: &Path) -> Result<crate::split::Prepared, RunError> {
    match check_out(out, &file.sha256)? {
        None => Ok(crate::split::prepare(file, plan, &data.dir, out)?),
        Some(p) => {
            let prepared = crate::split::rebuild(file, plan, &data.dir, out)?;
            p.check_resume(out, &RunRecord::new(plan, file, data, &prepared, p.exploratory))?;
            crate::split::write_prepared(&prepared, out)?;
            Ok(prepared)
        }
    }
}
