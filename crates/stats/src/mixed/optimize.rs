//! Minimisation of the profiled deviance over theta >= 0: Newton on
//! difference derivatives, Nelder-Mead, the first-order certificate and the
//! restarts that `optimum` combines.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

use super::system::System;
use super::{Certificate, Criterion, MixedError};

/// The optimum of the profiled deviance: theta, its deviance, the
/// evaluations used and its certificate.
pub(super) fn optimum(s: &System, criterion: Criterion) -> Result<(Vec<f64>, f64, usize, Certificate), MixedError> {
    let k = s.factors();
    let moments = s.moment_start();
    // The start is evaluated directly, so that a system that cannot be
    // factored (never, for finite data) is an error rather than an
    // infinite deviance.
    let f0 = s.evaluate(&moments, criterion)?.deviance;
    let evaluations = std::cell::Cell::new(1usize);
    let one = |theta: &[f64]| -> f64 { s.evaluate(theta, criterion).map(|e| e.deviance).unwrap_or(f64::INFINITY) };
    let mut dev = |theta: &[f64]| -> f64 {
        evaluations.set(evaluations.get() + 1);
        one(theta)
    };
    // Newton's difference stencils, evaluated in parallel: each point's
    // deviance is the same number in any order.
    let mut batch = |thetas: &[Vec<f64>]| -> Vec<f64> {
        use rayon::prelude::*;
        evaluations.set(evaluations.get() + thetas.len());
        thetas.par_iter().map(|t| one(t)).collect()
    };
    // Newton on difference derivatives from the moment start; where it does
    // not converge (a Hessian not positive definite far from the optimum,
    // an optimum on the boundary), Nelder-Mead to a relative 1e-4 and
    // Newton again, and then Nelder-Mead restarts with smaller simplices.
    let start = vec![1.0; k];
    let (mut best, mut best_dev, mut converged) = newton(&mut batch, moments.clone(), f0, 20);
    if !converged {
        let (t, d) = nelder_mead(&mut dev, &start, 0.5, 1e-4);
        if d < best_dev {
            (best, best_dev) = (t, d);
        }
        (best, best_dev, converged) = newton(&mut batch, best, best_dev, 12);
    }
    if !converged {
        for step in [0.1, 0.01, 1e-3, 1e-4] {
            let (t, d) = nelder_mead(&mut dev, &best, step, 1e-13);
            if d < best_dev {
                (best, best_dev) = (t, d);
            }
        }
        (best, best_dev, _) = newton(&mut batch, best, best_dev, 8);
    }
    // Boundary faces: a theta at exactly zero is where lme4's bounded
    // optimizer stops when the optimum is on the boundary.
    for j in 0..k {
        if best[j] == 0.0 {
            continue;
        }
        let mut t = best.clone();
        t[j] = 0.0;
        let d = dev(&t);
        if d <= best_dev {
            let (x, fx, _) = newton(&mut batch, t, d, 8);
            (best, best_dev) = (x, fx);
        }
    }
    // The certificate: the first-order conditions of a minimum over
    // theta >= 0 (Karush-Kuhn-Tucker), checked where the search stopped.
    // Newton holds a theta it clamped to zero there for good, and a
    // clamped simplex collapses into the face it hits, so a boundary point
    // that is not the optimum can look converged: where the certificate
    // fails, the search leaves the boundary in the direction that lowers
    // the deviance and restarts from several points, by Nelder-Mead over
    // all of R^k (the deviance is even in each theta, so zero is an
    // ordinary point for it) and Newton, until the certificate holds.
    let mut certificate = certify(&mut batch, &best, best_dev);
    let mut restarts = 0;
    for _ in 0..4 {
        if certificate.certified {
            break;
        }
        let mut starts: Vec<Vec<f64>> = certificate.escapes.clone();
        starts.push(best.clone());
        starts.push(moments.clone());
        starts.push(start.clone());
        starts.push(best.iter().map(|t| t.max(0.5)).collect());
        for from in starts {
            restarts += 1;
            let (t, d) = nelder_mead_even(&mut dev, &from, 0.5, 1e-12);
            // Thetas below 1e-6 are set to zero when that is no worse: the
            // point and its deviance stay a pair.
            let zeroed: Vec<f64> = t.iter().map(|&v| if v < 1e-6 { 0.0 } else { v }).collect();
            let (t, d) = if zeroed != t {
                let dz = dev(&zeroed);
                if dz <= d {
                    (zeroed, dz)
                } else {
                    (t, d)
                }
            } else {
                (t, d)
            };
            let (mut t, mut d, converged) = newton(&mut batch, t, d, 30);
            if !converged {
                for step in [0.1, 0.01, 1e-3] {
                    let (t2, d2) = nelder_mead_even(&mut dev, &t, step, 1e-14);
                    if d2 < d {
                        (t, d) = (t2, d2);
                    }
                }
                (t, d, _) = newton(&mut batch, t, d, 12);
            }
            if d < best_dev {
                (best, best_dev) = (t, d);
            }
        }
        certificate = certify(&mut batch, &best, best_dev);
    }
    let certificate = Certificate {
        gradient: certificate.gradient,
        predicted_decrease: certificate.predicted_decrease,
        boundary: certificate.boundary,
        certified: certificate.certified,
        restarts,
    };
    Ok((best, best_dev, evaluations.get(), certificate))
}

