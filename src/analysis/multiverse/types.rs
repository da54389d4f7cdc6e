//! What a multiverse analysis holds (`MultiverseAnalysis` and its parts)
//! and what it reads (`LevelInput`).

use serde::Serialize;

use super::joint::JointBootstrap;
pub use crate::analysis::record::SharedDraws;
use crate::analysis::Analysis;
use crate::cells::Cell;
use crate::design::{Choice, Combine, DecisionRule};
use crate::plan::Plan;
use crossaudit_stats::CrossedEstimate;

/// One outer level of a study: a specification, a draw, or both, with
/// its compiled plan and its cells.
pub struct LevelInput<'a> {
    /// The level's directory name (`spec-s1`, `draw-2`, `spec-s1_draw-2`).
    pub id: String,
    /// The specification's index in the multiverse, if any.
    pub spec: Option<usize>,
    /// The draw, under draw replication.
    pub draw: Option<u64>,
    /// The level whose run it shares (analysis-only choices), if not its own.
    pub shares: Option<String>,
    /// Its plan.
    pub plan: &'a Plan,
    /// Its cells.
    pub cells: &'a [Cell],
}

/// The whole multiverse (or draw-replication) analysis: `multiverse.json`.
#[derive(Debug, Clone, Serialize)]
pub struct MultiverseAnalysis {
    /// The study's name.
    pub study: String,
    /// The open choices (empty under draw replication alone).
    pub choices: Vec<Choice>,
    /// How specifications combine into the decision.
    pub combine: Combine,
    /// The preregistered rule, as written.
    #[serde(serialize_with = "as_text")]
    pub rule: DecisionRule,
    /// One row per specification (at the first draw).
    pub specs: Vec<SpecResult>,
    /// Each choice's paired effect on d, per alternative.
    pub choice_effects: Vec<ChoiceEffect>,
    /// Joint inference over the whole curve.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub joint: Option<JointBootstrap>,
    /// Draw replication, per specification.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub draws: Vec<DrawReplication>,
    /// Per unit: the reference arm's disjointness and early training
    /// (from the record's level folders: `analysis::evidence`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<UnitNotes>,
    /// The guards beside the combined verdict (a reference arm that is
    /// not disjoint, condition coverage), computed from the notes.
    pub guards: Vec<crate::analysis::Guard>,
    /// Starts and windows each pair of specifications shares (as the run
    /// recorded them in study.json).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub shared: Vec<SharedDraws>,
    /// The decision by the declared combination.
    pub decision: MultiverseDecision,
    /// Caveats.
    pub warnings: Vec<String>,
    /// Each level's own analysis, in level order (not serialized here: each
    /// is in its level's report).
    #[serde(skip)]
    pub levels: Vec<(String, Box<Analysis>)>,
    /// The design and where the analysis stands with its preregistration
    /// (results.json: `design_sha256`, `exploratory`, `preregistered` and
    /// the `standing` sentence).
    #[serde(flatten)]
    pub header: crate::analysis::AnalysisHeader,
}

fn as_text<S: serde::Serializer, T: std::fmt::Display>(v: &T, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&v.to_string())
}

/// One specification's primary result.
#[derive(Debug, Clone, Serialize)]
pub struct SpecResult {
    /// `s1`, `s2`, ...
    pub id: String,
    /// Its alternative of each choice, in choice order.
    pub values: Vec<String>,
    /// Whether it is the primary specification.
    pub primary: bool,
    /// The level whose run it shares, when only the analysis differs.
    pub shares_run_of: Option<String>,
    /// The primary crossed estimate of d (treated - reference), in the primary metric's unit.
    pub estimate: CrossedEstimate,
    /// Mean of the treated arm, in the primary metric's unit.
    pub mean_treated: f64,
    /// Mean of the reference arm, in the primary metric's unit.
    pub mean_reference: f64,
    /// 100 (reference - treated) / reference.
    pub optimism_pct: f64,
    /// The optimism's intervals (in %), as the specification's own
    /// analysis gives them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub optimism_interval: Option<crossaudit_stats::RatioInterval>,
    /// Whether the preregistered rule holds in this specification.
    pub rule_holds: bool,
    /// Evaluation recordings analysed.
    pub recordings: usize,
    /// The guards of the specification's own verdict (its rule's margin, a
    /// fragile decision, early stopping held fixed; from its level folders,
    /// early stopping, a reference arm that is not disjoint, its condition
    /// coverage).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub guards: Vec<crate::analysis::Guard>,
}

