//! Crossed-design statistics, usable on their own: a balanced I x J array of
//! differences d_ij (rows = recordings, columns = seeds) and estimators for
//! its grand mean. Constructors validate and return [`StatsError`]; nothing
//! here panics on user data.

mod bootstrap;
pub mod coverage;
mod crossed;
mod intervals;
mod matrix;
pub mod mixed;
mod rng;

pub use bootstrap::{pigeonhole_bootstrap, pigeonhole_variance, BootstrapInterval};
pub use crossed::{
    crossed_mom, crossed_reml, mean_squares, CrossedEstimate, DfRule, MeanSquares, RemlSummary, VarianceComponents,
};
pub use intervals::{compare_intervals, one_sample_interval, reml_intervals, IntervalEstimate, IntervalMethod};
pub use matrix::CrossedMatrix;
pub use rng::standard_normal;

/// Errors from the statistics on user data.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
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
    if df.is_infinite() {
        let n = Normal::new(0.0, 1.0).expect("standard normal parameters are valid");
        return Ok(n.inverse_cdf(p));
    }
    if df.is_nan() || df <= 0.0 {
        return Err(StatsError::TooFew { what: "degrees of freedom", found: 0 });
    }
    let t = StudentsT::new(0.0, 1.0, df).map_err(|_| StatsError::TooFew { what: "degrees of freedom", found: 0 })?;
    Ok(t.inverse_cdf(p))
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
