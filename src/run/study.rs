//! The analysis of any study, as a run writes it or `crossaudit analyze`
//! makes it ([`crate::analyze_study`]): one crossed contrast, a family
//! (doses or splits), or a multiverse; its decision line, warnings, JSON
//! and report.

use std::path::{Path, PathBuf};

use super::{outer, RunError};
use crate::analysis::family::FamilyAnalysis;
use crate::analysis::Analysis;

/// The analysis a run wrote: one crossed contrast, a family of them
/// (several splits or doses), or a multiverse. It serializes as the
/// analysis it holds (results.json's, or multiverse.json's).
#[derive(Debug, Clone, serde::Serialize)]
#[serde(untagged)]
pub enum StudyAnalysis {
    /// A single-split, single-dose study.
    Single(Box<Analysis>),
    /// A dose-response or multi-split study.
    Family(Box<FamilyAnalysis>),
    /// A multiverse or a draw-replicated study.
    Multiverse(Box<crate::analysis::multiverse::MultiverseAnalysis>),
}

impl StudyAnalysis {
    /// The decision line the console prints.
    pub fn decision_line(&self) -> String {
        match self {
            StudyAnalysis::Single(a) => crate::report::decision_line(a),
            StudyAnalysis::Family(a) => crate::report::family::family_decision_line(a),
            StudyAnalysis::Multiverse(a) => outer::decision_line(a),
        }
    }

    /// Whether the preregistered decision holds.
    pub fn holds(&self) -> bool {
        match self {
            StudyAnalysis::Single(a) => a.decision.holds,
            StudyAnalysis::Family(a) => a.decision.holds,
            StudyAnalysis::Multiverse(a) => a.decision.holds,
        }
    }

    /// The warnings the report puts beside the decision.
    pub fn warnings(&self) -> &[String] {
        match self {
            StudyAnalysis::Single(a) => &a.warnings,
            StudyAnalysis::Family(a) => &a.warnings,
            StudyAnalysis::Multiverse(a) => &a.warnings,
        }
    }

    /// `single`, `family` (a dose-response or multi-split study) or
    /// `multiverse` (a multiverse or draw-replicated study).
    pub fn kind(&self) -> &'static str {
        match self {
            StudyAnalysis::Single(_) => "single",
            StudyAnalysis::Family(_) => "family",
            StudyAnalysis::Multiverse(_) => "multiverse",
        }
    }

    /// The tidy table the report writes: `estimates.csv` of a single or
    /// family study, `specs.csv` of a multiverse (as CSV text).
    pub fn tidy_table(&self) -> String {
        match self {
            StudyAnalysis::Single(a) => crate::report::render_estimates(a),
            StudyAnalysis::Family(a) => crate::report::render_family_estimates(a),
            StudyAnalysis::Multiverse(a) => crate::report::multiverse::specs_csv(a),
        }
    }

    /// Writes the study's report into `dir`, as `crossaudit analyze` does;
    /// returns the files written. Its tidy table is `estimates.csv` (a
    /// single or family study) or `specs.csv` (a multiverse).
    pub fn write(&mut self, dir: &Path) -> Result<Vec<PathBuf>, RunError> {
        Ok(match self {
            // Figures as a run's report has them (no training curves:
            // per-cell data has none).
            StudyAnalysis::Single(a) => crate::report::write_with_figures(a, &[], dir)?,
            StudyAnalysis::Family(a) => crate::report::family::write_family(a, dir)?,
            StudyAnalysis::Multiverse(a) => crate::report::multiverse::write_multiverse(a, dir)?,
        })
    }
}
