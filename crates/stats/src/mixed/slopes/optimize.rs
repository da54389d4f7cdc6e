//! Minimisation of the random-slope deviance over all of R^m: Nelder-Mead
//! from lme4's start, Newton on difference derivatives, and the
//! unconstrained certificate, with restarts where it fails.

use faer::{Mat, Side};

use super::system::System;
use super::SlopeCertificate;
use crate::mixed::optimize::nelder_mead_free;
use crate::mixed::{Criterion, MixedError};

/// Evaluates a batch of points, one value per point in order.
pub(crate) type Batch<'a> = dyn FnMut(&[Vec<f64>]) -> Vec<f64> + 'a;

/// The optimum: lme4's theta (diagonal entries non-negative), the
/// evaluations used and the certificate.
///
/// The search and the certificate work in the scaled parameters (theta
/// times [`super::structure::Structure::scales`]), in which a step of 1e-4 means as much for
/// a slope in a column of large values as for an intercept; lme4's theta
/// is the point found divided by the scales.
pub(super) fn optimum(s: &System, criterion: Criterion) -> Result<(Vec<f64>, usize, SlopeCertificate), MixedError> {
    let st = &s.structure;
    let scales = st.scales().to_vec();
    let unscaled = |t: &[f64]| -> Vec<f64> { t.iter().zip(&scales).map(|(v, d)| v / d).collect() };
    // lme4's start, T = I, in the scaled parameters.
    let start: Vec<f64> = st.start();
    // The start is evaluated directly, so that a system that cannot be
    // factored is an error rather than an infinite deviance.
    s.evaluate(&unscaled(&start), criterion)?;
    let one =
        |theta: &[f64]| -> f64 { s.evaluate(&unscaled(theta), criterion).map(|e| e.deviance).unwrap_or(f64::INFINITY) };
    let (best, _, evaluations, certificate) = minimize(&one, start);
    Ok((st.normalized(&unscaled(&best)), evaluations, certificate))
}

/// Minimises `one` over all of R^m from `start`: Nelder-Mead, then Newton
/// on difference derivatives, then the certificate, with restarts from
/// where it fails (directions of negative curvature, the point, `start`)
/// with smaller simplices, up to three rounds. Returns the point, its
/// value, the evaluations used and the certificate. Points are evaluated
/// in parallel batches: the same values in any order.
pub(crate) fn minimize(
    one: &(dyn Fn(&[f64]) -> f64 + Sync),
    start: Vec<f64>,
) -> (Vec<f64>, f64, usize, SlopeCertificate) {
    let evaluations = std::cell::Cell::new(0usize);
    let mut dev = |theta: &[f64]| -> f64 {
        evaluations.set(evaluations.get() + 1);
        one(theta)
    };
    let mut batch = |thetas: &[Vec<f64>]| -> Vec<f64> {
        use rayon::prelude::*;
        evaluations.set(evaluations.get() + thetas.len());
        thetas.par_iter().map(|t| one(t)).collect()
    };
    let f0 = dev(&start);
    let (mut best, mut best_dev) = nelder_mead_free(&mut dev, &start, 0.5, 1e-8);
    if best_dev.is_nan() || best_dev > f0 {
        (best, best_dev) = (start.clone(), f0);
    }
    (best, best_dev, _) = newton(&mut batch, best, best_dev, 40);
    let mut checked = certify(&mut batch, &best, best_dev);
    let mut restarts = 0;
    for round in 0..3 {
        if checked.certified {
            break;
        }
        let mut starts = checked.escapes.clone();
        starts.push(best.clone());
        if round == 0 {
            starts.push(start.clone());
        }
        for from in starts {
            restarts += 1;
            let step = 0.1f64.powi(round) * 0.5;
            let (t, d) = nelder_mead_free(&mut dev, &from, step, 1e-12);
            let (t, d, _) = newton(&mut batch, t, d, 40);
            if d < best_dev {
                (best, best_dev) = (t, d);
            }
        }
        checked = certify(&mut batch, &best, best_dev);
    }
    let Checked { gradient, predicted_decrease, smallest_curvature, certified, .. } = checked;
    let certificate = SlopeCertificate { gradient, predicted_decrease, smallest_curvature, certified, restarts };
    (best, best_dev, evaluations.get(), certificate)
}

/// Central-difference steps at `x`.
fn steps(x: &[f64], relative: f64) -> Vec<f64> {
    x.iter().map(|v| relative * v.abs().max(0.1)).collect()
}

/// The gradient and Hessian of `f` at `x` (value `fx`) by central
/// differences (four points per pair for the off-diagonal terms).
pub(crate) fn derivatives(f: &mut Batch, x: &[f64], fx: f64, h: &[f64]) -> (Vec<f64>, Mat<f64>) {
    let m = x.len();
    let at = |d: &[(usize, f64)]| {
        let mut y = x.to_vec();
        for &(j, s) in d {
            y[j] += s;
        }
        y
    };
    let mut points: Vec<Vec<f64>> = (0..m).flat_map(|a| [at(&[(a, h[a])]), at(&[(a, -h[a])])]).collect();
    for a in 0..m {
        for b in 0..a {
            for (sa, sb) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
                points.push(at(&[(a, sa * h[a]), (b, sb * h[b])]));
            }
        }
    }
    let values = f(&points);
    let mut g = vec![0.0; m];
    let mut hess = Mat::<f64>::zeros(m, m);
    for a in 0..m {
        let (fp, fm) = (values[2 * a], values[2 * a + 1]);
        g[a] = (fp - fm) / (2.0 * h[a]);
        hess[(a, a)] = (fp - 2.0 * fx + fm) / (h[a] * h[a]);
    }
    let mut pairs = values[2 * m..].iter().copied();
    for a in 0..m {
        for b in 0..a {
            let mut four = [f64::NAN; 4];
            for v in &mut four {
                *v = pairs.next().unwrap_or(f64::NAN);
            }
            hess[(a, b)] = (four[0] - four[1] - four[2] + four[3]) / (4.0 * h[a] * h[b]);
            hess[(b, a)] = hess[(a, b)];
        }
    }
    (g, hess)
}

