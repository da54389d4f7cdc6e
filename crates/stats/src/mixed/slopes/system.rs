//! The penalized least-squares system of a random-slope model at one
//! theta, over every level of every term, factored densely.
//!
//! The cross-products Z'Z, Z'X, X'X, Z'y and X'y are formed once, of the
//! standardized response (centred, divided by its standard deviation, as
//! the random-intercept system does); at each theta the system
//! [Lambda'Z'Z Lambda + I, Lambda'Z'X; X'Z Lambda, X'X] is formed block by
//! block (Lambda is block diagonal with one k_t x k_t block per level) and
//! factored as [L 0; R' R_X'], so that log|L|^2 and log|R_X|^2 are sums
//! of the logarithms of its diagonal. The penalized residual sum of
//! squares is computed from the solution itself,
//! |y - X beta - Z Lambda u|^2 + |u|^2, not as a difference of squares.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

use super::structure::Structure;
use super::Term;
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
    ztz: Mat<f64>,
    ztx: Mat<f64>,
    xtx: Mat<f64>,
    zty: Vec<f64>,
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
    pub fn new(base: &MixedData, terms: &[Term]) -> Result<System, MixedError> {
        let n = base.len();
        let p = base.p();
        let y_mean = base.y.iter().sum::<f64>() / n as f64;
        let sd = (base.y.iter().map(|v| (v - y_mean).powi(2)).sum::<f64>() / (n as f64 - 1.0)).sqrt();
        let y_scale = if sd.is_finite() && sd > 0.0 { sd } else { 1.0 };
        let y: Vec<f64> = base.y.iter().map(|v| (v - y_mean) / y_scale).collect();
        let x = base.design();
        let structure = Structure::new(terms, n);
        let q = structure.q;
        let mut ztz = Mat::<f64>::zeros(q, q);
        let mut ztx = Mat::<f64>::zeros(q, p);
        let mut xtx = Mat::<f64>::zeros(p, p);
        let (mut zty, mut xty) = (vec![0.0; q], vec![0.0; p]);
        for (i, row) in structure.z_rows.iter().enumerate() {
            let xi = &x[i * p..(i + 1) * p];
            for &(a, va) in row {
                zty[a] += va * y[i];
                for &(b, vb) in row {
                    ztz[(a, b)] += va * vb;
                }
                for (c, xc) in xi.iter().enumerate() {
                    ztx[(a, c)] += va * xc;
                }
            }
            for (c, xc) in xi.iter().enumerate() {
                xty[c] += xc * y[i];
                for (d, xd) in xi.iter().enumerate() {
                    xtx[(c, d)] += xc * xd;
                }
            }
        }
        if !ztz.norm_l2().is_finite() || !xtx.norm_l2().is_finite() {
            return Err(MixedError::TooLarge("the random-effect columns' products overflow double precision".into()));
        }
        Ok(System { n, p, y_mean, y_scale, y, x, structure, ztz, ztx, xtx, zty, xty })
    }

    /// The deviance and estimates at `theta`.
    pub fn evaluate(&self, theta: &[f64], criterion: Criterion) -> Result<Eval, MixedError> {
        let st = &self.structure;
        let (q, p, n) = (st.q, self.p, self.n);
        let lambda = st.lambda(theta);
        // Lambda' Z'Z Lambda: columns, then (by symmetry) rows.
        let mut a = self.ztz.clone();
        st.times_lambda(&mut a, &lambda);
        let mut a = a.transpose().to_owned();
        st.times_lambda(&mut a, &lambda);
        // Lambda' Z'X and Lambda' Z'y: columns of their transposes.
        let mut bt = self.ztx.transpose().to_owned();
        st.times_lambda(&mut bt, &lambda);
        let mut cu = Mat::<f64>::from_fn(1, q, |_, j| self.zty[j]);
        st.times_lambda(&mut cu, &lambda);
        let mut m = Mat::<f64>::zeros(q + p, q + p);
        for i in 0..q {
            for j in 0..=i {
                m[(i, j)] = 0.5 * (a[(i, j)] + a[(j, i)]) + if i == j { 1.0 } else { 0.0 };
            }
        }
        for c in 0..p {
            for j in 0..q {
                m[(q + c, j)] = bt[(c, j)];
            }
            for d in 0..=c {
                m[(q + c, q + d)] = self.xtx[(c, d)];
            }
        }
        let not_pd = || MixedError::NotPositiveDefinite { theta: theta.to_vec() };
        let llt = m.llt(Side::Lower).map_err(|_| not_pd())?;
        let l = llt.L();
        let log_det_l2: f64 = (0..q).map(|i| 2.0 * l[(i, i)].ln()).sum();
        let log_det_rx2: f64 = (q..q + p).map(|i| 2.0 * l[(i, i)].ln()).sum();
        if !log_det_l2.is_finite() || !log_det_rx2.is_finite() {
            return Err(not_pd());
        }
        let rhs = Mat::<f64>::from_fn(q + p, 1, |i, _| if i < q { cu[(0, i)] } else { self.xty[i - q] });
        let sol = llt.solve(&rhs);
        let u: Vec<f64> = (0..q).map(|i| sol[(i, 0)]).collect();
        let beta_std: Vec<f64> = (0..p).map(|c| sol[(q + c, 0)]).collect();
        // b = Lambda u, then the residuals row by row.
        let b = st.lambda_times(&lambda, &u);
        let mut r2_std: f64 = u.iter().map(|v| v * v).sum();
        for i in 0..n {
            let fitted: f64 = (0..p).map(|c| self.x[i * p + c] * beta_std[c]).sum::<f64>()
                + st.z_rows[i].iter().map(|&(j, v)| v * b[j]).sum::<f64>();
            r2_std += (self.y[i] - fitted).powi(2);
        }
        // (R_X'R_X)^-1 = L_X^-T L_X^-1, L_X the fixed-effect block of the
        // factor (Var(beta) / sigma^2 on either scale: both scale by the
        // same factor).
        let mut w = Mat::<f64>::identity(p, p);
        let lx = l.submatrix(q, q, p, p);
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(lx, w.as_mut(), faer::Par::Seq);
        let rx_inv = w.transpose() * &w;
        let scale2 = self.y_scale * self.y_scale;
        let (deviance, sigma2) = match criterion {
            Criterion::Ml => {
                let nf = n as f64;
                (
                    log_det_l2 + nf * (1.0 + (2.0 * std::f64::consts::PI * r2_std * scale2 / nf).ln()),
                    r2_std * scale2 / nf,
                )
            }
            Criterion::Reml => {
                let df = (n - p) as f64;
                (
                    log_det_l2 + log_det_rx2 + df * (1.0 + (2.0 * std::f64::consts::PI * r2_std * scale2 / df).ln()),
                    r2_std * scale2 / df,
                )
            }
        };
        let mut beta: Vec<f64> = beta_std.iter().map(|v| v * self.y_scale).collect();
        beta[0] += self.y_mean;
        Ok(Eval { deviance, beta, sigma2, log_det_l2, log_det_rx2, r2_std, rx_inv })
    }
}
