//! One array task: its jobs (`ArrayRecord::per_task` of them, in the
//! array's job order), each locked, a finished one verified and skipped,
//! the rest trained as a local run trains them. On a GPU their networks
//! train together first (the batched trainer, `super::super::gpu`); on
//! the CPU each trains in turn on one thread. Each job's files and record
//! are those of a local run.

use std::collections::{HashMap, VecDeque};
use std::path::Path;
use std::sync::Mutex;

use super::{rebuild, reopen, SLURM_DIR};
use crate::io::create_dir_all;
use crate::model::{Engine, EpochLog};
use crate::plan::{Plan, TrainingJob};
use crate::run::job::Trained;
use crate::run::{JobRecord, RunError};
use crate::split::Prepared;

/// What one job of an array task did.
#[derive(Debug)]
pub enum TaskOutcome {
    /// The job had finished before: its files were verified and nothing ran.
    AlreadyFinished {
        /// `model/arm/seed`.
        job: String,
    },
    /// The job ran now.
    Ran {
        /// `model/arm/seed` (`split-s model/arm/seed` in a multi-split study).
        job: String,
        /// What it wrote.
        outcome: Box<crate::run::JobOutcome>,
    },
}

/// What one array task did: where it trained and each of its jobs.
#[derive(Debug)]
pub struct TaskRun {
    /// What `--device auto` chose, and why; `None` for `cpu` and `cuda`.
    pub device_note: Option<String>,
    /// The networks trained together on a GPU: how many, on what, in how
    /// many seconds; `None` on the CPU.
    pub batched: Option<(usize, String, f64)>,
    /// Each job, in the array's order.
    pub jobs: Vec<TaskOutcome>,
}

/// Runs the jobs of array task `index` of the run prepared in `dir`
/// (`per_task` of them in the array's job order, fewer in the last task)
/// exactly as a local run would: on the CPU one after another on one
/// thread, on a GPU their networks trained together first; skips (after
/// verifying its files) a job that finished. A lock on
/// `DIR/slurm/locks/J.lock` for each job J, released by the operating
/// system however the task ends, keeps two tasks off one job; a shared
/// lock on `DIR` itself keeps a `run` or `gather` off the folder. A job
/// that fails ends the task; the jobs before it keep their records, and a
/// resubmitted task skips them.
pub fn run_task(dir: &Path, index: usize, on_epoch: &mut (dyn FnMut(&EpochLog) + Send)) -> Result<TaskRun, RunError> {
    let p = reopen(dir)?;
    // Shared: the jobs of one run train side by side, while a `run`,
    // `train` or `gather` on the folder (exclusive) is refused meanwhile.
    let _folder = crate::run::lock_folder(dir, true)?;
    let jobs = p.jobs();
    let (per_task, tasks) = (p.array.per_task, p.array.tasks());
    if index >= tasks {
        return Err(RunError::NoSuchTask { index, jobs: jobs.len(), tasks, per_task });
    }
    let locks = dir.join(SLURM_DIR).join("locks");
    create_dir_all(&locks)?;
    // Held until the task ends.
    let mut held = Vec::new();
    let mut outcomes = Vec::new();
    let mut todo = Vec::new();
    for j in p.array.jobs_of(index) {
        let (k, local) = jobs[j];
        let (part, label) = (&p.parts[k].0, p.parts[k].0.label(local));
        held.push(lock_job(&locks, j, &label)?);
        match JobRecord::read(&part.dir, local)? {
            Some(r) => {
                r.verify(&part.dir, local, &p.array.design_sha256)?;
                outcomes.push((j, TaskOutcome::AlreadyFinished { job: label }));
            }
            None => todo.push(j),
        }
    }
    if todo.is_empty() {
        return Ok(TaskRun { device_note: None, batched: None, jobs: outcomes.into_iter().map(|(_, o)| o).collect() });
    }
    // Before anything is rebuilt: a node without the GPU asked for is told
    // at once.
    let (device, device_note) =
        crate::model::device::resolve(p.array.device).map_err(|e| RunError::Device(e.to_string()))?;
    // Each run directory with a job to run, rebuilt once: (part, split),
    // and each part's place among them.
    let mut built: Vec<(usize, Prepared)> = Vec::new();
    let mut place = vec![0; p.parts.len()];
    for &j in &todo {
        let k = jobs[j].0;
        if !built.iter().any(|(b, _)| *b == k) {
            let (part, run) = &p.parts[k];
            place[k] = built.len();
            built.push((k, rebuild(&p.array, part, run)?));
        }
    }
    // The GPU's networks, by (position in `built`, job stem).
    let levels: Vec<(&Plan, &Prepared)> = built.iter().map(|(k, s)| (&p.parts[*k].0.plan, s)).collect();
    let queue: VecDeque<(usize, TrainingJob)> = todo.iter().map(|&j| (place[jobs[j].0], jobs[j].1.clone())).collect();
    let (mut trained, batched) = train_together(&levels, &queue, &device, &mut *on_epoch)?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    for &j in &todo {
        let (k, local) = jobs[j];
        let part = &p.parts[k].0;
        let split = &built[place[k]].1;
        let given = trained.remove(&(place[k], local.stem()));
        let outcome = pool.install(|| {
            crate::run::job::run_job_given(
                Engine::Fused,
                &p.array.design_sha256,
                &part.plan,
                local,
                split,
                &part.dir,
                given,
                &mut *on_epoch,
            )
        })?;
        let mut outcome = Box::new(outcome);
        if let Some(level) = &part.level {
            // Paths relative to the study's directory, as the logs quote them.
            outcome.files = outcome.files.iter().map(|f| format!("{level}/{f}")).collect();
        }
        outcomes.push((j, TaskOutcome::Ran { job: part.label(local), outcome }));
    }
    drop(held);
    outcomes.sort_by_key(|(j, _)| *j);
    Ok(TaskRun { device_note, batched, jobs: outcomes.into_iter().map(|(_, o)| o).collect() })
}

