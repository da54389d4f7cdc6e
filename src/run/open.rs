//! A run directory opened for its jobs: the options of a run, the lock
//! it runs under, the split prepared and `run.json` written (`open`), and
//! the jobs not yet finished (`pending`).

use std::collections::VecDeque;
use std::path::{Path, PathBuf};

use super::guard::check_out;
use super::{Data, JobRecord, RunError, RunRecord};
use crate::analysis::StudyAnalysis;
use crate::design::{lock, DesignFile, LockStatus};
use crate::io::create_dir_all;
use crate::plan::{Plan, TrainingJob};

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
    /// copied instead of trained (`run --reuse DIR`, `reuse`).
    pub reuse: Option<PathBuf>,
    /// Where the networks train (`run --device`): the CPU by default.
    pub device: crate::model::Device,
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
    /// Jobs finished by an earlier run in this folder (resumed).
    pub skipped: usize,
    /// Jobs copied from another run's folder (`run --reuse`), not trained.
    pub copied: usize,
    /// Wall seconds.
    pub seconds: f64,
}

/// At least one worker, at most [`MAX_WORKERS`].
pub fn check_workers(workers: usize) -> Result<(), RunError> {
    match workers {
        0 => Err(RunError::NoWorkers),
        n if n > MAX_WORKERS => Err(RunError::TooManyWorkers { workers: n, max: MAX_WORKERS }),
        _ => Ok(()),
    }
}

/// A run directory made ready for its jobs: the lock state it runs under,
/// the prepared split and the record written to `run.json`.
pub(crate) struct Opened {
    /// The design's lock state when the run was opened.
    pub(crate) status: LockStatus,
    /// The split every job reads.
    pub(crate) prepared: crate::split::Prepared,
    /// What `run.json` holds.
    pub(crate) record: RunRecord,
    /// The run's notes, which run.json records and the report gives (jobs
    /// reused, external models' predictions).
    pub(crate) notes: Vec<String>,
}

impl Opened {
    /// Records in run.json the device the run trains on (nothing for the
    /// CPU), and for a GPU a note the report gives beside its findings.
    pub(crate) fn record_device(&mut self, device: &crate::model::Device, out: &Path) -> Result<(), RunError> {
        self.record.device = device.record();
        if let Some(name) = &self.record.device {
            self.notes.push(format!(
                "the networks trained now were trained on {name} (`run --device`): a CPU run of this design gives cells within the GPU trainer's floating-point tolerance of these, not the same bytes (docs/usage.md, \"Training on a GPU\")"
            ));
            self.record.write(out)?;
        }
        Ok(())
    }
}

/// Checks the lock, refuses a directory that holds another design or other
/// data, writes the audit, manifests and invariants, and (re)writes
/// `run.json`: everything before the first job. Nothing is written into a
/// directory that holds a run until its record (design, data, audit and
/// manifests) is found to be this run's.
pub(crate) fn open(
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
    // rewrites both (a `train` of one job gathers nothing); the lock state
    // and label the run began under stay for good (a resume of a run
    // labelled EXPLORATORY is too).
    let record = RunRecord {
        level: level.map(str::to_string),
        cells_sha256: previous.as_ref().and_then(|p| p.cells_sha256.clone()),
        lock: previous.as_ref().map_or_else(|| Some(status.clone()), |p| p.lock.clone()),
        ..RunRecord::new(plan, file, data, &prepared, exploratory || previous.as_ref().is_some_and(|p| p.exploratory))
    };
    record.write(out)?;
    Ok(Opened { status, prepared, record, notes: Vec::new() })
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
pub(crate) fn pending(
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
