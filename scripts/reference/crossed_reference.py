"""Outside reference for crossaudit's crossed MoM estimator.

Computes, with statsmodels (OLS + anova_lm) and scipy, the two-way ANOVA mean
squares, the truncated MoM variance components, SE, t(J-1) interval and SE^2
shares for (a) the Penicillin data (lme4; Davies & Goldsmith 1972), and (b)
the primary contrast of crossaudit's committed synthetic example cells file.
Exact rational mean squares for Penicillin come from `fractions`.

    python3 -m venv .venv-ref && .venv-ref/bin/pip install numpy pandas statsmodels scipy
    .venv-ref/bin/python scripts/reference/crossed_reference.py

Its output is quoted in tests/stats_reference.rs.
"""
from fractions import Fraction
import sys

import numpy as np
import pandas as pd
import statsmodels.formula.api as smf
from statsmodels.stats.anova import anova_lm
from scipy import stats


def mom(df, y, row, col, level=0.95, df_rule="cols"):
    model = smf.ols(f"{y} ~ C({row}) + C({col})", data=df).fit()
    table = anova_lm(model)
    ms_r = table.loc[f"C({row})", "mean_sq"]
    ms_c = table.loc[f"C({col})", "mean_sq"]
    ms_e = table.loc["Residual", "mean_sq"]
    i_n = df[row].nunique()
    j_n = df[col].nunique()
    sa = max(0.0, (ms_r - ms_e) / j_n)
    sb = max(0.0, (ms_c - ms_e) / i_n)
    se2 = sa / i_n + sb / j_n + ms_e / (i_n * j_n)
    se = np.sqrt(se2)
    mu = df[y].mean()
    q = stats.t.ppf(0.5 + level / 2, j_n - 1)
    return dict(mean=mu, ms_rows=ms_r, ms_cols=ms_c, ms_error=ms_e, s2_row=sa, s2_col=sb,
                s2_res=ms_e, se=se, lower=mu - q * se, upper=mu + q * se,
                share_row=sa / i_n / se2, share_col=sb / j_n / se2,
                share_res=ms_e / (i_n * j_n) / se2)


def exact_ms(df, y, row, col):
    """Mean squares in exact rational arithmetic (integer data)."""
    rows = sorted(df[row].unique())
    cols = sorted(df[col].unique())
    val = {(r, c): Fraction(int(v)) for r, c, v in zip(df[row], df[col], df[y])}
    i_n, j_n = len(rows), len(cols)
    mu = sum(val.values()) / (i_n * j_n)
    rm = {r: sum(val[r, c] for c in cols) / j_n for r in rows}
    cm = {c: sum(val[r, c] for r in rows) / i_n for c in cols}
    ss_r = j_n * sum((rm[r] - mu) ** 2 for r in rows)
    ss_c = i_n * sum((cm[c] - mu) ** 2 for c in cols)
    ss_e = sum((val[r, c] - rm[r] - cm[c] + mu) ** 2 for r in rows for c in cols)
    return mu, ss_r / (i_n - 1), ss_c / (j_n - 1), ss_e / ((i_n - 1) * (j_n - 1))


def show(name, d):
    print(name)
    for k, v in d.items():
        print(f"  {k} = {v!r}")


pen = pd.read_csv("tests/fixtures/penicillin.csv")
show("penicillin (rows = plate, cols = sample)", mom(pen, "diameter", "plate", "sample"))
mu, msr, msc, mse = exact_ms(pen, "diameter", "plate", "sample")
print("penicillin exact:", f"mean = {mu} ({float(mu)!r})", f"ms_rows = {msr} ({float(msr)!r})",
      f"ms_cols = {msc} ({float(msc)!r})", f"ms_error = {mse} ({float(mse)!r})", sep="\n  ")

cells = pd.read_csv("examples/cells/nanobench_synthetic.csv")
sel = cells[(cells.model == "world") & (cells.horizon_s == 1.0)]
wide = sel.pivot_table(index=["recording", "seed"], columns="arm", values="fa_position_rmse_m")
wide = wide.reset_index()
wide["d"] = wide["contaminated"] - wide["disjoint"]
show("synthetic example, world fa_position_rmse at 1 s, contaminated - disjoint",
     mom(wide, "d", "recording", "seed"))
print("  optimism =", repr(100 * (wide.disjoint.mean() - wide.contaminated.mean()) / wide.disjoint.mean()))
