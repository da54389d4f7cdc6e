//! A run's networks trained on a GPU before its workers start: every MLP
//! job of the queue, of every level, goes to the batched trainer at once
//! ([`crate::model::train_batch`]), which steps the jobs of one shape
//! together. The workers then save, roll out and score each network as if
//! they had trained it; each job's record names the device.

use std::collections::{HashMap, VecDeque};
use std::time::Instant;

use rayon::prelude::*;

use super::job::{mlp_setup, MlpSetup, Trained};
use super::RunError;
use crate::model::{train_batch, BatchJob, Device, EpochLog};
use crate::plan::{Plan, TrainingJob};
use crate::split::Prepared;

/// What a run reports while the GPU trains: the batch's start (how many
/// networks, on what), each job's every epoch, and the batch's end.
pub(crate) struct Progress<'a> {
    pub(crate) batch: &'a dyn Fn(usize, &str),
    pub(crate) done: &'a dyn Fn(usize, f64),
    pub(crate) epoch: &'a (dyn Fn(&TrainingJob, &EpochLog) + Sync),
}

/// Each MLP job's trained network by (level, job stem); nothing on the CPU,
/// where each worker trains its own jobs.
pub(crate) fn pretrain(
    levels: &[(&Plan, &Prepared)],
    todo: &VecDeque<(usize, TrainingJob)>,
    device: &Device,
    progress: Progress,
) -> Result<HashMap<(usize, String), Trained>, (usize, RunError)> {
    if *device == Device::Cpu {
        return Ok(HashMap::new());
    }
    // Each job's windows and standardizers, in parallel.
    let setups: Vec<Option<(usize, &TrainingJob, MlpSetup)>> = todo
        .par_iter()
        .map(|(level, job)| {
            let Some(&(plan, prepared)) = levels.get(*level) else { return Ok(None) };
            let setup = mlp_setup(plan, job, prepared).map_err(|e| (*level, e))?;
            Ok(setup.map(|s| (*level, job, s)))
        })
        .collect::<Result<_, (usize, RunError)>>()?;
    let setups: Vec<(usize, &TrainingJob, MlpSetup)> = setups.into_iter().flatten().collect();
    if setups.is_empty() {
        return Ok(HashMap::new());
    }
    let jobs: Vec<BatchJob> = setups
        .iter()
        .map(|(_, job, s)| BatchJob {
            widths: &s.widths,
            features: &s.features,
            fit: &s.fit,
            validation: &s.validation,
            training: &s.training,
            seed: job.seed.0,
        })
        .collect();
    (progress.batch)(jobs.len(), &device.to_string());
    let t0 = Instant::now();
    let on_epoch = |k: usize, log: &EpochLog| (progress.epoch)(setups[k].1, log);
    let nets = train_batch(device, &jobs, &on_epoch).map_err(|e| (setups[0].0, RunError::from(e)))?;
    let seconds = t0.elapsed().as_secs_f64();
    (progress.done)(jobs.len(), seconds);
    let share = seconds / jobs.len() as f64;
    let name = device.record().unwrap_or_else(|| device.to_string());
    Ok(setups
        .iter()
        .zip(nets)
        .map(|((level, job, _), (net, epochs))| {
            ((*level, job.stem()), Trained { net, epochs, seconds: share, device: name.clone() })
        })
        .collect())
}
