//! Profile-likelihood intervals for the standard deviations, as lme4's
//! `confint(fit, method = "profile")` defines them. lme4 profiles the ML
//! deviance whatever the fit (its `devfun2` calls `refitML` first), so
//! [`Criterion::Ml`] reproduces lme4; [`Criterion::Reml`] profiles the
//! REML deviance instead, with the same code.
//!
//! For each standard deviation s (a factor's sigma_k = theta_k sigma, or the
//! residual sigma), the profiled deviance d(v) is the minimum of the
//! deviance, not profiled over sigma,
//!
//! ```text
//! REML: log|L|^2 + log|R_X|^2 + (n - p) log(2 pi sigma^2) + r^2(theta) / sigma^2
//! ML:   log|L|^2 +          n log(2 pi sigma^2) + r^2(theta) / sigma^2
//! ```
//!
//! over every other parameter with s held at v. The interval is where
//! d(v) - d_min <= z^2, z the normal quantile of the level (lme4's signed
//! square root zeta = +-sqrt(d(v) - d_min) against +-z); a lower limit is 0
//! when the whole stretch down to zero stays below the cutoff. lme4 steps
//! along each profile and interpolates zeta by a spline; here each limit is
//! a root of d(v) - d_min - z^2 found by the Illinois method to a relative
//! 1e-9, each point an inner optimization warm-started at the last (or at
//! the estimates, whichever is lower) over the other SDs' signed values
//! (the deviance is even in each), so that an SD whose optimum is zero
//! near a limit does not trap the search. Checked against an exact profile
//! (lme4's deviance function, BOBYQA to 1e-12, uniroot to 1e-13;
//! `scripts/reference/mixed_profile.R`) to 1e-5 relative.

use serde::Serialize;

use super::system::System;
use super::{optimize, Criterion, MixedData, MixedError, MixedFit};

/// A profile-likelihood interval for one standard deviation.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProfileInterval {
    /// A factor's name, or `Residual`.
    pub name: String,
    /// The estimate (the square root of the variance).
    pub estimate: f64,
    /// Lower limit (0 when the profile stays below the cutoff down to 0).
    pub lower: f64,
    /// Upper limit.
    pub upper: f64,
}

/// The deviance at `theta` and `sigma`, not profiled over sigma; infinite
/// outside the parameter space or where the system cannot be solved.
fn deviance(s: &System, theta: &[f64], sigma: f64, criterion: Criterion) -> f64 {
    if sigma.is_nan() || sigma <= 0.0 || theta.iter().any(|t| t.is_nan() || *t < 0.0) {
        return f64::INFINITY;
    }
    s.unprofiled(theta, sigma, criterion).map_or(f64::INFINITY, |(d, _)| d)
}

/// The profile of standard deviation `which` (k factors, then the
/// residual) at `v`: the minimum over the others, from `start` (the other
/// factors' SDs and the residual SD, or the factors' SDs for the residual).
///
/// The deviance depends on each SD only through its square, so the search
/// runs over all of R^k on |x| (`nelder_mead_even`): near a limit another
/// SD's optimum is often zero (OrchardSprays' column SD at the residual's
/// upper limit), where a simplex clamped at zero collapses into the face
/// it hits and stops short of the minimum over the SDs left, making the
/// profile too high and the interval too narrow (0.4% on OrchardSprays).
/// A second search from the first's point and Newton steps polish it.
/// The search starts from the better of `start` (the last point's optimum)
/// and `fallback` (the estimates), with steps of `scale` (the largest
/// estimated SD): a last point whose SDs were all zero would otherwise
/// give a simplex of zero size, which never leaves zero.
fn profiled(
    s: &System,
    which: usize,
    v: f64,
    (start, fallback, scale): (&[f64], &[f64], f64),
    criterion: Criterion,
) -> (Vec<f64>, f64) {
    let k = s.factors();
    // Free parameters: the SDs of the other factors and the residual SD
    // (for a factor), or every factor's SD (for the residual).
    let mut f = |x: &[f64]| -> f64 {
        if which == k {
            let theta: Vec<f64> = x.iter().map(|sd| sd.abs() / v).collect();
            deviance(s, &theta, v, criterion)
        } else {
            let sigma = x[k - 1].abs();
            let mut theta = Vec::with_capacity(k);
            let mut others = x[..k - 1].iter();
            for j in 0..k {
                theta.push(if j == which { v } else { others.next().map_or(0.0, |sd| sd.abs()) } / sigma);
            }
            deviance(s, &theta, sigma, criterion)
        }
    };
    let (f0, f1) = (f(start), f(fallback));
    let (mut x, mut fx) = if f0 <= f1 { (start.to_vec(), f0) } else { (fallback.to_vec(), f1) };
    for step in [0.05, 0.005] {
        let (y, fy) = optimize::nelder_mead_even(&mut f, &x, step * scale, 1e-14);
        if fy <= fx {
            (x, fx) = (y, fy);
        }
    }
    let (x, fx, _) = optimize::newton_one_by_one(&mut f, x, fx, 12);
    (x, fx)
}

