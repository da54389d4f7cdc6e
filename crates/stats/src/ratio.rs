//! An interval for a relative difference, the optimism
//! rho = (mean_R - mean_T) / mean_R of two paired crossed arrays T (treated)
//! and R (reference), from the same crossed estimator that gives the
//! interval of the difference.
//!
//! Fieller's interval inverts the estimator's own test. Optimism rho is the
//! null E[T] = (1 - rho) E[R], that is E[L(rho)] = 0 for the array
//! L(rho) = T - (1 - rho) R. The Fieller set is every rho whose array
//! L(rho) has an interval containing 0: |mean L(rho)| <= t(df) SE(L(rho)),
//! with the SE and df that the estimator gives L(rho). A threshold lies
//! outside the set exactly when the estimator's test rejects "optimism equals
//! the threshold" at the interval's level, which is what a margin asks.
//!
//! The delta method's interval is rho +- t(df) SE(L(rho_hat)) / |mean_R|:
//! Var(rho_hat) ~ Var(mean_d + rho mean_R) / mean_R^2 with d = T - R, the
//! first-order expansion of -mean_d / mean_R, and d + rho R = L(rho).
//!
//! Both are found numerically, so that any estimator (the method of moments
//! with its truncated components, REML with missing cells, any df rule)
//! can be used; `scripts/reference/optimism_interval.py` checks them
//! against Fieller's closed form (untruncated moments, a quadratic in rho)
//! and against a pigeonhole bootstrap of the ratio.

use serde::Serialize;

use super::{CrossedEstimate, StatsError};

/// The set Fieller's method gives: an interval, or, when the reference
/// mean's own interval contains 0, an unbounded set (the whole line or
/// two rays): the data then bound the ratio on neither side.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum FiellerSet {
    /// [lower, upper].
    Bounded {
        /// Lower bound.
        lower: f64,
        /// Upper bound.
        upper: f64,
    },
    /// Not bounded: the reference arm's mean is not distinguishable from 0.
    Unbounded,
}

impl FiellerSet {
    /// The bounds, when the set is bounded.
    pub fn bounds(&self) -> Option<(f64, f64)> {
        match *self {
            FiellerSet::Bounded { lower, upper } => Some((lower, upper)),
            FiellerSet::Unbounded => None,
        }
    }

    /// Whether `x` lies in the set (an unbounded set holds every value
    /// that matters for a threshold: its side is not determined).
    pub fn contains(&self, x: f64) -> bool {
        match *self {
            FiellerSet::Bounded { lower, upper } => lower <= x && x <= upper,
            FiellerSet::Unbounded => true,
        }
    }
}

/// Intervals for the ratio rho = (mean_R - mean_T) / mean_R.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RatioInterval {
    /// The point estimate (mean_R - mean_T) / mean_R.
    pub estimate: f64,
    /// Confidence level.
    pub level: f64,
    /// Fieller's set: the inverted test of the estimator.
    pub fieller: FiellerSet,
    /// The delta method's SE of rho_hat.
    pub delta_se: f64,
    /// The delta method's df (those of L(rho_hat)).
    #[serde(serialize_with = "crate::df_json")]
    pub delta_df: f64,
    /// Lower delta-method bound.
    pub delta_lower: f64,
    /// Upper delta-method bound.
    pub delta_upper: f64,
}

impl RatioInterval {
    /// The same intervals for k rho (for example k = 100: in percent).
    pub fn scaled(self, k: f64) -> RatioInterval {
        let (a, b) = (self.delta_lower * k, self.delta_upper * k);
        RatioInterval {
            estimate: self.estimate * k,
            level: self.level,
            fieller: match self.fieller {
                FiellerSet::Bounded { lower, upper } => {
                    FiellerSet::Bounded { lower: (lower * k).min(upper * k), upper: (lower * k).max(upper * k) }
                }
                FiellerSet::Unbounded => FiellerSet::Unbounded,
            },
            delta_se: self.delta_se * k.abs(),
            delta_df: self.delta_df,
            delta_lower: a.min(b),
            delta_upper: a.max(b),
        }
    }
}

/// `g(rho) = |mean L(rho)| - t SE(L(rho))`: negative inside Fieller's set.
fn excess(e: &CrossedEstimate) -> f64 {
    e.mean.abs() - e.critical * e.se
}

