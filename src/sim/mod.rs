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
mod trajectory;

use std::path::{Path, PathBuf};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

pub use crate::design::SimSpec;
pub use flight::fly;
pub use trajectory::{catalogue, TRAJECTORIES};

/// The simulator's recordings could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write simulated recordings to {dir}: {source}")]
pub struct SimulateError {
    /// The output directory.
    pub dir: String,
    /// Why.
    pub source: std::io::Error,
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

/// Writes `spec.recordings` recordings (CSV + metadata YAML) into `dir`.
/// Deterministic for the spec; recording k uses ChaCha8 stream k.
pub fn simulate(spec: &SimSpec, dir: &Path) -> Result<Vec<PathBuf>, SimulateError> {
    let err = |source| SimulateError { dir: dir.display().to_string(), source };
    std::fs::create_dir_all(dir).map_err(err)?;
    catalogue(spec.recordings)
        .into_par_iter()
        .enumerate()
        .map(|(k, (name, kind, _speed, v, rep))| {
            let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
            rng.set_stream(k as u64);
            let t0 = 1_780_000_000.0 + 1000.0 * k as f64;
            let (text, v_start, v_end, rows) = fly(kind, v, spec.duration_s, spec.strength, &mut rng, t0);
            let csv = dir.join(format!("{name}.csv"));
            std::fs::write(&csv, text).map_err(err)?;
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
            std::fs::write(dir.join(format!("{name}_metadata.yaml")), yaml).map_err(err)?;
            Ok(csv)
        })
        .collect()
}
