//! Number formatting and the wording of decisions, shared by the guards
//! the analysis states and by every table and summary line of the reports
//! (re-exported as `crate::report::format`).

use crate::analysis::{Decision, Standing};

/// Fixed-point formatting used in every table; NaN prints as "NA". A
/// negative number that rounds to zero keeps its sign (a rule such as
/// `upper < 0` turns on it); only zero itself prints unsigned.
///
/// ```
/// use crossaudit::report::f;
/// assert_eq!(f(0.12345, 4), "0.1235");
/// assert_eq!(f(-0.00001, 4), "-0.0000");
/// assert_eq!(f(-0.0, 4), "0.0000");
/// assert_eq!(f(f64::NAN, 2), "NA");
/// ```
pub fn f(v: f64, decimals: usize) -> String {
    if v.is_nan() {
        "NA".to_string()
    } else if v.is_infinite() {
        if v > 0.0 { "inf" } else { "-inf" }.to_string()
    } else {
        // Negative zero prints as zero; any other negative value keeps its sign.
        let v = if v == 0.0 { 0.0 } else { v };
        format!("{v:.decimals$}")
    }
}

/// The observed value a condition reads, with its unit: optimism as a
/// percentage with two decimals, the mean and interval ends in the metric's unit;
/// a slope's, per percentage point of dose, in scientific notation.
fn condition_value(d: &Decision, q: crate::design::Quantity, v: f64) -> String {
    condition_value_against(d, q, v, None)
}

/// [`condition_value`], with as many more digits as it takes for the
/// printed value to lie on `threshold`'s side that `v` lies on (a bound of
/// -0.00001 m against `upper < 0` is `-1.0000e-5 m`, not `0.0000 m`; an
/// optimism of 9.999% against `>= 10%` is `9.999%`, not `10.00%`).
fn condition_value_against(d: &Decision, q: crate::design::Quantity, v: f64, threshold: Option<f64>) -> String {
    let slope = d.optimism_unit != "%";
    let (mut digits, mut sci) = match q {
        crate::design::Quantity::Optimism => (if slope { 3 } else { 2 }, false),
        _ if slope && v.is_finite() => (3, true),
        _ => (4, false),
    };
    let show = |sci: bool, digits: usize| if sci { format!("{v:.digits$e}") } else { f(v, digits) };
    // The printed value's side of the threshold must be v's: more digits
    // (scientific below 0.001 in magnitude) until it is, at most 12.
    if let Some(t) = threshold.filter(|t| v.is_finite() && t.is_finite() && v != *t) {
        let side = |s: &str| s.parse::<f64>().map(|x| (x - t).signum() * f64::from(u8::from(x != t)));
        while digits < 12 && side(&show(sci, digits)) != Ok((v - t).signum()) {
            if !sci && v.abs() < 1e-3 {
                (sci, digits) = (true, 4);
            } else {
                digits += 1;
            }
        }
    }
    let text = show(sci, digits);
    match q {
        crate::design::Quantity::Optimism => format!("{text}{}", d.optimism_unit),
        _ if d.value_unit.is_empty() => text,
        _ => format!("{text} {}", d.value_unit),
    }
}

