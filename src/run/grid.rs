//! The grid of training jobs on N workers, each a single-threaded rayon
//! pool pulling jobs from one queue. The first error stops every worker
//! after its current job; finished jobs stay finished.

use std::collections::VecDeque;
use std::path::Path;
use std::sync::Mutex;
use std::time::Instant;

use super::job::{run_job_given, JobOutcome};
use super::RunError;
use crate::model::{Device, Engine, EpochLog};
use crate::plan::{Plan, TrainingJob};
use crate::split::Prepared;

/// What a run reports while it works. Called from worker threads.
pub trait RunObserver: Sync {
    /// The grid starts: `total` jobs, `already_done` of them finished before.
    fn start(&self, _total: usize, _already_done: usize) {}
    /// Before [`RunObserver::start`]: `copied` of the `total` jobs were
    /// copied from the earlier run `from` (`run --reuse`), not trained; they
    /// are among the start's `already_done`.
    fn reused(&self, _copied: usize, _total: usize, _from: &Path) {}
    /// A study with outer levels (specifications, draws) starts level
    /// `index` of `count`, described by `label`.
    fn level(&self, _index: usize, _count: usize, _label: &str) {}
    /// `jobs` networks start training at once on `device` (a GPU), before
    /// the workers roll out and score them.
    fn batch_started(&self, _jobs: usize, _device: &str) {}
    /// The networks of [`RunObserver::batch_started`] are trained, after
    /// `seconds`.
    fn batch_finished(&self, _jobs: usize, _seconds: f64) {}
    /// `worker` took `job`.
    fn job_started(&self, _worker: usize, _job: &TrainingJob) {}
    /// An epoch of `job` finished.
    fn epoch(&self, _worker: usize, _job: &TrainingJob, _log: &EpochLog) {}
    /// `job` finished after `seconds`.
    fn job_finished(&self, _worker: usize, _job: &TrainingJob, _outcome: &JobOutcome, _seconds: f64) {}
}

/// An observer that reports nothing.
pub struct Quiet;
impl RunObserver for Quiet {}

/// Runs every job of `todo` on `workers` workers, its networks trained on
/// `device`.
pub(crate) fn run_grid(
    design_sha256: &str,
    plan: &Plan,
    prepared: &Prepared,
    out: &Path,
    todo: VecDeque<TrainingJob>,
    workers: (usize, &Device),
    observer: &dyn RunObserver,
) -> Result<(), RunError> {
    let todo = todo.into_iter().map(|j| (0, j)).collect();
    run_queue(design_sha256, &[(plan, prepared, out)], todo, workers, observer).map_err(|(_, e)| e)
}

/// One level's jobs' context: its plan, its prepared split and its folder.
pub(crate) type LevelContext<'a> = (&'a Plan, &'a Prepared, &'a Path);

/// Runs every job of `todo`, each of level `todo[i].0` of `levels`, on
/// `workers` workers pulling from one queue: a study with several levels
/// keeps every worker busy until the last job of the last level, not of
/// each. An error comes with the level of the job that failed. On a GPU
/// every network is trained first, all at once ([`super::gpu`]); the
/// workers then save and score them.
pub(crate) fn run_queue(
    design_sha256: &str,
    levels: &[LevelContext],
    todo: VecDeque<(usize, TrainingJob)>,
    (workers, device): (usize, &Device),
    observer: &dyn RunObserver,
) -> Result<(), (usize, RunError)> {
    let progress = super::gpu::Progress {
        batch: &|jobs, device| observer.batch_started(jobs, device),
        done: &|jobs, seconds| observer.batch_finished(jobs, seconds),
        epoch: &|job, log| observer.epoch(0, job, log),
    };
    let plans: Vec<(&Plan, &Prepared)> = levels.iter().map(|&(plan, prepared, _)| (plan, prepared)).collect();
    let trained = Mutex::new(super::gpu::pretrain(&plans, &todo, device, progress)?);
    // No idle threads: never more workers than jobs.
    let workers = workers.min(todo.len()).max(1);
    let queue = Mutex::new(todo);
    let first_error: Mutex<Option<(usize, RunError)>> = Mutex::new(None);
    let fail = |level: usize, e: RunError| {
        if let Ok(mut slot) = first_error.lock() {
            slot.get_or_insert((level, e));
        }
    };
    std::thread::scope(|scope| {
        for worker in 0..workers {
            let (queue, first_error, fail, trained) = (&queue, &first_error, &fail, &trained);
            scope.spawn(move || {
                // One thread per worker: dfdx's matmuls run on the current
                // rayon pool.
                let pool = match rayon::ThreadPoolBuilder::new().num_threads(1).build() {
                    Ok(p) => p,
                    Err(e) => return fail(0, RunError::WorkerPool(e)),
                };
                loop {
                    if first_error.lock().map(|e| e.is_some()).unwrap_or(true) {
                        return;
                    }
                    let Some((level, job)) = queue.lock().ok().and_then(|mut q| q.pop_front()) else { return };
                    let Some(&(plan, prepared, out)) = levels.get(level) else {
                        let known = format!("a job queued for level {level} of {}", levels.len());
                        return fail(level, RunError::UnknownJob { job: job.label(), known });
                    };
                    observer.job_started(worker, &job);
                    let t0 = Instant::now();
                    let given = trained.lock().ok().and_then(|mut t| t.remove(&(level, job.stem())));
                    let result = pool.install(|| {
                        let on_epoch = &mut |log: &EpochLog| observer.epoch(worker, &job, log);
                        run_job_given(Engine::Fused, design_sha256, plan, &job, prepared, out, given, on_epoch)
                    });
                    match result {
                        Ok(o) => observer.job_finished(worker, &job, &o, t0.elapsed().as_secs_f64()),
                        Err(e) => return fail(level, e),
                    }
                }
            });
        }
    });
    match first_error.into_inner().unwrap_or(None) {
        Some(e) => Err(e),
        None => Ok(()),
    }
}
