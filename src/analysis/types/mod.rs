//! What an analysis produces: the schema of `results.json`.

use serde::Serialize;

use crate::design::{Factor, Metric, Role};
use crossaudit_stats::{BootstrapInterval, CrossedEstimate, IntervalEstimate, RatioInterval};

mod decision;
pub use decision::{ConditionOutcome, Decision, Margin, MemberOf};

/// Options of [`crate::analysis::analyze`] that are not part of the design.
#[derive(Debug, Clone, Copy, Default)]
pub struct AnalyzeOptions {
    /// Add every interval estimator side by side for each contrast.
    pub compare_intervals: bool,
}

/// The whole analysis, serialized as results.json.
#[derive(Debug, Clone, Serialize)]
pub struct Analysis {
    /// The study's name.
    pub study: String,
    /// The design and where the analysis stands with its preregistration
    /// (results.json: `design_sha256`, `exploratory`, `preregistered` and
    /// the `standing` sentence).
    #[serde(flatten)]
    pub header: crate::analysis::AnalysisHeader,
    /// The treated arm of the contrast.
    pub treated: String,
    /// The reference arm of the contrast.
    pub reference: String,
    /// Confidence level of every interval.
    pub level: f64,
    /// The evaluation recordings and their condition labels, sorted by name.
    pub recordings: Vec<RecordingLabels>,
    /// The seeds, in design order.
    pub seeds: Vec<u64>,
    /// Every analysis unit, the primary first.
    pub units: Vec<UnitResult>,
    /// Model interactions of the contrast.
    pub interactions: Vec<InteractionResult>,
    /// The preregistered decision on the primary unit.
    pub decision: Decision,
    /// Analyses skipped or caveats, in plan order.
    pub warnings: Vec<String>,
    /// Cells of the crossed matrix absent from the per-cell data, one line
    /// each (only under `estimate reml ... missing allow`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub missing_cells: Vec<String>,
    /// Figure files (relative to the report), when a run drew them.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub figures: Vec<String>,
    /// How strong each treated arm's treatment is, when a run built the
    /// split (an analysis of a per-cell CSV alone has no split to measure).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub treatment: Vec<TreatmentStrength>,
    /// Which evaluation conditions the reference arm's fit set covers, when
    /// a run built the split.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coverage: Option<ConditionCoverage>,
    /// The primary contrast with early stopping held fixed (the primary
    /// model's `restore final` twin), when the design declares one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fixed_budget: Option<FixedBudget>,
    /// Which data, which cells and which build produced this analysis.
    pub provenance: Provenance,
    /// The guards of the verdict, computed from everything above
    /// (by the analysis's guards module); every view gives them beside it.
    pub guards: Vec<Guard>,
    /// The fitted jobs' validation-loss curves the run folder holds (the
    /// training curves figure; none for a per-cell file alone). Not in
    /// results.json.
    #[serde(skip)]
    pub curves: Vec<super::record::Curve>,
}

/// One arm's treatment strength: how close its contaminating windows (the
/// windows drawn from the evaluation recordings) sit to the rollouts that
/// are evaluated.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TreatmentStrength {
    /// The arm.
    pub arm: String,
    /// Its windows from the evaluation recordings.
    pub contaminating_windows: usize,
    /// Of those, the windows whose start lies inside an evaluated segment
    /// [start, start + horizon] of the same recording.
    pub inside_evaluated_segment: usize,
    /// The rollout horizon that defines a segment, in seconds.
    pub horizon_s: f64,
    /// Median distance from a window to the nearest rollout start of its
    /// recording, in seconds.
    pub median_distance_s: f64,
    /// Quartiles (first, median, third) of the distance from a window to
    /// the nearest evaluated segment of its recording, in seconds (0 for a
    /// window that shares a row with one); `None` where the split's audit
    /// was written by a build that did not measure them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub segment_distance_quartiles_s: Option<[f64; 3]>,
}

/// Where an analysis came from: reports print it beside the design hash.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Provenance {
    /// The flight logs the cells were computed from, when a run produced them.
    pub data: Option<String>,
    /// SHA-256 of the run's inclusion audit (`audit/recordings.csv`).
    pub audit_sha256: Option<String>,
    /// What that audit decided, counted (absent for a per-cell file alone,
    /// or an audit the report could not read).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inclusion: Option<super::record::Inclusion>,
    /// The per-cell CSV analysed and its SHA-256.
    pub cells: Option<(String, String)>,
    /// The crossaudit build that wrote the analysis ([`crate::io::BUILD`]).
    pub crossaudit: String,
}

impl Default for Provenance {
    fn default() -> Self {
        Provenance {
            data: None,
            audit_sha256: None,
            inclusion: None,
            cells: None,
            crossaudit: crate::io::BUILD.to_string(),
        }
    }
}

