#!/usr/bin/env python3
"""Simulated Crazyflie flight logs from RotorPy, for tests/fixtures/rotorpy.

Run outside CI (needs RotorPy, see requirements.txt next to this file):

    python -m venv /tmp/venv-rotorpy
    /tmp/venv-rotorpy/bin/pip install -r scripts/rotorpy/requirements.txt
    /tmp/venv-rotorpy/bin/python scripts/rotorpy/generate.py --out tests/fixtures/rotorpy/logs

Everything comes from RotorPy itself: the Crazyflie parameters
(rotorpy.vehicles.crazyflie_params.quad_params), the Multirotor dynamics, the
SE3Control geometric controller, the trajectory classes (ThreeDCircularTraj,
TwoDLissajous, MinSnap), the wind classes (SinusoidWind), the motion-capture
sensor (MotionCapture) and the Environment/simulate loop at 100 Hz.

One recording per file, `<ID>_<shape>_<speed>_rep<N>.csv.gz` (NanoBench
naming), gzip with mtime 0 so that reruns give identical bytes on the same
platform. Column names are RotorPy's own (rotorpy.utils.postprocessing.
unpack_sim_data), a subset of them; see tests/fixtures/rotorpy/README.md.

Each recording has its own seed, derived from --seed, the family, the speed
and the repetition (numpy SeedSequence). The seed drives both the random
trajectory parameters and numpy's global generator, which RotorPy's sensors
draw their noise from.
"""

import argparse
import gzip
import importlib.metadata
import io
import os
import sys

os.environ.setdefault("MPLBACKEND", "Agg")  # rotorpy.environments imports matplotlib

import numpy as np

from rotorpy.controllers.quadrotor_control import SE3Control
from rotorpy.environments import Environment
from rotorpy.sensors.external_mocap import MotionCapture
from rotorpy.simulate import ExitStatus
from rotorpy.trajectories.circular_traj import ThreeDCircularTraj
from rotorpy.trajectories.lissajous_traj import TwoDLissajous
from rotorpy.trajectories.minsnap import MinSnap
from rotorpy.vehicles.crazyflie_params import quad_params
from rotorpy.vehicles.multirotor import Multirotor
from rotorpy.wind.default_winds import SinusoidWind

SIM_RATE = 100  # Hz; the log is every simulator step
DT = 1.0 / SIM_RATE

# Peak speed of the reference (flat output) trajectory, m/s.
SPEEDS = {"slow": 0.4, "medium": 1.0, "fast": 1.8}
# Size of the shape, m, per speed class (so that the slow ones still show a
# good part of the shape within one recording).
SIZE = {"slow": 0.5, "medium": 0.8, "fast": 1.1}
FAMILIES = ["circle", "lissajous", "minsnap"]
CENTER = np.array([0.0, 0.0, 1.0])

# RotorPy's Environment default motion-capture parameters (rotorpy/environments.py),
# artifacts off.
MOCAP_PARAMS = {
    "pos_noise_density": 0.0005 * np.ones((3,)),
    "vel_noise_density": 0.0010 * np.ones((3,)),
    "att_noise_density": 0.0005 * np.ones((3,)),
    "rate_noise_density": 0.0005 * np.ones((3,)),
    "vel_artifact_max": 5,
    "vel_artifact_prob": 0.001,
    "rate_artifact_max": 1,
    "rate_artifact_prob": 0.0002,
}

# Columns written, in order, with RotorPy's names (unpack_sim_data).
COLUMNS = (
    ["time"]
    + ["mocap_x", "mocap_y", "mocap_z"]
    + ["mocap_xdot", "mocap_ydot", "mocap_zdot"]
    + ["mocap_qx", "mocap_qy", "mocap_qz", "mocap_qw"]
    + ["mocap_wx", "mocap_wy", "mocap_wz"]
    + ["windx", "windy", "windz"]
    + ["r1", "r2", "r3", "r4"]
    + ["xdes", "ydes", "zdes"]
    + ["r1des", "r2des", "r3des", "r4des"]
)


def peak_speed(traj, t_end, n=4001):
    ts = np.linspace(0.0, t_end, n)
    return max(float(np.linalg.norm(traj.update(t)["x_dot"])) for t in ts)


def make_circle(rng, speed, duration):
    """ThreeDCircularTraj: a circle in x-y, slightly tilted by a z term."""
    r = SIZE[speed] * rng.uniform(0.85, 1.15)
    rz = r * rng.uniform(0.0, 0.2)
    center = CENTER + np.array([rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2), 0.0])
    omega = SPEEDS[speed] / np.hypot(r, rz)  # peak |x_dot| = omega*sqrt(r^2+rz^2)
    f = omega / (2 * np.pi)
    traj = ThreeDCircularTraj(center=center, radius=np.array([r, r, rz]), freq=np.array([f, f, f]))
    desc = f"r={r:.2f} rz={rz:.2f} f={f:.3f}Hz"
    return traj, desc


