"""Writes the level folders of a synthetic 256-specification multiverse run
for benches/scale/multiverse.design: per specification, spec-sK/cells.csv
(200 recordings x 50 seeds x 2 arms of one endpoint) and the run.json that
names its level, the design's SHA-256 and the cells' SHA-256, as a real run
writes them. d = mu_s + a_i + b_j + e_sij with the paper's component sizes:
recordings and seeds shared by every specification (they are paired, as in
a real multiverse), mu_s moved by each choice. Standard library only;
deterministic.

    python3 benches/scale/multiverse.py OUT_DIR [DESIGN] [I] [J] [SPECS]
"""
import hashlib
import json
import os
import random
import sys

out = sys.argv[1]
design = sys.argv[2] if len(sys.argv) > 2 else "benches/scale/multiverse.design"
n_rec = int(sys.argv[3]) if len(sys.argv) > 3 else 200
n_seed = int(sys.argv[4]) if len(sys.argv) > 4 else 50
n_spec = int(sys.argv[5]) if len(sys.argv) > 5 else 256
design_sha = hashlib.sha256(open(design, "rb").read()).hexdigest()
rng = random.Random(2026)
families = ["circle", "figure_eight", "helix", "lissajous", "oval", "star", "trefoil", "multisine_sysid"]
speeds = ["slow", "medium", "fast"]
recs = [(f"R{i:05d}", families[i % len(families)], speeds[(i // len(families)) % len(speeds)]) for i in range(n_rec)]
level = [rng.gauss(0.9, 0.25) for _ in recs]
a = [rng.gauss(0.0, 0.04) for _ in recs]
b = [rng.gauss(0.0, 0.02) for _ in range(n_seed)]
header = "model,arm,seed,recording,trajectory,speed,horizon_s,n_starts,n_divergent,fa_position_rmse_m,conditional_position_rmse_m,divergence_rate,velocity_rmse_mps,attitude_rmse_deg\n"
# Level folders are numbered with as many digits as the largest (spec-s001).
width = len(str(n_spec))
for k in range(n_spec):
    # Each of the eight choices moves d by a few millimetres when its
    # second alternative is taken (bit c of k).
    mu = -0.03 + sum(0.004 * (c % 3 - 1) for c in range(8) if k >> (7 - c) & 1)
    lines = [header]
    for arm in ("contaminated", "disjoint"):
        for j in range(n_seed):
            for i, (rec, traj, speed) in enumerate(recs):
                d = mu + a[i] + b[j] + rng.gauss(0.0, 0.05) if arm == "contaminated" else 0.0
                v = max(0.05, level[i] + d + rng.gauss(0.0, 0.02))
                lines.append(f"world,{arm},{j + 1},{rec},{traj},{speed},1,5,0,{v:.6f},{v:.6f},0,{v * 1.1:.6f},{v * 4:.6f}\n")
    text = "".join(lines).encode()
    d = os.path.join(out, f"spec-s{k + 1:0{width}d}")
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "cells.csv"), "wb") as f:
        f.write(text)
    record = {
        "study": "scale-multiverse",
        "design_sha256": design_sha,
        "data": {"kind": "directory", "path": "recordings"},
        "audit_sha256": "synthetic: benches/scale/multiverse.py",
        "manifests_sha256": "synthetic: benches/scale/multiverse.py",
        "exploratory": False,
        "crossaudit": "benches/scale/multiverse.py",
        "level": f"spec-s{k + 1:0{width}d}",
        "cells_sha256": hashlib.sha256(text).hexdigest(),
    }
    with open(os.path.join(d, "run.json"), "w") as f:
        json.dump(record, f, indent=2)
