//! Small-sample inference for the fixed effects at the REML optimum:
//! Satterthwaite df as lmerTest computes them and Kenward-Roger as
//! pbkrtest computes it.
//!
//! Both are computed on the standardized response (see `system::System`),
//! so they are the same for y and a + b y, and from the deviance and
//! Var(beta) of the reduced system, whose terms are sums of positive
//! semi-definite parts: nothing is the small difference of two large
//! numbers, whatever the ratio of the variances. Each df is computed twice,
//! with difference steps a factor 2 apart; where the two disagree by more
//! than [`RELIABLE`] (relative), or the result is not a number of at least
//! 1, the df is reported as not computable and the caller falls back.

use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Mat, Par, Side};

use super::system::System;
use super::{Criterion, KenwardRoger, MixedError};

/// The largest relative disagreement between the df of two step sizes
/// that is taken as rounding.
pub(super) const RELIABLE: f64 = 1e-4;

/// A df, or why there is none.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Df {
    /// Computed, the two step sizes agreeing.
    Value(f64),
    /// The information matrix is not positive definite (Satterthwaite).
    NotPositiveDefinite,
    /// The two step sizes disagree, or the value is not a number >= 1.
    Unreliable(f64),
}

fn agree(a: Option<f64>, b: Option<f64>) -> Df {
    match (a, b) {
        (Some(a), Some(b)) if a.is_finite() && b.is_finite() && a >= 1.0 - 1e-9 => {
            if (a - b).abs() <= RELIABLE * a.abs() {
                Df::Value(a.max(1.0))
            } else {
                Df::Unreliable(a)
            }
        }
        (Some(a), _) => Df::Unreliable(a),
        (None, _) => Df::NotPositiveDefinite,
    }
}

/// The REML deviance of the standardized response, not profiled, less
/// (n - p) log(2 pi sigma^2), at
/// `p` = (theta_1..theta_k, sigma), lmerTest's parameterization, and
/// Var(beta_c) there for every c. The deviance depends on each theta only
/// through theta^2, so it is smooth and even at zero and a difference step
/// may cross it.
/// The term (n - p) log(2 pi sigma^2) is left out: the caller adds its
/// second derivative exactly, its rounding being the largest.
fn reml_at(s: &System, p: &[f64]) -> Result<(f64, Vec<f64>), MixedError> {
    let k = p.len() - 1;
    let e = s.evaluate(&p[..k], Criterion::Reml)?;
    let dev = e.log_det_l2 + e.log_det_rx2 + e.r2_std / (p[k] * p[k]);
    Ok((dev, (0..s.p).map(|c| p[k] * p[k] * e.rx_inv[(c, c)]).collect()))
}

/// Satterthwaite df of each fixed effect at the REML optimum `theta`,
/// `sigma2`, as lmerTest computes them: 2 Var(beta_c)^2 / (g' A g) with g
/// the gradient of Var(beta_c) and A = 2 H^-1, H the Hessian of the REML
/// deviance, both in (theta, sigma) and both by central differences. The
/// df do not depend on the parameterization, but the differences do: in
/// the variances sigma^2 theta^2 a small component makes them
/// ill-conditioned, in theta they are not.
pub(super) fn satterthwaite(s: &System, theta: &[f64], sigma2: f64) -> Result<Vec<Df>, MixedError> {
    use rayon::prelude::*;
    use std::cell::RefCell;
    use std::collections::HashMap;
    let sigma = sigma2.sqrt() / s.y_scale;
    // First the points the differences visit are listed (the deviance
    // stood in by zeros), then each distinct one is evaluated once, in
    // parallel, and the differences are taken from those values: the same
    // numbers as evaluating them one by one, in any order.
    let visited: RefCell<Vec<Vec<f64>>> = RefCell::new(Vec::new());
    let list = |p: &[f64]| -> Result<(f64, Vec<f64>), MixedError> {
        visited.borrow_mut().push(p.to_vec());
        Ok((0.0, vec![0.0; s.p]))
    };
    satterthwaite_steps(s, theta, sigma, 4e-3, &list)?;
    satterthwaite_steps(s, theta, sigma, 8e-3, &list)?;
    let bits = |p: &[f64]| -> Vec<u64> { p.iter().map(|x| x.to_bits()).collect() };
    let mut points: Vec<Vec<f64>> = Vec::new();
    let mut seen: HashMap<Vec<u64>, usize> = HashMap::new();
    for p in visited.into_inner() {
        seen.entry(bits(&p)).or_insert_with(|| {
            points.push(p);
            points.len() - 1
        });
    }
    let values: Vec<Result<(f64, Vec<f64>), MixedError>> = points.par_iter().map(|p| reml_at(s, p)).collect();
    let values: Vec<(f64, Vec<f64>)> = values.into_iter().collect::<Result<_, _>>()?;
    let known = |p: &[f64]| -> Result<(f64, Vec<f64>), MixedError> {
        match seen.get(&bits(p)) {
            Some(&k) => Ok(values[k].clone()),
            None => reml_at(s, p),
        }
    };
    let a = satterthwaite_steps(s, theta, sigma, 4e-3, &known)?;
    let b = satterthwaite_steps(s, theta, sigma, 8e-3, &known)?;
    Ok(a.into_iter().zip(b).map(|(a, b)| agree(a, b)).collect())
}

