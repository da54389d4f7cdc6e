//! A linear reference model: ridge regression of the MLP's standardized
//! target on its standardized inputs (and an unpenalized intercept), in
//! closed form. The penalty is declared, or chosen on the validation
//! windows from [`RIDGE_GRID`] by the same loss the MLP's early stopping
//! reads (mean squared error of the standardized target).
//!
//! With Gram matrix G = X'X / n and b = X'Y / n over the fit windows, the
//! weights solve (G + lambda D) W = b, D the identity with 0 for the
//! intercept: one (inputs + 1) x (inputs + 1) Cholesky (19 x 19 for
//! NanoBench) for every penalty tried. It is written
//! out in scalar f64 (not faer's kernels, which choose SIMD paths by CPU)
//! so that the weights, and every per-cell row, are the same bits on every
//! machine.

use serde::Serialize;

use super::features::FeatureMap;
use super::{Action, Dynamics, State};

/// The penalties tried when the design says `ridge auto`.
pub const RIDGE_GRID: [f64; 9] = [1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0];

/// A fitted ridge model.
#[derive(Debug, Clone, Serialize)]
pub struct Linear {
    /// The standardizers (the same as an MLP's on these windows).
    pub features: FeatureMap,
    /// The penalty used.
    pub lambda: f64,
    /// Weights, inputs + 1 rows (inputs, then the intercept) x the state's
    /// targets, row-major.
    pub weights: Vec<f64>,
    /// Every penalty tried with its validation loss (one row when declared).
    pub validation: Vec<(f64, f64)>,
}

/// Why a ridge model could not be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LinearError {
    /// No fit or no validation windows.
    #[error("no fit or validation windows to fit a linear model on")]
    NoData,
    /// The penalized Gram matrix is not positive definite (constant inputs
    /// with a zero penalty).
    #[error("the linear model's normal equations are singular at ridge {lambda} (constant inputs?); declare a positive `ridge`")]
    Singular {
        /// The penalty.
        lambda: f64,
    },
}

type Window = (State, Action, State);

/// Standardized inputs (with the intercept) and targets of `windows`, f64.
fn design_rows(features: &FeatureMap, windows: &[Window]) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let (mut xin, mut yt) = (vec![0f32; features.slots.input()], vec![0f32; features.slots.state]);
    windows
        .iter()
        .map(|(x, u, n)| {
            features.target(x, n, &mut yt);
            (input_row(features, x, u, &mut xin), yt.iter().map(|v| f64::from(*v)).collect())
        })
        .unzip()
}

/// One standardized input row with the intercept (1) last.
fn input_row(features: &FeatureMap, x: &[f64], u: &[f64], scratch: &mut [f32]) -> Vec<f64> {
    features.input(x, u, scratch);
    scratch.iter().map(|v| f64::from(*v)).chain([1.0]).collect()
}

/// Fits the weights on `fit` with penalty `ridge`, or with each of
/// [`RIDGE_GRID`] keeping the lowest validation loss (the first on a tie).
pub fn fit(
    features: FeatureMap,
    fit: &[Window],
    validation: &[Window],
    ridge: Option<f64>,
) -> Result<Linear, LinearError> {
    if fit.is_empty() || validation.is_empty() {
        return Err(LinearError::NoData);
    }
    let (x, y) = design_rows(&features, fit);
    let (p, s) = (features.slots.input() + 1, features.slots.state);
    let n = x.len() as f64;
    let gram: Vec<f64> = (0..p * p).map(|ij| x.iter().map(|r| r[ij / p] * r[ij % p]).sum::<f64>() / n).collect();
    let xty: Vec<f64> =
        (0..p * s).map(|ik| x.iter().zip(&y).map(|(r, t)| r[ik / s] * t[ik % s]).sum::<f64>() / n).collect();
    let (vx, vy) = design_rows(&features, validation);
    let grid: Vec<f64> = ridge.map_or_else(|| RIDGE_GRID.to_vec(), |l| vec![l]);
    let mut best: Option<(f64, Vec<f64>, f64)> = None;
    let mut tried = Vec::new();
    for lambda in grid {
        let mut penalized = gram.clone();
        for i in 0..p - 1 {
            penalized[i * p + i] += lambda;
        }
        let weights = cholesky_solve(penalized, &xty, p, s).ok_or(LinearError::Singular { lambda })?;
        let loss = mse(&weights, &vx, &vy, s);
        tried.push((lambda, loss));
        if best.as_ref().is_none_or(|b| loss < b.2) {
            best = Some((lambda, weights, loss));
        }
    }
    let (lambda, weights, _) = best.ok_or(LinearError::NoData)?;
    Ok(Linear { features, lambda, weights, validation: tried })
}

/// Solves A W = B for symmetric positive definite A (p x p, row-major) and
/// B (p x s, row-major) by Cholesky, A = L L'; `None` when A is not
/// positive definite.
#[allow(non_snake_case)] // P and STATE as the solver was first written for NanoBench's 19 and 14
fn cholesky_solve(mut a: Vec<f64>, b: &[f64], P: usize, STATE: usize) -> Option<Vec<f64>> {
    // L in the lower triangle of `a`.
    for j in 0..P {
        let mut d = a[j * P + j];
        for k in 0..j {
            d -= a[j * P + k] * a[j * P + k];
        }
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        let d = d.sqrt();
        a[j * P + j] = d;
        for i in j + 1..P {
            let mut v = a[i * P + j];
            for k in 0..j {
                v -= a[i * P + k] * a[j * P + k];
            }
            a[i * P + j] = v / d;
        }
    }
    let mut w = b.to_vec();
    for c in 0..STATE {
        // L z = b, then L' w = z, column by column.
        for i in 0..P {
            let mut v = w[i * STATE + c];
            for k in 0..i {
                v -= a[i * P + k] * w[k * STATE + c];
            }
            w[i * STATE + c] = v / a[i * P + i];
        }
        for i in (0..P).rev() {
            let mut v = w[i * STATE + c];
            for k in i + 1..P {
                v -= a[k * P + i] * w[k * STATE + c];
            }
            w[i * STATE + c] = v / a[i * P + i];
        }
    }
    Some(w)
}

/// The prediction of one standardized input row (`s` targets).
fn predict(weights: &[f64], row: &[f64], s: usize) -> Vec<f64> {
    let mut z = vec![0.0; s];
    for (i, r) in row.iter().enumerate() {
        for (k, zk) in z.iter_mut().enumerate() {
            *zk += r * weights[i * s + k];
        }
    }
    z
}

/// Mean over windows and the `s` targets of the squared error.
fn mse(weights: &[f64], x: &[Vec<f64>], y: &[Vec<f64>], s: usize) -> f64 {
    let sum: f64 = x
        .iter()
        .zip(y)
        .map(|(r, t)| predict(weights, r, s).iter().zip(t).map(|(p, t)| (p - t) * (p - t)).sum::<f64>())
        .sum();
    sum / (x.len() * s) as f64
}

impl Dynamics for Linear {
    fn step(&mut self, states: &[State], actions: &[Action]) -> Vec<State> {
        let mut xin = vec![0f32; self.features.slots.input()];
        let s = self.features.slots.state;
        states
            .iter()
            .zip(actions)
            .map(|(x, u)| {
                let row = input_row(&self.features, x, u, &mut xin);
                let z: Vec<f32> = predict(&self.weights, &row, s).iter().map(|v| *v as f32).collect();
                self.features.next_state(x, &z)
            })
            .collect()
    }
}
