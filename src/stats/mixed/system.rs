//! The penalized least-squares system of one theta, solved by eliminating
//! the largest random factor first.
//!
//! With u = (u1, u2), u1 the levels of the factor with the most levels and
//! u2 those of every other factor, the system for (u, beta) is
//!
//! ```text
//! [ D       B2     BX  ] [u1  ]   [ c1 ]
//! [ B2'     A22    A2X ] [u2  ] = [ c2 ]
//! [ BX'     A2X'   X'X ] [beta]   [ cX ]
//! ```
//!
//! where D = theta1^2 diag(n_s) + I is diagonal (each observation has one
//! level of a factor), so u1 is eliminated exactly and what is left is a
//! dense system of the other factors' levels plus the fixed effects:
//! M = [A22 A2X; A2X' X'X] - sum_s b_s b_s' / D_s, with b_s the sparse row s
//! of [B2 BX]. Its Cholesky factor [L22 0; R L_X] gives
//! log|Lambda'Z'Z Lambda + I| = sum log D_s + log|L22|^2 and
//! log|R_X|^2 = log|L_X|^2 (lme4's R_X is the Cholesky factor of the
//! fixed-effect Schur complement, L_X here). The elimination costs
//! sum_s nnz(b_s)^2, so InstEval (2,972 students crossed with 1,128
//! lecturers) factors a 1,129 x 1,129 matrix instead of 4,101 x 4,101.

use std::cell::RefCell;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch, LltParams};
use faer::linalg::triangular_solve::{solve_lower_triangular_in_place, solve_upper_triangular_in_place};
use faer::{Auto, Mat, Par};

use super::{Criterion, MixedData, MixedError};

/// The cross-products the deviance needs, computed once.
pub(super) struct System {
    /// Observations and fixed-effect columns.
    pub n: f64,
    pub p: usize,
    /// The response, centred at `y_mean` (the intercept is shifted back).
    pub y: Vec<f64>,
    pub y_mean: f64,
    /// Fixed-effect design, n x p row-major; column 0 is the intercept.
    pub x: Vec<f64>,
    /// Level of each factor per observation, n x k row-major.
    pub codes: Vec<usize>,
    /// Levels per factor.
    pub levels: Vec<usize>,
    /// The eliminated factor.
    pub first: usize,
    /// Column of each (non-eliminated) factor's first level in the dense
    /// block; `usize::MAX` for the eliminated factor.
    dense_offset: Vec<usize>,
    /// Factor of each dense column.
    dense_factor: Vec<usize>,
    /// Dense random-effect columns (q2).
    q2: usize,
    /// Per level s of the eliminated factor: n_s, Z1'y, Z1'X (p each) and
    /// the sparse row of Z1'Z2 as (dense column, count), sorted.
    ns: Vec<f64>,
    z1y: Vec<f64>,
    z1x: Vec<f64>,
    row_start: Vec<usize>,
    row: Vec<(usize, f64)>,
    /// Z2'Z2 (q2 x q2, lower triangle used), Z2'X (q2 x p), X'X, Z2'y, X'y.
    z2z2: Mat<f64>,
    z2x: Mat<f64>,
    pub xtx: Mat<f64>,
    z2y: Vec<f64>,
    xty: Vec<f64>,
    /// The dense matrix and the factorization's scratch, reused by every
    /// evaluation: allocating 10 MB afresh (InstEval) costs a third of a
    /// factorization in page faults.
    work: RefCell<(Mat<f64>, MemBuffer)>,
}

/// The deviance and the estimates at one theta.
#[derive(Debug, Clone)]
pub(super) struct Eval {
    pub deviance: f64,
    /// Fixed effects (the intercept shifted back by the centring).
    pub beta: Vec<f64>,
    pub sigma2: f64,
    /// log|Lambda'Z'Z Lambda + I| and log|R_X|^2.
    pub log_det_l2: f64,
    pub log_det_rx2: f64,
    /// Penalized residual sum of squares.
    pub r2: f64,
    /// (R_X'R_X)^-1 = Var(beta) / sigma^2, p x p.
    pub rx_inv: Mat<f64>,
}

