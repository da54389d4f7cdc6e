//! Monte Carlo coverage of the interval estimators for crossed designs.
//!
//! Balanced arrays d_ij = mu + a_i + b_j + e_ij are drawn with declared
//! I, J, variance components (given as shares of the true SE^2) and
//! distributions; every estimator of [`compare_intervals`] is applied to each
//! array; performance measures follow Morris, White & Crowther (2019,
//! Stat. Med. 38:2074) as implemented in rsimsum, each with its Monte Carlo
//! standard error. Replications run in parallel, each on its own ChaCha8
//! stream, so results do not depend on the thread count.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{compare_intervals, CrossedMatrix, IntervalMethod, StatsError};

mod measures;
pub mod ratio;
pub(crate) use measures::correlation;
pub use measures::measures;

/// How the random effects and errors are distributed (all scaled to the
/// declared variances).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Distribution {
    /// Normal effects and errors.
    Normal,
    /// Student t with 3 df, scaled to unit variance.
    HeavyTailed,
    /// Centred exponential (skewness 2), unit variance.
    Skewed,
    /// Residual SD varies by row: row i has SD multiplier sqrt(3) * (i+1)/I
    /// rescaled so the average residual variance is as declared.
    HeteroscedasticRows,
    /// Normal, but the first row's effect is 5 recording SDs.
    OutlyingRow,
}

/// Which cells of a simulated array are lost before the analysis.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Missing {
    /// Every cell present.
    #[default]
    Complete,
    /// Each cell lost independently with this probability (a failed job,
    /// an all-divergent cell): missing completely at random.
    Mcar(f64),
    /// This many whole rows lost, chosen at random (a recording with too
    /// few valid starts for every seed).
    RowLoss(usize),
}

/// One simulation setting.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Setting {
    /// Number of recordings I.
    pub rows: usize,
    /// Number of seeds J.
    pub cols: usize,
    /// Shares of the true SE^2 from rows, columns and residual (sum to 1).
    pub shares: [f64; 3],
    /// Distribution of effects and errors.
    pub distribution: Distribution,
    /// Cells lost before the analysis.
    #[serde(default)]
    pub missing: Missing,
}

impl Setting {
    /// Variance components giving SE^2 = 1 with the declared shares:
    /// sa = s_a I, sb = s_b J, se = s_e I J.
    pub fn components(&self) -> (f64, f64, f64) {
        let (i, j) = (self.rows as f64, self.cols as f64);
        (self.shares[0] * i, self.shares[1] * j, self.shares[2] * i * j)
    }

    /// What every estimator's expected value is away from the true mean 0
    /// by construction, in SE units: `outlying_row` fixes the first row's
    /// effect at 5 recording SDs, which moves the mean of I rows by
    /// 5 sqrt(sa) / I = 5 sqrt(s_a / I). 0 for every other distribution.
    pub fn built_in_bias(&self) -> f64 {
        match self.distribution {
            Distribution::OutlyingRow => 5.0 * self.components().0.sqrt() / self.rows as f64,
            _ => 0.0,
        }
    }

    /// A one-line label for tables.
    pub fn label(&self) -> String {
        let missing = match self.missing {
            Missing::Complete => String::new(),
            Missing::Mcar(p) => format!(", {:.0}% of cells missing at random", 100.0 * p),
            Missing::RowLoss(k) => format!(", {k} whole row(s) lost"),
        };
        format!(
            "I={} J={} shares {:.1}/{:.1}/{:.1} {:?}{missing}",
            self.rows,
            self.cols,
            100.0 * self.shares[0],
            100.0 * self.shares[1],
            100.0 * self.shares[2],
            self.distribution
        )
    }
}

fn standard_draw(d: Distribution, rng: &mut ChaCha8Rng) -> f64 {
    let normal = |rng: &mut ChaCha8Rng| super::standard_normal(rng);
    match d {
        Distribution::Normal | Distribution::HeteroscedasticRows | Distribution::OutlyingRow => normal(rng),
        Distribution::HeavyTailed => {
            // t_3 = Z / sqrt(chi2_3 / 3); Var = 3, so divide by sqrt(3).
            let z = normal(rng);
            let chi2: f64 = (0..3).map(|_| normal(rng).powi(2)).sum();
            z / (chi2 / 3.0).sqrt() / 3f64.sqrt()
        }
        Distribution::Skewed => {
            let u: f64 = rng.gen_range(f64::MIN_POSITIVE..1.0);
            -u.ln() - 1.0
        }
    }
}