/// The REML deviance and Var(beta) at a parameter vector, as [`reml_at`].
type Evaluator<'a> = dyn Fn(&[f64]) -> Result<(f64, Vec<f64>), MixedError> + 'a;

/// Satterthwaite df from central differences with relative steps `rel`
/// and `rel / 2` (of theta, or of 0.1 for theta below 0.1; of sigma),
/// combined by Richardson extrapolation (the O(h^2) errors cancel).
fn satterthwaite_steps(
    s: &System,
    theta: &[f64],
    sigma: f64,
    rel: f64,
    eval: &Evaluator,
) -> Result<Vec<Option<f64>>, MixedError> {
    let mut par: Vec<f64> = theta.to_vec();
    par.push(sigma);
    // Free parameters: sigma and every theta not at zero (a singular
    // component is held at zero, as lmerTest holds it).
    let free: Vec<usize> = (0..par.len()).filter(|&i| i == par.len() - 1 || theta[i] >= 1e-4).collect();
    let m = free.len();
    let pc = s.p;
    let at = |delta: &[(usize, f64)]| -> Result<(f64, Vec<f64>), MixedError> {
        let mut p = par.clone();
        for &(j, d) in delta {
            p[free[j]] += d;
        }
        eval(&p)
    };
    let (f0, v0) = at(&[])?;
    let derivatives = |rel: f64| -> Result<(Mat<f64>, Mat<f64>), MixedError> {
        let h: Vec<f64> =
            free.iter().map(|&i| if i == par.len() - 1 { rel * par[i] } else { rel * par[i].max(0.1) }).collect();
        let mut grad = Mat::<f64>::zeros(m, pc);
        let mut hess = Mat::<f64>::zeros(m, m);
        for a in 0..m {
            let (fp, vp) = at(&[(a, h[a])])?;
            let (fm, vm) = at(&[(a, -h[a])])?;
            for c in 0..pc {
                grad[(a, c)] = (vp[c] - vm[c]) / (2.0 * h[a]);
            }
            hess[(a, a)] = (fp - 2.0 * f0 + fm) / (h[a] * h[a]);
            for b in 0..a {
                let pp = at(&[(a, h[a]), (b, h[b])])?.0;
                let pm = at(&[(a, h[a]), (b, -h[b])])?.0;
                let mp = at(&[(a, -h[a]), (b, h[b])])?.0;
                let mm = at(&[(a, -h[a]), (b, -h[b])])?.0;
                hess[(a, b)] = (pp - pm - mp + mm) / (4.0 * h[a] * h[b]);
                hess[(b, a)] = hess[(a, b)];
            }
        }
        Ok((grad, hess))
    };
    let (g1, h1) = derivatives(rel)?;
    let (g2, h2) = derivatives(rel / 2.0)?;
    let mut grad = Mat::<f64>::from_fn(m, pc, |i, j| (4.0 * g2[(i, j)] - g1[(i, j)]) / 3.0);
    let mut hess = Mat::<f64>::from_fn(m, m, |i, j| (4.0 * h2[(i, j)] - h1[(i, j)]) / 3.0);
    // d^2/dsigma^2 of (n - p) log(2 pi sigma^2), left out of the differences.
    hess[(m - 1, m - 1)] -= 2.0 * (s.n - s.p as f64) / (sigma * sigma);
    // A = 2 H^-1 (the deviance is -2 log L); g' A g by a Cholesky solve.
    let Ok(llt) = hess.llt(Side::Lower) else { return Ok(vec![None; pc]) };
    solve_lower_triangular_in_place(llt.L(), grad.as_mut(), Par::Seq);
    Ok((0..pc)
        .map(|c| {
            let gag = 2.0 * (0..m).map(|i| grad[(i, c)] * grad[(i, c)]).sum::<f64>();
            Some(2.0 * v0[c] * v0[c] / gag)
        })
        .collect())
}

