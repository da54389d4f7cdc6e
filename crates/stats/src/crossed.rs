//! The two-way crossed random-effects model d_ij = mu + a_i + b_j + e_ij,
//! estimated by the method of moments (ANOVA mean squares), one observation
//! per cell.

use serde::Serialize;

use super::{critical_value, CrossedMatrix, StatsError};

/// Degrees of freedom for the interval's quantile.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DfRule {
    /// J - 1 (seeds minus one): the paper's rule.
    SeedsMinusOne,
    /// I - 1 (recordings minus one).
    RecordingsMinusOne,
    /// Satterthwaite's approximation: for the crossed MoM, of the linear
    /// combination of mean squares that makes SE^2; for REML, lmerTest's
    /// (observed information of the variance parameters).
    Satterthwaite,
    /// Kenward and Roger (1997), with the adjusted SE (REML only).
    KenwardRoger,
    /// The normal quantile (z).
    Normal,
}

impl DfRule {
    /// The degrees of freedom for an I x J array (`rows` x `cols`) when the
    /// rule fixes them: J - 1, I - 1 or infinite (the normal). `None` for
    /// Satterthwaite and Kenward-Roger, whose df depend on the data.
    ///
    /// ```
    /// use crossaudit_stats::DfRule;
    /// assert_eq!(DfRule::SeedsMinusOne.df(26, 20), Some(19.0));
    /// assert_eq!(DfRule::Normal.df(26, 20), Some(f64::INFINITY));
    /// assert_eq!(DfRule::Satterthwaite.df(26, 20), None);
    /// ```
    pub fn df(self, rows: usize, cols: usize) -> Option<f64> {
        match self {
            DfRule::SeedsMinusOne => Some(cols as f64 - 1.0),
            DfRule::RecordingsMinusOne => Some(rows as f64 - 1.0),
            DfRule::Normal => Some(f64::INFINITY),
            DfRule::Satterthwaite | DfRule::KenwardRoger => None,
        }
    }
}

/// Sums of squares and mean squares of the two-way layout without replication.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MeanSquares {
    /// Mean of all cells.
    pub grand_mean: f64,
    /// Sum of squares between rows (recordings).
    pub ss_rows: f64,
    /// Sum of squares between columns (seeds).
    pub ss_cols: f64,
    /// Residual sum of squares.
    pub ss_error: f64,
    /// I - 1.
    pub df_rows: f64,
    /// J - 1.
    pub df_cols: f64,
    /// (I - 1)(J - 1).
    pub df_error: f64,
    /// SS_rows / df_rows.
    pub ms_rows: f64,
    /// SS_cols / df_cols.
    pub ms_cols: f64,
    /// SS_error / df_error.
    pub ms_error: f64,
}

/// Variance components, truncated at zero as the MoM estimator does.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct VarianceComponents {
    /// sigma_a^2 = max(0, (MS_rows - MS_e) / J): between recordings.
    pub recording: f64,
    /// sigma_b^2 = max(0, (MS_cols - MS_e) / I): between seeds.
    pub seed: f64,
    /// sigma_e^2 = MS_e.
    pub residual: f64,
}

impl VarianceComponents {
    /// The MoM's components of a `rows` x `cols` array from its three mean
    /// squares, each truncated at zero.
    pub fn mom(ms_rows: f64, ms_cols: f64, ms_error: f64, rows: f64, cols: f64) -> VarianceComponents {
        VarianceComponents {
            recording: ((ms_rows - ms_error) / cols).max(0.0),
            seed: ((ms_cols - ms_error) / rows).max(0.0),
            residual: ms_error,
        }
    }

    /// The three parts of SE^2 for an I x J array: sa/I, sb/J and se/(IJ).
    pub fn se2_parts(&self, rows: f64, cols: f64) -> [f64; 3] {
        [self.recording / rows, self.seed / cols, self.residual / (rows * cols)]
    }

