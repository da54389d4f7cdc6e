//! What a dose-response or multi-split analysis holds (`FamilyAnalysis`
//! and its parts), shared by the family's analysis, its trend and its pooled fit.

use serde::Serialize;

use crate::analysis::types::{Analysis, Decision, Provenance};
use crate::design::DoseAxis;
use crate::plan::DoseArm;
use crossaudit_stats::CrossedEstimate;

/// The analysis of a dose-response or multi-split study (results.json).
#[derive(Debug, Clone, Serialize)]
pub struct FamilyAnalysis {
    /// The study's name.
    pub study: String,
    /// The design and where the analysis stands with its preregistration
    /// (results.json: `design_sha256`, `exploratory`, `preregistered` and
    /// the `standing` sentence).
    #[serde(flatten)]
    pub header: crate::analysis::AnalysisHeader,
    /// The treated arm (or dose-response family) of the contrast.
    pub treated: String,
    /// The reference arm.
    pub reference: String,
    /// Confidence level of every interval.
    pub level: f64,
    /// The primary unit, `model metric at h s`.
    pub unit: String,
    /// The primary metric's unit (`m`; empty for a rate): d, its SE and
    /// interval are in it, a slope per percentage point of dose.
    pub metric_unit: String,
    /// The doses, increasing (one entry, the treated arm, without doses).
    pub doses: Vec<DoseArm>,
    /// What the doses vary: the share replaced or the distance (written
    /// only for distances: a results.json without it is of shares).
    #[serde(skip_serializing_if = "DoseAxis::is_percent")]
    pub dose_axis: DoseAxis,
    /// Per split (one entry, split `None`, in a single-split study).
    pub splits: Vec<SplitResult>,
    /// Pooled over splits, when there are several.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pooled: Option<Pooled>,
    /// The preregistered decision.
    pub decision: Decision,
    /// Caveats, in order.
    pub warnings: Vec<String>,
    /// Figure files (relative to the report).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub figures: Vec<String>,
    /// In a distance-dose family, from how many evaluation recordings each
    /// arm's contaminating windows came, when a run built the splits: far
    /// from the segments, only long recordings may have windows to give.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub sources: Vec<DoseSource>,
    /// How strong each dose arm's treatment is, when a run built the split.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub treatment: Vec<crate::analysis::TreatmentStrength>,
    /// The reference arm's condition coverage over the splits, when a run
    /// built them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coverage: Option<crate::analysis::coverage::CoverageNote>,
    /// Which data, which cells and which build produced this analysis.
    pub provenance: Provenance,
    /// The guards of the verdict, computed from everything above (by the
    /// family's guards module); every view gives them beside it.
    pub guards: Vec<crate::analysis::Guard>,
    /// Each declared secondary endpoint's contrast per split and dose
    /// (descriptive: no rule reads them; the trend and the pooled fit are
    /// the primary endpoint's).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub secondary: Vec<SecondaryDose>,
}

/// One secondary endpoint's crossed contrast at one dose of one split.
#[derive(Debug, Clone, Serialize)]
pub struct SecondaryDose {
    /// The split value (`None` in a single-split study).
    pub split: Option<u64>,
    /// The treated arm.
    pub arm: String,
    /// Percent of the reference arm's windows replaced (NaN, written null,
    /// when the treated arm is not derived from the reference).
    pub percent: f64,
    /// In a distance-dose family, the arm's least distance in s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub distance_s: Option<f64>,
    /// The model.
    pub model: String,
    /// The metric.
    pub metric: crate::design::Metric,
    /// The horizon in seconds.
    pub horizon_s: f64,
    /// Mean of the treated arm.
    pub mean_treated: f64,
    /// Mean of the reference arm.
    pub mean_reference: f64,
    /// 100 (mean_reference - mean_treated) / mean_reference.
    pub optimism_pct: f64,
    /// Crossed estimate of treated - reference, in the metric's unit.
    pub estimate: CrossedEstimate,
}

/// From how many evaluation recordings one arm's contaminating windows
/// came: the fewest and the most over the run's draws, of how many.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DoseSource {
    /// The arm.
    pub arm: String,
    /// The fewest recordings it drew from in any draw.
    pub fewest: usize,
    /// The most.
    pub most: usize,
    /// Evaluation recordings (the fewest over the draws).
    pub of: usize,
}

/// One split's contrasts.
#[derive(Debug, Clone, Serialize)]
pub struct SplitResult {
    /// The split value (`None` in a single-split study).
    pub split: Option<u64>,
    /// Per dose, increasing.
    pub doses: Vec<DoseResult>,
    /// The trend over doses (two or more doses).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trend: Option<Trend>,
    /// The full single-contrast analysis of each dose, in dose order.
    #[serde(skip)]
    pub detail: Vec<Analysis>,
}

