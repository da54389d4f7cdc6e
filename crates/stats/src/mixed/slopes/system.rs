//! The penalized least-squares system of a random-slope model at one
//! theta, over every level of every term, held sparse
//! ([`crate::mixed::sparse`]): its pattern, ordering and symbolic factor
//! are found once; at each theta the system
//! [Lambda'Z'Z Lambda + I, Lambda'Z'X; X'Z Lambda, X'X] of the
//! standardized response (centred, divided by its standard deviation, as
//! the random-intercept system does) is added up observation by
//! observation and factored as [L 0; R' R_X'], so that log|L|^2 and
//! log|R_X|^2 are sums of the logarithms of its pivots. The penalized
//! residual sum of squares is computed from the solution itself,
//! |y - X beta - Z Lambda u|^2 + |u|^2, not as a difference of squares.
//! Prior weights W (lmer's `weights`) weight the system and the residuals,
//! and the deviance subtracts log|W| as lme4's does.

use faer::Mat;

use super::structure::Structure;
use super::Term;
use crate::mixed::sparse::Sparse;
use crate::mixed::{Criterion, MixedData, MixedError};

/// The products a deviance evaluation needs, computed once.
pub(super) struct System {
    pub n: usize,
    pub p: usize,
    pub y_mean: f64,
    pub y_scale: f64,
    /// The standardized response and the design, n x p row-major.
    y: Vec<f64>,
    x: Vec<f64>,
    /// Z and the layout of Lambda.
    pub structure: Structure,
    /// The pattern and symbolic factor of the bordered system.
    sparse: Sparse,
    /// Prior weights (all 1 without them) and the sum of their logarithms
    /// (lme4's ldW, which the deviance subtracts).
    w: Vec<f64>,
    pub log_w: f64,
    xty: Vec<f64>,
}

/// The deviance and estimates at one theta, on the response's scale.
pub(super) struct Eval {
    pub deviance: f64,
    pub beta: Vec<f64>,
    pub sigma2: f64,
    /// log|L|^2 and log|R_X|^2.
    pub log_det_l2: f64,
    pub log_det_rx2: f64,
    /// Penalized residual sum of squares of the standardized response.
    pub r2_std: f64,
    /// (R_X'R_X)^-1 = Var(beta) / sigma^2.
    pub rx_inv: Mat<f64>,
}

impl System {
    /// The products of `base` (response and fixed effects) and `terms`.
    pub fn new(base: &MixedData, terms: &[Term], weights: Option<&[f64]>) -> Result<System, MixedError> {
        let n = base.len();
        let p = base.p();
        let y_mean = base.y.iter().sum::<f64>() / n as f64;
        let sd = (base.y.iter().map(|v| (v - y_mean).powi(2)).sum::<f64>() / (n as f64 - 1.0)).sqrt();
        let y_scale = if sd.is_finite() && sd > 0.0 { sd } else { 1.0 };
        let y: Vec<f64> = base.y.iter().map(|v| (v - y_mean) / y_scale).collect();
        let x = base.design();
        let structure = Structure::new(terms, n);
        let z2: f64 = structure.z_rows.iter().flatten().map(|(_, v)| v * v).sum();
        let x2: f64 = x.iter().map(|v| v * v).sum();
        if !z2.is_finite() || !x2.is_finite() {
            return Err(MixedError::TooLarge("the random-effect columns' products overflow double precision".into()));
        }
        let w: Vec<f64> = weights.map_or_else(|| vec![1.0; n], <[f64]>::to_vec);
        let log_w: f64 = w.iter().map(|v| v.ln()).sum();
        let xty: Vec<f64> = (0..p).map(|c| (0..n).map(|i| x[i * p + c] * w[i] * y[i]).sum()).collect();
        let sparse = Sparse::new(&structure.z_rows, structure.q, p)?;
        Ok(System { n, p, y_mean, y_scale, y, x, structure, sparse, w, log_w, xty })
    }

    /// The deviance and estimates at `theta`.
    pub fn evaluate(&self, theta: &[f64], criterion: Criterion) -> Result<Eval, MixedError> {
        let st = &self.structure;
        let (q, p, n) = (st.q, self.p, self.n);
        let lambda = st.lambda(theta);
        // The system and, on the way, Lambda'Z'y.
        let mut rhs = Mat::<f64>::zeros(q + p, 1);
        let factor = self.sparse.factor(
            n,
            |i, out| {
                st.z_lambda_row(i, &lambda, out);
                let wy = self.w[i] * self.y[i];
                for &(j, v) in out.iter() {
                    rhs[(j, 0)] += v * wy;
                }
            },
            Some(&self.w),
            &self.x,
        );
        let not_pd = || MixedError::NotPositiveDefinite { theta: theta.to_vec() };
        let factor = factor.ok_or_else(not_pd)?;
        let log_det_l2 = factor.log_det_random();
        let log_det_rx2 = factor.log_det_fixed();
        if !log_det_l2.is_finite() || !log_det_rx2.is_finite() {
            return Err(not_pd());
        }
        for c in 0..p {
            rhs[(q + c, 0)] = self.xty[c];
        }
        factor.solve(&mut rhs);
        let u: Vec<f64> = (0..q).map(|i| rhs[(i, 0)]).collect();
        let beta_std: Vec<f64> = (0..p).map(|c| rhs[(q + c, 0)]).collect();
        // b = Lambda u, then the residuals row by row.
        let b = st.lambda_times(&lambda, &u);
        let mut r2_std: f64 = u.iter().map(|v| v * v).sum();
        for i in 0..n {
            let fitted: f64 = (0..p).map(|c| self.x[i * p + c] * beta_std[c]).sum::<f64>()
                + st.z_rows[i].iter().map(|&(j, v)| v * b[j]).sum::<f64>();
            r2_std += self.w[i] * (self.y[i] - fitted).powi(2);
        }
        // (R_X'R_X)^-1 (Var(beta) / sigma^2 on either scale: both scale by
        // the same factor).
        let rx_inv = factor.rx_inv();
        let scale2 = self.y_scale * self.y_scale;
        let (deviance, sigma2) = match criterion {
            Criterion::Ml => {
                let nf = n as f64;
                (
                    log_det_l2 - self.log_w + nf * (1.0 + (2.0 * std::f64::consts::PI * r2_std * scale2 / nf).ln()),
                    r2_std * scale2 / nf,
                )
            }
            Criterion::Reml => {
                let df = (n - p) as f64;
                (
                    log_det_l2 + log_det_rx2 - self.log_w
                        + df * (1.0 + (2.0 * std::f64::consts::PI * r2_std * scale2 / df).ln()),
                    r2_std * scale2 / df,
                )
            }
        };
        let mut beta: Vec<f64> = beta_std.iter().map(|v| v * self.y_scale).collect();
        beta[0] += self.y_mean;
        Ok(Eval { deviance, beta, sigma2, log_det_l2, log_det_rx2, r2_std, rx_inv })
    }
}
