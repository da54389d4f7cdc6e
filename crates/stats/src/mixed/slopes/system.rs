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

use super::Term;
use crate::mixed::{Criterion, MixedData, MixedError};

/// The products a deviance evaluation needs, computed once.
pub(super) struct System {
    pub n: usize,
    pub p: usize,
    /// Random effects over every level of every term.
    q: usize,
    pub y_mean: f64,
    pub y_scale: f64,
    /// The standardized response and the design, n x p row-major.
    y: Vec<f64>,
    x: Vec<f64>,
    /// Per term: columns k, first column in u, and the block of each level
    /// starts at offset + level * k.
    blocks: Vec<(usize, usize)>,
    /// Per theta parameter, the root mean square of the column of Z its
    /// row of T multiplies (1 for an intercept).
    scales: Vec<f64>,
    /// Per observation, its nonzero entries of Z as (column, value).
    z_rows: Vec<Vec<(usize, f64)>>,
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

/// The k x k lower triangular block, row-major, from its entries column
/// by column (lme4's theta order).
pub(super) fn lower_triangle(theta: &[f64], k: usize) -> Vec<f64> {
    let mut t = vec![0.0; k * k];
    let mut at = 0;
    for j in 0..k {
        for i in j..k {
            t[i * k + j] = theta[at];
            at += 1;
        }
    }
    t
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
        let mut blocks = Vec::new();
        let mut q = 0;
        let mut scales = Vec::new();
        for t in terms {
            let k = t.columns.len();
            blocks.push((k, q));
            q += t.levels * k;
            let rms: Vec<f64> = t
                .columns
                .iter()
                .map(|c| {
                    let r = (c.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
                    if r.is_finite() && r > 0.0 {
                        r
                    } else {
                        1.0
                    }
                })
                .collect();
            for j in 0..k {
                scales.extend(rms[j..].iter().copied());
            }
        }
        let z_rows: Vec<Vec<(usize, f64)>> = (0..n)
            .map(|i| {
                terms
                    .iter()
                    .zip(&blocks)
                    .flat_map(|(t, &(k, offset))| {
                        let start = offset + t.codes[i] * k;
                        t.columns.iter().enumerate().map(move |(j, c)| (start + j, c[i]))
                    })
                    .collect()
            })
            .collect();
        let mut ztz = Mat::<f64>::zeros(q, q);
        let mut ztx = Mat::<f64>::zeros(q, p);
        let mut xtx = Mat::<f64>::zeros(p, p);
        let (mut zty, mut xty) = (vec![0.0; q], vec![0.0; p]);
        for (i, row) in z_rows.iter().enumerate() {
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
        Ok(System { n, p, q, y_mean, y_scale, y, x, blocks, scales, z_rows, ztz, ztx, xtx, zty, xty })
    }

    /// Per theta parameter, its scale: theta_k times its scale is the
    /// entry of T for the column of Z divided by its root mean square, a
    /// parameterization in which every entry is of the order of the
    /// standard deviations' ratio whatever the columns' units (a slope in
    /// a temperature of 200 has an entry 200 times smaller than its
    /// intercept's in lme4's theta).
    pub fn scales(&self) -> &[f64] {
        &self.scales
    }

    /// Number of theta parameters.
    pub fn parameters(&self) -> usize {
        self.blocks.iter().map(|(k, _)| k * (k + 1) / 2).sum()
    }

    /// The positions in theta of the diagonal entries (lme4's lower bound
    /// 0, the ones `isSingular` reads).
    pub fn diagonal(&self) -> Vec<usize> {
        let mut out = Vec::new();
        let mut at = 0;
        for &(k, _) in &self.blocks {
            for j in 0..k {
                out.push(at);
                at += k - j;
            }
        }
        out
    }

    /// `theta` with each column of each T whose diagonal entry is negative
    /// negated: the same T T', in lme4's parameterization.
    pub fn normalized(&self, theta: &[f64]) -> Vec<f64> {
        let mut out = theta.to_vec();
        let mut at = 0;
        for &(k, _) in &self.blocks {
            for j in 0..k {
                let column = at..at + (k - j);
                if out[at] < 0.0 {
                    out[column].iter_mut().for_each(|v| *v = -*v);
                }
                at += k - j;
            }
        }
        out
    }

    /// lme4's start: every diagonal entry 1, the rest 0.
    pub fn start(&self) -> Vec<f64> {
        let mut theta = vec![0.0; self.parameters()];
        for j in self.diagonal() {
            theta[j] = 1.0;
        }
        theta
    }

    /// Each term's block T, row-major.
    fn lambda(&self, theta: &[f64]) -> Vec<Vec<f64>> {
        let mut at = 0;
        self.blocks
            .iter()
            .map(|&(k, _)| {
                let t = lower_triangle(&theta[at..at + k * (k + 1) / 2], k);
                at += k * (k + 1) / 2;
                t
            })
            .collect()
    }

    /// Right-multiplies the rows of `m` (q columns) by the block diagonal
    /// matrix of `blocks` (one per term, row-major, repeated over its
    /// levels), in place.
    fn times_lambda(&self, m: &mut Mat<f64>, lambda: &[Vec<f64>], levels_of: impl Fn(usize) -> usize) {
        let rows = m.nrows();
        for (b, &(k, offset)) in self.blocks.iter().enumerate() {
            let t = &lambda[b];
            let mut tmp = vec![0.0; k];
            for level in 0..levels_of(b) {
                let c0 = offset + level * k;
                for r in 0..rows {
                    for (jj, out) in tmp.iter_mut().enumerate() {
                        *out = (0..k).map(|j| m[(r, c0 + j)] * t[j * k + jj]).sum();
                    }
                    for (jj, v) in tmp.iter().enumerate() {
                        m[(r, c0 + jj)] = *v;
                    }
                }
            }
        }
    }

    /// The deviance and estimates at `theta`.
    pub fn evaluate(&self, theta: &[f64], criterion: Criterion) -> Result<Eval, MixedError> {
        let (q, p, n) = (self.q, self.p, self.n);
        let lambda = self.lambda(theta);
        let levels = |b: usize| {
            let (k, offset) = self.blocks[b];
            let end = self.blocks.get(b + 1).map_or(q, |&(_, o)| o);
            (end - offset) / k
        };
        // Lambda' Z'Z Lambda: columns, then (by symmetry) rows.
        let mut a = self.ztz.clone();
        self.times_lambda(&mut a, &lambda, levels);
        let mut a = a.transpose().to_owned();
        self.times_lambda(&mut a, &lambda, levels);
        // Lambda' Z'X and Lambda' Z'y: columns of their transposes.
        let mut bt = self.ztx.transpose().to_owned();
        self.times_lambda(&mut bt, &lambda, levels);
        let mut cu = Mat::<f64>::from_fn(1, q, |_, j| self.zty[j]);
        self.times_lambda(&mut cu, &lambda, levels);
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
        let mut b = Mat::<f64>::from_fn(1, q, |_, j| u[j]);
        let mut lambda_t = lambda.clone();
        for (t, &(k, _)) in lambda_t.iter_mut().zip(&self.blocks) {
            *t = (0..k * k).map(|ij| t[(ij % k) * k + ij / k]).collect();
        }
        self.times_lambda(&mut b, &lambda_t, levels);
        let mut r2_std: f64 = u.iter().map(|v| v * v).sum();
        for i in 0..n {
            let fitted: f64 = (0..p).map(|c| self.x[i * p + c] * beta_std[c]).sum::<f64>()
                + self.z_rows[i].iter().map(|&(j, v)| v * b[(0, j)]).sum::<f64>();
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
