//! Condition coverage beside the verdict: the evaluation recordings whose
//! condition (trajectory, or trajectory x speed) the reference arm never
//! fitted on, their share of the primary difference, and the primary
//! contrast over the covered recordings alone.
//!
//! A contrast between a contaminated arm and a reference arm measures
//! recording leakage only where the reference arm has seen the evaluated
//! condition on other recordings. Where it has not, the contaminated arm's
//! advantage mixes "saw this recording" with "saw this kind of flight at
//! all" (condition novelty). The run measures coverage from the split
//! (`split::FitCoverage`); this module turns it into the report's
//! statement and sensitivity row.

use std::collections::BTreeSet;

pub use super::types::{ConditionCoverage, CoverageNote, CoveredOnly, Uncovered};
use super::{analyze, AnalysisError, AnalyzeOptions};
use crate::cells::Cell;
use crate::design::{Grouped, Sensitivity};
use crate::io::md_text;
use crate::plan::Plan;

impl CoverageNote {
    /// The sentence beside a combined report's verdict (Markdown).
    pub fn sentence(&self) -> String {
        let c = self;
        let levels = if c.levels > 1 { format!(" in at least one of its {} levels", c.levels) } else { String::new() };
        if c.uncovered.is_empty() {
            return format!(
                "Condition coverage: the reference arm (`{}`) fits on other recordings of the {} of every evaluation recording{}.",
                c.arm,
                c.condition,
                if c.levels > 1 { format!(" in all {} levels", c.levels) } else { String::new() }
            );
        }
        let names: Vec<String> = c
            .uncovered
            .iter()
            .map(|u| format!("{} ({}, {} of {})", md_text(&u.recording), md_text(&u.condition), u.draws, c.levels))
            .collect();
        format!(
            "**The contrast mixes condition novelty with recording leakage**: the reference arm (`{}`) fits on no other recording of the {} of {} evaluation recording(s){levels}: {}.",
            c.arm,
            c.condition,
            c.uncovered.len(),
            names.join(", ")
        )
    }
}

impl ConditionCoverage {
    /// Whether some evaluation recording is uncovered.
    pub fn mixes_novelty(&self) -> bool {
        !self.uncovered.is_empty()
    }
}

/// The coverage statement for `plan`'s primary endpoint on `cells`: the
/// uncovered recordings `uncovered` (measured by the run over `draws`
/// draws), their share of d, and the primary contrast re-estimated over
/// the other recordings (the plan's estimator, no resampling sensitivity).
pub fn condition_coverage(
    plan: &Plan,
    cells: &[Cell],
    condition: &str,
    draws: usize,
    uncovered: Vec<Uncovered>,
) -> ConditionCoverage {
    let out: BTreeSet<String> = uncovered.iter().map(|u| u.recording.clone()).collect();
    let (mut all, mut part) = (0.0, 0.0);
    for (rec, _, d) in super::diff::Diff::of(plan, cells).iter() {
        all += d;
        if out.contains(rec.as_str()) {
            part += d;
        }
    }
    let mut coverage = ConditionCoverage {
        condition: condition.to_string(),
        arm: plan.contrast.reference.clone(),
        draws,
        share_of_d: if uncovered.is_empty() { 0.0 } else { part / all },
        uncovered,
        covered_only: None,
        covered_only_error: None,
    };
    if coverage.uncovered.is_empty() {
        return coverage;
    }
    match covered_only(plan, cells, &out) {
        Ok(c) => coverage.covered_only = Some(c),
        Err(e) => coverage.covered_only_error = Some(e.to_string()),
    }
    coverage
}

/// The primary contrast over the recordings outside `out`.
fn covered_only(plan: &Plan, cells: &[Cell], out: &BTreeSet<String>) -> Result<CoveredOnly, AnalysisError> {
    let pu = &plan.primary;
    let kept: Vec<Cell> = cells
        .iter()
        .filter(|c| c.model.as_str() == pu.model && (c.horizon_s - pu.horizon_s).abs() < 1e-9)
        .filter(|c| !out.contains(c.recording.as_str()))
        .cloned()
        .collect();
    let recordings = kept.iter().map(|c| c.recording.as_str()).collect::<BTreeSet<_>>().len();
    let mut p = plan.clone();
    p.recordings = recordings;
    p.recordings_may_be_absent = false;
    p.secondary.clear();
    p.interactions.clear();
    p.sensitivity = Sensitivity { bootstrap: None, grouped: Grouped::Off, leave_one_out: Vec::new() };
    let a = analyze(&p, &kept, AnalyzeOptions::default())?;
    let u = &a.units[0];
    Ok(CoveredOnly {
        recordings,
        optimism_pct: u.optimism_pct,
        optimism_interval: u.optimism_interval,
        estimate: u.estimate,
        rule_holds: u.rule_holds,
    })
}
