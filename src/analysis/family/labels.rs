//! A family analysis's labels: the design it ran under, its lock state
//! and the per-cell file, passed on to each split's and dose's own report.

use super::FamilyAnalysis;

impl FamilyAnalysis {
    /// Records the per-cell file analysed and its SHA-256.
    pub fn record_cells(&mut self, path: &std::path::Path, sha256: &str) {
        self.provenance.cells = Some((path.display().to_string(), sha256.to_string()));
    }

    /// Records the design the analysis ran under, as
    /// [`crate::analysis::Analysis::record_design`] does.
    pub fn record_design(&mut self, path: &str, sha256: &str, status: &crate::design::LockStatus) {
        self.design_sha256 = Some(sha256.to_string());
        let (exploratory, preregistered, warning) = crate::analysis::lock_labels(path, status);
        self.exploratory |= exploratory;
        self.preregistered = Some(preregistered && !self.exploratory);
        self.warnings.extend(warning);
        // Each dose's and split's own report carries the same labels.
        let (exploratory, preregistered) = (self.exploratory, self.preregistered);
        for a in self.splits.iter_mut().flat_map(|s| s.detail.iter_mut()) {
            a.design_sha256 = Some(sha256.to_string());
            a.exploratory |= exploratory;
            a.preregistered = preregistered;
        }
    }

    /// Labels the analysis EXPLORATORY, as
    /// [`crate::analysis::Analysis::mark_exploratory`] does.
    pub fn mark_exploratory(&mut self) {
        self.exploratory = true;
        if self.preregistered.is_some() {
            self.preregistered = Some(false);
        }
        for a in self.splits.iter_mut().flat_map(|s| s.detail.iter_mut()) {
            a.mark_exploratory();
        }
    }
}
