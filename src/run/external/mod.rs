//! Models fitted outside crossaudit: `crossaudit export` and `crossaudit
//! score`.
//!
//! [`export`] opens a run directory exactly as `run` does (lock, audit,
//! split, manifests, invariants, `run.json`), then writes `DIR/export/`:
//! what a user's training code needs for every external job, as float64
//! `.npy` arrays indexed by `export.json`:
//!
//! - per arm, its fit windows and the shared validation windows: states
//!   x_t, actions u_t, next states x_{t+1}; per external model, the inputs
//!   in its declared map and the targets, through the standardizers a
//!   built-in MLP would fit on that arm (recorded in the index); with
//!   `history N`, the N samples (state and action) before every window;
//! - the registered starts: initial states, the measured actions of every
//!   step, the measured exogenous components (reference, battery) the
//!   rollout overwrites after every step, and histories. Nothing else of
//!   the evaluation recordings.
//!
//! `score::score` rebuilds the export from the design and the data,
//! refuses any file that differs, reads `predictions/MODEL__ARM__SEED.npy`
//! (starts x steps x 14 state columns, float64, C order) with its
//! description `predictions/MODEL__ARM__SEED.json`, and scores every
//! trajectory with the code the built-in rollouts use
//! ([`crate::rollout::replay`]), then runs the built-in models and writes
//! cells.csv, the analysis and the report as `run` does.

mod format;
mod levels;
pub mod npy;
pub mod score;

use std::path::{Path, PathBuf};

use super::{open, Data, RunError};
use crate::design::DesignFile;

use format::write_export;
pub use format::{
    build, check_exportable, external_jobs, external_names, Built, ExportIndex, ExportJob, ExportOutcome, ExportSource,
    ACTION_COLUMNS, EXPORT_DIR, FORMAT, PREDICTIONS_DIR, STATE_COLUMNS,
};
pub use levels::{notes_for, score_predictions_in, LevelExport, LevelsIndex, LEVELS_FILE};
pub use score::ScoreOutcome;

/// `crossaudit export DESIGN [--data DIR] --out OUT` as the command line and
/// the Python package make it: the design checked and `out` refused if it
/// holds another design's run, both before anything is written (simulated
/// data included), the folder locked, the data found, then [`export`].
pub fn export_into(
    file: &DesignFile,
    study: &crate::plan::StudyPlan,
    data: Option<PathBuf>,
    out: &Path,
    exploratory: bool,
) -> Result<ExportOutcome, RunError> {
    check_exportable(file, &study.plan)?;
    super::check_lock(file, exploratory)?;
    super::check_out_plan(out, &study.plan, &file.sha256)?;
    let _lock = super::lock_folder(out, false)?;
    let data = super::data_dir(&file.design, &file.path, data, out)?;
    export(file, study, &data, out, exploratory)
}

/// `crossaudit export`: opens `out` as `run` does, then writes the export
/// (arrays first, `source.json`, the design copy, `export.json` last, each
/// atomically). Exporting again into the same directory rewrites the same
/// bytes; a directory of another design or other data is refused.
pub fn export(
    file: &DesignFile,
    study: &crate::plan::StudyPlan,
    data: &Data,
    out: &Path,
    exploratory: bool,
) -> Result<ExportOutcome, RunError> {
    let plan = &study.plan;
    check_exportable(file, plan)?;
    if let Some(outer) = &study.outer {
        return levels::export_levels(file, &outer.levels, data, out, exploratory);
    }
    let opened = open(file, plan, data, out, exploratory, None)?;
    write_export(file, plan, &opened.prepared, data, out, None)
}

/// Scores the predictions in `dir/predictions`, runs the design's
/// built-in models on `workers` workers, and writes cells.csv and the
/// report: of one run, or of every level of a study exported level by
/// level (`export/levels.json`). Predictions of every present job are
/// scored and kept even when others are missing; then the missing ones are
/// named (nothing else is run until all are there). `say` gets one line
/// per job scored.
pub fn score(
    dir: &Path,
    workers: usize,
    observer: &dyn super::RunObserver,
    say: &mut dyn FnMut(&str),
) -> Result<ScoreOutcome, RunError> {
    let started = std::time::Instant::now();
    crate::run::check_workers(workers)?;
    if dir.join(EXPORT_DIR).join(LEVELS_FILE).is_file() {
        return levels::score_levels(dir, workers, observer, say, started);
    }
    score::score_run(dir, workers, observer, say, started)
}
