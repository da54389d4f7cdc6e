//! The training curves a run reads back for its report (`curves/STEM.csv`
//! of every job crossaudit trained), and the warning they give when the
//! best validation epoch comes too early.

use std::path::Path;

use serde::Deserialize;

use super::RunError;
use crate::plan::{Plan, TrainingJob};
use crate::report::figures::Curve;

/// A warning when fitted models' best validation epoch (the weights the
/// rollouts use) falls in the first tenth of the planned epochs: a
/// decision that rests on barely trained models should say so.
pub(super) fn early_best_epochs(plan: &Plan, curves: &[Curve]) -> Option<String> {
    let planned = plan.training.as_ref()?.epochs;
    let first = planned.div_ceil(10).max(1) as f64;
    let best: Vec<f64> = curves
        .iter()
        .filter_map(|c| c.points.iter().copied().reduce(|a, b| if b.1 < a.1 { b } else { a }).map(|p| p.0))
        .collect();
    let early: Vec<f64> = best.iter().copied().filter(|e| *e <= first).collect();
    if early.is_empty() {
        return None;
    }
    let lo = early.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = early.iter().copied().fold(0.0, f64::max);
    Some(format!(
        "early best epochs: {} of {} fitted models reach their best validation loss within the first {first} of {planned} epochs (epochs {lo} to {hi}); their restored weights are barely trained (training curves figure)",
        early.len(),
        best.len()
    ))
}

/// The columns of a training curve the figures need.
#[derive(Deserialize)]
struct CurvePoint {
    epoch: f64,
    val_loss: f64,
}

/// The validation-loss curve of every fitted job, in file-name order.
pub(super) fn read_curves(plan: &Plan, out: &Path) -> Result<Vec<Curve>, RunError> {
    // External models' training happened elsewhere: no curve.
    let mut jobs: Vec<&TrainingJob> = plan.jobs.iter().filter(|j| j.trains() && !j.kind.is_external()).collect();
    jobs.sort_by_key(|j| j.stem());
    let mut curves = Vec::new();
    for j in jobs {
        let path = out.join("curves").join(format!("{}.csv", j.stem()));
        let csv_err = |source: csv::Error| RunError::Csv { path: path.display().to_string(), source };
        let mut rdr = csv::Reader::from_path(&path).map_err(csv_err)?;
        let points = rdr
            .deserialize::<CurvePoint>()
            .map(|p| p.map(|p| (p.epoch, p.val_loss)))
            .collect::<Result<Vec<_>, _>>()
            .map_err(csv_err)?;
        curves.push(Curve { arm: j.arm.clone(), points });
    }
    Ok(curves)
}
