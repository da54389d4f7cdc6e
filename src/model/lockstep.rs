//! The training loop of the protocol, for one job or many in lockstep:
//! per-epoch learning rate, ChaCha8 shuffling (stream 1) and action noise
//! (stream 2) from each job's seed, early stopping with patience, the best
//! parameters kept. What the parameters live on is a [`Backend`]: one
//! job's fused or dfdx trainer ([`PerJob`]), or K jobs' parameters on a GPU
//! (`super::cuda`), stepped together.
//!
//! Each job's shuffle, noise and minibatches are its own and are drawn in
//! the same order whatever else is in the batch: a job trained alone and
//! the same job trained beside others see the same inputs, step by step.
//! A job that stops early leaves the batch.

use std::time::Instant;

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use super::features::{Action, FeatureMap, State};
use super::minibatch::Minibatches;
use crate::design::{Schedule, Training};
use crossaudit_stats::standard_normal;

/// Windows as (x_t, u_t, x_{t+1}).
pub type Windows = [(State, Action, State)];

/// One epoch of training.
#[derive(Debug, Clone, Serialize)]
pub struct EpochLog {
    /// 1-based epoch.
    pub epoch: usize,
    /// Learning rate of the epoch.
    pub lr: f64,
    /// Mean standardized MSE over the epoch's batches (with action noise).
    pub train_loss: f64,
    /// Standardized MSE on the shared validation windows (clean actions).
    pub val_loss: f64,
    /// Wall seconds of the epoch.
    pub seconds: f64,
}

/// Learning rate at `epoch` (0-based) of `epochs`: cosine from lr to 0, or
/// constant.
pub fn learning_rate(t: &Training, epoch: usize) -> f64 {
    match t.schedule {
        Schedule::Constant => t.lr,
        Schedule::Cosine => t.lr * 0.5 * (1.0 + (std::f64::consts::PI * epoch as f64 / t.epochs as f64).cos()),
    }
}

/// One network to train: its architecture, standardizers, windows,
/// protocol and seed.
#[derive(Clone, Copy)]
pub struct BatchJob<'a> {
    /// Hidden widths.
    pub widths: &'a [usize],
    /// The standardizers fitted on its fit windows.
    pub features: &'a FeatureMap,
    /// Its fit windows.
    pub fit: &'a Windows,
    /// Its validation windows.
    pub validation: &'a Windows,
    /// The protocol (batch, epochs, schedule, patience, noise).
    pub training: &'a Training,
    /// Its seed: initialisation, shuffling and action noise.
    pub seed: u64,
}

/// A backend's failure (a GPU call that failed), in words.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct BackendError(pub String);

/// One optimizer step of one job: its minibatch of `n` rows.
pub(super) struct Step<'a> {
    /// The job's index in the batch.
    pub job: usize,
    /// n x inputs.
    pub x: &'a [f32],
    /// n x outputs.
    pub y: &'a [f32],
    /// Rows.
    pub n: usize,
    /// The epoch's learning rate.
    pub lr: f64,
}

