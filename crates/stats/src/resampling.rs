//! Further resampling intervals for the grand mean of a complete crossed
//! array, compared by the coverage study (docs/statistics.md gives the
//! references):
//!
//! - the pigeonhole bootstrap (Owen 2007) with an SE-based interval,
//!   mean +- z SD*, and a bootstrap-t interval, whose replicate statistic
//!   is t* = (mean* - mean) / SE*_MoM, the crossed MoM SE recomputed on the
//!   resampled array;
//! - Owen & Eckles' (2012) product weights: row i weighs W_i, column j
//!   V_j, cell (i, j) W_i V_j, with W and V independent Exp(1) (mean 1,
//!   variance 1); the replicate is the weighted mean; percentile and
//!   SE-based intervals. Normalised, Exp(1) weights are flat Dirichlet
//!   (Rubin's Bayesian bootstrap) along each factor, which gives the
//!   replicates' variance in closed form ([`product_weight_variance`]);
//! - a parametric bootstrap-t: arrays drawn from the crossed model with
//!   the MoM's (truncated) components, t* as above. For a balanced complete
//!   array the mean and the three sums of squares are sufficient and
//!   independent (mean ~ N(mu, SE^2); SS_rows ~ (se + J sa) chi2(I - 1),
//!   SS_cols ~ (se + I sb) chi2(J - 1), SS_error ~ se chi2((I-1)(J-1));
//!   Searle, Casella & McCulloch 1992, ch. 4), so a replicate draws those
//!   four numbers instead of I J cells.
//!
//! Every statistic is computed on the array centred at its mean, so each
//! interval moves with a shift of the data (the coverage study relies on
//! it) up to the rounding of that centring.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::interval::{IntervalEstimate, IntervalMethod};
use super::{
    critical_value, mean_squares, quantile_type7, standard_normal, CrossedMatrix, StatsError, VarianceComponents,
};

/// The crossed MoM's SE from the three mean squares of a `rows` x `cols`
/// array, components truncated at zero (as [`super::crossed_mom`]).
fn mom_se(ms_rows: f64, ms_cols: f64, ms_error: f64, rows: f64, cols: f64) -> f64 {
    VarianceComponents::mom(ms_rows, ms_cols, ms_error, rows, cols).se_at(rows, cols)
}

/// A replicate's t statistic; 0 for a replicate equal to the estimate with
/// a zero SE (a resample of one row and one column), +-infinity for one
/// away from it with a zero SE.
fn t_stat(diff: f64, se: f64) -> f64 {
    if se > 0.0 {
        diff / se
    } else if diff == 0.0 {
        0.0
    } else {
        diff.signum() * f64::INFINITY
    }
}

/// The array centred at its mean, and that mean.
fn centred(m: &CrossedMatrix) -> (Vec<f64>, f64) {
    let mean = m.mean();
    (m.values().iter().map(|v| v - mean).collect(), mean)
}

fn rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

/// Whether `b` replicates can give an interval (an SD needs two), after
/// checking the level.
fn enough(b: usize, level: f64) -> Result<bool, StatsError> {
    if !(level > 0.0 && level < 1.0) {
        return Err(StatsError::Level(level));
    }
    Ok(b >= 2)
}

/// The bootstrap-t interval from sorted t*: [mean - t*(1 - a/2) SE,
/// mean - t*(a/2) SE].
fn t_interval(method: IntervalMethod, mean: f64, se: f64, mut t: Vec<f64>, level: f64) -> IntervalEstimate {
    t.sort_by(f64::total_cmp);
    let alpha = 1.0 - level;
    let (lo, hi) = (quantile_type7(&t, alpha / 2.0), quantile_type7(&t, 1.0 - alpha / 2.0));
    IntervalEstimate {
        method,
        estimate: mean,
        se,
        df: f64::NAN,
        lower: mean - hi * se,
        upper: mean - lo * se,
        boundary: false,
    }
}

