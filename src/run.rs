//! `run`: a locked design from raw logs to decision. Audit, manifests and
//! invariants, then the grid of training cells on N workers (each a
//! single-threaded rayon pool), then cells.csv and the analysis.
//!
//! A cell's per-cell CSV is written atomically when it finishes and marks it
//! done; a rerun on the same directory verifies the design hash and the
//! manifests and skips finished cells. Each cell depends only on the design,
//! the data and its seed, so results do not depend on the number of workers
//! or on interruptions.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::cell::{run_cell, CellOutcome};
use crate::cells::{read_cells, write_cells, Cell};
use crate::design::{lock, DesignFile, LockStatus};
use crate::model::EpochLog;
use crate::pipeline::{self, TrainingCell};
use crate::{Error, SplitOutcome};

#[derive(Debug, Clone, Copy)]
pub struct RunOptions {
    pub workers: usize,
    /// Run a design that changed after locking, labelling every output.
    pub exploratory: bool,
}

/// What a run reports while it works. Called from worker threads.
pub trait RunObserver: Sync {
    fn start(&self, _total: usize, _already_done: usize) {}
    fn cell_started(&self, _worker: usize, _cell: &TrainingCell) {}
    fn epoch(&self, _worker: usize, _cell: &TrainingCell, _log: &EpochLog) {}
    fn cell_finished(&self, _worker: usize, _cell: &TrainingCell, _outcome: &CellOutcome, _seconds: f64) {}
}

/// An observer that reports nothing.
pub struct Quiet;
impl RunObserver for Quiet {}

/// run.json: what a run directory holds, checked on resume.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    pub study: String,
    pub design_sha256: String,
    pub manifests_sha256: String,
    pub exploratory: bool,
}

#[derive(Debug, Clone)]
pub struct RunOutcome {
    pub cells_csv: PathBuf,
    pub report_dir: PathBuf,
    pub analysis: crate::Analysis,
    pub trained: usize,
    pub skipped: usize,
    pub seconds: f64,
}

pub fn cell_stem(c: &TrainingCell) -> String {
    format!("{}__{}__{}", c.model, c.arm, c.seed.0)
}

/// Runs (or resumes) the whole study into `out`.
pub fn run(
    file: &DesignFile,
    data_dir: &Path,
    out: &Path,
    options: RunOptions,
    observer: &dyn RunObserver,
) -> Result<RunOutcome, Error> {
    let started = Instant::now();
    let status = lock::status(&file.path, &file.sha256)?;
    let exploratory = match status {
        LockStatus::LockedChanged { .. } if !options.exploratory => {
            return Err(Error::Cell(format!(
                "{} changed after it was locked; rerun with --exploratory to label every output EXPLORATORY, or lock an amended design",
                file.path.display()
            )))
        }
        LockStatus::LockedChanged { .. } => true,
        _ => options.exploratory,
    };
    std::fs::create_dir_all(out).map_err(|e| Error::Cell(format!("cannot create {}: {e}", out.display())))?;
    let record_path = out.join("run.json");
    let previous: Option<RunRecord> =
        std::fs::read_to_string(&record_path).ok().and_then(|t| serde_json::from_str(&t).ok());
    if let Some(p) = &previous {
        if p.design_sha256 != file.sha256 {
            return Err(Error::Cell(format!(
                "{} holds a run of a different design (sha256 {}); use a new output directory",
                out.display(),
                p.design_sha256
            )));
        }
    }
    let split = crate::split_stage(file, data_dir, out)?;
    let manifests_sha256 = crate::design::lock::sha256_hex(split.manifests.to_json().as_bytes());
    if let Some(p) = &previous {
        if p.manifests_sha256 != manifests_sha256 {
            return Err(Error::Cell(format!(
                "the manifests differ from those of the run in {} (the data changed?); use a new output directory",
                out.display()
            )));
        }
    }
    let record = RunRecord {
        study: file.design.study.clone(),
        design_sha256: file.sha256.clone(),
        manifests_sha256,
        exploratory,
    };
    crate::report::write_atomic(&record_path, serde_json::to_string_pretty(&record).unwrap_or_default().as_bytes())?;

    let plan = pipeline::compile(&file.design);
    let done = |c: &TrainingCell| out.join("cells").join(format!("{}.csv", cell_stem(c))).exists();
    let todo: VecDeque<TrainingCell> = plan.training_cells.iter().filter(|c| !done(c)).cloned().collect();
    let skipped = plan.training_cells.len() - todo.len();
    observer.start(plan.training_cells.len(), skipped);
    let trained = todo.len();
    run_grid(file, &split, out, todo, options.workers.max(1), observer)?;

    // cells.csv: every cell's rows in plan order.
    let mut all: Vec<Cell> = Vec::new();
    for c in &plan.training_cells {
        all.extend(read_cells(&out.join("cells").join(format!("{}.csv", cell_stem(c))))?);
    }
    check_baselines(file, &all)?;
    let cells_csv = out.join("cells.csv");
    let tmp = out.join("cells.csv.tmp");
    write_cells(&tmp, &all)?;
    std::fs::rename(&tmp, &cells_csv).map_err(|e| Error::Cell(format!("cannot write {}: {e}", cells_csv.display())))?;

    let mut analysis = crate::analyze_files(&file.path, &cells_csv, Default::default())?;
    analysis.exploratory |= exploratory;
    if status == LockStatus::Unlocked {
        analysis.warnings.push(format!(
            "{} was not locked before this run: lock a design (`crossaudit lock`) to preregister it",
            file.path.display()
        ));
    }
    let report_dir = out.join("report");
    std::fs::create_dir_all(&report_dir)
        .map_err(|e| Error::Cell(format!("cannot create {}: {e}", report_dir.display())))?;
    let figures = crate::report::figures::write_figures(&analysis, out, &report_dir)?;
    analysis.figures = figures.iter().filter_map(|p| p.file_name().map(|f| f.to_string_lossy().into_owned())).collect();
    crate::report::write_all(&analysis, &report_dir)?;
    Ok(RunOutcome { cells_csv, report_dir, analysis, trained, skipped, seconds: started.elapsed().as_secs_f64() })
}

