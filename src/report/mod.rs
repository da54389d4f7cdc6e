//! Stage 5: an [`Analysis`] rendered for people and for other tools:
//! `report.md` (tables like the paper's Table 2), `results.json`,
//! `results.tex` (one LaTeX macro per reported number) and SVG figures.
//!
//! Architecture Invariant: `report` renders what it is given; it reads no
//! file and imports no stage above `analysis`.

pub mod charts;
mod coverage;
mod estimates;
pub mod family;
pub mod figures;
mod format;
mod glmm;
mod header;
pub mod html;
mod markdown;
pub mod multiverse;
mod study;
mod table;
mod tex;

use std::path::{Path, PathBuf};

use crate::analysis::Analysis;
use crate::io::{create_dir_all, pretty_json, write_atomic, WriteError};

pub use crate::io::{md_code, md_text};
pub use charts::DrawError;
pub use coverage::summary as coverage_summary;
pub use estimates::{render_estimates, render_family_estimates};
pub use format::{decision_line, decision_summary, f, level_pct, unit_label};
pub use html::render_html;
pub use markdown::render_markdown;
pub use study::{study_decision_line, study_guards, study_table, write_study};
pub use table::MdTable;
pub use tex::render_tex;

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A file could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
    /// A figure could not be drawn.
    #[error(transparent)]
    Draw(#[from] DrawError),
    /// A table could not be written as Parquet.
    #[error("cannot write {path} as Parquet: {reason}")]
    Parquet {
        /// The file.
        path: String,
        /// Why.
        reason: String,
    },
}

/// estimates.parquet beside estimates.csv: the same table with typed
/// columns (`io::parquet::csv_to_parquet`), for pandas, polars and R's
/// arrow.
fn write_parquet_twin(dir: &Path, csv: &str) -> Result<PathBuf, ReportError> {
    let path = dir.join("estimates.parquet");
    let bytes = crate::io::parquet::csv_to_parquet(csv.as_bytes())
        .map_err(|reason| ReportError::Parquet { path: path.display().to_string(), reason })?;
    write_atomic(&path, &bytes)?;
    Ok(path)
}

/// results.json: the analysis as pretty JSON.
pub fn render_json(a: &Analysis) -> String {
    pretty_json(a)
}

/// Writes report.md, results.json, results.tex, estimates.csv (and its
/// typed twin estimates.parquet) and report.html into `dir` (created if
/// needed), each atomically (temporary file + rename). Returns the paths.
pub fn write_all(a: &Analysis, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    write_all_with(a, dir, &[])
}

/// The whole report with its figures: the figures drawn from `a` (and,
/// from a run, its training `curves`) into `dir`, named in `a.figures`,
/// then [`write_all_with`] with them inlined into report.html. What a run
/// and `crossaudit analyze` both write.
pub fn write_with_figures(a: &Analysis, curves: &[figures::Curve], dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    create_dir_all(dir)?;
    let drawn = figures::write_figures(a, curves, dir)?;
    let paths: Vec<PathBuf> = drawn.iter().map(|(p, _)| p.clone()).collect();
    // A figure an earlier analysis into this folder drew and this one does
    // not (training curves from a run folder, then a per-cell file alone)
    // would stand beside a report that no longer names it.
    for name in figures::OPTIONAL {
        let stale = dir.join(name);
        if !paths.contains(&stale) && stale.symlink_metadata().is_ok() {
            std::fs::remove_file(&stale).map_err(|e| crate::io::WriteError::new(&stale, e))?;
        }
    }
    let svgs = figures::by_name(drawn);
    let a = a.with_figures(svgs.iter().map(|(name, _)| name.clone()).collect());
    let mut written = write_all_with(&a, dir, &svgs)?;
    written.extend(paths);
    Ok(written)
}

/// As [`write_all`], with the figures report.md names inlined into
/// report.html: (file name, SVG text), as the caller read them.
pub fn write_all_with(a: &Analysis, dir: &Path, figures: &[(String, String)]) -> Result<Vec<PathBuf>, ReportError> {
    create_dir_all(dir)?;
    let mut out = Vec::new();
    let markdown = render_markdown(a);
    let html = render_html(a, &markdown, figures);
    let estimates = render_estimates(a);
    out.push(write_parquet_twin(dir, &estimates)?);
    for (name, text) in [
        // results.json first: a folder holding a report.md without it is
        // someone's own to the next `analyze`.
        ("results.json", render_json(a)),
        ("report.md", markdown),
        ("results.tex", render_tex(a)),
        ("estimates.csv", estimates),
        ("report.html", html),
    ] {
        let path = dir.join(name);
        write_atomic(&path, text.as_bytes())?;
        out.push(path);
    }
    Ok(out)
}
