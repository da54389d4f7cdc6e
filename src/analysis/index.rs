//! Per-cell rows indexed by (model, arm, seed, recording, horizon), every
//! row checked against the plan: names it declares, no duplicates,
//! consistent condition labels, and a complete crossed matrix.

use std::collections::{BTreeMap, HashMap};

use super::AnalysisError;
use crate::cells::{Cell, Origin};
use crate::label::{Label, NameHash};
use crate::plan::Plan;

/// Horizons in CSVs are written by people and tools alike; match them to the
/// design's to a nanosecond.
fn same_horizon(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

/// The rows of a per-cell file, indexed and checked.
///
/// The cells sit in one dense table, a block per recording (in order of
/// first appearance), each block models x arms x horizons x seeds of the
/// plan's, so that indexing a million rows copies and compares no string
/// (names are interned labels: the same name is the same number), and one
/// arm's recordings x seeds grid is read from consecutive slots. A slot
/// holds its row's place in `cells` plus one, 0 where no row is: 4 bytes,
/// where a reference took 8 (40 MB of 80 at 10 million rows).
pub(crate) struct Indexed<'a> {
    cells: &'a [Cell],
    table: Vec<u32>,
    /// The plan's models and arms, matched to a row's by pointer.
    models: Vec<Label>,
    arms: Vec<Label>,
    seeds: HashMap<u64, usize, NameHash>,
    /// The first seed, where the plan's seeds are consecutive numbers in
    /// order (a seed's place is then found without the map).
    first_seed: Option<u64>,
    horizons: Vec<f64>,
    recordings: HashMap<&'a str, usize, NameHash>,
    /// recording -> (trajectory, speed, first line)
    pub(crate) labels: BTreeMap<String, (String, String, Origin)>,
}

impl<'a> Indexed<'a> {
    fn slot(&self, recording: usize, model: usize, arm: usize, h: usize, seed: usize) -> usize {
        (((recording * self.models.len() + model) * self.arms.len() + arm) * self.horizons.len() + h) * self.seeds.len()
            + seed
    }

    /// The slot of the first seed of (model, arm, horizon) in `recording`'s
    /// block, when each is the plan's; the seeds follow in the plan's order.
    fn seeds_of(&self, model: &str, arm: &str, recording: &str, h: f64) -> Option<usize> {
        let m = self.models.iter().position(|x| *x == *model)?;
        let a = self.arms.iter().position(|x| *x == *arm)?;
        let h = self.horizons.iter().position(|x| x.to_bits() == h.to_bits())?;
        Some(self.slot(*self.recordings.get(recording)?, m, a, h, 0))
    }

    /// A seed's place in the plan's list.
    fn seed_place(&self, seed: u64) -> Option<usize> {
        match self.first_seed {
            Some(first) => seed.checked_sub(first).map(|k| k as usize).filter(|&k| k < self.seeds.len()),
            None => self.seeds.get(&seed).copied(),
        }
    }

    /// A row's model, arm, seed and horizon as positions in the plan's
    /// lists; a name the plan does not declare is refused.
    fn positions(&self, plan: &Plan, c: &Cell) -> Result<(usize, usize, usize, usize), AnalysisError> {
        let not_in = |field: &'static str, value: String, known: String| AnalysisError::NotInDesign {
            at: c.origin,
            field,
            value,
            known,
        };
        let Some(m) = self.models.iter().position(|x| *x == c.model) else {
            return Err(not_in("model", c.model.to_string(), format!("models: {}", joined(&self.models))));
        };
        let Some(a) = self.arms.iter().position(|x| *x == c.arm) else {
            return Err(not_in("arm", c.arm.to_string(), format!("arms: {}", joined(&self.arms))));
        };
        let Some(s) = self.seed_place(c.seed) else {
            let (a, b) = (plan.seeds[0].0, plan.seeds[plan.seeds.len() - 1].0);
            return Err(not_in("seed", c.seed.to_string(), format!("{} seeds, {a}..{b}", plan.seeds.len())));
        };
        let Some(h) = self.horizons.iter().position(|&h| same_horizon(h, c.horizon_s)) else {
            let known = self.horizons.iter().map(|h| format!("{h} s")).collect::<Vec<_>>().join(", ");
            return Err(not_in("horizon_s", c.horizon_s.to_string(), format!("endpoint horizons: {known}")));
        };
        Ok((m, a, s, h))
    }

    /// The cell at these names, if the data has it.
    pub(crate) fn find(&self, model: &str, arm: &str, seed: u64, recording: &str, h: f64) -> Option<&'a Cell> {
        let first = self.seeds_of(model, arm, recording, h)?;
        SeedRow { cells: self.cells, slots: &self.table[first..first + self.seeds.len()] }.get(self.seed_place(seed)?)
    }

    /// The cells of every plan seed, in the plan's order, at a recording.
    pub(crate) fn row(&self, model: &str, arm: &str, recording: &str, h: f64) -> Option<SeedRow<'a, '_>> {
        let first = self.seeds_of(model, arm, recording, h)?;
        Some(SeedRow { cells: self.cells, slots: &self.table[first..first + self.seeds.len()] })
    }
}

