#!/usr/bin/env bash
# Mixed models at scale (issue 40), whole process, side by side in one run:
#  1. InstEval (lme4's data, 73,421 ratings), y ~ 1 + (1|s) + (1|d) + (1|dept):
#     `crossaudit mixed` (REML fit, Satterthwaite df, the whole summary)
#     against lme4's `lmer` alone (the fit, inside one R session, R's
#     start-up and reading not counted) and lmerTest's `lmer` + `summary`
#     (the fit and its Satterthwaite df).
#  2. A 1,000,000-row crossed set (benches/scale/cells.py: 2,000 recordings
#     x 250 seeds x 2 arms), fa_position_rmse_m ~ 1 + arm + (1|recording) +
#     (1|seed): `crossaudit mixed`, whole process (reading the CSV included).
# Median (and min) of RUNS each (lmer: at most 2, lmerTest: 1); the machine
# and commit on the first line.
#
#   bash benches/mixed/scale.sh [RUNS] > /tmp/ms.txt && cp /tmp/ms.txt results/benchmarks/mixed_scale.txt
set -euo pipefail
cd "$(dirname "$0")/../.."
runs=${1:-3}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cargo build --release --quiet --bin crossaudit
ca=${CARGO_TARGET_DIR:-target}/release/crossaudit
Rscript -e 'suppressMessages(library(lme4)); d <- InstEval;
  write.csv(data.frame(y = d$y, s = d$s, d = d$d, dept = d$dept), commandArgs(TRUE)[1], row.names = FALSE, quote = FALSE)' \
  "$tmp/insteval.csv"
python3 benches/scale/cells.py "$tmp/cells1m.csv"
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores, avx512f: $(grep -qo avx512f /proc/cpuinfo && echo yes || echo no); crossaudit $($ca --version | sed 's/crossaudit //'); $(Rscript -e 'cat("lme4", as.character(packageVersion("lme4")), "lmerTest", as.character(packageVersion("lmerTest")))')"
timed() {  # label, then the command: median and min wall time of $runs runs, CPU of the last
  local label=$1; shift
  python3 - "$runs" "$label" "$@" <<'PY'
import statistics, subprocess, sys, time
runs, label, cmd = int(sys.argv[1]), sys.argv[2], sys.argv[3:]
ts = []
for _ in range(runs):
    t0 = time.perf_counter(); r = subprocess.run(["/usr/bin/time", "-f", "%P %M"] + cmd, check=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True); ts.append(time.perf_counter() - t0)
cpu, kb = r.stderr.strip().splitlines()[-1].split()
df = [l for l in r.stdout.splitlines() if l.startswith("(Intercept)")]
print(f"{label}: {statistics.median(ts):.2f} s median, {min(ts):.2f} s min over {runs}; CPU {cpu}, peak {int(kb) // 1024} MB")
print(f"  {df[0] if df else ''}")
PY
}
echo "## InstEval, y ~ 1 + (1|s) + (1|d) + (1|dept), REML"
timed "crossaudit mixed (fit + Satterthwaite df + summary, whole process)" \
  "$ca" mixed --formula "y ~ 1 + (1|s) + (1|d) + (1|dept)" "$tmp/insteval.csv"
Rscript - "$tmp/insteval.csv" "$runs" <<'R'
suppressMessages({library(lme4); library(lmerTest)})
a <- commandArgs(TRUE); reps <- min(as.integer(a[2]), 2)
d <- read.csv(a[1], colClasses = "character"); d$y <- as.numeric(d$y)
form <- y ~ 1 + (1 | s) + (1 | d) + (1 | dept)
el <- numeric(reps)
for (i in 1:reps) el[i] <- system.time(m <- lme4::lmer(form, d))[["elapsed"]]
cat(sprintf("lme4 lmer alone (fit, inside R): %.2f s median, %.2f s min over %d\n", median(el), min(el), reps))
reps <- 1  # lmerTest's summary takes a minute and more
et <- numeric(reps)
for (i in 1:reps) et[i] <- system.time({mt <- lmerTest::lmer(form, d); s <- summary(mt)})[["elapsed"]]
cat(sprintf("lmerTest lmer + summary (fit + Satterthwaite df, inside R): %.2f s median, %.2f s min over %d\n", median(et), min(et), reps))
cat(sprintf("  (Intercept) %.6f %.6f df %.3f\n", s$coefficients[1, 1], s$coefficients[1, 2], s$coefficients[1, 3]))
R
echo "## 1,000,000 rows: fa_position_rmse_m ~ 1 + arm + (1|recording) + (1|seed), REML"
timed "crossaudit mixed (read 82 MB CSV + fit + Satterthwaite df + summary, whole process)" \
  "$ca" mixed --formula "fa_position_rmse_m ~ 1 + arm + (1|recording) + (1|seed)" "$tmp/cells1m.csv"