    /// SE of the grand mean of an I x J array with these components:
    /// sqrt(sa/I + sb/J + se/(IJ)) (the crossed design's closed form).
    ///
    /// ```
    /// use crossaudit_stats::VarianceComponents;
    /// let c = VarianceComponents { recording: 4.0, seed: 2.0, residual: 8.0 };
    /// assert_eq!(c.se_at(4.0, 2.0), (1.0f64 + 1.0 + 1.0).sqrt());
    /// ```
    pub fn se_at(&self, rows: f64, cols: f64) -> f64 {
        self.se2_parts(rows, cols).iter().sum::<f64>().sqrt()
    }
}

/// The crossed MoM estimate of the grand mean and its interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CrossedEstimate {
    /// Number of recordings I.
    pub rows: usize,
    /// Number of seeds J.
    pub cols: usize,
    /// Grand mean.
    pub mean: f64,
    /// sqrt(sa/I + sb/J + se/(IJ)).
    pub se: f64,
    /// Degrees of freedom of the quantile; infinite for the normal (JSON:
    /// a number or `"infinite"`).
    #[serde(serialize_with = "crate::df_json")]
    pub df: f64,
    /// Confidence level.
    pub level: f64,
    /// The quantile multiplying the SE.
    pub critical: f64,
    /// Lower interval bound.
    pub lower: f64,
    /// Upper interval bound.
    pub upper: f64,
    /// The two-way ANOVA table (method of moments only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_squares: Option<MeanSquares>,
    /// The variance components.
    pub components: VarianceComponents,
    /// Shares of SE^2 from recordings, seeds and residual (sum to 1 when SE > 0).
    pub share_recording: f64,
    /// Share of SE^2 from seeds.
    pub share_seed: f64,
    /// Share of SE^2 from the residual.
    pub share_residual: f64,
    /// What the REML fit adds (REML only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reml: Option<RemlSummary>,
}

/// The REML fit behind a [`CrossedEstimate`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RemlSummary {
    /// The df rule of the interval.
    pub df_rule: DfRule,
    /// Cells the fit used.
    pub cells: usize,
    /// Cells of the rows x cols array it lacked.
    pub missing: usize,
    /// The REML criterion (-2 restricted log-likelihood) at the optimum.
    pub criterion: f64,
    /// A variance component estimated at zero (lme4's `isSingular`).
    pub singular: bool,
    /// The model-based SE, sqrt(sigma^2 / R_X^2), before any Kenward-Roger
    /// adjustment.
    pub se_model: f64,
    /// lmerTest's Satterthwaite df.
    #[serde(serialize_with = "crate::df_json")]
    pub df_satterthwaite: f64,
    /// Kenward-Roger df.
    #[serde(serialize_with = "crate::df_json")]
    pub df_kenward_roger: f64,
    /// The Kenward-Roger adjusted SE.
    pub se_kenward_roger: f64,
}

/// The two-way ANOVA of an I x J array without replication.
pub fn mean_squares(m: &CrossedMatrix) -> MeanSquares {
    let (i_n, j_n) = (m.rows() as f64, m.cols() as f64);
    // The grand, row and column sums in one pass, each added in the order
    // of `CrossedMatrix::{mean, row_means, col_means}`, so bit for bit
    // their values.
    let (mut total, mut rm, mut cm) = (-0.0, Vec::with_capacity(m.rows()), vec![0.0; m.cols()]);
    for i in 0..m.rows() {
        let mut row = -0.0;
        for (acc, &x) in cm.iter_mut().zip(m.row(i)) {
            total += x;
            row += x;
            *acc += x;
        }
        rm.push(row / j_n);
    }
    cm.iter_mut().for_each(|c| *c /= i_n);
    let mu = total / m.values().len() as f64;
    let mut ss_error = 0.0;
    for (i, r) in rm.iter().enumerate() {
        for (x, c) in m.row(i).iter().zip(&cm) {
            ss_error += (x - r - c + mu).powi(2);
        }
    }
    anova_table(mu, &rm, &cm, ss_error)
}

