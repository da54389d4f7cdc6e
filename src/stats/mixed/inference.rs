//! Small-sample inference for the fixed effects at the REML optimum:
//! Satterthwaite df as lmerTest computes them and Kenward-Roger as
//! pbkrtest computes it.

use faer::linalg::solvers::DenseSolveCore;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Mat, MatRef, Par, Side};

use super::system::System;
use super::{Criterion, KenwardRoger, MixedError};

/// The REML deviance, not profiled, at `p` = (theta_1..theta_k, sigma),
/// lmerTest's parameterization, and Var(beta_c) there for every c. The
/// deviance depends on each theta only through theta^2, so it is smooth and
/// even at zero and a difference step may cross it.
fn reml_at(s: &System, p: &[f64]) -> Result<(f64, Vec<f64>), MixedError> {
    let k = p.len() - 1;
    let (dev, e) = s.unprofiled(&p[..k], p[k], Criterion::Reml)?;
    Ok((dev, (0..s.p).map(|c| p[k] * p[k] * e.rx_inv[(c, c)]).collect()))
}

/// Satterthwaite df of each fixed effect at the REML optimum `theta`,
/// `sigma2`, as lmerTest computes them: 2 Var(beta_c)^2 / (g' A g) with g
/// the gradient of Var(beta_c) and A = 2 H^-1, H the Hessian of the REML
/// deviance, both in (theta, sigma) and both by central differences. The
/// df do not depend on the parameterization, but the differences do: in
/// the variances sigma^2 theta^2 a small component makes them
/// ill-conditioned, in theta they are not. `None` when H is not positive
/// definite.
pub(super) fn satterthwaite(s: &System, theta: &[f64], sigma2: f64) -> Result<Vec<Option<f64>>, MixedError> {
    let mut par: Vec<f64> = theta.to_vec();
    par.push(sigma2.sqrt());
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
        reml_at(s, &p)
    };
    let (f0, v0) = at(&[])?;
    // Central differences with steps of a relative 4e-3 and 2e-3 (of
    // theta, or of 0.1 for theta below 0.1; of sigma), combined by
    // Richardson extrapolation (the O(h^2) errors cancel); smaller steps
    // drown in the rounding of the deviance.
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
    let (g1, h1) = derivatives(4e-3)?;
    let (g2, h2) = derivatives(2e-3)?;
    let mut grad = Mat::<f64>::from_fn(m, pc, |i, j| (4.0 * g2[(i, j)] - g1[(i, j)]) / 3.0);
    let hess = Mat::<f64>::from_fn(m, m, |i, j| (4.0 * h2[(i, j)] - h1[(i, j)]) / 3.0);
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

