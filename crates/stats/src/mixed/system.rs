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

use std::sync::Mutex;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch, LltParams};
use faer::linalg::triangular_solve::{solve_lower_triangular_in_place, solve_upper_triangular_in_place};
use faer::{Auto, Mat, Par};

use super::levels::LevelEntries;
use super::{Criterion, MixedData, MixedError};

/// The cross-products the deviance needs, computed once.
///
/// The response is standardized (centred and divided by its standard
/// deviation) and every quantity below is of the standardized response;
/// [`System::evaluate`] returns the estimates and the deviance on the
/// response's own scale. A shift or a rescaling of y then changes nothing
/// but that last step, so the df and every ratio are the same for y and
/// a + b y to rounding.
///
/// The eliminated factor's level means are removed exactly: the products of
/// the other columns are kept as within-level scatter (about the eliminated
/// factor's level means, computed from within-level deviations so that a
/// column constant within every level, such as the intercept, has exactly
/// zero scatter) plus the level sums. For a given theta_1 the reduced
/// system is then W + sum_s c_s v_s v_s' with
/// c_s = 1 / (n_s (theta_1^2 n_s + 1)) > 0: a sum of positive
/// semi-definite terms, where the textbook form X'X - sum_s w_s v_s v_s'
/// subtracts two numbers that agree to log10(theta_1^2 n_s) digits (all
/// of them for a variance ratio of 1e16).
pub(super) struct System {
    /// Observations and fixed-effect columns.
    pub n: f64,
    pub p: usize,
    /// The response, centred at `y_mean` and divided by `y_scale`.
    pub y: Vec<f64>,
    pub y_mean: f64,
    pub y_scale: f64,
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
    /// Per level s of the eliminated factor: n_s, its sums Z1'y and Z1'X
    /// (p each), the mean of y and of X, and the sparse row of Z1'Z2 as
    /// (dense column, count), sorted.
    ns: Vec<f64>,
    z1y: Vec<f64>,
    z1x: Vec<f64>,
    ybar: Vec<f64>,
    xbar: Vec<f64>,
    row_start: Vec<usize>,
    row: Vec<(usize, f64)>,
    /// Per observation: y and X less their level's means (exactly zero for
    /// a column constant within the level).
    ry: Vec<f64>,
    rx: Vec<f64>,
    /// Within-level scatter: of Z2 (q2 x q2, lower triangle used), of Z2
    /// with X (q2 x p), of X (p x p), of Z2 and X with y.
    wz2z2: Mat<f64>,
    wz2x: Mat<f64>,
    wxx: Mat<f64>,
    wz2y: Vec<f64>,
    wxy: Vec<f64>,
    /// X'X and X'y (y standardized), for the rank check and the start.
    pub xtx: Mat<f64>,
    xty: Vec<f64>,
    /// Where each level of the eliminated factor writes, by column.
    entries: LevelEntries,
    /// Dense matrices and factorization scratch, reused by every evaluation
    /// (allocating 10 MB afresh, on InstEval, costs a third of a
    /// factorization in page faults): one per evaluation running at once,
    /// so that evaluations may run in parallel.
    work: Mutex<Vec<Work>>,
}

/// One evaluation's dense matrix and factorization scratch.
type Work = (Mat<f64>, MemBuffer);

/// The deviance and the estimates at one theta, on the response's scale.
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
    /// The same of the standardized response.
    pub r2_std: f64,
    /// (R_X'R_X)^-1 = Var(beta) / sigma^2, p x p.
    pub rx_inv: Mat<f64>,
}

/// The mean of `values`, exactly their common value when they are all equal.
fn exact_mean(values: impl Iterator<Item = f64> + Clone) -> f64 {
    let mut it = values.clone();
    let Some(first) = it.next() else { return 0.0 };
    if it.all(|v| v == first) {
        return first;
    }
    let (sum, count) = values.fold((0.0, 0.0), |(s, c), v| (s + v, c + 1.0));
    sum / count
}

