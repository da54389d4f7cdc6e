//! Number formatting shared by every table and summary line.

use crate::analysis::Decision;

/// Fixed-point formatting used in every table; NaN prints as "NA".
///
/// ```
/// use crossaudit::report::f;
/// assert_eq!(f(0.12345, 4), "0.1235");
/// assert_eq!(f(-0.00001, 4), "0.0000");
/// assert_eq!(f(f64::NAN, 2), "NA");
/// ```
pub fn f(v: f64, decimals: usize) -> String {
    if v.is_nan() {
        "NA".to_string()
    } else if v.is_infinite() {
        if v > 0.0 { "inf" } else { "-inf" }.to_string()
    } else {
        let s = format!("{v:.decimals$}");
        // "-0.0000" reads as a sign error; print zero plainly.
        if s.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
            s.trim_start_matches('-').to_string()
        } else {
            s
        }
    }
}

/// One line: the decision and, when it fails, which part failed.
pub fn decision_summary(d: &Decision) -> String {
    let parts: Vec<String> = d
        .conditions
        .iter()
        .map(|c| {
            format!(
                "{} ({} = {}: {})",
                c.condition,
                c.quantity.name(),
                f(c.value, 4),
                if c.holds { "met" } else { "NOT met" }
            )
        })
        .collect();
    let verdict = if d.holds { d.name.to_uppercase() } else { format!("NOT {}", d.name.to_uppercase()) };
    format!("decision: {verdict} on {}: {}", d.unit, parts.join("; "))
}

/// Confidence level as a percentage label: 0.95 -> "95%".
pub fn level_pct(level: f64) -> String {
    format!("{}%", f(level * 100.0, 0))
}