/// Minimises `f` over the non-negative orthant by Nelder-Mead (reflections
/// clamped at zero), from `start`, until the simplex's deviances agree to a
/// relative `tol`, its vertices to 1e-10, or 20,000 iterations.
pub(super) fn nelder_mead(f: &mut dyn FnMut(&[f64]) -> f64, start: &[f64], step: f64, tol: f64) -> (Vec<f64>, f64) {
    simplex_search(f, start, step, tol, true)
}

/// Nelder-Mead over all of R^k, for a deviance that is even in every
/// coordinate (it depends on theta only through theta^2): the boundary
/// theta = 0 is then an ordinary interior point, which a simplex crosses
/// and leaves as easily as any other, where clamped reflections collapse
/// the simplex into the face they hit. Returns |theta|.
pub(crate) fn nelder_mead_even(
    f: &mut dyn FnMut(&[f64]) -> f64,
    start: &[f64],
    step: f64,
    tol: f64,
) -> (Vec<f64>, f64) {
    let (x, fx) = simplex_search(f, start, step, tol, false);
    (x.into_iter().map(f64::abs).collect(), fx)
}

/// Nelder-Mead over all of R^k, for a function with no boundary (the
/// random-slope deviance), returning the point as found.
pub(super) fn nelder_mead_free(
    f: &mut dyn FnMut(&[f64]) -> f64,
    start: &[f64],
    step: f64,
    tol: f64,
) -> (Vec<f64>, f64) {
    simplex_search(f, start, step, tol, false)
}

