//! The two input maps and the prediction target.
//!
//! State layout (the NanoBench task-2 order): p = `x[0..3]`, v = `x[3..6]`,
//! q = `x[6..10]` (w, x, y, z), r = `x[10..13]` (position setpoint), b = `x[13]`
//! (battery). Action u: 4 motor commands in [0, 1].
//!
//! - world: [S(x), u], S the state standardizer (18 inputs);
//! - relative: [T(0_3, v, q, r - p, b), u], T its own standardizer.
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
//! Either way the exogenous components (r, b) of the target are zero: the
//! model never predicts what the rollout overwrites with measured values.

use serde::{Deserialize, Serialize};

use super::Standardizer;
use crate::design::{ActionScaling, InputMap, TargetKind};

/// State dimensions: position, velocity, quaternion, reference, battery.
pub const STATE: usize = 14;
/// Action dimensions: the four motor commands in [0, 1].
pub const ACTION: usize = 4;
/// Network input dimensions: state and action.
pub const INPUT: usize = STATE + ACTION;
/// Exogenous state components: reference (10..13) and battery (13).
pub const EXOGENOUS: std::ops::Range<usize> = 10..14;

/// One state x_t.
pub type State = [f64; STATE];
/// One action u_t.
pub type Action = [f64; ACTION];

/// Unstandardized network input of one (state, action).
pub fn raw_input(map: InputMap, x: &State, u: &Action) -> [f64; INPUT] {
    let mut out = [0.0; INPUT];
    match map {
        InputMap::World => out[..STATE].copy_from_slice(x),
        InputMap::Relative => {
            // out[0..3] stays 0: absolute position is not an input.
            out[3..10].copy_from_slice(&x[3..10]);
            for k in 0..3 {
                out[10 + k] = x[10 + k] - x[k];
            }
            out[13] = x[13];
        }
    }
    out[STATE..].copy_from_slice(u);
    out
}

/// Unstandardized target: the increment, exogenous components zeroed.
pub fn raw_target(x: &State, next: &State) -> State {
    let mut d = [0.0; STATE];
    for k in 0..STATE {
        d[k] = next[k] - x[k];
    }
    for k in EXOGENOUS {
        d[k] = 0.0;
    }
    d
}

/// Standardizers of one fitted model, fitted on its own arm's fit windows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FeatureMap {
    /// World or relative inputs.
    pub map: InputMap,
    /// How the actions enter (raw: the last 4 input dimensions are the identity).
    pub actions: ActionScaling,
    /// What the network predicts.
    pub target_kind: TargetKind,
    /// On the 18 inputs: S on the state for world, T for relative; the
    /// identity on u when actions are raw.
    pub input: Standardizer,
    /// On the 14-dimensional increment: mean 0 and S's SDs for the
    /// state-scaled target, the increment's own mean and SD otherwise.
    pub target: Standardizer,
    /// SHA-256 of the fit manifest these were fitted on (invariant 6).
    pub fitted_on: String,
}

impl FeatureMap {
    /// Fits the standardizers on (x_t, u_t, x_{t+1}) windows.
    pub fn fit(
        map: InputMap,
        actions: ActionScaling,
        target_kind: TargetKind,
        windows: &[(State, Action, State)],
        fitted_on: &str,
    ) -> FeatureMap {
        let inputs: Vec<[f64; INPUT]> = windows.iter().map(|(x, u, _)| raw_input(map, x, u)).collect();
        let mut input = Standardizer::fit(inputs.iter().map(|r| &r[..]), INPUT);
        if actions == ActionScaling::Raw {
            for k in STATE..INPUT {
                input.mean[k] = 0.0;
                input.std[k] = 1.0;
            }
        }
        let target = match target_kind {
            TargetKind::StateScaled => {
                // S: per-dimension population SD of x_t over these windows
                // (for world these are the input standardizer's first 14).
                let s = Standardizer::fit(windows.iter().map(|(x, _, _)| &x[..]), STATE);
                Standardizer { mean: vec![0.0; STATE], std: s.std }
            }
            TargetKind::Standardized => {
                let targets: Vec<State> = windows.iter().map(|(x, _, n)| raw_target(x, n)).collect();
                Standardizer::fit(targets.iter().map(|r| &r[..]), STATE)
            }
        };
        FeatureMap { map, actions, target_kind, input, target, fitted_on: fitted_on.to_string() }
    }

    /// Standardized input, written into `out` (18 values).
    pub fn input(&self, x: &State, u: &Action, out: &mut [f32]) {
        self.input.apply(&raw_input(self.map, x, u), out);
    }

    /// Standardized target (14 values).
    pub fn target(&self, x: &State, next: &State, out: &mut [f32]) {
        self.target.apply(&raw_target(x, next), out);
    }

    /// Next state from a standardized prediction: x + increment, with the
    /// exogenous components left for the caller to overwrite.
    pub fn next_state(&self, x: &State, z: &[f32]) -> State {
        let mut d = [0.0; STATE];
        self.target.invert(z, &mut d);
        let mut n = *x;
        for k in 0..STATE {
            if !EXOGENOUS.contains(&k) {
                n[k] += d[k];
            }
        }
        n
    }
}
