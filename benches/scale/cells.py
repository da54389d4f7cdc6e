"""Writes a synthetic per-cell CSV for benches/scale/scale.design: I
recordings x J seeds x 2 arms of one endpoint (default 2,000 x 250 x 2 =
1,000,000 rows), from the crossed model d = mu + a_i + b_j + e_ij with the
paper's component sizes. Standard library only; deterministic.

    python3 benches/scale/cells.py OUT.csv [I] [J]
"""
import random
import sys

out = sys.argv[1]
n_rec = int(sys.argv[2]) if len(sys.argv) > 2 else 2000
n_seed = int(sys.argv[3]) if len(sys.argv) > 3 else 250
rng = random.Random(2026)
families = ["circle", "figure_eight", "helix", "lissajous", "oval", "star", "trefoil", "multisine_sysid"]
speeds = ["slow", "medium", "fast"]
recs = [(f"R{i:05d}", families[i % len(families)], speeds[(i // len(families)) % len(speeds)]) for i in range(n_rec)]
level = [rng.gauss(0.9, 0.25) for _ in recs]
a = [rng.gauss(0.0, 0.04) for _ in recs]
b = [rng.gauss(0.0, 0.02) for _ in range(n_seed)]
header = "model,arm,seed,recording,trajectory,speed,horizon_s,n_starts,n_divergent,fa_position_rmse_m,conditional_position_rmse_m,divergence_rate,velocity_rmse_mps,attitude_rmse_deg\n"
with open(out, "w") as f:
    f.write(header)
    for arm, shift in (("contaminated", -0.03), ("disjoint", 0.0)):
        lines = []
        for j in range(n_seed):
            seed = j + 1
            for i, (rec, traj, speed) in enumerate(recs):
                d = shift + (a[i] + b[j] + rng.gauss(0.0, 0.05) if shift else 0.0)
                # Within the design's 2 m divergence cap (only files of more
                # than 2,000 recordings reach it).
                v = min(1.99, max(0.05, level[i] + d + rng.gauss(0.0, 0.02)))
                lines.append(f"world,{arm},{seed},{rec},{traj},{speed},1,5,0,{v:.6f},{v:.6f},0,{v * 1.1:.6f},{v * 4:.6f}\n")
            if len(lines) > 50000:
                f.writelines(lines)
                lines = []
        f.writelines(lines)