/// The sentences a report writes beside its verdict about the rule's
/// margin: each condition whose threshold lies inside the interval of the
/// quantity it reads, and a rule that holds without reading any interval
/// while the interval of d contains 0. `level` is the intervals' level
/// (`95%`). Markdown, one paragraph each. None for one contrast of a
/// family, on which the rule decides nothing.
pub fn decision_notes(d: &Decision, level: &str) -> Vec<String> {
    use crate::design::Quantity;
    let mut notes = Vec::new();
    if d.member_of.is_some() {
        return notes;
    }
    for m in &d.margins {
        let q = m.condition.quantity;
        let bound = |v: Option<f64>| v.map(|v| condition_value(d, q, v));
        let threshold = condition_value(d, q, m.condition.value);
        let interval = match (bound(m.lower), bound(m.upper)) {
            (Some(lo), Some(hi)) if q == Quantity::Optimism => {
                format!("the optimism's {level} interval [{lo}, {hi}] (Fieller's, from the crossed estimator)")
            }
            (Some(lo), Some(hi)) => format!("the {level} interval of d, [{lo}, {hi}]"),
            _ => format!(
                "the optimism's {level} Fieller set, which is unbounded (the reference arm's mean is not distinguishable from 0)"
            ),
        };
        notes.push(format!(
            "**The data do not determine the side of the threshold**: the threshold {threshold} of `{}` lies inside {interval}. The verdict is the rule's as the design states it, but an equally valid rerun could fall on either side of it.",
            m.condition
        ));
    }
    if let Some([lo, hi]) = d.unguarded {
        notes.push(format!(
            "**The rule reads no interval**: {} although the {level} interval of d, [{}, {}], contains 0. The rule as written compares point estimates with thresholds, so it holds without the data distinguishing the arms.",
            verdict_word(&d.name, d.holds),
            condition_value(d, Quantity::Mean, lo),
            condition_value(d, Quantity::Mean, hi)
        ));
    }
    notes
}

/// Fieller's bounds of an optimism when the data bound it, one decimal:
/// `[lo{unit}, hi{unit}]`.
pub(crate) fn fieller_text(iv: Option<crossaudit_stats::RatioInterval>, unit: &str) -> Option<String> {
    iv?.fieller.bounds().map(|(lo, hi)| format!("[{}{unit}, {}{unit}]", f(lo, 1), f(hi, 1)))
}

/// The same in a table cell: `unbounded` when the data bound it on neither
/// side, `-` when the analysis has none.
pub(crate) fn fieller_cell(iv: Option<crossaudit_stats::RatioInterval>) -> String {
    match iv {
        None => "-".into(),
        Some(_) => fieller_text(iv, "").unwrap_or_else(|| "unbounded".into()),
    }
}

/// Whether the rule reads an interval bound (`lower`, `upper`).
pub(crate) fn reads_interval(d: &Decision) -> bool {
    use crate::design::Quantity;
    d.conditions.iter().any(|c| matches!(c.quantity, Quantity::Lower | Quantity::Upper))
}

/// One line: the decision and, when it fails, which part failed, each
/// observed value with its unit.
pub fn decision_summary(d: &Decision) -> String {
    let parts: Vec<String> = d
        .conditions
        .iter()
        .map(|c| {
            format!(
                "{} ({} = {}: {})",
                c.condition,
                c.quantity.name(),
                condition_value_against(d, c.quantity, c.value, Some(c.condition.value)),
                if c.holds { "met" } else { "NOT met" }
            )
        })
        .collect();
    if let Some(m) = &d.member_of {
        return format!(
            "descriptive: {} is one contrast of a family; the family's rule `{}` decides on {} ({}; `{}`); read on this contrast alone, its conditions give {}",
            m.contrast,
            d.name,
            m.decides_on,
            m.verdict,
            m.report,
            parts.join("; ")
        );
    }
    let verdict = if d.holds { d.name.to_uppercase() } else { format!("NOT {}", d.name.to_uppercase()) };
    format!("decision: {verdict} on {}: {}", d.unit, parts.join("; "))
}

/// The rule's name in capitals, `NOT` before it when the rule fails:
/// `CONFIRMED`, `NOT GROWS`.
pub(crate) fn verdict_word(name: &str, holds: bool) -> String {
    let name = name.to_uppercase();
    if holds {
        name
    } else {
        format!("NOT {name}")
    }
}

/// A metric's unit as tables and headers name it: `fraction` for a rate
/// (whose [`crate::design::Metric::unit`] is empty, as it prints after a
/// value).
pub fn unit_label(unit: &str) -> &str {
    if unit.is_empty() {
        "fraction"
    } else {
        unit
    }
}

