//! Satterthwaite df of a random-slope fit's fixed effects, as lmerTest
//! computes them (`as_lmerModLT`, lmerTest 3.1): the Hessian H of the
//! deviance in lmerTest's parameters varpar = (theta, sigma), not
//! profiled, on the response's own scale; A = 2 H^+, the Moore-Penrose
//! inverse over the eigenvalues above lmerTest's tolerance 1e-8; the
//! gradient g of Var(beta_c) = sigma^2 (R_X'R_X)^-1_cc in varpar; and
//! df = 2 Var(beta_c)^2 / (g' A g). The derivatives are central
//! differences combined by Richardson extrapolation, computed twice with
//! steps a factor 2 apart; where the two df disagree by more than 1e-4
//! (relative) the df is not reported and the fit says why.

use faer::{Mat, Side};

use super::system::System;
use crate::mixed::{Criterion, MixedError};

/// lmerTest's tolerance on the Hessian's eigenvalues.
const EIGEN_TOL: f64 = 1e-8;

/// The deviance in varpar (lmerTest's `devfun_vp`) and every Var(beta_c),
/// at `par` = (theta times [`System::scales`], sigma).
fn at(s: &System, par: &[f64]) -> Result<(f64, Vec<f64>), MixedError> {
    let m = par.len() - 1;
    let theta: Vec<f64> = par[..m].iter().zip(s.structure.scales()).map(|(v, d)| v / d).collect();
    let e = s.evaluate(&theta, Criterion::Reml)?;
    let sigma2 = par[m] * par[m];
    let r2 = e.r2_std * s.y_scale * s.y_scale;
    let log2pis = (2.0 * std::f64::consts::PI * sigma2).ln();
    let dev = e.log_det_l2 + r2 / sigma2 + s.n as f64 * log2pis + e.log_det_rx2 - s.p as f64 * log2pis - s.log_w;
    Ok((dev, (0..s.p).map(|c| sigma2 * e.rx_inv[(c, c)]).collect()))
}

/// Per fixed effect, its Satterthwaite df at the REML optimum `theta`,
/// `sigma2`; `Err` with the reason where the df cannot be computed
/// reliably.
pub(super) fn satterthwaite(s: &System, theta: &[f64], sigma2: f64) -> Result<Result<Vec<f64>, String>, MixedError> {
    // The differences are taken in the scaled theta (see
    // `optimize::optimum`) and carried to lmerTest's by the chain rule.
    let mut par: Vec<f64> = theta.iter().zip(s.structure.scales()).map(|(v, d)| v * d).collect();
    par.push(sigma2.sqrt());
    let a = df_with_step(s, &par, 2e-3)?;
    let b = df_with_step(s, &par, 4e-3)?;
    let (Some(a), Some(b)) = (a, b) else {
        return Ok(Err("Satterthwaite df: the Hessian of the REML criterion has no positive eigenvalue above lmerTest's tolerance, so the df are not reported".into()));
    };
    for (c, (x, y)) in a.iter().zip(&b).enumerate() {
        if !x.is_finite() || (x - y).abs() > 1e-4 * x.abs() {
            return Ok(Err(format!(
                "Satterthwaite df of coefficient {}: the difference derivatives do not agree between step sizes ({x:.6e} and {y:.6e}), so the df are not reported",
                c + 1
            )));
        }
    }
    Ok(Ok(a))
}

/// The df from Richardson-extrapolated central differences with relative
/// steps `rel` and `rel / 2` (of max(|par|, 0.1)).
fn df_with_step(s: &System, par: &[f64], rel: f64) -> Result<Option<Vec<f64>>, MixedError> {
    use rayon::prelude::*;
    let m = par.len();
    let pc = s.p;
    let (f0, v0) = at(s, par)?;
    let derivatives = |rel: f64| -> Result<(Mat<f64>, Mat<f64>), MixedError> {
        let h: Vec<f64> = par.iter().map(|v| rel * v.abs().max(0.1)).collect();
        let shifted = |d: &[(usize, f64)]| {
            let mut p = par.to_vec();
            for &(j, x) in d {
                p[j] += x;
            }
            p
        };
        let mut points: Vec<Vec<f64>> = Vec::new();
        for a in 0..m {
            points.push(shifted(&[(a, h[a])]));
            points.push(shifted(&[(a, -h[a])]));
            for b in 0..a {
                for (sa, sb) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
                    points.push(shifted(&[(a, sa * h[a]), (b, sb * h[b])]));
                }
            }
        }
        let values: Vec<(f64, Vec<f64>)> =
            points.par_iter().map(|p| at(s, p)).collect::<Result<Vec<_>, MixedError>>()?;
        let mut next = values.into_iter();
        let mut grad = Mat::<f64>::zeros(m, pc);
        let mut hess = Mat::<f64>::zeros(m, m);
        for a in 0..m {
            let (fp, vp) = next.next().unwrap_or_default();
            let (fm, vm) = next.next().unwrap_or_default();
            for c in 0..pc {
                grad[(a, c)] = (vp[c] - vm[c]) / (2.0 * h[a]);
            }
            hess[(a, a)] = (fp - 2.0 * f0 + fm) / (h[a] * h[a]);
            for b in 0..a {
                let mut four = [0.0; 4];
                for v in &mut four {
                    *v = next.next().map_or(f64::NAN, |x| x.0);
                }
                hess[(a, b)] = (four[0] - four[1] - four[2] + four[3]) / (4.0 * h[a] * h[b]);
                hess[(b, a)] = hess[(a, b)];
            }
        }
        Ok((grad, hess))
    };
    let (g1, h1) = derivatives(rel)?;
    let (g2, h2) = derivatives(rel / 2.0)?;
    // d/dtheta = scale d/d(scaled theta); sigma's scale is 1.
    let scale = |i: usize| s.structure.scales().get(i).copied().unwrap_or(1.0);
    let grad = Mat::<f64>::from_fn(m, pc, |i, j| scale(i) * (4.0 * g2[(i, j)] - g1[(i, j)]) / 3.0);
    let hess = Mat::<f64>::from_fn(m, m, |i, j| scale(i) * scale(j) * (4.0 * h2[(i, j)] - h1[(i, j)]) / 3.0);
    let Ok(evd) = hess.self_adjoint_eigen(Side::Lower) else { return Ok(None) };
    let (sv, u) = (evd.S().column_vector(), evd.U());
    let positive: Vec<usize> = (0..m).filter(|&i| sv[i] > EIGEN_TOL).collect();
    if positive.is_empty() {
        return Ok(None);
    }
    Ok(Some(
        (0..pc)
            .map(|c| {
                // g' A g = 2 sum over positive eigenvalues (u_i' g)^2 / lambda_i.
                let gag: f64 = positive
                    .iter()
                    .map(|&i| {
                        let ug: f64 = (0..m).map(|j| u[(j, i)] * grad[(j, c)]).sum();
                        2.0 * ug * ug / sv[i]
                    })
                    .sum();
                2.0 * v0[c] * v0[c] / gag
            })
            .collect(),
    ))
}
