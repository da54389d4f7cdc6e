//! Early stopping held fixed: the primary contrast of the same network
//! trained to the full budget of epochs in both arms (`restore final`),
//! stated beside the verdict.
//!
//! The primary contrast compares two arms each restored at its own best
//! validation epoch; where one arm stops early more often, part of d is the
//! early-stopping decision, not the fit data. A model that differs from
//! the primary model only in `restore final` trains every seed of both
//! arms for the same `epochs` and rolls out the last epoch's weights, so
//! its contrast does not depend on either arm's stopping decision.

pub use super::types::FixedBudget;
use super::types::UnitResult;
use crate::design::ModelKind;
use crate::plan::Plan;

/// The model that differs from `plan`'s primary model only in `restore
/// final`, with its unit at the primary metric and horizon, when the design
/// declares one.
pub(crate) fn fixed_budget(plan: &Plan, units: &[UnitResult]) -> Option<FixedBudget> {
    let primary = plan.models.iter().find(|m| m.name == plan.primary.model)?;
    let ModelKind::Mlp { widths, inputs, actions, restore_final: false } = &primary.kind else { return None };
    let twin = plan.models.iter().find(|m| {
        matches!(&m.kind, ModelKind::Mlp { widths: w, inputs: i, actions: a, restore_final: true }
            if w == widths && i == inputs && a == actions)
    })?;
    let u = units.iter().find(|u| {
        u.model == twin.name && u.metric == plan.primary.metric && (u.horizon_s - plan.primary.horizon_s).abs() < 1e-9
    })?;
    Some(FixedBudget {
        model: twin.name.clone(),
        epochs: plan.training.as_ref()?.epochs,
        optimism_pct: u.optimism_pct,
        optimism_interval: u.optimism_interval,
        estimate: u.estimate,
        rule_holds: u.rule_holds,
    })
}