/// The Newton step -H^-1 g, with H's eigenvalues replaced by their
/// absolute values (floored at 1e-8 of the largest) so that it descends
/// where H is not positive definite; `None` where H is not a number.
fn newton_step(g: &[f64], hess: &Mat<f64>) -> Option<Vec<f64>> {
    let m = g.len();
    let evd = hess.self_adjoint_eigen(Side::Lower).ok()?;
    let (sv, u) = (evd.S().column_vector(), evd.U());
    let largest = (0..m).map(|i| sv[i].abs()).fold(0.0, f64::max);
    if !largest.is_finite() || largest <= 0.0 {
        return None;
    }
    let ug: Vec<f64> = (0..m).map(|i| (0..m).map(|j| u[(j, i)] * g[j]).sum()).collect();
    let scaled: Vec<f64> = (0..m).map(|i| ug[i] / sv[i].abs().max(1e-8 * largest)).collect();
    Some((0..m).map(|j| -(0..m).map(|i| u[(j, i)] * scaled[i]).sum::<f64>()).collect())
}

/// Newton steps from `x`, each taken only if the deviance does not rise
/// (halved up to twelve times otherwise). Returns the point, its value and
/// whether a step below 1e-7 of max(|x|, 0.01) was reached.
fn newton(f: &mut Batch, mut x: Vec<f64>, mut fx: f64, iterations: usize) -> (Vec<f64>, f64, bool) {
    for _ in 0..iterations {
        let h = steps(&x, 1e-4);
        let (g, hess) = derivatives(f, &x, fx, &h);
        let Some(step) = newton_step(&g, &hess) else { return (x, fx, false) };
        let mut taken = false;
        let mut scale = 1.0;
        for _ in 0..12 {
            let y: Vec<f64> = x.iter().zip(&step).map(|(a, d)| a + scale * d).collect();
            let fy = f(std::slice::from_ref(&y))[0];
            if fy <= fx {
                (x, fx) = (y, fy);
                taken = true;
                break;
            }
            scale *= 0.5;
        }
        let converged = step.iter().zip(&x).all(|(d, v)| (scale * d).abs() < 1e-7 * v.abs().max(1e-2));
        if !taken || converged {
            return (x, fx, converged);
        }
    }
    (x, fx, false)
}

/// The unconstrained first- and second-order conditions at `x`.
struct Checked {
    gradient: f64,
    predicted_decrease: f64,
    smallest_curvature: f64,
    certified: bool,
    /// Points along directions of negative curvature that are lower.
    escapes: Vec<Vec<f64>>,
}

/// Checks `x` (deviance `fx`): gradient and Hessian by central differences
/// with steps of 1e-3 of max(|theta|, 0.1); the predicted decrease
/// g' H^+ g / 2 over the eigenvalues above 1e-8 of the largest must be
/// below 1e-7 of the deviance (at least 1e-6); along each eigenvector of
/// a negative eigenvalue beyond rounding, the deviance at 1e-2, 1e-1 and 1
/// either side must not be lower than `fx` (beyond 1e-10 of it).
fn certify(f: &mut Batch, x: &[f64], fx: f64) -> Checked {
    let m = x.len();
    let tolerance = (1e-7 * fx.abs()).max(1e-6);
    let rounding = 1e-10 * fx.abs().max(1.0);
    let h = steps(x, 1e-3);
    let (g, hess) = derivatives(f, x, fx, &h);
    let gradient = g.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let Ok(evd) = hess.self_adjoint_eigen(Side::Lower) else {
        return Checked {
            gradient,
            predicted_decrease: f64::NAN,
            smallest_curvature: f64::NAN,
            certified: false,
            escapes: Vec::new(),
        };
    };
    let (sv, u) = (evd.S().column_vector(), evd.U());
    let largest = (0..m).map(|i| sv[i].abs()).fold(0.0, f64::max);
    let mut predicted_decrease = 0.0;
    let mut smallest = f64::INFINITY;
    let mut probes = Vec::new();
    for i in 0..m {
        let lambda = sv[i];
        smallest = smallest.min(lambda / largest);
        let ug: f64 = (0..m).map(|j| u[(j, i)] * g[j]).sum();
        if lambda > 1e-8 * largest {
            predicted_decrease += ug * ug / (2.0 * lambda);
        } else if lambda < -1e-6 * largest {
            for t in [1e-2, 1e-1, 1.0, -1e-2, -1e-1, -1.0] {
                probes.push(x.iter().enumerate().map(|(j, v)| v + t * u[(j, i)]).collect::<Vec<f64>>());
            }
        }
    }
    let values = f(&probes);
    let escapes: Vec<Vec<f64>> =
        probes.into_iter().zip(values).filter(|(_, v)| *v < fx - rounding).map(|(p, _)| p).collect();
    let certified = fx.is_finite()
        && predicted_decrease.is_finite()
        && predicted_decrease <= tolerance
        && escapes.is_empty()
        && g.iter().all(|v| v.is_finite());
    Checked { gradient, predicted_decrease, smallest_curvature: smallest, certified, escapes }
}
