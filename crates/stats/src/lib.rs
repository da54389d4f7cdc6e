//! Crossed-design statistics, usable on their own: a balanced I x J array of
//! differences d_ij (rows = recordings, columns = seeds) and estimators for
//! its grand mean, resampling, REML and `mixed` formulas checked against
//! lme4, and the coverage measures. Constructors validate and return
//! [`StatsError`]; nothing here panics on user data.
//!
//! This is the `crossaudit-stats` crate: it depends on no training,
//! plotting or parsing crate, reads no file, and `crossaudit` re-exports
//! it as `crossaudit::stats`. `docs/library.md` walks through it.

mod along;
mod bootstrap;
pub mod coverage;
mod crossed;
mod interval;
mod intervals;
mod loo;
mod matrix;
mod mean_profile;
pub mod mixed;
mod ratio;
pub mod resampling;
mod rng;
pub mod simsum;

/// The names most uses need, in one import: `use crossaudit_stats::prelude::*;`.
///
/// ```
/// use crossaudit_stats::prelude::*;
/// let m = CrossedMatrix::from_rows(&[vec![1.0, 2.0], vec![3.0, 5.0]]).unwrap();
/// let e = crossed_mom(&m, 0.95, DfRule::SeedsMinusOne).unwrap();
/// assert_eq!(e.mean, 2.75); // the plain mean of the four cells
/// assert_eq!(e.df, 1.0);
/// ```
pub mod prelude {
    pub use crate::coverage::{simulate, Distribution, Missing, Performance, Setting};
    pub use crate::mixed::formula::{
        compare_table, fit_glmm_table, fit_table, read_csv, DfMethod, FormulaFit, GlmmFormulaFit, Table,
    };
    pub use crate::mixed::glmm::Family;
    pub use crate::mixed::Criterion;
    pub use crate::{
        compare_intervals, crossed_mom, crossed_reml, further_intervals, leave_one_out_mom, mean_squares,
        pigeonhole_bootstrap, ratio_interval, Axis, CrossedEstimate, CrossedMatrix, DfRule, IntervalEstimate,
        IntervalMethod, StatsError,
    };
}

pub use along::{mean_squares_along, ALONG_LANES};
pub use bootstrap::{pigeonhole_bootstrap, pigeonhole_variance, BootstrapInterval};
pub use crossed::{
    crossed_mom, crossed_mom_draws, crossed_reml, mean_squares, mom_from_squares, CrossedEstimate, DfRule, MeanSquares,
    RemlSummary, VarianceComponents,
};
pub use intervals::{
    compare_intervals, further_intervals, incomplete_intervals, one_sample_interval, reml_intervals, IntervalEstimate,
    IntervalMethod,
};
pub use loo::{leave_one_out_mom, Axis};
pub use matrix::CrossedMatrix;
pub use mean_profile::profile_interval;
pub use ratio::{ratio_interval, ratio_interval_batched, FiellerSet, RatioInterval};
pub use rng::standard_normal;

/// The median (the mean of the middle two for an even count); NaN when
/// empty.
///
/// ```
/// assert_eq!(crossaudit_stats::median(vec![3.0, 1.0, 2.0]), 2.0);
/// assert_eq!(crossaudit_stats::median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
/// assert!(crossaudit_stats::median(Vec::new()).is_nan());
/// ```
pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

/// Degrees of freedom in JSON: a number when finite, `"infinite"` for the
/// normal quantile (z) and `"undefined"` where no df applies (a bootstrap
/// interval), which plain JSON numbers cannot tell apart (both would be
/// `null`). For `#[serde(serialize_with = "crossaudit_stats::df_json")]`.
pub fn df_json<S: serde::Serializer>(value: &f64, s: S) -> Result<S::Ok, S::Error> {
    if value.is_finite() {
        s.serialize_f64(*value)
    } else if value.is_infinite() {
        s.serialize_str("infinite")
    } else {
        s.serialize_str("undefined")
    }
}

