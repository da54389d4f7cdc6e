//! What a reanalysis of a run directory checks before it reads a level.

use std::path::Path;

use super::{run_dir, Level};
use crate::design::DesignFile;
use crate::run::{RunError, RunRecord};

/// Before a reanalysis reads a run directory: every level folder it reads
/// must hold the run of this design (its run.json's design hash), of that
/// level (the level its run.json records, so swapped or renamed folders
/// are refused), and the cells that run gathered: with its job records,
/// each job's per-cell file unchanged since the job wrote it and cells.csv
/// exactly those files gathered; without them (a folder trimmed to its
/// per-cell data), cells.csv's hash as run.json recorded it. What cannot
/// be checked (a run written before levels and hashes were recorded) is
/// returned as warnings.
pub(super) fn check_levels(file: &DesignFile, levels: &[Level], dir: &Path) -> Result<Vec<String>, RunError> {
    // The levels are checked in parallel; the first error in level order
    // is the one reported, as when they were checked one by one.
    use rayon::prelude::*;
    let checked: Vec<Result<Vec<String>, RunError>> =
        (0..levels.len()).into_par_iter().map(|k| check_level(file, levels, k, dir)).collect();
    let mut unverified: Vec<String> = Vec::new();
    for c in checked {
        unverified.extend(c?);
    }
    Ok(if unverified.is_empty() {
        Vec::new()
    } else {
        vec![format!(
            "this run was written before crossaudit recorded each level's name and cells.csv hash: not verified for {}",
            unverified.join(", ")
        )]
    })
}

/// [`check_levels`] for level `k`: what of it cannot be checked.
fn check_level(file: &DesignFile, levels: &[Level], k: usize, dir: &Path) -> Result<Vec<String>, RunError> {
    let level = &levels[k];
    // A level that shares another's folder is checked there.
    if level.shares.is_some() {
        return Ok(Vec::new());
    }
    let mut unverified: Vec<String> = Vec::new();
    let d = run_dir(dir, levels, k);
    let changed = |reason: String| RunError::LevelChanged { dir: d.display().to_string(), reason };
    let Some(record) = RunRecord::read(&d)? else {
        return Err(changed(format!(
            "it has no run.json, so its cells.csv cannot be read as level {} of {}: not a level of a crossaudit run of this design",
            level.id,
            file.path.display()
        )));
    };
    if record.design_sha256 != file.sha256 {
        return Err(changed(format!(
            "it was run from design sha256 {}, but {} is sha256 {}: under an edited design (alternatives reordered, other values) its cells would be read as another specification's; reanalyse it with the design it ran",
            record.design_sha256,
            file.path.display(),
            file.sha256
        )));
    }
    match &record.level {
        Some(was) if *was != level.id => {
            return Err(RunError::WrongLevel { dir: d.display().to_string(), was: was.clone(), is: level.id.clone() })
        }
        Some(_) => {}
        None => unverified.push(format!("{} (which level it holds)", level.id)),
    }
    let cells_csv = d.join("cells.csv");
    let plan = &level.plan;
    if d.join("jobs").is_dir() {
        crate::run::gathered::check_gathered(plan, &d, &file.sha256)?;
    } else if let Some(sha) = &record.cells_sha256 {
        let now = crate::cells::file_sha256(&cells_csv)?;
        if now != *sha {
            return Err(changed(format!(
                "cells.csv has sha256 {now}, but the run recorded {sha} when it gathered it: it was edited after the run"
            )));
        }
    } else {
        unverified.push(format!("{} (its cells.csv: no job records and no recorded hash)", level.id));
    }
    Ok(unverified)
}