/// One alternative of a choice against the primary's alternative.
#[derive(Debug, Clone, Serialize)]
pub struct ChoiceEffect {
    /// The choice.
    pub setting: String,
    /// The primary specification's alternative.
    pub reference: String,
    /// The alternative compared with it.
    pub alternative: String,
    /// Specifications on each side.
    pub specs_per_side: usize,
    /// The crossed estimate of mean d(alternative) - mean d(reference), in the primary metric's unit.
    pub estimate: Option<CrossedEstimate>,
    /// Why there is no estimate, if there is none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Recordings every specification shares (the rows of the paired matrix).
    pub recordings: usize,
    /// With `factor draw`: the draws the estimate is pooled over (REML over
    /// recording, seed, draw and their interactions, Kenward-Roger df);
    /// 0 when it is the first draw's crossed estimate.
    #[serde(skip_serializing_if = "is_zero")]
    pub pooled_draws: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// How much the unpublished draws move one specification's result.
#[derive(Debug, Clone, Serialize)]
pub struct DrawReplication {
    /// The specification (`-` without choices).
    pub spec: String,
    /// Per draw: (draw, estimate of d, lower, upper, optimism %, whether the rule holds).
    pub per_draw: Vec<(u64, f64, f64, f64, f64, bool)>,
    /// REML variance components of d over recording x seed x draw:
    /// (source, variance in m^2, share of Var(mean)).
    pub components: Vec<(String, f64, f64)>,
    /// The estimate pooled over draws by that REML fit, with Kenward-Roger
    /// df (Satterthwaite where they cannot be computed): what a
    /// draw-replicated design decides on.
    pub pooled: Option<PooledDraws>,
    /// Why there is no pooled fit, if none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// Windows of evaluation recordings (or their byte-identical copies) in a
/// unit's reference-arm fit sets (invariant 5, which holds only with a
/// warning under `duplicates keep`).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct ReferenceCopies {
    /// Fewest such windows in one level's fit set.
    pub fewest: usize,
    /// Most.
    pub most: usize,
    /// Levels (draws) whose fit set holds any.
    pub levels_with: usize,
    /// Levels of the unit.
    pub levels: usize,
}

/// What a unit's folders say beyond its cells (from its record).
#[derive(Debug, Clone, Serialize)]
pub struct UnitNotes {
    /// The unit (`spec-s1`, `draw-2`).
    pub id: String,
    /// Whether its reference arm holds copies of evaluation recordings.
    pub reference_copies: Option<ReferenceCopies>,
    /// Training that ended early.
    pub early: Option<crate::analysis::training::EarlyTraining>,
    /// The reference arm's condition coverage over the unit's levels
    /// (absent for levels written before coverage was measured).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coverage: Option<crate::analysis::coverage::CoverageNote>,
}

/// d pooled over recording x seed x draw.
#[derive(Debug, Clone, Serialize)]
pub struct PooledDraws {
    /// The REML intercept, in the primary metric's unit.
    pub mean: f64,
    /// Its SE (Kenward-Roger's adjusted SE with their df).
    pub se: f64,
    /// Denominator df (finite: a pooled fit without finite df has none).
    pub df: f64,
    /// `kenward_roger` or `satterthwaite`.
    pub df_rule: String,
    /// The interval at the design's level: lower bound.
    pub lower: f64,
    /// Upper bound.
    pub upper: f64,
    /// The design's level.
    pub level: f64,
    /// The arms' means over every draw's cells, in the primary metric's unit.
    pub mean_treated: f64,
    /// The reference arm's.
    pub mean_reference: f64,
    /// 100 (reference - treated) / reference over every draw's cells.
    pub optimism_pct: f64,
    /// Whether the preregistered rule holds on the pooled estimate.
    pub rule_holds: bool,
    /// Levels each random factor was estimated from.
    pub levels: Vec<(String, usize)>,
    /// Notes on the df (a fallback) and on factors with few levels.
    pub notes: Vec<String>,
}

/// The decision by the declared combination.
#[derive(Debug, Clone, Serialize)]
pub struct MultiverseDecision {
    /// The rule's name.
    pub name: String,
    /// Whether it holds by the combination.
    pub holds: bool,
    /// Specifications in which the rule holds.
    pub specs_holding: usize,
    /// Specifications.
    pub specs: usize,
    /// Whether it holds in the primary specification.
    pub primary_holds: bool,
    /// Under draw replication: draws of the primary specification in which
    /// the rule holds, and how many draws.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub draws_holding: Option<(usize, usize)>,
}