/// The quantities Kenward-Roger is built from, at the variances
/// `phi` = (phi_1..phi_k, phi_e) of the standardized response:
/// l(phi) = log|V| + log|X'V^-1 X| (lme4's log|L|^2 + log|R_X|^2 +
/// (n - p) log phi_e; the last term left out) and Phi_cc = Var(beta_c)
/// for every c.
fn kr_at(s: &System, phi: &[f64]) -> Result<Vec<f64>, MixedError> {
    let k = phi.len() - 1;
    let pe = phi[k];
    let theta: Vec<f64> = phi[..k].iter().map(|v| (v.max(0.0) / pe).sqrt()).collect();
    let e = s.evaluate(&theta, Criterion::Reml)?;
    // (n - p) log phi_e is left out here and differentiated exactly by
    // the caller: it is the largest term, and its rounding would swamp the
    // second differences.
    let ell = e.log_det_l2 + e.log_det_rx2;
    Ok(std::iter::once(ell).chain((0..s.p).map(|c| pe * e.rx_inv[(c, c)])).collect())
}

/// Gradients and Hessians of every output of `f` at `x` by differences
/// with steps `h`: central where `central[i]`, forward (a variance at or
/// near zero, which may not be stepped below it) otherwise; each
/// Richardson-extrapolated from steps h, 2h and 4h.
#[allow(clippy::type_complexity)] // (gradients, Hessians), one of each per output
fn differences(
    f: &dyn Fn(&[f64]) -> Result<Vec<f64>, MixedError>,
    x: &[f64],
    h: &[f64],
    central: &[bool],
) -> Result<(Vec<Vec<f64>>, Vec<Mat<f64>>), MixedError> {
    let m = x.len();
    let f0 = f(x)?;
    let outs = f0.len();
    let at = |delta: &[(usize, f64)]| -> Result<Vec<f64>, MixedError> {
        let mut p = x.to_vec();
        for &(j, d) in delta {
            p[j] += d;
        }
        f(&p)
    };
    // Raw estimates at step multiple `t` (1 or 2).
    let raw = |t: f64| -> Result<(Vec<Vec<f64>>, Vec<Mat<f64>>), MixedError> {
        let hs: Vec<f64> = h.iter().map(|v| v * t).collect();
        // Points of each coordinate: (+h, -h) / 2h, or (+h, 0) / h.
        let pts = |i: usize| -> ([f64; 2], f64) {
            if central[i] {
                ([hs[i], -hs[i]], 2.0 * hs[i])
            } else {
                ([hs[i], 0.0], hs[i])
            }
        };
        let mut grad = vec![vec![0.0; m]; outs];
        let mut hess = vec![Mat::<f64>::zeros(m, m); outs];
        for i in 0..m {
            let ([a, b], den) = pts(i);
            let fa = at(&[(i, a)])?;
            let fb = if b == 0.0 { f0.clone() } else { at(&[(i, b)])? };
            // Second derivative: central (f+ - 2 f0 + f-) / h^2, forward
            // (f(2h) - 2 f(h) + f0) / h^2.
            let (f1, f2, f3) = if central[i] {
                (fa.clone(), f0.clone(), fb.clone())
            } else {
                (at(&[(i, 2.0 * hs[i])])?, fa.clone(), f0.clone())
            };
            for o in 0..outs {
                grad[o][i] = (fa[o] - fb[o]) / den;
                hess[o][(i, i)] = (f1[o] - 2.0 * f2[o] + f3[o]) / (hs[i] * hs[i]);
            }
            for j in 0..i {
                let ([c, d], den_j) = pts(j);
                let g = |u: f64, v: f64| at(&[(i, u), (j, v)]);
                let (fac, fad, fbc, fbd) = (g(a, c)?, g(a, d)?, g(b, c)?, g(b, d)?);
                for o in 0..outs {
                    let v = (fac[o] - fad[o] - fbc[o] + fbd[o]) / (den * den_j);
                    hess[o][(i, j)] = v;
                    hess[o][(j, i)] = v;
                }
            }
        }
        Ok((grad, hess))
    };
    let (g1, h1) = raw(1.0)?;
    let (g2, h2) = raw(2.0)?;
    let (g4, h4) = raw(4.0)?;
    // Richardson over steps h, 2h and 4h. Central differences err by
    // c1 h^2 + c2 h^4 + ..., cancelled by (64 D(h) - 20 D(2h) + D(4h)) / 45
    // (error O(h^6)); any forward coordinate makes it c1 h + c2 h^2 + ...,
    // cancelled by (8 D(h) - 6 D(2h) + D(4h)) / 3 (error O(h^3)). A
    // variance at zero is differentiated forward, and with one level of
    // extrapolation its O(h^2) error was 1e-5 of the df at the steps that
    // keep rounding small; pbkrtest differentiates exactly.
    let extrapolate = |a: f64, b: f64, c: f64, both_central: bool| {
        if both_central {
            (64.0 * a - 20.0 * b + c) / 45.0
        } else {
            (8.0 * a - 6.0 * b + c) / 3.0
        }
    };
    let grad =
        (0..outs).map(|o| (0..m).map(|i| extrapolate(g1[o][i], g2[o][i], g4[o][i], central[i])).collect()).collect();
    let hess = (0..outs)
        .map(|o| {
            Mat::from_fn(m, m, |i, j| {
                extrapolate(h1[o][(i, j)], h2[o][(i, j)], h4[o][(i, j)], central[i] && central[j])
            })
        })
        .collect();
    Ok((grad, hess))
}