/// Mean +- z SD of the replicate deviations `dev` from the mean (divisor
/// B - 1).
fn se_interval(method: IntervalMethod, mean: f64, dev: &[f64], level: f64) -> Result<IntervalEstimate, StatsError> {
    let sd = super::sample_variance(dev).sqrt();
    let z = critical_value(level, f64::INFINITY)?;
    let (lower, upper) = (mean - z * sd, mean + z * sd);
    Ok(IntervalEstimate { method, estimate: mean, se: sd, df: f64::INFINITY, lower, upper, boundary: false })
}

/// The percentile interval (type-7 quantiles) of the replicate deviations
/// `dev`, reported with their SD `sd`.
fn percentile_interval(method: IntervalMethod, mean: f64, sd: f64, mut dev: Vec<f64>, level: f64) -> IntervalEstimate {
    dev.sort_by(f64::total_cmp);
    let alpha = 1.0 - level;
    let (lower, upper) = (mean + quantile_type7(&dev, alpha / 2.0), mean + quantile_type7(&dev, 1.0 - alpha / 2.0));
    IntervalEstimate { method, estimate: mean, se: sd, df: f64::NAN, lower, upper, boundary: false }
}

/// Per pigeonhole replicate: the resampled array's mean less the
/// array's, and its crossed MoM SE. The resamples are those of the
/// pigeonhole percentile interval ([`super::pigeonhole_bootstrap`]: the
/// same draws from the same (`seed`, `stream`), I row indices, then J
/// column indices, per replicate), so it and these share them.
///
/// With draw counts n (rows) and c (columns) and d the centred array, the
/// resampled array's mean is n' d c / (IJ), its row means (d c)_i / J for
/// each drawn row, its column means (n' d)_j / I, and its total sum of
/// squares n' (d o d) c - IJ mean^2: O(IJ) per replicate.
pub fn pigeonhole_t_replicates(m: &CrossedMatrix, b: usize, seed: u64, stream: u64) -> Vec<(f64, f64)> {
    let (rows, cols) = (m.rows(), m.cols());
    let (i_n, j_n) = (rows as f64, cols as f64);
    let (d, _) = centred(m);
    let mut rng = rng(seed, stream);
    let (mut rc, mut cc) = (vec![0.0f64; rows], vec![0.0f64; cols]);
    let mut col_sums = vec![0.0f64; cols];
    (0..b)
        .map(|_| {
            rc.iter_mut().for_each(|c| *c = 0.0);
            cc.iter_mut().for_each(|c| *c = 0.0);
            for _ in 0..rows {
                rc[rng.gen_range(0..rows)] += 1.0;
            }
            for _ in 0..cols {
                cc[rng.gen_range(0..cols)] += 1.0;
            }
            col_sums.iter_mut().for_each(|c| *c = 0.0);
            let (mut total, mut squares, mut row_part) = (0.0, 0.0, Vec::with_capacity(rows));
            for (i, &n) in rc.iter().enumerate() {
                if n == 0.0 {
                    continue;
                }
                let row = &d[i * cols..(i + 1) * cols];
                let (mut s, mut q) = (0.0, 0.0);
                for ((v, c), cs) in row.iter().zip(&cc).zip(col_sums.iter_mut()) {
                    s += v * c;
                    q += v * v * c;
                    *cs += n * v;
                }
                total += n * s;
                squares += n * q;
                row_part.push((n, s / j_n));
            }
            let g = total / (i_n * j_n);
            let ss_total = squares - i_n * j_n * g * g;
            let ss_rows = j_n * row_part.iter().map(|(n, r)| n * (r - g).powi(2)).sum::<f64>();
            let ss_cols = i_n * col_sums.iter().zip(&cc).map(|(s, c)| c * (s / i_n - g).powi(2)).sum::<f64>();
            let ss_error = (ss_total - ss_rows - ss_cols).max(0.0);
            (g, mom_se(ss_rows / (i_n - 1.0), ss_cols / (j_n - 1.0), ss_error / ((i_n - 1.0) * (j_n - 1.0)), i_n, j_n))
        })
        .collect()
}