/// One simulated array with true mean 0.
pub fn draw_array(s: &Setting, rng: &mut ChaCha8Rng) -> Result<CrossedMatrix, StatsError> {
    let (sa, sb, se) = s.components();
    let d = s.distribution;
    let mut a: Vec<f64> = (0..s.rows).map(|_| sa.sqrt() * standard_draw(d, rng)).collect();
    if d == Distribution::OutlyingRow {
        a[0] = 5.0 * sa.sqrt();
    }
    let b: Vec<f64> = (0..s.cols).map(|_| sb.sqrt() * standard_draw(d, rng)).collect();
    // Heteroscedastic multipliers m_i with mean(m_i^2) = 1.
    let m: Vec<f64> = if d == Distribution::HeteroscedasticRows {
        let raw: Vec<f64> = (0..s.rows).map(|i| (i + 1) as f64).collect();
        let ms = raw.iter().map(|x| x * x).sum::<f64>() / s.rows as f64;
        raw.iter().map(|x| x / ms.sqrt()).collect()
    } else {
        vec![1.0; s.rows]
    };
    let mut data = Vec::with_capacity(s.rows * s.cols);
    for i in 0..s.rows {
        for bj in &b {
            data.push(a[i] + bj + m[i] * se.sqrt() * standard_draw(d, rng));
        }
    }
    CrossedMatrix::new(s.rows, s.cols, data)
}

/// Performance of one estimator in one setting, with Monte Carlo SEs.
#[derive(Debug, Clone, Serialize)]
pub struct Performance {
    /// The setting's label.
    pub setting: String,
    /// The interval method.
    pub method: IntervalMethod,
    /// Replications.
    pub reps: usize,
    /// Fraction of intervals covering the true mean.
    pub coverage: f64,
    /// Monte Carlo SE of the coverage.
    pub coverage_mcse: f64,
    /// Mean interval width.
    pub mean_width: f64,
    /// Monte Carlo SE of the mean width.
    pub mean_width_mcse: f64,
    /// Median interval width.
    pub median_width: f64,
    /// Mean estimate minus the truth.
    pub bias: f64,
    /// Monte Carlo SE of the bias.
    pub bias_mcse: f64,
    /// Empirical SE: SD of the estimates.
    pub emp_se: f64,
    /// Monte Carlo SE of the empirical SE.
    pub emp_se_mcse: f64,
    /// Model SE: root mean of the estimated SE^2.
    pub mod_se: f64,
    /// Monte Carlo SE of the model SE.
    pub mod_se_mcse: f64,
    /// 100 (ModSE / EmpSE - 1).
    pub rel_error_mod_se: f64,
    /// Monte Carlo SE of the relative error.
    pub rel_error_mod_se_mcse: f64,
    /// Replications where the estimator gave no interval (left out of
    /// every measure above).
    pub undefined: usize,
    /// Share of intervals wholly below the truth (upper < truth): the
    /// misses that make a one-sided rule `upper < 0` hold wrongly when the
    /// truth is zero.
    pub miss_below: f64,
    /// Monte Carlo SE of `miss_below`.
    pub miss_below_mcse: f64,
    /// Share of intervals wholly above the truth (lower > truth).
    pub miss_above: f64,
    /// Monte Carlo SE of `miss_above`.
    pub miss_above_mcse: f64,
    /// Mean squared error of the estimates.
    pub mse: f64,
    /// Monte Carlo SE of the MSE.
    pub mse_mcse: f64,
    /// Bias-eliminated coverage: the share of intervals covering the mean
    /// estimate rather than the truth.
    pub be_coverage: f64,
    /// Monte Carlo SE of the bias-eliminated coverage.
    pub be_coverage_mcse: f64,
    /// The true mean mu the arrays were drawn around.
    pub true_mean: f64,
    /// The intervals' nominal level.
    pub level: f64,
    /// Relative bias, mean((estimate - mu) / mu) (rsimsum's `rbias`); NaN
    /// when mu = 0.
    pub rel_bias: f64,
    /// Monte Carlo SE of the relative bias.
    pub rel_bias_mcse: f64,
    /// rsimsum's power: the share with |estimate| >= z_{1 - (1 - level)/2}
    /// SE (a Wald z test, whatever the interval).
    pub power: f64,
    /// Monte Carlo SE of the power.
    pub power_mcse: f64,
    /// The share of intervals that exclude 0 (lower > 0 or upper < 0): the
    /// estimator's own test, the one a decision rule reads. With mu = 0,
    /// its type I error rate.
    pub rejection: f64,
    /// Monte Carlo SE of the rejection rate.
    pub rejection_mcse: f64,
    /// Type S error (Gelman & Carlin 2014): among intervals that exclude 0,
    /// the share on the side opposite to mu; NaN when mu = 0 or none does.
    pub type_s: f64,
    /// Monte Carlo SE of the type S error (over the intervals excluding 0).
    pub type_s_mcse: f64,
    /// Relative precision against the setting's first estimator,
    /// 100 ((EmpSE_ref / EmpSE)^2 - 1) (rsimsum's `relprec`).
    pub rel_precision: f64,
    /// Its paired Monte Carlo SE, 200 (EmpSE_ref / EmpSE)^2
    /// sqrt((1 - rho^2) / (n - 1)), rho the correlation of the two
    /// estimators' estimates over the replications where both are defined.
    pub rel_precision_mcse: f64,
    /// Median df of the usable replications (NaN where no df applies:
    /// bootstrap; infinite for the normal).
    pub df_median: f64,
    /// Share of the scored replications whose fit put a variance component
    /// at the boundary: the MoM truncated one at zero, or REML's fit was
    /// singular (0 for estimators without components; set by [`measures`]).
    pub boundary: f64,
    /// Monte Carlo SE of `boundary`.
    pub boundary_mcse: f64,
}

