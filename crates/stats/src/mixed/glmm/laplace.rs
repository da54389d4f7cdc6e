//! The Laplace approximation of a GLMM's deviance at one (theta, beta),
//! as lme4's `glmer` computes it (nAGQ = 1): the conditional mode u* of
//! the spherical random effects by penalized iteratively reweighted least
//! squares (Newton steps on -2 log p(y | u) + |u|^2, halved until it
//! falls), then
//!
//! ```text
//! -2 log L(theta, beta) ~= -2 log p(y | u*) + |u*|^2 + log|Lambda'Z'W Z Lambda + I|
//! ```
//!
//! with W the GLM weights at u* (binomial: m mu (1 - mu); Poisson: mu), and
//! -2 log p(y | u*) the family's `aic()` of R (the full log-likelihood,
//! binomial coefficients and log y! included).
//!
//! PIRLS starts from u = 0 at every point and runs until the Newton
//! decrement is below 1e-14 of the penalized deviance, so the value at a
//! point does not depend on the points evaluated before it. lme4 starts
//! from the previous point's mode, stops on a relative change of the
//! penalized residual sum of squares, and takes log|L|^2 from its last
//! factorization, whose weights are those before its last step: the two
//! agree to the penalized deviance's last digits and differ in log|L|^2 by
//! up to about 1e-8 of the objective (grouseticks, whose observation-level
//! effects make the mode's last digits slow to settle).

use faer::Mat;

use super::Family;
use crate::mixed::slopes::structure::Structure;
use crate::mixed::sparse::Sparse;
use crate::mixed::MixedError;

/// A GLMM's data in the form the evaluations use.
pub(super) struct Model {
    pub structure: Structure,
    /// The pattern of Lambda'Z'W Z Lambda + I, alone and bordered with
    /// the fixed effects.
    pub sparse: Sparse,
    pub bordered: Sparse,
    pub family: Family,
    pub n: usize,
    pub p: usize,
    /// The design, n x p row-major.
    pub x: Vec<f64>,
    /// Successes (binomial) or counts (Poisson).
    pub k: Vec<f64>,
    /// Trials (binomial); 1 for Poisson.
    pub m: Vec<f64>,
    /// The offset of each linear predictor.
    pub offset: Vec<f64>,
    /// The quadrature rule (one node at 0 of weight 1: Laplace).
    pub nodes: Vec<(f64, f64)>,
    /// sum log C(m, k) (binomial) or -sum log k! (Poisson).
    pub constant: f64,
}

/// The approximation at one point.
pub(super) struct Laplace {
    /// -2 log L, lme4's objective.
    pub objective: f64,
    /// Var(beta) from R_X at the mode (lme4's `vcov(use.hessian = FALSE)`).
    pub rx_vcov: Option<Mat<f64>>,
}

/// ln(1 + e^x) without overflow.
fn softplus(x: f64) -> f64 {
    x.max(0.0) + (-x.abs()).exp().ln_1p()
}

impl Model {
    /// The mean, the GLM weight, the score term and log p(y_i) of
    /// observation i at linear predictor eta.
    pub(super) fn observation(&self, i: usize, eta: f64) -> (f64, f64, f64) {
        let (k, m) = (self.k[i], self.m[i]);
        match self.family {
            Family::Binomial => {
                let mu = 1.0 / (1.0 + (-eta).exp());
                // log mu = -softplus(-eta), log(1 - mu) = -softplus(eta).
                let log_p = -k * softplus(-eta) - (m - k) * softplus(eta);
                (m * mu * (1.0 - mu), k - m * mu, log_p)
            }
            Family::Poisson => {
                let mu = eta.exp();
                (mu, k - mu, k * eta - mu)
            }
        }
    }

    /// The GLM weight and the score term of observation i at linear
    /// predictor eta: [`Model::observation`] without the log-likelihood
    /// (whose logarithms PIRLS's weights do not need).
    fn weight_score(&self, i: usize, eta: f64) -> (f64, f64) {
        let (k, m) = (self.k[i], self.m[i]);
        match self.family {
            Family::Binomial => {
                let mu = 1.0 / (1.0 + (-eta).exp());
                (m * mu * (1.0 - mu), k - m * mu)
            }
            Family::Poisson => {
                let mu = eta.exp();
                (mu, k - mu)
            }
        }
    }

    /// The GLM weight of every observation and the score Z Lambda' r at
    /// the linear predictors `eta` (rows of Z Lambda `zl`).
    fn weights(&self, zl: &[Vec<(usize, f64)>], eta: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let mut w = vec![0.0; self.n];
        let mut score = vec![0.0; self.structure.q];
        for i in 0..self.n {
            let (wi, r) = self.weight_score(i, eta[i]);
            w[i] = wi;
            for &(j, v) in &zl[i] {
                score[j] += r * v;
            }
        }
        (w, score)
    }