/// One dose's primary contrast in one split.
#[derive(Debug, Clone, Serialize)]
pub struct DoseResult {
    /// The treated arm.
    pub arm: String,
    /// Percent of the reference arm's windows replaced (NaN, written null,
    /// when the treated arm is not derived from the reference).
    pub percent: f64,
    /// In a distance-dose family, the dose: the least distance in s of the
    /// arm's contaminating windows from the evaluated segments.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub distance_s: Option<f64>,
    /// Mean of the treated arm.
    pub mean_treated: f64,
    /// Mean of the reference arm.
    pub mean_reference: f64,
    /// 100 (mean_reference - mean_treated) / mean_reference.
    pub optimism_pct: f64,
    /// The crossed estimate of treated - reference.
    pub estimate: CrossedEstimate,
}

/// The slope of the difference over doses.
#[derive(Debug, Clone, Serialize)]
pub struct Trend {
    /// Crossed estimate of the per-cell slope (metric units per percentage
    /// point, or per second of distance in a distance-dose family).
    pub slope: CrossedEstimate,
    /// -100 slope / mean(reference): optimism points per dose point.
    pub optimism_slope: f64,
    /// Its interval, from the slope's.
    pub optimism_slope_lower: f64,
    /// Its interval, from the slope's.
    pub optimism_slope_upper: f64,
    /// The smallest dose whose interval excludes zero, if any: descriptive,
    /// with no control of multiplicity over the doses. In a distance-dose
    /// family, the farthest distance whose interval lies below zero (the
    /// optimism survives there).
    pub smallest_dose_excluding_zero: Option<f64>,
    /// The lowest dose reached by step-down (fixed-sequence) testing from
    /// the largest dose: each dose's interval is examined in decreasing
    /// order of dose, and the sequence stops at the first that includes
    /// zero. A closed testing procedure, so the family-wise error over the
    /// doses is at most 1 - level. In a distance-dose family the sequence
    /// runs from the nearest distance outwards, an interval counting only
    /// below zero (optimism), and this is the farthest distance reached.
    pub step_down_dose: Option<f64>,
}

/// Estimates pooled over splits.
#[derive(Debug, Clone, Serialize)]
pub struct Pooled {
    /// Per dose, increasing.
    pub doses: Vec<PooledEstimate>,
    /// The slope over doses (two or more doses).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slope: Option<PooledEstimate>,
    /// The smallest dose whose pooled interval excludes zero, if any
    /// (descriptive, no multiplicity control; the farthest distance in a
    /// distance-dose family).
    pub smallest_dose_excluding_zero: Option<f64>,
    /// The lowest dose reached by step-down testing of the pooled
    /// intervals from the largest dose (family-wise error at most
    /// 1 - level; see [`Trend::step_down_dose`]).
    pub step_down_dose: Option<f64>,
}

/// A REML estimate over split, recording and seed.
#[derive(Debug, Clone, Serialize)]
pub struct PooledEstimate {
    /// What is estimated: `dose 5%`, `slope`.
    pub label: String,
    /// Observations (split x recording x seed cells).
    pub n: usize,
    /// Levels of split, recording and seed.
    pub levels: Vec<usize>,
    /// The intercept mu.
    pub mean: f64,
    /// Its SE (Kenward-Roger's adjusted SE under `df kenward_roger`).
    pub se: f64,
    /// The df of the interval.
    pub df: f64,
    /// Which df: `satterthwaite` or `kenward_roger`.
    pub df_rule: String,
    /// Lower bound.
    pub lower: f64,
    /// Upper bound.
    pub upper: f64,
    /// Optimism (%): for a dose, 100 (mean_reference - mean_treated) /
    /// mean_reference over every cell; for the slope, -100 mean / mean_reference.
    pub optimism_pct: f64,
    /// Optimism at the interval's bounds (-100 bound / mean_reference).
    pub optimism_lower: f64,
    /// Optimism at the interval's bounds.
    pub optimism_upper: f64,
    /// Variance components: split, recording, seed, residual.
    pub variances: [f64; 4],
    /// Share of the total variance from the split: var_split / sum.
    pub split_share: f64,
    /// Shares of Var(mu): split, recording, seed, residual.
    pub se2_shares: Vec<f64>,
    /// A component estimated at the boundary (lme4's singular fit).
    pub singular: bool,
}

/// The reference arm's and each dose's value of the primary metric, per
/// (recording, seed), for one split.
pub(super) struct Values {
    pub(super) recordings: Vec<String>,
    pub(super) seeds: Vec<u64>,
    /// [dose][recording * seeds + seed]: treated - reference.
    pub(super) d: Vec<Vec<Option<f64>>>,
    pub(super) mean_reference: f64,
}

impl FamilyAnalysis {
    /// The analysis as its report gives it, naming the figures drawn
    /// beside it (`figures`, file names in report order).
    pub fn with_figures(&self, figures: Vec<String>) -> FamilyAnalysis {
        FamilyAnalysis { figures, ..self.clone() }
    }
}
