//! Stage: open-loop rollouts from the registered starts, and the
//! per-recording metrics that become rows of the per-cell CSV.
//!
//! All starts of an arm roll together: one batched model call per step
//! (1,300 starts x 200 steps is 200 calls, not 260,000).

pub mod metrics;

use crate::cells::Cell;
use crate::data::Recording;
use crate::model::{Action, Dynamics, State};
use crate::split::{Split, Window};

pub use metrics::{attitude_error_deg, failure_aware, HorizonMetrics, StartOutcome};

/// Unit quaternion (w, x, y, z) at state[6..10]; returned to unit length
/// after every step. A zero or non-finite quaternion is left as is, and
/// the non-finite state is caught by the divergence check.
pub fn renormalize(x: &mut State) {
    let n = (x[6] * x[6] + x[7] * x[7] + x[8] * x[8] + x[9] * x[9]).sqrt();
    if n.is_finite() && n > 0.0 {
        x[6..10].iter_mut().for_each(|c| *c /= n);
    }
}

/// Per start: position error at every step 1..=steps, and the predicted and
/// measured states at each requested horizon step.
#[derive(Debug, Clone)]
pub struct Trace {
    /// The registered start.
    pub start: Window,
    /// |p_pred - p_true| at steps 1..=steps (index k-1).
    pub position_error: Vec<f64>,
    /// (step, predicted, measured) at each horizon step requested.
    pub at: Vec<(usize, State, State)>,
}

/// Rolls every start open loop for `steps` steps: measured future actions,
/// reference and battery overwritten with their measured next values,
/// quaternion renormalised each step.
pub fn rollout(
    dynamics: &mut dyn Dynamics,
    recordings: &[Recording],
    starts: &[Window],
    steps: usize,
    horizon_steps: &[usize],
) -> Vec<Trace> {
    let mut states: Vec<State> = starts.iter().map(|s| recordings[s.recording].state[s.t]).collect();
    let mut traces: Vec<Trace> =
        starts.iter().map(|&s| Trace { start: s, position_error: Vec::with_capacity(steps), at: Vec::new() }).collect();
    for k in 1..=steps {
        let actions: Vec<Action> = starts.iter().map(|s| recordings[s.recording].action[s.t + k - 1]).collect();
        let mut next = dynamics.step(&states, &actions);
        for ((n, s), tr) in next.iter_mut().zip(starts).zip(traces.iter_mut()) {
            let truth = &recordings[s.recording].state[s.t + k];
            n[10..14].copy_from_slice(&truth[10..14]);
            renormalize(n);
            let e = ((n[0] - truth[0]).powi(2) + (n[1] - truth[1]).powi(2) + (n[2] - truth[2]).powi(2)).sqrt();
            tr.position_error.push(if e.is_finite() { e } else { f64::INFINITY });
            if horizon_steps.contains(&k) {
                tr.at.push((k, *n, *truth));
            }
        }
        states = next;
    }
    traces
}

/// Horizons in seconds -> steps at the data's rate.
pub fn horizon_steps(horizons_s: &[f64], rate_hz: f64) -> Vec<usize> {
    horizons_s.iter().map(|h| (h * rate_hz).round() as usize).collect()
}

/// Per-cell rows for one (model, arm, seed): metrics per evaluation
/// recording and horizon.
#[allow(clippy::too_many_arguments)] // one per CSV key column; a struct would only rename them
pub fn cells(
    model: &str,
    arm: &str,
    seed: u64,
    split: &Split,
    traces: &[Trace],
    horizons_s: &[f64],
    rate_hz: f64,
    cap_m: f64,
) -> Vec<Cell> {
    let steps = horizon_steps(horizons_s, rate_hz);
    let mut out = Vec::new();
    for &r in &split.evaluation {
        let info = &split.recordings[r];
        let mine: Vec<&Trace> = traces.iter().filter(|t| t.start.recording == r).collect();
        for (h, &k) in horizons_s.iter().zip(&steps) {
            let outcomes: Vec<StartOutcome> = mine.iter().map(|t| StartOutcome::of(t, k, cap_m)).collect();
            let m = failure_aware(&outcomes, cap_m);
            out.push(Cell {
                split: None,
                dose: None,
                model: model.to_string(),
                arm: arm.to_string(),
                seed,
                recording: info.name.clone(),
                trajectory: info.trajectory.clone(),
                speed: info.speed.clone(),
                horizon_s: *h,
                n_starts: outcomes.len() as u64,
                n_divergent: m.n_divergent as u64,
                fa_position_rmse_m: m.fa_position_rmse,
                conditional_position_rmse_m: m.conditional_position_rmse,
                divergence_rate: m.n_divergent as f64 / outcomes.len().max(1) as f64,
                velocity_rmse_mps: m.velocity_rmse,
                attitude_rmse_deg: m.attitude_rmse_deg,
                line: 0,
            });
        }
    }
    out
}
