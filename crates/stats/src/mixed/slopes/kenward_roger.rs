//! Kenward-Roger inference for the fixed effects of a random-slope fit, as
//! pbkrtest computes it (`vcovAdj`, `Lb_ddf`): on the marginal covariance
//! V = sum_t Z_t (I (x) Sigma_t) Z_t' + sigma^2 I over the variance
//! parameters (each term's variances and covariances, then sigma^2), with
//! G_r = dV/d(parameter r), P_r = X'V^-1 G_r V^-1 X, Q_rs =
//! X'V^-1 G_r V^-1 G_s V^-1 X, the expected information
//! IE2_rs = tr(V^-1 G_r V^-1 G_s) - 2 tr(Phi Q_rs) + tr(Phi P_r Phi P_s),
//! W = 2 IE2^-1 and Phi = (X'V^-1 X)^-1: the adjusted covariance is
//! Phi + 2 Phi U Phi, U = sum_rs W_rs (Q_rs - P_r Phi P_s), and for one
//! coefficient the df are 2 / A, A = sum_rs W_rs g_r g_s / Phi_cc^2 with
//! g_r = (Phi P_r Phi)_cc (Kenward and Roger 1997; pbkrtest's scaling
//! factor is 1 for one coefficient). The matrices are n x n, one per
//! parameter: a model whose matrices would hold more than
//! [`MAX_KR_VALUES`] values is refused.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

use super::Term;
use crate::mixed::{MixedData, MixedError};

/// The most values of Kenward-Roger's n x n matrices, one per variance
/// parameter (400 MB).
pub const MAX_KR_VALUES: usize = 50_000_000;

/// One variance parameter: term t's covariance entry (a, b), a >= b, or
/// the residual variance (`None`).
type Parameter = Option<(usize, usize, usize)>;

/// G_r M for parameter `r`: each level's rows get z_a (z_b' M_level) (+ the
/// transpose's term when a != b); the residual's G is the identity.
fn apply(terms: &[Term], levels: &[Vec<Vec<usize>>], r: Parameter, m: &Mat<f64>) -> Mat<f64> {
    let Some((t, a, b)) = r else { return m.clone() };
    let term = &terms[t];
    let (za, zb) = (&term.columns[a], &term.columns[b]);
    let mut out = Mat::<f64>::zeros(m.nrows(), m.ncols());
    for rows in &levels[t] {
        for col in 0..m.ncols() {
            let sa: f64 = rows.iter().map(|&j| za[j] * m[(j, col)]).sum();
            let sb: f64 = rows.iter().map(|&j| zb[j] * m[(j, col)]).sum();
            for &i in rows {
                out[(i, col)] += za[i] * sb + if a != b { zb[i] * sa } else { 0.0 };
            }
        }
    }
    out
}

