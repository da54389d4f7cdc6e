//! One training cell end to end: the shared split, the model fitted on its
//! arm's fit windows with its seed, rollouts from the registered starts,
//! and that cell's per-cell rows. A cell is the unit a run schedules.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::cells::{write_cells, Cell};
use crate::data::Recording;
use crate::design::{Design, DesignFile, ModelKind};
use crate::model::baseline::{ConstantVelocity, Persistence};
use crate::model::features::{Action, State, EXOGENOUS, STATE};
use crate::model::{net, EpochLog, FeatureMap, Learned};
use crate::rollout::{self, Dynamics};
use crate::split::{Split, Window};
use crate::{Error, SplitOutcome};

/// Everything one cell produced.
#[derive(Debug, Clone, Serialize)]
pub struct CellOutcome {
    pub model: String,
    pub arm: String,
    pub seed: u64,
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
    #[serde(skip)]
    pub cells: Vec<Cell>,
    pub files: Vec<String>,
}

fn triples(recs: &[Recording], windows: &[Window]) -> Vec<(State, Action, State)> {
    windows
        .iter()
        .map(|w| {
            let r = &recs[w.recording];
            (r.state[w.t], r.action[w.t], r.state[w.t + 1])
        })
        .collect()
}

/// Horizons (s) at which this model is evaluated: every endpoint that
/// names it.
pub fn horizons_for(design: &Design, model: &str) -> Vec<f64> {
    let mut h: Vec<f64> = design
        .endpoints
        .iter()
        .filter(|e| e.models.iter().any(|m| m == model))
        .flat_map(|e| e.horizons.iter().map(|s| s.0))
        .collect();
    h.sort_by(f64::total_cmp);
    h.dedup();
    h
}

