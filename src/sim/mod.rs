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

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use nalgebra::{Matrix4, UnitQuaternion, Vector3, Vector4};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use crate::data::NANOBENCH_COLUMNS;
use crate::stats::standard_normal as normal;

const G: f64 = 9.81;
const MASS: f64 = 0.034;
const ARM: f64 = 0.046;
const INERTIA: [f64; 3] = [1.66e-5, 1.66e-5, 2.93e-5];
/// Thrust per motor = C_T (PWM/65535)^2 V^2: hover near PWM 57,000 at 3.8 V.
const C_T: f64 = 0.00763;
/// Yaw torque per newton of thrust (m).
const K_Q: f64 = 0.006;
const DRAG: f64 = 0.012;
const SIM_HZ: f64 = 500.0;
const LOG_HZ: f64 = 100.0;

pub use crate::design::SimSpec;

/// The trajectories NanoBench flies; `None` speed for those without one.
pub const TRAJECTORIES: [(&str, bool); 10] = [
    ("circle", true),
    ("figure_eight", true),
    ("helix", true),
    ("oval", true),
    ("star", true),
    ("trefoil", true),
    ("lissajous", true),
    ("linear_ramp", false),
    ("multisine_sysid", false),
    ("random_waypoints", false),
];
const SPEEDS: [(&str, f64); 3] = [("slow", 0.3), ("medium", 0.6), ("fast", 1.0)];

/// The (file stem, trajectory, speed token, speed m/s, repetition) of each
/// recording, cycling through trajectories and speeds.
pub fn catalogue(n: usize) -> Vec<(String, &'static str, &'static str, f64, usize)> {
    let mut slots: Vec<(&str, &str, f64)> = Vec::new();
    for (t, has_speed) in TRAJECTORIES {
        if has_speed {
            for (s, v) in SPEEDS {
                slots.push((t, s, v));
            }
        } else {
            slots.push((t, "", 0.5));
        }
    }
    (0..n)
        .map(|k| {
            let (t, s, v) = slots[k % slots.len()];
            let rep = k / slots.len() + 1;
            let name = if s.is_empty() {
                format!("S{:02}_{t}_rep{rep}", k % slots.len() + 1)
            } else {
                format!("S{:02}_{t}_{s}_rep{rep}", k % slots.len() + 1)
            };
            (name, t, s, v, rep)
        })
        .collect()
}

/// Reference position at time `tau` into the trajectory (m), centred at
/// (0, 0, 1). Scaled so that the mean speed is about `v`.
fn reference(kind: &str, tau: f64, v: f64, waypoints: &[Vector3<f64>]) -> Vector3<f64> {
    let r = 0.5;
    let w = v / r;
    let (s, c) = ((w * tau).sin(), (w * tau).cos());
    let z0 = 1.0;
    match kind {
        "circle" => Vector3::new(r * c - r, r * s, z0),
        "figure_eight" => Vector3::new(r * (w * tau).sin(), r * (2.0 * w * tau).sin() / 2.0, z0),
        "helix" => Vector3::new(r * c - r, r * s, z0 + 0.3 * (0.2 * w * tau).sin()),
        "oval" => Vector3::new(0.7 * c - 0.7, 0.4 * s, z0),
        "star" => {
            // Five-pointed star: straight legs between alternate vertices.
            let leg_len = 2.0 * 0.6 * (2.0 * std::f64::consts::PI / 5.0).sin();
            let pos = v * tau / leg_len;
            let k = pos.floor() as i64;
            let f = pos - k as f64;
            let vertex = |i: i64| {
                let a = std::f64::consts::FRAC_PI_2 + (i.rem_euclid(5) as f64) * 4.0 * std::f64::consts::PI / 5.0;
                Vector3::new(0.6 * a.cos(), 0.6 * a.sin() - 0.6, z0)
            };
            vertex(k) * (1.0 - f) + vertex(k + 1) * f
        }
        "trefoil" => {
            // About 2 m across, as NanoBench's trefoils.
            let k = 0.35;
            let a = 0.6 * w * tau / 2.0 * (0.15 / k);
            Vector3::new(
                k * (a.sin() + 2.0 * (2.0 * a).sin()),
                k * (a.cos() - 2.0 * (2.0 * a).cos()) + k,
                z0 - 0.1 * (3.0 * a).sin(),
            )
        }
        "lissajous" => Vector3::new(0.5 * (0.6 * w * tau).sin(), 0.4 * (0.9 * w * tau).sin(), z0),
        "linear_ramp" => Vector3::new(0.8 * (0.25 * tau).sin(), 0.0, z0 + 0.1 * tau / 10.0),
        "multisine_sysid" => Vector3::new(
            0.15 * ((1.1 * tau).sin() + 0.5 * (2.9 * tau).sin()),
            0.15 * ((1.3 * tau).sin() + 0.5 * (3.7 * tau).sin()),
            z0 + 0.08 * (2.3 * tau).sin(),
        ),
        _ => {
            // Random waypoints, visited with smoothstep blends, 3 s each.
            let k = (tau / 3.0).floor() as usize;
            let f = tau / 3.0 - k as f64;
            let f = f * f * (3.0 - 2.0 * f);
            let a = waypoints[k % waypoints.len()];
            let b = waypoints[(k + 1) % waypoints.len()];
            a * (1.0 - f) + b * f
        }
    }
}