fn simplex_search(
    f: &mut dyn FnMut(&[f64]) -> f64,
    start: &[f64],
    step: f64,
    tol: f64,
    bounded: bool,
) -> (Vec<f64>, f64) {
    let k = start.len();
    let clamp = |v: Vec<f64>| -> Vec<f64> {
        if bounded {
            v.into_iter().map(|x| x.max(0.0)).collect()
        } else {
            v
        }
    };
    let mut simplex: Vec<Vec<f64>> = vec![start.to_vec()];
    for i in 0..k {
        let mut v = start.to_vec();
        v[i] += step;
        simplex.push(v);
    }
    let mut values: Vec<f64> = simplex.iter().map(|v| f(v)).collect();
    for _ in 0..20_000 {
        let mut order: Vec<usize> = (0..=k).collect();
        order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
        simplex = order.iter().map(|&i| simplex[i].clone()).collect();
        values = order.iter().map(|&i| values[i]).collect();
        let spread = values[k] - values[0];
        let size =
            simplex[1..].iter().flat_map(|v| v.iter().zip(&simplex[0]).map(|(a, b)| (a - b).abs())).fold(0.0, f64::max);
        if spread <= tol * (1.0 + values[0].abs()) || size < 1e-10 {
            break;
        }
        let centroid: Vec<f64> = (0..k).map(|j| simplex[..k].iter().map(|v| v[j]).sum::<f64>() / k as f64).collect();
        let towards =
            |t: f64| -> Vec<f64> { clamp((0..k).map(|j| centroid[j] + t * (simplex[k][j] - centroid[j])).collect()) };
        let reflected = towards(-1.0);
        let fr = f(&reflected);
        if fr < values[0] {
            let expanded = towards(-2.0);
            let fe = f(&expanded);
            (simplex[k], values[k]) = if fe < fr { (expanded, fe) } else { (reflected, fr) };
        } else if fr < values[k - 1] {
            (simplex[k], values[k]) = (reflected, fr);
        } else {
            let contracted = if fr < values[k] { towards(-0.5) } else { towards(0.5) };
            let fc = f(&contracted);
            if fc < values[k].min(fr) {
                (simplex[k], values[k]) = (contracted, fc);
            } else {
                for i in 1..=k {
                    simplex[i] = clamp((0..k).map(|j| simplex[0][j] + 0.5 * (simplex[i][j] - simplex[0][j])).collect());
                    values[i] = f(&simplex[i]);
                }
            }
        }
    }
    let best = (0..=k).min_by(|&a, &b| values[a].total_cmp(&values[b])).unwrap_or(0);
    (simplex[best].clone(), values[best])
}

/// Evaluates a batch of points, returning one value per point in order.
pub(super) type Batch<'a> = dyn FnMut(&[Vec<f64>]) -> Vec<f64> + 'a;

/// [`newton`] on a function evaluated one point at a time.
pub(super) fn newton_one_by_one(
    f: &mut dyn FnMut(&[f64]) -> f64,
    x: Vec<f64>,
    fx: f64,
    iterations: usize,
) -> (Vec<f64>, f64, bool) {
    newton(&mut |xs: &[Vec<f64>]| xs.iter().map(|x| f(x)).collect(), x, fx, iterations)
}

