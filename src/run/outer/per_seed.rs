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

use super::{level_plan, run_dir, Level};
use crate::analysis::FileAnalysisError;
use crate::cells::{read_cells, Cell};
use crate::design::{Design, DesignFile, LockStatus};
use crate::io::create_dir_all;
use crate::plan::Plan;
use crate::run::{RunError, RunOutcome, RunRecord, StudyAnalysis};

/// What the multiverse analysis treats as one level: a level, or under
/// per-seed draws a specification's seed levels together.
#[derive(Debug, Clone)]
pub(super) struct Unit {
    /// Its folder (`spec-s1`, `draw-2`, `spec-s1_draw-2`).
    pub id: String,
    pub spec: Option<usize>,
    pub draw: Option<u64>,
    /// The unit whose cells it shares, if it trained nothing of its own.
    pub shares: Option<String>,
    /// Its levels, by index.
    pub members: Vec<usize>,
    /// The design it analyses as one study.
    pub design: Design,
}

/// The analysis units of `levels`: each level its own, except that under
/// per-seed draws in a multiverse a specification's seeds form one.
pub(super) fn units(design: &Design, levels: &[Level]) -> Vec<Unit> {
    let (Some(m), true) = (&design.multiverse, design.per_seed_draws) else {
        return levels
            .iter()
            .enumerate()
            .map(|(k, l)| Unit {
                id: l.id.clone(),
                spec: l.spec,
                draw: l.draw,
                shares: l.shares.map(|s| levels[s].id.clone()),
                members: vec![k],
                design: l.design.clone(),
            })
            .collect();
    };
    let unit_id = |s: usize| format!("spec-{}", m.specs[s].id);
    m.specs
        .iter()
        .enumerate()
        .map(|(s, spec)| {
            let members: Vec<usize> = (0..levels.len()).filter(|&k| levels[k].spec == Some(s)).collect();
            // It shares a specification's cells when each of its seeds does.
            let shared: Vec<Option<usize>> =
                members.iter().map(|&k| levels[k].shares.and_then(|o| levels[o].spec)).collect();
            let shares = match shared.first() {
                Some(Some(o)) if shared.iter().all(|x| *x == Some(*o)) => Some(unit_id(*o)),
                _ => None,
            };
            let mut d = (*spec.design).clone();
            d.multiverse = None;
            d.per_seed_draws = false;
            Unit { id: unit_id(s), spec: Some(s), draw: None, shares, members, design: d }
        })
        .collect()
}

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
    levels: &[Level],
    out: &Path,
    run: (&LockStatus, bool, &RunRecord),
    builds: BTreeSet<String>,
) -> Result<(), RunError> {
    for u in units(&file.design, levels) {
        let members: Vec<Level> = u.members.iter().map(|&k| levels[k].clone()).collect();
        let dirs: Vec<PathBuf> = u.members.iter().map(|&k| run_dir(out, levels, k)).collect();
        let plan = crate::plan::compile(&u.design);
        let finished = finish_seeds(file, &plan, (&members, &dirs), &out.join(&u.id), run, (builds.clone(), &[]));
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
        curves.extend(crate::run::curves::read_curves(&level_plan(l, study), dir)?);
    }
    create_dir_all(dest)?;
    let cells_csv = dest.join("cells.csv");
    crate::cells::write_cells_atomic(&cells_csv, &all)?;
    let mut analysis =
        crate::analysis::analyze(study, &all, Default::default()).map_err(|e| FileAnalysisError::new(&cells_csv, e))?;
    analysis.record_design(&file.path.display().to_string(), &record.design_sha256, status);
    if exploratory {
        analysis.mark_exploratory();
    }
    analysis.record_cells(Path::new("cells.csv"), &crate::cells::file_sha256(&cells_csv)?);
    analysis.record_provenance(&record.data.describe(), &record.audit_sha256);
    let seeds: Vec<String> = levels
        .iter()
        .map(|l| format!("seed {} draw {}", l.design.seeds.first().map(|s| s.0).unwrap_or(0), l.draw.unwrap_or(1)))
        .collect();
    analysis.warnings.push(format!(
        "draws per seed: each seed trained and was evaluated on its own draw of the validation, fit and contamination windows (the evaluation recordings fixed), so the seed component carries the draw variance; {} (each in its folder draw-K)",
        seeds.join(", ")
    ));
    let draws: Vec<(u64, PathBuf)> = levels.iter().zip(dirs).map(|(l, d)| (l.draw.unwrap_or(1), d.clone())).collect();
    analysis.warnings.extend(super::notes::invariant_warnings(&draws));
    analysis.coverage = crate::run::coverage::statement_of_levels(study, &all, dirs);
    analysis.warnings.extend(crate::run::resumed_builds(builds));
    analysis.warnings.extend(notes.iter().cloned());
    if let Some(w) = crate::run::curves::early_best_epochs(study, &curves, &all) {
        analysis.warnings.push(w);
    }
    let report_dir = dest.join("report");
    create_dir_all(&report_dir)?;
    let figures = crate::report::figures::write_figures(&analysis, &curves, &report_dir)
        .map_err(crate::report::ReportError::from)?;
    let svgs = crate::report::figures::by_name(figures);
    analysis.figures = svgs.iter().map(|(name, _)| name.clone()).collect();
    crate::report::write_all_with(&analysis, &report_dir, &svgs)?;
    Ok(RunOutcome {
        cells_csv,
        report_dir,
        analysis: StudyAnalysis::Single(Box::new(analysis)),
        trained: 0,
        skipped: 0,
        seconds: started.elapsed().as_secs_f64(),
    })
}
