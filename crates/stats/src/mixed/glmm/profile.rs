//! Profile-likelihood intervals of a GLMM's fixed effects and of its
//! scalar random effects' standard deviations, as lme4's
//! `confint(m, method = "profile")` defines them: the values b of beta_c
//! at which the Laplace deviance minimised over every other parameter
//! (theta and the other fixed effects) exceeds its minimum by the
//! chi-square(1) quantile at the level. The bounds are found by the secant
//! method on the signed root zeta(b) = sign(b - beta_c) sqrt(dev(b) -
//! dev_min), which is nearly linear in b, each profile point minimised by
//! the model's own search (warm-started from the last point). lme4
//! interpolates a spline through a grid of profile points; crossaudit
//! solves for the bound itself. A standard deviation is theta itself (a
//! GLMM has no residual scale), profiled the same way with its lower bound
//! at 0 where the deviance there stays under the threshold.

use serde::Serialize;

use super::{model, search_scales, GlmmData, GlmmFit};
use crate::mixed::slopes::optimize::minimize;
use crate::mixed::MixedError;

/// One fixed effect's profile interval.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FixedProfile {
    /// R's name.
    pub name: String,
    /// The lower bound.
    pub lower: f64,
    /// The upper bound.
    pub upper: f64,
}

/// Profile intervals at `level` of every scalar random effect's standard
/// deviation and every fixed effect of `fit` (a fit of `data` by
/// [`super::fit_glmm`]), in lme4's order.
pub fn profile_fixed(data: &GlmmData, fit: &GlmmFit, level: f64) -> Result<Vec<FixedProfile>, MixedError> {
    if !(level > 0.0 && level < 1.0) {
        return Err(MixedError::Level(level));
    }
    if !fit.separated.is_empty() {
        return Err(MixedError::Profile(format!(
            "the data separate {}, so the profile of the deviance does not reach a bound on their side (the likelihood rises without bound); no profile interval is computed",
            fit.separated.join(", ")
        )));
    }
    let (m, names, _) = model(data)?;
    let nt = m.structure.parameters();
    let scales = search_scales(&m);
    let optimum: Vec<f64> = fit
        .theta
        .iter()
        .copied()
        .chain(fit.fixed.iter().map(|f| f.estimate))
        .zip(&scales)
        .map(|(v, s)| v * s)
        .collect();
    let normal = statrs::distribution::Normal::standard();
    let root = statrs::distribution::ContinuousCDF::inverse_cdf(&normal, 0.5 + level / 2.0);
    let objective = |par: &[f64]| -> f64 {
        let par: Vec<f64> = par.iter().zip(&scales).map(|(v, s)| v / s).collect();
        m.evaluate(&par[..nt], &par[nt..], None, false).map(|l| l.objective).unwrap_or(f64::INFINITY)
    };
    let mut out = sd_profiles(&objective, &optimum, fit, (&scales, root))?;
    for (c, name) in names.iter().enumerate() {
        let j = nt + c;
        let se = fit.fixed[c].se * scales[j];
        let mut bounds = [0.0; 2];
        for (k, side) in [-1.0, 1.0].into_iter().enumerate() {
            let b = bound(&objective, &optimum, j, fit.deviance, (side, root, se))?;
            bounds[k] = b / scales[j];
        }
        out.push(FixedProfile { name: name.clone(), lower: bounds[0], upper: bounds[1] });
    }
    Ok(out)
}

