"""An independent simulation of the optimism's coverage study
(specs/coverage_decision.json, `ratio` settings), to check
results/coverage_decision/ratio.csv within Monte Carlo error.

Independent of crossaudit: Python's own generator (random.Random.gauss),
the reference and contrast arrays drawn from the spec's components and
correlations as the study's model states them, and Fieller's set found
from the closed form of the method of moments on L(rho) = D + rho R: each
term's component of L(rho) is var_D + 2 rho cov + rho^2 var_R from the
arrays' (cross) mean squares, truncated at 0 as the MoM truncates, so
SE(rho)^2 = sum of the truncated components over their n; the set is every
rho with |mean L(rho)| <= t(J - 1) SE(rho), its ends found by doubling
steps and bisection. The delta method's interval is
rho_hat +- t SE(L(rho_hat)) / |mean R|.

  python3 scripts/reference/decision_coverage_reference.py > scripts/reference/decision_coverage_reference.out

Standard library only; about a minute. Prints, per setting and interval,
this simulation's coverage with its MCSE, crossaudit's from ratio.csv, and
whether they agree within 3 combined MCSEs.
"""

import csv
import json
import math
import random

SPEC = "specs/coverage_decision.json"
COMMITTED = "results/coverage_decision/ratio.csv"
REPS = 4000
# R: qt(0.975, 19)
T_975 = {19: 2.093024054408263}


def draw(s, rng):
    i, j = s["rows"], s["cols"]
    r, d, c = s["reference"], s["d"], s["correlation"]

    def pair(term):
        z1, z2 = rng.gauss(0, 1), rng.gauss(0, 1)
        rho = c[term]
        return math.sqrt(r[term]) * z1, math.sqrt(d[term]) * (rho * z1 + math.sqrt(max(0.0, 1 - rho * rho)) * z2)

    a = [pair("recording") for _ in range(i)]
    b = [pair("seed") for _ in range(j)]
    ref, con = [], []
    for x in range(i):
        rr, dd = [], []
        for y in range(j):
            e = pair("residual")
            rr.append(s["mean_reference"] + a[x][0] + b[y][0] + e[0])
            dd.append(s["mean_d"] + a[x][1] + b[y][1] + e[1])
        ref.append(rr)
        con.append(dd)
    return ref, con


def squares(x, y):
    """Mean (cross) squares of rows, columns and error, and the means."""
    i, j = len(x), len(x[0])
    gx = sum(map(sum, x)) / (i * j)
    gy = sum(map(sum, y)) / (i * j)
    rx, ry = [sum(v) / j for v in x], [sum(v) / j for v in y]
    cx = [sum(x[a][b] for a in range(i)) / i for b in range(j)]
    cy = [sum(y[a][b] for a in range(i)) / i for b in range(j)]
    rows = j * sum((rx[a] - gx) * (ry[a] - gy) for a in range(i)) / (i - 1)
    cols = i * sum((cx[b] - gx) * (cy[b] - gy) for b in range(j)) / (j - 1)
    err = sum((x[a][b] - rx[a] - cx[b] + gx) * (y[a][b] - ry[a] - cy[b] + gy)
              for a in range(i) for b in range(j)) / ((i - 1) * (j - 1))
    return rows, cols, err


def replicate(s, rng, t):
    i, j = s["rows"], s["cols"]
    ref, con = draw(s, rng)
    n = i * j
    mr = sum(map(sum, ref)) / n
    md = sum(map(sum, con)) / n
    dd, dr, rr = squares(con, con), squares(con, ref), squares(ref, ref)

    def se2(rho):
        ms = [dd[k] + 2 * rho * dr[k] + rho * rho * rr[k] for k in range(3)]
        comp = (max(0.0, (ms[0] - ms[2]) / j), max(0.0, (ms[1] - ms[2]) / i), ms[2])
        return comp[0] / i + comp[1] / j + comp[2] / n

    def excess(rho):
        return abs(md + rho * mr) - t * math.sqrt(se2(rho))

    rho_hat = -md / mr
    se_hat = math.sqrt(se2(rho_hat))
    delta_se = se_hat / abs(mr)

    def edge(step):
        inside, width = rho_hat, step
        for _ in range(60):
            if excess(inside + width) > 0:
                out = inside + width
                break
            inside += width
            width *= 2
        else:
            return None
        for _ in range(200):
            mid = inside + (out - inside) / 2
            if mid in (inside, out):
                break
            if excess(mid) > 0:
                out = mid
            else:
                inside = mid
        return inside

    # The reference mean's own interval holding 0 leaves the set unbounded.
    r_se = math.sqrt(max(0.0, (rr[0] - rr[2]) / j) / i + max(0.0, (rr[1] - rr[2]) / i) / j + rr[2] / n)
    if abs(mr) <= t * r_se:
        fieller = None
    else:
        lo, hi = edge(-delta_se), edge(delta_se)
        fieller = None if lo is None or hi is None else (lo, hi)
    return rho_hat, fieller, (rho_hat - t * delta_se, rho_hat + t * delta_se)


def main():
    spec = json.load(open(SPEC))
    committed = {(r["setting"], r["method"]): r for r in csv.DictReader(open(COMMITTED))}
    print(f"# {REPS} replications per setting (crossaudit's: {spec['reps']}), level {spec['level']}")
    for k, s in enumerate(spec["ratio"]):
        t = T_975[s["cols"] - 1]
        rng = random.Random(20261128 + k)
        truth = -s["mean_d"] / s["mean_reference"]
        hits = {"fieller": 0, "delta": 0}
        unbounded = 0
        for _ in range(REPS):
            _, f, dl = replicate(s, rng, t)
            unbounded += f is None
            hits["fieller"] += f is None or f[0] <= truth <= f[1]
            hits["delta"] += dl[0] <= truth <= dl[1]
        for method in ("fieller", "delta"):
            p = hits[method] / REPS
            mcse = math.sqrt(p * (1 - p) / REPS)
            c = committed[(s["label"], method)]
            q, qm = float(c["coverage"]), float(c["coverage_mcse"])
            z = (p - q) / math.sqrt(mcse ** 2 + qm ** 2)
            verdict = "agree" if abs(z) < 3 else "DISAGREE"
            print(f"{s['label']} | {method}: here {p:.4f} ({mcse:.4f}), crossaudit {q:.4f} ({qm:.4f}); "
                  f"z = {z:+.2f}: {verdict} within 3 combined MCSEs")
        print(f"{s['label']} | unbounded Fieller sets here: {unbounded}")


if __name__ == "__main__":
    main()
