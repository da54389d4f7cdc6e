//! Per-dimension standardizers, fitted on one arm's own fit windows only.

use serde::{Deserialize, Serialize};

/// Mean and standard deviation per dimension (population SD, divisor n).
/// A constant dimension gets SD 1, so it maps to a constant, not to NaN.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Standardizer {
    /// Per-dimension mean.
    pub mean: Vec<f64>,
    /// Per-dimension standard deviation (never zero).
    pub std: Vec<f64>,
}

/// SDs below this are treated as constant dimensions.
const CONSTANT_SD: f64 = 1e-12;

impl Standardizer {
    /// Fits on rows of equal length `dim`. Two passes (mean, then squared
    /// deviations) for accuracy.
    pub fn fit<'a>(rows: impl Iterator<Item = &'a [f64]> + Clone, dim: usize) -> Standardizer {
        let mut mean = vec![0.0; dim];
        let mut n = 0usize;
        for r in rows.clone() {
            for (m, v) in mean.iter_mut().zip(r) {
                *m += v;
            }
            n += 1;
        }
        let n_f = n.max(1) as f64;
        mean.iter_mut().for_each(|m| *m /= n_f);
        let mut var = vec![0.0; dim];
        for r in rows {
            for ((s, v), m) in var.iter_mut().zip(r).zip(&mean) {
                *s += (v - m).powi(2);
            }
        }
        let std = var.into_iter().map(|s| (s / n_f).sqrt()).map(|s| if s < CONSTANT_SD { 1.0 } else { s }).collect();
        Standardizer { mean, std }
    }

    /// The identity map on `dim` dimensions.
    pub fn identity(dim: usize) -> Standardizer {
        Standardizer { mean: vec![0.0; dim], std: vec![1.0; dim] }
    }

    /// Number of dimensions.
    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// (x - mean) / std, into `out`.
    pub fn apply(&self, x: &[f64], out: &mut [f32]) {
        for (((o, v), m), s) in out.iter_mut().zip(x).zip(&self.mean).zip(&self.std) {
            *o = ((v - m) / s) as f32;
        }
    }

    /// z std + mean, into `out`.
    pub fn invert(&self, z: &[f32], out: &mut [f64]) {
        for (((o, v), m), s) in out.iter_mut().zip(z).zip(&self.mean).zip(&self.std) {
            *o = f64::from(*v) * s + m;
        }
    }
}
