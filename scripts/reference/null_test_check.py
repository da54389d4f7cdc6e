"""The specification curve under the null, computed independently of
crossaudit (NumPy only, its own random numbers) from a multiverse run's
committed multiverse_cells.csv and report/specs.csv.

Simonsohn, Simmons and Nelson (2020), "Specification curve analysis",
Nature Human Behaviour 4, step 3 (specr's `boot_null`): each
specification's d = treated - reference matrix (recording x seed, on the
recordings every specification shares) is centred at zero; every bootstrap
replicate draws recordings and seeds with replacement once (the pigeonhole
bootstrap, Owen 2007) and applies that draw to every specification. For the
median d over specifications, the number of specifications meeting the
rule (each specification's own interval half-widths and reference mean
from specs.csv, its d replaced by the replicate's), and Stouffer's combined
t (d / bootstrap SE, summed, over sqrt(S)), the one-sided p-value in the
rule's direction is (1 + replicates at least as extreme) / (1 + B).

Usage (writes the p-values and their Monte Carlo standard errors):
  python3 scripts/reference/null_test_check.py RUN_DIR MODEL METRIC HORIZON \
      TREATED REFERENCE OPTIMISM_PCT B SEED > RUN_DIR/reference/null_test.out
"""
import csv
import sys

import numpy as np

run, model, metric, horizon, treated, reference = sys.argv[1:7]
min_optimism, B, seed = float(sys.argv[7]), int(sys.argv[8]), int(sys.argv[9])
horizon = float(horizon)

with open(f"{run}/multiverse_cells.csv") as f:
    rows = list(csv.DictReader(f))
# Per-seed draws (`draws per seed`): each seed of a specification has one
# draw of its own, and every seed counts; under draw replication only the
# first draw does.
draws_of = {}
for r in rows:
    draws_of.setdefault((r["spec"], r["seed"]), set()).add(r["draw"])
per_seed = len({r["draw"] for r in rows}) > 1 and all(len(d) == 1 for d in draws_of.values())
cells = {}
for r in rows:
    if (not per_seed and r["draw"] not in ("", "1")) or r["model"] != model or float(r["horizon_s"]) != horizon:
        continue
    cells.setdefault(r["spec"], {})[(r["arm"], r["recording"], int(r["seed"]))] = float(r[metric])
specs = []
with open(f"{run}/report/specs.csv") as f:
    for r in csv.DictReader(f):
        specs.append(r)
ids = [s["spec"] for s in specs]

def diff(spec):
    c = cells[spec]
    return {(rec, sd): c[(treated, rec, sd)] - c[(reference, rec, sd)]
            for (arm, rec, sd) in c if arm == treated and (reference, rec, sd) in c}

diffs = [diff(s) for s in ids]
recs = sorted(set.intersection(*[{k[0] for k in d} for d in diffs]))
seeds = sorted(set.intersection(*[{k[1] for k in d} for d in diffs]))
mats = np.array([[[d[(r, s)] for s in seeds] for r in recs] for d in diffs])  # S x I x J
S, I, J = mats.shape
observed = mats.mean(axis=(1, 2))

rng = np.random.default_rng(seed)
reps = np.empty((B, S))
for b in range(B):
    rc = np.bincount(rng.integers(0, I, I), minlength=I)
    cc = np.bincount(rng.integers(0, J, J), minlength=J)
    reps[b] = np.einsum("sij,i,j->s", mats, rc, cc) / (I * J)
se = reps.std(axis=0, ddof=1)
null = reps - observed  # each replicate's d of the centred matrices

half_lo = np.array([float(s["estimate"]) - float(s["lower"]) for s in specs])
half_hi = np.array([float(s["upper"]) - float(s["estimate"]) for s in specs])
ref_mean = np.array([float(s["reference_mean"]) for s in specs])

def holding(d):
    upper = d + half_hi
    optimism = -100.0 * d / ref_mean
    return int(np.sum((optimism >= min_optimism) & (upper < 0)))

def stouffer(d):
    return float(np.sum(d / se) / np.sqrt(S))

med_obs, hold_obs, z_obs = float(np.median(observed)), holding(observed), stouffer(observed)
at_med = int(np.sum(np.median(null, axis=1) <= med_obs))
at_hold = int(sum(holding(null[b]) >= hold_obs for b in range(B)))
at_z = int(sum(stouffer(null[b]) <= z_obs for b in range(B)))

def p(m):
    return (1 + m) / (1 + B)

def mcse(q):
    return (q * (1 - q) / B) ** 0.5

print(f"# {run}: {S} specifications, {I} shared recordings x {J} seeds, B = {B}, numpy seed {seed}")
print("statistic,observed,p,mcse")
print(f"median_d,{med_obs:.10g},{p(at_med):.6f},{mcse(p(at_med)):.6f}")
print(f"holding,{hold_obs},{p(at_hold):.6f},{mcse(p(at_hold)):.6f}")
print(f"stouffer,{z_obs:.10g},{p(at_z):.6f},{mcse(p(at_z)):.6f}")
