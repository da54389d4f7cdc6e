#!/usr/bin/env python3
"""Random formulas and options for `crossaudit mixed` on three committed
fixtures (cbpp, Penicillin, Machines): terms drawn from each table's
columns, random terms of every form, sometimes one character changed,
with --family, --ml, --df, --profile, --compare, --weights, --offset,
--nagq and --json at random. Printed: a panic, an abort or a run past
120 s; then the count of each exit code.

    CA=target/release/crossaudit python3 fuzz/mutate/mixed_formulas.py N SEED"""
import os, random, re, sys

from answered import answered, failed
n, seed = int(sys.argv[1]), int(sys.argv[2])
rng = random.Random(seed)
F = "tests/fixtures/"
CA = os.environ.get("CA", "target/release/crossaudit")
sets = [
  (F+"glmm_cbpp.csv", ["cbind(incidence, healthy)", "incidence", "prop", "cbind(incidence, size - incidence)", "size", "healthy"],
   ["period", "size", "obs", "1", "period:size", "offset(log(size))", "herd"],
   ["(1|herd)", "(1|obs)", "(period|herd)", "(size||herd)", "(0 + size|herd)", "(1|herd:obs)", "(1|herd/obs)", "(1 + size|herd)", "(1|period)", "(obs|herd)"],
   ["binomial", "poisson", "gaussian"], ["size", "obs", "prop", "incidence"]),
  (F+"penicillin.csv", ["diameter"], ["1", "plate", "sample"],
   ["(1|plate)", "(1|sample)", "(1|plate:sample)", "(1|plate/sample)", "(sample|plate)", "(1|plate) + (1|plate)"], ["gaussian", "poisson"], ["diameter"]),
  (F+"machines.csv", ["score"], ["1", "Machine", "Worker", "Machine:Worker"],
   ["(1|Worker)", "(1|Worker:Machine)", "(Machine|Worker)", "(Machine||Worker)", "(0 + Machine|Worker)", "(1|Machine)"], ["gaussian"], ["score"]),
]
def formula(s):
    _, ys, fx, rs, _, _ = s
    parts = rng.sample(fx, rng.randint(0, min(3, len(fx)))) + rng.sample(rs, rng.randint(0, 3))
    if not parts: parts = ["1"]
    f = f"{rng.choice(ys)} ~ {' + '.join(parts)}"
    if rng.random() < 0.1:
        k = rng.randrange(len(f)); f = f[:k] + rng.choice(["", "(", ")", "|", "+", ":", "/", "*", " ", "1", "-", "0"]) + f[k+1:]
    return f
bad = {}; RC = {}
for i in range(n):
    s = rng.choice(sets)
    args = [CA, "mixed", s[0], "--formula", formula(s), "--family", rng.choice(s[4])]
    if rng.random() < 0.2: args += ["--ml"]
    if rng.random() < 0.2: args += ["--df", "kenward-roger"]
    if rng.random() < 0.15: args += ["--profile", rng.choice(["0.95", "0.5", "0.999", "1", "0", "0.9999999"])]
    if rng.random() < 0.1: args += ["--compare", formula(s)]
    if rng.random() < 0.1: args += ["--weights", rng.choice(s[5])]
    if rng.random() < 0.1: args += ["--offset", rng.choice(s[5])]
    if rng.random() < 0.15: args += ["--nagq", str(rng.choice([1, 2, 5, 25, 0, 26]))]
    if rng.random() < 0.3: args += ["--json"]
    rc, err = answered(args, 120)
    RC[rc] = RC.get(rc, 0) + 1
    if failed(rc, err):
        lines = [l for l in err.splitlines() if "panicked" in l]
        key = (rc, re.sub(r"\(\d+\)", "", lines[0]) if lines else err[-120:])
        if key not in bad:
            bad[key] = i
            print(i, rc, args[2:], err[:500].replace("\n", " | "), flush=True)
print("done", n, "distinct bad:", len(bad), RC, flush=True)
