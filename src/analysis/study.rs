//! The analysis of any study: one crossed contrast, a family (doses or
//! splits), or a multiverse. [`crate::analyze_study`] makes it from a
//! design and its cells (or a run folder); a run hands it back in its
//! outcome; `report::write_study` writes it and `report::study_decision_line`
//! gives its decision line.

use super::family::FamilyAnalysis;
use super::multiverse::MultiverseAnalysis;
use super::types::Analysis;

/// The analysis of a study of any kind. It serializes as the analysis it
/// holds (results.json's, or multiverse.json's).
#[derive(Debug, Clone, serde::Serialize)]
#[serde(untagged)]
pub enum StudyAnalysis {
    /// A single-split, single-dose study.
    Single(Box<Analysis>),
    /// A dose-response or multi-split study.
    Family(Box<FamilyAnalysis>),
    /// A multiverse or a draw-replicated study.
    Multiverse(Box<MultiverseAnalysis>),
}

impl StudyAnalysis {
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
}
