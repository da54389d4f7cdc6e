//! One simulated flight: the vehicle's true parameters, the controller
//! (nominal parameters), the plant (true parameters) and the logged
//! sensors, written as NanoBench CSV text.

use std::fmt::Write as _;

use nalgebra::{Matrix4, UnitQuaternion, Vector3, Vector4};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::trajectory::Profile;
use crate::data::NANOBENCH_COLUMNS;
use crossaudit_stats::standard_normal as normal;

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

/// The simulated vehicle's state and the controller's memory.
struct Vehicle {
    p: Vector3<f64>,
    vel: Vector3<f64>,
    q: UnitQuaternion<f64>,
    omega: Vector3<f64>,
    /// Integral of the position error.
    integral: Vector3<f64>,
    accel: Vector3<f64>,
    pwm: [f64; 4],
    thrust_cmd: f64,
    torque_cmd: Vector3<f64>,
    /// Battery voltage.
    vbat: f64,
    /// Seconds flown so far (drives the battery's sag).
    flown: f64,
}

impl Vehicle {
    fn on_the_ground(v0: f64) -> Self {
        Vehicle {
            p: Vector3::new(0.0, 0.0, 0.0),
            vel: Vector3::zeros(),
            q: UnitQuaternion::identity(),
            omega: Vector3::zeros(),
            integral: Vector3::zeros(),
            accel: Vector3::zeros(),
            pwm: [0.0; 4],
            thrust_cmd: 0.0,
            torque_cmd: Vector3::zeros(),
            vbat: v0,
            flown: 0.0,
        }
    }

    /// The cascaded controller with nominal parameters: position PID ->
    /// thrust vector -> attitude P -> body-rate P -> mixing -> PWM.
    fn control(&mut self, r: Vector3<f64>, v_ref: Vector3<f64>, a_ref: Vector3<f64>, unmix: &Matrix4<f64>, dt: f64) {
        let e = r - self.p;
        self.integral += e * dt;
        self.integral = self.integral.map(|x| x.clamp(-0.5, 0.5));
        let a_cmd = a_ref
            + Vector3::new(6.0, 6.0, 8.0).component_mul(&e)
            + Vector3::new(4.0, 4.0, 5.0).component_mul(&(v_ref - self.vel))
            + self.integral * 1.0;
        let f = MASS * (a_cmd + Vector3::new(0.0, 0.0, G));
        let z_des = f.normalize();
        let z_body = self.q * Vector3::z();
        self.thrust_cmd = f.dot(&z_body).max(0.0);
        let x_c = Vector3::x();
        let y_des = z_des.cross(&x_c).normalize();
        let x_des = y_des.cross(&z_des);
        let r_des = nalgebra::Rotation3::from_basis_unchecked(&[x_des, y_des, z_des]);
        let r_now = self.q.to_rotation_matrix();
        let e_r_m = r_des.matrix().transpose() * r_now.matrix() - r_now.matrix().transpose() * r_des.matrix();
        let e_r = 0.5 * Vector3::new(e_r_m[(2, 1)], e_r_m[(0, 2)], e_r_m[(1, 0)]);
        let omega_des = -8.0 * e_r;
        let j_nom = Vector3::new(INERTIA[0], INERTIA[1], INERTIA[2]);
        let omega = self.omega;
        self.torque_cmd =
            j_nom.component_mul(&(25.0 * (omega_des - omega))) + omega.cross(&j_nom.component_mul(&omega));
        let tc = self.torque_cmd;
        let motor_t = unmix * Vector4::new(self.thrust_cmd, tc.x, tc.y, tc.z);
        let vbat = self.vbat;
        for i in 0..4 {
            // Nominal thrust map inverted at the measured voltage.
            self.pwm[i] = (65535.0 * (motor_t[i].max(0.0) / (C_T * vbat * vbat)).sqrt()).clamp(0.0, 65535.0);
        }
    }

