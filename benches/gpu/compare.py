"""Compares a GPU run's report with a CPU run's of the same design: the
same verdict line, and every estimate within RTOL relative (or RTOL x the
largest estimate's size, for estimates near zero).

    python3 benches/gpu/compare.py CPU_RUN GPU_RUN RTOL
"""
import csv
import sys

cpu, gpu, rtol = sys.argv[1], sys.argv[2], float(sys.argv[3])


def verdict(run):
    with open(f"{run}/report/report.md") as f:
        return next(line.strip() for line in f if line.startswith("decision"))


def estimates(run):
    with open(f"{run}/report/estimates.csv") as f:
        rows = list(csv.DictReader(f))
    # A row is named by the columns up to the level; the rest are numbers.
    names = list(rows[0].keys())
    named = names[: names.index("level") + 1]
    out = {}
    for r in rows:
        key = tuple(r[k] for k in named)
        for k in names[len(named):]:
            if r[k] not in ("", "true", "false"):
                out[key + (k,)] = float(r[k])
    return out


vc, vg = verdict(cpu), verdict(gpu)
print(f"CPU: {vc}\nGPU: {vg}")
if vc.split(":")[1] != vg.split(":")[1]:
    sys.exit("compare: the GPU's verdict is not the CPU's")
ec, eg = estimates(cpu), estimates(gpu)
if ec.keys() != eg.keys():
    sys.exit(f"compare: the estimates differ in their rows: {sorted(ec.keys() ^ eg.keys())[:5]}")
scale = max(abs(v) for v in ec.values()) or 1.0
worst = max(abs(eg[k] - ec[k]) / max(abs(ec[k]), scale * 1e-3) for k in ec)
print(f"{len(ec)} estimates; largest relative difference {worst:.2e} (tolerance {rtol})")
if worst > rtol:
    sys.exit("compare: an estimate differs by more than the tolerance")