def make_lissajous(rng, speed, duration):
    """TwoDLissajous with frequency ratio 1:2 (figure-8 for delta=0)."""
    A = SIZE[speed] * rng.uniform(0.9, 1.2)
    B = 0.5 * SIZE[speed] * rng.uniform(0.9, 1.2)
    delta = rng.uniform(0.0, np.pi / 2)
    tau = np.linspace(0.0, 2 * np.pi, 20001)
    unit_peak = np.max(np.hypot(A * np.cos(tau + delta), 2 * B * np.cos(2 * tau)))
    w = SPEEDS[speed] / unit_peak
    traj = TwoDLissajous(A=A, B=B, a=w, b=2 * w, delta=delta,
                         x_offset=CENTER[0], y_offset=CENTER[1], height=CENTER[2] + rng.uniform(-0.2, 0.2))
    desc = f"A={A:.2f} B={B:.2f} w={w:.3f}rad/s delta={delta:.2f}"
    return traj, desc


def make_minsnap(rng, speed, duration):
    """MinSnap through random waypoints, enough of them to last the recording.

    Waypoint sets whose reference overshoots the flight box are drawn again.
    """
    half = 1.2 * SIZE[speed] / SIZE["fast"] + 0.3  # half-width of the waypoint box, m
    target = SPEEDS[speed]
    for attempt in range(100):
        pts = [CENTER + np.array([rng.uniform(-half, half), rng.uniform(-half, half), 0.0])]
        while len(pts) < 60:
            p = CENTER + np.array([rng.uniform(-half, half), rng.uniform(-half, half), rng.uniform(-0.3, 0.3)])
            if np.linalg.norm(p - pts[-1]) >= 0.6 * half:
                pts.append(p)
        pts = np.array(pts)
        cum = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))))

        v_avg = target / 1.5
        npts = 0
        for _ in range(6):
            want = int(np.searchsorted(cum, 1.05 * duration * v_avg)) + 1
            want = max(3, min(want, len(pts)))
            if want == npts:
                break
            npts = want
            traj = MinSnap(pts[:npts], v_avg=v_avg, verbose=False)
            v_avg *= target / peak_speed(traj, traj.t_keyframes[-1])
        # Same waypoints, rescaled in time: the peak speed is now exactly the target.
        traj = MinSnap(pts[:npts], v_avg=v_avg, verbose=False)
        ts = np.linspace(0.0, traj.t_keyframes[-1], 2001)
        ref = np.array([traj.update(t)["x"] for t in ts]) - CENTER
        if np.max(np.abs(ref[:, :2])) <= half + 0.3 and np.max(np.abs(ref[:, 2])) <= 0.5:
            break
    else:
        raise RuntimeError("no MinSnap waypoint set stayed in the box")
    desc = f"{npts} waypoints v_avg={v_avg:.3f}m/s T={traj.t_keyframes[-1]:.1f}s (draw {attempt + 1})"
    return traj, desc


MAKERS = {"circle": make_circle, "lissajous": make_lissajous, "minsnap": make_minsnap}


def make_wind(rng):
    """SinusoidWind: a slow gust along a random horizontal direction, plus a little vertical."""
    mag = rng.uniform(0.2, 0.7)  # m/s, horizontal amplitude
    heading = rng.uniform(0.0, 2 * np.pi)
    amps = np.array([mag * np.cos(heading), mag * np.sin(heading), rng.uniform(0.0, 0.1)])
    f = rng.uniform(0.03, 0.2)  # Hz
    freqs = np.array([f, f, rng.uniform(0.1, 0.5)])
    phase = rng.uniform(0.0, 1.0 / f)  # seconds
    phases = np.array([phase, phase, rng.uniform(0.0, 10.0)])
    return SinusoidWind(amplitudes=amps, frequencies=freqs, phase=phases), f"|A|={mag:.2f}m/s f={f:.3f}Hz"


def recording_seed(base_seed, fam_idx, speed_idx, rep):
    return int(np.random.SeedSequence([base_seed, fam_idx, speed_idx, rep]).generate_state(1)[0])


def fly(family, speed, seed, duration):
    rng = np.random.default_rng(seed)
    np.random.seed(seed)  # RotorPy's sensors and wind draw from numpy's global generator
    traj, traj_desc = MAKERS[family](rng, speed, duration)
    wind, wind_desc = make_wind(rng)

    flat0 = traj.update(0.0)
    initial_state = {
        "x": np.array(flat0["x"], dtype=float),
        "v": np.array(flat0["x_dot"], dtype=float),
        "q": np.array([0.0, 0.0, 0.0, 1.0]),
        "w": np.zeros(3),
        "wind": np.zeros(3),
        "rotor_speeds": np.full(4, np.sqrt(quad_params["mass"] * 9.81 / (4 * quad_params["k_eta"]))),
    }
    vehicle = Multirotor(quad_params, initial_state=initial_state)
    controller = SE3Control(quad_params)
    mocap = MotionCapture(sampling_rate=SIM_RATE, mocap_params=MOCAP_PARAMS, with_artifacts=False)
    env = Environment(vehicle=vehicle, controller=controller, trajectory=traj, wind_profile=wind,
                      mocap=mocap, sim_rate=SIM_RATE)
    n = int(round(duration * SIM_RATE)) + 1
    # A hair past the end so that the float time accumulation cannot stop a step short.
    res = env.run(t_final=duration + 0.5 * DT, use_mocap=True, terminate=False)
    return res, n, traj_desc, wind_desc