/// The ANOVA table of an array from its grand mean, row means, column
/// means and residual sum of squares (the end of [`mean_squares`], shared
/// with `along::mean_squares_along`, so both finish bit for bit alike).
pub(crate) fn anova_table(mu: f64, rm: &[f64], cm: &[f64], ss_error: f64) -> MeanSquares {
    let (i_n, j_n) = (rm.len() as f64, cm.len() as f64);
    let ss_rows = j_n * rm.iter().map(|r| (r - mu).powi(2)).sum::<f64>();
    let ss_cols = i_n * cm.iter().map(|c| (c - mu).powi(2)).sum::<f64>();
    let df_rows = i_n - 1.0;
    let df_cols = j_n - 1.0;
    let df_error = df_rows * df_cols;
    MeanSquares {
        grand_mean: mu,
        ss_rows,
        ss_cols,
        ss_error,
        df_rows,
        df_cols,
        df_error,
        ms_rows: ss_rows / df_rows,
        ms_cols: ss_cols / df_cols,
        ms_error: ss_error / df_error,
    }
}

/// Crossed method-of-moments estimate of the grand mean with a two-sided
/// interval at `level`.
pub fn crossed_mom(m: &CrossedMatrix, level: f64, df_rule: DfRule) -> Result<CrossedEstimate, StatsError> {
    mom_from_squares(mean_squares(m), m.rows(), m.cols(), level, df_rule)
}

/// The crossed MoM estimate from the ANOVA table of a `rows` x `cols`
/// array: what [`crossed_mom`] computes after [`mean_squares`], bit for
/// bit (with [`crate::mean_squares_along`], many arrays' tables from one
/// pass over the data).
pub fn mom_from_squares(
    ms: MeanSquares,
    rows: usize,
    cols: usize,
    level: f64,
    df_rule: DfRule,
) -> Result<CrossedEstimate, StatsError> {
    let (i_n, j_n) = (rows as f64, cols as f64);
    let components = VarianceComponents::mom(ms.ms_rows, ms.ms_cols, ms.ms_error, i_n, j_n);
    let (sa, sb) = (components.recording, components.seed);
    let se2_parts = components.se2_parts(i_n, j_n);
    let se2: f64 = se2_parts.iter().sum();
    let se = se2.sqrt();
    if df_rule == DfRule::KenwardRoger {
        return Err(StatsError::Invalid(
            "Kenward-Roger df need a likelihood: use crossed_reml, not the method of moments".to_string(),
        ));
    }
    let df = df_rule.df(rows, cols).unwrap_or_else(|| satterthwaite(&ms, sa > 0.0, sb > 0.0, i_n, j_n));
    let critical = critical_value(level, df)?;
    let share = |x: f64| if se2 > 0.0 { x / se2 } else { 0.0 };
    Ok(CrossedEstimate {
        rows,
        cols,
        mean: ms.grand_mean,
        se,
        df,
        level,
        critical,
        lower: ms.grand_mean - critical * se,
        upper: ms.grand_mean + critical * se,
        mean_squares: Some(ms),
        components,
        share_recording: share(se2_parts[0]),
        share_seed: share(se2_parts[1]),
        share_residual: share(se2_parts[2]),
        reml: None,
    })
}

