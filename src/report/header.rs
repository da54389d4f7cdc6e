//! report.md's header: the title with the verdict, what stands beside the
//! verdict, the rule and the contrast, notes on the estimator, provenance
//! and the figures.

use std::fmt::Write as _;

use super::format::{decision_summary, level_pct};
use crate::analysis::Analysis;
use crossaudit_stats::DfRule;

/// Title with the verdict, the decision line, the rule and the figures.
pub(super) fn header(a: &Analysis) -> String {
    let mut s = String::new();
    let _ =
        writeln!(s, "# {}: {}\n", super::md_text(&a.study), super::format::verdict(&a.decision, &a.header.standing));
    beside_verdict(&mut s, a);
    rule_and_contrast(&mut s, a);
    estimator_notes(&mut s, a);
    provenance_and_figures(&mut s, a);
    s
}

/// What stands beside the verdict: the decision's summary, then its
/// guards ([`crate::analysis::guards`]).
fn beside_verdict(s: &mut String, a: &Analysis) {
    let _ = writeln!(s, "{}\n", decision_summary(&a.decision));
    for g in &a.guards {
        let _ = writeln!(s, "{}\n", g.text);
    }
}

/// The rule, what it reads, the optimism's interval and the contrast.
fn rule_and_contrast(s: &mut String, a: &Analysis) {
    let level = level_pct(a.level);
    if let Some(m) = &a.decision.member_of {
        let _ = writeln!(
            s,
            "Rule: `{}`, the family's, evaluated on {} (`{}`). No rule decides on this contrast: its estimates and intervals are descriptive, and its conditions above are the rule's thresholds read on it alone.",
            a.decision.rule, m.decides_on, m.report
        );
    } else if super::format::reads_interval(&a.decision) {
        let _ = writeln!(s, "Rule: `{}`, evaluated on {}.", a.decision.rule, a.decision.unit);
        let _ = writeln!(
            s,
            "The decision uses the {level} crossed-estimator interval (the `{level} CI` column); bootstrap intervals are shown for comparison and decide nothing. Secondary endpoints are descriptive: no rule applies to them."
        );
    } else {
        let _ = writeln!(s, "Rule: `{}`, evaluated on {}.", a.decision.rule, a.decision.unit);
        let _ = writeln!(
            s,
            "The rule reads no interval bound: it compares point estimates with its thresholds. The {level} crossed-estimator interval (the `{level} CI` column) and the bootstrap intervals are shown beside it and decide nothing. Secondary endpoints are descriptive: no rule applies to them."
        );
    }
    let _ = writeln!(
        s,
        "The optimism's {level} interval (the `optimism {level} CI` column) is Fieller's: every optimism x for which the crossed estimator's interval of {t} - (1 - x/100) {r} contains 0, from the same estimator and df as d's."
    , t = a.treated, r = a.reference);
    let estimator = match a.units.first().and_then(|u| u.estimate.reml) {
        None => "crossed method-of-moments estimator".to_string(),
        Some(r) => format!(
            "REML estimator (random intercepts for recording and seed, lme4's model), {} df",
            match r.df_rule {
                DfRule::KenwardRoger => "Kenward-Roger SE and",
                DfRule::Satterthwaite => "Satterthwaite",
                DfRule::SeedsMinusOne => "J - 1",
                DfRule::RecordingsMinusOne => "I - 1",
                DfRule::Normal => "normal (infinite)",
            }
        ),
    };
    let _ = writeln!(
        s,
        "Contrast `{} - {}` over {} recordings x {} seeds; {estimator}, {} intervals.",
        a.treated,
        a.reference,
        a.recordings.len(),
        a.seeds.len(),
        level_pct(a.level)
    );
    let _ = writeln!(
        s,
        "d = {t} - {r} per recording x seed cell, in the metric's unit; optimism (%) = 100 ({r} mean - {t} mean) / {r} mean: how much better the {t} arm looks.",
        t = a.treated,
        r = a.reference
    );
}

/// Units analysed over recordings alone, and singular REML fits.
fn estimator_notes(s: &mut String, a: &Analysis) {
    let invariant: Vec<String> = a
        .units
        .iter()
        .filter(|u| u.seed_invariant)
        .map(|u| format!("{} {} at {} s", u.model, u.metric.name(), u.horizon_s))
        .collect();
    if !invariant.is_empty() {
        let _ = writeln!(
            s,
            "Analysed over recordings alone: {}. Every recording's value is the same for every seed in both arms (a model that does not vary with the seed, as a closed-form fit on a split that does not change with it): the seeds add no variation, so these intervals take their df from the I recordings (I - 1 = {}), not from the seeds.",
            invariant.join("; "),
            a.recordings.len().saturating_sub(1)
        );
    }
    let singular: Vec<String> = a
        .units
        .iter()
        .filter(|u| u.estimate.reml.is_some_and(|r| r.singular))
        .map(|u| format!("{} {} at {} s", u.model, u.metric.name(), u.horizon_s))
        .collect();
    if !singular.is_empty() {
        let _ = writeln!(
            s,
            "Singular REML fit (a variance component estimated at zero, as lme4's isSingular says) for {}. There Satterthwaite's df hold the zero component fixed while Kenward-Roger's keep it through a generalized inverse, so the two df differ.",
            singular.join("; ")
        );
    }
}

/// The design's hash, the data, the per-cell file, the build, and the
/// figures.
fn provenance_and_figures(s: &mut String, a: &Analysis) {
    if let Some(h) = &a.header.design_sha256 {
        let _ = writeln!(s, "Design SHA-256: `{h}`.");
    }
    let p = &a.provenance;
    if let Some(d) = &p.data {
        let _ = writeln!(
            s,
            "Data: {}; inclusion audit SHA-256 `{}`{}.",
            crate::io::md_line(d),
            p.audit_sha256.as_deref().unwrap_or("unknown"),
            p.inclusion.map(|i| format!(" ({})", i.sentence())).unwrap_or_default()
        );
    }
    if let Some((path, sha)) = &p.cells {
        let _ = writeln!(s, "Per-cell data: {} (SHA-256 `{sha}`).", super::md_code(path));
    }
    let _ = writeln!(
        s,
        "Analysed by crossaudit {}{}.",
        p.crossaudit,
        a.header.standing.line().map(|s| format!("; {s}")).unwrap_or_default()
    );
    let _ = writeln!(s);
    if !a.figures.is_empty() {
        let _ = writeln!(s, "## Figures\n");
        for f in &a.figures {
            let _ = writeln!(s, "![{f}]({f})\n");
        }
    }
}