/// A report's title after the study's name, its first line: the verdict
/// (`CONFIRMED`, `NOT CONFIRMED`; `DESCRIPTIVE` and the family's verdict
/// for one contrast of a family) and, when the analysis is not the
/// preregistered one, its standing ([`Standing::short`]).
pub(crate) fn verdict(d: &Decision, standing: &Standing) -> String {
    let verdict = match &d.member_of {
        Some(m) => format!(
            "DESCRIPTIVE ({} of a family; the family's verdict: {}, on {})",
            m.contrast, m.verdict, m.decides_on
        ),
        None => verdict_word(&d.name, d.holds),
    };
    match standing.short() {
        Some(why) => format!("{verdict} ({why})"),
        None => verdict,
    }
}

/// The decision line as the console prints it: [`decision_summary`],
/// prefixed with the standing's tag (`EXPLORATORY`, `NOT PREREGISTERED`,
/// `POST HOC`) when the analysis is not the preregistered one.
pub fn decision_line(a: &crate::analysis::Analysis) -> String {
    labelled(decision_summary(&a.decision), &a.header.standing)
}

/// `line` prefixed with the analysis's standing tag, when it is not the
/// preregistered analysis.
pub(crate) fn labelled(line: String, standing: &Standing) -> String {
    match standing.tag() {
        Some(tag) => format!("{tag} {line}"),
        None => line,
    }
}

/// Confidence level as a percentage label: 0.95 -> "95%".
pub fn level_pct(level: f64) -> String {
    let text = format!("{:.7}", level * 100.0);
    let text = text.trim_end_matches('0').trim_end_matches('.');
    format!("{text}%")
}

/// Degrees of freedom: `z` for the normal.
pub(crate) fn df(v: f64) -> String {
    if v.is_infinite() {
        "z".into()
    } else {
        f(v, 1)
    }
}

/// Variance-scale numbers span many orders of magnitude.
pub(crate) fn sci(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else {
        format!("{v:.3e}")
    }
}

#[cfg(test)]
mod tests {
    use super::decision_summary;
    use crate::analysis::{ConditionOutcome, Decision};
    use crate::design::{Cmp, DecisionCondition, DecisionRule, DecisionTarget, Quantity};

    fn decision(conditions: &[(Quantity, Cmp, f64, f64)]) -> Decision {
        let outcomes: Vec<ConditionOutcome> = conditions
            .iter()
            .map(|&(quantity, cmp, threshold, value)| {
                let condition = DecisionCondition { quantity, cmp, value: threshold };
                ConditionOutcome { holds: condition.holds(value), condition, quantity, value }
            })
            .collect();
        Decision {
            name: "confirmed".into(),
            rule: DecisionRule {
                name: "confirmed".into(),
                on: DecisionTarget::Primary,
                conditions: outcomes.iter().map(|c| c.condition).collect(),
            },
            unit: "world fa_position_rmse at 1 s".into(),
            value_unit: "m".into(),
            optimism_unit: "%".into(),
            holds: outcomes.iter().all(|c| c.holds),
            conditions: outcomes,
            margins: Vec::new(),
            unguarded: None,
            member_of: None,
        }
    }

    /// Every number that decides is printed on its side of the threshold:
    /// a micrometre bound against `upper < 0`, an optimism a thousandth
    /// below 10%, where the default digits printed `0.0000 m`-like values
    /// on the threshold itself.
    #[test]
    fn a_deciding_number_shows_its_side_of_the_threshold() {
        let line = decision_summary(&decision(&[(Quantity::Upper, Cmp::Lt, 0.0, -0.00001)]));
        assert!(line.contains("upper = -1.0000e-5 m: met"), "{line}");
        let line = decision_summary(&decision(&[(Quantity::Optimism, Cmp::Ge, 10.0, 9.999)]));
        assert!(line.contains("optimism = 9.999%: NOT met"), "{line}");
        // Values that already show their side keep the usual digits.
        let line = decision_summary(&decision(&[
            (Quantity::Upper, Cmp::Lt, 0.0, -0.0323),
            (Quantity::Optimism, Cmp::Ge, 10.0, 13.2862),
        ]));
        assert!(line.contains("upper = -0.0323 m: met") && line.contains("optimism = 13.29%: met"), "{line}");
    }
}
