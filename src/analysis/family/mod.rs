//! Studies of several crossed contrasts: a dose-response contrast (one
//! treated arm per dose, against one shared reference arm) and a
//! multi-split study (the whole split redrawn per split value), alone or
//! together.
//!
//! For each split and dose, the contrast is analysed exactly as a
//! single-split, single-dose study ([`super::analyze`] on that split's cells
//! of that dose's arm and the reference arm). On top of that:
//! - the trend over doses: per cell (recording x seed), the least-squares
//!   slope of d = treated - reference over the doses, the reference itself
//!   included as dose 0 (d = 0); its crossed estimate is the slope of the
//!   mean difference per percentage point of dose, with the crossed
//!   interval of the design's estimator. The slope in optimism is
//!   -100 slope / mean(reference), percentage points of optimism per
//!   percentage point of dose;
//! - in a distance-dose family (one share at several distances from the
//!   evaluated segments) the dose is the distance in s and the reference
//!   arm, which holds no contaminating window, is off the axis: the slope
//!   is that of d over the distances alone (the reference cancels), per
//!   second of distance;
//! - the smallest dose whose interval excludes zero (descriptive), and the
//!   lowest dose reached by step-down testing from the largest dose, which
//!   controls the family-wise error over the doses (over distances: the
//!   farthest distance whose interval excludes zero, and the farthest
//!   reached by step-down testing from the nearest);
//! - over several splits, a pooled estimate of each dose's difference and
//!   of the slope: REML fit of value = mu + a_split + b_recording + c_seed + e
//!   (recordings recur across splits and seeds are shared, so all three are
//!   crossed random intercepts; lme4's `(1|split) + (1|recording) +
//!   (1|seed)`), with the interval mu +- t(df) SE, df Satterthwaite's
//!   (Kenward-Roger's SE and df when the design's estimator uses them).

mod guards;
mod pool;
mod trend;
mod types;

pub use guards::guards;
pub(crate) use guards::{dose_label, dose_name, dose_value};
use trend::trend;
use types::Values;
pub use types::{DoseResult, DoseSource, FamilyAnalysis, Pooled, PooledEstimate, SecondaryDose, SplitResult, Trend};

use std::collections::{BTreeMap, BTreeSet};

use super::types::{Analysis, ConditionOutcome, Decision};
use super::unit::value_of;
use super::{analyze, AnalysisError, AnalyzeOptions};
use crate::cells::Cell;
use crate::design::DoseAxis;
use crate::design::{ArmKind, DecisionRule, DecisionTarget, Quantity};
use crate::plan::{dose_axis, DoseArm, Plan};

/// The doses a plan contrasts: its dose arms, or the treated arm alone.
pub fn contrast_doses(plan: &Plan) -> Vec<DoseArm> {
    if !plan.doses.is_empty() {
        return plan.doses.clone();
    }
    let percent = plan
        .arms
        .iter()
        .find(|a| a.name == plan.contrast.treated)
        .and_then(|a| match &a.kind {
            ArmKind::Derived { percent, .. } => Some(*percent),
            ArmKind::Fit { .. } => None,
        })
        .unwrap_or(f64::NAN);
    vec![DoseArm { arm: plan.contrast.treated.clone(), percent, distance_s: None }]
}

fn fail(message: String) -> AnalysisError {
    AnalysisError::Family { message }
}

/// Checks the split and dose columns against the plan.
fn check_columns(plan: &Plan, cells: &[Cell]) -> Result<(), AnalysisError> {
    let splits: BTreeSet<u64> = plan.splits.iter().copied().collect();
    for c in cells {
        if !plan.arms.iter().any(|a| a.name == c.arm) {
            let known: Vec<&str> = plan.arms.iter().map(|a| a.name.as_str()).collect();
            return Err(fail(format!(
                "{}, field `arm`: {:?} is not in the design ({})",
                c.origin,
                c.arm,
                known.join(", ")
            )));
        }
        match (c.split, plan.splits.is_empty()) {
            (Some(s), false) if !splits.contains(&s) => {
                return Err(fail(format!(
                    "{}, field `split`: {s} is not a split of the design ({})",
                    c.origin,
                    plan.splits.iter().map(|s| s.to_string()).collect::<Vec<_>>().join(", ")
                )))
            }
            (None, false) => {
                return Err(fail(format!(
                    "{}: the design has a split factor, so every row needs a `split` value; this file has no `split` column",
                    c.origin
                )))
            }
            (Some(_), true) => {
                return Err(fail(format!(
                    "{}: the file has a `split` column, but the design has no split factor",
                    c.origin
                )))
            }
            _ => {}
        }
        if c.dose.is_some() && plan.doses.is_empty() {
            return Err(fail(format!(
                "{}: the file has a `dose` column, but the design has no dose-response contrast",
                c.origin
            )));
        }
        if let Some(dose) = c.dose {
            let expected = if c.arm == plan.contrast.reference {
                Some(0.0)
            } else {
                plan.doses.iter().find(|d| d.arm == c.arm).map(|d| d.percent)
            };
            if dose_axis(&plan.doses) == DoseAxis::Distance {
                return Err(fail(format!(
                    "{}, field `dose`: a distance-dose study's cells carry no `dose` column (each arm names its distance)",
                    c.origin
                )));
            }
            if let Some(e) = expected {
                if e != dose {
                    return Err(fail(format!(
                        "{}, field `dose`: {dose} disagrees with arm `{}`, which the design gives dose {e}",
                        c.origin, c.arm
                    )));
                }
            }
        }
    }
    Ok(())
}

