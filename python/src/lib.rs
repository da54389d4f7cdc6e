//! `crossaudit._native`: the Python package's bridge to the library. Each
//! function makes the library call the command line makes and returns
//! plain values or JSON text; `crossaudit/__init__.py` turns them into
//! NumPy arrays and pandas DataFrames. Every library error is raised as
//! `CrossauditError` with the message the command line prints (a design
//! error with its file, line and column).

use std::path::{Path, PathBuf};

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    _native,
    CrossauditError,
    PyException,
    "An error crossaudit reports: bad input, a refused run or export, a failed check."
);

fn fail(e: impl Into<crossaudit::Error>) -> PyErr {
    let e: crossaudit::Error = e.into();
    let text = match &e {
        crossaudit::Error::Design(crossaudit::design::LoadError::Design(d)) => d.render(false),
        other => other.to_string(),
    };
    CrossauditError::new_err(text.trim_end().to_string())
}

fn json(v: &impl serde::Serialize) -> PyResult<String> {
    serde_json::to_string(v).map_err(|e| CrossauditError::new_err(e.to_string()))
}

/// Loads and validates a design; returns JSON with its path, SHA-256, lock
/// state, compiled plan (jobs, models, arms, seeds, endpoints), the plan
/// as `crossaudit check` prints it, and the validated design.
#[pyfunction]
fn load_design(path: PathBuf) -> PyResult<String> {
    let file = crossaudit::design::load(&path).map_err(fail)?;
    let status = crossaudit::design::lock::status(&file).map_err(fail)?;
    let study = crossaudit::compile_study(&file.design);
    let plan = &study.plan;
    json(&serde_json::json!({
        "path": path.display().to_string(),
        "sha256": file.sha256,
        "lock": status.label(),
        "plan": plan,
        "plan_text": plan.render_text(),
        "validated": file.design,
    }))
}

/// `crossaudit export DESIGN --out OUT`; returns the export's SHA-256.
#[pyfunction]
#[pyo3(signature = (design, out, data=None, exploratory=false))]
fn export(py: Python<'_>, design: PathBuf, out: PathBuf, data: Option<PathBuf>, exploratory: bool) -> PyResult<String> {
    py.detach(|| {
        let file = crossaudit::design::load(&design).map_err(fail)?;
        let study = crossaudit::compile_study(&file.design);
        let o = crossaudit::run::external::export_into(&file, &study, data, &out, exploratory).map_err(fail)?;
        Ok(o.sha256)
    })
}

/// `crossaudit score DIR`; returns JSON: cells.csv and report paths, the
/// decision line and whether it holds, jobs scored now and before, and
/// the non-finite trajectories per job.
#[pyfunction]
#[pyo3(signature = (dir, workers=None))]
fn score(py: Python<'_>, dir: PathBuf, workers: Option<usize>) -> PyResult<String> {
    let workers = workers.unwrap_or_else(|| std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1));
    let o = py.detach(|| {
        crossaudit::run::external::score(&dir, workers, &crossaudit::run::Quiet, &mut |_| {}).map_err(fail)
    })?;
    json(&serde_json::json!({
        "cells_csv": o.run.cells_csv,
        "report_dir": o.run.report_dir,
        "decision": crossaudit::report::study_decision_line(&o.run.analysis),
        "guards": crossaudit::report::study_guards(&o.run.analysis),
        "holds": o.run.analysis.holds(),
        "scored": o.scored,
        "resumed": o.resumed,
        "trained": o.run.trained,
        "non_finite": o.non_finite,
    }))
}