/// The pigeonhole SE-based (z) and bootstrap-t intervals of `m` from `b`
/// replicates ([`pigeonhole_t_replicates`]).
pub fn pigeonhole_further(
    m: &CrossedMatrix,
    level: f64,
    b: usize,
    seed: u64,
    stream: u64,
) -> Result<[IntervalEstimate; 2], StatsError> {
    if !enough(b, level)? {
        return Ok([IntervalMethod::PigeonholeSe, IntervalMethod::PigeonholeT].map(IntervalEstimate::undefined));
    }
    let ms = mean_squares(m);
    let se = mom_se(ms.ms_rows, ms.ms_cols, ms.ms_error, m.rows() as f64, m.cols() as f64);
    let reps = pigeonhole_t_replicates(m, b, seed, stream);
    let t: Vec<f64> = reps.iter().map(|(g, s)| t_stat(*g, *s)).collect();
    let dev: Vec<f64> = reps.iter().map(|r| r.0).collect();
    let se_based = se_interval(IntervalMethod::PigeonholeSe, m.mean(), &dev, level)?;
    if se.is_nan() || se <= 0.0 {
        return Ok([se_based, IntervalEstimate::undefined(IntervalMethod::PigeonholeT)]);
    }
    Ok([se_based, t_interval(IntervalMethod::PigeonholeT, m.mean(), se, t, level)])
}

/// Per product-weight replicate: the weighted mean less the mean,
/// sum_ij W_i V_j d_ij / (sum W sum V) on the centred array d, with W
/// (rows) then V (columns) drawn per replicate as Exp(1) = -ln U, U
/// uniform on (0, 1).
pub fn product_weight_replicates(m: &CrossedMatrix, b: usize, seed: u64, stream: u64) -> Vec<f64> {
    let (rows, cols) = (m.rows(), m.cols());
    let (d, _) = centred(m);
    let mut rng = rng(seed, stream);
    let exp = |rng: &mut ChaCha8Rng| -rng.gen_range(f64::MIN_POSITIVE..1.0).ln();
    let (mut w, mut v) = (vec![0.0f64; rows], vec![0.0f64; cols]);
    (0..b)
        .map(|_| {
            w.iter_mut().for_each(|x| *x = exp(&mut rng));
            v.iter_mut().for_each(|x| *x = exp(&mut rng));
            let mut total = 0.0;
            for (i, wi) in w.iter().enumerate() {
                let row: f64 = d[i * cols..(i + 1) * cols].iter().zip(&v).map(|(x, vj)| x * vj).sum();
                total += wi * row;
            }
            total / (w.iter().sum::<f64>() * v.iter().sum::<f64>())
        })
        .collect()
}

/// The exact variance of one product-weight replicate given the data.
///
/// W_i / sum W and V_j / sum V are independent flat Dirichlet vectors (Exp(1)
/// weights normalised), so with d_ij = alpha_i + beta_j + gamma_ij (effects
/// summing to zero over each index) the replicate is sum_i w_i alpha_i +
/// sum_j v_j beta_j + sum_ij w_i v_j gamma_ij, E[w_i w_k] = (1 + [i = k]) /
/// (I (I + 1)), and
///
/// Var* = sum alpha^2 / (I (I+1)) + sum beta^2 / (J (J+1))
///      + sum gamma^2 / (I (I+1) J (J+1)):
///
/// the pigeonhole's [`super::pigeonhole_variance`] with each I^2 (J^2)
/// replaced by I (I + 1) (J (J + 1)), so a little narrower, most with
/// few columns.
pub fn product_weight_variance(m: &CrossedMatrix) -> f64 {
    let ms = mean_squares(m);
    let (i_n, j_n) = (m.rows() as f64, m.cols() as f64);
    // sum alpha^2 = SS_rows / J, sum beta^2 = SS_cols / I, sum gamma^2 = SS_error.
    ms.ss_rows / j_n / (i_n * (i_n + 1.0))
        + ms.ss_cols / i_n / (j_n * (j_n + 1.0))
        + ms.ss_error / (i_n * (i_n + 1.0) * j_n * (j_n + 1.0))
}