/// Where the jobs' parameters live and are stepped.
pub(super) trait Backend {
    /// One optimizer step of each job in `steps` (each job at most once);
    /// each one's batch loss before its step, in the order of `steps`.
    fn steps(&mut self, steps: &[Step<'_>]) -> Result<Vec<f32>, BackendError>;
    /// The validation loss of each job in `jobs` with its current parameters.
    fn val_losses(&mut self, jobs: &[usize]) -> Result<Vec<f64>, BackendError>;
    /// Keeps job `job`'s current parameters as its best.
    fn keep_best(&mut self, job: usize) -> Result<(), BackendError>;
    /// Jobs `jobs` have stopped (early, or at their last epoch) while
    /// others go on: none of them steps again, and each one's best
    /// parameters are kept wherever the backend keeps them.
    fn leave(&mut self, jobs: &[usize]) -> Result<(), BackendError> {
        let _ = jobs;
        Ok(())
    }
}

/// Writes the standardized inputs of windows `idx` into `out` (one row of
/// 18 per window), adding clipped Gaussian action noise when asked.
fn fill_inputs(
    features: &FeatureMap,
    windows: &Windows,
    idx: &[usize],
    noise: Option<(f64, &mut ChaCha8Rng)>,
    out: &mut [f32],
) {
    let mut noise = noise;
    let mut u = vec![0.0; features.slots.action];
    for (row, &k) in out.chunks_exact_mut(features.slots.input()).zip(idx) {
        let (s, action, _) = &windows[k];
        u.copy_from_slice(action);
        if let Some((sd, rng)) = noise.as_mut() {
            for a in u.iter_mut() {
                *a = (*a + *sd * standard_normal(rng)).clamp(0.0, 1.0);
            }
        }
        features.input(s, &u, row);
    }
}

/// Writes the standardized targets of windows `idx` into `out`.
fn fill_targets(features: &FeatureMap, windows: &Windows, idx: &[usize], out: &mut [f32]) {
    for (row, &k) in out.chunks_exact_mut(features.slots.state).zip(idx) {
        let (s, _, n) = &windows[k];
        features.target(s, n, row);
    }
}

/// A job's validation inputs and targets (clean actions), every window.
pub(super) fn validation_set(job: &BatchJob) -> (Vec<f32>, Vec<f32>) {
    let (features, windows) = (job.features, job.validation);
    let all: Vec<usize> = (0..windows.len()).collect();
    let mut x = vec![0f32; all.len() * features.slots.input()];
    fill_inputs(features, windows, &all, None, &mut x);
    let mut y = vec![0f32; all.len() * features.slots.state];
    fill_targets(features, windows, &all, &mut y);
    (x, y)
}

/// One job's course through its epochs.
struct Course {
    shuffle: ChaCha8Rng,
    noise: ChaCha8Rng,
    order: Vec<usize>,
    /// The current minibatch's inputs and targets.
    x: Vec<f32>,
    y: Vec<f32>,
    best_val: f64,
    since_best: usize,
    done: bool,
    loss_sum: f64,
    lr: f64,
    started: Instant,
    logs: Vec<EpochLog>,
}

impl Course {
    fn new(job: &BatchJob) -> Course {
        let mut shuffle = ChaCha8Rng::seed_from_u64(job.seed);
        shuffle.set_stream(1);
        let mut noise = ChaCha8Rng::seed_from_u64(job.seed);
        noise.set_stream(2);
        let (t, slots) = (job.training, job.features.slots);
        Course {
            shuffle,
            noise,
            order: (0..job.fit.len()).collect(),
            x: vec![0f32; t.batch * slots.input()],
            y: vec![0f32; t.batch * slots.state],
            best_val: f64::INFINITY,
            since_best: 0,
            done: false,
            loss_sum: 0.0,
            lr: 0.0,
            started: Instant::now(),
            logs: Vec::new(),
        }
    }

    /// Epoch `epoch` begins: its learning rate and shuffle.
    fn begin(&mut self, job: &BatchJob, epoch: usize) {
        self.started = Instant::now();
        self.lr = learning_rate(job.training, epoch);
        self.order.shuffle(&mut self.shuffle);
        self.loss_sum = 0.0;
    }

    /// Fills minibatch `b` of the epoch (with action noise); its rows, or
    /// `None` when this job's epoch has fewer batches.
    fn fill(&mut self, job: &BatchJob, b: usize) -> Option<usize> {
        let t = job.training;
        let batch = self.order.chunks(t.batch).nth(b)?;
        let n = batch.len();
        let (inputs, state) = (job.features.slots.input(), job.features.slots.state);
        let noise = Some((t.action_noise, &mut self.noise));
        fill_inputs(job.features, job.fit, batch, noise, &mut self.x[..n * inputs]);
        fill_targets(job.features, job.fit, batch, &mut self.y[..n * state]);
        Some(n)
    }

    /// Epoch `epoch` ends with validation loss `val_loss`: its log, and
    /// early stopping. Returns whether the current parameters are the
    /// job's best so far.
    fn end(&mut self, job: &BatchJob, epoch: usize, val_loss: f64) -> (EpochLog, bool) {
        let t = job.training;
        let log = EpochLog {
            epoch: epoch + 1,
            lr: self.lr,
            train_loss: self.loss_sum / job.fit.len() as f64,
            val_loss,
            seconds: self.started.elapsed().as_secs_f64(),
        };
        self.logs.push(log.clone());
        let keep = if t.restore_final {
            // The full budget: no early stopping, the last epoch kept.
            epoch + 1 == t.epochs
        } else if val_loss < self.best_val {
            self.best_val = val_loss;
            self.since_best = 0;
            true
        } else {
            self.since_best += 1;
            self.done = self.since_best >= t.patience;
            false
        };
        self.done |= epoch + 1 >= t.epochs;
        (log, keep)
    }
}

/// Trains `jobs` on `backend` in lockstep, epoch by epoch and minibatch by
/// minibatch; `on_epoch` sees each job's every epoch (job index, log).
/// Returns each job's epoch logs; the backend holds each job's best
/// parameters.
pub(super) fn lockstep(
    backend: &mut dyn Backend,
    jobs: &[BatchJob],
    on_epoch: &mut dyn FnMut(usize, &EpochLog),
) -> Result<Vec<Vec<EpochLog>>, BackendError> {
    let mut courses: Vec<Course> = jobs.iter().map(Course::new).collect();
    for epoch in 0.. {
        let active: Vec<usize> =
            (0..jobs.len()).filter(|&k| !courses[k].done && epoch < jobs[k].training.epochs).collect();
        if active.is_empty() {
            break;
        }
        for &k in &active {
            courses[k].begin(&jobs[k], epoch);
        }
        for b in 0.. {
            // Each active job's next minibatch, filled in parallel: each
            // job draws only from its own streams.
            let rows: Vec<Option<usize>> = courses
                .par_iter_mut()
                .zip(jobs.par_iter())
                .enumerate()
                .map(|(k, (c, job))| if active.contains(&k) { c.fill(job, b) } else { None })
                .collect();
            let steps: Vec<Step> = rows
                .iter()
                .enumerate()
                .filter_map(|(k, n)| n.map(|n| (k, n)))
                .map(|(k, n)| {
                    let (c, slots) = (&courses[k], jobs[k].features.slots);
                    Step { job: k, x: &c.x[..n * slots.input()], y: &c.y[..n * slots.state], n, lr: c.lr }
                })
                .collect();
            if steps.is_empty() {
                break;
            }
            let losses = backend.steps(&steps)?;
            let stepped: Vec<(usize, usize)> = steps.iter().map(|s| (s.job, s.n)).collect();
            for ((k, n), loss) in stepped.into_iter().zip(losses) {
                courses[k].loss_sum += f64::from(loss) * n as f64;
            }
        }
        let val = backend.val_losses(&active)?;
        for (&k, val_loss) in active.iter().zip(val) {
            let (log, keep) = courses[k].end(&jobs[k], epoch, val_loss);
            on_epoch(k, &log);
            if keep {
                backend.keep_best(k)?;
            }
        }
        let stopped: Vec<usize> = active.iter().copied().filter(|&k| courses[k].done).collect();
        if !stopped.is_empty() && stopped.len() < active.len() {
            backend.leave(&stopped)?;
        }
    }
    Ok(courses.into_iter().map(|c| c.logs).collect())
}

/// Jobs each on its own CPU trainer (the fused trainer or dfdx's), with
/// its validation set on the host.
pub(super) struct PerJob<'a> {
    trainers: Vec<&'a mut dyn Minibatches>,
    validation: Vec<(Vec<f32>, Vec<f32>)>,
}

impl<'a> PerJob<'a> {
    /// `trainers[k]` trains `jobs[k]`.
    pub(super) fn new(trainers: Vec<&'a mut dyn Minibatches>, jobs: &[BatchJob]) -> PerJob<'a> {
        PerJob { trainers, validation: jobs.iter().map(validation_set).collect() }
    }
}

impl Backend for PerJob<'_> {
    fn steps(&mut self, steps: &[Step<'_>]) -> Result<Vec<f32>, BackendError> {
        Ok(steps.iter().map(|s| self.trainers[s.job].step(s.x, s.y, s.n, s.lr)).collect())
    }
    fn val_losses(&mut self, jobs: &[usize]) -> Result<Vec<f64>, BackendError> {
        Ok(jobs
            .iter()
            .map(|&k| {
                let (x, y) = &self.validation[k];
                self.trainers[k].val_loss(x, y)
            })
            .collect())
    }
    fn keep_best(&mut self, job: usize) -> Result<(), BackendError> {
        self.trainers[job].keep_best();
        Ok(())
    }
}