/// Newton steps from `x` on the coordinates not at zero, with gradient
/// by central differences and Hessian by differences of the same points
/// (one more point per pair of coordinates), each step taken only if the
/// deviance does not rise (halved up to four times otherwise). Once a step
/// is small (below 1e-3 of theta) the Hessian is kept for the next steps,
/// which then cost 2k + 1 evaluations instead of 2k + k(k-1)/2 + 1. A
/// derivative-free search stops where the deviance is flat to its
/// rounding, which leaves theta about sqrt(1e-13) from the optimum; the
/// gradient's root is a thousand times sharper. Returns the point, its
/// value and whether it converged (a step below 1e-5 of theta taken).
/// The points of each difference stencil go to `f` as one batch.
pub(super) fn newton(f: &mut Batch, mut x: Vec<f64>, mut fx: f64, iterations: usize) -> (Vec<f64>, f64, bool) {
    let mut kept: Option<(Vec<usize>, Mat<f64>)> = None;
    for _ in 0..iterations {
        let free: Vec<usize> = (0..x.len()).filter(|&i| x[i] > 0.0).collect();
        let m = free.len();
        if m == 0 {
            return (x, fx, true);
        }
        let h: Vec<f64> = free.iter().map(|&i| (1e-4 * x[i].max(1.0)).min(0.5 * x[i])).collect();
        let at = |d: &[(usize, f64)]| {
            let mut y = x.clone();
            for &(j, s) in d {
                y[free[j]] += s;
            }
            y
        };
        // Each stencil's points are evaluated as one batch (in parallel,
        // where the caller can).
        let pm: Vec<Vec<f64>> = (0..m).flat_map(|a| [at(&[(a, h[a])]), at(&[(a, -h[a])])]).collect();
        let pm = f(&pm);
        let mut g = Mat::<f64>::zeros(m, 1);
        let mut plus = vec![0.0; m];
        let mut curvature = vec![0.0; m];
        for a in 0..m {
            let (fp, fm) = (pm[2 * a], pm[2 * a + 1]);
            g[(a, 0)] = (fp - fm) / (2.0 * h[a]);
            curvature[a] = (fp - 2.0 * fx + fm) / (h[a] * h[a]);
            plus[a] = fp;
        }
        let hess = match kept.take() {
            Some((free_then, hess)) if free_then == free => hess,
            _ => {
                let pairs: Vec<Vec<f64>> = (0..m)
                    .flat_map(|a| (0..a).map(move |b| (a, b)))
                    .map(|(a, b)| at(&[(a, h[a]), (b, h[b])]))
                    .collect();
                let mut pp = f(&pairs).into_iter();
                let mut hess = Mat::<f64>::zeros(m, m);
                for a in 0..m {
                    hess[(a, a)] = curvature[a];
                    for b in 0..a {
                        let pp = pp.next().unwrap_or(f64::NAN);
                        hess[(a, b)] = (pp - plus[a] - plus[b] + fx) / (h[a] * h[b]);
                        hess[(b, a)] = hess[(a, b)];
                    }
                }
                hess
            }
        };
        // Far from the optimum the Hessian may be indefinite: its
        // eigenvalues are then replaced by their absolute values (floored
        // at 1e-6 of the largest), which keeps the step a descent direction.
        let step = match hess.llt(Side::Lower) {
            Ok(llt) => llt.solve(&g),
            Err(_) => {
                let Ok(evd) = hess.self_adjoint_eigen(Side::Lower) else { return (x, fx, false) };
                let (sv, u) = (evd.S().column_vector(), evd.U());
                let largest = (0..m).map(|i| sv[i].abs()).fold(0.0, f64::max);
                if largest.is_nan() || largest <= 0.0 {
                    return (x, fx, false);
                }
                let ug = u.transpose() * &g;
                let scaled = Mat::<f64>::from_fn(m, 1, |i, _| ug[(i, 0)] / sv[i].abs().max(1e-6 * largest));
                u * scaled
            }
        };
        let mut taken = false;
        let mut scale = 1.0;
        for _ in 0..12 {
            let mut y = x.clone();
            for (j, &i) in free.iter().enumerate() {
                y[i] = (x[i] - scale * step[(j, 0)]).max(0.0);
            }
            let fy = f(std::slice::from_ref(&y))[0];
            if fy <= fx {
                (x, fx) = (y, fy);
                taken = true;
                break;
            }
            scale *= 0.5;
        }
        // Newton converges quadratically (linearly with a kept Hessian, at
        // a rate of the Hessian's change, below 1e-3): after a step below
        // 1e-5 of theta the error left is below 1e-8 of theta, far below
        // what the variances are reported to. (The difference gradient
        // carries the deviance's rounding divided by the difference step,
        // which keeps steps at about 1e-10 however long one iterates.)
        let relative = |tol: f64| free.iter().enumerate().all(|(j, &i)| step[(j, 0)].abs() < tol * x[i].max(1e-2));
        let converged = relative(1e-5);
        if !taken || converged {
            return (x, fx, converged);
        }
        if relative(1e-3) && scale == 1.0 {
            kept = Some((free, hess));
        }
    }
    (x, fx, false)
}

