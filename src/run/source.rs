//! Where a study's flight logs come from: `--data`, the simulator's
//! recordings generated once into the output directory (and verified
//! against their record whenever they are reused), or the design's `path`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::RunError;
use crate::design::{Design, SimSpec};

/// Where a run's flight logs came from, as run.json and the report say.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum DataOrigin {
    /// Logs in a directory: the design's `path` or `--data`.
    Directory {
        /// The directory as given.
        path: String,
    },
    /// The built-in simulator's recordings of the design's spec.
    Simulated {
        /// What was simulated.
        spec: SimSpec,
        /// SHA-256 of the simulated data's record (`simulation.json`), which
        /// lists every file's SHA-256.
        record_sha256: String,
    },
}

impl DataOrigin {
    /// One line for reports.
    pub fn describe(&self) -> String {
        match self {
            DataOrigin::Directory { path } => format!("flight logs in `{path}`"),
            DataOrigin::Simulated { spec, record_sha256 } => format!(
                "simulated recordings (recordings {}, seed {}, strength {}, duration {} s; record sha256 {record_sha256})",
                spec.recordings, spec.seed, spec.strength, spec.duration_s
            ),
        }
    }
}

/// A data directory and where its logs came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Data {
    /// The directory the loader reads.
    pub dir: PathBuf,
    /// What it holds.
    pub origin: DataOrigin,
}

impl Data {
    /// Flight logs in `dir`.
    pub fn directory(dir: &Path) -> Data {
        Data { dir: dir.to_path_buf(), origin: DataOrigin::Directory { path: dir.display().to_string() } }
    }
}

/// The data of a design: `--data` if given (refused for a `data simulated`
/// design, whose report would describe the simulation); for `data
/// simulated`, the simulator's recordings in `out/simulated_data`,
/// generated there once and verified on every reuse; else the design's
/// `path` (see [`design_data_path`]).
pub fn data_dir(design: &Design, design_file: &Path, data: Option<PathBuf>, out: &Path) -> Result<Data, RunError> {
    let data = match (data, &design.data.path, &design.data.simulated) {
        (Some(_), _, Some(_)) => return Err(RunError::DataOverride),
        (Some(d), _, None) => Data::directory(&d),
        (None, _, Some(sim)) => {
            let dir = out.join("simulated_data");
            let ensured = crate::sim::ensure(sim, &dir)?;
            let record_sha256 = ensured.record().sha256();
            Data { dir, origin: DataOrigin::Simulated { spec: *sim, record_sha256 } }
        }
        (None, Some(p), None) => Data::directory(&design_data_path(design_file, p)?),
        (None, None, None) => return Err(RunError::NoDataPath),
    };
    if !data.dir.is_dir() {
        return Err(RunError::NoDataDir { dir: data.dir.display().to_string() });
    }
    if let DataOrigin::Directory { .. } = data.origin {
        super::check_out_dir(&data.dir, out)?;
    }
    Ok(data)
}

/// A design's data `path`: absolute as written; relative, from the design
/// file's directory. A relative path that exists only from the current
/// directory (designs written when paths resolved from there, such as the
/// shipped ones, run from the repository root) is used from there; one
/// that exists from both and names two different directories is refused
/// as ambiguous, and one that exists from neither is named with both
/// places looked in.
pub fn design_data_path(design_file: &Path, path: &str) -> Result<PathBuf, RunError> {
    let p = Path::new(path);
    if p.is_absolute() {
        return Ok(p.to_path_buf());
    }
    let beside = design_file.parent().unwrap_or(Path::new("")).join(p);
    let (a, b) = (beside.is_dir(), p.is_dir());
    match (a, b) {
        (true, true) => {
            let same = match (beside.canonicalize(), p.canonicalize()) {
                (Ok(x), Ok(y)) => x == y,
                _ => false,
            };
            if same {
                Ok(p.to_path_buf())
            } else {
                Err(RunError::AmbiguousDataPath { path: path.to_string(), beside: beside.display().to_string() })
            }
        }
        (true, false) => Ok(beside),
        (false, true) => Ok(p.to_path_buf()),
        (false, false) => {
            // Named in full: the two relative spellings can read the same.
            let full = |q: &Path| std::path::absolute(q).unwrap_or_else(|_| q.to_path_buf());
            let (from_design, from_here) = (full(&beside), full(p));
            let dir = if from_design == from_here {
                format!(
                    "{} (the design's path {path}, from the design's directory, which is the current one)",
                    from_here.display()
                )
            } else {
                format!(
                    "{} (the design's path {path}, from the design's directory) or {} (from the current directory)",
                    from_design.display(),
                    from_here.display()
                )
            };
            Err(RunError::NoDataDir { dir })
        }
    }
}
