//! The decision rule as data, evaluated on an estimate: which conditions
//! hold and with what observed values.

use super::types::{ConditionOutcome, Decision, Margin, UnitResult};
use crate::design::{DecisionRule, DecisionTarget, Quantity};
use crossaudit_stats::{CrossedEstimate, FiellerSet};

/// The observed value of a quantity a rule may name.
pub(crate) fn quantity(q: Quantity, optimism_pct: f64, e: &CrossedEstimate) -> f64 {
    match q {
        Quantity::Optimism => optimism_pct,
        Quantity::Mean => e.mean,
        Quantity::Lower => e.lower,
        Quantity::Upper => e.upper,
    }
}

/// Whether every condition of `rule` holds for this estimate; never for a
/// rule on the divergence GLMM, which reads no crossed estimate.
pub(crate) fn rule_holds(rule: &DecisionRule, optimism_pct: f64, e: &CrossedEstimate) -> bool {
    rule.on != DecisionTarget::Divergence
        && rule.conditions.iter().all(|c| c.holds(quantity(c.quantity, optimism_pct, e)))
}

/// The study's decision: the rule on the primary unit (the plan's first),
/// or `on divergence` on the one unit with a binomial GLMM.
pub(crate) fn study_decision(
    rule: &DecisionRule,
    units: &[UnitResult],
    contrast: &crate::design::Contrast,
) -> Result<Decision, super::AnalysisError> {
    let arms = (contrast.treated.as_str(), contrast.reference.as_str());
    if rule.on != DecisionTarget::Divergence {
        return Ok(decide(rule, &units[0]));
    }
    let unit = units.iter().find(|u| u.glmm.is_some()).unwrap_or(&units[0]);
    decide_divergence(rule, unit, arms).map_err(|detail| super::AnalysisError::Degenerate {
        unit: format!("{} divergence_rate at {} s (binomial GLMM)", unit.model, unit.horizon_s),
        detail: format!("the rule `on divergence` cannot be evaluated: {detail}"),
    })
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
        member_of: None,
    }
}

/// The rule `on divergence` applied to the binomial GLMM of `unit`: `mean`,
/// `lower` and `upper` are its log odds ratio of a diverged rollout,
/// treated over reference, and that ratio's Wald interval. `Err` with the
/// reason where the GLMM has no estimate (then the rule cannot be
/// evaluated, and saying it does not hold would be a verdict the data did
/// not give).
pub(crate) fn decide_divergence(
    rule: &DecisionRule,
    unit: &UnitResult,
    (treated, reference): (&str, &str),
) -> Result<Decision, String> {
    let glmm = unit.glmm.as_ref().ok_or("the unit has no binomial GLMM")?;
    let Some(g) = &glmm.estimate else {
        return Err(glmm.not_estimable.clone().unwrap_or_else(|| "the GLMM has no estimate".into()));
    };
    if !g.certified {
        return Err("the GLMM's optimizer could not certify its optimum, so its interval is not reported".into());
    }
    let value = |q: Quantity| match q {
        Quantity::Mean => g.log_odds_ratio,
        Quantity::Lower => g.lower,
        Quantity::Upper => g.upper,
        Quantity::Optimism => f64::NAN,
    };
    let conditions: Vec<ConditionOutcome> = rule
        .conditions
        .iter()
        .map(|c| ConditionOutcome {
            condition: *c,
            quantity: c.quantity,
            value: value(c.quantity),
            holds: c.holds(value(c.quantity)),
        })
        .collect();
    let holds = conditions.iter().all(|c| c.holds);
    Ok(Decision {
        name: rule.name.clone(),
        rule: rule.clone(),
        unit: format!(
            "{} divergence at {} s (binomial GLMM: log odds ratio of a diverged rollout, {treated} over {reference}, within recording and seed)",
            unit.model, unit.horizon_s
        ),
        value_unit: "log OR".to_string(),
        optimism_unit: "%".to_string(),
        holds,
        conditions,
        margins: margins(rule, None, (g.lower, g.upper)),
        unguarded: unguarded(rule, holds, (g.lower, g.upper)),
        member_of: None,
    })
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
