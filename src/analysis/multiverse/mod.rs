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

mod draws;
mod joint;

mod effects;
mod guards;
mod types;

use draws::{draw_replication, pooled_choice_effects};
use effects::effect_cells;
pub use guards::{attach_unit_guards, guards};
use joint::joint_bootstrap;
pub use joint::{JointBootstrap, NullTest};
pub use types::*;

use super::diff::{common, Diff};
use super::{analyze, Analysis, AnalysisError, AnalyzeOptions};
use crate::design::{Combine, Design, Estimator, Multiverse};
use crossaudit_stats::CrossedEstimate;

/// Analyses every level and combines them.
pub fn analyze_multiverse(design: &Design, levels: &[LevelInput]) -> Result<MultiverseAnalysis, AnalysisError> {
    let analyses = analyze_levels(levels)?;
    let mv = design.multiverse.as_ref();
    let first_draw = levels.iter().filter_map(|l| l.draw).min();
    let spec_levels: Vec<usize> =
        (0..levels.len()).filter(|&k| levels[k].draw.is_none() || levels[k].draw == first_draw).collect();
    let mut specs = spec_results(mv, levels, &analyses, &spec_levels);
    let mut warnings = Vec::new();
    let diffs: Vec<Diff> = {
        use rayon::prelude::*;
        spec_levels.par_iter().map(|&k| Diff::of(levels[k].plan, levels[k].cells)).collect()
    };
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
        guards: Vec::new(),
        warnings,
        levels: analyses,
        header: crate::analysis::AnalysisHeader::default(),
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
            optimism_interval: u.optimism_interval,
            rule_holds: a.decision.holds,
            recordings: u.estimate.rows,
            guards: a.guards.clone(),
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
