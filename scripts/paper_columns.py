"""Which state columns make the paper's experiment closest to its Table 2?

    python3 scripts/paper_columns.py results/paper_columns > results/paper_columns/decision.md

Reads the two world-only runs (world_onboard, world_motion_capture) and puts
their disjoint and contaminated levels at 0.5, 1 and 2 s and their 1 s
divergence rates beside the paper's (../shared/paper/NUMBERS.md). The
distance of a run is the mean absolute relative difference of its six
levels from the paper's; the divergence rates are compared in percentage
points. The preset closer on both is chosen; if they disagree, the levels
decide (they are the paper's table).
"""
import json
import os
import sys

PAPER = {  # Table 2, world model: (contaminated, disjoint) in metres
    0.5: (0.096, 0.117),
    1.0: (0.262, 0.299),
    2.0: (0.662, 0.739),
}
PAPER_DIVERGENCE_1S = (0.2, 0.1)  # % of starts, contaminated / disjoint

root = sys.argv[1]
rows = {}
for preset in ["onboard", "motion_capture"]:
    r = json.load(open(os.path.join(root, f"world_{preset}", "report", "results.json")))
    levels = {}
    div = None
    for u in r["units"]:
        if u["model"] != "world":
            continue
        levels[u["horizon_s"]] = (u["mean_treated"], u["mean_reference"])
        if abs(u["horizon_s"] - 1.0) < 1e-9:
            c = u["conditional"]
            div = (100 * c["divergent_treated"] / c["starts_treated"], 100 * c["divergent_reference"] / c["starts_reference"])
    rel = [abs(levels[h][k] - PAPER[h][k]) / PAPER[h][k] for h in PAPER for k in (0, 1)]
    dist = sum(rel) / len(rel)
    ddiv = sum(abs(div[k] - PAPER_DIVERGENCE_1S[k]) for k in (0, 1)) / 2
    rows[preset] = (levels, div, dist, ddiv)

print("| preset | horizon | contaminated (m) | disjoint (m) | paper contaminated | paper disjoint |")
print("|---|---|---:|---:|---:|---:|")
for preset, (levels, _, _, _) in rows.items():
    for h in sorted(PAPER):
        c, d = levels[h]
        print(f"| {preset} | {h:g} s | {c:.3f} | {d:.3f} | {PAPER[h][0]:.3f} | {PAPER[h][1]:.3f} |")
print()
print("| preset | divergent at 1 s, contaminated / disjoint (%) | paper (%) | mean abs. relative difference of the six levels | mean abs. divergence difference (points) |")
print("|---|---|---|---:|---:|")
for preset, (_, div, dist, ddiv) in rows.items():
    print(f"| {preset} | {div[0]:.2f} / {div[1]:.2f} | 0.2 / 0.1 | {100 * dist:.1f}% | {ddiv:.2f} |")
by_levels = min(rows, key=lambda p: rows[p][2])
by_div = min(rows, key=lambda p: rows[p][3])
print()
if by_levels == by_div:
    print(f"Chosen: `state {by_levels}` (closer on both the levels and the divergence rate).")
else:
    print(f"Chosen: `state {by_levels}` (closer on the levels; `{by_div}` is closer on divergence).")