    /// Motors off on the ground: the controller is reset.
    fn idle(&mut self) {
        self.pwm = [0.0; 4];
        self.integral = Vector3::zeros();
        self.thrust_cmd = 0.0;
        self.torque_cmd = Vector3::zeros();
    }

    /// One integration step of the plant with the true parameters, and the battery.
    fn step(&mut self, tr: &Truth, mix: &Matrix4<f64>, flying: bool, dt: f64) {
        let vbat = self.vbat;
        let pwm = self.pwm;
        let thrusts: [f64; 4] = [0, 1, 2, 3].map(|i| tr.efficiency[i] * C_T * (pwm[i] / 65535.0).powi(2) * vbat * vbat);
        let wrench = mix * Vector4::new(thrusts[0], thrusts[1], thrusts[2], thrusts[3]);
        let force = self.q * Vector3::new(0.0, 0.0, wrench[0])
            - DRAG * (self.vel - tr.wind)
            - Vector3::new(0.0, 0.0, tr.mass * G);
        self.accel = force / tr.mass;
        self.vel += self.accel * dt;
        self.p += self.vel * dt;
        if self.p.z <= 0.0 {
            self.p.z = 0.0;
            self.vel.z = self.vel.z.max(0.0);
            if !flying {
                self.vel = Vector3::zeros();
                self.omega = Vector3::zeros();
            }
        }
        let tau = Vector3::new(wrench[1], wrench[2], wrench[3]);
        let omega = self.omega;
        let omega_dot = (tau - omega.cross(&tr.inertia.component_mul(&omega))).component_div(&tr.inertia);
        self.omega += omega_dot * dt;
        self.q *= UnitQuaternion::from_scaled_axis(self.omega * dt);
        // Battery: slow sag over the flight plus a drop under load.
        let load = thrusts.iter().sum::<f64>() / (tr.mass * G);
        if flying {
            self.flown += dt;
        }
        self.vbat = tr.v0 - 0.35 * self.flown / 60.0 - 0.12 * load;
    }
}

/// One simulated recording as NanoBench CSV text, with its battery voltage
/// at the start and the end and its number of rows.
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
    let hover_start = super::trajectory::reference(kind, 0.0, v, &waypoints);
    let profile = Profile { kind, v, duration, waypoints: &waypoints, hover_start };
    let total = profile.total();
    let dt = 1.0 / SIM_HZ;
    let sub = (SIM_HZ / LOG_HZ) as usize;
    let mut craft = Vehicle::on_the_ground(tr.v0);
    let mut logged_v = 0.0;
    let mut text = String::with_capacity((total * LOG_HZ) as usize * 560);
    text.push_str(&NANOBENCH_COLUMNS.join(","));
    text.push('\n');
    let n_log = (total * LOG_HZ) as usize;
    // The onboard estimator's velocity error is smooth (a filter), not white.
    let mut est_v_err: Vector3<f64> = Vector3::zeros();
    for k in 0..n_log {
        let t = k as f64 / LOG_HZ;
        let flying = profile.flying(t);
        let r = profile.at(t);
        for _ in 0..sub {
            // The reference is read at the logged time for every sub-step.
            let r_next = profile.at(t + 0.01);
            let r_prev = profile.at((t - 0.01).max(0.0));
            let v_ref = (r_next - r_prev) / 0.02;
            let a_ref = (r_next - 2.0 * profile.at(t) + r_prev) / 1e-4;
            if flying {
                craft.control(r, v_ref, a_ref, &unmix, dt);
            } else {
                craft.idle();
            }
            craft.step(&tr, &mix, flying, dt);
        }
        if k % 10 == 0 && t >= 0.3 {
            logged_v = craft.vbat;
        }
        let sp = if flying { r } else { Vector3::zeros() };
        let row = sense(&craft, &tr, rng, &mut est_v_err, sp, t_start + t, logged_v);
        for (i, x) in row.iter().enumerate() {
            if i > 0 {
                text.push(',');
            }
            let _ = write!(text, "{x:.9}");
        }
        text.push('\n');
    }
    (text, tr.v0, craft.vbat, n_log)
}