/// Kenward-Roger inference for each fixed effect at the REML optimum, with
/// pbkrtest's quantities written as derivatives: with
/// l(phi) = log|V| + log|X'V^-1 X| and Phi = (X'V^-1 X)^-1,
///
/// ```text
/// d l / d phi_i = tr(P G_i)   so  IE2_ij = tr(P G_i P G_j) = -d^2 l / d phi_i d phi_j
/// d Phi / d phi_i = -Phi P_i Phi
/// d^2 Phi / d phi_i d phi_j = Phi (P_i Phi P_j + P_j Phi P_i - Q_ij - Q_ji) Phi
/// ```
///
/// (P = V^-1 - V^-1 X Phi X'V^-1, G_i = Z_i Z_i' or I; P_i, Q_ij as in
/// pbkrtest's `vcovAdj`), so with W = 2 IE2^-1 (a generalized inverse
/// where IE2 is numerically singular, as pbkrtest takes) the adjusted
/// variance Phi + 2 Phi (sum_ij W_ij (Q_ij - P_i Phi P_j)) Phi is
/// Phi - sum_ij W_ij d^2 Phi / d phi_i d phi_j, and the df of one
/// coefficient are 2 Phi_cc^2 / (g' W g), g the gradient of Phi_cc (the
/// KR scaling factor is 1 for one df). The derivatives are differences in
/// the variances of the standardized response: relative steps, forward
/// for a variance at or near zero.
///
/// Also returns the shares of Var(intercept) by source,
/// phi_i dPhi_00/dphi_i / Phi_00.
#[allow(clippy::type_complexity)] // ((KR, its df's verdict) per coefficient, shares)
pub(super) fn kenward_roger(
    s: &System,
    theta: &[f64],
    sigma2: f64,
) -> Result<(Vec<(KenwardRoger, Df)>, Vec<f64>), MixedError> {
    let (first, shares) = kr_steps(s, theta, sigma2, 1e-2)?;
    let (second, _) = kr_steps(s, theta, sigma2, 2e-2)?;
    let out = first
        .into_iter()
        .zip(second)
        .map(|((se, df), (_, df2))| {
            let verdict = agree(Some(df), Some(df2));
            (KenwardRoger { se, df, fallback: false }, verdict)
        })
        .collect();
    Ok((out, shares))
}

