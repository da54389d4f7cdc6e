//! The draws in a multiverse: each specification's d, and each choice
//! effect, pooled over `factor draw` by one REML fit over recording, seed,
//! draw and their interactions, with the Kenward-Roger interval.

use std::collections::{BTreeMap, BTreeSet};

use super::effects::{effect_cells, EffectCells};
use super::types::{ChoiceEffect, DrawReplication, LevelInput, PooledDraws};
use crate::analysis::diff::Diff;
use crate::analysis::Analysis;
use crate::design::Design;
use crossaudit_stats::CrossedEstimate;

/// The choice effects of a multiverse crossed with `factor draw`, each
/// pooled over the draws as a specification's d is: its paired cells in
/// every draw (`per_draw`: the draw and its specifications' differences,
/// in specification order), REML over recording, seed, draw,
/// recording:draw and seed:draw, and the intercept's Kenward-Roger
/// interval. An effect whose pooled fit fails keeps its first-draw
/// estimate, with the reason.
pub(super) fn pooled_choice_effects(
    m: &crate::design::Multiverse,
    per_draw: &[(u64, Vec<Diff>)],
    effects: &mut [ChoiceEffect],
    level: f64,
) {
    let cells: Vec<(u64, Vec<EffectCells>)> =
        per_draw.iter().map(|(k, diffs)| (*k, effect_cells(m, diffs, &mut Vec::new()))).collect();
    for (e, effect) in effects.iter_mut().enumerate() {
        let rows: Vec<(&str, u64, u64, f64)> = cells
            .iter()
            .filter_map(|(k, es)| es.get(e).map(|x| (k, x)))
            .flat_map(|(k, x)| {
                x.recs.iter().flat_map(move |r| x.seeds.iter().map(move |s| (r.as_str(), *s, *k))).zip(&x.values)
            })
            .map(|((r, s, k), v)| (r, s, k, *v))
            .collect();
        let fit = fit_over_draws(&rows).map_err(|x| x.to_string()).and_then(|f| {
            let (se, df, _, lower, upper) = f.intercept_interval(true, level).map_err(|x| x.to_string())?;
            Ok((f.intercept, se, df, lower, upper))
        });
        match (fit, effect.estimate) {
            (Ok((mean, se, df, lower, upper)), Some(template)) => {
                effect.estimate =
                    Some(CrossedEstimate { mean, se, df, critical: (upper - mean) / se, lower, upper, ..template });
                effect.pooled_draws = cells.len();
            }
            (Err(x), _) => {
                effect.error = Some(format!("no fit pooled over the draws ({x}); the estimate is the first draw's"));
            }
            _ => {}
        }
    }
}

/// REML of d over recording, seed, draw, recording:draw and seed:draw,
/// from (recording, seed, draw, d) rows; certified.
fn fit_over_draws(
    rows: &[(&str, u64, u64, f64)],
) -> Result<crossaudit_stats::mixed::MixedFit, crossaudit_stats::mixed::MixedError> {
    let mut names: BTreeMap<&str, usize> = BTreeMap::new();
    let (mut y, mut rec, mut seed, mut draw, mut rec_draw, mut seed_draw) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for &(r, s, k, v) in rows {
        let n = names.len();
        let ri = *names.entry(r).or_insert(n);
        let kd = k as usize;
        y.push(v);
        rec.push(ri);
        seed.push(s as usize);
        draw.push(kd);
        rec_draw.push(ri * 100_000 + kd);
        seed_draw.push(s as usize * 100_000 + kd);
    }
    let factors = vec![
        ("recording".to_string(), rec),
        ("seed".to_string(), seed),
        ("draw".to_string(), draw),
        ("recording:draw".to_string(), rec_draw),
        ("seed:draw".to_string(), seed_draw),
    ];
    crossaudit_stats::mixed::MixedData::new(y, factors)
        .and_then(|data| crossaudit_stats::mixed::fit(&data, crossaudit_stats::mixed::Criterion::Reml))
        .and_then(|f| f.certified())
}