/// One replication's (estimate, SE, lower, upper).
pub type Estimate = (f64, f64, f64, f64);

/// Morris, White & Crowther (2019), Table 6, against the true value, over
/// the usable replications of `est` (see [`usable`]; `reps` counts them).
/// Monte Carlo SEs need two or more and are NaN with fewer. The level,
/// power, rejection rate and df are left NaN (see [`performance_at`]).
pub fn performance(setting: &str, method: IntervalMethod, est: &[Estimate], truth: f64) -> Performance {
    performance_at(setting, method, est, &[], truth, f64::NAN)
}

/// As [`performance`], at a nominal level with each replication's df
/// (`dfs`, parallel to `est`; empty for none): adds the power, the
/// rejection rate, the type S error, the relative bias and the median df.
/// The relative precision needs the other estimators ([`measures`]).
pub fn performance_at(
    setting: &str,
    method: IntervalMethod,
    est: &[Estimate],
    dfs: &[f64],
    truth: f64,
    level: f64,
) -> Performance {
    performance_each(setting, method, est, dfs, Truth::One(truth), level)
}

/// The true value of a set of replications: one for all, or each
/// replication's own (parallel to the estimates), as rsimsum takes `true`
/// as a number or a column.
#[derive(Debug, Clone, Copy)]
pub enum Truth<'a> {
    /// The same for every replication.
    One(f64),
    /// Each replication's, parallel to the estimates.
    Each(&'a [f64]),
}

