//! The one reader of what an analysis reads: a per-cell file, a run
//! folder (of a study of one run or of several level folders) or a folder
//! `crossaudit combine` wrote, each turned into one typed
//! [`Record`] by the readers of `read` and `combine`.

use std::path::Path;

use super::combine::{read_combined, CombinedRecord};
use super::read::{folder_record, levels_record, read_folder, read_levels, LevelFolder};
use super::{RunError, RunRecord, StudyRecord};
use crate::analysis::record::{DesignLabel, Record};
use crate::cells::{last_line_open, read_cells_hashed};
use crate::design::{lock, DesignFile};
use crate::plan::study::LevelRole;
use crate::plan::StudyPlan;

/// The record of `cells` for the design `file` compiled as `plan`: a run
/// folder (its `cells.csv` and its evidence), a run's own `cells.csv`
/// (read with its folder's evidence when the folder's run.json records
/// this design and this file's hash), or any other per-cell file alone.
pub fn read_record(file: &DesignFile, study: &StudyPlan, cells: &Path) -> Result<Record, RunError> {
    let plan = &study.plan;
    let design = DesignLabel::new(file, lock::status(file)?);
    let outer = study.outer.as_ref().filter(|o| matches!(o.role, LevelRole::PerSeed | LevelRole::Redraw));
    if cells.is_dir() && cells.join("combined.json").exists() {
        return read_combined(design, study, cells);
    }
    if cells.is_dir() {
        return match outer {
            Some(o) => read_levels(design, cells, &LevelFolder::of(o, cells)),
            None => read_folder(design, plan, cells),
        };
    }
    // Hashed as it is read: the hash is of the bytes the rows came from.
    let (rows, sha) = read_cells_hashed(cells)?;
    let shown = cells.display().to_string();
    let beside = cells.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    refuse_edited(cells, beside, &file.sha256, &sha)?;
    let combined = cells.file_name().is_some_and(|n| n == "cells.csv")
        && matches!(CombinedRecord::read(beside), Ok(Some(r)) if r.design_sha256 == file.sha256 && r.cells_sha256 == sha);
    if combined {
        let mut record = read_combined(design, study, beside)?;
        (record.cells_file.0, record.cells_path) = (shown, cells.to_path_buf());
        return Ok(record);
    }
    if let Some(o) = outer {
        // A study's own combined cells.csv: read with its level folders.
        let own = cells.file_name().is_some_and(|n| n == "cells.csv")
            && matches!(StudyRecord::read(beside), Ok(Some(r)) if r.design_sha256 == file.sha256 && r.cells_sha256 == sha);
        if own {
            let mut record = levels_record(design, beside, &LevelFolder::of(o, beside), (rows, sha))?;
            (record.cells_file.0, record.cells_path) = (shown, cells.to_path_buf());
            return Ok(record);
        }
        return Ok(Record {
            design,
            cells: rows,
            cells_path: cells.to_path_buf(),
            cells_file: (shown, sha),
            run: None,
            last_line_open: last_line_open(cells)?,
        });
    }
    let own = cells.file_name().is_some_and(|n| n == "cells.csv")
        && matches!(RunRecord::read(beside), Ok(Some(r)) if r.design_sha256 == file.sha256 && r.cells_sha256.as_deref() == Some(&sha));
    if own {
        let mut record = folder_record(design, plan, beside, (rows, sha))?;
        (record.cells_file.0, record.cells_path) = (shown, cells.to_path_buf());
        return Ok(record);
    }
    let last_line_open = last_line_open(cells)?;
    Ok(Record {
        design,
        cells: rows,
        cells_path: cells.to_path_buf(),
        cells_file: (shown, sha),
        run: None,
        last_line_open,
    })
}

/// A run's own `cells.csv` (so named, beside the run.json, study.json or
/// combined.json of a run of this design, whose sha256 it records) that
/// is not the file the run recorded: refused, as its folder is, not read
/// as a per-cell file of its own and labelled with the run's standing.
fn refuse_edited(cells: &Path, beside: &Path, design_sha256: &str, sha: &str) -> Result<(), RunError> {
    if cells.file_name().is_none_or(|n| n != "cells.csv") {
        return Ok(());
    }
    // A record beside it edited since the run wrote it vouches for nothing.
    let (combined, study, run) = (
        vouching(CombinedRecord::read(beside))?,
        vouching(StudyRecord::read(beside))?,
        vouching(RunRecord::read(beside))?,
    );
    let recorded = if let Some(r) = combined {
        (r.design_sha256 == design_sha256).then_some((r.cells_sha256, "combined.json"))
    } else if let Some(r) = study {
        (r.design_sha256 == design_sha256).then_some((r.cells_sha256, "study.json"))
    } else if let Some(r) = run {
        r.cells_sha256.filter(|_| r.design_sha256 == design_sha256).map(|c| (c, "run.json"))
    } else {
        None
    };
    match recorded {
        Some((want, record)) if want != sha => Err(RunError::LevelChanged {
            dir: beside.display().to_string(),
            reason: format!(
                "{} has sha256 {sha}, but the run recorded {want} in {record}: it was edited after the run (to analyse the edited file as a per-cell file of its own, copy it out of the run's folder)",
                cells.display()
            ),
        }),
        _ => Ok(()),
    }
}

/// A record beside a per-cell file, where readable: one edited since its
/// run wrote it is refused; one unreadable otherwise vouches for nothing.
fn vouching<T>(read: Result<Option<T>, RunError>) -> Result<Option<T>, RunError> {
    match read {
        Err(e @ RunError::RecordEdited { .. }) => Err(e),
        read => Ok(read.ok().flatten()),
    }
}
