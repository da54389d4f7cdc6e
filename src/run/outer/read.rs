//! The run folder of a multiverse or draw-replicated study read back as
//! one typed record ([`MultiverseRecord`]): every level folder verified
//! ([`super::verify::check_levels`]), each unit's cells and its levels'
//! evidence ([`crate::run::read::read_level`]), each level's run.json and
//! the study's own study.json. A run's finish and `crossaudit analyze
//! DESIGN --cells DIR` both read it here and analyse it with
//! [`crate::analysis::evidence::analyze_multiverse_record`].

use std::path::Path;

use super::verify::check_levels;
use super::{run_dir, Outer};
use crate::analysis::multiverse::{LevelInput, MultiverseAnalysis};
use crate::analysis::record::{DesignLabel, MultiverseRecord};
use crate::cells::{read_cells, Cell};
use crate::design::{Design, DesignFile};
use crate::run::read::{levels_evidence, read_each, LevelFolder};
use crate::run::{RunError, RunRecord, StudyRecord};

/// The record of the run folder `dir` of `file`'s multiverse or
/// draw-replicated study `outer`, analysed under `design`.
pub(crate) fn read_multiverse(
    design: DesignLabel,
    file: &DesignFile,
    outer: &Outer,
    dir: &Path,
) -> Result<MultiverseRecord, RunError> {
    let (levels, units) = (&outer.levels, &outer.units);
    let mut missing = check_levels(file, levels, dir)?;
    // Level files are read in parallel; the first error in level order is
    // the one reported.
    use rayon::prelude::*;
    let read: Vec<Result<Vec<Cell>, crate::cells::CellsError>> = units
        .par_iter()
        .map(|u| {
            let mut all = Vec::new();
            for &k in &u.members {
                all.extend(read_cells(&run_dir(dir, levels, k).join("cells.csv"))?);
            }
            Ok(all)
        })
        .collect();
    let cells: Vec<Vec<Cell>> = read.into_iter().collect::<Result<_, _>>()?;
    // Every unit's levels read as one list, so what several lack is said once.
    let folders: Vec<LevelFolder> = units
        .iter()
        .flat_map(|u| u.members.iter().map(|&k| LevelFolder::at(&levels[k], run_dir(dir, levels, k))))
        .map(|l| LevelFolder { strength: false, ..l })
        .collect();
    let mut evidence = read_each(&folders, &mut missing).into_iter();
    let out =
        units.iter().zip(cells).map(|(u, cells)| (cells, evidence.by_ref().take(u.members.len()).collect())).collect();
    let mut runs: Vec<RunRecord> = Vec::new();
    for k in (0..levels.len()).filter(|&k| levels[k].shares.is_none()) {
        runs.extend(RunRecord::read(&run_dir(dir, levels, k))?);
    }
    let study = StudyRecord::read(dir)?;
    match &study {
        Some(s) if s.design_sha256 != design.sha256 => {
            return Err(RunError::ran_other(dir.display().to_string(), s.design_sha256.clone(), &design))
        }
        Some(_) => {}
        None => missing.push(format!(
            "{} is absent (a folder written before it was recorded): the run's notes (jobs reused or copied, external models) and the evaluation recordings, starts and fit windows its specifications share not reported",
            dir.join("study.json").display()
        )),
    }
    let run = levels_evidence(&runs, study.as_ref(), missing);
    let shared = study.map(|s| s.shared).unwrap_or_default();
    Ok(MultiverseRecord { design, dir: dir.to_path_buf(), units: out, run, shared })
}

/// The combined analysis of a multiverse record: each unit's plan from
/// `outer`, its cells from the record.
pub(crate) fn analyze(
    design: &Design,
    outer: &Outer,
    record: &MultiverseRecord,
) -> Result<MultiverseAnalysis, RunError> {
    let inputs: Vec<LevelInput> = outer
        .units
        .iter()
        .zip(&record.units)
        .map(|(u, (cells, _))| LevelInput {
            id: u.id.clone(),
            spec: u.spec,
            draw: u.draw,
            shares: u.shares.clone(),
            plan: &u.plan,
            cells,
        })
        .collect();
    Ok(crate::analysis::evidence::analyze_multiverse_record(design, &inputs, record)?)
}
