#!/usr/bin/env bash
# Sparse mixed-model fits against lme4, side by side in one run (issue 75):
#  1. y ~ x + (x|g), 20 observations per group, 1,500, 2,500 and 10,000
#     groups (3,000 to 20,000 random effects), REML;
#  2. InstEval (lme4's data, 73,421 ratings) with a random slope:
#     y ~ service + (1|s) + (service|d) + (1|dept), REML;
#  3. the divergence endpoint's crossed binomial GLMM, diverged ~ arm +
#     (1|recording) + (1|seed) + (1|recording:seed), at 100 x 30 and
#     300 x 40 recordings x seeds, two arms per cell (3,130 and 12,340
#     random effects), Laplace.
# Data sets 1 and 3 are simulated in R with set.seed(75) (below).
# crossaudit: the whole process (reading the CSV, the fit, Satterthwaite df
# for the linear models, the summary), median and min of RUNS, CPU share and
# peak memory of the last; lme4: lmer or glmer alone with its defaults,
# inside one R session (R's start-up and reading not counted), median of
# min(RUNS, 2) (InstEval's slope model: 1). The criterion is the REML
# criterion (linear) or -2 log L (Laplace), each tool's own at its optimum;
# "crossaudit - lme4" below 0 is a lower (better) optimum.
#
#   bash benches/mixed/sparse.sh [RUNS] > /tmp/sp.txt && cp /tmp/sp.txt results/benchmarks/mixed_sparse.txt
set -euo pipefail
cd "$(dirname "$0")/../.."
runs=${1:-3}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cargo build --release --quiet --bin crossaudit
ca=${CARGO_TARGET_DIR:-target}/release/crossaudit
Rscript - "$tmp" <<'R'
suppressMessages(library(lme4))
out <- commandArgs(TRUE)[1]
set.seed(75)
for (G in c(1500, 2500, 10000)) {
  g <- rep(seq_len(G), each = 20); x <- rnorm(G * 20)
  b0 <- rnorm(G, 0, 1); b1 <- rnorm(G, 0, 0.5)
  y <- 1 + 0.3 * x + b0[g] + b1[g] * x + rnorm(G * 20)
  write.csv(data.frame(y = y, x = x, g = paste0("g", g)), file.path(out, sprintf("slope_%d.csv", G)), row.names = FALSE, quote = FALSE)
}
for (s in list(c(100, 30), c(300, 40))) {
  R <- s[1]; S <- s[2]
  d <- expand.grid(arm = c("disjoint", "contaminated"), seed = seq_len(S), recording = seq_len(R))
  a <- rnorm(R, 0, 0.8); b <- rnorm(S, 0, 0.3); ab <- matrix(rnorm(R * S, 0, 0.5), R, S)
  eta <- -1 + 0.4 * (d$arm == "contaminated") + a[d$recording] + b[d$seed] + ab[cbind(d$recording, d$seed)]
  d$diverged <- rbinom(nrow(d), 1, plogis(eta))
  d$recording <- paste0("r", d$recording); d$seed <- paste0("s", d$seed)
  write.csv(d[, c("diverged", "arm", "recording", "seed")], file.path(out, sprintf("glmm_%dx%d.csv", R, S)), row.names = FALSE, quote = FALSE)
}
d <- InstEval
write.csv(data.frame(y = d$y, s = d$s, d = d$d, dept = d$dept, service = as.integer(d$service) - 1L),
          file.path(out, "insteval.csv"), row.names = FALSE, quote = FALSE)
R
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores, avx512f: $(grep -qo avx512f /proc/cpuinfo && echo yes || echo no); crossaudit $($ca --version | sed 's/crossaudit //'); $(Rscript -e 'cat("R", R.version$major, R.version$minor, "lme4", as.character(packageVersion("lme4")))')"
timed() {  # label, criterion key (reml or laplace), then the command
  local label=$1 key=$2; shift 2
  python3 - "$runs" "$label" "$key" "$@" <<'PY'
import json, statistics, subprocess, sys, time
runs, label, key, cmd = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4:]
ts = []
for _ in range(runs):
    t0 = time.perf_counter()
    r = subprocess.run(["/usr/bin/time", "-f", "%P %M"] + cmd, check=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    ts.append(time.perf_counter() - t0)
cpu, kb = r.stderr.strip().splitlines()[-1].split()
d = json.loads(r.stdout)
crit = d["likelihood"]["reml_criterion"] if key == "reml" else d["fit"]["deviance"]
print(f"crossaudit {label}: {statistics.median(ts):.2f} s median, {min(ts):.2f} s min over {runs}; CPU {cpu}, peak {int(kb) // 1024} MB; criterion {crit:.8f}")
PY
}
lme4() {  # label, data file, formula, family, reps
  Rscript - "$@" <<'R'
suppressMessages(library(lme4))
a <- commandArgs(TRUE); label <- a[1]; f <- a[2]; form <- as.formula(a[3]); family <- a[4]; reps <- as.integer(a[5])
d <- read.csv(f, colClasses = "character")
num <- intersect(c("y", "x", "service", "diverged"), names(d))
for (v in num) d[[v]] <- as.numeric(d[[v]])
el <- numeric(reps)
for (i in seq_len(reps)) el[i] <- system.time(m <- if (family == "gaussian") lmer(form, d) else glmer(form, d, family = binomial))[["elapsed"]]
crit <- if (family == "gaussian") REMLcrit(m) else -2 * as.numeric(logLik(m))
cat(sprintf("lme4 %s: %.2f s median, %.2f s min over %d (%s alone, inside R); criterion %.8f\n",
            label, median(el), min(el), reps, if (family == "gaussian") "lmer" else "glmer", crit))
R
}
r2=$((runs < 2 ? runs : 2))
for G in 1500 2500 10000; do
  echo "## y ~ x + (x|g), $G groups of 20 ($((2 * G)) random effects), REML"
  timed "(x|g) G=$G" reml "$ca" mixed --json --formula "y ~ x + (x|g)" "$tmp/slope_$G.csv"
  lme4 "(x|g) G=$G" "$tmp/slope_$G.csv" "y ~ x + (x | g)" gaussian "$r2"
done
echo "## InstEval, y ~ service + (1|s) + (service|d) + (1|dept), REML (5,242 random effects)"
timed "InstEval slope" reml "$ca" mixed --json --formula "y ~ service + (1|s) + (service|d) + (1|dept)" "$tmp/insteval.csv"
lme4 "InstEval slope" "$tmp/insteval.csv" "y ~ service + (1 | s) + (service | d) + (1 | dept)" gaussian 1
for rs in 100x30 300x40; do
  echo "## diverged ~ arm + (1|recording) + (1|seed) + (1|recording:seed), ${rs} x 2 arms, binomial (Laplace)"
  timed "GLMM $rs" laplace "$ca" mixed --json --family binomial --formula "diverged ~ arm + (1|recording) + (1|seed) + (1|recording:seed)" "$tmp/glmm_$rs.csv"
  lme4 "GLMM $rs" "$tmp/glmm_$rs.csv" "diverged ~ arm + (1 | recording) + (1 | seed) + (1 | recording:seed)" binomial "$r2"
done
