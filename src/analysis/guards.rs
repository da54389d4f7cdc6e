//! The guards of a verdict: what its contrast may have measured besides
//! what it is named after (DESIGN.md, "What a verdict must guard"),
//! computed by the analysis from its own results and evidence and worded
//! once. Every view reads them from the analysis: report.md and the HTML
//! banner, the console line, results.json, estimates.csv and Python.

use std::fmt::Write as _;

use super::words::{decision_notes, f, fieller_text, level_pct, unit_label};
use super::{Analysis, Guard, GuardKind};
use crate::io::{md_line, md_text};

/// The guards of `a`'s verdict in the order the report gives them beside
/// it: the decision's notes (a threshold inside the interval, a rule that
/// reads no interval), a fragile decision, early stopping and its
/// held-fixed contrast, a reference arm that is not disjoint, a validation
/// set that holds copies of evaluation flights, condition coverage, a
/// divergence rule's events held by few recordings.
pub fn guards(a: &Analysis) -> Vec<Guard> {
    let mut out: Vec<Guard> = decision_notes(&a.decision, &level_pct(a.level))
        .into_iter()
        .map(|n| {
            let kind =
                if n.starts_with("**The rule reads no interval**") { GuardKind::NoInterval } else { GuardKind::Margin };
            Guard::new(kind, n)
        })
        .collect();
    let decides = a.decision.member_of.is_none();
    for w in a.warnings.iter().filter(|w| decides && w.starts_with("fragile decision")) {
        out.push(Guard::new(GuardKind::Fragile, format!("**Warning**: {}.", md_line(w))));
    }
    // Models restored early, and the contrast with early stopping held fixed.
    for w in a.warnings.iter().filter(|w| w.starts_with("early best epochs")) {
        out.push(Guard::new(GuardKind::EarlyStopping, format!("**Early stopping**: {}.", md_line(w))));
    }
    if let Some(b) = &a.fixed_budget {
        let contrast = contrast_text(a, &b.estimate, (b.optimism_pct, b.optimism_interval), b.rule_holds);
        out.push(Guard::new(
            GuardKind::FixedBudget,
            format!(
                "**Early stopping held fixed**: the same network trained for the full {} epochs in both arms, its last weights rolled out (model `{}`): {contrast} (its row in Endpoints).",
                b.epochs, b.model
            ),
        ));
    }
    // A reference arm that is not disjoint (copies of evaluation flights in
    // its fit set, allowed by `duplicates keep`).
    for w in a.warnings.iter().filter(|w| w.starts_with("invariant 5 ")) {
        out.push(Guard::new(GuardKind::NotDisjoint, format!("**The reference arm is not disjoint**: {}.", md_line(w))));
    }
    // A validation set that holds copies of evaluation flights: every
    // arm's early stopping is then steered by those flights themselves.
    for w in a.warnings.iter().filter(|w| w.starts_with("invariant 3 ")) {
        out.push(Guard::new(
            GuardKind::ValidationCopies,
            format!(
                "**Validation holds copies of evaluation flights**: {}. Early stopping (the epoch each model is restored to) is then steered by the evaluation flights themselves, through their copies.",
                md_line(w)
            ),
        ));
    }
    out.extend(coverage(a).map(|t| Guard::new(GuardKind::Coverage, t)));
    out.extend(coverage_unknown(&a.warnings));
    out.extend(concentrated(a).map(|t| Guard::new(GuardKind::Concentrated, t)));
    out
}

/// How the warning begins that the evidence gives where the run's folders
/// record no condition coverage (the guard below finds it by it).
pub(crate) const COVERAGE_UNKNOWN: &str = "condition coverage unknown: ";

/// The coverage guard where the run's folders record no coverage: that
/// warning, beside the verdict.
pub(crate) fn coverage_unknown(warnings: &[String]) -> Option<Guard> {
    let w = warnings.iter().find_map(|w| w.strip_prefix(COVERAGE_UNKNOWN))?;
    Some(Guard::new(GuardKind::Coverage, format!("**Condition coverage unknown**: {}.", md_line(w))))
}

