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
/// decision that rests on barely trained models should say so, per arm,
/// with the primary d of the seeds with and without such a model.
pub(super) fn early_best_epochs(plan: &Plan, curves: &[Curve], cells: &[crate::cells::Cell]) -> Option<String> {
    crate::analysis::training::early_training(plan, &crate::analysis::evidence::best_epochs(plan, curves), cells)?
        .warning()
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
    let mut jobs: Vec<&TrainingJob> = plan.jobs.iter().filter(|j| j.kind.has_curve()).collect();
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
        curves.push(Curve { model: j.model.clone(), arm: j.arm.clone(), seed: j.seed.0, points });
    }
    Ok(curves)
}