fn run_grid(
    file: &DesignFile,
    split: &SplitOutcome,
    out: &Path,
    todo: VecDeque<TrainingCell>,
    workers: usize,
    observer: &dyn RunObserver,
) -> Result<(), Error> {
    let queue = Mutex::new(todo);
    let first_error: Mutex<Option<Error>> = Mutex::new(None);
    std::thread::scope(|scope| {
        for worker in 0..workers {
            let (queue, first_error) = (&queue, &first_error);
            scope.spawn(move || {
                // One thread per worker: dfdx's matmuls run on the current
                // rayon pool.
                let pool = match rayon::ThreadPoolBuilder::new().num_threads(1).build() {
                    Ok(p) => p,
                    Err(e) => {
                        *first_error.lock().unwrap_or_else(|p| p.into_inner()) =
                            Some(Error::Cell(format!("worker pool: {e}")));
                        return;
                    }
                };
                loop {
                    if first_error.lock().map(|e| e.is_some()).unwrap_or(true) {
                        return;
                    }
                    let Some(cell) = queue.lock().ok().and_then(|mut q| q.pop_front()) else { return };
                    observer.cell_started(worker, &cell);
                    let t0 = Instant::now();
                    let result = pool.install(|| {
                        run_cell(file, split, &cell.model, &cell.arm, cell.seed.0, out, &mut |log| {
                            observer.epoch(worker, &cell, log)
                        })
                    });
                    match result {
                        Ok(o) => observer.cell_finished(worker, &cell, &o, t0.elapsed().as_secs_f64()),
                        Err(e) => {
                            if let Ok(mut slot) = first_error.lock() {
                                slot.get_or_insert(e);
                            }
                            return;
                        }
                    }
                }
            });
        }
    });
    match first_error.into_inner().unwrap_or(None) {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Parameter-free models fit nothing split-dependent: their rows must be
/// identical across arms.
fn check_baselines(file: &DesignFile, cells: &[Cell]) -> Result<(), Error> {
    for m in file.design.models.iter().filter(|m| !m.kind.trains()) {
        let rows = |arm: &str| -> Vec<(u64, String, u64, String)> {
            cells
                .iter()
                .filter(|c| c.model == m.name && c.arm == arm)
                .map(|c| {
                    (
                        c.seed,
                        c.recording.clone(),
                        c.horizon_s.to_bits(),
                        format!("{:?}", (c.fa_position_rmse_m, c.conditional_position_rmse_m, c.n_divergent)),
                    )
                })
                .collect()
        };
        let arms: Vec<&str> = file.design.arms.iter().map(|a| a.name.as_str()).collect();
        for w in arms.windows(2) {
            if rows(w[0]) != rows(w[1]) {
                return Err(Error::Cell(format!(
                    "parameter-free model `{}` scored differently on arms `{}` and `{}`: its rollouts depend on the arm, which they must not",
                    m.name, w[0], w[1]
                )));
            }
        }
    }
    Ok(())
}