/// The cells of one (model, arm, recording, horizon), a slot per plan seed
/// in the plan's order.
#[derive(Clone, Copy)]
pub(crate) struct SeedRow<'a, 't> {
    cells: &'a [Cell],
    slots: &'t [u32],
}

impl<'a> SeedRow<'a, '_> {
    /// The cell of the plan's `j`-th seed: `None` where the data lacks one.
    pub(crate) fn get(&self, j: usize) -> Option<&'a Cell> {
        let slot = *self.slots.get(j)?;
        slot.checked_sub(1).and_then(|k| self.cells.get(k as usize))
    }

    /// The cells of every seed, in the plan's order.
    pub(crate) fn iter(&self) -> impl Iterator<Item = Option<&'a Cell>> + '_ {
        (0..self.slots.len()).map(|j| self.get(j))
    }
}

/// Indexes `cells`, refusing names the plan does not declare, duplicate
/// cells, recordings labelled two ways, and more recordings than the plan
/// declares.
pub(crate) fn index<'a>(plan: &Plan, cells: &'a [Cell]) -> Result<Indexed<'a>, AnalysisError> {
    let mut horizons: Vec<f64> = plan.units().map(|u| u.horizon_s).collect();
    horizons.sort_by(f64::total_cmp);
    horizons.dedup();
    // A slot numbers its row in 4 bytes: more rows than that are refused
    // (they would take some 600 GB as cells).
    if cells.len() >= u32::MAX as usize {
        return Err(AnalysisError::TooManyRows { rows: cells.len(), most: u32::MAX - 1 });
    }
    let mut out = Indexed {
        cells,
        table: Vec::new(),
        models: plan.models.iter().map(|m| Label::from(&m.name)).collect(),
        arms: plan.arms.iter().map(|a| Label::from(&a.name)).collect(),
        seeds: plan.seeds.iter().enumerate().map(|(k, s)| (s.0, k)).collect(),
        first_seed: plan
            .seeds
            .first()
            .map(|s| s.0)
            .filter(|&first| plan.seeds.iter().enumerate().all(|(k, s)| first.checked_add(k as u64) == Some(s.0))),
        horizons,
        recordings: HashMap::default(),
        labels: BTreeMap::new(),
    };
    let block = out.models.len() * out.arms.len() * out.horizons.len() * out.seeds.len();
    // Per recording: its name, its labels and the line that first gave
    // them; found by the label's id (the same name is the same label), so
    // a row's lookup reads no name.
    let mut labels: Vec<(Label, Label, Label, Origin)> = Vec::new();
    let mut ids = RecordingIds::default();
    // Room for the recordings a complete file of these rows holds, taken
    // once (grown a block at a time, the table was copied as it doubled).
    let expected = cells.len().div_ceil(block.max(1)).min(plan.recordings);
    out.table.reserve_exact(expected.saturating_mul(block));
    for (row, c) in cells.iter().enumerate() {
        let (m, a, s, h) = out.positions(plan, c)?;
        let next = ids.len();
        let r = ids.number(c.recording.id());
        if r == next {
            // A recording beyond the declared number is an error whatever
            // else the file holds: counted over the whole file, and no
            // table is grown for it.
            if next >= plan.recordings {
                return Err(too_many(plan, cells));
            }
            labels.push((c.recording, c.trajectory, c.speed, c.origin));
            out.table.resize(out.table.len() + block, 0);
        }
        let k = out.slot(r, m, a, h, s);
        if let Some(first) = out.table[k].checked_sub(1).map(|f| &cells[f as usize]) {
            return Err(AnalysisError::Duplicate {
                at: c.origin,
                first_at: first.origin,
                model: c.model.to_string(),
                arm: c.arm.to_string(),
                seed: c.seed,
                recording: c.recording.to_string(),
                horizon: out.horizons[h],
            });
        }
        // Fits: fewer rows than u32::MAX, as checked above.
        out.table[k] = row as u32 + 1;
        if r != next {
            let (_, t, s, at) = labels[r];
            check_labels((t, s, at), c)?;
        }
    }
    out.recordings = labels.iter().enumerate().map(|(r, (name, ..))| (name.as_str(), r)).collect();
    out.labels =
        labels.iter().map(|&(name, t, s, at)| (name.to_string(), (t.to_string(), s.to_string(), at))).collect();
    Ok(out)
}