impl Analysis {
    /// The analysis as its report gives it, naming the figures drawn
    /// beside it (`figures`, file names in report order).
    pub fn with_figures(&self, figures: Vec<String>) -> Analysis {
        Analysis { figures, ..self.clone() }
    }
}

/// What a guard is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GuardKind {
    /// A rule threshold inside the interval of the quantity it reads.
    Margin,
    /// A rule that reads no interval bound holds while d's interval holds 0.
    NoInterval,
    /// The rule does not hold in every leave-one-out fit.
    Fragile,
    /// Models restored at an early best epoch.
    EarlyStopping,
    /// The primary contrast with early stopping held fixed.
    FixedBudget,
    /// The reference arm fits on copies of evaluation flights.
    NotDisjoint,
    /// The validation set holds copies of evaluation flights (invariant
    /// 3 with a warning): early stopping is steered by those flights.
    ValidationCopies,
    /// Which evaluated conditions the reference arm covers.
    Coverage,
    /// A divergence endpoint's events held by few recordings.
    Concentrated,
    /// What a distance-dose family's contrasts measure (every arm
    /// replaces the same share; only the distance differs).
    Distance,
    /// Doses whose treated arm is worse than the reference: the trend
    /// also measures the cost of the fit windows replaced.
    Harm,
}

impl GuardKind {
    /// The kind's name as results.json and the CSV tables write it.
    pub fn name(self) -> &'static str {
        match self {
            GuardKind::Margin => "margin",
            GuardKind::NoInterval => "no_interval",
            GuardKind::Fragile => "fragile",
            GuardKind::EarlyStopping => "early_stopping",
            GuardKind::FixedBudget => "fixed_budget",
            GuardKind::NotDisjoint => "not_disjoint",
            GuardKind::ValidationCopies => "validation_copies",
            GuardKind::Coverage => "coverage",
            GuardKind::Concentrated => "concentrated",
            GuardKind::Distance => "distance",
            GuardKind::Harm => "harm",
        }
    }
}

/// One guard: its kind and its statement, a Markdown paragraph (a bold
/// heading, code spans for names).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Guard {
    /// What it is about.
    pub kind: GuardKind,
    /// The paragraph report.md gives beside the verdict.
    pub text: String,
}

impl Guard {
    /// A guard of kind `kind` stating `text` (Markdown).
    pub fn new(kind: GuardKind, text: String) -> Guard {
        Guard { kind, text }
    }

    /// The statement as plain text (the Markdown emphasis removed), as the
    /// console, the banner and Python give it.
    pub fn plain(&self) -> String {
        self.text.replace("**", "")
    }
}

/// A recording's condition labels.
#[derive(Debug, Clone, Serialize)]
pub struct RecordingLabels {
    /// The recording's name.
    pub recording: String,
    /// Its trajectory family.
    pub trajectory: String,
    /// Its speed label.
    pub speed: String,
}

/// The contrast of one analysis unit and its sensitivity analyses.
#[derive(Debug, Clone, Serialize)]
pub struct UnitResult {
    /// Primary or secondary.
    pub role: Role,
    /// The model.
    pub model: String,
    /// The metric.
    pub metric: Metric,
    /// The horizon in seconds.
    pub horizon_s: f64,
    /// Mean of the treated arm over the I x J matrix.
    pub mean_treated: f64,
    /// Mean of the reference arm over the I x J matrix.
    pub mean_reference: f64,
    /// 100 (mean_reference - mean_treated) / mean_reference.
    pub optimism_pct: f64,
    /// The optimism's intervals (in %): Fieller's (the estimator's test of
    /// `optimism = x` inverted) and the delta method's, from the same
    /// crossed estimator as `estimate`; absent (with a warning) when the
    /// reference arm's mean or its estimate cannot give one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub optimism_interval: Option<RatioInterval>,
    /// Every recording's value is the same for every seed in both arms (a
    /// model that does not vary with the seed, such as a closed-form fit on
    /// a split that does not change with it): the unit is analysed over the
    /// recordings alone, with df I - 1.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub seed_invariant: bool,
    /// The crossed estimate of the mean difference treated - reference.
    pub estimate: CrossedEstimate,
    /// The pigeonhole bootstrap interval, when preregistered.
    pub bootstrap: Option<BootstrapInterval>,
    /// The estimate over condition groups, when preregistered and possible.
    pub grouped: Option<GroupedResult>,
    /// Leave-one-level-out ranges, one per preregistered factor.
    pub leave_one_out: Vec<LeaveOneOut>,
    /// Optimism within each seed.
    pub per_seed_optimism: Vec<SeedOptimism>,
    /// Mean difference within each trajectory family.
    pub per_trajectory: Vec<TrajectoryMean>,
    /// Divergence counts and the conditional-RMSE contrast.
    pub conditional: ConditionalSummary,
    /// Whether this unit alone would meet the decision rule.
    pub rule_holds: bool,
    /// Every interval estimator side by side (`--compare-intervals`).
    pub intervals: Option<Vec<IntervalEstimate>>,
    /// The crossed binomial GLMM of the unit's diverged starts, when its
    /// endpoint declares `glmm binomial`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub glmm: Option<GlmmEndpoint>,
}

