//! The analysis of a multiverse and of draw replication: every
//! specification's preregistered analysis, the paired effect of each choice
//! on the primary difference d, joint inference over the whole
//! specification curve, the share of specifications meeting the rule, the
//! decision by the declared combination, and the variance the unpublished
//! draws add.
//!
//! Specifications share their evaluation recordings and seeds wherever the
//! data allow, so the primary difference d(recording, seed) of two
//! specifications is paired cell by cell. A choice's effect is, per cell,
//! the mean of d over the specifications taking an alternative minus its
//! mean over those taking the primary's alternative; its interval is the
//! design's crossed estimator on that recording x seed matrix. The joint
//! bootstrap resamples recordings and seeds once per replicate, the same
//! draw for every specification (the pigeonhole bootstrap of one contrast,
//! applied to all at once), and gives simultaneous max-|t| bands.

use std::collections::BTreeSet;

use serde::Serialize;

mod draws;
mod joint;

use draws::{draw_replication, pooled_choice_effects};
use joint::joint_bootstrap;
pub use joint::{JointBootstrap, NullTest};

use super::diff::{common, Diff};
use super::{analyze, Analysis, AnalysisError, AnalyzeOptions};
use crate::cells::Cell;
use crate::design::{Choice, Combine, DecisionRule, Design, Estimator, Multiverse};
use crate::label::Label;
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
    /// (filled by the run from the level folders).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<UnitNotes>,
    /// Starts and windows each pair of specifications shares (filled by the run).
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
    /// SHA-256 of the design, lock state: filled by the run.
    pub design_sha256: Option<String>,
    /// Whether the design was locked and unchanged.
    pub preregistered: Option<bool>,
    /// Whether every output is labelled EXPLORATORY.
    pub exploratory: bool,
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
    /// Whether the preregistered rule holds in this specification.
    pub rule_holds: bool,
    /// Evaluation recordings analysed.
    pub recordings: usize,
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

/// What a unit's folders say beyond its cells (filled by the run).
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

/// What two specifications' splits have in common.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct SharedDraws {
    /// The two specifications.
    pub left: String,
    /// The other.
    pub right: String,
    /// Shared evaluation recordings / of the left's.
    pub recordings: (usize, usize),
    /// Shared rollout starts (recording name and row) / of the left's.
    pub starts: (usize, usize),
    /// Shared fit windows of the reference arm / of the left's.
    pub fit_windows: (usize, usize),
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

/// Analyses every level and combines them.
pub fn analyze_multiverse(design: &Design, levels: &[LevelInput]) -> Result<MultiverseAnalysis, AnalysisError> {
    let analyses = analyze_levels(levels)?;
    let mv = design.multiverse.as_ref();
    let first_draw = levels.iter().filter_map(|l| l.draw).min();
    let spec_levels: Vec<usize> =
        (0..levels.len()).filter(|&k| levels[k].draw.is_none() || levels[k].draw == first_draw).collect();
    let mut specs = spec_results(mv, levels, &analyses, &spec_levels);
    let mut warnings = Vec::new();
    let diffs: Vec<Diff> = spec_levels.iter().map(|&k| Diff::of(levels[k].plan, levels[k].cells)).collect();
    let (mut choice_effects, joint) = match mv {
        Some(m) => curve_inference(design, m, &specs, &diffs, &mut warnings),
        None => (Vec::new(), None),
    };
    let draws = draw_replication(design, levels, &analyses, mv.map(|m| m.specs.iter().map(|s| s.id.clone()).collect()));
    if let Some(m) = mv {
        pool_effects_over_draws(design, m, levels, &mut choice_effects);
    }
    decide_on_pooled_draws(&draws, &mut specs);
    let combine = mv.map(|m| m.combine).unwrap_or(Combine::Primary);
    let decision = combined_decision(design, combine, &specs, &draws);
    if !draws.is_empty() {
        draw_warnings(levels, &draws, mv.is_some(), first_draw, &mut warnings);
    }
    Ok(MultiverseAnalysis {
        study: design.study.clone(),
        choices: mv.map(|m| m.choices.clone()).unwrap_or_default(),
        combine,
        rule: design.decision.clone(),
        decision,
        specs,
        choice_effects,
        joint,
        draws,
        shared: Vec::new(),
        notes: Vec::new(),
        warnings,
        levels: analyses,
        design_sha256: None,
        preregistered: None,
        exploratory: false,
    })
}

/// Each level's own analysis, in level order. Levels are analysed in
/// parallel; the first error in level order is the one reported.
fn analyze_levels(levels: &[LevelInput]) -> Result<Vec<(String, Box<Analysis>)>, AnalysisError> {
    use rayon::prelude::*;
    let each: Vec<Result<Analysis, AnalysisError>> =
        levels.par_iter().map(|l| analyze(l.plan, l.cells, AnalyzeOptions::default())).collect();
    let mut analyses: Vec<(String, Box<Analysis>)> = Vec::new();
    for (l, a) in levels.iter().zip(each) {
        analyses.push((l.id.clone(), Box::new(a?)));
    }
    Ok(analyses)
}

