//! The primary difference d = treated - reference of one run's cells, as
//! a dense recordings x seeds table: what the multiverse, the training
//! notes and the condition coverage all read from a level's cells.

use std::collections::HashMap;

use crate::cells::Cell;
use crate::label::{Label, NameHash};
use crate::plan::Plan;

/// The primary difference d = treated - reference of one level, per
/// (recording, seed), at the primary unit: a dense recordings x seeds
/// table, empty where either arm lacks the cell.
pub(crate) struct Diff {
    /// Recordings with a cell of either arm, sorted.
    recs: Vec<Label>,
    /// Seeds with a cell of either arm, sorted.
    seeds: Vec<u64>,
    /// d per recording (row) and seed (column).
    values: Vec<Option<f64>>,
}

impl Diff {
    pub(crate) fn of(plan: &Plan, cells: &[Cell]) -> Diff {
        let u = &plan.primary;
        // Names compared as labels, by number: a level's cells are read
        // once each, and no name is compared as text per cell.
        let model = Label::from(&u.model);
        let (treated, reference) = (Label::from(&plan.contrast.treated), Label::from(&plan.contrast.reference));
        let ours: Vec<(&Cell, bool)> = cells
            .iter()
            .filter(|c| c.model == model && (c.horizon_s - u.horizon_s).abs() < 1e-9)
            .filter_map(|c| {
                let is_treated = c.arm == treated;
                (is_treated || c.arm == reference).then_some((c, is_treated))
            })
            .collect();
        // The distinct recordings (found by label number), then sorted by
        // name.
        let mut row: HashMap<usize, usize, NameHash> = HashMap::default();
        let mut recs: Vec<Label> = Vec::new();
        for (c, _) in &ours {
            row.entry(c.recording.id()).or_insert_with(|| {
                recs.push(c.recording);
                0
            });
        }
        recs.sort_unstable();
        for (i, r) in recs.iter().enumerate() {
            row.insert(r.id(), i);
        }
        let mut seeds: Vec<u64> = ours.iter().map(|(c, _)| c.seed).collect();
        seeds.sort_unstable();
        seeds.dedup();
        let n = recs.len() * seeds.len();
        let (mut t, mut r) = (vec![None; n], vec![None; n]);
        for (c, is_treated) in ours {
            let Some(v) = super::unit::value_of(c, u.metric) else { continue };
            let (Some(&i), Ok(j)) = (row.get(&c.recording.id()), seeds.binary_search(&c.seed)) else { continue };
            // A later row for the same cell replaces an earlier one.
            if is_treated {
                t[i * seeds.len() + j] = Some(v);
            } else {
                r[i * seeds.len() + j] = Some(v);
            }
        }
        let values = t.iter().zip(&r).map(|(t, r)| Some(t.as_ref()? - r.as_ref()?)).collect();
        Diff { recs, seeds, values }
    }

    /// d at recording row `i`, seed column `j`.
    fn at(&self, i: usize, j: usize) -> Option<f64> {
        self.values[i * self.seeds.len() + j]
    }

    /// Every (recording, seed, d), by recording then seed.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (&Label, u64, f64)> + '_ {
        self.recs
            .iter()
            .enumerate()
            .flat_map(move |(i, r)| (0..self.seeds.len()).filter_map(move |j| Some((r, self.seeds[j], self.at(i, j)?))))
    }
}

/// The recordings and seeds every level has a d for, and each level's
/// recordings x seeds matrix over them.
pub(crate) fn common(diffs: &[&Diff]) -> (Vec<String>, Vec<u64>, Vec<Vec<f64>>) {
    let Some(first) = diffs.first() else { return (Vec::new(), Vec::new(), Vec::new()) };
    let (nr, ns) = (first.recs.len(), first.seeds.len());
    // Each level's row of each of the first level's recordings, and its
    // column of each of the first's seeds.
    let rows: Vec<Vec<Option<usize>>> =
        diffs.iter().map(|d| first.recs.iter().map(|r| d.recs.binary_search(r).ok()).collect()).collect();
    let cols: Vec<Vec<Option<usize>>> =
        diffs.iter().map(|d| first.seeds.iter().map(|s| d.seeds.binary_search(s).ok()).collect()).collect();
    let value = |k: usize, i: usize, j: usize| diffs[k].at(rows[k][i]?, cols[k][j]?);
    // The cells every level has.
    let shared: Vec<bool> =
        (0..nr * ns).map(|x| (0..diffs.len()).all(|k| value(k, x / ns, x % ns).is_some())).collect();
    let any_row = |i: usize| (0..ns).any(|j| shared[i * ns + j]);
    let seeds: Vec<usize> = (0..ns).filter(|&j| (0..nr).any(|i| shared[i * ns + j])).collect();
    // Only complete rows and columns: a recording every seed has.
    let recs: Vec<usize> = (0..nr).filter(|&i| any_row(i) && seeds.iter().all(|&j| shared[i * ns + j])).collect();
    let seeds: Vec<usize> = seeds.into_iter().filter(|&j| recs.iter().all(|&i| shared[i * ns + j])).collect();
    let mats = (0..diffs.len())
        .map(|k| recs.iter().flat_map(|&i| seeds.iter().map(move |&j| value(k, i, j).unwrap_or(f64::NAN))).collect())
        .collect();
    (recs.iter().map(|&i| first.recs[i].to_string()).collect(), seeds.iter().map(|&j| first.seeds[j]).collect(), mats)
}