/// Recordings numbered in order of first appearance, found by their
/// label's number: in a vector for the first [`DENSE_LABELS`] label
/// numbers (one read, no hash), in a map beyond.
#[derive(Default)]
struct RecordingIds {
    /// By label number: the recording's number plus one, 0 for none.
    dense: Vec<u32>,
    sparse: HashMap<usize, usize, NameHash>,
    count: usize,
}

/// Label numbers a [`RecordingIds`] holds in its vector: 4 MB at most.
const DENSE_LABELS: usize = 1 << 20;

impl RecordingIds {
    /// The number of the recording labelled `id`, the next one if it is new.
    fn number(&mut self, id: usize) -> usize {
        if id >= DENSE_LABELS {
            let next = self.count;
            let r = *self.sparse.entry(id).or_insert(next);
            self.count += usize::from(r == next);
            return r;
        }
        if self.dense.len() <= id {
            self.dense.resize((id + 1).next_power_of_two().min(DENSE_LABELS), 0);
        }
        match self.dense[id].checked_sub(1) {
            Some(r) => r as usize,
            None => {
                // Fewer recordings than rows, which fit in a u32 (see `index`).
                self.dense[id] = self.count as u32 + 1;
                self.count += 1;
                self.count - 1
            }
        }
    }

    fn len(&self) -> usize {
        self.count
    }
}

/// The error of a file with more recordings than the design declares,
/// counted over the whole file, naming the one in the fewest rows (a
/// misspelt name is in few rows), where it first appears.
fn too_many(plan: &Plan, cells: &[Cell]) -> AnalysisError {
    let mut rows: HashMap<usize, (usize, usize), NameHash> = HashMap::default();
    for (k, c) in cells.iter().enumerate() {
        rows.entry(c.recording.id()).or_insert((0, k)).0 += 1;
    }
    // Fewest rows; of those, the one first seen latest.
    let (count, k) = rows.values().copied().min_by_key(|&(n, k)| (n, std::cmp::Reverse(k))).unwrap_or((0, 0));
    let fewest = cells.get(k).map(|c| {
        let name = c.recording.as_str();
        let shown = match name.char_indices().nth(60) {
            Some((cut, _)) => format!("`{}`... ({} characters)", &name[..cut], name.chars().count()),
            None => format!("`{name}`"),
        };
        format!("; the one in the fewest rows is {shown}: {count} row(s), first at {}", c.origin)
    });
    AnalysisError::RecordingCount { found: rows.len(), declared: plan.recordings, fewest: fewest.unwrap_or_default() }
}

/// Names as a message lists them.
fn joined(names: &[Label]) -> String {
    names.iter().map(Label::as_str).collect::<Vec<_>>().join(", ")
}

/// Refuses a row that labels its recording otherwise than the row that
/// first named it.
fn check_labels((t, s, first_at): (Label, Label, Origin), c: &Cell) -> Result<(), AnalysisError> {
    for (field, value, first) in [("trajectory", c.trajectory, t), ("speed", c.speed, s)] {
        if value != first {
            return Err(AnalysisError::InconsistentLabel {
                at: c.origin,
                field,
                recording: c.recording.to_string(),
                value: value.to_string(),
                first: first.to_string(),
                first_at,
            });
        }
    }
    Ok(())
}

/// Every (model, horizon) x contrast arm x seed x recording the plan needs
/// is present; otherwise the first ten missing cells are named. Under
/// `estimate reml ... missing allow` the missing cells are returned, every
/// one, for the report to list.
pub(crate) fn check_complete(plan: &Plan, data: &Indexed, recordings: &[String]) -> Result<Vec<String>, AnalysisError> {
    let mut missing = Vec::new();
    for (model, h) in plan.row_keys() {
        for arm in [&plan.contrast.treated, &plan.contrast.reference] {
            let rows: Vec<Option<SeedRow>> = recordings.iter().map(|r| data.row(model, arm, r, h)).collect();
            for (j, s) in plan.seeds.iter().enumerate() {
                for (r, row) in recordings.iter().zip(&rows) {
                    if row.and_then(|row| row.get(j)).is_none() {
                        missing.push(format!("model={model} arm={arm} seed={} recording={r} horizon={h} s", s.0));
                    }
                }
            }
        }
    }
    if missing.is_empty() || plan.estimator.missing_allowed {
        return Ok(missing);
    }
    let count = missing.len();
    let mut list: Vec<String> = missing.into_iter().take(10).map(|m| format!("  {m}")).collect();
    if count > 10 {
        list.push(format!("  ... and {} more", count - 10));
    }
    Err(AnalysisError::Missing { count, list: list.join("\n") })
}