    /// sum_g log M_g, the adaptive Gauss-Hermite correction of the Laplace
    /// value (`super::quadrature`) of a model with one scalar term (each
    /// row of `zl` one entry), at the mode `u` with linear predictors
    /// `eta` and GLM weights `w`.
    fn quadrature(&self, zl: &[Vec<(usize, f64)>], eta: &[f64], u: &[f64], w: &[f64]) -> f64 {
        let q = self.structure.q;
        let (mut l2, mut h0) = (vec![1.0; q], vec![0.0; q]);
        for i in 0..self.n {
            let (g, v) = zl[i][0];
            l2[g] += w[i] * v * v;
            h0[g] -= 2.0 * self.observation(i, eta[i]).2;
        }
        for g in 0..q {
            h0[g] += u[g] * u[g];
        }
        let mut sums = vec![0.0; q];
        for &(z, weight) in &self.nodes {
            if z == 0.0 {
                sums.iter_mut().for_each(|m| *m += weight);
                continue;
            }
            let shift: Vec<f64> = l2.iter().map(|l| z / l.sqrt()).collect();
            let mut h: Vec<f64> = (0..q).map(|g| (u[g] + shift[g]).powi(2)).collect();
            for i in 0..self.n {
                let (g, v) = zl[i][0];
                h[g] -= 2.0 * self.observation(i, eta[i] + v * shift[g]).2;
            }
            for g in 0..q {
                sums[g] += weight * (-0.5 * (h[g] - h0[g]) + 0.5 * z * z).exp();
            }
        }
        sums.iter().map(|m| m.ln()).sum()
    }

    /// -2 log p(y | u) + |u|^2 at the linear predictors `eta`.
    fn penalized(&self, eta: &[f64], u: &[f64]) -> f64 {
        let log_p: f64 = (0..self.n).map(|i| self.observation(i, eta[i]).2).sum();
        -2.0 * (log_p + self.constant) + u.iter().map(|v| v * v).sum::<f64>()
    }

    /// The Laplace approximation at (theta, beta), PIRLS starting from
    /// `start` (zeros where `None`); with `vcov`, Var(beta) from R_X too.
    pub fn evaluate(
        &self,
        theta: &[f64],
        beta: &[f64],
        start: Option<&[f64]>,
        vcov: bool,
    ) -> Result<Laplace, MixedError> {
        let (n, q, p) = (self.n, self.structure.q, self.p);
        let lambda = self.structure.lambda(theta);
        let mut zl: Vec<Vec<(usize, f64)>> = Vec::with_capacity(n);
        let mut row = Vec::new();
        for i in 0..n {
            self.structure.z_lambda_row(i, &lambda, &mut row);
            zl.push(row.clone());
        }
        let fixed: Vec<f64> =
            (0..n).map(|i| self.offset[i] + (0..p).map(|c| self.x[i * p + c] * beta[c]).sum::<f64>()).collect();
        let eta_at = |u: &[f64]| -> Vec<f64> {
            (0..n).map(|i| fixed[i] + zl[i].iter().map(|&(j, v)| v * u[j]).sum::<f64>()).collect()
        };
        let mut u: Vec<f64> = start.map_or_else(|| vec![0.0; q], |s| s.to_vec());
        let mut eta = eta_at(&u);
        let mut value = self.penalized(&eta, &u);
        let not_pd = || MixedError::NotPositiveDefinite { theta: theta.to_vec() };
        let copy = |i: usize, out: &mut Vec<(usize, f64)>| {
            out.clear();
            out.extend_from_slice(&zl[i]);
        };
        let weights = |eta: &[f64]| self.weights(&zl, eta);
        for _ in 0..100 {
            let (w, score) = weights(&eta);
            let rhs: Vec<f64> = (0..q).map(|j| score[j] - u[j]).collect();
            let system = self.sparse.factor(n, copy, Some(&w), &[]).ok_or_else(not_pd)?;
            let delta = system.solve_vec(&rhs);
            let decrement: f64 = delta.iter().zip(&rhs).map(|(a, b)| a * b).sum();
            if !decrement.is_finite() {
                return Err(not_pd());
            }
            // The Newton decrement is half the predicted fall of the
            // penalized deviance; below rounding the mode is found.
            if decrement <= 1e-14 * (1.0 + value.abs()) {
                break;
            }
            let mut scale = 1.0;
            let mut moved = false;
            for _ in 0..30 {
                let trial: Vec<f64> = (0..q).map(|j| u[j] + scale * delta[j]).collect();
                let trial_eta = eta_at(&trial);
                let trial_value = self.penalized(&trial_eta, &trial);
                if trial_value <= value {
                    (u, eta, value) = (trial, trial_eta, trial_value);
                    moved = true;
                    break;
                }
                scale *= 0.5;
            }
            if !moved {
                break;
            }
        }
        let (w, _) = weights(&eta);
        let log_det = self.sparse.factor(n, copy, Some(&w), &[]).ok_or_else(not_pd)?.log_det_random();
        let mut objective = value + log_det;
        if self.nodes.len() > 1 {
            objective -= 2.0 * self.quadrature(&zl, &eta, &u, &w);
        }
        if !objective.is_finite() {
            return Err(not_pd());
        }
        let rx_vcov = if vcov {
            let bordered = self.bordered.factor(n, copy, Some(&w), &self.x);
            Some(bordered.ok_or_else(|| MixedError::FixedEffects("X'WX is singular at the mode".into()))?.rx_inv())
        } else {
            None
        };
        Ok(Laplace { objective, rx_vcov })
    }
}