/// `crossaudit run DESIGN --out OUT` (the built-in models); returns JSON as
/// [`score`] does.
#[pyfunction]
#[pyo3(signature = (design, out, data=None, workers=None, exploratory=false, device="cpu"))]
fn run(
    py: Python<'_>,
    design: PathBuf,
    out: PathBuf,
    data: Option<PathBuf>,
    workers: Option<usize>,
    exploratory: bool,
    device: &str,
) -> PyResult<String> {
    let workers = workers.unwrap_or_else(|| std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1));
    let device_error = |e: String| fail(crossaudit::run::RunError::Device(e));
    let choice: crossaudit::model::DeviceChoice = device.parse().map_err(device_error)?;
    // `auto` says where it trains through a Python warning.
    let (device, said) = crossaudit::model::device::resolve(choice).map_err(|e| device_error(e.to_string()))?;
    if let Some(said) = said {
        let warn = py.import("warnings")?.getattr("warn")?;
        warn.call1((said,))?;
    }
    let o = py.detach(|| {
        let file = crossaudit::design::load(&design).map_err(fail)?;
        let study = crossaudit::compile_study(&file.design);
        let options = crossaudit::run::RunOptions { workers, exploratory, reuse: None, device };
        crossaudit::run::run_into(&file, &study, data, &out, options, &crossaudit::run::Quiet).map_err(fail)
    })?;
    json(&serde_json::json!({
        "cells_csv": o.cells_csv,
        "report_dir": o.report_dir,
        "decision": crossaudit::report::study_decision_line(&o.analysis),
        "guards": crossaudit::report::study_guards(&o.analysis),
        "holds": o.analysis.holds(),
        "trained": o.trained,
    }))
}