/// Intervals for the optimism rho = (mean_R - mean_T) / mean_R. `estimate`
/// gives the crossed estimate of the array L(rho) = T - (1 - rho) R for any
/// rho (the caller builds the array, so any estimator works); `reference`
/// is the estimate of R alone, whose interval says whether Fieller's set is
/// bounded; `point` is rho_hat.
///
/// ```
/// use crossaudit_stats::{crossed_mom, ratio_interval, CrossedMatrix, DfRule};
/// // 3 recordings x 2 seeds: T is R shrunk by a third plus noise.
/// let r = [3.0, 3.2, 2.9, 3.4, 3.1, 2.8];
/// let t = [2.1, 2.0, 2.0, 2.3, 2.1, 1.9];
/// let arr = |rho: f64| CrossedMatrix::new(3, 2, (0..6).map(|k| t[k] - (1.0 - rho) * r[k]).collect());
/// let at = |rho: f64| crossed_mom(&arr(rho)?, 0.95, DfRule::Normal);
/// let reference = crossed_mom(&CrossedMatrix::new(3, 2, r.to_vec()).unwrap(), 0.95, DfRule::Normal).unwrap();
/// let rho = (r.iter().sum::<f64>() - t.iter().sum::<f64>()) / r.iter().sum::<f64>();
/// let iv = ratio_interval(rho, &reference, at).unwrap();
/// assert!(iv.fieller.contains(rho) && !iv.fieller.contains(0.0));
/// assert!(iv.delta_lower < rho && rho < iv.delta_upper);
/// ```
pub fn ratio_interval(
    point: f64,
    reference: &CrossedEstimate,
    estimate: impl Fn(f64) -> Result<CrossedEstimate, StatsError> + Sync,
) -> Result<RatioInterval, StatsError> {
    if !point.is_finite() || !reference.mean.is_finite() || reference.mean == 0.0 {
        return Err(StatsError::Invalid(format!(
            "the ratio needs a finite estimate and a finite, non-zero reference mean (estimate {point}, reference mean {})",
            reference.mean
        )));
    }
    let at = estimate(point)?;
    let delta_se = at.se / reference.mean.abs();
    let fieller = if reference.lower <= 0.0 && 0.0 <= reference.upper {
        FiellerSet::Unbounded
    } else {
        let step = if delta_se > 0.0 { delta_se } else { 1e-6 * point.abs().max(1e-6) };
        // The two edges are searched at once, each its own sequence of
        // evaluations: the same numbers at any thread count.
        let (lower, upper) = rayon::join(|| root(point, -step, &estimate), || root(point, step, &estimate));
        match (lower?, upper?) {
            (Some(lower), Some(upper)) => FiellerSet::Bounded { lower, upper },
            _ => FiellerSet::Unbounded,
        }
    };
    Ok(RatioInterval {
        estimate: point,
        level: at.level,
        fieller,
        delta_se,
        delta_df: at.df,
        delta_lower: point - at.critical * delta_se,
        delta_upper: point + at.critical * delta_se,
    })
}

