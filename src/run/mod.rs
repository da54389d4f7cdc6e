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

mod error;
pub mod external;
mod folder;
mod grid;
mod guard;
pub mod job;
pub mod outer;
mod read;
mod record;
pub mod reuse;
pub mod slurm;
mod source;
mod trained_invariants;

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::analysis::{self, StudyAnalysis};
use crate::cells::{read_cells, write_cells_atomic, Cell, CellsError};
use crate::design::{lock, DesignFile, LockStatus};
use crate::io::create_dir_all;
use crate::plan::{Plan, StudyPlan, TrainingJob};

pub use error::RunError;
pub use folder::{check_out_dir, lock_folder, FolderLock};
pub use grid::{Quiet, RunObserver};
use guard::refuse_single_run;
pub use guard::{check_not_runs_own, check_out, check_out_plan, check_output_dir};
pub use job::{run_job, run_job_with, JobOutcome};
pub use read::{read_folder, read_levels, read_record, LevelFolder};
pub use record::{job_record_path, JobRecord, RunRecord, StudyRecord};
pub use source::{data_dir, design_data_path, Data, DataOrigin};
pub use trained_invariants::check as check_trained_invariants;

/// The most training workers (threads) a run starts.
pub const MAX_WORKERS: usize = 1024;

/// Options of a run that are not part of the design.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Parallel training workers, one thread each.
    pub workers: usize,
    /// Run a design that changed after locking, labelling every output.
    pub exploratory: bool,
    /// An earlier run folder whose finished jobs with identical inputs are
    /// copied instead of trained (`run --reuse DIR`, [`reuse`]).
    pub reuse: Option<PathBuf>,
}

/// What a finished run produced.
#[derive(Debug, Clone)]
pub struct RunOutcome {
    /// `out/cells.csv`.
    pub cells_csv: PathBuf,
    /// `out/report`.
    pub report_dir: PathBuf,
    /// The analysis written to the report.
    pub analysis: StudyAnalysis,
    /// Jobs run now.
    pub trained: usize,
    /// Jobs finished by an earlier run.
    pub skipped: usize,
    /// Wall seconds.
    pub seconds: f64,
}

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
    let (mut todo, builds) = pending(plan, out, &file.sha256)?;
    let keys = reuse::keys(&file.design, plan, &opened.prepared.manifests, &opened.record);
    if let Some(index) = &index {
        let mut taken = 0;
        for (j, key) in &keys {
            if todo.contains(j) && index.take(key, out, j, &file.sha256)? {
                todo.retain(|t| t != j);
                taken += 1;
            }
        }
        if taken > 0 {
            opened.warnings.push(reuse::reused_note(taken, plan.jobs.len(), index.from()));
        }
    }
    let skipped = plan.jobs.len() - todo.len();
    observer.start(plan.jobs.len(), skipped);
    let trained = todo.len();
    grid::run_grid(&file.sha256, plan, &opened.prepared, out, todo, options.workers, observer)?;
    reuse::stamp(out, &keys)?;
    let mut outcome = finish(&file.path.display().to_string(), plan, &opened, out, builds)?;
    (outcome.trained, outcome.skipped, outcome.seconds) = (trained, skipped, started.elapsed().as_secs_f64());
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

/// At least one worker, at most [`MAX_WORKERS`].
pub fn check_workers(workers: usize) -> Result<(), RunError> {
    match workers {
        0 => Err(RunError::NoWorkers),
        n if n > MAX_WORKERS => Err(RunError::TooManyWorkers { workers: n }),
        _ => Ok(()),
    }
}

/// After every split finished: `out/cells.csv` with a `split` column, then
/// the folder finished as [`finish_combined`] finishes it (the family
/// analysis in `out/report`).
pub(crate) fn finish_splits(
    design: analysis::record::DesignLabel,
    plan: &Plan,
    outer: &outer::Outer,
    out: &Path,
    notes: &[String],
) -> Result<RunOutcome, RunError> {
    let started = Instant::now();
    let levels = LevelFolder::of(outer, out);
    let mut all: Vec<Cell> = Vec::new();
    for (l, level) in levels.iter().zip(&outer.levels) {
        let split = level.split;
        all.extend(read_cells(&l.dir.join("cells.csv"))?.into_iter().map(|c| Cell { split, ..c }));
    }
    write_cells_atomic(&out.join("cells.csv"), &all)?;
    let mut outcome = finish_combined(design, plan, out, &levels, notes)?;
    outcome.seconds = started.elapsed().as_secs_f64();
    Ok(outcome)
}

