//! A simulated Crazyflie: rigid-body quadrotor physics under a cascaded
//! controller, flying the NanoBench reference trajectories, logged in the
//! exact NanoBench schema (52 columns, 100 Hz, metadata YAML).
//!
//! Physics (integrated at 500 Hz, logged at 100 Hz): a 34 g rigid body
//! (markers included), arm 46 mm, Crazyflie inertia; motor thrust
//! c (PWM/65535)^2 V^2 per motor, yaw torque proportional to thrust; linear
//! rotor drag on the air-relative velocity; battery voltage sagging over the
//! flight and under load. Control (500 Hz): position PID -> desired thrust
//! vector -> attitude P -> body-rate P -> motor mixing -> PWM, computed with
//! the *nominal* parameters, so each recording's true parameters make real
//! tracking and model errors.
//!
//! Recording-specific structure scales with the declared `strength` s: mass
//! (sd 5% s) and inertia (sd 10% s) offsets, per-motor efficiency (sd 5% s),
//! a constant wind (sd 0.3 s m/s per axis) and sensor biases. With s = 0
//! recordings differ only by sensor and process noise: exchangeable given
//! the trajectory. Everything is drawn from ChaCha8 seeded by the design.

mod flight;
pub mod lab;
mod trajectory;

use std::collections::BTreeMap;
use std::path::Path;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::io::{pretty_json, sha256_file, sha256_hex, write_atomic};

pub use crate::design::SimSpec;
pub use flight::fly;
pub use lab::simulate_lab;
pub use trajectory::{catalogue, TRAJECTORIES};

/// The simulator's recordings could not be written, or a directory of
/// them cannot be reused.
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    /// A file could not be written.
    #[error("cannot write simulated recordings to {dir}: {source}")]
    Write {
        /// The output directory.
        dir: String,
        /// Why.
        source: std::io::Error,
    },
    /// The directory holds recordings simulated from another spec.
    #[error("{dir} holds recordings simulated from another spec ({recorded}; this design asks for {wanted}); delete {dir} or use a new output directory")]
    OtherSpec {
        /// The simulated-data directory.
        dir: String,
        /// The spec it was generated from.
        recorded: String,
        /// The spec asked for now.
        wanted: String,
    },
    /// A simulated file differs from the one the simulator wrote.
    #[error("{path} is not the file the simulator wrote ({reason}); delete {dir} to generate the recordings again")]
    Modified {
        /// The file.
        path: String,
        /// The directory to delete.
        dir: String,
        /// Missing, or its SHA-256 against the recorded one.
        reason: String,
    },
    /// The directory's record is not one the simulator wrote.
    #[error("{path} cannot be read as a simulation record ({reason}); delete {dir} to generate the recordings again")]
    BadRecord {
        /// `simulation.json`.
        path: String,
        /// The directory to delete.
        dir: String,
        /// Why.
        reason: String,
    },
}

/// `simulation.json`, written after every recording: the spec a directory
/// of simulated recordings was generated from and each file's SHA-256. A
/// directory without it is an interrupted generation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimRecord {
    /// What was simulated.
    pub spec: SimSpec,
    /// File name to SHA-256, every CSV and metadata file.
    pub files: BTreeMap<String, String>,
}

/// The record's file name inside the simulated-data directory.
pub const RECORD: &str = "simulation.json";

impl SimRecord {
    /// SHA-256 of the record as written: identifies the simulated data.
    pub fn sha256(&self) -> String {
        sha256_hex(pretty_json(self).as_bytes())
    }
}

/// What [`ensure`] did.
#[derive(Debug, Clone, PartialEq)]
pub enum Ensured {
    /// The directory held the complete, unmodified recordings of the spec.
    Reused(SimRecord),
    /// The recordings were generated now.
    Generated(SimRecord),
}

impl Ensured {
    /// The record, either way.
    pub fn record(&self) -> &SimRecord {
        match self {
            Ensured::Reused(r) | Ensured::Generated(r) => r,
        }
    }
}

fn describe(spec: &SimSpec) -> String {
    format!(
        "recordings {}, seed {}, strength {}, duration {} s",
        spec.recordings, spec.seed, spec.strength, spec.duration_s
    )
}