/// Kenward-Roger inference for each fixed effect at the REML optimum, in
/// the q-dimensional space of random-effect levels rather than pbkrtest's
/// n x n matrices. With V = sum_k phi_k Z_k Z_k' + phi_e I, the penalized
/// block C = Lambda'Z'Z Lambda + I, B = Lambda C^-1 Lambda, K = Z'Z and
/// T = Z'X, Woodbury gives V^-1 = (I - Z B Z') / phi_e, hence with
/// W = V^-1 X:
///
/// ```text
/// Z'W = (I - K B) T / phi_e =: U / phi_e      Phi = (X'W)^-1 = phi_e (X'X - T'BT)^-1
/// Z'V^-1 Z = (K - K B K) / phi_e =: M1 / phi_e  W'W = (X'X - 2 T'BT + T'BKBT) / phi_e^2
/// ```
///
/// and every quantity of pbkrtest's `vcovAdj` (P_i = -X'V^-1 G_i V^-1 X,
/// Q_ij = X'V^-1 G_i V^-1 G_j V^-1 X, tr(V^-1 G_i V^-1 G_j), G_k = Z_k Z_k'
/// and G_e = I) is a p x p matrix of q x q products:
/// P_k = -U_k'U_k / phi_e^2, Q_kl = U_k' M1_kl U_l / phi_e^3,
/// Q_ke = U_k'(U - KBU)_k / phi_e^3, P_e = -W'W, Q_ee = (phi_e^2 W'W - U'BU) / phi_e^3.
///
/// For a single coefficient pbkrtest's `Lb_ddf` reduces to 2 / A with
/// A = sum_ij W_ij (e'Phi P_i Phi e)(e'Phi P_j Phi e) / (e'Phi e)^2 (its
/// scaling factor is 1 when the hypothesis has one df).
///
/// Also returns the shares of Var(intercept) = Phi_00 by source,
/// -phi_k (Phi P_k Phi)_00 / Phi_00 (dPhi/dphi_k = -Phi P_k Phi).
pub(super) fn kenward_roger(
    s: &System,
    theta: &[f64],
    sigma2: f64,
) -> Result<(Vec<KenwardRoger>, Vec<f64>), MixedError> {
    let (ztz, ztx, factor_of) = s.dense_products();
    let q = ztz.nrows();
    let k = theta.len();
    let m = k + 1;
    let pc = s.p;
    let pe = sigma2;
    let not_pd = || MixedError::NotPositiveDefinite { theta: theta.to_vec() };
    let lambda: Vec<f64> = factor_of.iter().map(|&f| theta[f]).collect();
    let a = Mat::<f64>::from_fn(q, q, |i, j| lambda[i] * ztz[(i, j)] * lambda[j] + if i == j { 1.0 } else { 0.0 });
    let cinv = a.llt(Side::Lower).map_err(|_| not_pd())?.inverse();
    let b = Mat::<f64>::from_fn(q, q, |i, j| lambda[i] * cinv[(i, j)] * lambda[j]);
    let kb = &ztz * &b;
    let m1 = &ztz - &kb * &ztz;
    let m2 = &m1 - &kb * &m1;
    let t = &ztx;
    let bt = &b * t;
    let tbt = t.transpose() * &bt;
    let u = t - &kb * t;
    let bu = &b * &u;
    let kbu = &kb * &u;
    let xtx = s.xtx.clone();
    // phi_e^2 W'W and U'BU.
    let ww = &xtx - &tbt * 2.0 + bt.transpose() * (&ztz * &bt);
    let ubu = u.transpose() * &bu;
    let phi = (&xtx - &tbt).llt(Side::Lower).map_err(|_| not_pd())?.inverse() * pe;
    let block: Vec<std::ops::Range<usize>> = (0..k)
        .map(|f| {
            let start = factor_of.iter().position(|&g| g == f).unwrap_or(0);
            start..start + s.levels[f]
        })
        .collect();
    let rows = |x: &Mat<f64>, r: &std::ops::Range<usize>| -> Mat<f64> { x.subrows(r.start, r.len()).to_owned() };
    let (pe2, pe3) = (pe * pe, pe * pe * pe);
    let mut pm: Vec<Mat<f64>> = Vec::with_capacity(m);
    let mut qm: Vec<Vec<Mat<f64>>> = vec![vec![Mat::zeros(pc, pc); m]; m];
    let mut kt = Mat::<f64>::zeros(m, m);
    let ukbu = &u - &kbu;
    for i in 0..k {
        let ui = rows(&u, &block[i]);
        pm.push(ui.transpose() * &ui * (-1.0 / pe2));
        for j in 0..k {
            let m1ij: MatRef<f64> = m1.submatrix(block[i].start, block[j].start, block[i].len(), block[j].len());
            let uj = rows(&u, &block[j]);
            qm[i][j] = ui.transpose() * (m1ij * &uj) * (1.0 / pe3);
            let mut frob = 0.0;
            for c in 0..m1ij.ncols() {
                for r in 0..m1ij.nrows() {
                    frob += m1ij[(r, c)] * m1ij[(r, c)];
                }
            }
            kt[(i, j)] = frob / pe2;
        }
        let qie = ui.transpose() * rows(&ukbu, &block[i]) * (1.0 / pe3);
        qm[k][i] = qie.transpose().to_owned();
        qm[i][k] = qie;
        let tr = block[i].clone().map(|a| m2[(a, a)]).sum::<f64>() / pe2;
        kt[(i, k)] = tr;
        kt[(k, i)] = tr;
    }
    pm.push(&ww * (-1.0 / pe2));
    qm[k][k] = (&ww - &ubu) * (1.0 / pe3);
    let tr_bk: f64 = (0..q).map(|i| kb[(i, i)]).sum();
    let tr_bkbk: f64 = (0..q).flat_map(|i| (0..q).map(move |j| (i, j))).map(|(i, j)| kb[(i, j)] * kb[(j, i)]).sum();
    kt[(k, k)] = (s.n - 2.0 * tr_bk + tr_bkbk) / pe2;
    let trace = |x: &Mat<f64>| (0..x.nrows()).map(|i| x[(i, i)]).sum::<f64>();
    let phi_p: Vec<Mat<f64>> = pm.iter().map(|p| &phi * p).collect();
    // Expected REML information (times 2) and W = 2 IE2^-1; pbkrtest takes
    // a generalized inverse when IE2 is numerically singular.
    let ie2 = Mat::<f64>::from_fn(m, m, |i, j| {
        kt[(i, j)] - 2.0 * trace(&(&phi * &qm[i][j])) + trace(&(&phi_p[i] * &phi_p[j]))
    });
    let evd = ie2.self_adjoint_eigen(Side::Lower).map_err(|_| not_pd())?;
    let (sv, vecs) = (evd.S().column_vector(), evd.U());
    let largest = (0..m).map(|i| sv[i].abs()).fold(0.0, f64::max);
    let smallest = (0..m).map(|i| sv[i].abs()).fold(f64::INFINITY, f64::min);
    let keep = |x: f64| if smallest > 1e-10 { true } else { x.abs() > f64::EPSILON.sqrt() * largest };
    let w = Mat::<f64>::from_fn(m, m, |i, j| {
        2.0 * (0..m).filter(|&l| keep(sv[l])).map(|l| vecs[(i, l)] * vecs[(j, l)] / sv[l]).sum::<f64>()
    });
    let mut uu = Mat::<f64>::zeros(pc, pc);
    for i in 0..m {
        for j in 0..m {
            uu += (&qm[i][j] - &pm[i] * &phi_p[j]) * w[(i, j)];
        }
    }
    let adjusted = &phi + &phi * &uu * &phi * 2.0;
    let g: Vec<Mat<f64>> = phi_p.iter().map(|pp| pp * &phi).collect();
    let out = (0..pc)
        .map(|c| {
            let mut aa = 0.0;
            for i in 0..m {
                for j in 0..m {
                    aa += w[(i, j)] * g[i][(c, c)] * g[j][(c, c)];
                }
            }
            let v = phi[(c, c)];
            KenwardRoger { se: adjusted[(c, c)].sqrt(), df: 2.0 * v * v / aa }
        })
        .collect();
    let variances: Vec<f64> = theta.iter().map(|t| pe * t * t).chain([pe]).collect();
    let shares = (0..m).map(|i| -variances[i] * g[i][(0, 0)] / phi[(0, 0)]).collect();
    Ok((out, shares))
}
