"""Outside reference for crossaudit's interval of the optimism
rho = (mean_R - mean_T) / mean_R (crates/stats/src/ratio.rs).

Written from the definitions, sharing no code with crossaudit:

- Fieller's closed form. The optimism x is tested by the crossed method of
  moments on L(x) = T - (1 - x) R. With untruncated moment components the
  SE^2 of L(x) is a quadratic in x built from the bivariate mean squares of
  (d, R), d = T - R; the interval's edges are the roots of
  (mean_d + x mean_R)^2 = t^2 SE^2(L(x)). The script checks that no
  component is truncated at the roots, where crossaudit's numerical
  inversion of the truncated estimator agrees with the closed form.
- The delta method: x_hat +- t SE(L(x_hat)) / |mean_R|.
- A pigeonhole bootstrap of the ratio (rows and columns resampled
  independently with replacement, 9,999 replicates, percentile interval),
  the resampling check of the two analytic intervals.
- A Monte Carlo coverage of both intervals under the crossed model with the
  paper run's variance components (26 x 20, 2,000 replications).

Inputs: the primary endpoint of results/multiverse/per_seed/cells.csv (the
paper design with per-seed draws) and of results/quickstart/cells.csv.

    python3 -m venv .venv-ref && .venv-ref/bin/pip install numpy scipy
    .venv-ref/bin/python scripts/reference/optimism_interval.py > scripts/reference/optimism_interval.out

Its output is read by tests/optimism_interval.rs.
"""
import csv
import sys

import numpy as np
from scipy import stats


def arrays(path, model, horizon, treated, reference):
    rows = {}
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            if r["model"] != model or float(r["horizon_s"]) != horizon:
                continue
            rows.setdefault(r["recording"], {}).setdefault(int(r["seed"]), {})[r["arm"]] = float(
                r["fa_position_rmse_m"]
            )
    recs = sorted(rows)
    seeds = sorted(rows[recs[0]])
    t = np.array([[rows[i][j][treated] for j in seeds] for i in recs])
    r = np.array([[rows[i][j][reference] for j in seeds] for i in recs])
    return t, r


def cross_ms(a, b):
    """Bivariate two-way ANOVA mean products (rows, cols, error) of a and b."""
    i_n, j_n = a.shape
    ra, ca, ma = a.mean(1), a.mean(0), a.mean()
    rb, cb, mb = b.mean(1), b.mean(0), b.mean()
    rows = j_n * np.sum((ra - ma) * (rb - mb)) / (i_n - 1)
    cols = i_n * np.sum((ca - ma) * (cb - mb)) / (j_n - 1)
    ea = a - ra[:, None] - ca[None, :] + ma
    eb = b - rb[:, None] - cb[None, :] + mb
    err = np.sum(ea * eb) / ((i_n - 1) * (j_n - 1))
    return np.array([rows, cols, err])


def se2_untruncated(ms, i_n, j_n):
    """SE^2 of the grand mean from mean squares, components not truncated."""
    sa = (ms[0] - ms[2]) / j_n
    sb = (ms[1] - ms[2]) / i_n
    return sa / i_n + sb / j_n + ms[2] / (i_n * j_n), sa, sb


def mom(x, level=0.95):
    i_n, j_n = x.shape
    ms = cross_ms(x, x)
    sa = max(0.0, (ms[0] - ms[2]) / j_n)
    sb = max(0.0, (ms[1] - ms[2]) / i_n)
    se = np.sqrt(sa / i_n + sb / j_n + ms[2] / (i_n * j_n))
    q = stats.t.ppf(0.5 + level / 2, j_n - 1)
    return x.mean(), se, q


