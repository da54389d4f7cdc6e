//! `draws per seed`: every seed a level of its own, with the draw that
//! `factor draw` numbers after it, and the seeds' cells analysed together
//! as one crossed recording x seed study whose seed component carries the
//! draw variance. In a single design the levels are `out/draw-K` and the
//! study's cells and report are `out/cells.csv` and `out/report`; in a
//! multiverse each specification's seeds are `out/spec-ID/draw-K`, its
//! cells and report `out/spec-ID/cells.csv` and `out/spec-ID/report`, and
//! the specification is one unit of the multiverse analysis.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::Instant;

use super::{run_dir, Level, Outer};
use crate::analysis::FileAnalysisError;
use crate::analysis::StudyAnalysis;
use crate::cells::{read_cells, Cell};
use crate::design::{DesignFile, LockStatus};
use crate::io::create_dir_all;
use crate::plan::Plan;
use crate::run::{RunError, RunOutcome, RunRecord};

/// After every seed's level of a `draws per seed` study finished: their
/// cells in one `dest/cells.csv` (seed order), the design's own analysis
/// of them (the crossed recording x seed estimator, whose seed component
/// now carries the draw variance) and its report in `dest/report`.
/// `dirs` holds each level's folder (another's, where it shares a run).
pub(crate) fn finish_per_seed(
    file: &DesignFile,
    study: &Plan,
    levels: &[Level],
    out: &Path,
    (status, exploratory, record): (&LockStatus, bool, &RunRecord),
    builds: BTreeSet<String>,
    notes: &[String],
) -> Result<RunOutcome, RunError> {
    let dirs: Vec<PathBuf> = levels.iter().map(|l| out.join(&l.id)).collect();
    finish_seeds(file, study, (levels, &dirs), out, (status, exploratory, record), (builds, notes))
}

/// Each specification of a multiverse with per-seed draws, finished as
/// [`finish_per_seed`] finishes a single design, in `out/spec-ID`.
pub(crate) fn finish_specs(
    file: &DesignFile,
    outer: &Outer,
    out: &Path,
    run: (&LockStatus, bool, &RunRecord),
    builds: BTreeSet<String>,
) -> Result<(), RunError> {
    let levels = &outer.levels;
    for u in &outer.units {
        let members: Vec<Level> = u.members.iter().map(|&k| levels[k].clone()).collect();
        let dirs: Vec<PathBuf> = u.members.iter().map(|&k| run_dir(out, levels, k)).collect();
        let finished = finish_seeds(file, &u.plan, (&members, &dirs), &out.join(&u.id), run, (builds.clone(), &[]));
        finished.map_err(|e| RunError::InLevel { level: u.id.clone(), source: Box::new(e) })?;
    }
    Ok(())
}

fn finish_seeds(
    file: &DesignFile,
    study: &Plan,
    (levels, dirs): (&[Level], &[PathBuf]),
    dest: &Path,
    (status, exploratory, record): (&LockStatus, bool, &RunRecord),
    (builds, notes): (BTreeSet<String>, &[String]),
) -> Result<RunOutcome, RunError> {
    let started = Instant::now();
    let mut all: Vec<Cell> = Vec::new();
    let mut curves = Vec::new();
    for (l, dir) in levels.iter().zip(dirs) {
        all.extend(read_cells(&dir.join("cells.csv"))?);
        curves.extend(crate::run::curves::read_curves(&l.plan, dir)?);
    }
    create_dir_all(dest)?;
    let cells_csv = dest.join("cells.csv");
    crate::cells::write_cells_atomic(&cells_csv, &all)?;
    let seeds: Vec<String> = levels
        .iter()
        .map(|l| format!("seed {} draw {}", l.design.seeds.first().map(|s| s.0).unwrap_or(0), l.draw.unwrap_or(1)))
        .collect();
    let note = format!(
        "draws per seed: each seed trained and was evaluated on its own draw of the validation, fit and contamination windows (the evaluation recordings fixed), so the seed component carries the draw variance; {} (each in its folder draw-K)",
        seeds.join(", ")
    );
    let draws: Vec<(u64, PathBuf)> = levels.iter().zip(dirs).map(|(l, d)| (l.draw.unwrap_or(1), d.clone())).collect();
    if !study.doses.is_empty() {
        // A dose-response family: each dose's contrast and the trend, over
        // the seeds' own draws.
        let path = file.path.display().to_string();
        let labels = (status, exploratory, record);
        return crate::run::report_family(&path, study, dest, cells_csv, labels, builds, |a| {
            a.warnings.push(note);
            a.warnings.extend(super::notes::invariant_warnings(&draws));
            a.warnings.extend(notes.iter().cloned());
            a.coverage = crate::run::coverage::note_of_levels(study, dirs);
            a.sources = crate::run::coverage::distance_sources(study, dirs);
            a.treatment = crate::run::coverage::treatment_over_levels(study, dirs);
            if !a.treatment.is_empty() {
                a.warnings.push(format!(
                    "treatment strength: each value is the median over the {} draws of that draw's own (each draw's audit/treatment.json)",
                    dirs.len()
                ));
            }
        });
    }
    let mut analysis =
        crate::analysis::analyze(study, &all, Default::default()).map_err(|e| FileAnalysisError::new(&cells_csv, e))?;
    analysis.record_design(&file.path.display().to_string(), &record.design_sha256, status);
    if exploratory {
        analysis.mark_exploratory();
    }
    analysis.record_cells(Path::new("cells.csv"), &crate::cells::file_sha256(&cells_csv)?);
    analysis.record_provenance(&record.data.describe(), &record.audit_sha256);
    analysis.warnings.push(note);
    analysis.warnings.extend(super::notes::invariant_warnings(&draws));
    analysis.coverage = crate::run::coverage::statement_of_levels(study, &all, dirs);
    analysis.warnings.extend(crate::run::resumed_builds(builds));
    analysis.warnings.extend(notes.iter().cloned());
    if let Some(w) = crate::run::curves::early_best_epochs(study, &curves, &all) {
        analysis.warnings.push(w);
    }
    let report_dir = dest.join("report");
    analysis.curves = curves;
    let mut analysis = StudyAnalysis::Single(Box::new(analysis));
    crate::report::write_study(&mut analysis, &report_dir)?;
    Ok(RunOutcome { cells_csv, report_dir, analysis, trained: 0, skipped: 0, seconds: started.elapsed().as_secs_f64() })
}
