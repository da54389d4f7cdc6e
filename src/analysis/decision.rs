//! The decision rule as data, evaluated on an estimate: which conditions
//! hold and with what observed values.

use super::types::{ConditionOutcome, Decision, UnitResult};
use crate::design::{DecisionRule, Quantity};
use crate::stats::CrossedEstimate;

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
    Decision {
        name: rule.name.clone(),
        rule: rule.clone(),
        unit: format!("{} {} at {} s", primary.model, primary.metric.name(), primary.horizon_s),
        value_unit: primary.metric.unit().to_string(),
        optimism_unit: "%".to_string(),
        holds: conditions.iter().all(|c| c.holds),
        conditions,
    }
}