/// Owen & Eckles' product-weight SE-based (z) and percentile intervals
/// from `b` replicates ([`product_weight_replicates`]).
pub fn product_weights(
    m: &CrossedMatrix,
    level: f64,
    b: usize,
    seed: u64,
    stream: u64,
) -> Result<[IntervalEstimate; 2], StatsError> {
    if !enough(b, level)? {
        let methods = [IntervalMethod::ProductWeightsSe, IntervalMethod::ProductWeightsPercentile];
        return Ok(methods.map(IntervalEstimate::undefined));
    }
    let dev = product_weight_replicates(m, b, seed, stream);
    let se_based = se_interval(IntervalMethod::ProductWeightsSe, m.mean(), &dev, level)?;
    let percentile = percentile_interval(IntervalMethod::ProductWeightsPercentile, m.mean(), se_based.se, dev, level);
    Ok([se_based, percentile])
}

/// A chi-square draw with `k` df: twice a Gamma(k / 2) draw by Marsaglia &
/// Tsang (2000), "A simple method for generating gamma variables", ACM
/// TOMS 26(3), with their boost U^(1/a) for shapes below 1.
pub fn chi_squared<R: Rng + ?Sized>(rng: &mut R, k: f64) -> f64 {
    let a = k / 2.0;
    let (shape, boost) = if a < 1.0 { (a + 1.0, true) } else { (a, false) };
    let dd = shape - 1.0 / 3.0;
    let c = 1.0 / (9.0 * dd).sqrt();
    let g = loop {
        let x = standard_normal(rng);
        let v = (1.0 + c * x).powi(3);
        if v <= 0.0 {
            continue;
        }
        let u: f64 = rng.gen_range(f64::MIN_POSITIVE..1.0);
        if u.ln() < 0.5 * x * x + dd - dd * v + dd * v.ln() {
            break dd * v;
        }
    };
    let g = if boost { g * rng.gen_range(f64::MIN_POSITIVE..1.0).powf(1.0 / a) } else { g };
    2.0 * g
}

/// Per parametric replicate: (mean* - mean, SE*_MoM) of an array drawn
/// from the crossed normal model with the MoM's truncated components of
/// `m`, through its sufficient statistics: per replicate one normal, then
/// the row, column and residual sums of squares' chi-squares, in that order.
pub fn parametric_replicates(m: &CrossedMatrix, b: usize, seed: u64, stream: u64) -> Vec<(f64, f64)> {
    let ms = mean_squares(m);
    let (i_n, j_n) = (m.rows() as f64, m.cols() as f64);
    let c = VarianceComponents::mom(ms.ms_rows, ms.ms_cols, ms.ms_error, i_n, j_n);
    let sd_mean = c.se_at(i_n, j_n);
    let (se, lr, lc) = (c.residual, c.residual + j_n * c.recording, c.residual + i_n * c.seed);
    let mut rng = rng(seed, stream);
    (0..b)
        .map(|_| {
            let g = sd_mean * standard_normal(&mut rng);
            let ms_rows = lr * chi_squared(&mut rng, ms.df_rows) / ms.df_rows;
            let ms_cols = lc * chi_squared(&mut rng, ms.df_cols) / ms.df_cols;
            let ms_error = se * chi_squared(&mut rng, ms.df_error) / ms.df_error;
            (g, mom_se(ms_rows, ms_cols, ms_error, i_n, j_n))
        })
        .collect()
}

/// The parametric bootstrap-t interval of `m` from `b` replicates
/// ([`parametric_replicates`]); undefined when the MoM SE is zero.
pub fn parametric_t(
    m: &CrossedMatrix,
    level: f64,
    b: usize,
    seed: u64,
    stream: u64,
) -> Result<IntervalEstimate, StatsError> {
    let ms = mean_squares(m);
    if !enough(b, level)? {
        return Ok(IntervalEstimate::undefined(IntervalMethod::ParametricT));
    }
    let se = mom_se(ms.ms_rows, ms.ms_cols, ms.ms_error, m.rows() as f64, m.cols() as f64);
    if se.is_nan() || se <= 0.0 {
        return Ok(IntervalEstimate::undefined(IntervalMethod::ParametricT));
    }
    let t = parametric_replicates(m, b, seed, stream).iter().map(|(g, s)| t_stat(*g, *s)).collect();
    Ok(t_interval(IntervalMethod::ParametricT, m.mean(), se, t, level))
}