/// As [`performance_at`], against each replication's own true value where
/// `truth` gives one per replication (rsimsum's `true` as a column): the
/// bias, relative bias, MSE, coverage, misses and type S error use each
/// replication's truth (rsimsum 0.13's formulas, `R/performance.R`); the
/// empirical SE, the bias's MCSE (the SD of the estimates over sqrt(n)),
/// the power and the bias-eliminated coverage do not involve it, and
/// `true_mean` is NaN. With one truth the numbers are [`performance_at`]'s
/// to the bit.
pub fn performance_each(
    setting: &str,
    method: IntervalMethod,
    est: &[Estimate],
    dfs: &[f64],
    truth: Truth,
    level: f64,
) -> Performance {
    let all = est.len();
    let Usable { est, truths, dfs, one } = Usable::of(est, dfs, truth);
    let est = est.as_slice();
    let n = est.len() as f64;
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let var = super::sample_variance;
    let theta: Vec<f64> = est.iter().map(|e| e.0).collect();
    let se2: Vec<f64> = est.iter().map(|e| e.1 * e.1).collect();
    let covered: Vec<f64> = est.iter().zip(&truths).map(|(e, &t)| f64::from(u8::from(e.2 <= t && t <= e.3))).collect();
    let cov = mean(&covered);
    let emp = var(&theta).sqrt();
    let (mod_se, mod_se_mcse, rel_error_mod_se, rel_error_mod_se_mcse) = model_se(&se2, emp);
    let (mean_width, mean_width_mcse, median_width) = widths(est);
    let share = |hit: &dyn Fn(&Estimate) -> bool| est.iter().filter(|e| hit(e)).count() as f64 / n;
    // A share's MCSE, sqrt(p (1 - p) / n); none from fewer than 2.
    let share_mcse = |p: f64| if n >= 2.0 { (p * (1.0 - p) / n).sqrt() } else { f64::NAN };
    let (below, above) = misses(est, &truths);
    let mean_theta = mean(&theta);
    let be = share(&|e| e.2 <= mean_theta && mean_theta <= e.3);
    let (mse, mse_mcse) = mse(&theta, &truths);
    let z = super::critical_value(level, f64::INFINITY).unwrap_or(f64::NAN);
    let power = share(&|e| e.0.abs() >= z * e.1);
    let rejection = share(&|e| e.2 > 0.0 || e.3 < 0.0);
    let (type_s, type_s_mcse) = type_s(est, &truths);
    let (rel_bias, rel_bias_mcse) = relative_bias(&theta, &truths);
    Performance {
        setting: setting.to_string(),
        method,
        reps: est.len(),
        coverage: cov,
        // No Monte Carlo SE from fewer than 2 replications: NaN, not 0.
        coverage_mcse: if n >= 2.0 { (cov * (1.0 - cov) / n).sqrt() } else { f64::NAN },
        mean_width,
        mean_width_mcse,
        median_width,
        bias: bias(&theta, &truths, one),
        bias_mcse: (var(&theta) / n).sqrt(),
        emp_se: emp,
        emp_se_mcse: emp / (2.0 * (n - 1.0)).sqrt(),
        mod_se,
        mod_se_mcse,
        rel_error_mod_se,
        rel_error_mod_se_mcse,
        undefined: all - est.len(),
        miss_below: below,
        miss_below_mcse: share_mcse(below),
        miss_above: above,
        miss_above_mcse: share_mcse(above),
        mse,
        mse_mcse,
        be_coverage: be,
        be_coverage_mcse: share_mcse(be),
        true_mean: one.unwrap_or(f64::NAN),
        level,
        rel_bias,
        rel_bias_mcse,
        power: if level.is_nan() { f64::NAN } else { power },
        power_mcse: if level.is_nan() { f64::NAN } else { share_mcse(power) },
        rejection,
        rejection_mcse: share_mcse(rejection),
        type_s,
        type_s_mcse,
        rel_precision: f64::NAN,
        rel_precision_mcse: f64::NAN,
        df_median: if dfs.is_empty() { f64::NAN } else { super::quantile_type7(&dfs, 0.5) },
        boundary: f64::NAN,
        boundary_mcse: f64::NAN,
    }
}

/// The usable replications (see [`usable`]) with their true values and
/// their df (NaN ones left out, sorted), and the one truth where there is
/// one.
struct Usable {
    est: Vec<Estimate>,
    truths: Vec<f64>,
    dfs: Vec<f64>,
    one: Option<f64>,
}

impl Usable {
    fn of(est: &[Estimate], dfs: &[f64], truth: Truth) -> Usable {
        let mut dfs: Vec<f64> =
            est.iter().zip(dfs).filter(|(e, _)| usable(e)).map(|(_, d)| *d).filter(|d| !d.is_nan()).collect();
        dfs.sort_by(f64::total_cmp);
        let (truths, one) = match truth {
            Truth::One(t) => (vec![t; est.len()], Some(t)),
            Truth::Each(t) => (t.to_vec(), None),
        };
        let (est, truths) = est.iter().copied().zip(truths).filter(|(e, _)| usable(e)).unzip();
        Usable { est, truths, dfs, one }
    }
}