/// One row per specification, from the levels at `spec_levels` (those
/// of the first draw): its primary unit's estimate and its rule.
fn spec_results(
    mv: Option<&Multiverse>,
    levels: &[LevelInput],
    analyses: &[(String, Box<Analysis>)],
    spec_levels: &[usize],
) -> Vec<SpecResult> {
    let primary = mv.map(|m| m.primary).unwrap_or(0);
    let mut specs = Vec::new();
    for &k in spec_levels {
        let (l, a) = (&levels[k], &analyses[k].1);
        let u = &a.units[0];
        let index = l.spec.unwrap_or(0);
        specs.push(SpecResult {
            id: mv.map(|m| m.specs[index].id.clone()).unwrap_or_else(|| "-".to_string()),
            values: mv.map(|m| m.specs[index].values.clone()).unwrap_or_default(),
            primary: index == primary,
            shares_run_of: l.shares.clone(),
            estimate: u.estimate,
            mean_treated: u.mean_treated,
            mean_reference: u.mean_reference,
            optimism_pct: u.optimism_pct,
            rule_holds: a.decision.holds,
            recordings: u.estimate.rows,
        });
    }
    specs
}

/// Each choice's paired effect and the joint bootstrap over the curve,
/// from the specifications' paired differences `diffs`.
fn curve_inference(
    design: &Design,
    m: &Multiverse,
    specs: &[SpecResult],
    diffs: &[Diff],
    warnings: &mut Vec<String>,
) -> (Vec<ChoiceEffect>, Option<JointBootstrap>) {
    let effects = choice_effects(m, diffs, &design.estimator, warnings);
    let seed = design.sensitivity.bootstrap.as_ref().map(|b| b.seed).unwrap_or(11);
    let reps = design.sensitivity.bootstrap.as_ref().map(|b| b.replicates).unwrap_or(1999).min(9999);
    let ids: Vec<String> = specs.iter().map(|s| s.id.clone()).collect();
    // Whether specification s's rule holds were its d `d`: its own
    // interval half-widths and reference mean, d replaced.
    let rule = |s: usize, d: f64| -> bool {
        let r = &specs[s];
        let e = CrossedEstimate {
            mean: d,
            lower: r.estimate.lower - r.estimate.mean + d,
            upper: r.estimate.upper - r.estimate.mean + d,
            ..r.estimate
        };
        let optimism = -100.0 * d / r.mean_reference;
        super::decision::rule_holds(&design.decision, optimism, &e)
    };
    (effects, joint_bootstrap(&ids, diffs, (reps, seed, design.estimator.level), &rule))
}

/// With two or more draws of every specification, each choice effect is
/// pooled over them too.
fn pool_effects_over_draws(
    design: &Design,
    m: &Multiverse,
    levels: &[LevelInput],
    choice_effects: &mut [ChoiceEffect],
) {
    let draw_ids: BTreeSet<u64> = levels.iter().filter_map(|l| l.draw).collect();
    if draw_ids.len() < 2 {
        return;
    }
    let per_draw: Vec<(u64, Vec<Diff>)> = draw_ids
        .iter()
        .map(|&k| {
            let mut at: Vec<usize> = (0..levels.len()).filter(|&i| levels[i].draw == Some(k)).collect();
            at.sort_by_key(|&i| levels[i].spec);
            let at: Vec<Diff> = at.iter().map(|&i| Diff::of(levels[i].plan, levels[i].cells)).collect();
            (k, at)
        })
        .filter(|(_, at)| at.len() == m.specs.len())
        .collect();
    if per_draw.len() >= 2 {
        pooled_choice_effects(m, &per_draw, choice_effects, design.estimator.level);
    }
}

/// With draws, each specification is decided on its estimate pooled over
/// them, not on one draw.
fn decide_on_pooled_draws(draws: &[DrawReplication], specs: &mut [SpecResult]) {
    for d in draws {
        let (Some(p), Some(r)) = (&d.pooled, specs.iter_mut().find(|r| r.id == d.spec)) else { continue };
        r.estimate = CrossedEstimate {
            mean: p.mean,
            se: p.se,
            df: p.df,
            critical: (p.upper - p.mean) / p.se,
            lower: p.lower,
            upper: p.upper,
            ..r.estimate
        };
        (r.mean_treated, r.mean_reference) = (p.mean_treated, p.mean_reference);
        r.optimism_pct = p.optimism_pct;
        r.rule_holds = p.rule_holds;
    }
}

