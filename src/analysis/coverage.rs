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
//! (`split::ConditionCoverage`); this module turns it into the report's
//! statement and sensitivity row.

use std::collections::BTreeSet;

use serde::Serialize;

use super::{analyze, AnalysisError, AnalyzeOptions};
use crate::cells::Cell;
use crate::design::{Grouped, Sensitivity};
use crate::plan::Plan;
use crate::stats::{CrossedEstimate, RatioInterval};

/// An evaluation recording whose condition the reference arm fits on no
/// other recording of.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Uncovered {
    /// The recording.
    pub recording: String,
    /// Its condition (`circle`, or `circle / fast`).
    pub condition: String,
    /// In how many of the study's draws it was uncovered (1 in a single
    /// split; up to J under per-seed draws).
    pub draws: usize,
}

/// The reference arm's condition coverage, as the report states it.
#[derive(Debug, Clone, Serialize)]
pub struct ConditionCoverage {
    /// What a condition is: `trajectory` or `trajectory x speed`.
    pub condition: String,
    /// The reference arm.
    pub arm: String,
    /// The draws coverage was measured in (1, or each seed's draw).
    pub draws: usize,
    /// The uncovered evaluation recordings (in any draw), by name.
    pub uncovered: Vec<Uncovered>,
    /// Their share of the primary endpoint's summed difference d over every
    /// cell (of sum d; NaN when sum d is 0).
    pub share_of_d: f64,
    /// The primary contrast over the covered recordings alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub covered_only: Option<CoveredOnly>,
    /// Why the covered-only row could not be estimated.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub covered_only_error: Option<String>,
}

/// The primary contrast over the recordings every draw of the reference
/// arm covers.
#[derive(Debug, Clone, Serialize)]
pub struct CoveredOnly {
    /// Covered recordings.
    pub recordings: usize,
    /// Optimism (%) over them.
    pub optimism_pct: f64,
    /// Its interval (%).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub optimism_interval: Option<RatioInterval>,
    /// The crossed estimate of d over them.
    pub estimate: CrossedEstimate,
    /// Whether the decision rule would hold on them.
    pub rule_holds: bool,
}

/// The reference arm's coverage over the levels of a combined study (a
/// multiverse unit's draws, a family's split), as its report states it.
#[derive(Debug, Clone, Serialize)]
pub struct CoverageNote {
    /// What a condition is: `trajectory` or `trajectory x speed`.
    pub condition: String,
    /// The reference arm.
    pub arm: String,
    /// The levels whose coverage was read.
    pub levels: usize,
    /// The evaluation recordings uncovered in at least one level.
    pub uncovered: Vec<Uncovered>,
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
    for (rec, _, d) in super::multiverse::Diff::of(plan, cells).iter() {
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
