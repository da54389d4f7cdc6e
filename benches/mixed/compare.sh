#!/usr/bin/env bash
# stats::mixed against lme4, side by side in one run, on two data sets:
# the per-cell differences d = contaminated - disjoint of the audited paper
# run's primary unit (world, 1 s: 24 recordings x 20 seeds, crossed), and
# the unbalanced Penicillin fixture. REML, y ~ 1 + (1|a) + (1|b); each tool
# fits 50 times and reports the median time of one fit (lme4: lmer with its
# default optimizer, inside R, so R's start-up is not counted).
#   bash benches/mixed/compare.sh > /tmp/m.txt && cp /tmp/m.txt results/benchmarks/mixed_vs_lme4.txt
# (through /tmp: a tracked file rewritten during the build marks it -dirty)
set -euo pipefail
cd "$(dirname "$0")/../.."
tmp=$(mktemp -d)
python3 - "$tmp/primary.csv" <<'PY'
import csv, sys
rows = {}
for r in csv.DictReader(open("results/nanobench_paper_audited/cells.csv")):
    if r["model"] == "world" and abs(float(r["horizon_s"]) - 1.0) < 1e-9:
        rows.setdefault((r["recording"], r["seed"]), {})[r["arm"]] = float(r["fa_position_rmse_m"])
with open(sys.argv[1], "w") as f:
    f.write("d,recording,seed\n")
    for (rec, seed), v in sorted(rows.items()):
        f.write(f"{v['contaminated'] - v['disjoint']!r},{rec},{seed}\n")
PY
cargo build --release --quiet --bin crossaudit --example mixed_fit
echo "# $(date -u +%FT%TZ), $(nproc) cores; crossaudit $(${CARGO_TARGET_DIR:-target}/release/crossaudit --version | sed 's/crossaudit //'), $(Rscript -e 'cat("lme4", as.character(packageVersion("lme4")))')"
for data in "$tmp/primary.csv" tests/fixtures/penicillin_unbalanced.csv; do
  echo "## $(basename "$data")"
  ${CARGO_TARGET_DIR:-target}/release/examples/mixed_fit "$data" 50
  Rscript - "$data" <<'R'
suppressMessages(library(lme4))
f <- commandArgs(TRUE)[1]
d <- read.csv(f, colClasses = "character"); d[[1]] <- as.numeric(d[[1]])
form <- as.formula(paste(names(d)[1], "~ 1 +", paste(sprintf("(1 | %s)", names(d)[-1]), collapse = " + ")))
t <- numeric(50)
for (i in 1:50) t[i] <- system.time(m <- lmer(form, d))[["elapsed"]]
vc <- as.data.frame(VarCorr(m))
cat(sprintf("lme4 rows %d intercept %.10f se %.8f residual %.8e\n", nrow(d), fixef(m)[[1]], sqrt(vcov(m)[1, 1]), vc$vcov[vc$grp == "Residual"]))
for (i in which(vc$grp != "Residual")) cat(sprintf("lme4 var %s %.8e\n", vc$grp[i], vc$vcov[i]))
cat(sprintf("lme4 median_fit_seconds %.6f over 50 fits\n", median(t)))
R
done
rm -rf "$tmp"
