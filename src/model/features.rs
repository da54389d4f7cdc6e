//! The state layout, the two input maps and the prediction target.
//!
//! State layout ([`Slots`]; NanoBench's task-2 order): p = `x[0..3]`, v =
//! `x[3..6]`, q = `x[6..10]` (w, x, y, z) (velocity and attitude when the
//! data declare them: without a velocity q moves to `x[3..7]`), then any
//! further predicted state (body rates, other declared columns); then the
//! exogenous slots:
//! r (position setpoint) and any extra measured columns (NanoBench: r =
//! `x[10..13]`, battery b = `x[13]`). Action u: the declared commands in
//! [0, 1] (NanoBench: 4 motor commands).
//!
//! - world: [S(x), u], S the state standardizer (18 inputs for NanoBench);
//! - relative: [T(0_3, v, q, .., r - p, ..), u], T its own standardizer.
//!   Absolute position never enters, so a joint translation of position and
//!   reference leaves the inputs unchanged.
//!
//! u enters raw, in [0, 1], as in the paper (`actions raw`); with `actions
//! standardized` it goes through the input standardizer as well.
//!
//! Target (`target state_scaled`, the paper's): dz = S(x_{t+1}) - S(x_t) =
//! (x_{t+1} - x_t) / sd_x per dimension, no centring, no second
//! standardizer; the rollout inverts it as x_{t+1} = x_t + sd_x dz. With
//! `target standardized` the increment goes through its own mean and SD.
//! Either way the exogenous components of the target are zero: the model
//! never predicts what the rollout overwrites with measured values.

use serde::{Deserialize, Serialize};

use super::Standardizer;
pub use crate::design::Slots;
use crate::design::{ActionScaling, InputMap, TargetKind};

/// NanoBench's state dimensions: position, velocity, quaternion, reference, battery.
pub const STATE: usize = 14;
/// NanoBench's action dimensions: the four motor commands in [0, 1].
pub const ACTION: usize = 4;
/// NanoBench's network input dimensions: state and action.
pub const INPUT: usize = STATE + ACTION;
/// NanoBench's exogenous state components: reference (10..13) and battery (13).
pub const EXOGENOUS: std::ops::Range<usize> = 10..14;

/// One state x_t: [`Slots::state`] values.
pub type State = Vec<f64>;
/// One action u_t: [`Slots::action`] values in [0, 1].
pub type Action = Vec<f64>;

/// Writes the unstandardized network input of one (state, action) into
/// `out` ([`Slots::input`] values).
pub fn raw_input_into(slots: &Slots, map: InputMap, x: &[f64], u: &[f64], out: &mut [f64]) {
    let s = slots.state;
    match map {
        InputMap::World => out[..s].copy_from_slice(&x[..s]),
        InputMap::Relative => {
            // Absolute position is not an input.
            out[..3].fill(0.0);
            out[3..s].copy_from_slice(&x[3..s]);
            if slots.reference {
                let r = slots.predicted;
                for k in 0..3 {
                    out[r + k] = x[r + k] - x[k];
                }
            }
        }
    }
    out[s..s + slots.action].copy_from_slice(&u[..slots.action]);
}

/// Unstandardized network input of one (state, action).
pub fn raw_input(slots: &Slots, map: InputMap, x: &[f64], u: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; slots.input()];
    raw_input_into(slots, map, x, u, &mut out);
    out
}

/// Writes the unstandardized target into `out` ([`Slots::state`] values):
/// the increment, exogenous components zeroed.
pub fn raw_target_into(slots: &Slots, x: &[f64], next: &[f64], out: &mut [f64]) {
    for ((o, n), x) in out.iter_mut().zip(next).zip(x) {
        *o = n - x;
    }
    out[slots.exogenous()].fill(0.0);
}

/// Unstandardized target: the increment, exogenous components zeroed.
pub fn raw_target(slots: &Slots, x: &[f64], next: &[f64]) -> State {
    let mut d = vec![0.0; slots.state];
    raw_target_into(slots, x, next, &mut d);
    d
}