/// One step's noisy sensor readings: motion capture, IMU and the onboard
/// estimate.
struct Readings {
    /// Motion capture: position, attitude, velocity and body rates.
    pv: Vector3<f64>,
    qn: UnitQuaternion<f64>,
    vv: Vector3<f64>,
    wv: Vector3<f64>,
    /// IMU: specific force (in g) and gyro.
    acc: Vector3<f64>,
    gyro: Vector3<f64>,
    /// The onboard estimate: position, velocity and attitude.
    est_p: Vector3<f64>,
    est_v: Vector3<f64>,
    est_q: UnitQuaternion<f64>,
}

/// The sensors' readings of the craft's state, their noise drawn in a
/// fixed order (the onboard velocity error `est_v_err` is carried from
/// step to step).
fn readings(craft: &Vehicle, tr: &Truth, rng: &mut ChaCha8Rng, est_v_err: &mut Vector3<f64>) -> Readings {
    let (p, q, vel, omega, accel) = (craft.p, craft.q, craft.vel, craft.omega, craft.accel);
    let mut noisy = |sd: f64| sd * normal(rng);
    let pv = p + tr.pos_bias + Vector3::new(noisy(5e-4), noisy(5e-4), noisy(5e-4));
    let qn = q * UnitQuaternion::from_scaled_axis(Vector3::new(noisy(2e-3), noisy(2e-3), noisy(2e-3)));
    let vv = vel + Vector3::new(noisy(0.01), noisy(0.01), noisy(0.01));
    let wv = omega + Vector3::new(noisy(0.02), noisy(0.02), noisy(0.02));
    let specific = q.inverse() * (accel + Vector3::new(0.0, 0.0, G)) / G;
    let acc = specific + Vector3::new(noisy(0.01), noisy(0.01), noisy(0.01));
    let gyro = omega + tr.gyro_bias + Vector3::new(noisy(0.005), noisy(0.005), noisy(0.005));
    let est_p = p + Vector3::new(noisy(2e-3), noisy(2e-3), noisy(2e-3));
    *est_v_err = *est_v_err * 0.95 + Vector3::new(noisy(0.004), noisy(0.004), noisy(0.004));
    let est_v = vel + *est_v_err;
    let est_q = q * UnitQuaternion::from_scaled_axis(Vector3::new(noisy(5e-3), noisy(5e-3), noisy(5e-3)));
    Readings { pv, qn, vv, wv, acc, gyro, est_p, est_v, est_q }
}

/// The 52 logged columns of one row: noisy motion capture, IMU, onboard
/// estimate, setpoint, controller output and battery.
fn sense(
    craft: &Vehicle,
    tr: &Truth,
    rng: &mut ChaCha8Rng,
    est_v_err: &mut Vector3<f64>,
    sp: Vector3<f64>,
    t: f64,
    logged_v: f64,
) -> [f64; 52] {
    let Readings { pv, qn, vv, wv, acc, gyro, est_p, est_v, est_q } = readings(craft, tr, rng, est_v_err);
    let accel = craft.accel;
    let (roll, pitch, yaw) = qn.euler_angles();
    let (er, ep, ey) = est_q.euler_angles();
    let qv = qn.quaternion();
    let eq = est_q.quaternion();
    let deg = |x: f64| x.to_degrees();
    let (pwm, tc, thrust_cmd) = (craft.pwm, craft.torque_cmd, craft.thrust_cmd);
    [
        t,
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
        tc.x * 1e4,
        tc.y * 1e4,
        tc.z * 1e4,
        thrust_cmd / (4.0 * C_T * 16.0) * 65535.0,
        logged_v,
    ]
}