/// The first rho from `from` in the direction of `step` where the excess
/// turns positive (the edge of Fieller's set), to the last representable
/// digits; `None` when none is found within 2^60 steps.
fn root(
    from: f64,
    step: f64,
    estimate: &impl Fn(f64) -> Result<CrossedEstimate, StatsError>,
) -> Result<Option<f64>, StatsError> {
    // Inside: the excess at the point estimate is -t SE (or 0 when SE = 0,
    // where the set is the point itself).
    let (mut inside, mut width) = (from, step);
    let mut outside = None;
    for _ in 0..60 {
        let x = inside + width;
        if excess(&estimate(x)?) > 0.0 {
            outside = Some(x);
            break;
        }
        inside = x;
        width *= 2.0;
    }
    let Some(mut out) = outside else { return Ok(None) };
    // Bisection until the two ends are adjacent doubles (or 200 halvings).
    for _ in 0..200 {
        let mid = inside + (out - inside) / 2.0;
        if mid == inside || mid == out {
            break;
        }
        if excess(&estimate(mid)?) > 0.0 {
            out = mid;
        } else {
            inside = mid;
        }
    }
    Ok(Some(inside))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{crossed_mom, CrossedMatrix, DfRule};

    /// Fieller's closed form on an array whose moment components stay
    /// positive: Var(L(rho)) is the quadratic a + 2 b rho + c rho^2 of the
    /// untruncated mean squares, and the set's edges are the roots of
    /// (mean_d + rho mean_R)^2 = t^2 Var(L(rho)).
    #[test]
    fn fieller_matches_the_quadratic_closed_form() {
        let (rows, cols) = (6usize, 5usize);
        // Pseudo-random effects (a 64-bit LCG, uniform on [-0.5, 0.5)):
        // recording and seed effects in both arms, and noise.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut u = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let (ra, rb): (Vec<f64>, Vec<f64>) = ((0..rows).map(|_| u()).collect(), (0..cols).map(|_| u()).collect());
        let (ta, tb): (Vec<f64>, Vec<f64>) = ((0..rows).map(|_| u()).collect(), (0..cols).map(|_| u()).collect());
        let mut t = Vec::new();
        let mut r = Vec::new();
        for i in 0..rows {
            for j in 0..cols {
                let base = 1.0 + 0.4 * ra[i] + 0.3 * rb[j] + 0.05 * u();
                r.push(base);
                t.push(0.85 * base + 0.2 * ta[i] + 0.2 * tb[j] + 0.05 * u());
            }
        }
        let arr =
            |rho: f64| CrossedMatrix::new(rows, cols, (0..rows * cols).map(|k| t[k] - (1.0 - rho) * r[k]).collect());
        let at = |rho: f64| crossed_mom(&arr(rho)?, 0.95, DfRule::SeedsMinusOne);
        let rm = CrossedMatrix::new(rows, cols, r.clone()).unwrap();
        let reference = crossed_mom(&rm, 0.95, DfRule::SeedsMinusOne).unwrap();
        let (st, sr): (f64, f64) = (t.iter().sum(), r.iter().sum());
        let rho = (sr - st) / sr;
        let iv = ratio_interval(rho, &reference, at).unwrap();
        // Var(L(rho)) from three evaluations: a quadratic through them (the
        // components stay positive here, so no truncation bends it).
        let v = |x: f64| {
            let e = at(x).unwrap();
            let c = e.components;
            assert!(c.recording > 0.0 && c.seed > 0.0);
            e.se * e.se
        };
        let (v0, v1, vm) = (v(0.0), v(1.0), v(-1.0));
        let cq = (v1 + vm) / 2.0 - v0;
        let bq = (v1 - vm) / 2.0;
        let q = reference.critical.powi(2);
        let md = (st - sr) / (rows * cols) as f64;
        let mr = sr / (rows * cols) as f64;
        // (md + rho mr)^2 - q (v0 + bq rho + cq rho^2) = 0
        let (qa, qb, qc) = (mr * mr - q * cq, 2.0 * md * mr - q * bq, md * md - q * v0);
        let disc = (qb * qb - 4.0 * qa * qc).sqrt();
        let (lo, hi) = ((-qb - disc) / (2.0 * qa), (-qb + disc) / (2.0 * qa));
        for x in [lo, hi, rho] {
            let c = at(x).unwrap().components;
            assert!(c.recording > 0.0 && c.seed > 0.0, "truncated at {x}: {c:?}");
        }
        match iv.fieller {
            FiellerSet::Bounded { lower, upper } => {
                assert!((lower - lo).abs() < 1e-9, "{lower} vs {lo}");
                assert!((upper - hi).abs() < 1e-9, "{upper} vs {hi}");
            }
            FiellerSet::Unbounded => panic!("bounded expected"),
        }
        // The delta method is symmetric about rho_hat and, for a precisely
        // known denominator, close to Fieller.
        assert!((iv.delta_upper - rho - (rho - iv.delta_lower)).abs() < 1e-12);
        assert!((iv.delta_lower - lo).abs() < 0.2 * (hi - lo));
    }

    #[test]
    fn a_reference_mean_near_zero_gives_an_unbounded_set() {
        let r = [0.1, -0.2, 0.15, -0.05, 0.0, 0.02];
        let t = [0.0, -0.1, 0.1, -0.02, 0.01, 0.0];
        let arr = |rho: f64| CrossedMatrix::new(3, 2, (0..6).map(|k| t[k] - (1.0 - rho) * r[k]).collect());
        let at = |rho: f64| crossed_mom(&arr(rho)?, 0.95, DfRule::SeedsMinusOne);
        let reference = crossed_mom(&CrossedMatrix::new(3, 2, r.to_vec()).unwrap(), 0.95, DfRule::SeedsMinusOne);
        let reference = reference.unwrap();
        let sr: f64 = r.iter().sum();
        let st: f64 = t.iter().sum();
        let iv = ratio_interval((sr - st) / sr, &reference, at).unwrap();
        assert_eq!(iv.fieller, FiellerSet::Unbounded);
        assert!(iv.fieller.contains(1e9));
    }
}