/// Per-recording physical and sensor parameters.
struct Truth {
    mass: f64,
    inertia: Vector3<f64>,
    efficiency: [f64; 4],
    wind: Vector3<f64>,
    pos_bias: Vector3<f64>,
    gyro_bias: Vector3<f64>,
    v0: f64,
}

fn truth(strength: f64, rng: &mut ChaCha8Rng) -> Truth {
    let s = strength;
    Truth {
        mass: MASS * (1.0 + 0.05 * s * normal(rng)).max(0.5),
        inertia: Vector3::new(INERTIA[0], INERTIA[1], INERTIA[2]) * (1.0 + 0.1 * s * normal(rng)).max(0.5),
        efficiency: [0; 4].map(|_| (1.0 + 0.05 * s * normal(rng)).clamp(0.7, 1.3)),
        wind: Vector3::new(normal(rng), normal(rng), 0.2 * normal(rng)) * 0.3 * s,
        pos_bias: Vector3::new(normal(rng), normal(rng), normal(rng)) * 0.01 * s,
        gyro_bias: Vector3::new(normal(rng), normal(rng), normal(rng)) * 0.02 * s,
        v0: 3.95 + 0.1 * rng.gen::<f64>(),
    }
}

/// Motor mixing for the X configuration: [T, tau_x, tau_y, tau_z] = A t.
fn mixer() -> Matrix4<f64> {
    let d = ARM / 2f64.sqrt();
    // Motors: m1 front-right (+x, -y), m2 back-right (-x, -y), m3 back-left
    // (-x, +y), m4 front-left (+x, +y); m1 and m3 spin one way, m2 and m4 the other.
    let pos = [(d, -d), (-d, -d), (-d, d), (d, d)];
    let spin = [-1.0, 1.0, -1.0, 1.0];
    let mut a = Matrix4::zeros();
    for i in 0..4 {
        a[(0, i)] = 1.0;
        a[(1, i)] = pos[i].1;
        a[(2, i)] = -pos[i].0;
        a[(3, i)] = spin[i] * K_Q;
    }
    a
}

