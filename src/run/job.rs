//! One training job end to end: the shared split, the model fitted on its
//! arm's fit windows with its seed, rollouts from the registered starts,
//! and that job's per-cell rows. A job is the unit a run schedules.

use std::path::Path;

use serde::Serialize;

use super::record::JobRecord;
use super::RunError;
use crate::cells::{write_cells_atomic, Cell};
use crate::data::Recording;
use crate::design::Training;
use crate::design::{ActionScaling, InputMap, ModelKind, TargetKind};
use crate::io::{create_dir_all, f64_text, write_atomic};
use crate::model::baseline::{ConstantVelocity, Persistence};
use crate::model::{linear, net, Action, Dynamics, Engine, EpochLog, FeatureMap, Learned, Net, State};
use crate::plan::{Plan, TrainingJob};
use crate::rollout;
use crate::split::{JobManifests, Prepared, Window};

/// Everything one job produced.
#[derive(Debug, Clone, Serialize)]
pub struct JobOutcome {
    /// The model's name.
    pub model: String,
    /// The arm it was fitted on.
    pub arm: String,
    /// The training seed.
    pub seed: u64,
    /// Every epoch's losses (empty for parameter-free models).
    pub epochs: Vec<EpochLog>,
    /// Best (restored) validation loss; None for parameter-free models.
    pub best_val_loss: Option<f64>,
    /// One-step validation error of this model and the baselines, in this
    /// model's standardized target units over the 10 predicted components.
    pub one_step: Vec<(String, f64)>,
    /// Mean over evaluation recordings of the failure-aware position RMSE at
    /// each horizon, for this model and the baselines.
    pub mean_fa_rmse: Vec<(String, f64, f64)>,
    /// Wall seconds spent fitting (0 for parameter-free models).
    pub train_seconds: f64,
    /// Wall seconds of this model's batched rollouts from every start.
    pub rollout_seconds: f64,
    /// The job's per-cell rows.
    #[serde(skip)]
    pub cells: Vec<Cell>,
    /// Files written, in order, relative to the run directory.
    pub files: Vec<String>,
}

/// The (x_t, u_t, x_{t+1}) of each window.
pub(crate) fn triples(recs: &[Recording], windows: &[Window]) -> Vec<(State, Action, State)> {
    windows
        .iter()
        .map(|w| {
            let r = &recs[w.recording];
            (r.state[w.t].clone(), r.action[w.t].clone(), r.state[w.t + 1].clone())
        })
        .collect()
}