impl System {
    /// The system with the factor with the most levels eliminated.
    pub fn new(d: &MixedData) -> System {
        let levels: Vec<usize> = d.factors.iter().map(|f| f.levels).collect();
        let first = (0..levels.len()).max_by_key(|&j| (levels[j], std::cmp::Reverse(j))).unwrap_or(0);
        System::eliminating(d, first)
    }

    /// The system with factor `first` eliminated.
    pub fn eliminating(d: &MixedData, first: usize) -> System {
        let n = d.y.len();
        let k = d.factors.len();
        let p = d.p();
        let levels: Vec<usize> = d.factors.iter().map(|f| f.levels).collect();
        let mut dense_offset = vec![usize::MAX; k];
        let mut dense_factor = Vec::new();
        for j in (0..k).filter(|&j| j != first) {
            dense_offset[j] = dense_factor.len();
            dense_factor.extend(std::iter::repeat_n(j, levels[j]));
        }
        let q2 = dense_factor.len();
        let y_mean = d.y.iter().sum::<f64>() / n as f64;
        let centred: Vec<f64> = d.y.iter().map(|v| v - y_mean).collect();
        let sd = (centred.iter().map(|v| v * v).sum::<f64>() / (n as f64 - 1.0).max(1.0)).sqrt();
        let y_scale = if sd.is_finite() && sd > 0.0 { sd } else { 1.0 };
        let y: Vec<f64> = centred.iter().map(|v| v / y_scale).collect();
        let x = d.design();
        let codes: Vec<usize> = (0..n).flat_map(|i| d.factors.iter().map(move |f| f.codes[i])).collect();
        let n1 = levels[first];
        // Rows of each level of the eliminated factor.
        let mut members: Vec<Vec<usize>> = vec![Vec::new(); n1];
        for i in 0..n {
            members[codes[i * k + first]].push(i);
        }
        let (mut ns, mut z1y, mut z1x) = (vec![0.0; n1], vec![0.0; n1], vec![0.0; n1 * p]);
        let (mut ybar, mut xbar) = (vec![0.0; n1], vec![0.0; n1 * p]);
        let (mut ry, mut rx) = (vec![0.0; n], vec![0.0; n * p]);
        let mut rows: Vec<std::collections::BTreeMap<usize, f64>> = vec![Default::default(); n1];
        let mut wz2z2 = Mat::<f64>::zeros(q2, q2);
        let mut wz2x = Mat::<f64>::zeros(q2, p);
        let mut wxx = Mat::<f64>::zeros(p, p);
        let mut xtx = Mat::<f64>::zeros(p, p);
        let (mut wz2y, mut wxy, mut xty) = (vec![0.0; q2], vec![0.0; p], vec![0.0; p]);
        let dense_of = |i: usize| (0..k).filter(move |&j| j != first).map(move |j| (j, i));
        for (s, rows_s) in members.iter().enumerate() {
            ns[s] = rows_s.len() as f64;
            z1y[s] = rows_s.iter().map(|&i| y[i]).sum();
            ybar[s] = exact_mean(rows_s.iter().map(|&i| y[i]));
            for c in 0..p {
                z1x[s * p + c] = rows_s.iter().map(|&i| x[i * p + c]).sum();
                xbar[s * p + c] = exact_mean(rows_s.iter().map(|&i| x[i * p + c]));
            }
            let (mut sum_ry, mut sum_rx) = (0.0, vec![0.0; p]);
            for &i in rows_s {
                ry[i] = y[i] - ybar[s];
                sum_ry += ry[i];
                for c in 0..p {
                    rx[i * p + c] = x[i * p + c] - xbar[s * p + c];
                    sum_rx[c] += rx[i * p + c];
                }
                let xi = &x[i * p..(i + 1) * p];
                let rxi = &rx[i * p..(i + 1) * p];
                for c in 0..p {
                    xty[c] += xi[c] * y[i];
                    wxy[c] += rxi[c] * ry[i];
                    for c2 in 0..p {
                        xtx[(c, c2)] += xi[c] * xi[c2];
                        wxx[(c, c2)] += rxi[c] * rxi[c2];
                    }
                }
                for (j, i) in dense_of(i) {
                    let a = dense_offset[j] + codes[i * k + j];
                    *rows[s].entry(a).or_insert(0.0) += 1.0;
                    wz2y[a] += ry[i];
                    for c in 0..p {
                        wz2x[(a, c)] += rxi[c];
                    }
                    for (j2, _) in dense_of(i) {
                        wz2z2[(a, dense_offset[j2] + codes[i * k + j2])] += 1.0;
                    }
                }
            }
            // Less the level means: sum_i (z_i - zbar)(r_i) = sum_i z_i r_i -
            // zbar sum_i r_i, and Z2's own scatter less r r' / n_s.
            let nsf = ns[s];
            for (&a, &cnt) in &rows[s] {
                wz2y[a] -= cnt / nsf * sum_ry;
                for c in 0..p {
                    wz2x[(a, c)] -= cnt / nsf * sum_rx[c];
                }
                for (&b, &cnt2) in &rows[s] {
                    wz2z2[(a, b)] -= cnt * cnt2 / nsf;
                }
            }
        }
        let mut row_start = vec![0];
        let mut row = Vec::new();
        for r in rows {
            row.extend(r);
            row_start.push(row.len());
        }
        let entries = LevelEntries::new(&row_start, &row, q2, p);
        System {
            n: n as f64,
            p,
            y,
            y_mean,
            y_scale,
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
            ybar,
            xbar,
            row_start,
            row,
            ry,
            rx,
            wz2z2,
            wz2x,
            wxx,
            wz2y,
            wxy,
            xtx,
            xty,
            entries,
            work: Mutex::new(Vec::new()),
        }
    }