/// Profile-likelihood intervals at `level` for every factor's standard
/// deviation and the residual's: `data` is fitted by `criterion` and that
/// criterion's deviance profiled. lme4's `confint(method = "profile")` is
/// `Criterion::Ml`. Costs a few hundred fits' worth of deviance
/// evaluations.
pub fn profile_intervals(
    data: &MixedData,
    criterion: Criterion,
    level: f64,
) -> Result<Vec<ProfileInterval>, MixedError> {
    if level.is_nan() || level <= 0.0 || level >= 1.0 {
        return Err(MixedError::Level(level));
    }
    // Aliased fixed-effect columns are dropped as the fit drops them.
    let (data, _) = data.full_rank();
    let data: &MixedData = &data;
    let s = System::new(data);
    let fit: MixedFit = super::fit_system(&s, data, criterion, super::Inference::Estimates)?;
    let k = s.factors();
    let sigma = fit.residual.sqrt();
    let sds: Vec<f64> = fit.variances.iter().map(|v| v.sqrt()).chain([sigma]).collect();
    let d_min = deviance(&s, &fit.theta, sigma, criterion);
    let z = crate::critical_value(level, f64::INFINITY).map_err(|_| MixedError::Level(level))?;
    let cutoff = z * z;
    let scale = sds.iter().copied().fold(0.0, f64::max).max(f64::MIN_POSITIVE);
    let names: Vec<String> = fit.factors.iter().cloned().chain(["Residual".to_string()]).collect();
    let mut out = Vec::with_capacity(k + 1);
    for which in 0..=k {
        let others: Vec<f64> = (0..=k).filter(|&j| j != which).map(|j| sds[j]).collect();
        let est = sds[which];
        // g(v) = d(v) - d_min - z^2, with the inner optimum carried along
        // from point to point on each side.
        let sys = &s;
        let fallback: &[f64] = &others;
        let side = || {
            let mut warm = others.clone();
            move |v: f64| -> f64 {
                let (x, fx) = profiled(sys, which, v, (&warm, fallback, scale), criterion);
                warm = x;
                fx - d_min - cutoff
            }
        };
        let upper = limit(&mut side(), est, true, -cutoff)?;
        let mut g = side();
        let lower = if which < k && (est == 0.0 || g(0.0) <= 0.0) { 0.0 } else { limit(&mut g, est, false, -cutoff)? };
        out.push(ProfileInterval { name: names[which].clone(), estimate: est, lower, upper });
    }
    Ok(out)
}

/// The root of `g` above (or below) `est`, where g(est) = `at_est` < 0: a
/// bracket by doubling (halving) the distance from the estimate, then the
/// Illinois variant of regula falsi to a relative 1e-9.
fn limit(g: &mut dyn FnMut(f64) -> f64, est: f64, above: bool, at_est: f64) -> Result<f64, MixedError> {
    let base = if est > 0.0 { est } else { 1e-3 };
    let (mut a, mut ga) = (est, at_est);
    let mut b = if above { est + 0.5 * base } else { 0.5 * est };
    let mut gb = g(b);
    let mut tries = 0;
    while gb < 0.0 {
        tries += 1;
        if tries > 60 {
            return Err(MixedError::Profile(format!(
                "no {} limit found from {est}",
                if above { "upper" } else { "lower" }
            )));
        }
        (a, ga) = (b, gb);
        b = if above { est + (b - est) * 2.0 } else { b * 0.5 };
        gb = g(b);
    }
    let mut side = 0;
    for _ in 0..200 {
        let c = (a * gb - b * ga) / (gb - ga);
        if (b - a).abs() <= 1e-9 * c.abs().max(1e-12) {
            return Ok(c);
        }
        let gc = g(c);
        if gc == 0.0 {
            return Ok(c);
        }
        if (gc > 0.0) == (gb > 0.0) {
            (b, gb) = (c, gc);
            if side == -1 {
                ga /= 2.0;
            }
            side = -1;
        } else {
            (a, ga) = (c, gc);
            if side == 1 {
                gb /= 2.0;
            }
            side = 1;
        }
    }
    Ok(0.5 * (a + b))
}
