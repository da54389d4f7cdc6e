//! The decision rule as data, evaluated on an estimate: which conditions
//! hold and with what observed values.

use super::types::{ConditionOutcome, Decision, Margin, UnitResult};
use crate::design::{DecisionRule, Quantity};
use crate::stats::{CrossedEstimate, FiellerSet};

/// The observed value of a quantity a rule may name.
pub(crate) fn quantity(q: Quantity, optimism_pct: f64, e: &CrossedEstimate) -> f64 {
    match q {
        Quantity::Optimism => optimism_pct,
        Quantity::Mean => e.mean,
        Quantity::Lower => e.lower,
        Quantity::Upper => e.upper,
    }
}

/// Whether every condition of `rule` holds for this estimate.
pub(crate) fn rule_holds(rule: &DecisionRule, optimism_pct: f64, e: &CrossedEstimate) -> bool {
    rule.conditions.iter().all(|c| c.holds(quantity(c.quantity, optimism_pct, e)))
}

/// The rule applied to the primary unit, condition by condition.
pub(crate) fn decide(rule: &DecisionRule, primary: &UnitResult) -> Decision {
    let conditions: Vec<ConditionOutcome> = rule
        .conditions
        .iter()
        .map(|c| {
            let value = quantity(c.quantity, primary.optimism_pct, &primary.estimate);
            ConditionOutcome { condition: *c, quantity: c.quantity, value, holds: c.holds(value) }
        })
        .collect();
    let optimism = primary.optimism_interval.map(|iv| iv.fieller);
    let holds = conditions.iter().all(|c| c.holds);
    let e = &primary.estimate;
    Decision {
        name: rule.name.clone(),
        rule: rule.clone(),
        unit: format!("{} {} at {} s", primary.model, primary.metric.name(), primary.horizon_s),
        value_unit: primary.metric.unit().to_string(),
        optimism_unit: "%".to_string(),
        holds,
        conditions,
        margins: margins(rule, optimism, (e.lower, e.upper)),
        unguarded: unguarded(rule, holds, (e.lower, e.upper)),
    }
}

/// The conditions whose threshold lies inside the interval of the quantity
/// they read: an `optimism` threshold inside the optimism's interval
/// (`optimism`: Fieller's set, `None` when the analysis has none), a `mean`
/// threshold inside the interval of d (`mean_interval`). Conditions on a
/// bound (`lower`, `upper`) already read an interval.
pub(crate) fn margins(rule: &DecisionRule, optimism: Option<FiellerSet>, mean_interval: (f64, f64)) -> Vec<Margin> {
    rule.conditions
        .iter()
        .filter_map(|c| match c.quantity {
            Quantity::Optimism => {
                let set = optimism?;
                set.contains(c.value).then(|| {
                    let b = set.bounds();
                    Margin { condition: *c, lower: b.map(|b| b.0), upper: b.map(|b| b.1), interval: "fieller" }
                })
            }
            Quantity::Mean => {
                let (lo, hi) = mean_interval;
                (lo <= c.value && c.value <= hi).then_some(Margin {
                    condition: *c,
                    lower: Some(lo),
                    upper: Some(hi),
                    interval: "crossed",
                })
            }
            Quantity::Lower | Quantity::Upper => None,
        })
        .collect()
}

/// The interval of d when a rule that reads no interval bound holds while
/// that interval contains 0.
pub(crate) fn unguarded(rule: &DecisionRule, holds: bool, interval: (f64, f64)) -> Option<[f64; 2]> {
    let reads_bound = rule.conditions.iter().any(|c| matches!(c.quantity, Quantity::Lower | Quantity::Upper));
    (holds && !reads_bound && interval.0 <= 0.0 && 0.0 <= interval.1).then_some([interval.0, interval.1])
}