impl System {
    pub fn new(d: &MixedData) -> System {
        let n = d.y.len();
        let k = d.factors.len();
        let p = d.p();
        let levels: Vec<usize> = d.factors.iter().map(|f| f.levels).collect();
        let first = (0..k).max_by_key(|&j| (levels[j], std::cmp::Reverse(j))).unwrap_or(0);
        let mut dense_offset = vec![usize::MAX; k];
        let mut dense_factor = Vec::new();
        for j in (0..k).filter(|&j| j != first) {
            dense_offset[j] = dense_factor.len();
            dense_factor.extend(std::iter::repeat_n(j, levels[j]));
        }
        let q2 = dense_factor.len();
        // Centring y keeps the penalized residual sum of squares from being a
        // small difference of large sums.
        let y_mean = d.y.iter().sum::<f64>() / n as f64;
        let y: Vec<f64> = d.y.iter().map(|v| v - y_mean).collect();
        let x = d.design();
        let codes: Vec<usize> = (0..n).flat_map(|i| d.factors.iter().map(move |f| f.codes[i])).collect();
        let n1 = levels[first];
        let (mut ns, mut z1y, mut z1x) = (vec![0.0; n1], vec![0.0; n1], vec![0.0; n1 * p]);
        let mut rows: Vec<std::collections::BTreeMap<usize, f64>> = vec![Default::default(); n1];
        let mut z2z2 = Mat::<f64>::zeros(q2, q2);
        let mut z2x = Mat::<f64>::zeros(q2, p);
        let mut xtx = Mat::<f64>::zeros(p, p);
        let (mut z2y, mut xty) = (vec![0.0; q2], vec![0.0; p]);
        let mut dense = Vec::with_capacity(k);
        for i in 0..n {
            let c = &codes[i * k..(i + 1) * k];
            let xi = &x[i * p..(i + 1) * p];
            let s = c[first];
            ns[s] += 1.0;
            z1y[s] += y[i];
            dense.clear();
            dense.extend((0..k).filter(|&j| j != first).map(|j| dense_offset[j] + c[j]));
            for &a in &dense {
                *rows[s].entry(a).or_insert(0.0) += 1.0;
                z2y[a] += y[i];
                for &b in &dense {
                    z2z2[(a, b)] += 1.0;
                }
                for (col, v) in xi.iter().enumerate() {
                    z2x[(a, col)] += v;
                }
            }
            for (col, v) in xi.iter().enumerate() {
                z1x[s * p + col] += v;
                xty[col] += v * y[i];
                for (col2, w) in xi.iter().enumerate() {
                    xtx[(col, col2)] += v * w;
                }
            }
        }
        let m = q2 + p;
        let scratch = cholesky_in_place_scratch::<f64>(m, Par::Seq, <LltParams as Auto<f64>>::auto().into());
        let work = RefCell::new((Mat::zeros(m, m), MemBuffer::new(scratch)));
        let mut row_start = vec![0];
        let mut row = Vec::new();
        for r in rows {
            row.extend(r);
            row_start.push(row.len());
        }
        System {
            n: n as f64,
            p,
            y,
            y_mean,
            x,
            codes,
            levels,
            first,
            dense_offset,
            dense_factor,
            q2,
            ns,
            z1y,
            z1x,
            row_start,
            row,
            z2z2,
            z2x,
            xtx,
            z2y,
            xty,
            work,
        }
    }

    /// Number of random factors.
    pub fn factors(&self) -> usize {
        self.levels.len()
    }