/// Errors from the statistics on user data.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StatsError {
    /// Fewer than two levels of a factor.
    #[error("a crossed design needs at least 2 {what}, found {found}")]
    TooFew {
        /// What there are too few of.
        what: &'static str,
        /// How many there are.
        found: usize,
    },
    /// Values do not fill the declared shape.
    #[error("expected {expected} values for a {rows} x {cols} array, found {found}")]
    Shape {
        /// Declared rows.
        rows: usize,
        /// Declared columns.
        cols: usize,
        /// What was expected.
        expected: usize,
        /// How many there are.
        found: usize,
    },
    /// A NaN or infinite value.
    #[error("value at row {row}, column {col} is not finite ({value})")]
    NonFinite {
        /// Row index.
        row: usize,
        /// Column index.
        col: usize,
        /// The value as found.
        value: f64,
    },
    /// A confidence level outside (0, 1).
    #[error("confidence level {0} is outside (0, 1)")]
    Level(f64),
    /// A bootstrap with no replicates.
    #[error("the bootstrap needs at least 1 replicate")]
    NoReplicates,
    /// Group labels that do not fit the rows.
    #[error("group labels: {0}")]
    Groups(String),
    /// Any other invalid argument.
    #[error("{0}")]
    Invalid(String),
}

/// Two-sided quantile for `level`: t with `df` degrees of freedom, or the
/// normal when `df` is infinite.
pub fn critical_value(level: f64, df: f64) -> Result<f64, StatsError> {
    use statrs::distribution::{ContinuousCDF, Normal, StudentsT};
    if !(level > 0.0 && level < 1.0) {
        return Err(StatsError::Level(level));
    }
    let p = 0.5 + level / 2.0;
    if df.is_nan() || df <= 0.0 {
        return Err(StatsError::TooFew { what: "degrees of freedom", found: 0 });
    }
    if df > LARGE_DF {
        // The normal quantile, with (below infinite df, where each term is
        // 0) its Cornish-Fisher terms (Abramowitz and Stegun 26.7.5): exact
        // to rounding here, the next term of order df^-4 < 1e-24; statrs's
        // inverse searches without end beyond about 1e8 df.
        let z = Normal::new(0.0, 1.0).expect("standard normal parameters are valid").inverse_cdf(p);
        let (z2, n) = (z * z, df);
        let g1 = (z2 + 1.0) * z / 4.0;
        let g2 = ((5.0 * z2 + 16.0) * z2 + 3.0) * z / 96.0;
        let g3 = (((3.0 * z2 + 19.0) * z2 + 17.0) * z2 - 15.0) * z / 384.0;
        return Ok(z + g1 / n + g2 / (n * n) + g3 / (n * n * n));
    }
    let t = StudentsT::new(0.0, 1.0, df).map_err(|_| StatsError::TooFew { what: "degrees of freedom", found: 0 })?;
    if p <= EXTREME_P {
        // Checked as the tail is below: at df near 0 (1e-60) statrs's
        // inverse returns a small finite number, an interval of no width.
        let value = t.inverse_cdf(p);
        let back = t.cdf(-value);
        if value.is_finite() && (back - (1.0 - p)).abs() <= 1e-6 * (1.0 - p) {
            return Ok(value);
        }
        return Err(StatsError::Invalid(format!(
            "the {level} interval's t quantile on {df} df cannot be computed to working precision (its tail probability comes back as {back:e}, not {:e})",
            1.0 - p
        )));
    }
    // Far in the tail statrs's inverse loses its digits (for 1 df it is
    // off by a factor of 8 at level 0.999999999, and not even monotone):
    // the closed forms for 1 and 2 df, and otherwise the lower tail's
    // quantile, kept only when the distribution function gives its tail
    // probability back.
    let q = (1.0 - level) / 2.0;
    let value = if df == 1.0 {
        1.0 / (std::f64::consts::PI * q).tan()
    } else if df == 2.0 {
        (1.0 - 2.0 * q) / (2.0 * q * (1.0 - q)).sqrt()
    } else {
        -t.inverse_cdf(q)
    };
    // The closed forms are exact; the lower tail is checked.
    let back = if df == 1.0 || df == 2.0 { q } else { t.cdf(-value) };
    if !value.is_finite() || (back - q).abs() > 1e-6 * q {
        return Err(StatsError::Invalid(format!(
            "the {level} interval's t quantile on {df} df cannot be computed to working precision (its tail probability comes back as {back:e}, not {q:e}): lower the level"
        )));
    }
    Ok(value)
}

/// Above this many df the t quantile is the normal's with its
/// Cornish-Fisher terms ([`critical_value`]).
const LARGE_DF: f64 = 1e6;

/// Above this probability the t quantile is taken from its closed form or
/// its lower tail ([`critical_value`]); below it, as always.
const EXTREME_P: f64 = 0.9999;