/// The model-based SE, sqrt(mean(SE^2)), and its MCSE; the relative error
/// of the model SE against the empirical SE `emp`, and its MCSE (Morris,
/// White & Crowther 2019, Table 6), from the squared SEs `se2`.
fn model_se(se2: &[f64], emp: f64) -> (f64, f64, f64, f64) {
    let n = se2.len() as f64;
    let mod_se = (se2.iter().sum::<f64>() / n).sqrt();
    let var_se2 = super::sample_variance(se2);
    (
        mod_se,
        (var_se2 / (4.0 * n * mod_se * mod_se)).sqrt(),
        100.0 * (mod_se / emp - 1.0),
        100.0 * (mod_se / emp) * (var_se2 / (4.0 * n * mod_se.powi(4)) + 1.0 / (2.0 * (n - 1.0))).sqrt(),
    )
}

/// The intervals' mean width, its MCSE and the median width.
fn widths(est: &[Estimate]) -> (f64, f64, f64) {
    let width: Vec<f64> = est.iter().map(|e| e.3 - e.2).collect();
    let n = width.len() as f64;
    let mut sorted = width.clone();
    sorted.sort_by(f64::total_cmp);
    let median = if sorted.is_empty() { f64::NAN } else { super::quantile_type7(&sorted, 0.5) };
    (width.iter().sum::<f64>() / n, (super::sample_variance(&width) / n).sqrt(), median)
}

/// The shares of intervals entirely below and entirely above their
/// replication's truth.
fn misses(est: &[Estimate], truths: &[f64]) -> (f64, f64) {
    let n = est.len() as f64;
    let share =
        |hit: &dyn Fn(&Estimate, f64) -> bool| est.iter().zip(truths).filter(|(e, t)| hit(e, **t)).count() as f64 / n;
    (share(&|e, t| e.3 < t), share(&|e, t| e.2 > t))
}

/// The mean squared error and rsimsum's MCSE of it,
/// sqrt(sum((d^2 - MSE)^2) / (n (n - 1))), d = estimate - truth.
fn mse(theta: &[f64], truths: &[f64]) -> (f64, f64) {
    let sq: Vec<f64> = theta.iter().zip(truths).map(|(x, t)| (x - t).powi(2)).collect();
    let n = sq.len() as f64;
    let mse = sq.iter().sum::<f64>() / n;
    (mse, (sq.iter().map(|d| (d - mse).powi(2)).sum::<f64>() / (n * (n - 1.0))).sqrt())
}

/// The bias, mean(estimate - truth); with one truth, mean(estimate) -
/// truth (the bits every earlier result was computed with).
fn bias(theta: &[f64], truths: &[f64], one: Option<f64>) -> f64 {
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    match one {
        Some(t) => mean(theta) - t,
        None => mean(&theta.iter().zip(truths).map(|(x, t)| x - t).collect::<Vec<_>>()),
    }
}

/// The type S error: among the intervals that exclude 0, the share whose
/// estimate has the other sign than its replication's truth, with its
/// MCSE; NaN where none excludes 0 or a truth is 0 (no sign to get wrong).
fn type_s(est: &[Estimate], truths: &[f64]) -> (f64, f64) {
    let rejecting: Vec<(&Estimate, f64)> =
        est.iter().zip(truths).filter(|(e, _)| e.2 > 0.0 || e.3 < 0.0).map(|(e, t)| (e, *t)).collect();
    if truths.contains(&0.0) || rejecting.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let k = rejecting.len() as f64;
    let wrong = rejecting.iter().filter(|(e, t)| (e.0 > 0.0) != (*t > 0.0)).count() as f64 / k;
    (wrong, if k >= 2.0 { (wrong * (1.0 - wrong) / k).sqrt() } else { f64::NAN })
}

/// The relative bias, mean((estimate - truth) / truth), and its MCSE, the
/// SD of those ratios over sqrt(n) (rsimsum's); NaN where a truth is 0.
fn relative_bias(theta: &[f64], truths: &[f64]) -> (f64, f64) {
    if truths.contains(&0.0) {
        return (f64::NAN, f64::NAN);
    }
    let rel: Vec<f64> = theta.iter().zip(truths).map(|(x, t)| (x - t) / t).collect();
    let n = rel.len() as f64;
    (rel.iter().sum::<f64>() / n, (super::sample_variance(&rel) / n).sqrt())
}

