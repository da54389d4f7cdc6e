//! Per-cell rows indexed by (model, arm, seed, recording, horizon), every
//! row checked against the plan: names it declares, no duplicates,
//! consistent condition labels, and a complete crossed matrix.

use std::collections::BTreeMap;

use super::AnalysisError;
use crate::cells::Cell;
use crate::plan::Plan;

/// Cells indexed by (model, arm, seed, recording, horizon bits).
pub(crate) type Key = (String, String, u64, String, u64);

/// Horizons in CSVs are written by people and tools alike; match them to the
/// design's to a nanosecond.
fn same_horizon(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

/// The rows of a per-cell file, indexed and checked.
pub(crate) struct Indexed<'a> {
    pub(crate) cells: BTreeMap<Key, &'a Cell>,
    /// recording -> (trajectory, speed, first line)
    pub(crate) labels: BTreeMap<String, (String, String, u64)>,
}

impl Indexed<'_> {
    /// The cell at a key, if the data has it.
    pub(crate) fn find(&self, model: &str, arm: &str, seed: u64, recording: &str, h: f64) -> Option<&Cell> {
        let k = (model.to_string(), arm.to_string(), seed, recording.to_string(), h.to_bits());
        self.cells.get(&k).copied()
    }
}

/// Indexes `cells`, refusing names the plan does not declare, duplicate
/// cells and recordings labelled two ways.
pub(crate) fn index<'a>(plan: &Plan, cells: &'a [Cell]) -> Result<Indexed<'a>, AnalysisError> {
    let models: Vec<&str> = plan.models.iter().map(|m| m.name.as_str()).collect();
    let arms: Vec<&str> = plan.arms.iter().map(|a| a.name.as_str()).collect();
    let mut horizons: Vec<f64> = plan.units().map(|u| u.horizon_s).collect();
    horizons.sort_by(f64::total_cmp);
    horizons.dedup();
    let mut out = Indexed { cells: BTreeMap::new(), labels: BTreeMap::new() };
    for c in cells {
        let not_in = |field: &'static str, value: String, known: String| AnalysisError::NotInDesign {
            line: c.line,
            field,
            value,
            known,
        };
        if !models.contains(&c.model.as_str()) {
            return Err(not_in("model", c.model.clone(), format!("models: {}", models.join(", "))));
        }
        if !arms.contains(&c.arm.as_str()) {
            return Err(not_in("arm", c.arm.clone(), format!("arms: {}", arms.join(", "))));
        }
        if !plan.seeds.iter().any(|s| s.0 == c.seed) {
            let (a, b) = (plan.seeds[0].0, plan.seeds[plan.seeds.len() - 1].0);
            return Err(not_in("seed", c.seed.to_string(), format!("{} seeds, {a}..{b}", plan.seeds.len())));
        }
        let Some(&h) = horizons.iter().find(|&&h| same_horizon(h, c.horizon_s)) else {
            let known = horizons.iter().map(|h| format!("{h} s")).collect::<Vec<_>>().join(", ");
            return Err(not_in("horizon_s", c.horizon_s.to_string(), format!("endpoint horizons: {known}")));
        };
        let k = (c.model.clone(), c.arm.clone(), c.seed, c.recording.clone(), h.to_bits());
        if let Some(first) = out.cells.get(&k) {
            return Err(AnalysisError::Duplicate {
                line: c.line,
                first_line: first.line,
                model: c.model.clone(),
                arm: c.arm.clone(),
                seed: c.seed,
                recording: c.recording.clone(),
                horizon: h,
            });
        }
        out.cells.insert(k, c);
        check_labels(&mut out.labels, c)?;
    }
    Ok(out)
}

/// Records a recording's labels on first sight; refuses a later row that
/// labels it differently.
fn check_labels(labels: &mut BTreeMap<String, (String, String, u64)>, c: &Cell) -> Result<(), AnalysisError> {
    let Some((t, s, first_line)) = labels.get(&c.recording) else {
        labels.insert(c.recording.clone(), (c.trajectory.clone(), c.speed.clone(), c.line));
        return Ok(());
    };
    for (field, value, first) in [("trajectory", &c.trajectory, t), ("speed", &c.speed, s)] {
        if value != first {
            return Err(AnalysisError::InconsistentLabel {
                line: c.line,
                field,
                recording: c.recording.clone(),
                value: value.clone(),
                first: first.clone(),
                first_line: *first_line,
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
            for s in &plan.seeds {
                for r in recordings {
                    let k = (model.to_string(), arm.clone(), s.0, r.clone(), h.to_bits());
                    if !data.cells.contains_key(&k) {
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