/// What [`analyze`] returns to the Python side: the analysis as JSON, the
/// decision line, whether the rule holds, the study's kind, its tidy table
/// as CSV text, and the guards beside the verdict.
type Analyzed = (String, String, bool, &'static str, String, Vec<String>);

/// `crossaudit analyze DESIGN --cells CELLS`: the preregistered analysis of
/// any study (a single contrast, a dose-response or multi-split family from
/// its per-cell CSV, or a multiverse or draw-replicated study from its run
/// directory); returns the analysis as JSON, the decision line, whether the
/// decision holds, the study's kind (`single`, `family`, `multiverse`) and
/// its tidy table as the report writes it (`estimates.csv`, or `specs.csv`
/// of a multiverse).
/// With `out`, the report is written there too, as the command writes it;
/// `compare_intervals` is the command's `--compare-intervals`.
#[pyfunction]
#[pyo3(signature = (design, cells, out=None, compare_intervals=false))]
fn analyze(
    py: Python<'_>,
    design: PathBuf,
    cells: PathBuf,
    out: Option<PathBuf>,
    compare_intervals: bool,
) -> PyResult<Analyzed> {
    py.detach(|| {
        let file = crossaudit::design::load(&design).map_err(fail)?;
        let study = crossaudit::compile_study(&file.design);
        let outer = study.combines_levels();
        let options = crossaudit::AnalyzeOptions { compare_intervals };
        let analysis = crossaudit::analyze_study(&file, &study, &cells, options).map_err(fail)?;
        if let Some(dir) = &out {
            crossaudit::run::check_output_dir(dir, &file.sha256).map_err(fail)?;
            // A run's own folders are written by the run alone.
            crossaudit::run::check_not_runs_own(dir, outer.then_some(cells.as_path())).map_err(fail)?;
            crossaudit::io::create_dir_all(dir).map_err(fail)?;
            crossaudit::report::write_study(&analysis, dir).map_err(fail)?;
        }
        let (line, table) =
            (crossaudit::report::study_decision_line(&analysis), crossaudit::report::study_table(&analysis));
        let guards = crossaudit::report::study_guards(&analysis);
        Ok((json(&analysis)?, line, analysis.holds(), analysis.kind(), table, guards))
    })
}

/// `crossaudit audit split SPLIT --data DATA --out OUT`; returns the paths
/// written (split_audit.json, split_audit.md, split_recordings.csv) and
/// whether exact leakage was found.
#[pyfunction]
#[pyo3(signature = (split, data, out, design=None, min_run=crossaudit::split_audit::DEFAULT_MIN_RUN_ROWS, gap=crossaudit::split_audit::DEFAULT_GAP_S))]
fn audit_split(
    py: Python<'_>,
    split: PathBuf,
    data: PathBuf,
    out: PathBuf,
    design: Option<PathBuf>,
    min_run: usize,
    gap: f64,
) -> PyResult<(Vec<PathBuf>, bool, bool)> {
    py.detach(|| {
        let published = crossaudit::published::read(&split).map_err(fail)?;
        let (spec, from) = match &design {
            Some(d) => {
                (crossaudit::design::load(d).map_err(fail)?.design.data, format!("data rules of {}", d.display()))
            }
            None => (crossaudit::design::DataSpec::upstream_task2(), "upstream NanoBench task-2 loader".to_string()),
        };
        if !Path::new(&data).is_dir() {
            return Err(fail(crossaudit::run::RunError::NoDataDir { dir: data.display().to_string() }));
        }
        crossaudit::run::check_out_dir(&data, &out).map_err(fail)?;
        let _lock = crossaudit::run::lock_folder(&out, false).map_err(fail)?;
        if !(gap.is_finite() && gap > 0.0) {
            return Err(CrossauditError::new_err(format!("gap {gap} is not a number of seconds above 0")));
        }
        let options = crossaudit::split_audit::AuditOptions { min_run_rows: min_run, gap_s: gap };
        let audit = crossaudit::split_audit::audit(&published, &spec, &from, &data, options).map_err(fail)?;
        let written = audit.write(&out).map_err(fail)?;
        Ok((written, audit.has_exact_leak(), audit.has_gap_violation()))
    })
}

/// `crossaudit simsum`: scores a replications CSV as rsimsum does (methods
/// paired by replication id); returns the paths written (simsum.csv, then
/// simsum.md).
#[pyfunction]
#[pyo3(signature = (file, out, truth, estimate="estimate".to_string(), se="se".to_string(), method="method".to_string(), rep=None, by=Vec::new(), level="0.95".to_string(), ci=None, df=None, reference=None, target_mcse=None))]
#[allow(clippy::too_many_arguments)]
fn simsum(
    py: Python<'_>,
    file: PathBuf,
    out: PathBuf,
    truth: String,
    estimate: String,
    se: String,
    method: String,
    rep: Option<String>,
    by: Vec<String>,
    level: String,
    ci: Option<(String, String)>,
    df: Option<String>,
    reference: Option<String>,
    target_mcse: Option<String>,
) -> PyResult<Vec<PathBuf>> {
    use crossaudit::methods::simsum as ss;
    py.detach(|| {
        let targets = match target_mcse.as_deref() {
            Some(t) => ss::parse_targets(t).map_err(fail)?,
            None => Vec::new(),
        };
        let cols = ss::Columns { estimate, se, method, rep, by, truth, level, ci, df, reference, targets };
        let _lock = crossaudit::run::lock_folder(&out, false).map_err(fail)?;
        let (groups, unused) = ss::summarise(&file, &cols).map_err(fail)?;
        crossaudit::methods::simsum_report::write(&groups, &cols, &file.display().to_string(), &unused, &out)
            .map_err(fail)
    })
}

/// The crossaudit build (version and commit).
#[pyfunction]
fn build() -> &'static str {
    crossaudit::BUILD
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("CrossauditError", m.py().get_type::<CrossauditError>())?;
    for f in [
        wrap_pyfunction!(load_design, m)?,
        wrap_pyfunction!(export, m)?,
        wrap_pyfunction!(score, m)?,
        wrap_pyfunction!(run, m)?,
        wrap_pyfunction!(analyze, m)?,
        wrap_pyfunction!(audit_split, m)?,
        wrap_pyfunction!(simsum, m)?,
        wrap_pyfunction!(build, m)?,
    ] {
        m.add_function(f)?;
    }
    Ok(())
}