/// `draws` crossed MoM estimates of a complete `rows` x `cols` array, at
/// confidence `level` with df by `df_rule`, drawn
/// from their exact sampling distribution under the normal crossed model
/// with grand mean `mean` and variance components `truth`: the grand mean
/// ~ N(mean, SE^2) and, independent of it, SS_rows / (se + J sa) ~
/// chi^2(I - 1), SS_cols / (se + I sb) ~ chi^2(J - 1) and SS_error / se ~
/// chi^2((I - 1)(J - 1)), each estimate then computed from its mean
/// squares as [`crossed_mom`] computes it (components truncated at zero,
/// the df `df_rule` gives or Satterthwaite's). A planner's probability that
/// a rule holds then accounts for the estimated SE and df, not the true
/// SE alone. Deterministic in `seed` (ChaCha8).
///
/// ```
/// use crossaudit_stats::{crossed_mom_draws, DfRule, VarianceComponents};
/// let truth = VarianceComponents { recording: 0.004, seed: 0.001, residual: 0.002 };
/// let draws = crossed_mom_draws(-0.03, truth, (13, 3), (0.95, DfRule::SeedsMinusOne), 4000, 7).unwrap();
/// let mean = draws.iter().map(|e| e.mean).sum::<f64>() / 4000.0;
/// assert!((mean + 0.03).abs() < 4.0 * truth.se_at(13.0, 3.0) / 4000f64.sqrt());
/// assert!(draws.iter().all(|e| e.df == 2.0));
/// ```
pub fn crossed_mom_draws(
    mean: f64,
    truth: VarianceComponents,
    (rows, cols): (usize, usize),
    (level, df_rule): (f64, DfRule),
    draws: usize,
    seed: u64,
) -> Result<Vec<CrossedEstimate>, StatsError> {
    use rand::SeedableRng;
    use statrs::distribution::ChiSquared;
    if rows < 2 || cols < 2 {
        return Err(StatsError::Invalid(format!("a crossed array needs at least 2 x 2 cells, not {rows} x {cols}")));
    }
    let bad = |what: &str, v: f64| StatsError::Invalid(format!("{what} must be finite and not negative, found {v}"));
    for (what, v) in
        [("sigma^2 recording", truth.recording), ("sigma^2 seed", truth.seed), ("sigma^2 residual", truth.residual)]
    {
        if !(v.is_finite() && v >= 0.0) {
            return Err(bad(what, v));
        }
    }
    let (i_n, j_n) = (rows as f64, cols as f64);
    let (df_r, df_c, df_e) = (i_n - 1.0, j_n - 1.0, (i_n - 1.0) * (j_n - 1.0));
    let chi = |df: f64| ChiSquared::new(df).map_err(|e| StatsError::Invalid(e.to_string()));
    let (chi_r, chi_c, chi_e) = (chi(df_r)?, chi(df_c)?, chi(df_e)?);
    let (e_r, e_c, e_e) = (truth.residual + j_n * truth.recording, truth.residual + i_n * truth.seed, truth.residual);
    let se = truth.se_at(i_n, j_n);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..draws)
        .map(|_| {
            use rand::distributions::Distribution;
            let grand_mean = mean + se * crate::standard_normal(&mut rng);
            let (ss_rows, ss_cols, ss_error) =
                (e_r * chi_r.sample(&mut rng), e_c * chi_c.sample(&mut rng), e_e * chi_e.sample(&mut rng));
            let ms = MeanSquares {
                grand_mean,
                ss_rows,
                ss_cols,
                ss_error,
                df_rows: df_r,
                df_cols: df_c,
                df_error: df_e,
                ms_rows: ss_rows / df_r,
                ms_cols: ss_cols / df_c,
                ms_error: ss_error / df_e,
            };
            mom_from_squares(ms, rows, cols, level, df_rule)
        })
        .collect()
}

/// REML estimate of the grand mean of a crossed rows x cols array with
/// cells missing: `cells` holds (row, col, value) for the cells present.
/// The model is the crossed MoM's, y = mu + a_row + b_col + e, fitted by
/// [`super::mixed`]; the interval is mu +- t(df) SE with the df and SE
/// `df_rule` names: Kenward-Roger (adjusted SE), Satterthwaite (lmerTest's;
/// model SE), J - 1, I - 1 or the normal. On a complete array with both
/// components positive the REML estimates are the MoM estimates.
pub fn crossed_reml(
    cells: &[(usize, usize, f64)],
    rows: usize,
    cols: usize,
    level: f64,
    df_rule: DfRule,
) -> Result<CrossedEstimate, StatsError> {
    reml_with(&crossed_reml_fit(cells)?, cells.len(), rows * cols, level, df_rule)
}