/// The crossed binomial GLMM of a divergence endpoint: each cell's
/// diverged starts out of its starts, the arm fixed, recording, seed and
/// recording x seed random intercepts (lme4's `glmer`, Laplace).
#[derive(Debug, Clone, Serialize)]
pub struct GlmmEndpoint {
    /// The model, in lme4's formula language.
    pub model: String,
    /// Diverged starts and starts, treated arm.
    pub diverged_treated: u64,
    /// All starts, treated arm.
    pub starts_treated: u64,
    /// Diverged starts, reference arm.
    pub diverged_reference: u64,
    /// All starts, reference arm.
    pub starts_reference: u64,
    /// The arm's effect, when it is estimable.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub estimate: Option<GlmmContrast>,
    /// Why it is not (no divergence, or every start diverged, in an arm;
    /// or the fit failed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub not_estimable: Option<String>,
    /// The fewest recordings that hold nine tenths of the diverged starts
    /// (both arms) and how many each holds, most first, when they are at
    /// most a fifth of the recordings; empty otherwise.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub concentrated: Vec<(String, u64)>,
}

/// The treated arm's effect on the odds that a rollout diverges, within
/// recording and seed (a conditional odds ratio, not a ratio of rates).
#[derive(Debug, Clone, Serialize)]
pub struct GlmmContrast {
    /// log odds ratio, treated over reference.
    pub log_odds_ratio: f64,
    /// Its standard error (lme4's default: the Hessian in theta and beta).
    pub se: f64,
    /// Wald z.
    pub z: f64,
    /// Two-sided p of z.
    pub p: f64,
    /// Wald interval of the log odds ratio at the estimate's level.
    pub lower: f64,
    /// Its upper bound.
    pub upper: f64,
    /// exp(log odds ratio).
    pub odds_ratio: f64,
    /// exp(lower).
    pub odds_ratio_lower: f64,
    /// exp(upper).
    pub odds_ratio_upper: f64,
    /// Standard deviation of the recordings' intercepts (log odds).
    pub sd_recording: f64,
    /// Of the seeds'.
    pub sd_seed: f64,
    /// Of the recording x seed cells'.
    pub sd_recording_seed: f64,
    /// -2 log-likelihood (Laplace).
    pub deviance: f64,
    /// Whether the optimizer certified its optimum.
    pub certified: bool,
    /// Whether a variance is estimated at zero.
    pub singular: bool,
}

/// The crossed estimate after averaging recordings within condition groups.
#[derive(Debug, Clone, Serialize)]
pub struct GroupedResult {
    /// Group labels, in row order of the grouped matrix.
    pub groups: Vec<String>,
    /// Recordings in each group.
    pub recordings_per_group: Vec<usize>,
    /// The estimate on the groups x seeds matrix.
    pub estimate: CrossedEstimate,
}

/// Ranges over the fits that each leave one level of a factor out.
#[derive(Debug, Clone, Serialize)]
pub struct LeaveOneOut {
    /// The factor whose levels are left out.
    pub factor: Factor,
    /// How many fits (one per level left out).
    pub fits: usize,
    /// Smallest mean difference.
    pub mean_min: f64,
    /// Largest mean difference.
    pub mean_max: f64,
    /// Smallest upper bound.
    pub upper_min: f64,
    /// Largest upper bound.
    pub upper_max: f64,
    /// Smallest optimism (%).
    pub optimism_min: f64,
    /// Largest optimism (%).
    pub optimism_max: f64,
    /// Fits in which the decision rule still holds.
    pub rule_holds: usize,
    /// The levels (recording names, or seeds) whose leaving-out moves the
    /// verdict: the rule fails without them where it holds on every level,
    /// or holds without them where it fails.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub moves_verdict: Vec<String>,
}

/// Optimism within one seed.
#[derive(Debug, Clone, Serialize)]
pub struct SeedOptimism {
    /// The seed.
    pub seed: u64,
    /// Its optimism (%), from the seed's column means.
    pub optimism_pct: f64,
}

/// Mean difference within one trajectory family.
#[derive(Debug, Clone, Serialize)]
pub struct TrajectoryMean {
    /// The family.
    pub trajectory: String,
    /// Its evaluation recordings.
    pub recordings: usize,
    /// Mean of d over its recordings and every seed.
    pub mean_difference: f64,
}