/// One simulated recording as NanoBench CSV text and its metadata.
pub fn fly(
    kind: &str,
    v: f64,
    duration: f64,
    strength: f64,
    rng: &mut ChaCha8Rng,
    t_start: f64,
) -> (String, f64, f64, usize) {
    let tr = truth(strength, rng);
    let waypoints: Vec<Vector3<f64>> = (0..12)
        .map(|_| Vector3::new(rng.gen_range(-0.6..0.6), rng.gen_range(-0.6..0.6), rng.gen_range(0.7..1.3)))
        .collect();
    let mix = mixer();
    let unmix = mix.try_inverse().expect("the X mixer is invertible");
    let (idle, takeoff, land) = (1.0, 2.0, 2.0);
    let total = idle + takeoff + duration + land + 0.5;
    let dt = 1.0 / SIM_HZ;
    let sub = (SIM_HZ / LOG_HZ) as usize;
    let mut p = Vector3::new(0.0, 0.0, 0.0);
    let mut vel = Vector3::zeros();
    let mut q = UnitQuaternion::identity();
    let mut omega = Vector3::zeros();
    let mut integral = Vector3::zeros();
    let mut pwm = [0.0f64; 4];
    let mut vbat = tr.v0;
    let mut logged_v = 0.0;
    let mut thrust_cmd = 0.0;
    let mut torque_cmd = Vector3::zeros();
    let mut accel = Vector3::zeros();
    let hover_start = reference(kind, 0.0, v, &waypoints);
    let mut text = String::with_capacity((total * LOG_HZ) as usize * 560);
    text.push_str(&NANOBENCH_COLUMNS.join(","));
    text.push('\n');
    let n_log = (total * LOG_HZ) as usize;
    let mut v_start = 0.0;
    // The onboard estimator's velocity error is smooth (a filter), not white.
    let mut est_v_err: Vector3<f64> = Vector3::zeros();
    for k in 0..n_log {
        let t = k as f64 / LOG_HZ;
        // Reference: idle on the ground, climb to the trajectory's start,
        // fly it, descend.
        let refpos = |t: f64| -> Vector3<f64> {
            if t < idle {
                Vector3::new(0.0, 0.0, 0.0)
            } else if t < idle + takeoff {
                let f = (t - idle) / takeoff;
                let f = f * f * (3.0 - 2.0 * f);
                hover_start * f
            } else if t < idle + takeoff + duration {
                reference(kind, t - idle - takeoff, v, &waypoints)
            } else {
                let end = reference(kind, duration, v, &waypoints);
                let f = ((t - idle - takeoff - duration) / land).min(1.0);
                let f = f * f * (3.0 - 2.0 * f);
                Vector3::new(end.x, end.y, end.z * (1.0 - f))
            }
        };
        let flying = t >= idle && t < idle + takeoff + duration + land;
        let r = refpos(t);
        for _ in 0..sub {
            let ts = t;
            // Controller (nominal parameters).
            let r_next = refpos(ts + 0.01);
            let r_prev = refpos((ts - 0.01).max(0.0));
            let v_ref = (r_next - r_prev) / 0.02;
            let a_ref = (r_next - 2.0 * refpos(ts) + r_prev) / 1e-4;
            if flying {
                let e = r - p;
                integral += e * dt;
                integral = integral.map(|x| x.clamp(-0.5, 0.5));
                let a_cmd = a_ref
                    + Vector3::new(6.0, 6.0, 8.0).component_mul(&e)
                    + Vector3::new(4.0, 4.0, 5.0).component_mul(&(v_ref - vel))
                    + integral * 1.0;
                let f = MASS * (a_cmd + Vector3::new(0.0, 0.0, G));
                let z_des = f.normalize();
                let z_body = q * Vector3::z();
                thrust_cmd = f.dot(&z_body).max(0.0);
                let x_c = Vector3::x();
                let y_des = z_des.cross(&x_c).normalize();
                let x_des = y_des.cross(&z_des);
                let r_des = nalgebra::Rotation3::from_basis_unchecked(&[x_des, y_des, z_des]);
                let r_now = q.to_rotation_matrix();
                let e_r_m = r_des.matrix().transpose() * r_now.matrix() - r_now.matrix().transpose() * r_des.matrix();
                let e_r = 0.5 * Vector3::new(e_r_m[(2, 1)], e_r_m[(0, 2)], e_r_m[(1, 0)]);
                let omega_des = -8.0 * e_r;
                let j_nom = Vector3::new(INERTIA[0], INERTIA[1], INERTIA[2]);
                torque_cmd =
                    j_nom.component_mul(&(25.0 * (omega_des - omega))) + omega.cross(&j_nom.component_mul(&omega));
                let motor_t = unmix * Vector4::new(thrust_cmd, torque_cmd.x, torque_cmd.y, torque_cmd.z);
                for i in 0..4 {
                    // Nominal thrust map inverted at the measured voltage.
                    pwm[i] = (65535.0 * (motor_t[i].max(0.0) / (C_T * vbat * vbat)).sqrt()).clamp(0.0, 65535.0);
                }
            } else {
                pwm = [0.0; 4];
                integral = Vector3::zeros();
                thrust_cmd = 0.0;
                torque_cmd = Vector3::zeros();
            }
            // Plant (true parameters).
            let thrusts: [f64; 4] =
                [0, 1, 2, 3].map(|i| tr.efficiency[i] * C_T * (pwm[i] / 65535.0).powi(2) * vbat * vbat);
            let wrench = mix * Vector4::new(thrusts[0], thrusts[1], thrusts[2], thrusts[3]);
            let force =
                q * Vector3::new(0.0, 0.0, wrench[0]) - DRAG * (vel - tr.wind) - Vector3::new(0.0, 0.0, tr.mass * G);
            accel = force / tr.mass;
            vel += accel * dt;
            p += vel * dt;
            if p.z <= 0.0 {
                p.z = 0.0;
                vel.z = vel.z.max(0.0);
                if !flying {
                    vel = Vector3::zeros();
                    omega = Vector3::zeros();
                }
            }
            let tau = Vector3::new(wrench[1], wrench[2], wrench[3]);
            let omega_dot = (tau - omega.cross(&tr.inertia.component_mul(&omega))).component_div(&tr.inertia);
            omega += omega_dot * dt;
            q *= UnitQuaternion::from_scaled_axis(omega * dt);
            // Battery: slow sag over the flight plus a drop under load.
            let load = thrusts.iter().sum::<f64>() / (tr.mass * G);
            if flying {
                v_start += dt;
            }
            vbat = tr.v0 - 0.35 * v_start / 60.0 - 0.12 * load;
        }
        if k % 10 == 0 && t >= 0.3 {
            logged_v = vbat;
        }
        // Sensors.
        let mut noisy = |sd: f64| sd * normal(rng);
        let pv = p + tr.pos_bias + Vector3::new(noisy(5e-4), noisy(5e-4), noisy(5e-4));
        let qn = q * UnitQuaternion::from_scaled_axis(Vector3::new(noisy(2e-3), noisy(2e-3), noisy(2e-3)));
        let (roll, pitch, yaw) = qn.euler_angles();
        let vv = vel + Vector3::new(noisy(0.01), noisy(0.01), noisy(0.01));
        let wv = omega + Vector3::new(noisy(0.02), noisy(0.02), noisy(0.02));
        let specific = q.inverse() * (accel + Vector3::new(0.0, 0.0, G)) / G;
        let acc = specific + Vector3::new(noisy(0.01), noisy(0.01), noisy(0.01));
        let gyro = omega + tr.gyro_bias + Vector3::new(noisy(0.005), noisy(0.005), noisy(0.005));
        let est_p = p + Vector3::new(noisy(2e-3), noisy(2e-3), noisy(2e-3));
        est_v_err = est_v_err * 0.95 + Vector3::new(noisy(0.004), noisy(0.004), noisy(0.004));
        let est_v = vel + est_v_err;
        let est_q = q * UnitQuaternion::from_scaled_axis(Vector3::new(noisy(5e-3), noisy(5e-3), noisy(5e-3)));
        let (er, ep, ey) = est_q.euler_angles();
        let sp = if flying { r } else { Vector3::zeros() };
        let qv = qn.quaternion();
        let eq = est_q.quaternion();
        let deg = |x: f64| x.to_degrees();
        let row = [
            t_start + t,
            pv.x,
            pv.y,
            pv.z,
            qv.i,
            qv.j,
            qv.k,
            qv.w,
            deg(roll),
            deg(pitch),
            deg(yaw),
            vv.x,
            vv.y,
            vv.z,
            wv.x,
            wv.y,
            wv.z,
            acc.x,
            acc.y,
            acc.z,
            gyro.x,
            gyro.y,
            gyro.z,
            pwm[0].round(),
            pwm[1].round(),
            pwm[2].round(),
            pwm[3].round(),
            est_p.x,
            est_p.y,
            est_p.z,
            est_v.x,
            est_v.y,
            est_v.z,
            accel.x,
            accel.y,
            accel.z,
            deg(er),
            deg(ep),
            deg(ey),
            eq.i,
            eq.j,
            eq.k,
            eq.w,
            sp.x,
            sp.y,
            sp.z,
            0.0,
            torque_cmd.x * 1e4,
            torque_cmd.y * 1e4,
            torque_cmd.z * 1e4,
            thrust_cmd / (4.0 * C_T * 16.0) * 65535.0,
            logged_v,
        ];
        for (i, x) in row.iter().enumerate() {
            if i > 0 {
                text.push(',');
            }
            let _ = write!(text, "{x:.9}");
        }
        text.push('\n');
    }
    (text, tr.v0, vbat, n_log)
}

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