/// Per specification with several draws: each draw's estimate and the
/// REML variance components of d over recording, seed and draw.
pub(super) fn draw_replication(
    design: &Design,
    levels: &[LevelInput],
    analyses: &[(String, Box<Analysis>)],
    spec_ids: Option<Vec<String>>,
) -> Vec<DrawReplication> {
    let specs: BTreeSet<usize> = levels.iter().filter(|l| l.draw.is_some()).map(|l| l.spec.unwrap_or(0)).collect();
    let mut out = Vec::new();
    for s in specs {
        let members: Vec<usize> =
            (0..levels.len()).filter(|&k| levels[k].draw.is_some() && levels[k].spec.unwrap_or(0) == s).collect();
        let per_draw = members
            .iter()
            .map(|&k| {
                let a = &analyses[k].1;
                let u = &a.units[0];
                let draw = levels[k].draw.unwrap_or(1);
                (draw, u.estimate.mean, u.estimate.lower, u.estimate.upper, u.optimism_pct, a.decision.holds)
            })
            .collect();
        let diffs: Vec<(u64, Diff)> =
            members.iter().map(|&k| (levels[k].draw.unwrap_or(1), Diff::of(levels[k].plan, levels[k].cells))).collect();
        let rows: Vec<(&str, u64, u64, f64)> =
            diffs.iter().flat_map(|(kd, d)| d.iter().map(move |(r, sd, v)| (r.as_str(), sd, *kd, v))).collect();
        let fit = fit_over_draws(&rows);
        let spec = spec_ids.as_ref().map(|ids| ids[s].clone()).unwrap_or_else(|| "-".to_string());
        match fit {
            Ok(f) => {
                let mut components: Vec<(String, f64, f64)> = f
                    .factors
                    .iter()
                    .zip(&f.variances)
                    .zip(&f.shares)
                    .map(|((n, v), sh)| (n.clone(), *v, *sh))
                    .collect();
                components.push(("residual".to_string(), f.residual, f.shares.last().copied().unwrap_or(0.0)));
                let mean_of = |arm: fn(&crate::analysis::UnitResult) -> f64| {
                    members.iter().map(|&k| arm(&analyses[k].1.units[0])).sum::<f64>() / members.len().max(1) as f64
                };
                let means = (mean_of(|u| u.mean_treated), mean_of(|u| u.mean_reference));
                let template = &analyses[members[0]].1.units[0].estimate;
                let (pooled, error) = match pooled_draws(design, &f, means, template) {
                    Ok(p) => (Some(p), None),
                    Err(e) => (None, Some(e)),
                };
                out.push(DrawReplication { spec, per_draw, components, pooled, error });
            }
            Err(e) => out.push(DrawReplication {
                spec,
                per_draw,
                components: Vec::new(),
                pooled: None,
                error: Some(e.to_string()),
            }),
        }
    }
    out
}

/// The decision's estimate from a certified REML fit over draws: Kenward-
/// Roger's adjusted SE and df (Satterthwaite's where KR has none), the
/// design's level, and the rule applied to it.
fn pooled_draws(
    design: &Design,
    f: &crossaudit_stats::mixed::MixedFit,
    (mean_treated, mean_reference): (f64, f64),
    template: &CrossedEstimate,
) -> Result<PooledDraws, String> {
    let level = design.estimator.level;
    let (se, df, df_rule, lower, upper) = f.intercept_interval(true, level).map_err(|e| e.to_string())?;
    let critical = (upper - f.intercept) / se;
    let optimism_pct = -100.0 * f.intercept / mean_reference;
    let e = CrossedEstimate { mean: f.intercept, se, df, level, critical, lower, upper, ..*template };
    let levels: Vec<(String, usize)> = f.factors.iter().cloned().zip(f.levels.iter().copied()).collect();
    let mut notes = f.notes.clone();
    let few: Vec<String> = levels.iter().filter(|(_, n)| *n < 5).map(|(name, n)| format!("{name} ({n})")).collect();
    if !few.is_empty() {
        notes.push(format!(
            "estimated from fewer than 5 levels: {}; such a variance component is poorly determined, and the interval's width with it",
            few.join(", ")
        ));
    }
    Ok(PooledDraws {
        mean: f.intercept,
        se,
        df,
        df_rule: df_rule.to_string(),
        lower,
        upper,
        level,
        mean_treated,
        mean_reference,
        optimism_pct,
        rule_holds: crate::analysis::decision::rule_holds(&design.decision, optimism_pct, &e),
        levels,
        notes,
    })
}
