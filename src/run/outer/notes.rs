//! What each level's folder says beyond its cells, for the combined
//! reports: invariants that hold only with a warning (a reference arm
//! whose fit set holds copies of evaluation recordings) and training that
//! ended early.

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::analysis::multiverse::{ReferenceCopies, UnitNotes};
use crate::analysis::training::early_training;
use crate::cells::Cell;
use crate::plan::Plan;

/// The invariants of one level's audit/invariants.json that hold with a
/// warning (empty when the file is absent).
fn warned(dir: &Path) -> Vec<Value> {
    let Ok(text) = std::fs::read_to_string(dir.join("audit/invariants.json")) else { return Vec::new() };
    let Ok(v) = serde_json::from_str::<Value>(&text) else { return Vec::new() };
    v["invariants"]
        .as_array()
        .map(|a| a.iter().filter(|i| i["status"] == "warn").cloned().collect())
        .unwrap_or_default()
}

/// Windows of evaluation recordings or their copies an invariant counts.
fn from_evaluation(i: &Value) -> usize {
    let n = |k: &str| i["numbers"][k].as_u64().unwrap_or(0) as usize;
    n("from_duplicates") + n("from_evaluation")
}

/// Invariant 5 (the reference arm's fit set is disjoint) over `dirs`: the
/// fewest and most windows from evaluation recordings or their copies.
pub(super) fn reference_copies(dirs: &[PathBuf]) -> Option<ReferenceCopies> {
    let found: Vec<usize> =
        dirs.iter().filter_map(|d| warned(d).into_iter().find(|i| i["id"] == 5).map(|i| from_evaluation(&i))).collect();
    if found.is_empty() {
        return None;
    }
    Some(ReferenceCopies {
        fewest: *found.iter().min().unwrap_or(&0),
        most: *found.iter().max().unwrap_or(&0),
        levels_with: found.len(),
        levels: dirs.len(),
    })
}

/// One warning per invariant that holds with a warning in any of the
/// levels `(draw, folder)` of a per-seed-draw study, with the range of its
/// counts over the draws.
pub(super) fn invariant_warnings(levels: &[(u64, PathBuf)]) -> Vec<String> {
    let mut by_id: std::collections::BTreeMap<u64, Vec<(u64, Value)>> = Default::default();
    for (draw, dir) in levels {
        for i in warned(dir) {
            by_id.entry(i["id"].as_u64().unwrap_or(0)).or_default().push((*draw, i));
        }
    }
    by_id
        .into_iter()
        .map(|(id, found)| {
            let name = found[0].1["name"].as_str().unwrap_or("").to_string();
            let counts: Vec<usize> = found.iter().map(|(_, i)| from_evaluation(i)).collect();
            let (lo, hi) = (counts.iter().min().copied().unwrap_or(0), counts.iter().max().copied().unwrap_or(0));
            let (first_draw, first) = (&found[0].0, found[0].1["detail"].as_str().unwrap_or(""));
            format!(
                "invariant {id} ({name}) holds with a warning in {} of {} draws: {lo} to {hi} windows per draw from evaluation recordings or byte-identical copies of them; draw {first_draw}: {first}",
                found.len(),
                levels.len()
            )
        })
        .collect()
}

/// The notes on one unit of a multiverse (a specification, or a draw):
/// its reference arm and its training.
pub(super) fn unit_notes(id: &str, plan: &Plan, level_plans: &[(&Plan, PathBuf)], cells: &[Cell]) -> UnitNotes {
    let dirs: Vec<PathBuf> = level_plans.iter().map(|(_, d)| d.clone()).collect();
    let mut curves = Vec::new();
    for (p, d) in level_plans {
        // A folder trimmed of its curves has no training to report.
        if let Ok(c) = crate::run::curves::read_curves(p, d) {
            curves.extend(c);
        }
    }
    let best = crate::analysis::evidence::best_epochs(plan, &curves);
    UnitNotes {
        id: id.to_string(),
        coverage: crate::run::coverage::note_of_levels(plan, &dirs),
        reference_copies: reference_copies(&dirs),
        early: if best.is_empty() { None } else { early_training(plan, &best, cells) },
    }
}