/// The queue's networks trained together on `device` by the batched
/// trainer, by (level, job stem), with how many, on what and in how many
/// seconds; nothing on the CPU, where each job trains in turn.
#[allow(clippy::type_complexity)]
fn train_together(
    levels: &[(&Plan, &Prepared)],
    queue: &VecDeque<(usize, TrainingJob)>,
    device: &crate::model::Device,
    on_epoch: &mut (dyn FnMut(&EpochLog) + Send),
) -> Result<(HashMap<(usize, String), Trained>, Option<(usize, String, f64)>), RunError> {
    let batch = Mutex::new(None);
    let on_epoch = Mutex::new(on_epoch);
    let progress = crate::run::gpu::Progress {
        batch: &|n, d| {
            if let Ok(mut b) = batch.lock() {
                *b = Some((n, d.to_string(), 0.0));
            }
        },
        done: &|_, seconds| {
            if let Ok(mut b) = batch.lock() {
                if let Some(b) = b.as_mut() {
                    b.2 = seconds;
                }
            }
        },
        epoch: &|_: &TrainingJob, log: &EpochLog| {
            if let Ok(mut f) = on_epoch.lock() {
                f(log);
            }
        },
    };
    let trained = crate::run::gpu::pretrain(levels, queue, device, progress).map_err(|(_, e)| e)?;
    Ok((trained, batch.into_inner().unwrap_or(None)))
}

/// Job `j`'s lock, `DIR/slurm/locks/J.lock`, taken; refused where another
/// task holds it.
fn lock_job(locks: &Path, j: usize, label: &str) -> Result<std::fs::File, RunError> {
    let path = locks.join(format!("{j}.lock"));
    let lock = std::fs::File::create(&path).map_err(|e| RunError::Write(crate::io::WriteError::new(&path, e)))?;
    match lock.try_lock() {
        Ok(()) => Ok(lock),
        Err(std::fs::TryLockError::WouldBlock) => {
            Err(RunError::JobBusy { job: label.to_string(), lock: path.display().to_string() })
        }
        Err(std::fs::TryLockError::Error(e)) => Err(RunError::Write(crate::io::WriteError::new(&path, e))),
    }
}