/// The recordings of `spec` in `dir`: reused when `dir` holds a complete
/// simulation of the same spec whose every file still has its recorded
/// SHA-256, generated when `dir` holds no complete simulation, refused
/// (with what differs) when it holds another spec's or modified files.
pub fn ensure(spec: &SimSpec, dir: &Path) -> Result<Ensured, SimulateError> {
    let record_path = dir.join(RECORD);
    let dir_text = dir.display().to_string();
    let bad = |reason: String| SimulateError::BadRecord {
        path: record_path.display().to_string(),
        dir: dir_text.clone(),
        reason,
    };
    let text = match crate::io::read_own(&record_path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Ensured::Generated(simulate(spec, dir)?)),
        Err(e) => return Err(bad(e.to_string())),
    };
    let record: SimRecord = serde_json::from_slice(&text).map_err(|e| bad(e.to_string()))?;
    if record.spec != *spec {
        return Err(SimulateError::OtherSpec {
            dir: dir_text,
            recorded: describe(&record.spec),
            wanted: describe(spec),
        });
    }
    let expected = catalogue(spec.recordings);
    if record.files.len() != 2 * expected.len() {
        return Err(bad(format!("{} files listed for {} recordings", record.files.len(), expected.len())));
    }
    for (name, sha) in &record.files {
        let path = dir.join(name);
        let modified = |reason: String| SimulateError::Modified {
            path: path.display().to_string(),
            dir: dir_text.clone(),
            reason,
        };
        let now = sha256_file(&path).map_err(|e| modified(e.to_string()))?;
        if now != *sha {
            return Err(modified(format!("sha256 {now}, recorded {sha}")));
        }
    }
    Ok(Ensured::Reused(record))
}

/// `params` of the simulated metadata.
#[derive(Serialize)]
struct Params {
    duration_s: f64,
    speed_mps: f64,
}

/// `row_counts` of the simulated metadata.
#[derive(Serialize)]
struct RowCounts {
    vicon: usize,
}

/// `simulated` of the metadata: what reproduces the recording.
#[derive(Serialize)]
struct Provenance {
    seed: u64,
    stream: u64,
    strength: f64,
}

/// A simulated recording's metadata, in the NanoBench `*_metadata.yaml`
/// form (keys sorted as NanoBench writes them).
#[derive(Serialize)]
struct SimMetadata {
    battery_voltage_end: f64,
    battery_voltage_start: f64,
    category: &'static str,
    crazyflie_id: &'static str,
    params: Params,
    repetition: usize,
    row_counts: RowCounts,
    simulated: Provenance,
    trajectory_id: String,
    trajectory_type: &'static str,
}

/// Writes `spec.recordings` recordings (CSV + metadata YAML) into `dir`
/// and returns their record.
/// Deterministic for the spec; recording k uses ChaCha8 stream k.
///
/// Every file is written atomically and [`RECORD`] last (after removing
/// any earlier one), so an interrupted generation is never mistaken for a
/// complete one.
pub fn simulate(spec: &SimSpec, dir: &Path) -> Result<SimRecord, SimulateError> {
    let err = |source| SimulateError::Write { dir: dir.display().to_string(), source };
    std::fs::create_dir_all(dir).map_err(err)?;
    match std::fs::remove_file(dir.join(RECORD)) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(err(e)),
        _ => {}
    }
    let atomic = |path: &Path, bytes: &[u8]| -> Result<(String, String), SimulateError> {
        write_atomic(path, bytes).map_err(|e| err(e.source))?;
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        Ok((name, sha256_hex(bytes)))
    };
    let written: Vec<[(String, String); 2]> = catalogue(spec.recordings)
        .into_par_iter()
        .enumerate()
        .map(|(k, (name, kind, _speed, v, rep))| {
            let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
            rng.set_stream(k as u64);
            let t0 = 1_780_000_000.0 + 1000.0 * k as f64;
            let (text, v_start, v_end, rows) = fly(kind, v, spec.duration_s, spec.strength, &mut rng, t0);
            let csv = atomic(&dir.join(format!("{name}.csv")), text.as_bytes())?;
            let meta = SimMetadata {
                battery_voltage_end: v_end,
                battery_voltage_start: v_start,
                category: "tracking",
                crazyflie_id: "SIM",
                params: Params { duration_s: spec.duration_s, speed_mps: v },
                repetition: rep,
                row_counts: RowCounts { vicon: rows },
                simulated: Provenance { seed: spec.seed, stream: k as u64, strength: spec.strength },
                trajectory_id: name.trim_end_matches(&format!("_rep{rep}")).to_string(),
                trajectory_type: kind,
            };
            let yaml = serde_yaml_ng::to_string(&meta).map_err(|e| err(std::io::Error::other(e)))?;
            let meta = atomic(&dir.join(format!("{name}_metadata.yaml")), yaml.as_bytes())?;
            Ok([csv, meta])
        })
        .collect::<Result<_, SimulateError>>()?;
    let record = SimRecord { spec: *spec, files: written.into_iter().flatten().collect() };
    write_atomic(&dir.join(RECORD), pretty_json(&record).as_bytes()).map_err(|e| err(e.source))?;
    Ok(record)
}
