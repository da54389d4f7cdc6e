//! Parameter-free predictors, through the same rollout and metric code.

use super::features::{Action, State};
use super::Dynamics;

/// x_{t+1} = x_t.
pub struct Persistence;

impl Dynamics for Persistence {
    fn step(&mut self, states: &[State], _: &[Action]) -> Vec<State> {
        states.to_vec()
    }
}

/// Position advances with the current velocity; velocity and attitude hold.
pub struct ConstantVelocity {
    /// Seconds per step (1 / log rate).
    pub dt: f64,
}

impl Dynamics for ConstantVelocity {
    fn step(&mut self, states: &[State], _: &[Action]) -> Vec<State> {
        states
            .iter()
            .map(|x| {
                let mut n = x.clone();
                for k in 0..3 {
                    n[k] += x[3 + k] * self.dt;
                }
                n
            })
            .collect()
    }
}