#[allow(clippy::type_complexity)] // ((adjusted SE, df) per coefficient, shares)
fn kr_steps(s: &System, theta: &[f64], sigma2: f64, rel: f64) -> Result<(Vec<(f64, f64)>, Vec<f64>), MixedError> {
    let k = theta.len();
    let m = k + 1;
    let pc = s.p;
    let pe = sigma2 / (s.y_scale * s.y_scale);
    let phi: Vec<f64> = theta.iter().map(|t| pe * t * t).chain([pe]).collect();
    // Each variance's unit: itself, or a tenth of the residual variance
    // for one smaller than that (a step relative to zero is no step).
    let unit: Vec<f64> = phi.iter().map(|v| v.max(0.1 * pe)).collect();
    // Central differences (error O(h^4) once extrapolated) take steps of
    // `rel`; forward ones (error O(h^2)) a fiftieth of that.
    let central: Vec<bool> = (0..m).map(|i| phi[i] > 4.5 * rel * unit[i]).collect();
    let h: Vec<f64> = (0..m).map(|i| if central[i] { rel * unit[i] } else { 0.02 * rel * unit[i] }).collect();
    let f = |x: &[f64]| kr_at(s, x);
    let (grad, hess) = differences(&f, &phi, &h, &central)?;
    let values = kr_at(s, &phi)?;
    // IE2 = -Hessian of l, scaled by the units so that its eigenvalues are
    // comparable, then W = 2 IE2^-1 back in the variances.
    let mut hl = hess[0].clone();
    hl[(k, k)] -= (s.n - s.p as f64) / (pe * pe);
    let ie2 = Mat::<f64>::from_fn(m, m, |i, j| -hl[(i, j)] * unit[i] * unit[j]);
    let ie2 = Mat::<f64>::from_fn(m, m, |i, j| 0.5 * (ie2[(i, j)] + ie2[(j, i)]));
    let not_pd = || MixedError::NotPositiveDefinite { theta: theta.to_vec() };
    let evd = ie2.self_adjoint_eigen(Side::Lower).map_err(|_| not_pd())?;
    let (sv, vecs) = (evd.S().column_vector(), evd.U());
    let largest = (0..m).map(|i| sv[i].abs()).fold(0.0, f64::max);
    let smallest = (0..m).map(|i| sv[i]).fold(f64::INFINITY, f64::min);
    // pbkrtest solves IE2 unless it is numerically singular, and then
    // takes MASS::ginv's generalized inverse (tolerance sqrt(eps)).
    let keep = |x: f64| if smallest > 1e-10 * largest { true } else { x > f64::EPSILON.sqrt() * largest };
    let w = Mat::<f64>::from_fn(m, m, |i, j| {
        2.0 * (0..m).filter(|&l| keep(sv[l])).map(|l| vecs[(i, l)] * vecs[(j, l)] / sv[l]).sum::<f64>()
            * unit[i]
            * unit[j]
    });
    let out = (0..pc)
        .map(|c| {
            let g = &grad[1 + c];
            let hc = &hess[1 + c];
            let v = values[1 + c];
            let mut gwg = 0.0;
            let mut correction = 0.0;
            for i in 0..m {
                for j in 0..m {
                    gwg += w[(i, j)] * g[i] * g[j];
                    correction += w[(i, j)] * hc[(i, j)];
                }
            }
            // The Kackar-Harville term 2 Phi (sum W (Q - P Phi P)) Phi is
            // positive semi-definite (it is the expected variance added by
            // estimating the variances): sum W d^2Phi is <= 0, and a
            // computed sum above zero is the differences' rounding.
            let adjusted = v - correction.min(0.0);
            (adjusted.max(0.0).sqrt() * s.y_scale, 2.0 * v * v / gwg)
        })
        .collect();
    let shares = (0..m).map(|i| phi[i] * grad[1][i] / values[1]).collect();
    Ok((out, shares))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_recover_a_quadratic_in_central_and_forward_steps() {
        // f = (x0^2 x1 + 3 x1^2, x0 x1): exact derivatives at (1, 0.5).
        let f = |x: &[f64]| -> Result<Vec<f64>, MixedError> {
            Ok(vec![x[0] * x[0] * x[1] + 3.0 * x[1] * x[1], x[0] * x[1]])
        };
        for central in [[true, true], [true, false], [false, false]] {
            let (g, h) = differences(&f, &[1.0, 0.5], &[1e-3, 1e-3], &central).unwrap();
            let close = |a: f64, b: f64| (a - b).abs() < 1e-6 * b.abs().max(1.0);
            assert!(close(g[0][0], 1.0) && close(g[0][1], 4.0), "{central:?} {:?}", g[0]);
            assert!(close(h[0][(0, 0)], 1.0) && close(h[0][(1, 1)], 6.0) && close(h[0][(0, 1)], 2.0), "{central:?}");
            assert!(close(h[1][(0, 1)], 1.0) && close(h[1][(0, 0)], 0.0), "{central:?}");
        }
    }
}
