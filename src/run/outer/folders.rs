//! What the levels of an outer study share: where each level's files are
//! (`run_dir`), a finished job copied between level folders, the notes
//! a level adds once, and `score`'s notes on external models.

use std::path::{Path, PathBuf};

use crate::io::{create_dir_all, write_atomic};
use crate::plan::study::Level;
use crate::plan::TrainingJob;
use crate::run::{JobRecord, RunError};

/// What `score` says of each level's external models (by level folder),
/// for that level's report.
#[derive(Debug, Clone, Default)]
pub(crate) struct ExternalNotes(pub Vec<(String, Vec<String>)>);

/// Adds a level's unreadable-files warning to `notes` once (every level reads the same folder).
pub(crate) fn note_unread(notes: &mut Vec<String>, audit: &crate::data::Audit) {
    if let Some(w) = audit.unread_warning().filter(|w| !notes.contains(w)) {
        notes.push(w);
    }
}

/// Copies a finished job's files and record from the run directory `from`
/// into `to`, where `job` (the same model, arm and seed) will find it finished.
pub(crate) fn copy_job(from: &Path, earlier: &TrainingJob, to: &Path, job: &TrainingJob) -> Result<(), RunError> {
    let record = JobRecord::read(from, earlier)?.ok_or_else(|| RunError::BadJobRecord {
        path: crate::run::job_record_path(from, earlier).display().to_string(),
        reason: "the job it would be copied from has no record".to_string(),
    })?;
    for name in record.files.keys() {
        let target = to.join(name);
        create_dir_all(target.parent().unwrap_or(to))?;
        let bytes = std::fs::read(from.join(name)).map_err(|e| crate::io::WriteError::new(&from.join(name), e))?;
        write_atomic(&target, &bytes)?;
    }
    record.write(to, job)
}

/// The directory holding level `k`'s cells: its own, or the one it shares.
pub(crate) fn run_dir(out: &Path, levels: &[Level], k: usize) -> PathBuf {
    out.join(&levels[levels[k].shares.unwrap_or(k)].id)
}