    /// Solves the system at `theta` and returns the profiled deviance.
    pub fn evaluate(&self, theta: &[f64], criterion: Criterion) -> Result<Eval, MixedError> {
        let (p, q2, k) = (self.p, self.q2, self.factors());
        let m = q2 + p;
        let t1 = theta[self.first];
        let lam: Vec<f64> = self.dense_factor.iter().map(|&j| theta[j]).collect();
        // Lower triangle of M before the elimination, and the right side.
        let mut work = self.work.borrow_mut();
        let (a, buffer) = &mut *work;
        for j in 0..q2 {
            for i in j..q2 {
                a[(i, j)] = lam[i] * self.z2z2[(i, j)] * lam[j];
            }
            a[(j, j)] += 1.0;
            for c in 0..p {
                a[(q2 + c, j)] = lam[j] * self.z2x[(j, c)];
            }
        }
        for c in 0..p {
            for c2 in 0..=c {
                a[(q2 + c, q2 + c2)] = self.xtx[(c, c2)];
            }
        }
        let mut rhs: Vec<f64> = (0..q2).map(|i| lam[i] * self.z2y[i]).chain(self.xty.iter().copied()).collect();
        // Eliminate u1: M -= w_s v_s v_s', rhs -= w_s z1y_s v_s, with
        // v_s = [Lambda2 (Z1'Z2)_s, (Z1'X)_s] and w_s = theta1^2 / D_s.
        let mut log_det_d = 0.0;
        let t1sq = t1 * t1;
        let mut idx: Vec<usize> = Vec::new();
        let mut val: Vec<f64> = Vec::new();
        for s in 0..self.ns.len() {
            let ds = t1sq * self.ns[s] + 1.0;
            log_det_d += ds.ln();
            if t1sq == 0.0 {
                continue;
            }
            let w = t1sq / ds;
            idx.clear();
            val.clear();
            for &(col, cnt) in &self.row[self.row_start[s]..self.row_start[s + 1]] {
                idx.push(col);
                val.push(lam[col] * cnt);
            }
            for c in 0..p {
                idx.push(q2 + c);
                val.push(self.z1x[s * p + c]);
            }
            for (e, (&i, &vi)) in idx.iter().zip(&val).enumerate() {
                let wvi = w * vi;
                rhs[i] -= wvi * self.z1y[s];
                for (&j, &vj) in idx[..=e].iter().zip(&val[..=e]) {
                    a[(i, j)] -= wvi * vj;
                }
            }
        }
        cholesky_in_place(
            a.as_mut(),
            Default::default(),
            Par::Seq,
            MemStack::new(buffer),
            <LltParams as Auto<f64>>::auto().into(),
        )
        .map_err(|_| MixedError::NotPositiveDefinite { theta: theta.to_vec() })?;
        let l = a.as_ref();
        let mut log_det_l2 = log_det_d;
        let mut log_det_rx2 = 0.0;
        for i in 0..m {
            let v = 2.0 * l[(i, i)].ln();
            if i < q2 {
                log_det_l2 += v;
            } else {
                log_det_rx2 += v;
            }
        }
        let mut sol = Mat::<f64>::from_fn(m, 1, |i, _| rhs[i]);
        solve_lower_triangular_in_place(l, sol.as_mut(), Par::Seq);
        solve_upper_triangular_in_place(l.transpose(), sol.as_mut(), Par::Seq);
        let beta_c: Vec<f64> = (0..p).map(|c| sol[(q2 + c, 0)]).collect();
        // Back-substitute u1 and form b = Lambda u on the data scale.
        let mut r2 = 0.0;
        let b1: Vec<f64> = (0..self.ns.len())
            .map(|s| {
                let ds = t1sq * self.ns[s] + 1.0;
                let mut dot: f64 = self.row[self.row_start[s]..self.row_start[s + 1]]
                    .iter()
                    .map(|&(c, n)| lam[c] * n * sol[(c, 0)])
                    .sum();
                dot += (0..p).map(|c| self.z1x[s * p + c] * beta_c[c]).sum::<f64>();
                let u1 = t1 * (self.z1y[s] - dot) / ds;
                r2 += u1 * u1;
                t1 * u1
            })
            .collect();
        let b2: Vec<f64> = (0..q2)
            .map(|i| {
                let u = sol[(i, 0)];
                r2 += u * u;
                lam[i] * u
            })
            .collect();
        for (i, yi) in self.y.iter().enumerate() {
            let c = &self.codes[i * k..(i + 1) * k];
            let mut fitted: f64 = self.x[i * p..(i + 1) * p].iter().zip(&beta_c).map(|(x, b)| x * b).sum();
            for (j, &code) in c.iter().enumerate() {
                fitted += if j == self.first { b1[code] } else { b2[self.dense_offset[j] + code] };
            }
            r2 += (yi - fitted).powi(2);
        }
        let r2 = r2.max(f64::MIN_POSITIVE);
        // (R_X'R_X)^-1 = L_X^-T L_X^-1.
        let mut rx_inv = Mat::<f64>::identity(p, p);
        let lx = l.submatrix(q2, q2, p, p);
        solve_lower_triangular_in_place(lx, rx_inv.as_mut(), Par::Seq);
        solve_upper_triangular_in_place(lx.transpose(), rx_inv.as_mut(), Par::Seq);
        let mut beta = beta_c;
        beta[0] += self.y_mean;
        let two_pi = 2.0 * std::f64::consts::PI;
        let n = self.n;
        let (deviance, sigma2) = match criterion {
            Criterion::Ml => (log_det_l2 + n * (1.0 + (two_pi * r2 / n).ln()), r2 / n),
            Criterion::Reml => {
                let dof = n - p as f64;
                (log_det_l2 + log_det_rx2 + dof * (1.0 + (two_pi * r2 / dof).ln()), r2 / dof)
            }
        };
        Ok(Eval { deviance, beta, sigma2, log_det_l2, log_det_rx2, r2, rx_inv })
    }

