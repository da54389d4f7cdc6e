//! What an interval estimator returns, and which estimator it was: the
//! types every interval of the crate shares ([`super::intervals`] and
//! [`super::resampling`] both make them).

use serde::Serialize;

/// Interval methods compared by the coverage study and `--compare-intervals`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum IntervalMethod {
    /// Crossed MoM with t(J - 1).
    MomT,
    /// Crossed MoM with Satterthwaite df.
    MomSatterthwaite,
    /// Crossed MoM with the normal quantile.
    MomZ,
    /// REML with lmerTest's Satterthwaite df and the model-based SE.
    RemlSatterthwaite,
    /// REML with Kenward-Roger df and adjusted SE (pbkrtest).
    RemlKenwardRoger,
    /// REML's model-based SE with the preregistered t(J - 1) (coverage
    /// settings with missing cells).
    RemlT,
    /// Crossed MoM with t(J - 1) on the rows with every cell present
    /// (listwise deletion; coverage settings with missing cells).
    MomTCompleteRows,
    /// Pigeonhole bootstrap percentile interval.
    PigeonholePercentile,
    /// All I x J cells treated as independent: t(IJ - 1).
    NaiveIid,
    /// One-way clustered by recording: the I row means, t(I - 1).
    ClusterRecording,
    /// One-way clustered by seed: the J column means, t(J - 1).
    ClusterSeed,
    /// Cameron, Gelbach & Miller (2011) two-way cluster-robust variance,
    /// V_row + V_col - V_cell (sandwich's `vcovCL(lm(y ~ 1), cluster =
    /// ~ row + col)`), t(min(I, J) - 1); undefined when V <= 0 (coverage
    /// study only).
    TwoWayCluster,
    /// The conservative sum-of-margins variance s2(row means) / I +
    /// s2(column means) / J, which for the grand mean is also the row
    /// jackknife's plus the column jackknife's; t(min(I, J) - 1)
    /// (coverage study only).
    SumOfMargins,
    /// Crossed MoM without truncating a component at zero, SE^2 = (MS_r +
    /// MS_c - MS_e) / (IJ), t(J - 1); undefined when that is <= 0
    /// (coverage study only).
    MomUntruncated,
    /// Pigeonhole bootstrap, mean +- z SD of the replicate means (coverage
    /// study only; the percentile interval's replicates).
    PigeonholeSe,
    /// Pigeonhole bootstrap-t: t* = (mean* - mean) / SE*, the crossed MoM
    /// SE of each resampled array (coverage study only).
    PigeonholeT,
    /// Owen & Eckles' product weights (Exp(1) row and column weights),
    /// mean +- z SD of the weighted means (coverage study only).
    ProductWeightsSe,
    /// Owen & Eckles' product weights, percentile interval (coverage study only).
    ProductWeightsPercentile,
    /// Parametric bootstrap-t from the crossed normal model with the MoM's
    /// components (coverage study only).
    ParametricT,
    /// The ML profile-likelihood interval (lme4's `confint(method =
    /// "profile")`, which profiles ML for a fixed effect even for a REML
    /// fit), chi2(1) cutoff (coverage study only).
    ProfileMl,
}

impl IntervalMethod {
    /// A readable label naming the quantile used.
    pub fn label(self) -> &'static str {
        match self {
            IntervalMethod::MomT => "crossed MoM, t(J-1)",
            IntervalMethod::MomSatterthwaite => "crossed MoM, Satterthwaite df",
            IntervalMethod::MomZ => "crossed MoM, z",
            IntervalMethod::RemlSatterthwaite => "REML, Satterthwaite df",
            IntervalMethod::RemlKenwardRoger => "REML, Kenward-Roger",
            IntervalMethod::RemlT => "REML, t(J-1)",
            IntervalMethod::MomTCompleteRows => "crossed MoM, t(J-1), complete rows only",
            IntervalMethod::PigeonholePercentile => "pigeonhole bootstrap, percentile",
            IntervalMethod::NaiveIid => "naive iid over cells, t(IJ-1)",
            IntervalMethod::ClusterRecording => "clustered by recording, t(I-1)",
            IntervalMethod::ClusterSeed => "clustered by seed, t(J-1)",
            IntervalMethod::TwoWayCluster => "two-way cluster-robust (CGM), t(min(I,J)-1)",
            IntervalMethod::SumOfMargins => "sum of margins (row + column jackknife), t(min(I,J)-1)",
            IntervalMethod::MomUntruncated => "crossed MoM untruncated, t(J-1)",
            IntervalMethod::PigeonholeSe => "pigeonhole bootstrap, SE-based (z)",
            IntervalMethod::PigeonholeT => "pigeonhole bootstrap-t (MoM SE)",
            IntervalMethod::ProductWeightsSe => "product weights (Owen-Eckles), SE-based (z)",
            IntervalMethod::ProductWeightsPercentile => "product weights (Owen-Eckles), percentile",
            IntervalMethod::ParametricT => "parametric bootstrap-t (MoM components)",
            IntervalMethod::ProfileMl => "profile likelihood (ML, lme4's confint)",
        }
    }
}

/// One interval for the grand mean.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct IntervalEstimate {
    /// How it was computed.
    pub method: IntervalMethod,
    /// Point estimate.
    pub estimate: f64,
    /// Standard error.
    pub se: f64,
    /// Infinite for the normal; NaN where no df applies (bootstrap) or the
    /// method is undefined on the array (every field NaN). JSON:
    /// a number, `"infinite"` or `"undefined"`.
    #[serde(serialize_with = "crate::df_json")]
    pub df: f64,
    /// Lower bound.
    pub lower: f64,
    /// Upper bound.
    pub upper: f64,
    /// A variance component at the boundary: the MoM truncated one at
    /// zero, or REML's fit is singular (false for estimators without
    /// components). Not serialized: the coverage study counts it.
    #[serde(skip)]
    pub boundary: bool,
}

impl IntervalEstimate {
    /// An estimator undefined on this array: every field NaN.
    pub fn undefined(method: IntervalMethod) -> IntervalEstimate {
        let nan = f64::NAN;
        IntervalEstimate { method, estimate: nan, se: nan, df: nan, lower: nan, upper: nan, boundary: false }
    }
}
