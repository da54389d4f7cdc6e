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

use super::intervals::{IntervalEstimate, IntervalMethod};
use super::{critical_value, mean_squares, quantile_type7, standard_normal, CrossedMatrix, StatsError};

/// The crossed MoM's SE^2 from the three mean squares of a `rows` x `cols`
/// array, components truncated at zero (as [`super::crossed_mom`]).
fn mom_se2(ms_rows: f64, ms_cols: f64, ms_error: f64, rows: f64, cols: f64) -> f64 {
    let sa = ((ms_rows - ms_error) / cols).max(0.0);
    let sb = ((ms_cols - ms_error) / rows).max(0.0);
    sa / rows + sb / cols + ms_error / (rows * cols)
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

/// Mean +- z SD of the replicates (divisor B - 1), and the percentile
/// interval (type-7 quantiles), of replicate deviations from the mean.
fn se_and_percentile(
    (se_method, pct_method): (IntervalMethod, IntervalMethod),
    mean: f64,
    mut dev: Vec<f64>,
    level: f64,
) -> Result<[IntervalEstimate; 2], StatsError> {
    let b = dev.len() as f64;
    let centre = dev.iter().sum::<f64>() / b;
    let sd = (dev.iter().map(|d| (d - centre).powi(2)).sum::<f64>() / (b - 1.0)).sqrt();
    let z = critical_value(level, f64::INFINITY)?;
    dev.sort_by(f64::total_cmp);
    let alpha = 1.0 - level;
    let inf = f64::INFINITY;
    Ok([
        IntervalEstimate {
            method: se_method,
            estimate: mean,
            se: sd,
            df: inf,
            lower: mean - z * sd,
            upper: mean + z * sd,
            boundary: false,
        },
        IntervalEstimate {
            method: pct_method,
            estimate: mean,
            se: sd,
            df: f64::NAN,
            lower: mean + quantile_type7(&dev, alpha / 2.0),
            upper: mean + quantile_type7(&dev, 1.0 - alpha / 2.0),
            boundary: false,
        },
    ])
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
            let se2 =
                mom_se2(ss_rows / (i_n - 1.0), ss_cols / (j_n - 1.0), ss_error / ((i_n - 1.0) * (j_n - 1.0)), i_n, j_n);
            (g, se2.sqrt())
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
    let (i_n, j_n) = (m.rows() as f64, m.cols() as f64);
    let se = mom_se2(ms.ms_rows, ms.ms_cols, ms.ms_error, i_n, j_n).sqrt();
    let reps = pigeonhole_t_replicates(m, b, seed, stream);
    let t: Vec<f64> = reps.iter().map(|(g, s)| t_stat(*g, *s)).collect();
    let [se_based, _] = se_and_percentile(
        (IntervalMethod::PigeonholeSe, IntervalMethod::PigeonholePercentile),
        m.mean(),
        reps.iter().map(|r| r.0).collect(),
        level,
    )?;
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
    se_and_percentile(
        (IntervalMethod::ProductWeightsSe, IntervalMethod::ProductWeightsPercentile),
        m.mean(),
        product_weight_replicates(m, b, seed, stream),
        level,
    )
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
    let sa = ((ms.ms_rows - ms.ms_error) / j_n).max(0.0);
    let sb = ((ms.ms_cols - ms.ms_error) / i_n).max(0.0);
    let se = ms.ms_error;
    let sd_mean = (sa / i_n + sb / j_n + se / (i_n * j_n)).sqrt();
    let (lr, lc) = (se + j_n * sa, se + i_n * sb);
    let mut rng = rng(seed, stream);
    (0..b)
        .map(|_| {
            let g = sd_mean * standard_normal(&mut rng);
            let ms_rows = lr * chi_squared(&mut rng, ms.df_rows) / ms.df_rows;
            let ms_cols = lc * chi_squared(&mut rng, ms.df_cols) / ms.df_cols;
            let ms_error = se * chi_squared(&mut rng, ms.df_error) / ms.df_error;
            (g, mom_se2(ms_rows, ms_cols, ms_error, i_n, j_n).sqrt())
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
    let se = mom_se2(ms.ms_rows, ms.ms_cols, ms.ms_error, m.rows() as f64, m.cols() as f64).sqrt();
    if se.is_nan() || se <= 0.0 {
        return Ok(IntervalEstimate::undefined(IntervalMethod::ParametricT));
    }
    let t = parametric_replicates(m, b, seed, stream).iter().map(|(g, s)| t_stat(*g, *s)).collect();
    Ok(t_interval(IntervalMethod::ParametricT, m.mean(), se, t, level))
}
