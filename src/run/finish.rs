//! Everything after a run's last job: the invariants on what the jobs
//! recorded, the cells gathered, and the folder read back as a record,
//! analysed and reported (a study of one run: `finish`; of several level
//! folders: `finish_combined`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::gathered::gathered;
use super::open::{Opened, RunOutcome};
use super::{read, trained_invariants, LevelFolder, RunError, RunRecord, StudyRecord};
use crate::analysis;
use crate::cells::{read_cells, write_cells_and_parquet, Cell};
use crate::plan::study::Outer;
use crate::plan::Plan;

/// After every split finished: `out/cells.csv` with a `split` column, then
/// the folder finished as [`finish_combined`] finishes it (the family
/// analysis in `out/report`).
pub(crate) fn finish_splits(
    design: analysis::record::DesignLabel,
    plan: &Plan,
    outer: &Outer,
    out: &Path,
    notes: &[String],
) -> Result<RunOutcome, RunError> {
    let started = Instant::now();
    let levels = LevelFolder::of(outer, out);
    let mut all: Vec<Cell> = Vec::new();
    for (l, level) in levels.iter().zip(&outer.levels) {
        let split = level.split;
        all.extend(read_cells(&l.dir.join("cells.csv"))?.into_iter().map(|c| Cell { split, ..c }));
    }
    write_cells_and_parquet(&out.join("cells.csv"), &all)?;
    let mut outcome = finish_combined(design, plan, out, &levels, notes)?;
    outcome.seconds = started.elapsed().as_secs_f64();
    Ok(outcome)
}

/// The folder `dir` of a study of several level folders `levels`, once its
/// combined `cells.csv` is written: `study.json` (the levels, the cells'
/// hash, the run's `notes`), then the folder read back as a record,
/// analysed and reported in `dir/report`, exactly as `crossaudit analyze
/// DESIGN --cells DIR` does.
pub(crate) fn finish_combined(
    design: analysis::record::DesignLabel,
    plan: &Plan,
    dir: &Path,
    levels: &[LevelFolder],
    notes: &[String],
) -> Result<RunOutcome, RunError> {
    let started = Instant::now();
    let cells_csv = dir.join("cells.csv");
    StudyRecord {
        study: plan.study.clone(),
        design_sha256: design.sha256.clone(),
        crossaudit: crate::io::BUILD.to_string(),
        levels: levels.iter().map(|l| l.id.clone()).collect(),
        cells_sha256: crate::cells::file_sha256(&cells_csv)?,
        notes: notes.to_vec(),
        shared: Vec::new(),
    }
    .write(dir)?;
    let record = read::read_levels(design, dir, levels)?;
    report(plan, &record, dir, cells_csv, started)
}

/// Everything after the last job: the invariants on what the jobs recorded,
/// cells.csv (with the builds that trained it and the run's notes in
/// run.json), then the folder read back as a record, analysed and
/// reported, exactly as `crossaudit analyze DESIGN --cells OUT` does.
/// `design_path` is the design as the user named it (the report quotes
/// it); `builds` are the builds that trained cells.
pub(crate) fn finish(
    design: analysis::record::DesignLabel,
    plan: &Plan,
    opened: &Opened,
    out: &Path,
    builds: std::collections::BTreeSet<String>,
) -> Result<RunOutcome, RunError> {
    let started = Instant::now();
    let cells_csv = gather_recorded(plan, opened, out, &builds)?;
    let record = read::read_folder(design, plan, out)?;
    report(plan, &record, out, cells_csv, started)
}

/// The record of the run folder `dir` analysed and its report written in
/// `dir/report`: the last step of every finish.
fn report(
    plan: &Plan,
    record: &analysis::record::Record,
    dir: &Path,
    cells_csv: PathBuf,
    started: Instant,
) -> Result<RunOutcome, RunError> {
    let analysis = analysis::analyze_study(plan, record, Default::default())?;
    let report_dir = dir.join("report");
    crate::report::write_study(&analysis, &report_dir)?;
    Ok(RunOutcome {
        cells_csv,
        report_dir,
        analysis,
        trained: 0,
        skipped: plan.jobs.len(),
        copied: 0,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// cells.csv: every job's rows in plan order, written atomically.
fn gather(plan: &Plan, out: &Path) -> Result<PathBuf, RunError> {
    let all = gathered(plan, out)?;
    let cells_csv = out.join("cells.csv");
    write_cells_and_parquet(&cells_csv, &all)?;
    Ok(cells_csv)
}

/// The invariants on what the jobs recorded, then `cells.csv` gathered and
/// its hash recorded in `run.json`, with the builds other than this one
/// among `builds` (those that trained cells) and the run's notes.
pub(crate) fn gather_recorded(
    plan: &Plan,
    opened: &Opened,
    out: &Path,
    builds: &std::collections::BTreeSet<String>,
) -> Result<PathBuf, RunError> {
    trained_invariants::check(plan, &opened.prepared, out)?;
    let cells_csv = gather(plan, out)?;
    let sha = crate::cells::file_sha256(&cells_csv)?;
    let resumed_from = builds.iter().filter(|b| *b != crate::io::BUILD).cloned().collect();
    let notes = opened.notes.clone();
    RunRecord { cells_sha256: Some(sha), resumed_from, notes, ..opened.record.clone() }.write(out)?;
    Ok(cells_csv)
}