/// Analyses a dose-response or multi-split study's per-cell data.
pub fn analyze_family(plan: &Plan, cells: &[Cell], options: AnalyzeOptions) -> Result<FamilyAnalysis, AnalysisError> {
    check_columns(plan, cells)?;
    let doses = contrast_doses(plan);
    let split_values: Vec<Option<u64>> =
        if plan.splits.is_empty() { vec![None] } else { plan.splits.iter().copied().map(Some).collect() };
    let mut splits: Vec<SplitResult> = Vec::new();
    let mut values = Vec::new();
    let mut warnings = Vec::new();
    for &split in &split_values {
        let (result, v) = analyze_split(plan, split, cells, &doses, options, &mut warnings)?;
        splits.push(result);
        values.push(v);
    }
    let pooled = if split_values.len() >= 2 { Some(pool::pool(plan, &split_values, &values, &doses)?) } else { None };
    let provenance = splits[0].detail[0].provenance.clone();
    let unit = plan.primary.label();
    let (axis, metric_unit) = (dose_axis(&doses), plan.primary.metric.unit());
    let decision = decide(&plan.decision, (&unit, metric_unit, axis), &splits, pooled.as_ref());
    mark_members(&mut splits, &doses, &decision);
    let secondary = secondary(&splits, &doses);
    Ok(FamilyAnalysis {
        study: plan.study.clone(),
        header: crate::analysis::AnalysisHeader::default(),
        treated: plan.contrast.treated.clone(),
        reference: plan.contrast.reference.clone(),
        level: plan.estimator.level,
        unit,
        metric_unit: metric_unit.to_string(),
        doses,
        dose_axis: axis,
        splits,
        pooled,
        decision,
        warnings,
        figures: Vec::new(),
        sources: Vec::new(),
        treatment: Vec::new(),
        coverage: None,
        provenance,
        guards: Vec::new(),
        secondary,
    })
}

/// Marks each split's and dose's analysis as one contrast of the family:
/// descriptive, the family's rule deciding on `decision`'s target (its
/// report in `split-S/` and/or the dose arm's folder below the family's).
fn mark_members(splits: &mut [SplitResult], doses: &[DoseArm], decision: &Decision) {
    let by_dose = doses.len() >= 2;
    for sp in splits.iter_mut() {
        for (dose, a) in doses.iter().zip(sp.detail.iter_mut()) {
            let contrast = match (sp.split, by_dose) {
                (Some(s), true) => format!("split {s}, dose `{}`", dose.arm),
                (Some(s), false) => format!("split {s}"),
                (None, _) => format!("dose `{}`", dose.arm),
            };
            let depth = usize::from(sp.split.is_some()) + usize::from(by_dose);
            a.decision.member_of = Some(super::MemberOf {
                contrast,
                decides_on: decision.unit.clone(),
                verdict: super::words::verdict_word(&decision.name, decision.holds),
                report: format!("{}report.md", "../".repeat(depth)),
            });
            a.guards = super::guards::guards(a);
        }
    }
}

/// Each declared secondary endpoint's contrast, per split and dose, from
/// the dose analyses (every unit but the primary one, in design order).
fn secondary(splits: &[SplitResult], doses: &[DoseArm]) -> Vec<SecondaryDose> {
    let mut out = Vec::new();
    for sp in splits {
        for (a, dose) in sp.detail.iter().zip(doses) {
            for u in a.units.iter().filter(|u| u.role == crate::design::Role::Secondary) {
                out.push(SecondaryDose {
                    split: sp.split,
                    arm: dose.arm.clone(),
                    percent: dose.percent,
                    distance_s: dose.distance_s,
                    model: u.model.clone(),
                    metric: u.metric,
                    horizon_s: u.horizon_s,
                    mean_treated: u.mean_treated,
                    mean_reference: u.mean_reference,
                    optimism_pct: u.optimism_pct,
                    estimate: u.estimate,
                });
            }
        }
    }
    out
}