/// The folder `dir` of a study of several level folders `levels`, once its
/// combined `cells.csv` is written: `study.json` (the levels, the cells'
/// hash, the run's `notes`), then the folder read back as a record,
/// analysed and reported in `dir/report`, exactly as `crossaudit analyze
/// DESIGN --cells DIR` does.
pub(crate) fn finish_combined(
    design: analysis::record::DesignLabel,
    plan: &Plan,
    dir: &Path,
    levels: &[LevelFolder],
    notes: &[String],
) -> Result<RunOutcome, RunError> {
    let started = Instant::now();
    let cells_csv = dir.join("cells.csv");
    StudyRecord {
        study: plan.study.clone(),
        design_sha256: design.sha256.clone(),
        crossaudit: crate::io::BUILD.to_string(),
        levels: levels.iter().map(|l| l.id.clone()).collect(),
        cells_sha256: crate::cells::file_sha256(&cells_csv)?,
        notes: notes.to_vec(),
        shared: Vec::new(),
    }
    .write(dir)?;
    let record = read::read_levels(design, dir, levels)?;
    let mut analysis = analysis::analyze_study(plan, &record, Default::default())?;
    let report_dir = dir.join("report");
    crate::report::write_study(&mut analysis, &report_dir)?;
    Ok(RunOutcome {
        cells_csv,
        report_dir,
        analysis,
        trained: 0,
        skipped: plan.jobs.len(),
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// A run directory made ready for its jobs: the lock state it runs under,
/// the prepared split and the record written to `run.json`.
struct Opened {
    /// The design's lock state when the run was opened.
    status: LockStatus,
    /// The split every job reads.
    prepared: crate::split::Prepared,
    /// What `run.json` holds.
    record: RunRecord,
    /// Warnings the report adds (external models' predictions).
    warnings: Vec<String>,
}

/// Checks the lock, refuses a directory that holds another design or other
/// data, writes the audit, manifests and invariants, and (re)writes
/// `run.json`: everything before the first job. Nothing is written into a
/// directory that holds a run until its record (design, data, audit and
/// manifests) is found to be this run's.
fn open(
    file: &DesignFile,
    plan: &Plan,
    data: &Data,
    out: &Path,
    exploratory: bool,
    level: Option<&str>,
) -> Result<Opened, RunError> {
    let status = check_lock(file, exploratory)?;
    let exploratory = exploratory || status.changed();
    let previous = check_out(out, &file.sha256)?;
    create_dir_all(out)?;
    let prepared = match &previous {
        None => crate::split::prepare(file, plan, &data.dir, out)?,
        Some(p) => {
            // Built in memory and compared first: a directory of another
            // data set is refused before anything in it is overwritten.
            let prepared = crate::split::rebuild(file, plan, &data.dir, out)?;
            let now = RunRecord {
                level: level.map(str::to_string),
                ..RunRecord::new(plan, file, data, &prepared, exploratory)
            };
            p.check_resume(out, &now)?;
            crate::split::write_prepared(&prepared, out)?;
            prepared
        }
    };
    // The hash of a cells.csv gathered earlier stays until a gather
    // rewrites both (a `train` of one job gathers nothing).
    let record = RunRecord {
        level: level.map(str::to_string),
        cells_sha256: previous.as_ref().and_then(|p| p.cells_sha256.clone()),
        ..RunRecord::new(plan, file, data, &prepared, exploratory)
    };
    record.write(out)?;
    Ok(Opened { status, prepared, record, warnings: Vec::new() })
}

/// The design's lock state, refusing a design that changed after it was
/// locked unless the run is labelled exploratory: checked before anything
/// (simulated data included) is written.
pub fn check_lock(file: &DesignFile, exploratory: bool) -> Result<LockStatus, RunError> {
    let status = lock::status(file)?;
    if status.changed() && !exploratory {
        return Err(RunError::LockChanged { path: file.path.display().to_string(), reason: status.reason() });
    }
    Ok(status)
}

/// The jobs without a record, in plan order, and the builds that ran the
/// finished ones. Each finished job's record must be of this run's design
/// and list exactly the files such a job writes, each unchanged.
fn pending(
    plan: &Plan,
    out: &Path,
    design_sha256: &str,
) -> Result<(VecDeque<TrainingJob>, std::collections::BTreeSet<String>), RunError> {
    let mut todo = VecDeque::new();
    let mut builds = std::collections::BTreeSet::new();
    for j in &plan.jobs {
        match JobRecord::read(out, j)? {
            Some(r) => {
                r.verify(out, j, design_sha256)?;
                builds.insert(r.crossaudit);
            }
            None => todo.push_back(j.clone()),
        }
    }
    Ok((todo, builds))
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

/// Everything after the last job: the invariants on what the jobs recorded,
/// cells.csv (with the builds that trained it and the run's notes in
/// run.json), then the folder read back as a record, analysed and
/// reported, exactly as `crossaudit analyze DESIGN --cells OUT` does.
/// `design_path` is the design as the user named it (the report quotes
/// it); `builds` are the builds that trained cells.
fn finish(
    design_path: &str,
    plan: &Plan,
    opened: &Opened,
    out: &Path,
    builds: std::collections::BTreeSet<String>,
) -> Result<RunOutcome, RunError> {
    let started = Instant::now();
    let cells_csv = gather_recorded(plan, opened, out, &builds)?;
    let design = analysis::record::DesignLabel {
        path: design_path.to_string(),
        sha256: opened.record.design_sha256.clone(),
        status: opened.status.clone(),
    };
    let record = read::read_folder(design, plan, out)?;
    let mut analysis = analysis::analyze_study(plan, &record, Default::default())?;
    let report_dir = out.join("report");
    crate::report::write_study(&mut analysis, &report_dir)?;
    Ok(RunOutcome {
        cells_csv,
        report_dir,
        analysis,
        trained: 0,
        skipped: plan.jobs.len(),
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// `out/cells/STEM.csv`: the per-cell rows of one job, present once it finished.
pub fn job_cells(out: &Path, job: &TrainingJob) -> PathBuf {
    out.join("cells").join(format!("{}.csv", job.stem()))
}

/// cells.csv: every job's rows in plan order, written atomically.
fn gather(plan: &Plan, out: &Path) -> Result<PathBuf, RunError> {
    let all = gathered(plan, out)?;
    let cells_csv = out.join("cells.csv");
    write_cells_atomic(&cells_csv, &all)?;
    Ok(cells_csv)
}

/// The invariants on what the jobs recorded, then `cells.csv` gathered and
/// its hash recorded in `run.json`, with the builds other than this one
/// among `builds` (those that trained cells) and the run's notes.
fn gather_recorded(
    plan: &Plan,
    opened: &Opened,
    out: &Path,
    builds: &std::collections::BTreeSet<String>,
) -> Result<PathBuf, RunError> {
    trained_invariants::check(plan, &opened.prepared, out)?;
    let cells_csv = gather(plan, out)?;
    let sha = crate::cells::file_sha256(&cells_csv)?;
    let resumed_from = builds.iter().filter(|b| *b != crate::io::BUILD).cloned().collect();
    let notes = opened.warnings.clone();
    RunRecord { cells_sha256: Some(sha), resumed_from, notes, ..opened.record.clone() }.write(out)?;
    Ok(cells_csv)
}

/// Every job's per-cell rows, in plan order, as `cells.csv` holds them.
pub(crate) fn gathered(plan: &Plan, out: &Path) -> Result<Vec<Cell>, RunError> {
    let mut all: Vec<Cell> = Vec::new();
    for j in &plan.jobs {
        all.extend(read_cells(&job_cells(out, j))?);
    }
    check_baselines(plan, &all)?;
    if !plan.doses.is_empty() && crate::plan::dose_axis(&plan.doses) == crate::design::DoseAxis::Percent {
        // A dose-response study's cells carry their dose: 0 for the
        // reference. A distance-dose study's arms name their distances.
        for c in &mut all {
            c.dose = if c.arm == plan.contrast.reference {
                Some(0.0)
            } else {
                plan.doses.iter().find(|d| d.arm == c.arm).map(|d| d.percent)
            };
        }
    }
    Ok(all)
}

/// Parameter-free models fit nothing split-dependent: their rows must be
/// identical across arms.
fn check_baselines(plan: &Plan, cells: &[Cell]) -> Result<(), RunError> {
    for m in plan.models.iter().filter(|m| !m.kind.trains()) {
        let rows = |arm: &str| -> Vec<(u64, String, u64, String)> {
            cells
                .iter()
                .filter(|c| c.model == m.name && c.arm == arm)
                .map(|c| {
                    (
                        c.seed,
                        c.recording.to_string(),
                        c.horizon_s.to_bits(),
                        format!("{:?}", (c.fa_position_rmse_m, c.conditional_position_rmse_m, c.n_divergent)),
                    )
                })
                .collect()
        };
        for w in plan.arms.windows(2) {
            if rows(&w[0].name) != rows(&w[1].name) {
                return Err(RunError::BaselineDependsOnArm {
                    model: m.name.clone(),
                    left: w[0].name.clone(),
                    right: w[1].name.clone(),
                });
            }
        }
    }
    Ok(())
}
