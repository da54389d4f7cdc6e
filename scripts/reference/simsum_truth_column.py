"""rsimsum's measures where the true value is a column (it differs by
replication), computed independently of crossaudit, with the formulas of
rsimsum's R/performance.R (ellessenne/rsimsum, commit 6041ba7, version
0.13.1.9000): rsimsum groups by `by` only, and uses each row's `:true`.

    bias     = mean(theta - true)            mcse sqrt(sum((theta - mean(theta))^2) / (n (n - 1)))
    rbias    = mean((theta - true) / true)   mcse sd((theta - true) / true) / sqrt(n)
    empse    = sd(theta)                     mcse empse / sqrt(2 (n - 1))
    mse      = mean((theta - true)^2)        mcse sqrt(sum(((theta - true)^2 - mse)^2) / (n (n - 1)))
    modelse  = sqrt(mean(se^2))              mcse sqrt(var(se^2) / (4 n modelse^2))
    cover    = mean(true in theta -+ z se)   mcse sqrt(cover (1 - cover) / n)
    becover  = mean(mean(theta) in theta -+ z se), power = mean(|theta| >= z se), same MCSE form

z = qnorm(0.975). Writes the replications (tests/fixtures/simsum_truth_column.csv)
and the expected values (scripts/reference/simsum_truth_column.out), which
tests/simsum.rs compares with `crossaudit simsum --true true_value`.

    python3 scripts/reference/simsum_truth_column.py
"""
import math
from statistics import NormalDist

Z = NormalDist().inv_cdf(0.975)


def replications():
    rows = []
    for i in range(1, 9):
        truth = 0.5 + 0.1 * i
        for m, shift, se in (("A", 0.0, 0.20), ("B", 0.07, 0.12)):
            # Deterministic estimates around each replication's truth.
            noise = 0.4 * math.sin(1.7 * i + (0.9 if m == "B" else 0.0))
            rows.append((i, m, truth, truth + shift + noise, se + 0.01 * (i % 3)))
    return rows


def mean(v):
    return sum(v) / len(v)


def var(v):
    m = mean(v)
    return sum((x - m) ** 2 for x in v) / (len(v) - 1)


def measures(rows):
    theta = [r[3] for r in rows]
    truth = [r[2] for r in rows]
    se = [r[4] for r in rows]
    n = len(rows)
    d = [t - u for t, u in zip(theta, truth)]
    rb = [(t - u) / u for t, u in zip(theta, truth)]
    sq = [x * x for x in d]
    mse = mean(sq)
    empse = math.sqrt(var(theta))
    se2 = [s * s for s in se]
    modelse = math.sqrt(mean(se2))
    share = lambda hits: sum(hits) / n
    cover = share([t - Z * s <= u <= t + Z * s for t, u, s in zip(theta, truth, se)])
    mt = mean(theta)
    becover = share([t - Z * s <= mt <= t + Z * s for t, s in zip(theta, se)])
    power = share([abs(t) >= Z * s for t, s in zip(theta, se)])
    p_mcse = lambda p: math.sqrt(p * (1 - p) / n)
    return {
        "nsim": (n, float("nan")),
        "bias": (mean(d), math.sqrt(sum((t - mt) ** 2 for t in theta) / (n * (n - 1)))),
        "rbias": (mean(rb), math.sqrt(var(rb)) / math.sqrt(n)),
        "empse": (empse, empse / math.sqrt(2 * (n - 1))),
        "mse": (mse, math.sqrt(sum((x - mse) ** 2 for x in sq) / (n * (n - 1)))),
        "modelse": (modelse, math.sqrt(var(se2) / (4 * n * modelse ** 2))),
        "cover": (cover, p_mcse(cover)),
        "becover": (becover, p_mcse(becover)),
        "power": (power, p_mcse(power)),
    }


def main():
    rows = replications()
    with open("tests/fixtures/simsum_truth_column.csv", "w") as f:
        f.write("rep,method,true_value,estimate,se\n")
        for r in rows:
            f.write(f"{r[0]},{r[1]},{r[2]!r},{r[3]!r},{r[4]!r}\n")
    with open("scripts/reference/simsum_truth_column.out", "w") as f:
        f.write("# method stat est mcse (scripts/reference/simsum_truth_column.py)\n")
        for m in ("A", "B"):
            for stat, (est, mcse) in measures([r for r in rows if r[1] == m]).items():
                f.write(f"{m} {stat} {est!r} {mcse!r}\n")


if __name__ == "__main__":
    main()