/// One split's contrasts (each dose against the reference, analysed as a
/// single-dose study), its trend, and the values the pooled fit needs; the
/// dose analyses' warnings join `warnings`, labelled.
fn analyze_split(
    plan: &Plan,
    split: Option<u64>,
    cells: &[Cell],
    doses: &[DoseArm],
    options: AnalyzeOptions,
    warnings: &mut Vec<String>,
) -> Result<(SplitResult, Values), AnalysisError> {
    let mine: Vec<Cell> = cells.iter().filter(|c| c.split == split).cloned().collect();
    let mut detail = Vec::new();
    let mut results = Vec::new();
    for dose in doses {
        let (dose_plan, subset) = member(plan, split, dose, &mine);
        let a = analyze(&dose_plan, &subset, options).map_err(|e| match split {
            Some(s) => fail(format!("split {s}, arm {}: {e}", dose.arm)),
            None if !plan.doses.is_empty() => fail(format!("arm {}: {e}", dose.arm)),
            None => e,
        })?;
        let u = &a.units[0];
        for w in &a.warnings {
            let at = match split {
                Some(s) => format!("split {s}, arm {}", dose.arm),
                None => format!("arm {}", dose.arm),
            };
            warnings.push(format!("{at}: {w}"));
        }
        results.push(DoseResult {
            arm: dose.arm.clone(),
            percent: dose.percent,
            distance_s: dose.distance_s,
            mean_treated: u.mean_treated,
            mean_reference: u.mean_reference,
            optimism_pct: u.optimism_pct,
            estimate: u.estimate,
        });
        detail.push(a);
    }
    let v = split_values_of(plan, &mine, doses, &detail[0])?;
    let trend = if doses.len() >= 2 { Some(trend(plan, &v, doses, &results)?) } else { None };
    Ok((SplitResult { split, doses: results, trend, detail }, v))
}

/// One contrast of the family: the plan of `split` (None: the only one)
/// and `dose` as a single-contrast study, and its cells among `cells`
/// (those of the dose's arm and the reference arm, of that split), their
/// split and dose columns cleared.
pub(crate) fn member(plan: &Plan, split: Option<u64>, dose: &DoseArm, cells: &[Cell]) -> (Plan, Vec<Cell>) {
    let sub_plan = match split {
        Some(s) => plan.for_split(s),
        None => plan.clone(),
    };
    let dose_plan = if plan.doses.is_empty() { sub_plan } else { sub_plan.for_dose(dose) };
    let arms = [dose.arm.as_str(), plan.contrast.reference.as_str()];
    let subset = cells
        .iter()
        .filter(|c| c.split == split && arms.contains(&c.arm.as_str()))
        .map(|c| Cell { split: None, dose: None, ..c.clone() })
        .collect();
    (dose_plan, subset)
}

/// The primary metric's differences of one split, per dose, in the row and
/// column order of that split's analysis.
fn split_values_of(plan: &Plan, cells: &[Cell], doses: &[DoseArm], a: &Analysis) -> Result<Values, AnalysisError> {
    let u = &plan.primary;
    let mut by: BTreeMap<(&str, &str, u64), f64> = BTreeMap::new();
    let model = crate::label::Label::from(&u.model);
    for c in cells {
        if c.model == model && (c.horizon_s - u.horizon_s).abs() <= 1e-9 * u.horizon_s.max(1.0) {
            if let Some(x) = value_of(c, u.metric) {
                by.insert((c.arm.as_str(), c.recording.as_str(), c.seed), x);
            }
        }
    }
    let recordings: Vec<String> = a.recordings.iter().map(|r| r.recording.clone()).collect();
    let seeds = a.seeds.clone();
    let reference = &plan.contrast.reference;
    let mut ref_sum = 0.0;
    let mut ref_n = 0usize;
    let mut d = Vec::new();
    for dose in doses {
        let mut v = Vec::with_capacity(recordings.len() * seeds.len());
        for r in &recordings {
            for &s in &seeds {
                let t = by.get(&(dose.arm.as_str(), r.as_str(), s));
                let b = by.get(&(reference.as_str(), r.as_str(), s));
                v.push(match (t, b) {
                    (Some(t), Some(b)) => Some(t - b),
                    _ => None,
                });
            }
        }
        d.push(v);
    }
    for r in &recordings {
        for &s in &seeds {
            if let Some(b) = by.get(&(reference.as_str(), r.as_str(), s)) {
                ref_sum += b;
                ref_n += 1;
            }
        }
    }
    Ok(Values { recordings, seeds, d, mean_reference: ref_sum / ref_n.max(1) as f64 })
}

