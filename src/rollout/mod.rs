//! Stage: open-loop rollouts from the registered starts, and the
//! per-recording metrics that become rows of the per-cell CSV.
//!
//! All starts of an arm roll together: one batched model call per step
//! (1,300 starts x 200 steps is 200 calls, not 260,000).

pub mod metrics;

use crate::cells::Cell;
use crate::data::{norm4, Recording};
use crate::model::{Action, Dynamics, Slots, State};
use crate::split::{Split, Window};

pub use metrics::{attitude_error_deg, failure_aware, HorizonMetrics, StartOutcome};

/// The unit quaternion (w, x, y, z) at the layout's quaternion slots
/// (NanoBench: state[6..10]) returned to unit length after every step; a
/// layout without an attitude is left as is. A zero or non-finite
/// quaternion is left as is, and the non-finite state is caught by the
/// divergence check.
pub fn renormalize(x: &mut State, slots: &Slots) {
    let Some(q) = slots.quaternion_slots() else { return };
    let n = norm4(&x[q.clone()]);
    if n.is_finite() && n > 0.0 {
        x[q].iter_mut().for_each(|c| *c /= n);
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
    /// The recording's layout: where the velocity and quaternion are, if
    /// declared.
    pub slots: Slots,
}

/// Rolls every start open loop for `steps` steps: measured future actions,
/// the exogenous state (NanoBench: reference and battery; see
/// `Recording::predicted`) overwritten with its measured next values,
/// quaternion renormalised each step.
pub fn rollout(
    dynamics: &mut dyn Dynamics,
    recordings: &[Recording],
    starts: &[Window],
    steps: usize,
    horizon_steps: &[usize],
) -> Vec<Trace> {
    trajectories(dynamics, recordings, starts, steps, &mut |_, _| {}, horizon_steps)
}

/// As [`rollout`], handing every step's states (after the exogenous
/// overwrite and renormalisation: what the next step is fed) to `each`
/// with the step number: the trajectories an external model's
/// predictions replace (see [`replay`]).
pub fn trajectories(
    dynamics: &mut dyn Dynamics,
    recordings: &[Recording],
    starts: &[Window],
    steps: usize,
    each: &mut dyn FnMut(usize, &[State]),
    horizon_steps: &[usize],
) -> Vec<Trace> {
    let mut states: Vec<State> = starts.iter().map(|s| recordings[s.recording].state[s.t].clone()).collect();
    let mut traces = new_traces(recordings, starts, steps);
    for k in 1..=steps {
        let actions: Vec<Action> = starts.iter().map(|s| recordings[s.recording].action[s.t + k - 1].clone()).collect();
        let mut next = dynamics.step(&states, &actions);
        for ((n, s), tr) in next.iter_mut().zip(starts).zip(traces.iter_mut()) {
            let rec = &recordings[s.recording];
            let truth = &rec.state[s.t + k];
            n[rec.slots.predicted..].copy_from_slice(&truth[rec.slots.predicted..]);
            renormalize(n, &rec.slots);
            score_step(tr, k, n, truth, horizon_steps);
        }
        each(k, &next);
        states = next;
    }
    traces
}

fn new_traces(recordings: &[Recording], starts: &[Window], steps: usize) -> Vec<Trace> {
    starts
        .iter()
        .map(|&s| Trace {
            start: s,
            position_error: Vec::with_capacity(steps),
            at: Vec::new(),
            slots: recordings[s.recording].slots,
        })
        .collect()
}

/// One step of one start: its position error (infinite when not finite)
/// and, at a horizon step, the predicted and measured states.
fn score_step(tr: &mut Trace, k: usize, n: &State, truth: &State, horizon_steps: &[usize]) {
    let e = ((n[0] - truth[0]).powi(2) + (n[1] - truth[1]).powi(2) + (n[2] - truth[2]).powi(2)).sqrt();
    tr.position_error.push(if e.is_finite() { e } else { f64::INFINITY });
    if horizon_steps.contains(&k) {
        tr.at.push((k, n.clone(), truth.clone()));
    }
}

/// Traces of trajectories predicted elsewhere (an external model's
/// rollouts): `predicted(i, k)` is start i's predicted state at step k
/// (1..=steps). Scored exactly as [`rollout`] scores its own states: the
/// exogenous components are overwritten with their measured values, and
/// the quaternion is returned to unit length unless it is within 1e-12 of
/// it already (so a built-in model's own states, already renormalised,
/// score bit for bit as they did). A non-finite state is divergent from
/// that step on, as a diverged built-in rollout is.
pub fn replay(
    predicted: &dyn Fn(usize, usize) -> State,
    recordings: &[Recording],
    starts: &[Window],
    steps: usize,
    horizon_steps: &[usize],
) -> Vec<Trace> {
    let mut traces = new_traces(recordings, starts, steps);
    for (i, (s, tr)) in starts.iter().zip(traces.iter_mut()).enumerate() {
        for k in 1..=steps {
            let rec = &recordings[s.recording];
            let truth = &rec.state[s.t + k];
            let mut n = predicted(i, k);
            n[rec.slots.predicted..].copy_from_slice(&truth[rec.slots.predicted..]);
            if rec.slots.quaternion_slots().is_some_and(|q| (norm4(&n[q]) - 1.0).abs() > 1e-12) {
                renormalize(&mut n, &rec.slots);
            }
            score_step(tr, k, &n, truth, horizon_steps);
        }
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
                model: model.into(),
                arm: arm.into(),
                seed,
                recording: info.name.as_str().into(),
                trajectory: info.trajectory.as_str().into(),
                speed: info.speed.as_str().into(),
                horizon_s: *h,
                // At most `limits::STARTS` (100,000) starts: a u32 holds them.
                n_starts: outcomes.len() as u32,
                n_divergent: m.n_divergent as u32,
                fa_position_rmse_m: m.fa_position_rmse,
                conditional_position_rmse_m: m.conditional_position_rmse,
                divergence_rate: m.n_divergent as f64 / outcomes.len().max(1) as f64,
                velocity_rmse_mps: m.velocity_rmse,
                attitude_rmse_deg: m.attitude_rmse_deg,
                origin: crate::cells::Origin::default(),
            });
        }
    }
    out
}
