//! Interval estimators for the grand mean of a crossed array, side by side.
//! Only the crossed MoM accounts for both random factors; the others are
//! here because published work uses them, so a reader can see what each
//! would have said.

use super::crossed::{crossed_reml_fit, reml_with};
use super::{critical_value, crossed_mom, pigeonhole_bootstrap, CrossedMatrix, DfRule, StatsError};

pub use super::interval::{IntervalEstimate, IntervalMethod};

/// Mean, SE = sd / sqrt(n) and the t(n - 1) interval of independent values.
pub fn one_sample_interval(values: &[f64], level: f64) -> Result<(f64, f64, f64, f64, f64), StatsError> {
    let n = values.len();
    if n < 2 {
        return Err(StatsError::TooFew { what: "values", found: n });
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let se = (var / n as f64).sqrt();
    let df = (n - 1) as f64;
    let q = critical_value(level, df)?;
    Ok((mean, se, df, mean - q * se, mean + q * se))
}

/// Every interval of [`compare_intervals`] and [`further_intervals`] on a
/// rows x cols array with cells missing (`cells`: row, column, value of
/// those present), in their order: the two REML intervals, the naive iid
/// interval over the present cells, and the one-way cluster-robust
/// intervals by row and by column (intercept-only CR1, as R's
/// `sandwich::vcovCL(type = "HC1")`: V = G / (G - 1) sum_g (sum of the
/// residuals in cluster g)^2 / N^2, on G - 1 df; on a complete array this
/// is the one-sample interval of the cluster means that
/// [`compare_intervals`] gives). Every other method needs a complete
/// array and is a row of NaN ([`IntervalEstimate::undefined`]).
pub fn incomplete_intervals(
    cells: &[(usize, usize, f64)],
    rows: usize,
    cols: usize,
    level: f64,
) -> Result<Vec<IntervalEstimate>, StatsError> {
    use IntervalMethod as M;
    let mut out: Vec<IntervalEstimate> =
        [M::MomT, M::MomSatterthwaite, M::MomZ].map(IntervalEstimate::undefined).to_vec();
    match reml_intervals(cells, rows, cols, level) {
        Ok(rows) => out.extend(rows),
        Err(_) => out.extend([M::RemlSatterthwaite, M::RemlKenwardRoger].map(IntervalEstimate::undefined)),
    }
    out.push(IntervalEstimate::undefined(M::PigeonholePercentile));
    let values: Vec<f64> = cells.iter().map(|c| c.2).collect();
    let (estimate, se, df, lower, upper) = one_sample_interval(&values, level)?;
    out.push(IntervalEstimate { method: M::NaiveIid, estimate, se, df, lower, upper, boundary: false });
    out.push(one_way_cluster(cells, rows, |c| c.0, M::ClusterRecording, level));
    out.push(one_way_cluster(cells, cols, |c| c.1, M::ClusterSeed, level));
    out.push(two_way_cluster(cells, rows, cols, level)?);
    out.extend(
        [
            M::SumOfMargins,
            M::MomUntruncated,
            M::PigeonholeSe,
            M::PigeonholeT,
            M::ProductWeightsSe,
            M::ProductWeightsPercentile,
            M::ParametricT,
            M::ProfileMl,
        ]
        .map(IntervalEstimate::undefined),
    );
    Ok(out)
}

/// The intercept-only CR1 interval of the mean of `cells`, clustered by
/// `cluster` (one of `groups` clusters; those without a cell do not
/// count): NaN where fewer than two clusters hold a cell or the variance
/// is not positive.
fn one_way_cluster(
    cells: &[(usize, usize, f64)],
    groups: usize,
    cluster: impl Fn(&(usize, usize, f64)) -> usize,
    method: IntervalMethod,
    level: f64,
) -> IntervalEstimate {
    let n = cells.len() as f64;
    let mean = cells.iter().map(|c| c.2).sum::<f64>() / n;
    let mut sums = vec![0.0; groups];
    let mut held = vec![false; groups];
    for c in cells {
        let g = cluster(c);
        sums[g] += c.2 - mean;
        held[g] = true;
    }
    let g = held.iter().filter(|h| **h).count() as f64;
    let v = g / (g - 1.0) * sums.iter().map(|s| s * s).sum::<f64>() / (n * n);
    let df = g - 1.0;
    match critical_value(level, df) {
        Ok(q) if g >= 2.0 && v > 0.0 => {
            let se = v.sqrt();
            IntervalEstimate {
                method,
                estimate: mean,
                se,
                df,
                lower: mean - q * se,
                upper: mean + q * se,
                boundary: false,
            }
        }
        _ => IntervalEstimate::undefined(method),
    }
}

/// The two-way cluster-robust interval (Cameron, Gelbach & Miller 2011)
/// of the mean of the cells present, as on a complete array: with e the
/// residuals about their mean and G_r, G_c the rows and columns that hold
/// a cell, V = [G_r / (G_r - 1) sum_r (row sum of e)^2 + G_c / (G_c - 1)
/// sum_c (column sum of e)^2 - n / (n - 1) sum e^2] / n^2
/// (sandwich::vcovCL(lm(d ~ 1), cluster = ~ row + col), type HC1), on
/// t(min(G_r, G_c) - 1); undefined (a boundary row) where V is not
/// positive.
fn two_way_cluster(
    cells: &[(usize, usize, f64)],
    rows: usize,
    cols: usize,
    level: f64,
) -> Result<IntervalEstimate, StatsError> {
    let n = cells.len() as f64;
    let mean = cells.iter().map(|c| c.2).sum::<f64>() / n;
    let (mut row_sums, mut col_sums) = (vec![0.0; rows], vec![0.0; cols]);
    let (mut row_held, mut col_held) = (vec![false; rows], vec![false; cols]);
    let mut squares = 0.0;
    for &(r, c, v) in cells {
        let e = v - mean;
        row_sums[r] += e;
        col_sums[c] += e;
        row_held[r] = true;
        col_held[c] = true;
        squares += e * e;
    }
    let gr = row_held.iter().filter(|h| **h).count() as f64;
    let gc = col_held.iter().filter(|h| **h).count() as f64;
    if gr < 2.0 || gc < 2.0 {
        return Ok(IntervalEstimate::undefined(IntervalMethod::TwoWayCluster));
    }
    let sum_sq = |s: &[f64]| s.iter().map(|v| v * v).sum::<f64>();
    let v =
        (gr / (gr - 1.0) * sum_sq(&row_sums) + gc / (gc - 1.0) * sum_sq(&col_sums) - n / (n - 1.0) * squares) / (n * n);
    from_variance(IntervalMethod::TwoWayCluster, mean, v, gr.min(gc) - 1.0, level)
}

/// The two REML intervals of a rows x cols array with cells missing
/// (`cells`: row, column, value of those present).
pub fn reml_intervals(
    cells: &[(usize, usize, f64)],
    rows: usize,
    cols: usize,
    level: f64,
) -> Result<Vec<IntervalEstimate>, StatsError> {
    let fit = crossed_reml_fit(cells)?;
    let boundary = fit.singular;
    // A df rule that is undefined on this fit (Satterthwaite where the
    // numerical Hessian is not positive definite) gives a NaN row, not the
    // loss of the other.
    Ok([
        (IntervalMethod::RemlSatterthwaite, DfRule::Satterthwaite),
        (IntervalMethod::RemlKenwardRoger, DfRule::KenwardRoger),
    ]
    .into_iter()
    .map(|(method, rule)| match reml_with(&fit, cells.len(), rows * cols, level, rule) {
        Ok(e) => {
            IntervalEstimate { method, estimate: e.mean, se: e.se, df: e.df, lower: e.lower, upper: e.upper, boundary }
        }
        Err(_) => IntervalEstimate::undefined(method),
    })
    .collect())
}

/// Every interval of [`IntervalMethod`] for one array. The bootstrap uses
/// (`b`, `seed`, `stream`).
pub fn compare_intervals(
    m: &CrossedMatrix,
    level: f64,
    b: usize,
    seed: u64,
    stream: u64,
) -> Result<Vec<IntervalEstimate>, StatsError> {
    let mut out = Vec::new();
    for (method, rule) in [
        (IntervalMethod::MomT, DfRule::SeedsMinusOne),
        (IntervalMethod::MomSatterthwaite, DfRule::Satterthwaite),
        (IntervalMethod::MomZ, DfRule::Normal),
    ] {
        let e = crossed_mom(m, level, rule)?;
        let boundary = e.mean_squares.is_some_and(|m| m.ms_rows < m.ms_error || m.ms_cols < m.ms_error);
        out.push(IntervalEstimate {
            method,
            estimate: e.mean,
            se: e.se,
            df: e.df,
            lower: e.lower,
            upper: e.upper,
            boundary,
        });
    }
    let cells: Vec<(usize, usize, f64)> =
        (0..m.rows()).flat_map(|i| (0..m.cols()).map(move |j| (i, j))).map(|(i, j)| (i, j, m.get(i, j))).collect();
    // REML can be undefined where the MoM is not (a residual of exactly
    // zero): those rows are NaN rather than the whole comparison refused.
    match reml_intervals(&cells, m.rows(), m.cols(), level) {
        Ok(rows) => out.extend(rows),
        Err(_) => out.extend(
            [IntervalMethod::RemlSatterthwaite, IntervalMethod::RemlKenwardRoger].map(IntervalEstimate::undefined),
        ),
    }
    let boot = pigeonhole_bootstrap(m, b, level, seed, stream)?;
    out.push(IntervalEstimate {
        method: IntervalMethod::PigeonholePercentile,
        estimate: m.mean(),
        se: boot.se,
        df: f64::NAN,
        lower: boot.lower,
        upper: boot.upper,
        boundary: false,
    });
    for (method, values) in [
        (IntervalMethod::NaiveIid, m.values().to_vec()),
        (IntervalMethod::ClusterRecording, m.row_means()),
        (IntervalMethod::ClusterSeed, m.col_means()),
    ] {
        let (estimate, se, df, lower, upper) = one_sample_interval(&values, level)?;
        out.push(IntervalEstimate { method, estimate, se, df, lower, upper, boundary: false });
    }
    Ok(out)
}

/// The interval of `mean` with variance `v` on `df` df, or undefined (every
/// field NaN) when the variance is not positive.
fn from_variance(
    method: IntervalMethod,
    mean: f64,
    v: f64,
    df: f64,
    level: f64,
) -> Result<IntervalEstimate, StatsError> {
    if !(v > 0.0 && v.is_finite()) {
        return Ok(IntervalEstimate { boundary: true, ..IntervalEstimate::undefined(method) });
    }
    let se = v.sqrt();
    let q = critical_value(level, df)?;
    Ok(IntervalEstimate { method, estimate: mean, se, df, lower: mean - q * se, upper: mean + q * se, boundary: false })
}

/// Stream offsets of the further resampling intervals: the pigeonhole ones
/// share the percentile interval's stream (and so its resamples); the
/// product weights and the parametric bootstrap draw from their own.
pub const PRODUCT_WEIGHTS_STREAM: u64 = 1 << 40;
/// See [`PRODUCT_WEIGHTS_STREAM`].
pub const PARAMETRIC_STREAM: u64 = 2 << 40;

/// The further estimators the coverage study compares on complete arrays:
/// two-way cluster-robust, sum of margins and the untruncated MoM, then
/// the resampling intervals of [`super::resampling`] from `b` replicates
/// and the ML profile-likelihood interval ([`super::profile_interval`])
/// (the pigeonhole ones on (`seed`, `stream`), the others on `stream`
/// plus `PRODUCT_WEIGHTS_STREAM` and `PARAMETRIC_STREAM`); see
/// [`IntervalMethod`], and docs/statistics.md for their references.
pub fn further_intervals(
    m: &CrossedMatrix,
    level: f64,
    b: usize,
    seed: u64,
    stream: u64,
) -> Result<Vec<IntervalEstimate>, StatsError> {
    let (i, j) = (m.rows() as f64, m.cols() as f64);
    let n = i * j;
    let mean = m.mean();
    let rows = m.row_means();
    let cols = m.col_means();
    // CGM: residuals e = y - mean summed per row and per column.
    let row_sums: f64 = rows.iter().map(|r| (j * (r - mean)).powi(2)).sum();
    let col_sums: f64 = cols.iter().map(|c| (i * (c - mean)).powi(2)).sum();
    let cells: f64 = m.values().iter().map(|v| (v - mean).powi(2)).sum();
    let cgm = i / (i - 1.0) * row_sums / (n * n) + j / (j - 1.0) * col_sums / (n * n) - n / (n - 1.0) * cells / (n * n);
    let margins = super::sample_variance(&rows) / i + super::sample_variance(&cols) / j;
    let small = i.min(j) - 1.0;
    let e = crossed_mom(m, level, DfRule::SeedsMinusOne)?;
    let untruncated = e.mean_squares.map_or(f64::NAN, |ms| (ms.ms_rows + ms.ms_cols - ms.ms_error) / n);
    let mut out = vec![
        from_variance(IntervalMethod::TwoWayCluster, mean, cgm, small, level)?,
        from_variance(IntervalMethod::SumOfMargins, mean, margins, small, level)?,
        from_variance(IntervalMethod::MomUntruncated, mean, untruncated, j - 1.0, level)?,
    ];
    out.extend(super::resampling::pigeonhole_further(m, level, b, seed, stream)?);
    out.extend(super::resampling::product_weights(m, level, b, seed, stream + PRODUCT_WEIGHTS_STREAM)?);
    out.push(super::resampling::parametric_t(m, level, b, seed, stream + PARAMETRIC_STREAM)?);
    out.push(super::profile_interval(m, level)?);
    Ok(out)
}