/// The estimators that work with missing cells, on one array with the
/// cells of `setting.missing` removed (drawn from `rng` after the array):
/// REML with Kenward-Roger, Satterthwaite and t(J - 1) df on the cells
/// present, and the crossed MoM with t(J - 1) on the complete rows
/// (listwise deletion). An estimator undefined on this array (fewer than
/// two complete rows, say) gives NaN, left out of its performance.
fn with_missing(
    s: &Setting,
    m: &CrossedMatrix,
    level: f64,
    rng: &mut ChaCha8Rng,
) -> Result<Vec<(IntervalMethod, Estimate, f64, bool)>, StatsError> {
    use super::crossed::{crossed_mom, crossed_reml_fit, reml_with};
    use super::DfRule;
    let (rows, cols) = (m.rows(), m.cols());
    let mut present = vec![true; rows * cols];
    match s.missing {
        Missing::Complete => {}
        Missing::Mcar(p) => present.iter_mut().for_each(|c| *c = rng.gen::<f64>() >= p),
        Missing::RowLoss(k) => {
            let mut order: Vec<usize> = (0..rows).collect();
            for i in 0..k.min(rows) {
                let j = rng.gen_range(i..rows);
                order.swap(i, j);
                present[order[i] * cols..(order[i] + 1) * cols].iter_mut().for_each(|c| *c = false);
            }
        }
    }
    let nan = (f64::NAN, f64::NAN, f64::NAN, f64::NAN);
    let cells: Vec<(usize, usize, f64)> = (0..rows)
        .flat_map(|i| (0..cols).map(move |j| (i, j)))
        .filter(|&(i, j)| present[i * cols + j])
        .map(|(i, j)| (i, j, m.get(i, j)))
        .collect();
    let mut out = Vec::new();
    let fit = crossed_reml_fit(&cells).ok();
    for (method, rule) in [
        (IntervalMethod::RemlKenwardRoger, DfRule::KenwardRoger),
        (IntervalMethod::RemlSatterthwaite, DfRule::Satterthwaite),
        (IntervalMethod::RemlT, DfRule::SeedsMinusOne),
    ] {
        let e = fit.as_ref().and_then(|f| reml_with(f, cells.len(), rows * cols, level, rule).ok());
        let singular = fit.as_ref().is_some_and(|f| f.singular);
        let estimate = e.as_ref().map_or(nan, |e| (e.mean, e.se, e.lower, e.upper));
        out.push((method, estimate, e.map_or(f64::NAN, |e| e.df), singular));
    }
    let complete: Vec<usize> = (0..rows).filter(|&i| present[i * cols..(i + 1) * cols].iter().all(|c| *c)).collect();
    let listwise = if complete.len() >= 2 {
        let data = complete.iter().flat_map(|&i| (0..cols).map(move |j| m.get(i, j))).collect();
        CrossedMatrix::new(complete.len(), cols, data)
            .and_then(|sub| crossed_mom(&sub, level, DfRule::SeedsMinusOne))
            .ok()
            .map(|e| {
                let truncated = e.mean_squares.is_some_and(|m| m.ms_rows < m.ms_error || m.ms_cols < m.ms_error);
                ((e.mean, e.se, e.lower, e.upper), e.df, truncated)
            })
    } else {
        None
    };
    let (listwise, df, truncated) = listwise.unwrap_or((nan, f64::NAN, false));
    out.push((IntervalMethod::MomTCompleteRows, listwise, df, truncated));
    Ok(out)
}

/// Whether a replication's estimate can be scored: its estimate, SE and
/// both interval ends are numbers. A Kenward-Roger interval with NaN ends
/// (df undefined) is not a miss but no interval at all, left out with the
/// estimator's other undefined replications; an infinite end still covers.
pub fn usable(e: &Estimate) -> bool {
    ![e.0, e.1, e.2, e.3].iter().any(|x| x.is_nan())
}

