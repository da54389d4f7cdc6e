//! `draws per seed`: every seed a level of its own, with the draw that
//! `factor draw` numbers after it, and the seeds' cells analysed together
//! as one crossed recording x seed study whose seed component carries the
//! draw variance. In a single design the levels are `out/draw-K` and the
//! study's cells and report are `out/cells.csv` and `out/report`; in a
//! multiverse each specification's seeds are `out/spec-ID/draw-K`, its
//! cells and report `out/spec-ID/cells.csv` and `out/spec-ID/report`, and
//! the specification is one unit of the multiverse analysis.

use std::path::Path;

use super::{Level, Outer};
use crate::analysis::record::DesignLabel;
use crate::cells::{read_cells, Cell};
use crate::design::{DesignFile, LockStatus};
use crate::io::create_dir_all;
use crate::plan::Plan;
use crate::run::{LevelFolder, RunError, RunOutcome};

/// After every seed's level of a `draws per seed` study finished: their
/// cells in one `out/cells.csv` (seed order), then the study's folder
/// finished as [`crate::run::finish_combined`] finishes it: the design's
/// own analysis of the cells (the crossed recording x seed estimator,
/// whose seed component now carries the draw variance) with every level's
/// evidence, its report in `out/report`. `notes` are the run's (jobs
/// reused or copied, external models).
pub(crate) fn finish_per_seed(
    file: &DesignFile,
    study: &Plan,
    outer: &Outer,
    out: &Path,
    status: &LockStatus,
    notes: &[String],
) -> Result<RunOutcome, RunError> {
    finish_seeds(file, study, &LevelFolder::of(outer, out), out, status, notes)
}

/// Each specification of a multiverse with per-seed draws, finished as
/// [`finish_per_seed`] finishes a single design, in `out/spec-ID`.
pub(crate) fn finish_specs(file: &DesignFile, outer: &Outer, out: &Path, status: &LockStatus) -> Result<(), RunError> {
    let levels: &[Level] = &outer.levels;
    for u in &outer.units {
        let members: Vec<LevelFolder> = u
            .members
            .iter()
            .map(|&k| LevelFolder::at(&levels[k], out.join(&levels[levels[k].shares.unwrap_or(k)].id)))
            .collect();
        let finished = finish_seeds(file, &u.plan, &members, &out.join(&u.id), status, &[]);
        finished.map_err(|e| RunError::InLevel { level: u.id.clone(), source: Box::new(e) })?;
    }
    Ok(())
}

fn finish_seeds(
    file: &DesignFile,
    study: &Plan,
    levels: &[LevelFolder],
    dest: &Path,
    status: &LockStatus,
    notes: &[String],
) -> Result<RunOutcome, RunError> {
    let mut all: Vec<Cell> = Vec::new();
    for l in levels {
        all.extend(read_cells(&l.dir.join("cells.csv"))?);
    }
    create_dir_all(dest)?;
    crate::cells::write_cells_atomic(&dest.join("cells.csv"), &all)?;
    let design = DesignLabel::new(file, status.clone());
    crate::run::finish_combined(design, study, dest, levels, notes)
}
