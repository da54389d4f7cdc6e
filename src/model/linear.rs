//! A linear reference model: ridge regression of the MLP's standardized
//! target on its standardized inputs (and an unpenalized intercept), in
//! closed form. The penalty is declared, or chosen on the validation
//! windows from [`RIDGE_GRID`] by the same loss the MLP's early stopping
//! reads (mean squared error of the standardized target).
//!
//! With Gram matrix G = X'X / n and b = X'Y / n over the fit windows, the
//! weights solve (G + lambda D) W = b, D the identity with 0 for the
//! intercept: one 19 x 19 Cholesky for every penalty tried. It is written
//! out in scalar f64 (not faer's kernels, which choose SIMD paths by CPU)
//! so that the weights, and every per-cell row, are the same bits on every
//! machine.

use serde::Serialize;

use super::features::{FeatureMap, INPUT, STATE};
use super::{Action, Dynamics, State};

/// The penalties tried when the design says `ridge auto`.
pub const RIDGE_GRID: [f64; 9] = [1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0];

/// Inputs plus the intercept.
const P: usize = INPUT + 1;

/// A fitted ridge model.
#[derive(Debug, Clone, Serialize)]
pub struct Linear {
    /// The standardizers (the same as an MLP's on these windows).
    pub features: FeatureMap,
    /// The penalty used.
    pub lambda: f64,
    /// Weights, `P` rows (inputs, then the intercept) x 14 targets, row-major.
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
fn design_rows(features: &FeatureMap, windows: &[Window]) -> (Vec<[f64; P]>, Vec<[f64; STATE]>) {
    let (mut xin, mut yt) = ([0f32; INPUT], [0f32; STATE]);
    windows
        .iter()
        .map(|(x, u, n)| {
            features.input(x, u, &mut xin);
            features.target(x, n, &mut yt);
            let mut row = [1.0; P];
            row[..INPUT].iter_mut().zip(&xin).for_each(|(r, v)| *r = f64::from(*v));
            (row, yt.map(f64::from))
        })
        .unzip()
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
    let n = x.len() as f64;
    let gram: Vec<f64> = (0..P * P).map(|ij| x.iter().map(|r| r[ij / P] * r[ij % P]).sum::<f64>() / n).collect();
    let xty: Vec<f64> = (0..P * STATE)
        .map(|ik| x.iter().zip(&y).map(|(r, t)| r[ik / STATE] * t[ik % STATE]).sum::<f64>() / n)
        .collect();
    let (vx, vy) = design_rows(&features, validation);
    let grid: Vec<f64> = ridge.map_or_else(|| RIDGE_GRID.to_vec(), |l| vec![l]);
    let mut best: Option<(f64, Vec<f64>, f64)> = None;
    let mut tried = Vec::new();
    for lambda in grid {
        let mut penalized = gram.clone();
        for i in 0..INPUT {
            penalized[i * P + i] += lambda;
        }
        let weights = cholesky_solve(penalized, &xty).ok_or(LinearError::Singular { lambda })?;
        let loss = mse(&weights, &vx, &vy);
        tried.push((lambda, loss));
        if best.as_ref().is_none_or(|b| loss < b.2) {
            best = Some((lambda, weights, loss));
        }
    }
    let (lambda, weights, _) = best.ok_or(LinearError::NoData)?;
    Ok(Linear { features, lambda, weights, validation: tried })
}

/// Solves A W = B for symmetric positive definite A (P x P, row-major) and
/// B (P x 14, row-major) by Cholesky, A = L L'; `None` when A is not
/// positive definite.
fn cholesky_solve(mut a: Vec<f64>, b: &[f64]) -> Option<Vec<f64>> {
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

/// The prediction of one standardized input row.
fn predict(weights: &[f64], row: &[f64; P]) -> [f64; STATE] {
    let mut z = [0.0; STATE];
    for (i, r) in row.iter().enumerate() {
        for (k, zk) in z.iter_mut().enumerate() {
            *zk += r * weights[i * STATE + k];
        }
    }
    z
}

/// Mean over windows and the 14 targets of the squared error.
fn mse(weights: &[f64], x: &[[f64; P]], y: &[[f64; STATE]]) -> f64 {
    let sum: f64 = x
        .iter()
        .zip(y)
        .map(|(r, t)| predict(weights, r).iter().zip(t).map(|(p, t)| (p - t) * (p - t)).sum::<f64>())
        .sum();
    sum / (x.len() * STATE) as f64
}

impl Dynamics for Linear {
    fn step(&mut self, states: &[State], actions: &[Action]) -> Vec<State> {
        let mut xin = [0f32; INPUT];
        states
            .iter()
            .zip(actions)
            .map(|(x, u)| {
                self.features.input(x, u, &mut xin);
                let mut row = [1.0; P];
                row[..INPUT].iter_mut().zip(&xin).for_each(|(r, v)| *r = f64::from(*v));
                let z = predict(&self.weights, &row).map(|v| v as f32);
                self.features.next_state(x, &z)
            })
            .collect()
    }
}
