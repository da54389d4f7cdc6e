//! A choice effect's paired cells: per recording and seed, the mean d of
//! the specifications taking an alternative minus the primary's.

use std::collections::HashSet;

use crate::analysis::diff::{common, Diff};
use crate::label::NameHash;

/// One choice effect's paired cells: per recording and seed (over the
/// recordings and seeds every specification has), mean d over the
/// specifications taking the alternative minus mean d over those taking
/// the primary's.
pub(super) struct EffectCells {
    pub(super) setting: String,
    pub(super) reference: String,
    pub(super) alternative: String,
    pub(super) specs_per_side: usize,
    pub(super) recs: Vec<String>,
    pub(super) seeds: Vec<u64>,
    pub(super) values: Vec<f64>,
}

/// Each choice's effect cells over `diffs` (one per specification);
/// warnings where an effect has too few cells.
pub(super) fn effect_cells(
    m: &crate::design::Multiverse,
    diffs: &[Diff],
    warnings: &mut Vec<String>,
) -> Vec<EffectCells> {
    let all: Vec<&Diff> = diffs.iter().collect();
    let (recs, seeds, mats) = common(&all);
    // Counted by label number: no name compared per cell.
    let total: HashSet<usize, NameHash> = diffs.iter().flat_map(|d| d.iter().map(|(r, _, _)| r.id())).collect();
    if recs.len() < total.len() {
        warnings.push(format!(
            "{} of {} evaluation recordings are in every specification; the paired choice effects and the joint bootstrap use those",
            recs.len(),
            total.len()
        ));
    }
    let primary = &m.specs[m.primary].values;
    let mut out = Vec::new();
    for (c, choice) in m.choices.iter().enumerate() {
        for alt in choice.alternatives.iter().filter(|a| **a != primary[c]) {
            let side =
                |value: &str| -> Vec<usize> { (0..m.specs.len()).filter(|&s| m.specs[s].values[c] == value).collect() };
            let (with, without) = (side(alt), side(&primary[c]));
            let n = recs.len() * seeds.len();
            let mean_over =
                |idx: &[usize], cell: usize| idx.iter().map(|&s| mats[s][cell]).sum::<f64>() / idx.len() as f64;
            out.push(EffectCells {
                setting: choice.setting.clone(),
                reference: primary[c].clone(),
                alternative: alt.clone(),
                specs_per_side: with.len(),
                recs: recs.clone(),
                seeds: seeds.clone(),
                values: (0..n).map(|cell| mean_over(&with, cell) - mean_over(&without, cell)).collect(),
            });
        }
    }
    out
}