/// Mean standardized one-step squared error over the non-exogenous
/// components: how well `dynamics` predicts x_{t+1} from (x_t, u_t).
pub fn one_step_error(dynamics: &mut dyn Dynamics, features: &FeatureMap, windows: &[(State, Action, State)]) -> f64 {
    let states: Vec<State> = windows.iter().map(|w| w.0.clone()).collect();
    let actions: Vec<Action> = windows.iter().map(|w| w.1.clone()).collect();
    let next = dynamics.step(&states, &actions);
    let mut sum = 0.0;
    let mut n = 0usize;
    let slots = features.slots;
    let (mut zp, mut zt) = (vec![0f32; slots.state], vec![0f32; slots.state]);
    for ((x, _, truth), pred) in windows.iter().zip(&next) {
        features.target(x, pred, &mut zp);
        features.target(x, truth, &mut zt);
        for k in 0..slots.predicted {
            sum += f64::from(zp[k] - zt[k]).powi(2);
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

fn mean_fa(cells: &[Cell], h: f64) -> f64 {
    let v: Vec<f64> = cells.iter().filter(|c| c.horizon_s == h).map(|c| c.fa_position_rmse_m).collect();
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// What every model of a job is scored with: the fit and validation
/// windows, the rollout steps, and the world standardizers of the arm as
/// the yardstick for one-step errors.
struct Bench<'a> {
    plan: &'a Plan,
    job: &'a TrainingJob,
    prepared: &'a Prepared,
    fit: Vec<(State, Action, State)>,
    fit_sha: String,
    validation: Vec<(State, Action, State)>,
    steps: Vec<usize>,
    yardstick: FeatureMap,
}

impl Bench<'_> {
    /// The manifests this job reads, by hash.
    fn manifests(&self) -> JobManifests {
        job_manifests(self.prepared, self.job)
    }

    /// Rolls `d` out from every start and scores it: (one-step validation
    /// error, per-cell rows, seconds spent rolling out).
    fn score(&self, name: &str, d: &mut dyn Dynamics) -> (f64, Vec<Cell>, f64) {
        let one_step = one_step_error(d, &self.yardstick, &self.validation);
        let max_steps = self.steps.iter().copied().max().unwrap_or(0);
        let t0 = std::time::Instant::now();
        let p = self.prepared;
        let traces = rollout::rollout(d, &p.recordings, &p.split.starts, max_steps, &self.steps);
        let seconds = t0.elapsed().as_secs_f64();
        let (job, plan) = (self.job, self.plan);
        let cells =
            rollout::cells(name, &job.arm, job.seed.0, &p.split, &traces, &job.horizons_s, plan.rate_hz, plan.cap.0);
        (one_step, cells, seconds)
    }
}

/// Runs one job of `plan` on the prepared split; files go under `out`.
/// Its record (`jobs/STEM.json`: manifests, standardizers, seed, and the
/// SHA-256 of every file written) is written last, atomically: its
/// presence marks the job as finished for a resumed run.
pub fn run_job(
    design_sha256: &str,
    plan: &Plan,
    job: &TrainingJob,
    prepared: &Prepared,
    out: &Path,
    on_epoch: &mut dyn FnMut(&EpochLog),
) -> Result<JobOutcome, RunError> {
    run_job_with(Engine::Fused, design_sha256, plan, job, prepared, out, on_epoch)
}

/// A job's network trained before the job ran, by the batched trainer on
/// a GPU ([`crate::model::train_batch`]), for [`run_job_given`].
pub struct Trained {
    /// The best (restored) network.
    pub net: Net,
    /// Its epochs.
    pub epochs: Vec<EpochLog>,
    /// Its share of the batch's wall seconds.
    pub seconds: f64,
    /// The device it trained on, as the job record gives it.
    pub device: String,
}

/// What an MLP job trains on, exactly as [`run_job`] trains it.
pub struct MlpSetup {
    /// Hidden widths.
    pub widths: Vec<usize>,
    /// The standardizers, fitted on the fit windows.
    pub features: FeatureMap,
    /// The arm's fit windows.
    pub fit: Vec<(State, Action, State)>,
    /// The shared validation windows.
    pub validation: Vec<(State, Action, State)>,
    /// The protocol, with the model's `restore final`.
    pub training: Training,
}

/// The [`MlpSetup`] of `job`; `None` for a model that is not an MLP.
pub fn mlp_setup(plan: &Plan, job: &TrainingJob, prepared: &Prepared) -> Result<Option<MlpSetup>, RunError> {
    let ModelKind::Mlp { widths, inputs, actions, restore_final } = &job.kind else { return Ok(None) };
    let bench = bench(plan, job, prepared)?;
    let (training, features) = mlp_protocol(&bench, *inputs, *actions, *restore_final)?;
    let Bench { fit, validation, .. } = bench;
    Ok(Some(MlpSetup { widths: widths.clone(), features, fit, validation, training }))
}

/// The protocol and standardizers of an MLP job: the design's training with
/// the model's `restore final`, standardizers fitted on its fit windows.
fn mlp_protocol(
    bench: &Bench,
    inputs: InputMap,
    actions: ActionScaling,
    restore_final: bool,
) -> Result<(Training, FeatureMap), RunError> {
    // Invariant 6 is checked after training on what the job record
    // says these were fitted on (run/trained_invariants.rs).
    let mut training = bench.plan.training.clone().ok_or(RunError::NoTraining)?;
    training.restore_final = restore_final;
    let features = FeatureMap::fit(bench.plan.slots, inputs, actions, training.target, &bench.fit, &bench.fit_sha);
    Ok((training, features))
}

/// As [`run_job`], training and rolling out with `engine` (the dfdx
/// reference gives bit-identical files, about twice as slowly).
pub fn run_job_with(
    engine: Engine,
    design_sha256: &str,
    plan: &Plan,
    job: &TrainingJob,
    prepared: &Prepared,
    out: &Path,
    on_epoch: &mut dyn FnMut(&EpochLog),
) -> Result<JobOutcome, RunError> {
    run_job_given(engine, design_sha256, plan, job, prepared, out, None, on_epoch)
}

/// As [`run_job_with`], with the job's network already trained when
/// `given` holds it (the batched trainer's), which is saved and scored as
/// a network trained here would be.
#[allow(clippy::too_many_arguments)]
pub fn run_job_given(
    engine: Engine,
    design_sha256: &str,
    plan: &Plan,
    job: &TrainingJob,
    prepared: &Prepared,
    out: &Path,
    given: Option<Trained>,
    on_epoch: &mut dyn FnMut(&EpochLog),
) -> Result<JobOutcome, RunError> {
    let bench = bench(plan, job, prepared)?;
    let stem = job.stem();
    let device = given.as_ref().map(|t| t.device.clone());
    let fitted = match &job.kind {
        ModelKind::Mlp { widths, inputs, actions, restore_final } => {
            let mlp = (widths.as_slice(), *inputs, *actions, *restore_final);
            train_mlp(&bench, (engine, given), design_sha256, out, on_epoch, mlp)?
        }
        ModelKind::Linear { inputs, actions, ridge } => {
            fit_linear(&bench, design_sha256, out, (*inputs, *actions, *ridge))?
        }
        ModelKind::External { .. } => {
            return Err(RunError::ExternalModels { models: job.model.clone() });
        }
        ModelKind::Persistence | ModelKind::ConstantVelocity => {
            let mut d = baseline(&job.kind, plan.rate_hz);
            let (e, cells, secs) = bench.score(&job.model, d.as_mut());
            Fitted::parameter_free(e, cells, secs)
        }
    };
    let Fitted { cells, epochs, best_val_loss, train_seconds, rollout_seconds, one_step, standardizers, mut files } =
        fitted;
    let mut one_step = vec![(job.model.clone(), one_step)];
    let mut mean_fa_rmse: Vec<(String, f64, f64)> =
        job.horizons_s.iter().map(|h| (job.model.clone(), *h, mean_fa(&cells, *h))).collect();
    score_yardsticks(&bench, &mut one_step, &mut mean_fa_rmse);
    if !epochs.is_empty() {
        files.push(write_curve(out, &stem, &epochs)?);
    }
    let cells_name = format!("cells/{stem}.csv");
    create_dir_all(&out.join("cells"))?;
    write_cells_atomic(&out.join(&cells_name), &cells)?;
    files.push(cells_name);
    let record = JobRecord {
        model: job.model.clone(),
        arm: job.arm.clone(),
        seed: job.seed.0,
        design_sha256: design_sha256.to_string(),
        manifests: bench.manifests(),
        standardizers,
        files: JobRecord::hash_files(out, &files)?,
        crossaudit: crate::io::BUILD.to_string(),
        non_finite_starts: None,
        key: None,
        reused_from: None,
        device,
    };
    record.write(out, job)?;
    Ok(JobOutcome {
        model: job.model.clone(),
        arm: job.arm.clone(),
        seed: job.seed.0,
        epochs,
        best_val_loss,
        one_step,
        mean_fa_rmse,
        train_seconds,
        rollout_seconds,
        cells,
        files,
    })
}

/// What fitting and scoring a job's own model gave.
struct Fitted {
    /// Its per-cell rows.
    cells: Vec<Cell>,
    /// Every epoch's losses (empty unless trained by epochs).
    epochs: Vec<EpochLog>,
    best_val_loss: Option<f64>,
    train_seconds: f64,
    rollout_seconds: f64,
    /// Its one-step validation error.
    one_step: f64,
    /// The standardizers it was fitted with, for the job record.
    standardizers: Option<FeatureMap>,
    /// The model files written, relative to the run directory.
    files: Vec<String>,
}

impl Fitted {
    /// A model with nothing to fit (a baseline): scored only.
    fn parameter_free(one_step: f64, cells: Vec<Cell>, rollout_seconds: f64) -> Fitted {
        Fitted {
            cells,
            epochs: Vec::new(),
            best_val_loss: None,
            train_seconds: 0.0,
            rollout_seconds,
            one_step,
            standardizers: None,
            files: Vec::new(),
        }
    }
}

/// An MLP (`widths`, input map, action scaling, `restore final`) trained
/// with `engine` on the bench's fit windows (or given, trained already),
/// saved under `models/`, and scored.
fn train_mlp(
    bench: &Bench,
    (engine, given): (Engine, Option<Trained>),
    design_sha256: &str,
    out: &Path,
    on_epoch: &mut dyn FnMut(&EpochLog),
    (widths, inputs, actions, restore_final): (&[usize], InputMap, ActionScaling, bool),
) -> Result<Fitted, RunError> {
    let job = bench.job;
    let (training, features) = mlp_protocol(bench, inputs, actions, restore_final)?;
    let t0 = std::time::Instant::now();
    let (net, epochs, before) = match given {
        Some(t) => (t.net, t.epochs, t.seconds),
        None => {
            let (v, f) = (&bench.validation, &bench.fit);
            let (net, epochs) = net::train_with(engine, widths, &features, f, v, &training, job.seed.0, on_epoch)?;
            (net, epochs, 0.0)
        }
    };
    let meta = serde_json::json!({
        "model": job.model, "arm": job.arm, "seed": job.seed.0, "widths": widths,
        "design_sha256": design_sha256, "fit_manifest_sha256": bench.fit_sha, "features": features,
    });
    let files = save_model(out, &job.stem(), &net, &meta)?.to_vec();
    let train_seconds = before + t0.elapsed().as_secs_f64();
    let best = epochs.iter().map(|e| e.val_loss).fold(f64::INFINITY, f64::min);
    let (e, cells, secs) = bench.score(&job.model, &mut Learned::with(engine, &net, &features));
    Ok(Fitted {
        cells,
        epochs,
        best_val_loss: Some(best),
        train_seconds,
        rollout_seconds: secs,
        one_step: e,
        standardizers: Some(features),
        files,
    })
}

/// A linear model (input map, action scaling, ridge penalty) fitted on
/// the bench's fit windows, saved as `models/STEM.json`, and scored.
fn fit_linear(
    bench: &Bench,
    design_sha256: &str,
    out: &Path,
    (inputs, actions, ridge): (InputMap, ActionScaling, Option<f64>),
) -> Result<Fitted, RunError> {
    let job = bench.job;
    let training = bench.plan.training.as_ref().ok_or(RunError::NoTraining)?;
    let features = FeatureMap::fit(bench.plan.slots, inputs, actions, training.target, &bench.fit, &bench.fit_sha);
    let t0 = std::time::Instant::now();
    let mut model = linear::fit(features.clone(), &bench.fit, &bench.validation, ridge)
        .map_err(|source| RunError::Linear { model: job.model.clone(), source })?;
    let meta = serde_json::json!({
        "model": job.model, "arm": job.arm, "seed": job.seed.0, "kind": "linear",
        "design_sha256": design_sha256, "fit_manifest_sha256": bench.fit_sha, "linear": &model,
    });
    create_dir_all(&out.join("models"))?;
    let name = format!("models/{}.json", job.stem());
    write_atomic(&out.join(&name), serde_json::to_string_pretty(&meta).unwrap_or_default().as_bytes())?;
    let train_seconds = t0.elapsed().as_secs_f64();
    let best = model.validation.iter().find(|(l, _)| *l == model.lambda).map(|(_, v)| *v);
    let (e, cells, secs) = bench.score(&job.model, &mut model);
    Ok(Fitted {
        cells,
        epochs: Vec::new(),
        best_val_loss: best,
        train_seconds,
        rollout_seconds: secs,
        one_step: e,
        standardizers: Some(features),
        files: vec![name],
    })
}

/// The yardsticks' one-step errors and mean failure-aware RMSEs, after the
/// model's; constant velocity only where the data declare a velocity.
fn score_yardsticks(bench: &Bench, one_step: &mut Vec<(String, f64)>, mean_fa_rmse: &mut Vec<(String, f64, f64)>) {
    let (plan, job) = (bench.plan, bench.job);
    let yardsticks = [("persistence", ModelKind::Persistence), ("constant_velocity", ModelKind::ConstantVelocity)];
    for (name, kind) in yardsticks.into_iter().filter(|(_, k)| plan.slots.velocity || *k != ModelKind::ConstantVelocity)
    {
        let (e, bc, _) = bench.score(name, baseline(&kind, plan.rate_hz).as_mut());
        one_step.push((name.to_string(), e));
        mean_fa_rmse.extend(job.horizons_s.iter().map(|h| (name.to_string(), *h, mean_fa(&bc, *h))));
    }
}

/// The manifests `job` reads, by hash: what its record states and the
/// trained invariants check (the built-in and the external jobs alike).
pub(crate) fn job_manifests(prepared: &Prepared, job: &TrainingJob) -> JobManifests {
    let m = &prepared.manifests;
    JobManifests {
        model: job.model.clone(),
        arm: job.arm.clone(),
        seed: job.seed,
        evaluation_sha256: m.sha256("evaluation_recordings.csv").to_string(),
        starts_sha256: m.sha256("evaluation_starts.csv").to_string(),
        validation_sha256: m.sha256("validation_windows.csv").to_string(),
        fit_sha256: m.sha256(&format!("fit_{}.csv", job.arm)).to_string(),
    }
}

fn bench<'a>(plan: &'a Plan, job: &'a TrainingJob, prepared: &'a Prepared) -> Result<Bench<'a>, RunError> {
    let split = &prepared.split;
    let recs = &prepared.recordings;
    let fit_windows = split.fit(&job.arm).ok_or_else(|| RunError::NoFitSet { arm: job.arm.clone() })?;
    let fit_sha = prepared.manifests.sha256(&format!("fit_{}.csv", job.arm)).to_string();
    let fit = triples(recs, fit_windows);
    // The world standardizers of this arm: the yardstick for one-step
    // errors, whatever the model.
    // (Standardized actions and increments: the first wave's scale, kept so
    // that one-step errors stay comparable across parameterizations.)
    let yardstick = FeatureMap::fit(
        plan.slots,
        InputMap::World,
        ActionScaling::Standardized,
        TargetKind::Standardized,
        &fit,
        &fit_sha,
    );
    Ok(Bench {
        plan,
        job,
        prepared,
        validation: triples(recs, &split.validation),
        fit,
        fit_sha,
        steps: rollout::horizon_steps(&job.horizons_s, plan.rate_hz),
        yardstick,
    })
}

