"""Variance components of what the paper's decision reads, for the coverage
study of the interaction and the optimism (specs/coverage_decision.json).

From the reconstruction's per-cell results (results/nanobench_paper/cells.csv:
the paper's design on the 100 NanoBench logs at hand, 24 evaluation
recordings x 20 seeds), failure-aware position RMSE at 1 s:

- the interaction world - relative: the array d_world - d_relative, its
  crossed method-of-moments components (each truncated at 0);
- the world model's reference (disjoint) arm R and contrast D = T - R: each
  one's components, and per term the correlation of D with R from the
  cross mean products (cov = (MCP_term - MCP_error) / n, the MoM's
  formula applied to cross products), clipped to [-1, 1].

The SE each set of components gives, sqrt(s_rec/I + s_seed/J + s_res/(IJ)),
is printed beside the SE crossaudit's report gives for the same contrast
(results/nanobench_paper/report/estimates.csv), which it must equal.
Standard library only: python3 scripts/decision_components.py
"""

import csv
import math
import sys
from collections import defaultdict

CELLS = "results/nanobench_paper/cells.csv"
ESTIMATES = "results/nanobench_paper/report/estimates.csv"
METRIC, HORIZON = "fa_position_rmse_m", "1"


def arrays():
    """{(model, arm): {(recording, seed): value}} at the horizon."""
    out = defaultdict(dict)
    with open(CELLS, newline="") as f:
        for row in csv.DictReader(f):
            if row["horizon_s"] == HORIZON:
                out[(row["model"], row["arm"])][(row["recording"], row["seed"])] = float(row[METRIC])
    return out


def matrix(values, recordings, seeds):
    return [[values[(r, s)] for s in seeds] for r in recordings]


def cross_squares(x, y):
    """Mean cross products of rows, columns and error of two I x J arrays."""
    i, j = len(x), len(x[0])
    mean = lambda m: sum(map(sum, m)) / (i * j)
    rows = lambda m: [sum(r) / j for r in m]
    cols = lambda m: [sum(m[a][b] for a in range(i)) / i for b in range(j)]
    gx, gy, rx, ry, cx, cy = mean(x), mean(y), rows(x), rows(y), cols(x), cols(y)
    ms_rows = j * sum((rx[a] - gx) * (ry[a] - gy) for a in range(i)) / (i - 1)
    ms_cols = i * sum((cx[b] - gx) * (cy[b] - gy) for b in range(j)) / (j - 1)
    ms_err = sum(
        (x[a][b] - rx[a] - cx[b] + gx) * (y[a][b] - ry[a] - cy[b] + gy) for a in range(i) for b in range(j)
    ) / ((i - 1) * (j - 1))
    return ms_rows, ms_cols, ms_err


def components(x, y=None):
    """MoM components (recording, seed, residual); of a covariance when y is given (untruncated)."""
    i, j = len(x), len(x[0])
    r, c, e = cross_squares(x, x if y is None else y)
    comp = ((r - e) / j, (c - e) / i, e)
    return comp if y is not None else tuple(max(0.0, v) for v in comp)


def se(comp, i, j):
    return math.sqrt(comp[0] / i + comp[1] / j + comp[2] / (i * j))


def reported_se(kind, model):
    with open(ESTIMATES, newline="") as f:
        for row in csv.DictReader(f):
            if row["kind"] == kind and row["model"] == model and row["horizon_s"] == HORIZON and row["estimator"] == "crossed_mom":
                return float(row["se"])
    sys.exit(f"no {kind} {model} row in {ESTIMATES}")


def main():
    a = arrays()
    recordings = sorted({r for (r, _) in a[("world", "disjoint")]})
    seeds = sorted({s for (_, s) in a[("world", "disjoint")]}, key=int)
    i, j = len(recordings), len(seeds)
    m = {k: matrix(v, recordings, seeds) for k, v in a.items()}
    d = {model: [[m[(model, "contaminated")][x][y] - m[(model, "disjoint")][x][y] for y in range(j)] for x in range(i)]
         for model in ("world", "relative")}
    inter = [[d["world"][x][y] - d["relative"][x][y] for y in range(j)] for x in range(i)]
    ci = components(inter)
    print(f"{i} recordings x {j} seeds, {METRIC} at {HORIZON} s")
    print(f"interaction world - relative: components {ci[0]:.6g} {ci[1]:.6g} {ci[2]:.6g}; "
          f"SE {se(ci, i, j):.10g} (report: {reported_se('interaction', 'world - relative'):.10g}); "
          f"mean {sum(map(sum, inter)) / (i * j):.6g}")
    r, dw = m[("world", "disjoint")], d["world"]
    cr, cd, cov = components(r), components(dw), components(dw, r)
    corr = [max(-1.0, min(1.0, cv / math.sqrt(vr * vd))) if vr > 0 and vd > 0 else 0.0
            for cv, vr, vd in zip(cov, cr, cd)]
    print(f"world reference (disjoint): components {cr[0]:.6g} {cr[1]:.6g} {cr[2]:.6g}; mean {sum(map(sum, r)) / (i * j):.6g}")
    print(f"world contrast d: components {cd[0]:.6g} {cd[1]:.6g} {cd[2]:.6g}; SE {se(cd, i, j):.10g} "
          f"(report: {reported_se('endpoint', 'world'):.10g}); mean {sum(map(sum, dw)) / (i * j):.6g}")
    print(f"correlation of d with the reference, per term: {corr[0]:.4f} {corr[1]:.4f} {corr[2]:.4f}")
    # The paper's interaction at 1 s, 0.0145 [-0.0035, 0.0324] m with t(19)
    # (../shared/paper/NUMBERS.md): its SE; the reconstruction's components
    # scaled to give it at the paper's 26 x 20 (coverage depends only on the
    # shares, so the scale sets the widths alone).
    t19 = 2.093024054408263  # R: qt(0.975, 19)
    se_paper = (0.0324 + 0.0035) / (2 * t19)
    k = se_paper ** 2 / se(ci, 26, j) ** 2
    print(f"interaction at the paper's SE {se_paper:.6g} over 26 x {j}: components "
          f"{k * ci[0]:.6g} {k * ci[1]:.6g} {k * ci[2]:.6g}")


if __name__ == "__main__":
    main()