/// Mean standardized one-step squared error over the non-exogenous
/// components: how well `dynamics` predicts x_{t+1} from (x_t, u_t).
pub fn one_step_error(dynamics: &mut dyn Dynamics, features: &FeatureMap, windows: &[(State, Action, State)]) -> f64 {
    let states: Vec<State> = windows.iter().map(|w| w.0).collect();
    let actions: Vec<Action> = windows.iter().map(|w| w.1).collect();
    let next = dynamics.step(&states, &actions);
    let mut sum = 0.0;
    let mut n = 0usize;
    let (mut zp, mut zt) = ([0f32; STATE], [0f32; STATE]);
    for ((x, _, truth), pred) in windows.iter().zip(&next) {
        features.target(x, pred, &mut zp);
        features.target(x, truth, &mut zt);
        for k in (0..STATE).filter(|k| !EXOGENOUS.contains(k)) {
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

/// Runs one cell. `outcome` is the shared split; files go under `out`.
pub fn run_cell(
    file: &DesignFile,
    outcome: &SplitOutcome,
    model_name: &str,
    arm: &str,
    seed: u64,
    out: &Path,
    on_epoch: &mut dyn FnMut(&EpochLog),
) -> Result<CellOutcome, Error> {
    let design = &file.design;
    let model = design
        .models
        .iter()
        .find(|m| m.name == model_name)
        .ok_or_else(|| Error::Cell(format!("no model named `{model_name}` in the design")))?;
    if !design.arms.iter().any(|a| a.name == arm) {
        return Err(Error::Cell(format!("no arm named `{arm}` in the design")));
    }
    if !design.seeds.iter().any(|s| s.0 == seed) {
        return Err(Error::Cell(format!("seed {seed} is not one of the design's seeds")));
    }
    let split: &Split = &outcome.split;
    let recs = &outcome.recordings;
    let fit_windows = split.fit(arm).ok_or_else(|| Error::Cell(format!("arm `{arm}` has no fit set")))?;
    let fit_sha = outcome.manifests.sha256(&format!("fit_{arm}.csv")).to_string();
    let fit = triples(recs, fit_windows);
    let validation = triples(recs, &split.validation);
    let horizons = horizons_for(design, model_name);
    let rate = design.data.rate_hz;
    let steps = rollout::horizon_steps(&horizons, rate);
    let max_steps = steps.iter().copied().max().unwrap_or(0);
    let cap = design.endpoints.iter().map(|e| e.cap.0).find(|c| c.is_finite()).unwrap_or(2.0);
    let stem = format!("{model_name}__{arm}__{seed}");
    let mut files = Vec::new();
    let io = |p: &Path, e: std::io::Error| Error::Cell(format!("cannot write {}: {e}", p.display()));

    // The world standardizers of this arm: the yardstick for one-step errors,
    // whatever the model.
    let yardstick = FeatureMap::fit(crate::design::InputMap::World, &fit, &fit_sha);
    let mut one_step = Vec::new();
    let mut mean_fa_rmse = Vec::new();
    let baselines: Vec<(String, Box<dyn Dynamics>)> = vec![
        ("persistence".into(), Box::new(Persistence)),
        ("constant_velocity".into(), Box::new(ConstantVelocity { dt: 1.0 / rate })),
    ];
    let mut train_seconds = 0.0;
    let rollout_seconds;
    let (cells, epochs, best_val_loss) = match &model.kind {
        ModelKind::Mlp { widths, inputs } => {
            let features = FeatureMap::fit(*inputs, &fit, &fit_sha);
            // Invariant 6: standardizers fitted on this arm's own fit set.
            if features.fitted_on != fit_sha {
                return Err(Error::Cell(
                    "invariant 6 failed: standardizers were not fitted on this arm's fit set".into(),
                ));
            }
            let t0 = std::time::Instant::now();
            let (net, epochs) = net::train(
                widths,
                &features,
                &fit,
                &validation,
                design.training.as_ref().ok_or_else(|| Error::Cell("the design has no train block".into()))?,
                seed,
                on_epoch,
            )?;
            let models_dir = out.join("models");
            std::fs::create_dir_all(&models_dir).map_err(|e| io(&models_dir, e))?;
            let weights = models_dir.join(format!("{stem}.safetensors"));
            net.save(&weights)?;
            let meta = serde_json::json!({
                "model": model_name, "arm": arm, "seed": seed, "widths": widths,
                "design_sha256": file.sha256, "fit_manifest_sha256": fit_sha, "features": features,
            });
            let meta_path = models_dir.join(format!("{stem}.json"));
            crate::report::write_atomic(
                &meta_path,
                serde_json::to_string_pretty(&meta).unwrap_or_default().as_bytes(),
            )?;
            files.push(weights.display().to_string());
            files.push(meta_path.display().to_string());
            train_seconds = t0.elapsed().as_secs_f64();
            let best = epochs.iter().map(|e| e.val_loss).fold(f64::INFINITY, f64::min);
            let mut learned = Learned { net: &net, features: &features };
            one_step.push((model_name.to_string(), one_step_error(&mut learned, &yardstick, &validation)));
            let t1 = std::time::Instant::now();
            let traces = rollout::rollout(&mut learned, recs, &split.starts, max_steps, &steps);
            rollout_seconds = t1.elapsed().as_secs_f64();
            let cells = rollout::cells(model_name, arm, seed, split, &traces, &horizons, rate, cap);
            (cells, epochs, Some(best))
        }
        ModelKind::Persistence | ModelKind::ConstantVelocity => {
            let mut d: Box<dyn Dynamics> = if model.kind == ModelKind::Persistence {
                Box::new(Persistence)
            } else {
                Box::new(ConstantVelocity { dt: 1.0 / rate })
            };
            one_step.push((model_name.to_string(), one_step_error(d.as_mut(), &yardstick, &validation)));
            let t1 = std::time::Instant::now();
            let traces = rollout::rollout(d.as_mut(), recs, &split.starts, max_steps, &steps);
            rollout_seconds = t1.elapsed().as_secs_f64();
            (rollout::cells(model_name, arm, seed, split, &traces, &horizons, rate, cap), Vec::new(), None)
        }
    };
    for h in &horizons {
        mean_fa_rmse.push((model_name.to_string(), *h, mean_fa(&cells, *h)));
    }
    for (name, mut b) in baselines {
        one_step.push((name.clone(), one_step_error(b.as_mut(), &yardstick, &validation)));
        let traces = rollout::rollout(b.as_mut(), recs, &split.starts, max_steps, &steps);
        let bc = rollout::cells(&name, arm, seed, split, &traces, &horizons, rate, cap);
        for h in &horizons {
            mean_fa_rmse.push((name.clone(), *h, mean_fa(&bc, *h)));
        }
    }
    if !epochs.is_empty() {
        let curve: PathBuf = out.join("curves").join(format!("{stem}.csv"));
        std::fs::create_dir_all(curve.parent().unwrap_or(out)).map_err(|e| io(&curve, e))?;
        let mut text = String::from("epoch,lr,train_loss,val_loss,seconds\n");
        for e in &epochs {
            text.push_str(&format!("{},{},{},{},{}\n", e.epoch, e.lr, e.train_loss, e.val_loss, e.seconds));
        }
        crate::report::write_atomic(&curve, text.as_bytes())?;
        files.push(curve.display().to_string());
    }
    // The per-cell CSV is written last, atomically: its presence marks the
    // cell as finished for a resumed run.
    let cells_dir = out.join("cells");
    std::fs::create_dir_all(&cells_dir).map_err(|e| io(&cells_dir, e))?;
    let cells_path = cells_dir.join(format!("{stem}.csv"));
    let tmp = cells_dir.join(format!("{stem}.csv.tmp"));
    write_cells(&tmp, &cells)?;
    std::fs::rename(&tmp, &cells_path).map_err(|e| io(&cells_path, e))?;
    files.push(cells_path.display().to_string());
    Ok(CellOutcome {
        model: model_name.to_string(),
        arm: arm.to_string(),
        seed,
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
