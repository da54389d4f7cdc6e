//! A run directory's split rebuilt in memory from its data, checked
//! against its run.json (what a Slurm task and a scoring of external
//! models reopen).

use std::path::Path;

use super::{Data, DataOrigin, RunError, RunRecord};

/// The split of the run directory `dir` rebuilt in memory from `data_dir`
/// (simulated data verified against its record, never generated), refused
/// unless its audit and manifests are those of its run.json.
pub(crate) fn rebuild_from(
    data_dir: &Path,
    origin: &DataOrigin,
    file: &crate::design::DesignFile,
    plan: &crate::plan::Plan,
    dir: &Path,
    run: &RunRecord,
) -> Result<crate::split::Prepared, RunError> {
    if let DataOrigin::Simulated { spec, record_sha256 } = origin {
        // Verify, never generate: other tasks may be reading the directory.
        if !data_dir.join(crate::sim::RECORD).is_file() {
            return Err(RunError::NoDataDir {
                dir: format!("{} (its simulation record is missing)", data_dir.display()),
            });
        }
        let ensured = crate::sim::ensure(spec, data_dir)?;
        let now = ensured.record().sha256();
        if now != *record_sha256 {
            return Err(RunError::OtherData {
                dir: dir.display().to_string(),
                what: "simulation record (sha256)".into(),
                was: record_sha256.clone(),
                is: now,
            });
        }
    }
    if !data_dir.is_dir() {
        return Err(RunError::NoDataDir { dir: data_dir.display().to_string() });
    }
    let prepared = crate::split::rebuild(file, plan, data_dir, dir)?;
    let data = Data { dir: data_dir.to_path_buf(), origin: origin.clone() };
    let now = RunRecord::new(plan, file, &data, &prepared, run.exploratory);
    run.check_resume(dir, &now)?;
    Ok(prepared)
}