/// The first-order conditions at `x` (see `Certificate` in the parent
/// module), and the points that leave the boundary to a lower deviance.
pub(super) struct Checked {
    pub gradient: f64,
    pub predicted_decrease: f64,
    pub boundary: Vec<Option<f64>>,
    pub certified: bool,
    /// For each boundary theta whose ladder found a lower deviance: `x`
    /// with that theta at the lowest point of its ladder.
    pub escapes: Vec<Vec<f64>>,
}

/// A theta below this is on the boundary (lme4's `isSingular` flags
/// 1e-4; a theta of 1e-6 is a variance ratio of 1e-12).
const BOUNDARY: f64 = 1e-6;

/// Checks the first-order conditions of a minimum over theta >= 0 at `x`
/// (deviance `fx`). Off the boundary: central differences with a step of
/// 1e-3 of max(theta, 0.1), which the deviance's evenness lets cross zero;
/// the predicted decrease sum g^2 / (2 H_kk) must be below 1e-7 of the
/// deviance (at least 1e-6), and every H_kk positive. On it: the
/// one-sided derivative in theta^2 from a step of 0.01, and the deviance
/// at theta = 0.01, 0.03, 0.1, 0.3, 1 and 3 (the rest held), none lower
/// than `fx` beyond rounding (1e-10 of the deviance).
pub(super) fn certify(f: &mut Batch, x: &[f64], fx: f64) -> Checked {
    let k = x.len();
    let tolerance = (1e-7 * fx.abs()).max(1e-6);
    let rounding = 1e-10 * fx.abs().max(1.0);
    let mut gradient: f64 = 0.0;
    let mut predicted_decrease = 0.0;
    let mut boundary = vec![None; k];
    let mut escapes = Vec::new();
    let mut certified = fx.is_finite();
    // Every point the checks visit, evaluated as one batch: per coordinate
    // at the boundary, its value at h and at each escape distance; per
    // interior coordinate, x -+ h.
    const H: f64 = 1e-2;
    const ESCAPES: [f64; 6] = [0.01, 0.03, 0.1, 0.3, 1.0, 3.0];
    let step = |j: usize| 1e-3 * x[j].max(0.1);
    let with = |j: usize, t: f64| {
        let mut y = x.to_vec();
        y[j] = t;
        y
    };
    let points: Vec<Vec<f64>> = (0..k)
        .flat_map(|j| -> Vec<Vec<f64>> {
            if x[j] < BOUNDARY {
                std::iter::once(H).chain(ESCAPES).map(|t| with(j, t)).collect()
            } else {
                vec![with(j, x[j] + step(j)), with(j, x[j] - step(j))]
            }
        })
        .collect();
    let values = f(&points);
    let mut at = values.into_iter();
    let mut next = || at.next().unwrap_or(f64::NAN);
    for j in 0..k {
        if x[j] < BOUNDARY {
            let derivative = (next() - fx) / (H * H - x[j] * x[j]);
            boundary[j] = Some(derivative);
            let mut lowest = (fx - rounding, None);
            for t in ESCAPES {
                let v = next();
                if v < lowest.0 {
                    lowest = (v, Some(t));
                }
            }
            if let (_, Some(t)) = lowest {
                escapes.push(with(j, t));
                certified = false;
            } else if derivative * H * H < -rounding {
                escapes.push(with(j, H));
                certified = false;
            }
        } else {
            let h = step(j);
            let (fp, fm) = (next(), next());
            let g = (fp - fm) / (2.0 * h);
            let curvature = (fp - 2.0 * fx + fm) / (h * h);
            gradient = gradient.max(g.abs());
            if curvature > 0.0 {
                predicted_decrease += g * g / (2.0 * curvature);
            } else if (fp.min(fm)) < fx - rounding {
                certified = false;
            }
            if !fp.is_finite() || !fm.is_finite() {
                certified = false;
            }
        }
    }
    if predicted_decrease.is_nan() || predicted_decrease > tolerance {
        certified = false;
    }
    Checked { gradient, predicted_decrease, boundary, certified, escapes }
}