def intervals(t, r, level=0.95, strict=True):
    i_n, j_n = t.shape
    d = t - r
    q = stats.t.ppf(0.5 + level / 2, j_n - 1)
    md, mr = d.mean(), r.mean()
    rho = -md / mr
    # SE^2(L(x)) = A + 2 B x + C x^2 with L(x) = d + x r.
    m_dd, m_dr, m_rr = cross_ms(d, d), cross_ms(d, r), cross_ms(r, r)
    a_, _, _ = se2_untruncated(m_dd, i_n, j_n)
    b_, _, _ = se2_untruncated(m_dr, i_n, j_n)
    c_, _, _ = se2_untruncated(m_rr, i_n, j_n)
    qa = mr * mr - q * q * c_
    qb = 2 * md * mr - 2 * q * q * b_
    qc = md * md - q * q * a_
    disc = qb * qb - 4 * qa * qc
    lo, hi = sorted([(-qb - np.sqrt(disc)) / (2 * qa), (-qb + np.sqrt(disc)) / (2 * qa)])
    # No component truncated at either root (else crossaudit's truncated
    # estimator would bend the quadratic there).
    for x in (lo, hi):
        _, sa, sb = se2_untruncated(m_dd + 2 * x * m_dr + x * x * m_rr, i_n, j_n)
        assert not strict or (sa > 0 and sb > 0), "a component is truncated at a root"
    se_l = np.sqrt(a_ + 2 * b_ * rho + c_ * rho * rho)
    _, sa, sb = se2_untruncated(m_dd + 2 * rho * m_dr + rho * rho * m_rr, i_n, j_n)
    assert not strict or (sa > 0 and sb > 0)
    delta_se = se_l / abs(mr)
    return dict(
        optimism=100 * rho,
        fieller_lower=100 * lo,
        fieller_upper=100 * hi,
        delta_se=100 * delta_se,
        delta_lower=100 * (rho - q * delta_se),
        delta_upper=100 * (rho + q * delta_se),
        d_mean=md,
        d_lower=mom(d)[0] - mom(d)[2] * mom(d)[1],
        d_upper=mom(d)[0] + mom(d)[2] * mom(d)[1],
    )


def bootstrap(t, r, reps=9999, seed=20261128, level=0.95):
    rng = np.random.default_rng(seed)
    i_n, j_n = t.shape
    out = np.empty(reps)
    for b in range(reps):
        ii = rng.integers(0, i_n, i_n)
        jj = rng.integers(0, j_n, j_n)
        tb = t[np.ix_(ii, jj)].mean()
        rb = r[np.ix_(ii, jj)].mean()
        out[b] = 100 * (rb - tb) / rb
    a = (1 - level) / 2
    return np.quantile(out, a), np.quantile(out, 1 - a)


def coverage(reps=2000, seed=7, i_n=26, j_n=20):
    """Coverage of both intervals when T = (1 - rho) R + crossed noise, with
    the reference arm's and d's crossed components near the paper run's."""
    rng = np.random.default_rng(seed)
    rho = 0.10
    hits_f = hits_d = 0
    for _ in range(reps):
        r = (
            0.30
            + rng.normal(0, 0.08, (i_n, 1))
            + rng.normal(0, 0.04, (1, j_n))
            + rng.normal(0, 0.05, (i_n, j_n))
        )
        t = (
            (1 - rho) * r
            + rng.normal(0, 0.033, (i_n, 1))
            + rng.normal(0, 0.043, (1, j_n))
            + rng.normal(0, 0.083, (i_n, j_n))
        )
        iv = intervals(t, r, strict=False)
        hits_f += iv["fieller_lower"] <= 100 * rho <= iv["fieller_upper"]
        hits_d += iv["delta_lower"] <= 100 * rho <= iv["delta_upper"]
    return hits_f / reps, hits_d / reps, reps


def main():
    cases = [
        ("per_seed", "results/multiverse/per_seed/cells.csv", "world", 1.0),
        ("quickstart", "results/quickstart/cells.csv", "world", 1.0),
    ]
    for name, path, model, h in cases:
        t, r = arrays(path, model, h, "contaminated", "disjoint")
        iv = intervals(t, r)
        print(f"case {name} {path} {model} {h} {t.shape[0]}x{t.shape[1]}")
        for k, v in iv.items():
            print(f"  {k} {float(v)!r}")
        lo, hi = bootstrap(t, r)
        print(f"  bootstrap_lower {float(lo)!r}")
        print(f"  bootstrap_upper {float(hi)!r}")
    f, d, n = coverage()
    print(f"coverage fieller {float(f)!r} delta {float(d)!r} replications {n}")


if __name__ == "__main__":
    sys.exit(main())