/// The estimate a family's rule reads, the one row of estimates.csv it
/// decides.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RuleReads {
    /// The first split's first dose (a single split and dose).
    Dose,
    /// The first split's slope over the doses (`on slope`, one split).
    Trend,
    /// The first dose pooled over the splits.
    PooledDose,
    /// The slope pooled over the splits (`on slope`).
    PooledTrend,
}

impl RuleReads {
    fn of(rule: &DecisionRule, pooled: bool) -> Self {
        match (rule.on == DecisionTarget::Slope, pooled) {
            (true, true) => RuleReads::PooledTrend,
            (true, false) => RuleReads::Trend,
            (false, true) => RuleReads::PooledDose,
            (false, false) => RuleReads::Dose,
        }
    }
}

/// The rule on its target: the primary (single split and dose), the pooled
/// estimate (several splits, one dose) or the slope (pooled when there are
/// several splits).
/// `unit` is the primary unit's label and its metric's unit.
fn decide(
    rule: &DecisionRule,
    unit: (&str, &str, DoseAxis),
    splits: &[SplitResult],
    pooled: Option<&Pooled>,
) -> Decision {
    let (unit, metric_unit, axis) = unit;
    let slope = rule.on == DecisionTarget::Slope;
    let observed = observed(rule, (unit, axis), splits, pooled);
    let conditions: Vec<ConditionOutcome> = rule
        .conditions
        .iter()
        .map(|c| {
            let value = match c.quantity {
                Quantity::Optimism => observed.1,
                Quantity::Mean => observed.2,
                Quantity::Lower => observed.3,
                Quantity::Upper => observed.4,
            };
            ConditionOutcome { condition: *c, quantity: c.quantity, value, holds: c.holds(value) }
        })
        .collect();
    let holds = conditions.iter().all(|c| c.holds);
    Decision {
        name: rule.name.clone(),
        rule: rule.clone(),
        unit: observed.0,
        value_unit: match (slope, axis) {
            (false, _) => metric_unit.to_string(),
            (true, DoseAxis::Percent) => format!("{metric_unit}/pp"),
            (true, DoseAxis::Distance) => format!("{metric_unit} per s of distance"),
        },
        optimism_unit: match (slope, axis) {
            (false, _) => "%",
            (true, DoseAxis::Percent) => "%/pp",
            (true, DoseAxis::Distance) => "% per s of distance",
        }
        .to_string(),
        holds,
        conditions,
        // A family's optimism bounds hold the reference mean fixed; its
        // margins are read on the interval of the mean (or slope) only.
        margins: super::decision::margins(rule, None, (observed.3, observed.4)),
        unguarded: super::decision::unguarded(rule, holds, (observed.3, observed.4)),
        member_of: None,
    }
}

/// What the rule reads, labelled: (label, optimism, mean, lower, upper) of
/// the slope (pooled over splits when there are several), the pooled dose,
/// or the single split's primary. `unit` is the primary unit's label and
/// the dose axis.
fn observed(
    rule: &DecisionRule,
    unit: (&str, DoseAxis),
    splits: &[SplitResult],
    pooled: Option<&Pooled>,
) -> (String, f64, f64, f64, f64) {
    let (unit, axis) = unit;
    let over = match axis {
        DoseAxis::Percent => "slope over doses",
        DoseAxis::Distance => "slope over distance",
    };
    match (RuleReads::of(rule, pooled.is_some()), pooled) {
        (RuleReads::PooledTrend, Some(p)) => {
            let s = p.slope.as_ref();
            let s = s.map(|s| (s.optimism_pct, s.mean, s.lower, s.upper)).unwrap_or((
                f64::NAN,
                f64::NAN,
                f64::NAN,
                f64::NAN,
            ));
            (format!("{over}, pooled over {} splits: {unit}", splits.len()), s.0, s.1, s.2, s.3)
        }
        (RuleReads::Trend, _) => {
            let t = splits[0].trend.as_ref();
            let t = t.map(|t| (t.optimism_slope, t.slope.mean, t.slope.lower, t.slope.upper)).unwrap_or((
                f64::NAN,
                f64::NAN,
                f64::NAN,
                f64::NAN,
            ));
            (format!("{over}: {unit}"), t.0, t.1, t.2, t.3)
        }
        (RuleReads::PooledDose, Some(p)) => {
            let e = &p.doses[0];
            (format!("pooled over {} splits: {unit}", splits.len()), e.optimism_pct, e.mean, e.lower, e.upper)
        }
        _ => {
            let d = &splits[0].doses[0];
            (unit.to_string(), d.optimism_pct, d.estimate.mean, d.estimate.lower, d.estimate.upper)
        }
    }
}

impl FamilyAnalysis {
    /// The estimate the rule reads.
    pub fn rule_reads(&self) -> RuleReads {
        RuleReads::of(&self.decision.rule, self.pooled.is_some())
    }
}