/// The decision by the declared combination of the specifications' rules,
/// with the primary specification's draws holding it, under draws.
fn combined_decision(
    design: &Design,
    combine: Combine,
    specs: &[SpecResult],
    draws: &[DrawReplication],
) -> MultiverseDecision {
    let holding = specs.iter().filter(|s| s.rule_holds).count();
    let primary_holds = specs.iter().find(|s| s.primary).map(|s| s.rule_holds).unwrap_or(false);
    let holds = match combine {
        Combine::Primary => primary_holds,
        Combine::Every => holding == specs.len(),
        Combine::AtLeast(p) => 100.0 * holding as f64 >= p * specs.len() as f64,
    };
    MultiverseDecision {
        name: design.decision.name.clone(),
        holds,
        specs_holding: holding,
        specs: specs.len(),
        primary_holds,
        draws_holding: draws
            .iter()
            .find(|d| d.spec == specs.iter().find(|s| s.primary).map_or("-", |s| s.id.as_str()))
            .map(|d| (d.per_draw.iter().filter(|x| x.5).count(), d.per_draw.len())),
    }
}

/// The caveats of draw replication: the decision reads d pooled over the
/// draws (or one draw, where no pooled fit was found), and with choices,
/// the joint bands use the first draw only.
fn draw_warnings(
    levels: &[LevelInput],
    draws: &[DrawReplication],
    choices: bool,
    first_draw: Option<u64>,
    warnings: &mut Vec<String>,
) {
    let k = levels.iter().filter_map(|l| l.draw).collect::<BTreeSet<u64>>().len();
    let unpooled: Vec<&str> = draws.iter().filter(|d| d.pooled.is_none()).map(|d| d.spec.as_str()).collect();
    warnings.push(format!(
        "the decision reads d pooled over the {k} draws (REML over recording, seed, draw and their interactions; Kenward-Roger df), so it includes the variance of the unpublished draws; each draw's own result is in the draw table{}",
        if unpooled.is_empty() {
            String::new()
        } else {
            format!(". No pooled fit for {}: there the decision reads draw {}", unpooled.join(", "), first_draw.unwrap_or(1))
        }
    ));
    if choices {
        warnings.push(format!(
            "the choice effects are pooled over the draws as the specifications are; the joint bands and the null test use draw {} only, so they do not include the draw variance (`draws per seed` puts it in every estimate)",
            first_draw.unwrap_or(1)
        ));
    }
}

/// One choice effect's paired cells: per recording and seed (over the
/// recordings and seeds every specification has), mean d over the
/// specifications taking the alternative minus mean d over those taking
/// the primary's.
struct EffectCells {
    setting: String,
    reference: String,
    alternative: String,
    specs_per_side: usize,
    recs: Vec<String>,
    seeds: Vec<u64>,
    values: Vec<f64>,
}

fn effect_cells(m: &crate::design::Multiverse, diffs: &[Diff], warnings: &mut Vec<String>) -> Vec<EffectCells> {
    let all: Vec<&Diff> = diffs.iter().collect();
    let (recs, seeds, mats) = common(&all);
    let total: BTreeSet<&Label> = diffs.iter().flat_map(|d| d.iter().map(|(r, _, _)| r)).collect();
    if recs.len() < total.len() {
        warnings.push(format!(
            "{} of {} evaluation recordings are in every specification; the paired choice effects and the joint bootstrap use those",
            recs.len(),
            total.len()
        ));
    }
    let primary = &m.specs[m.primary].values;
    let mut out = Vec::new();
    for (c, choice) in m.choices.iter().enumerate() {
        for alt in choice.alternatives.iter().filter(|a| **a != primary[c]) {
            let side =
                |value: &str| -> Vec<usize> { (0..m.specs.len()).filter(|&s| m.specs[s].values[c] == value).collect() };
            let (with, without) = (side(alt), side(&primary[c]));
            let n = recs.len() * seeds.len();
            let mean_over =
                |idx: &[usize], cell: usize| idx.iter().map(|&s| mats[s][cell]).sum::<f64>() / idx.len() as f64;
            out.push(EffectCells {
                setting: choice.setting.clone(),
                reference: primary[c].clone(),
                alternative: alt.clone(),
                specs_per_side: with.len(),
                recs: recs.clone(),
                seeds: seeds.clone(),
                values: (0..n).map(|cell| mean_over(&with, cell) - mean_over(&without, cell)).collect(),
            });
        }
    }
    out
}

fn choice_effects(
    m: &crate::design::Multiverse,
    diffs: &[Diff],
    est: &Estimator,
    warnings: &mut Vec<String>,
) -> Vec<ChoiceEffect> {
    effect_cells(m, diffs, warnings)
        .into_iter()
        .map(|e| {
            let v = e.values.iter().map(|v| Some(*v)).collect();
            let (estimate, error) = match super::unit::estimate_grid(est, e.recs.len(), e.seeds.len(), v) {
                Ok(x) => (Some(x), None),
                Err(x) => (None, Some(x.to_string())),
            };
            ChoiceEffect {
                setting: e.setting,
                reference: e.reference,
                alternative: e.alternative,
                specs_per_side: e.specs_per_side,
                estimate,
                error,
                recordings: e.recs.len(),
                pooled_draws: 0,
            }
        })
        .collect()
}
