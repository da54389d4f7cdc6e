//! A run's per-cell rows as its jobs wrote them: each job's file, all of
//! them gathered in plan order (what `cells.csv` holds), and a `cells.csv`
//! checked against them.

use std::path::{Path, PathBuf};

use super::RunError;
use crate::cells::{read_cells, Cell};
use crate::plan::{Plan, TrainingJob};

/// `out/cells/STEM.csv`: the per-cell rows of one job, present once it finished.
pub fn job_cells(out: &Path, job: &TrainingJob) -> PathBuf {
    out.join("cells").join(format!("{}.csv", job.stem()))
}

/// Every job's per-cell rows, in plan order, as `cells.csv` holds them.
pub(crate) fn gathered(plan: &Plan, out: &Path) -> Result<Vec<Cell>, RunError> {
    let mut all: Vec<Cell> = Vec::new();
    for j in &plan.jobs {
        all.extend(read_cells(&job_cells(out, j))?);
    }
    check_baselines(plan, &all)?;
    if !plan.doses.is_empty() && crate::plan::dose_axis(&plan.doses) == crate::design::DoseAxis::Percent {
        // A dose-response study's cells carry their dose: 0 for the
        // reference. A distance-dose study's arms name their distances.
        for c in &mut all {
            c.dose = if c.arm == plan.contrast.reference {
                Some(0.0)
            } else {
                plan.doses.iter().find(|d| d.arm == c.arm).map(|d| d.percent)
            };
        }
    }
    Ok(all)
}

/// Parameter-free models fit nothing split-dependent: their rows must be
/// identical across arms.
fn check_baselines(plan: &Plan, cells: &[Cell]) -> Result<(), RunError> {
    for m in plan.models.iter().filter(|m| !m.kind.trains()) {
        let rows = |arm: &str| -> Vec<(u64, String, u64, String)> {
            cells
                .iter()
                .filter(|c| c.model == m.name && c.arm == arm)
                .map(|c| {
                    (
                        c.seed,
                        c.recording.to_string(),
                        c.horizon_s.to_bits(),
                        format!("{:?}", (c.fa_position_rmse_m, c.conditional_position_rmse_m, c.n_divergent)),
                    )
                })
                .collect()
        };
        for w in plan.arms.windows(2) {
            if rows(&w[0].name) != rows(&w[1].name) {
                return Err(RunError::BaselineDependsOnArm {
                    model: m.name.clone(),
                    left: w[0].name.clone(),
                    right: w[1].name.clone(),
                });
            }
        }
    }
    Ok(())
}

/// That `dir/cells.csv` is exactly the per-cell files of `plan`'s jobs
/// gathered, each checked against its job record (of design
/// `design_sha256`): refused where a job has no record, a per-cell file
/// changed since its job wrote it, or cells.csv was edited after the run.
pub(crate) fn check_gathered(plan: &Plan, dir: &Path, design_sha256: &str) -> Result<(), RunError> {
    let changed = |reason: String| RunError::LevelChanged { dir: dir.display().to_string(), reason };
    for job in &plan.jobs {
        let Some(r) = super::JobRecord::read(dir, job)? else {
            return Err(changed(format!("job {} has no record in jobs/: the run did not finish", job.label())));
        };
        r.verify_cells(dir, job, design_sha256)?;
    }
    let gathered = crate::cells::cells_bytes(&gathered(plan, dir)?);
    let on_disk = crate::io::read_input(&dir.join("cells.csv"), crate::io::MAX_CELLS_FILE, "a per-cell CSV")
        .map_err(|e| changed(format!("cells.csv: {}", e.reason())))?;
    if gathered != on_disk {
        return Err(changed(
            "cells.csv is not the per-cell files its jobs wrote (cells/*.csv, each checked against its job record): it was edited after the run".to_string(),
        ));
    }
    Ok(())
}