/// Per fixed effect, Kenward-Roger's adjusted SE and df, at the REML
/// estimates `covariances` (per term, k x k row-major) and `sigma2`.
pub(super) fn kenward_roger(
    base: &MixedData,
    terms: &[Term],
    covariances: &[Vec<f64>],
    sigma2: f64,
) -> Result<Vec<(f64, f64)>, MixedError> {
    let (n, p) = (base.len(), base.p());
    let parameters: usize = terms.iter().map(|t| t.columns.len() * (t.columns.len() + 1) / 2).sum::<usize>() + 1;
    if n.saturating_mul(n).saturating_mul(parameters + 2) > MAX_KR_VALUES {
        return Err(MixedError::TooLarge(format!(
            "Kenward-Roger works with an n x n matrix per variance parameter; {n} observations and {parameters} parameters are over the limit of {MAX_KR_VALUES} values for a model with random slopes: use Satterthwaite df"
        )));
    }
    let levels: Vec<Vec<Vec<usize>>> = terms
        .iter()
        .map(|t| {
            let mut rows = vec![Vec::new(); t.levels];
            for (i, &c) in t.codes.iter().enumerate() {
                rows[c].push(i);
            }
            rows
        })
        .collect();
    // V, then its inverse.
    let mut v = Mat::<f64>::identity(n, n) * faer::Scale(sigma2);
    for ((t, rows_of), cov) in terms.iter().zip(&levels).zip(covariances) {
        let k = t.columns.len();
        for rows in rows_of {
            for &i in rows {
                for &j in rows {
                    let mut s = 0.0;
                    for a in 0..k {
                        for b in 0..k {
                            s += t.columns[a][i] * cov[a * k + b] * t.columns[b][j];
                        }
                    }
                    v[(i, j)] += s;
                }
            }
        }
    }
    let not_pd = || MixedError::Unidentifiable {
        factor: "Kenward-Roger".into(),
        reason: "the marginal covariance is not positive definite at the estimates".into(),
    };
    let vi = v.llt(Side::Lower).map_err(|_| not_pd())?.solve(Mat::<f64>::identity(n, n));
    let xs = base.design();
    let x = Mat::<f64>::from_fn(n, p, |i, c| xs[i * p + c]);
    let vix = &vi * &x;
    let phi = (x.transpose() * &vix).llt(Side::Lower).map_err(|_| not_pd())?.solve(Mat::<f64>::identity(p, p));
    let mut params: Vec<Parameter> = Vec::new();
    for (t, term) in terms.iter().enumerate() {
        let k = term.columns.len();
        for b in 0..k {
            for a in b..k {
                params.push(Some((t, a, b)));
            }
        }
    }
    params.push(None);
    let m = params.len();
    // O_r = G_r V^-1 X, P_r = X'V^-1 G_r V^-1 X, H_r = G_r V^-1.
    let o: Vec<Mat<f64>> = params.iter().map(|&r| apply(terms, &levels, r, &vix)).collect();
    let pr: Vec<Mat<f64>> = o.iter().map(|o| vix.transpose() * o).collect();
    let h: Vec<Mat<f64>> = params.iter().map(|&r| apply(terms, &levels, r, &vi)).collect();
    let mut ie2 = Mat::<f64>::zeros(m, m);
    let mut q = vec![vec![Mat::<f64>::zeros(p, p); m]; m];
    for r in 0..m {
        for s in r..m {
            q[r][s] = o[r].transpose() * &vi * &o[s];
            q[s][r] = q[r][s].transpose().to_owned();
            // tr(H_r H_s) = sum_ij H_r[i][j] H_s[j][i].
            let mut ktrace = 0.0;
            for i in 0..n {
                for j in 0..n {
                    ktrace += h[r][(i, j)] * h[s][(j, i)];
                }
            }
            let phi_q: f64 =
                (0..p).flat_map(|a| (0..p).map(move |b| (a, b))).map(|(a, b)| phi[(a, b)] * q[r][s][(a, b)]).sum();
            let pp = &phi * &pr[r] * &phi * &pr[s];
            let trace_pp: f64 = (0..p).map(|a| pp[(a, a)]).sum();
            ie2[(r, s)] = ktrace - 2.0 * phi_q + trace_pp;
            ie2[(s, r)] = ie2[(r, s)];
        }
    }
    let w = ie2.llt(Side::Lower).map_err(|_| not_pd())?.solve(Mat::<f64>::identity(m, m)) * faer::Scale(2.0);
    let mut u = Mat::<f64>::zeros(p, p);
    for r in 0..m {
        for s in 0..m {
            let term = &q[r][s] - &pr[r] * &phi * &pr[s];
            u += term * faer::Scale(w[(r, s)]);
        }
    }
    let adjusted = &phi + (&phi * &u * &phi) * faer::Scale(2.0);
    let g: Vec<Mat<f64>> = pr.iter().map(|p_r| &phi * p_r * &phi).collect();
    Ok((0..p)
        .map(|c| {
            let mut a = 0.0;
            for r in 0..m {
                for s in 0..m {
                    a += w[(r, s)] * g[r][(c, c)] * g[s][(c, c)];
                }
            }
            a /= phi[(c, c)] * phi[(c, c)];
            (adjusted[(c, c)].sqrt(), 2.0 / a)
        })
        .collect())
}
