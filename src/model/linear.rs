//! A linear reference model: ridge regression of the MLP's standardized
//! target on its standardized inputs (and an unpenalized intercept), in
//! closed form. The penalty is declared, or chosen on the validation
//! windows from [`RIDGE_GRID`] by the same loss the MLP's early stopping
//! reads (mean squared error of the standardized target).
//!
//! With Gram matrix G = X'X / n and b = X'Y / n over the fit windows, the
//! weights solve (G + lambda D) W = b, D the identity with 0 for the
//! intercept: one 19 x 19 Cholesky (faer) for every penalty tried.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
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
    let gram = Mat::<f64>::from_fn(P, P, |i, j| x.iter().map(|r| r[i] * r[j]).sum::<f64>() / n);
    let xty = Mat::<f64>::from_fn(P, STATE, |i, k| x.iter().zip(&y).map(|(r, t)| r[i] * t[k]).sum::<f64>() / n);
    let (vx, vy) = design_rows(&features, validation);
    let grid: Vec<f64> = ridge.map_or_else(|| RIDGE_GRID.to_vec(), |l| vec![l]);
    let mut best: Option<(f64, Vec<f64>, f64)> = None;
    let mut tried = Vec::new();
    for lambda in grid {
        let penalized = Mat::<f64>::from_fn(P, P, |i, j| gram[(i, j)] + if i == j && i < INPUT { lambda } else { 0.0 });
        let llt = penalized.llt(Side::Lower).map_err(|_| LinearError::Singular { lambda })?;
        let w = llt.solve(&xty);
        let weights: Vec<f64> = (0..P).flat_map(|i| (0..STATE).map(move |k| (i, k))).map(|(i, k)| w[(i, k)]).collect();
        let loss = mse(&weights, &vx, &vy);
        tried.push((lambda, loss));
        if best.as_ref().is_none_or(|b| loss < b.2) {
            best = Some((lambda, weights, loss));
        }
    }
    let (lambda, weights, _) = best.ok_or(LinearError::NoData)?;
    Ok(Linear { features, lambda, weights, validation: tried })
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
