//! What the split's treatment audit gives the analysis: each arm's
//! treatment strength, and the reference arm's condition coverage from
//! the split of each draw (`split::ConditionCoverage`, in each level's
//! `audit/treatment.json`) turned into the analysis's statement
//! (`analysis::coverage`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::analysis::coverage::{condition_coverage, ConditionCoverage, CoverageNote, Uncovered};
use crate::cells::Cell;
use crate::plan::Plan;
use crate::split::ConditionCoverage as SplitCoverage;

/// The statement over the draws `draws` (one split's coverage each):
/// every evaluation recording the reference arm leaves uncovered in any
/// draw, with the number of draws it was uncovered in. `None` without a
/// draw to read.
pub(crate) fn statement(plan: &Plan, cells: &[Cell], draws: &[SplitCoverage]) -> Option<ConditionCoverage> {
    let first = draws.first()?;
    Some(condition_coverage(plan, cells, &first.condition, draws.len(), uncovered(plan, draws)))
}

/// The recordings the reference arm leaves uncovered in any of `draws`,
/// with the number of draws each is uncovered in.
fn uncovered(plan: &Plan, draws: &[SplitCoverage]) -> Vec<Uncovered> {
    let mut count: BTreeMap<(String, String), usize> = BTreeMap::new();
    for d in draws {
        for r in d.uncovered(&plan.contrast.reference) {
            *count.entry((r.recording.clone(), r.condition.clone())).or_default() += 1;
        }
    }
    count.into_iter().map(|((recording, condition), draws)| Uncovered { recording, condition, draws }).collect()
}

/// The note of a combined report over the level folders `dirs`, when every
/// one of them records its coverage.
pub(crate) fn note_of_levels(plan: &Plan, dirs: &[PathBuf]) -> Option<CoverageNote> {
    let draws: Vec<SplitCoverage> = dirs.iter().map(|d| read_level(d)).collect::<Option<_>>()?;
    Some(CoverageNote {
        condition: draws.first()?.condition.clone(),
        arm: plan.contrast.reference.clone(),
        levels: draws.len(),
        uncovered: uncovered(plan, &draws),
    })
}

/// The coverage a level folder's `audit/treatment.json` records; `None`
/// for a folder written before coverage was measured (or without one).
pub(crate) fn read_level(dir: &Path) -> Option<SplitCoverage> {
    let text = std::fs::read_to_string(dir.join("audit/treatment.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    serde_json::from_value(v.get("coverage")?.clone()).ok()
}

/// The statement over the level folders `dirs`, when every one of them
/// records its coverage.
pub(crate) fn statement_of_levels(plan: &Plan, cells: &[Cell], dirs: &[PathBuf]) -> Option<ConditionCoverage> {
    let draws: Option<Vec<SplitCoverage>> = dirs.iter().map(|d| read_level(d)).collect();
    statement(plan, cells, &draws?)
}

/// One arm's treatment audit as the analysis reports it.
fn strength(a: &crate::split::ArmTreatment, horizon_s: f64) -> crate::analysis::TreatmentStrength {
    crate::analysis::TreatmentStrength {
        arm: a.arm.clone(),
        contaminating_windows: a.contaminating_windows,
        inside_evaluated_segment: a.inside_evaluated_segment,
        horizon_s,
        median_distance_s: a.median_distance_s,
        segment_distance_quartiles_s: a.segment_distance_quartiles_s,
    }
}

/// Per arm of a distance-dose family, from how many evaluation recordings
/// its contaminating windows came in the run folders `dirs` (each level's
/// `manifests/contaminating_ARM.csv` against its
/// `manifests/evaluation_recordings.csv`); empty for any other study or
/// where a folder lacks its manifests.
pub(crate) fn distance_sources(plan: &Plan, dirs: &[PathBuf]) -> Vec<crate::analysis::family::DoseSource> {
    if crate::plan::dose_axis(&plan.doses) != crate::design::DoseAxis::Distance {
        return Vec::new();
    }
    let names = |path: &Path| -> Option<Vec<String>> {
        let mut r = csv::Reader::from_path(path).ok()?;
        r.records().map(|row| row.ok().and_then(|row| row.get(0).map(str::to_string))).collect()
    };
    let evaluated: Option<Vec<usize>> =
        dirs.iter().map(|d| names(&d.join("manifests/evaluation_recordings.csv")).map(|e| e.len())).collect();
    let Some(evaluated) = evaluated else { return Vec::new() };
    let mut out = Vec::new();
    for d in &plan.doses {
        let mut counts = Vec::new();
        for (dir, &evaluation) in dirs.iter().zip(&evaluated) {
            let Some(windows) = names(&dir.join(format!("manifests/contaminating_{}.csv", d.arm))) else {
                return Vec::new();
            };
            let drawn: std::collections::BTreeSet<String> = windows.into_iter().collect();
            counts.push((drawn.len(), evaluation));
        }
        let (Some(fewest), Some(most), Some(of)) =
            (counts.iter().map(|c| c.0).min(), counts.iter().map(|c| c.0).max(), counts.iter().map(|c| c.1).min())
        else {
            return Vec::new();
        };
        out.push(crate::analysis::family::DoseSource { arm: d.arm.clone(), fewest, most, of });
    }
    out
}

/// Each arm's treatment strength over the level folders `dirs` (each
/// level's `audit/treatment.json`): per field, the median over the draws
/// ([`crate::split::median`]). Empty where a folder lacks its audit or an
/// arm is missing from one.
pub(crate) fn treatment_over_levels(plan: &Plan, dirs: &[PathBuf]) -> Vec<crate::analysis::TreatmentStrength> {
    let read = |dir: &PathBuf| -> Option<(f64, Vec<crate::split::ArmTreatment>)> {
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("audit/treatment.json")).ok()?).ok()?;
        let horizon_s = v.get("horizon_samples")?.as_f64()? / plan.rate_hz;
        Some((horizon_s, serde_json::from_value(v.get("arms")?.clone()).ok()?))
    };
    let Some(levels) = dirs.iter().map(read).collect::<Option<Vec<_>>>() else { return Vec::new() };
    let Some((_, first)) = levels.first() else { return Vec::new() };
    let mut out = Vec::new();
    for arm in first {
        let per: Option<Vec<crate::analysis::TreatmentStrength>> =
            levels.iter().map(|(h, arms)| arms.iter().find(|a| a.arm == arm.arm).map(|a| strength(a, *h))).collect();
        let Some(per) = per else { return Vec::new() };
        let m =
            |f: &dyn Fn(&crate::analysis::TreatmentStrength) -> f64| crate::split::median(per.iter().map(f).collect());
        let q = |k: usize| m(&|t| t.segment_distance_quartiles_s[k]);
        out.push(crate::analysis::TreatmentStrength {
            arm: arm.arm.clone(),
            contaminating_windows: m(&|t| t.contaminating_windows as f64).round() as usize,
            inside_evaluated_segment: m(&|t| t.inside_evaluated_segment as f64).round() as usize,
            horizon_s: m(&|t| t.horizon_s),
            median_distance_s: m(&|t| t.median_distance_s),
            segment_distance_quartiles_s: [q(0), q(1), q(2)],
        });
    }
    out
}
