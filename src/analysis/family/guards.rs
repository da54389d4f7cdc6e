//! The guards beside a dose-response or multi-split family's verdict:
//! what a distance-dose family's contrast measures, doses where the
//! treated arm is worse than the reference, the rule's margin and the
//! reference arm's condition coverage over the splits. Computed with the
//! family's analysis and worded once; its report, banner, console line,
//! results.json and Python read them from [`FamilyAnalysis::guards`].

use super::{DoseResult, FamilyAnalysis};
use crate::analysis::words::{decision_notes, level_pct};
use crate::analysis::{Guard, GuardKind};
use crate::design::DoseAxis;

/// The guards of a family's verdict in the order its report gives them.
pub fn guards(a: &FamilyAnalysis) -> Vec<Guard> {
    let mut out: Vec<Guard> = distance_estimand(a).map(|t| Guard::new(GuardKind::Distance, t)).into_iter().collect();
    out.extend(harm_note(a).map(|t| Guard::new(GuardKind::Harm, t)));
    out.extend(decision_notes(&a.decision, &level_pct(a.level)).into_iter().map(|n| {
        let kind =
            if n.starts_with("**The rule reads no interval**") { GuardKind::NoInterval } else { GuardKind::Margin };
        Guard::new(kind, n)
    }));
    out.extend(a.coverage.iter().map(|c| Guard::new(GuardKind::Coverage, c.sentence())));
    out.extend(crate::analysis::guards::coverage_unknown(&a.warnings));
    out
}

/// A dose as its rows name it: `25%`, `at least 5 s`, or the treated arm
/// where it is not derived from the reference.
pub(crate) fn dose_name(d: &DoseResult) -> String {
    dose_label(d.distance_s, d.percent, &d.arm)
}

/// [`dose_name`] from a dose's parts (a secondary endpoint's row has them too).
pub(crate) fn dose_label(distance_s: Option<f64>, percent: f64, arm: &str) -> String {
    match distance_s {
        Some(g) => format!("at least {g} s"),
        None if percent.is_nan() => arm.to_string(),
        None => format!("{percent}%"),
    }
}

/// A dose value on the axis (`25%`, `5 s`), or `none`.
pub(crate) fn dose_value(axis: DoseAxis, v: Option<f64>) -> String {
    match (v, axis) {
        (None, _) => "none".into(),
        (Some(p), DoseAxis::Percent) => format!("{p}%"),
        (Some(g), DoseAxis::Distance) => format!("{g} s"),
    }
}

/// What a distance-dose family measures, beside its verdict: every arm
/// replaces the same share, so the contrasts differ only in where in the
/// evaluation recordings the contaminating windows lie.
fn distance_estimand(a: &FamilyAnalysis) -> Option<String> {
    if a.dose_axis != DoseAxis::Distance {
        return None;
    }
    let percent = a.doses.first().map(|d| d.percent).unwrap_or(f64::NAN);
    let list: Vec<String> = a.doses.iter().map(|d| dose_value(DoseAxis::Distance, d.distance_s)).collect();
    let sources: Vec<String> = a
        .sources
        .iter()
        .map(|s| {
            let k = if s.fewest == s.most { s.fewest.to_string() } else { format!("{} to {}", s.fewest, s.most) };
            format!("{} from {k} of {}", s.arm, s.of)
        })
        .collect();
    let sources = if sources.is_empty() {
        String::new()
    } else {
        format!(" Evaluation recordings the contaminating windows came from (over the draws): {}. Where a far arm draws from fewer recordings, its contrast also measures which recordings are long enough to give windows that far.", sources.join(", "))
    };
    Some(format!(
        "What this measures: each arm replaces the same {percent}% of the reference arm's fit windows with windows of the evaluation recordings, drawn at least {} from every evaluated segment (a registered start to its horizon). The contrasts differ only in that distance, so the slope is the change in d per second of distance: how the optimism of seeing the same flights falls as the contaminating windows move away from the evaluated rollouts. A slope near zero with optimism at every distance says the leak is the flight itself (vehicle, battery, disturbances), not the evaluated transitions or their neighbours.{sources}",
        list.join(", ")
    ))
}

/// Beside a dose-response verdict: the doses whose treated arm is worse
/// than the reference (an interval above zero; every metric is an error),
/// where replacing fit windows cost more than the contaminating windows
/// gave. A slope over such doses measures that cost as well as the leak.
fn harm_note(a: &FamilyAnalysis) -> Option<String> {
    if a.doses.len() < 2 {
        return None;
    }
    let worse: Vec<String> = a
        .splits
        .iter()
        .flat_map(|sp| sp.doses.iter().filter(|d| d.estimate.lower > 0.0).map(move |d| (sp.split, d)))
        .map(|(split, d)| match split {
            Some(s) => format!("`{}` ({}, split {s})", d.arm, dose_name(d)),
            None => format!("`{}` ({})", d.arm, dose_name(d)),
        })
        .collect();
    if worse.is_empty() {
        return None;
    }
    Some(format!(
        "**Not only the leak**: {} worse than the reference arm (an interval above zero). There the fit windows replaced were worth more to the model than the evaluation-recording windows received, so the trend also measures that cost of replacement, not only how much the leak helps: read the per-dose estimates, not the slope alone.",
        match worse.len() {
            1 => format!("{} is", worse[0]),
            _ => format!("{} are", worse.join(", ")),
        }
    ))
}
