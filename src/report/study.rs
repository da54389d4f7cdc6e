//! One writer and one decision line for any study
//! ([`crate::analysis::StudyAnalysis`]): what a run, `crossaudit analyze`
//! and the Python package all write and print.

use std::path::{Path, PathBuf};

use super::ReportError;
use crate::analysis::StudyAnalysis;

/// The decision line the console prints for any study.
pub fn study_decision_line(a: &StudyAnalysis) -> String {
    match a {
        StudyAnalysis::Single(a) => super::format::decision_line(a),
        StudyAnalysis::Family(a) => super::family::family_decision_line(a),
        StudyAnalysis::Multiverse(a) => super::multiverse::decision_line(a),
    }
}

/// The guards beside the study's verdict, as plain text (one paragraph
/// each, Markdown emphasis removed): what the report and its banner give
/// beside the verdict, for the console and the Python result.
pub fn study_guards(a: &StudyAnalysis) -> Vec<String> {
    let guards = match a {
        StudyAnalysis::Single(a) => &a.guards,
        StudyAnalysis::Family(a) => &a.guards,
        StudyAnalysis::Multiverse(a) => &a.guards,
    };
    guards.iter().map(|g| g.plain()).collect()
}

/// The study's tidy table as CSV text: `estimates.csv` of a single or
/// family study, `specs.csv` of a multiverse.
pub fn study_table(a: &StudyAnalysis) -> String {
    match a {
        StudyAnalysis::Single(a) => super::estimates::render_estimates(a),
        StudyAnalysis::Family(a) => super::estimates::render_family_estimates(a),
        StudyAnalysis::Multiverse(a) => super::multiverse::specs_csv(a),
    }
}

/// The files other than figures (`*.svg`) a report of any kind may write.
const REPORT_FILES: [&str; 9] = [
    "report.md",
    "report.html",
    "results.json",
    "results.tex",
    "estimates.csv",
    "estimates.parquet",
    "multiverse.json",
    "specs.csv",
    "choice_effects.csv",
];

/// Writes the report of any study into `dir` and returns the files
/// written: with its figures (and, for a single study read from a run
/// folder, the training curves its analysis carries; a family or
/// multiverse has none, nor has a per-cell file alone), the figure names
/// recorded in the analysis.
pub fn write_study(a: &StudyAnalysis, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    crate::io::refuse_protected_in(dir, |name| REPORT_FILES.contains(&name) || name.ends_with(".svg"))?;
    match a {
        StudyAnalysis::Single(a) => super::write_with_figures(a, &a.curves, dir),
        StudyAnalysis::Family(a) => super::family::write_family(a, dir),
        StudyAnalysis::Multiverse(a) => super::multiverse::write_multiverse(a, dir),
    }
}