/// A rule decided on the divergence GLMM whose diverged starts few
/// recordings hold: its odds ratio is theirs more than the study's.
fn concentrated(a: &Analysis) -> Option<String> {
    if a.decision.rule.on != crate::design::DecisionTarget::Divergence {
        return None;
    }
    // The unit the rule reads: the one with a binomial GLMM.
    let g = a.units.iter().find_map(|u| u.glmm.as_ref())?;
    if g.concentrated.is_empty() {
        return None;
    }
    let total = g.diverged_treated + g.diverged_reference;
    let held: u64 = g.concentrated.iter().map(|(_, n)| n).sum();
    let names: Vec<String> = g.concentrated.iter().map(|(r, n)| format!("{} ({n})", md_text(r))).collect();
    Some(format!(
        "**The diverged rollouts come from few recordings**: {held} of the {total} diverged starts ({}%) are on {} of the {} evaluation recordings: {}. The odds ratio the rule reads is decided by them, not spread over the study.",
        f(100.0 * held as f64 / total.max(1) as f64, 1),
        g.concentrated.len(),
        a.recordings.len(),
        names.join(", ")
    ))
}

/// The coverage guard: what the contrast measured, given the reference
/// arm's coverage of the evaluated conditions.
fn coverage(a: &Analysis) -> Option<String> {
    let c = a.coverage.as_ref()?;
    let n = a.recordings.len();
    if !c.mixes_novelty() {
        return Some(format!(
            "Condition coverage: the reference arm (`{}`) fits on other recordings of the {} of every evaluation recording{}, so the contrast is not a contrast with unseen conditions.",
            c.arm,
            c.condition,
            in_draws(c.draws)
        ));
    }
    let names: Vec<String> = c
        .uncovered
        .iter()
        .map(|u| {
            let draws = if c.draws > 1 { format!(", {} of {} draws", u.draws, c.draws) } else { String::new() };
            format!("{} ({}{draws})", md_text(&u.recording), md_text(&u.condition))
        })
        .collect();
    let mut s = format!(
        "**The contrast mixes condition novelty with recording leakage**: the reference arm (`{}`) fits on no other recording of the {} of {} of {n} evaluation recordings{}: {}. They carry {}% of the summed d; on them the contaminated arm saw the condition and the reference arm never did.",
        c.arm,
        c.condition,
        c.uncovered.len(),
        if c.draws > 1 { format!(" in at least one of the {} draws (each seed's own)", c.draws) } else { String::new() },
        names.join(", "),
        f(100.0 * c.share_of_d, 1),
    );
    match (&c.covered_only, &c.covered_only_error) {
        (Some(k), _) => {
            let contrast = contrast_text(a, &k.estimate, (k.optimism_pct, k.optimism_interval), k.rule_holds);
            let _ = write!(
                s,
                " Over the {} covered recordings alone: {contrast} (table: Condition coverage).",
                k.recordings
            );
        }
        (None, Some(err)) => {
            let _ =
                write!(s, " The contrast over the covered recordings alone could not be estimated: {}.", md_text(err));
        }
        (None, None) => {}
    }
    Some(s)
}

/// A sensitivity contrast as a guard states it: `d = X unit [lo, hi],
/// optimism Y% [Fieller's]; the rule would hold|fail there`.
fn contrast_text(
    a: &Analysis,
    e: &crossaudit_stats::CrossedEstimate,
    (optimism, interval): (f64, Option<crossaudit_stats::RatioInterval>),
    holds: bool,
) -> String {
    format!(
        "d = {} {} [{}, {}], optimism {}%{}; the rule would {} there",
        f(e.mean, 4),
        unit_label(&a.decision.value_unit),
        f(e.lower, 4),
        f(e.upper, 4),
        f(optimism, 1),
        fieller_text(interval, "%").map(|t| format!(" {t}")).unwrap_or_default(),
        if holds { "hold" } else { "fail" }
    )
}

fn in_draws(draws: usize) -> String {
    if draws > 1 {
        format!(" (in every one of the {draws} draws, each seed's own)")
    } else {
        String::new()
    }
}
