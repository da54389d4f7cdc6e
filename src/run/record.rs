//! `run.json`: what a run directory holds, checked before a run resumes so
//! that finished jobs are only ever reused for the same design and data.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::RunError;
use crate::io::write_atomic;

/// run.json: what a run directory holds, checked on resume.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// The study's name.
    pub study: String,
    /// SHA-256 of the design file.
    pub design_sha256: String,
    /// SHA-256 of manifests.json.
    pub manifests_sha256: String,
    /// Whether the run's outputs are labelled EXPLORATORY.
    pub exploratory: bool,
}

impl RunRecord {
    /// The record of the run in `out`, if one was written and is readable.
    pub fn read(out: &Path) -> Option<RunRecord> {
        let text = std::fs::read_to_string(out.join("run.json")).ok()?;
        serde_json::from_str(&text).ok()
    }

    /// Refuses a directory that holds a run of another design.
    pub fn check_design(&self, out: &Path, design_sha256: &str) -> Result<(), RunError> {
        if self.design_sha256 != design_sha256 {
            return Err(RunError::OtherDesign { dir: out.display().to_string(), sha256: self.design_sha256.clone() });
        }
        Ok(())
    }

    /// Refuses a directory whose manifests (so whose data) differ.
    pub fn check_manifests(&self, out: &Path, manifests_sha256: &str) -> Result<(), RunError> {
        if self.manifests_sha256 != manifests_sha256 {
            return Err(RunError::ManifestsChanged { dir: out.display().to_string() });
        }
        Ok(())
    }

    /// Writes `out/run.json` atomically.
    pub fn write(&self, out: &Path) -> Result<(), RunError> {
        // No final newline: the form run.json has always had.
        let text = serde_json::to_string_pretty(self).unwrap_or_default();
        Ok(write_atomic(&out.join("run.json"), text.as_bytes())?)
    }
}