/// The profile intervals of the standard deviations of the scalar random
/// effects `(1|g)` (theta itself: a GLMM has no residual scale), named as
/// lme4's `confint(..., oldNames = FALSE)` names them
/// (`sd_(Intercept)|g`), first as lme4 lists them. The deviance is even in
/// theta, so the lower bound is 0 where the deviance at 0 stays within the
/// level's threshold (lme4 reports 0 there too), and otherwise the bound's
/// absolute value. A term with more columns (correlations) gets no
/// interval: refused by name.
fn sd_profiles(
    objective: &(dyn Fn(&[f64]) -> f64 + Sync),
    optimum: &[f64],
    fit: &GlmmFit,
    (scales, root): (&[f64], f64),
) -> Result<Vec<FixedProfile>, MixedError> {
    let mut out = Vec::new();
    for (j, term) in fit.terms.iter().enumerate() {
        if term.names.len() != 1 || fit.terms.iter().any(|t| t.names.len() != 1) {
            return Err(MixedError::Profile(format!(
                "profile intervals of a GLMM's standard deviations are computed for scalar random effects (1|g); the term of {} has {} columns (and correlations)",
                term.group,
                term.names.len()
            )));
        }
        let name = format!("sd_{}|{}", term.names[0], term.group);
        let centre = optimum[j];
        // The first step: a tenth of the SD, at least 0.05 (scaled).
        let step = (0.1 * centre.abs()).max(0.05) / root;
        // The deviance at theta_j = 0, minimised over the rest.
        let with_zero = |x: &[f64]| {
            let mut full = x.to_vec();
            full.insert(j, 0.0);
            full
        };
        let others: Vec<f64> = optimum.iter().enumerate().filter(|(i, _)| *i != j).map(|(_, v)| *v).collect();
        let (_, at_zero, _, _) = minimize(&|x: &[f64]| objective(&with_zero(x)), others);
        let lower = if at_zero - fit.deviance <= root * root {
            0.0
        } else {
            bound(objective, optimum, j, fit.deviance, (-1.0, root, step))?.abs() / scales[j]
        };
        let upper = bound(objective, optimum, j, fit.deviance, (1.0, root, step))? / scales[j];
        out.push(FixedProfile { name, lower, upper });
    }
    Ok(out)
}

/// The bound on `side` (-1 or 1) of coordinate `j` (scaled): where the
/// signed root of the profile deviance reaches `side` x `root`, from a
/// first step of `root` x `se`.
fn bound(
    objective: &(dyn Fn(&[f64]) -> f64 + Sync),
    optimum: &[f64],
    j: usize,
    minimum: f64,
    (side, root, se): (f64, f64, f64),
) -> Result<f64, MixedError> {
    let centre = optimum[j];
    let mut others: Vec<f64> = optimum.iter().enumerate().filter(|(i, _)| *i != j).map(|(_, v)| *v).collect();
    let zeta = |b: f64, start: &mut Vec<f64>| -> f64 {
        let with = |x: &[f64]| -> Vec<f64> {
            let mut full = x.to_vec();
            full.insert(j, b);
            full
        };
        let (best, value, _, _) = minimize(&|x: &[f64]| objective(&with(x)), start.clone());
        *start = best;
        (b - centre).signum() * (value - minimum).max(0.0).sqrt()
    };
    let target = side * root;
    let (mut b0, mut z0) = (centre, 0.0);
    let mut b1 = centre + side * root * se;
    let mut z1 = zeta(b1, &mut others);
    for _ in 0..40 {
        if !z1.is_finite() {
            return Err(MixedError::Profile(format!(
                "the deviance is not finite at {b1} on the way to the bound; the interval cannot be computed"
            )));
        }
        if (z1 - target).abs() < 1e-8 {
            return Ok(b1);
        }
        let slope = (z1 - z0) / (b1 - b0);
        // zeta rises with b on both sides of the optimum.
        let next = if slope.is_finite() && slope > 0.0 {
            b1 + (target - z1) / slope
        } else {
            // A flat or turning profile: step further out.
            b1 + side * root * se
        };
        (b0, z0) = (b1, z1);
        b1 = next;
        z1 = zeta(b1, &mut others);
        if (b1 - b0).abs() < 1e-9 * se {
            return Ok(b1);
        }
    }
    Err(MixedError::Profile(format!(
        "the profile did not reach its bound on the {} side after 40 steps",
        if side < 0.0 { "lower" } else { "upper" }
    )))
}