/// Two-sided p-value of `t` on `df` degrees of freedom, P(|T| >= |t|),
/// for any df, as R's `2 * pt(-|t|, df)` computes it: the normal's where
/// `df` is infinite; above 4e5 df R's approximation (Abramowitz and Stegun
/// 26.7.8), P(T > t) = Q(t (1 - 1/(4 df)) / sqrt(1 + t^2 / (2 df))); below
/// that statrs's Student t, which beyond about 1e7 df loses digits (its
/// regularized incomplete beta at x = df / (df + t^2) rounds to 1, so
/// every p becomes 1). NaN for a NaN t or a df that is not positive.
pub fn t_two_sided_p(t: f64, df: f64) -> f64 {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    use statrs::function::erf::erfc;
    if t.is_nan() || df.is_nan() || df <= 0.0 {
        return f64::NAN;
    }
    let t = t.abs();
    if df.is_infinite() {
        return erfc(t / std::f64::consts::SQRT_2);
    }
    if df > 4e5 {
        let v = 1.0 / (4.0 * df);
        let z = t * (1.0 - v) / (1.0 + t * t * 2.0 * v).sqrt();
        return erfc(z / std::f64::consts::SQRT_2);
    }
    match StudentsT::new(0.0, 1.0, df) {
        Ok(dist) => (2.0 * dist.sf(t)).min(1.0),
        Err(_) => f64::NAN,
    }
}

/// Sample variance (divisor n - 1, R's `var`): mean first, then the
/// squared deviations; NaN (R's `NA`) from fewer than 2 values.
///
/// ```
/// use crossaudit_stats::sample_variance;
/// assert_eq!(sample_variance(&[1.0, 2.0, 3.0]), 1.0);
/// assert!(sample_variance(&[]).is_nan() && sample_variance(&[4.0]).is_nan());
/// ```
pub fn sample_variance(v: &[f64]) -> f64 {
    if v.len() < 2 {
        return f64::NAN;
    }
    let m = v.iter().sum::<f64>() / v.len() as f64;
    v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() as f64 - 1.0)
}

/// Sample quantile by linear interpolation between order statistics
/// (Hyndman & Fan type 7, R's default `quantile(type = 7)`). `sorted` must be
/// ascending and non-empty.
pub fn quantile_type7(sorted: &[f64], p: f64) -> f64 {
    let n = sorted.len();
    if n == 1 {
        return sorted[0];
    }
    let h = (n - 1) as f64 * p;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(n - 1);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// Uniform draws on [-0.5, 0.5) from a 64-bit LCG (Knuth's MMIX
/// constants): the unit tests' pseudo-random data, the same on every
/// machine.
#[cfg(test)]
pub(crate) fn lcg_uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}

#[cfg(test)]
mod tests {
    use super::critical_value;

    /// Far in the tail: 1 df is the Cauchy, whose upper q quantile x has
    /// atan(1/x) = pi q; 2 df has P(T > x) = (1 - x / sqrt(2 + x^2)) / 2
    /// = 1 / (s (s + x)) with s = sqrt(2 + x^2) (written without the
    /// cancellation).
    #[test]
    fn extreme_levels_give_the_closed_form_quantiles() {
        for level in [0.9999, 0.999999, 0.99999999, 0.999999999] {
            let q = (1.0 - level) / 2.0;
            let x1 = critical_value(level, 1.0).unwrap();
            let tail1 = (1.0 / x1).atan() / std::f64::consts::PI;
            assert!((tail1 - q).abs() < 1e-9 * q, "1 df at {level}: {x1}");
            let x2 = critical_value(level, 2.0).unwrap();
            let s = (2.0 + x2 * x2).sqrt();
            let tail2 = 1.0 / (s * (s + x2));
            assert!((tail2 - q).abs() < 1e-6 * q, "2 df at {level}: {x2}");
        }
    }

    #[test]
    fn quantiles_grow_with_the_level_at_any_df() {
        let levels = [0.9, 0.95, 0.99, 0.999, 0.9999, 0.99999, 0.999999, 0.9999999, 0.99999999, 0.999999999];
        for df in [1.0, 1.5, 2.0, 3.0, 5.0, 19.0, 1e3, f64::INFINITY] {
            let mut last = 0.0;
            for level in levels {
                if let Ok(t) = critical_value(level, df) {
                    assert!(t > last, "df {df}: {t} at {level} is not above {last}");
                    last = t;
                }
            }
        }
        // Ordinary levels are computed as before (t table: t(0.975, 19) = 2.093).
        assert!((critical_value(0.95, 19.0).unwrap() - 2.093024054408263).abs() < 1e-12);
    }
}