fn baseline(kind: &ModelKind, rate_hz: f64) -> Box<dyn Dynamics> {
    if *kind == ModelKind::Persistence {
        Box::new(Persistence)
    } else {
        Box::new(ConstantVelocity { dt: 1.0 / rate_hz })
    }
}

/// `models/STEM.safetensors` and `models/STEM.json` (what produced them).
fn save_model(out: &Path, stem: &str, net: &net::Net, meta: &serde_json::Value) -> Result<[String; 2], RunError> {
    create_dir_all(&out.join("models"))?;
    let (weights, meta_name) = (format!("models/{stem}.safetensors"), format!("models/{stem}.json"));
    net.save(&out.join(&weights))?;
    // No final newline: the form these files have always had.
    write_atomic(&out.join(&meta_name), serde_json::to_string_pretty(meta).unwrap_or_default().as_bytes())?;
    Ok([weights, meta_name])
}

/// One row of `curves/STEM.csv`.
#[derive(Serialize)]
struct CurveRow {
    epoch: usize,
    #[serde(serialize_with = "f64_text")]
    lr: f64,
    #[serde(serialize_with = "f64_text")]
    train_loss: f64,
    #[serde(serialize_with = "f64_text")]
    val_loss: f64,
    #[serde(serialize_with = "f64_text")]
    seconds: f64,
}

/// `curves/STEM.csv`: the losses of every epoch.
fn write_curve(out: &Path, stem: &str, epochs: &[EpochLog]) -> Result<String, RunError> {
    let name = format!("curves/{stem}.csv");
    let path = out.join(&name);
    create_dir_all(path.parent().unwrap_or(out))?;
    let mut w = csv::Writer::from_writer(Vec::new());
    for e in epochs {
        let row =
            CurveRow { epoch: e.epoch, lr: e.lr, train_loss: e.train_loss, val_loss: e.val_loss, seconds: e.seconds };
        w.serialize(row).map_err(|e| RunError::Csv { path: path.display().to_string(), source: e })?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| RunError::Csv { path: path.display().to_string(), source: e.into_error().into() })?;
    write_atomic(&path, &bytes)?;
    Ok(name)
}