    /// A dense matrix and scratch for one evaluation: a free one, or a new one.
    fn take_work(&self) -> Work {
        let free = self.work.lock().unwrap_or_else(|e| e.into_inner()).pop();
        free.unwrap_or_else(|| {
            let m = self.q2 + self.p;
            let scratch = cholesky_in_place_scratch::<f64>(m, Par::Seq, <LltParams as Auto<f64>>::auto().into());
            (Mat::zeros(m, m), MemBuffer::new(scratch))
        })
    }

    /// Number of random factors.
    pub fn factors(&self) -> usize {
        self.levels.len()
    }

    /// Solves the system at `theta` and returns the profiled deviance.
    pub fn evaluate(&self, theta: &[f64], criterion: Criterion) -> Result<Eval, MixedError> {
        let mut work = self.take_work();
        let out = self.evaluate_in(&mut work, theta, criterion);
        self.work.lock().unwrap_or_else(|e| e.into_inner()).push(work);
        out
    }

    fn evaluate_in(&self, (a, buffer): &mut Work, theta: &[f64], criterion: Criterion) -> Result<Eval, MixedError> {
        let (p, q2, k) = (self.p, self.q2, self.factors());
        let m = q2 + p;
        let t1 = theta[self.first];
        let lam: Vec<f64> = self.dense_factor.iter().map(|&j| theta[j]).collect();
        // Lower triangle of the reduced system: the within-level scatter,
        // then each level's sums with weight c_s.
        for j in 0..q2 {
            for i in j..q2 {
                a[(i, j)] = lam[i] * self.wz2z2[(i, j)] * lam[j];
            }
            a[(j, j)] += 1.0;
            for c in 0..p {
                a[(q2 + c, j)] = lam[j] * self.wz2x[(j, c)];
            }
        }
        for c in 0..p {
            for c2 in 0..=c {
                a[(q2 + c, q2 + c2)] = self.wxx[(c, c2)];
            }
        }
        let mut rhs: Vec<f64> = (0..q2).map(|i| lam[i] * self.wz2y[i]).chain(self.wxy.iter().copied()).collect();
        // M += c_s v_s v_s', rhs += c_s z1y_s v_s, with v_s = [Lambda2
        // (Z1'Z2)_s, (Z1'X)_s] and c_s = 1 / (n_s D_s), D_s = theta1^2 n_s + 1.
        let mut log_det_d = 0.0;
        let t1sq = t1 * t1;
        let mut val: Vec<f64> = Vec::with_capacity(self.entries.len());
        let mut wval: Vec<f64> = Vec::with_capacity(self.entries.len());
        for s in 0..self.ns.len() {
            let ds = t1sq * self.ns[s] + 1.0;
            log_det_d += ds.ln();
            let w = 1.0 / (self.ns[s] * ds);
            val.extend(self.row[self.row_start[s]..self.row_start[s + 1]].iter().map(|&(col, cnt)| lam[col] * cnt));
            val.extend(&self.z1x[s * p..(s + 1) * p]);
            let (range, cols) = self.entries.of(s);
            wval.extend(val[range.clone()].iter().map(|&v| w * v));
            for (&i, &wvi) in cols.iter().zip(&wval[range]) {
                rhs[i] += wvi * self.z1y[s];
            }
        }
        self.entries.add_outer_products(a, &val, &wval);
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
        let b2: Vec<f64> = (0..q2).map(|i| lam[i] * sol[(i, 0)]).collect();
        let mut r2: f64 = (0..q2).map(|i| sol[(i, 0)] * sol[(i, 0)]).sum();
        // Per level: m_s, the level mean of X beta + Z2 b2, then u1 =
        // theta1 n_s (ybar_s - m_s) / D_s. Each residual is taken as its
        // within-level part plus what the level's mean leaves,
        // (ybar_s - m_s) / D_s, so that nothing of the size of y is
        // subtracted from itself.
        let mut gap = vec![0.0; self.ns.len()];
        for (s, gap) in gap.iter_mut().enumerate() {
            let ds = t1sq * self.ns[s] + 1.0;
            let z2b: f64 = self.row[self.row_start[s]..self.row_start[s + 1]].iter().map(|&(c, n)| n * b2[c]).sum();
            let xb: f64 = (0..p).map(|c| self.xbar[s * p + c] * beta_c[c]).sum();
            let ms = xb + z2b / self.ns[s];
            let u1 = t1 * self.ns[s] * (self.ybar[s] - ms) / ds;
            r2 += u1 * u1;
            *gap = (self.ybar[s] - ms) / ds + z2b / self.ns[s];
        }
        for i in 0..self.y.len() {
            let c = &self.codes[i * k..(i + 1) * k];
            let s = c[self.first];
            let xb: f64 = self.rx[i * p..(i + 1) * p].iter().zip(&beta_c).map(|(x, b)| x * b).sum();
            let z2b: f64 = (0..k).filter(|&j| j != self.first).map(|j| b2[self.dense_offset[j] + c[j]]).sum();
            r2 += (self.ry[i] - xb - z2b + gap[s]).powi(2);
        }
        let r2_std = r2.max(f64::MIN_POSITIVE);
        // (R_X'R_X)^-1 = L_X^-T L_X^-1.
        let mut rx_inv = Mat::<f64>::identity(p, p);
        let lx = l.submatrix(q2, q2, p, p);
        solve_lower_triangular_in_place(lx, rx_inv.as_mut(), Par::Seq);
        solve_upper_triangular_in_place(lx.transpose(), rx_inv.as_mut(), Par::Seq);
        let scale2 = self.y_scale * self.y_scale;
        let mut beta: Vec<f64> = beta_c.iter().map(|b| b * self.y_scale).collect();
        beta[0] += self.y_mean;
        let r2 = r2_std * scale2;
        let two_pi = 2.0 * std::f64::consts::PI;
        let n = self.n;
        let (deviance, sigma2) = match criterion {
            Criterion::Ml => (log_det_l2 + n * (1.0 + (two_pi * r2_std / n).ln() + scale2.ln()), r2 / n),
            Criterion::Reml => {
                let dof = n - p as f64;
                (log_det_l2 + log_det_rx2 + dof * (1.0 + (two_pi * r2_std / dof).ln() + scale2.ln()), r2 / dof)
            }
        };
        Ok(Eval { deviance, beta, sigma2, log_det_l2, log_det_rx2, r2, r2_std, rx_inv })
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
}