    /// A starting theta from one-way analyses of variance, factor by
    /// factor: sigma_j^2 = (MS_between - MS_within) / n0 (n0 the effective
    /// level size), each relative to the smallest MS_within. Each ignores
    /// the other factors, so it is only a start (near the optimum when
    /// the factors are crossed and roughly balanced); 1 where undefined,
    /// and kept in [0.05, 1000].
    /// With fixed effects beyond the intercept the analyses are of the
    /// ordinary least-squares residuals, so that a fixed effect that
    /// varies between a factor's levels is not taken for that factor's
    /// variance (which can start the search in the wrong basin).
    pub fn moment_start(&self) -> Vec<f64> {
        let k = self.factors();
        let n = self.n;
        let residuals = self.ols_residuals();
        let y = residuals.as_deref().unwrap_or(&self.y);
        let mut between = vec![0.0; k];
        let mut within = vec![f64::INFINITY; k];
        let mut n0 = vec![0.0; k];
        for j in 0..k {
            let l = self.levels[j];
            let (mut sum, mut cnt) = (vec![0.0; l], vec![0.0; l]);
            for (i, y) in y.iter().enumerate() {
                sum[self.codes[i * k + j]] += y;
                cnt[self.codes[i * k + j]] += 1.0;
            }
            let mean = |a: usize| sum[a] / cnt[a];
            let ssb: f64 = (0..l).map(|a| cnt[a] * mean(a) * mean(a)).sum::<f64>() - y.iter().sum::<f64>().powi(2) / n;
            let ssw: f64 = y.iter().enumerate().map(|(i, y)| (y - mean(self.codes[i * k + j])).powi(2)).sum();
            if n > l as f64 {
                within[j] = ssw / (n - l as f64);
            }
            between[j] = ssb / (l as f64 - 1.0);
            n0[j] = (n - cnt.iter().map(|c| c * c).sum::<f64>() / n) / (l as f64 - 1.0);
        }
        let residual = within.iter().copied().fold(f64::INFINITY, f64::min);
        // A within-level variance that is rounding (a factor reproducing the
        // response) gives no usable ratio; theta is kept in [0.05, 1000].
        let total = y.iter().map(|v| v * v).sum::<f64>() / (n - 1.0);
        (0..k)
            .map(|j| {
                let w = if within[j].is_finite() { within[j] } else { residual };
                let v = (between[j] - w) / n0[j];
                if residual.is_finite() && residual > 1e-10 * total && v.is_finite() {
                    (v.max(0.0) / residual).sqrt().clamp(0.05, 1e3)
                } else {
                    1.0
                }
            })
            .collect()
    }

    /// y - X beta by ordinary least squares; `None` for an intercept-only
    /// model (the centred response already is that) or a singular X'X.
    fn ols_residuals(&self) -> Option<Vec<f64>> {
        use faer::linalg::solvers::Solve;
        if self.p == 1 {
            return None;
        }
        let llt = self.xtx.llt(faer::Side::Lower).ok()?;
        let beta = llt.solve(Mat::<f64>::from_fn(self.p, 1, |i, _| self.xty[i]));
        Some(
            self.y
                .iter()
                .enumerate()
                .map(|(i, yi)| yi - (0..self.p).map(|c| self.x[i * self.p + c] * beta[(c, 0)]).sum::<f64>())
                .collect(),
        )
    }

    /// The deviance at `theta` and `sigma`, not profiled over sigma
    /// (lmerTest's parameterization for the Satterthwaite Hessian, lme4's
    /// for its profiles), and the solution there:
    /// REML: log|L|^2 + log|R_X|^2 + (n - p) log(2 pi sigma^2) + r^2 / sigma^2;
    /// ML: log|L|^2 + n log(2 pi sigma^2) + r^2 / sigma^2.
    pub fn unprofiled(&self, theta: &[f64], sigma: f64, criterion: Criterion) -> Result<(f64, Eval), MixedError> {
        let e = self.evaluate(theta, criterion)?;
        let s2 = sigma * sigma;
        let log_2pi_s2 = (2.0 * std::f64::consts::PI * s2).ln();
        let dev = match criterion {
            Criterion::Reml => e.log_det_l2 + e.log_det_rx2 + (self.n - self.p as f64) * log_2pi_s2 + e.r2 / s2,
            Criterion::Ml => e.log_det_l2 + self.n * log_2pi_s2 + e.r2 / s2,
        };
        Ok((dev, e))
    }

    /// Z'Z over all q levels (factors in order), Z'X (q x p) and the factor
    /// of each level: the dense products Kenward-Roger works with.
    pub fn dense_products(&self) -> (Mat<f64>, Mat<f64>, Vec<usize>) {
        let (k, p) = (self.factors(), self.p);
        let offsets: Vec<usize> = self
            .levels
            .iter()
            .scan(0, |acc, l| {
                let o = *acc;
                *acc += l;
                Some(o)
            })
            .collect();
        let q: usize = self.levels.iter().sum();
        let mut ztz = Mat::<f64>::zeros(q, q);
        let mut ztx = Mat::<f64>::zeros(q, p);
        for i in 0..self.y.len() {
            let cols: Vec<usize> = (0..k).map(|j| offsets[j] + self.codes[i * k + j]).collect();
            for &a in &cols {
                for &b in &cols {
                    ztz[(a, b)] += 1.0;
                }
                for c in 0..p {
                    ztx[(a, c)] += self.x[i * p + c];
                }
            }
        }
        let factor_of = (0..k).flat_map(|j| std::iter::repeat_n(j, self.levels[j])).collect();
        (ztz, ztx, factor_of)
    }
}