/// Room for the unstandardized values of one row on the stack: the
/// standardizers run for every window of every batch and every rollout
/// step, so a row of up to this many values allocates nothing.
const STACK_ROW: usize = 64;

/// Runs `f` on a zeroed buffer of `n` values: on the stack when it fits.
fn with_row<R>(n: usize, f: impl FnOnce(&mut [f64]) -> R) -> R {
    if n <= STACK_ROW {
        f(&mut [0.0; STACK_ROW][..n])
    } else {
        f(&mut vec![0.0; n])
    }
}

/// Standardizers of one fitted model, fitted on its own arm's fit windows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FeatureMap {
    /// World or relative inputs.
    pub map: InputMap,
    /// How the actions enter (raw: the last action dimensions are the identity).
    pub actions: ActionScaling,
    /// What the network predicts.
    pub target_kind: TargetKind,
    /// On the inputs: S on the state for world, T for relative; the
    /// identity on u when actions are raw.
    pub input: Standardizer,
    /// On the state increment: mean 0 and S's SDs for the state-scaled
    /// target, the increment's own mean and SD otherwise.
    pub target: Standardizer,
    /// SHA-256 of the fit manifest these were fitted on (invariant 6).
    pub fitted_on: String,
    /// The state and action layout (written only when it is not NanoBench's).
    #[serde(default, skip_serializing_if = "Slots::is_nanobench")]
    pub slots: Slots,
}

impl FeatureMap {
    /// Fits the standardizers on (x_t, u_t, x_{t+1}) windows.
    pub fn fit(
        slots: Slots,
        map: InputMap,
        actions: ActionScaling,
        target_kind: TargetKind,
        windows: &[(State, Action, State)],
        fitted_on: &str,
    ) -> FeatureMap {
        let (state, input_dim) = (slots.state, slots.input());
        let inputs: Vec<Vec<f64>> = windows.iter().map(|(x, u, _)| raw_input(&slots, map, x, u)).collect();
        let mut input = Standardizer::fit(inputs.iter().map(|r| &r[..]), input_dim);
        if actions == ActionScaling::Raw {
            for k in state..input_dim {
                input.mean[k] = 0.0;
                input.std[k] = 1.0;
            }
        }
        let target = match target_kind {
            TargetKind::StateScaled => {
                // S: per-dimension population SD of x_t over these windows
                // (for world these are the input standardizer's state part).
                let s = Standardizer::fit(windows.iter().map(|(x, _, _)| &x[..]), state);
                Standardizer { mean: vec![0.0; state], std: s.std }
            }
            TargetKind::Standardized => {
                let targets: Vec<State> = windows.iter().map(|(x, _, n)| raw_target(&slots, x, n)).collect();
                Standardizer::fit(targets.iter().map(|r| &r[..]), state)
            }
        };
        FeatureMap { map, actions, target_kind, input, target, fitted_on: fitted_on.to_string(), slots }
    }

    /// Standardized input, written into `out` ([`Slots::input`] values).
    pub fn input(&self, x: &[f64], u: &[f64], out: &mut [f32]) {
        with_row(self.slots.input(), |raw| {
            raw_input_into(&self.slots, self.map, x, u, raw);
            self.input.apply(raw, out);
        });
    }

    /// Standardized target ([`Slots::state`] values).
    pub fn target(&self, x: &[f64], next: &[f64], out: &mut [f32]) {
        with_row(self.slots.state, |raw| {
            raw_target_into(&self.slots, x, next, raw);
            self.target.apply(raw, out);
        });
    }

    /// Next state from a standardized prediction: x + increment, with the
    /// exogenous components left for the caller to overwrite.
    pub fn next_state(&self, x: &[f64], z: &[f32]) -> State {
        let mut d = vec![0.0; self.slots.state];
        self.target.invert(z, &mut d);
        let mut n = x.to_vec();
        for k in 0..self.slots.predicted {
            n[k] += d[k];
        }
        n
    }
}