/// A setting's seed: the first 8 bytes (little-endian) of the SHA-256 of
/// the base seed and the setting's values (I, J, the shares' bits, the
/// distribution and the missing-cell pattern), so that adding, removing or
/// reordering settings leaves every other setting's draws unchanged. The
/// true mean and the level are not in it: every mean and level of a
/// setting is scored on the same arrays.
pub fn setting_seed(base: u64, s: &Setting) -> u64 {
    use sha2::{Digest, Sha256};
    let missing = match s.missing {
        Missing::Complete => "complete".to_string(),
        Missing::Mcar(p) => format!("mcar {:016x}", p.to_bits()),
        Missing::RowLoss(k) => format!("row_loss {k}"),
    };
    let text = format!(
        "crossaudit coverage setting seed 1|{base}|{}|{}|{:016x} {:016x} {:016x}|{:?}|{missing}",
        s.rows,
        s.cols,
        s.shares[0].to_bits(),
        s.shares[1].to_bits(),
        s.shares[2].to_bits(),
        s.distribution
    );
    let digest = Sha256::digest(text.as_bytes());
    let mut first = [0u8; 8];
    first.copy_from_slice(&digest[..8]);
    u64::from_le_bytes(first)
}

/// Every replication of one setting at true mean 0: per level, per
/// estimator, each replication's (estimate, SE, lower, upper) and df.
#[derive(Debug, Clone)]
pub struct Simulated {
    /// The setting's label.
    pub label: String,
    /// The nominal levels, in the order of `replications`.
    pub levels: Vec<f64>,
    /// The estimators, in the order of each level's entries.
    pub methods: Vec<IntervalMethod>,
    /// `[level][method][replication]`: (estimate, SE, lower, upper), df,
    /// and whether a variance component was at the boundary.
    pub replications: Vec<Vec<Vec<(Estimate, f64, bool)>>>,
}

/// An estimate of an array shifted by `mu`: every estimator here is
/// location-equivariant (the estimate and both interval ends move by mu,
/// the SE and df do not), so the arrays drawn around mu are the arrays
/// drawn around 0, plus mu (tests/coverage.rs checks it estimator by
/// estimator).
pub fn shifted(e: Estimate, mu: f64) -> Estimate {
    (e.0 + mu, e.1, e.2 + mu, e.3 + mu)
}

/// Runs `reps` replications of one setting at every level: every estimator
/// on every array. Replication r uses ChaCha8 stream r of `seed` for the
/// data and stream 2^32 + r for its bootstrap (the same at every level).
/// With missing cells, the estimators of `with_missing` instead, the same
/// cells lost at every level.
pub fn simulate_reps(s: &Setting, reps: usize, levels: &[f64], b: usize, seed: u64) -> Result<Simulated, StatsError> {
    type PerLevel = Vec<(IntervalMethod, Estimate, f64, bool)>;
    let per_rep: Vec<Vec<PerLevel>> = (0..reps)
        .into_par_iter()
        .map(|r| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(r as u64);
            let m = draw_array(s, &mut rng)?;
            levels
                .iter()
                .map(|&level| -> Result<PerLevel, StatsError> {
                    if s.missing != Missing::Complete {
                        let mut lost = rng.clone();
                        return with_missing(s, &m, level, &mut lost);
                    }
                    let stream = (1u64 << 32) + r as u64;
                    let mut iv = compare_intervals(&m, level, b, seed, stream)?;
                    iv.extend(super::further_intervals(&m, level, b, seed, stream)?);
                    Ok(iv
                        .into_iter()
                        .map(|e| (e.method, (e.estimate, e.se, e.lower, e.upper), e.df, e.boundary))
                        .collect())
                })
                .collect()
        })
        .collect::<Result<_, StatsError>>()?;
    let methods: Vec<IntervalMethod> =
        per_rep.first().and_then(|v| v.first()).map(|v| v.iter().map(|x| x.0).collect()).unwrap_or_default();
    let replications = (0..levels.len())
        .map(|l| {
            (0..methods.len()).map(|k| per_rep.iter().map(|v| (v[l][k].1, v[l][k].2, v[l][k].3)).collect()).collect()
        })
        .collect();
    Ok(Simulated { label: s.label(), levels: levels.to_vec(), methods, replications })
}

/// Runs `reps` replications of one setting at one level and scores them
/// against the true mean 0 ([`simulate_reps`], [`measures`]).
pub fn simulate(s: &Setting, reps: usize, level: f64, b: usize, seed: u64) -> Result<Vec<Performance>, StatsError> {
    Ok(measures(&simulate_reps(s, reps, &[level], b, seed)?, &[0.0]))
}