/// Divergence and the conditional-on-finite RMSE of both arms.
#[derive(Debug, Clone, Serialize)]
pub struct ConditionalSummary {
    /// Mean conditional-on-finite position RMSE over cells that have one.
    pub mean_conditional_treated: Option<f64>,
    /// As above, reference arm.
    pub mean_conditional_reference: Option<f64>,
    /// Diverged starts, treated arm.
    pub divergent_treated: u64,
    /// All starts, treated arm.
    pub starts_treated: u64,
    /// Diverged starts, reference arm.
    pub divergent_reference: u64,
    /// All starts, reference arm.
    pub starts_reference: u64,
    /// Crossed interval of the conditional RMSE difference over the pairs
    /// where both arms have a finite value: the plan's estimator when none
    /// is dropped; otherwise REML, with the plan's df when the plan's
    /// estimator is REML and Kenward-Roger df when it is the method of
    /// moments; absent when too few pairs remain for a crossed model (see
    /// `difference_error`).
    pub difference: Option<CrossedEstimate>,
    /// Cells (either arm) in which every start diverged.
    pub cells_without_finite_rollout: usize,
    /// Recording x seed pairs left out of the conditional contrast because
    /// an arm has no finite value there (or no cell).
    pub pairs_dropped: usize,
    /// Why the contrast over the pairs left could not be estimated.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub difference_error: Option<String>,
}

/// The crossed estimate of an interaction of two models' contrasts.
#[derive(Debug, Clone, Serialize)]
pub struct InteractionResult {
    /// The metric.
    pub metric: Metric,
    /// The horizon in seconds.
    pub horizon_s: f64,
    /// `left - right`.
    pub left: String,
    /// `left - right`.
    pub right: String,
    /// Estimate of d(left) - d(right).
    pub estimate: CrossedEstimate,
    /// The pigeonhole bootstrap interval, when preregistered.
    pub bootstrap: Option<BootstrapInterval>,
}

/// The primary endpoint's contrast for the full-budget twin of the
/// primary model.
#[derive(Debug, Clone, Serialize)]
pub struct FixedBudget {
    /// The twin model (`restore final`).
    pub model: String,
    /// The epochs every model of it trained.
    pub epochs: usize,
    /// Optimism (%).
    pub optimism_pct: f64,
    /// Its interval (%).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub optimism_interval: Option<RatioInterval>,
    /// The crossed estimate of d.
    pub estimate: CrossedEstimate,
    /// Whether the decision rule would hold on it.
    pub rule_holds: bool,
}

/// An evaluation recording whose condition the reference arm fits on no
/// other recording of.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Uncovered {
    /// The recording.
    pub recording: String,
    /// Its condition (`circle`, or `circle / fast`).
    pub condition: String,
    /// In how many of the study's draws it was uncovered (1 in a single
    /// split; up to J under per-seed draws).
    pub draws: usize,
}

/// The reference arm's condition coverage, as the report states it.
#[derive(Debug, Clone, Serialize)]
pub struct ConditionCoverage {
    /// What a condition is: `trajectory` or `trajectory x speed`.
    pub condition: String,
    /// The reference arm.
    pub arm: String,
    /// The draws coverage was measured in (1, or each seed's draw).
    pub draws: usize,
    /// The uncovered evaluation recordings (in any draw), by name.
    pub uncovered: Vec<Uncovered>,
    /// Their share of the primary endpoint's summed difference d over every
    /// cell (of sum d; NaN when sum d is 0).
    pub share_of_d: f64,
    /// The primary contrast over the covered recordings alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub covered_only: Option<CoveredOnly>,
    /// Why the covered-only row could not be estimated.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub covered_only_error: Option<String>,
}

/// The primary contrast over the recordings every draw of the reference
/// arm covers.
#[derive(Debug, Clone, Serialize)]
pub struct CoveredOnly {
    /// Covered recordings.
    pub recordings: usize,
    /// Optimism (%) over them.
    pub optimism_pct: f64,
    /// Its interval (%).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub optimism_interval: Option<RatioInterval>,
    /// The crossed estimate of d over them.
    pub estimate: CrossedEstimate,
    /// Whether the decision rule would hold on them.
    pub rule_holds: bool,
}

/// The reference arm's coverage over the levels of a combined study (a
/// multiverse unit's draws, a family's split), as its report states it.
#[derive(Debug, Clone, Serialize)]
pub struct CoverageNote {
    /// What a condition is: `trajectory` or `trajectory x speed`.
    pub condition: String,
    /// The reference arm.
    pub arm: String,
    /// The levels whose coverage was read.
    pub levels: usize,
    /// The evaluation recordings uncovered in at least one level.
    pub uncovered: Vec<Uncovered>,
}