def table(res, n):
    t = res["time"]
    if len(t) < n:
        raise RuntimeError(f"simulation stopped early at t={t[-1]:.2f}s: {res['exit'].value}")
    k = np.arange(n)
    if np.max(np.abs(t[:n] - k * DT)) > 1e-6:
        raise RuntimeError("simulator time is not k*0.01 s")
    s, mc, c, fl = res["state"], res["mocap_measurements"], res["control"], res["flat"]
    q = mc["q"][:n]
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    cols = np.hstack([
        (k * DT)[:, None],
        mc["x"][:n], mc["v"][:n], q, mc["w"][:n],
        s["wind"][:n], s["rotor_speeds"][:n],
        fl["x"][:n],
        c["cmd_motor_speeds"][:n],
    ])
    assert cols.shape[1] == len(COLUMNS)
    return cols


def write_csv_gz(path, data):
    buf = io.StringIO()
    buf.write(",".join(COLUMNS) + "\n")
    fmt = ["%.2f"] + ["%.6g"] * (len(COLUMNS) - 1)
    np.savetxt(buf, data, fmt=fmt, delimiter=",")
    raw = buf.getvalue().encode("ascii")
    with open(path, "wb") as f:
        with gzip.GzipFile(filename="", mode="wb", fileobj=f, compresslevel=9, mtime=0) as gz:
            gz.write(raw)


def check(data, res, n):
    """Divergence and format checks on what will be written."""
    if not np.all(np.isfinite(data)):
        raise RuntimeError("non-finite value")
    x = res["state"]["x"][:n]
    if np.max(np.abs(x - CENTER)) > 2.0:
        raise RuntimeError("position left the 2 m box: diverged")
    if np.max(np.linalg.norm(x - res["flat"]["x"][:n], axis=1)) > 0.5:
        raise RuntimeError("tracking error above 0.5 m: diverged")
    qn = np.linalg.norm(data[:, 7:11], axis=1)
    if np.max(np.abs(qn - 1)) > 1e-4:
        raise RuntimeError("quaternion not unit length")
    if res["exit"] not in (ExitStatus.TIMEOUT, ExitStatus.COMPLETE):
        raise RuntimeError(res["exit"].value)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="tests/fixtures/rotorpy/logs", help="output folder")
    ap.add_argument("--seed", type=int, default=20250611, help="base seed")
    ap.add_argument("--reps", type=int, default=3, help="repetitions per family x speed")
    ap.add_argument("--duration", type=float, default=12.0, help="seconds per recording")
    args = ap.parse_args(argv)

    os.makedirs(args.out, exist_ok=True)
    print(f"rotorpy {importlib.metadata.version('rotorpy')}, scipy {importlib.metadata.version('scipy')}, numpy {np.__version__}, seed {args.seed}, "
          f"{args.reps} reps, {args.duration:g} s at {SIM_RATE} Hz")
    print(f"{'file':34s} {'rows':>5s} {'|v|max':>7s} {'|vdes|max':>9s} {'|e|max':>7s} {'|e|rms':>7s} "
          f"{'cmd max':>7s}  trajectory / wind")
    total = 0
    rid = 0
    for fi, family in enumerate(FAMILIES):
        for si, speed in enumerate(SPEEDS):
            rid += 1
            for rep in range(1, args.reps + 1):
                seed = recording_seed(args.seed, fi, si, rep)
                res, n, traj_desc, wind_desc = fly(family, speed, seed, args.duration)
                data = table(res, n)
                check(data, res, n)
                name = f"R{rid}_{family}_{speed}_rep{rep}.csv.gz"
                path = os.path.join(args.out, name)
                write_csv_gz(path, data)
                size = os.path.getsize(path)
                total += size
                vmax = np.max(np.linalg.norm(res["mocap_measurements"]["v"][:n], axis=1))
                vdes = np.max(np.linalg.norm(res["flat"]["x_dot"][:n], axis=1))
                err = np.linalg.norm(res["state"]["x"][:n] - res["flat"]["x"][:n], axis=1)
                cmd = np.max(res["control"]["cmd_motor_speeds"][:n])
                print(f"{name:34s} {n:5d} {vmax:7.2f} {vdes:9.2f} {err.max():7.3f} "
                      f"{np.sqrt(np.mean(err**2)):7.3f} {cmd:7.0f}  {traj_desc}; wind {wind_desc}; "
                      f"{size/1024:.0f} KiB", flush=True)
    print(f"total {total/1e6:.2f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