/// The REML fit of the crossed model on the cells present.
pub(crate) fn crossed_reml_fit(cells: &[(usize, usize, f64)]) -> Result<super::mixed::MixedFit, StatsError> {
    use super::mixed::{fit, Criterion, MixedData};
    let fail = |e: super::mixed::MixedError| StatsError::Invalid(e.to_string());
    if let Some(&(row, col, value)) = cells.iter().find(|c| !c.2.is_finite()) {
        return Err(StatsError::NonFinite { row, col, value });
    }
    let distinct = |f: fn(&(usize, usize, f64)) -> usize| {
        let mut v: Vec<usize> = cells.iter().map(f).collect();
        v.sort_unstable();
        v.dedup();
        v.len()
    };
    let (i_n, j_n) = (distinct(|c| c.0), distinct(|c| c.1));
    if i_n < 2 {
        return Err(StatsError::TooFew { what: "rows with a cell", found: i_n });
    }
    if j_n < 2 {
        return Err(StatsError::TooFew { what: "columns with a cell", found: j_n });
    }
    let data = MixedData::new(
        cells.iter().map(|c| c.2).collect(),
        vec![
            ("recording".into(), cells.iter().map(|c| c.0).collect()),
            ("seed".into(), cells.iter().map(|c| c.1).collect()),
        ],
    )
    .map_err(fail)?;
    fit(&data, Criterion::Reml).and_then(|f| f.certified()).map_err(fail)
}

/// The estimate from a REML fit of `cells` cells of a `size`-cell array.
pub(crate) fn reml_with(
    f: &super::mixed::MixedFit,
    cells: usize,
    size: usize,
    level: f64,
    df_rule: DfRule,
) -> Result<CrossedEstimate, StatsError> {
    let kr = f.kenward_roger.ok_or_else(|| StatsError::Invalid("not a REML fit".into()))?;
    let df_s = f.df_satterthwaite.unwrap_or(f64::NAN);
    let (i_n, j_n) = (f.levels[0], f.levels[1]);
    let (se, df) = match df_rule {
        DfRule::KenwardRoger => (kr.se, kr.df),
        DfRule::Satterthwaite if df_s.is_nan() => {
            return Err(StatsError::Invalid(
                "Satterthwaite df undefined: the REML deviance's Hessian is not positive definite at the optimum"
                    .into(),
            ))
        }
        DfRule::Satterthwaite => (f.se, df_s),
        other => (f.se, other.df(i_n, j_n).expect("fixed df rules")),
    };
    let critical = critical_value(level, df)?;
    Ok(CrossedEstimate {
        rows: i_n,
        cols: j_n,
        mean: f.intercept,
        se,
        df,
        level,
        critical,
        lower: f.intercept - critical * se,
        upper: f.intercept + critical * se,
        mean_squares: None,
        components: VarianceComponents { recording: f.variances[0], seed: f.variances[1], residual: f.residual },
        share_recording: f.shares[0],
        share_seed: f.shares[1],
        share_residual: f.shares[2],
        reml: Some(RemlSummary {
            df_rule,
            cells,
            missing: size - cells.min(size),
            criterion: f.deviance,
            singular: f.singular,
            se_model: f.se,
            df_satterthwaite: df_s,
            df_kenward_roger: kr.df,
            se_kenward_roger: kr.se,
        }),
    })
}
/// Satterthwaite (1946) df for SE^2 written as sum_k c_k MS_k. With both
/// components kept, SE^2 = (MS_r + MS_c - MS_e)/(IJ); a component truncated
/// at zero drops its MS_k and gives MS_e back its share.
fn satterthwaite(ms: &MeanSquares, keep_rows: bool, keep_cols: bool, i_n: f64, j_n: f64) -> f64 {
    let ij = i_n * j_n;
    let c_r = if keep_rows { 1.0 / ij } else { 0.0 };
    let c_c = if keep_cols { 1.0 / ij } else { 0.0 };
    let c_e = (1.0 - f64::from(u8::from(keep_rows)) - f64::from(u8::from(keep_cols))) / ij;
    let terms = [(c_r * ms.ms_rows, ms.df_rows), (c_c * ms.ms_cols, ms.df_cols), (c_e * ms.ms_error, ms.df_error)];
    let num: f64 = terms.iter().map(|(v, _)| v).sum::<f64>().powi(2);
    let den: f64 = terms.iter().map(|(v, df)| v * v / df).sum();
    if den > 0.0 {
        num / den
    } else {
        f64::INFINITY
    }
}
