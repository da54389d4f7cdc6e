//! Where a study's flight logs come from: `--data`, the simulator's
//! recordings generated once into the output directory, or the design's
//! `path`.

use std::path::{Path, PathBuf};

use super::RunError;
use crate::design::Design;

/// The data directory: `--data` if given; for `data simulated`, the
/// simulator's recordings, generated once into `out/simulated_data`; else
/// the design's `path` (relative to the current directory).
pub fn data_dir(design: &Design, data: Option<PathBuf>, out: &Path) -> Result<PathBuf, RunError> {
    let dir = match (data, &design.data.path, &design.data.simulated) {
        (Some(d), _, _) => d,
        (None, _, Some(sim)) => {
            let dir = out.join("simulated_data");
            let expected = crate::sim::catalogue(sim.recordings);
            let complete = expected.iter().all(|(name, ..)| dir.join(format!("{name}.csv")).exists());
            if !complete {
                crate::sim::simulate(sim, &dir)?;
            }
            dir
        }
        (None, Some(p), None) => PathBuf::from(p),
        (None, None, None) => return Err(RunError::NoDataPath),
    };
    if !dir.is_dir() {
        return Err(RunError::NoDataDir { dir: dir.display().to_string() });
    }
    Ok(dir)
}
