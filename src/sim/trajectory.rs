//! The reference trajectories: NanoBench's ten shapes, the catalogue of
//! simulated recordings, and the flight profile (idle, take-off, the
//! trajectory, landing) the controller tracks.

use nalgebra::Vector3;

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
pub(super) fn reference(kind: &str, tau: f64, v: f64, waypoints: &[Vector3<f64>]) -> Vector3<f64> {
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

/// The reference of one flight: idle on the ground, climb to the
/// trajectory's start, fly it, descend.
pub(super) struct Profile<'a> {
    pub kind: &'a str,
    /// Speed, m/s.
    pub v: f64,
    /// Seconds on the trajectory.
    pub duration: f64,
    pub waypoints: &'a [Vector3<f64>],
    pub hover_start: Vector3<f64>,
}

impl Profile<'_> {
    pub const IDLE: f64 = 1.0;
    pub const TAKEOFF: f64 = 2.0;
    pub const LAND: f64 = 2.0;

    /// Seconds logged in all (with half a second on the ground at the end).
    pub fn total(&self) -> f64 {
        Self::IDLE + Self::TAKEOFF + self.duration + Self::LAND + 0.5
    }

    /// Whether the motors run at time `t`.
    pub fn flying(&self, t: f64) -> bool {
        t >= Self::IDLE && t < Self::IDLE + Self::TAKEOFF + self.duration + Self::LAND
    }

    /// Reference position at time `t` of the flight.
    pub fn at(&self, t: f64) -> Vector3<f64> {
        let (idle, takeoff, land, duration) = (Self::IDLE, Self::TAKEOFF, Self::LAND, self.duration);
        if t < idle {
            Vector3::new(0.0, 0.0, 0.0)
        } else if t < idle + takeoff {
            let f = (t - idle) / takeoff;
            let f = f * f * (3.0 - 2.0 * f);
            self.hover_start * f
        } else if t < idle + takeoff + duration {
            reference(self.kind, t - idle - takeoff, self.v, self.waypoints)
        } else {
            let end = reference(self.kind, duration, self.v, self.waypoints);
            let f = ((t - idle - takeoff - duration) / land).min(1.0);
            let f = f * f * (3.0 - 2.0 * f);
            Vector3::new(end.x, end.y, end.z * (1.0 - f))
        }
    }
}
