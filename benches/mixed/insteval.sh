#!/usr/bin/env bash
# stats::mixed against lme4 on lme4's InstEval (73,421 ratings; 2,972
# students s crossed with 1,128 lecturers d, lecturers nested in 14
# departments), side by side in one run:
#   y ~ 1 + (1|s) + (1|d)   and   y ~ 1 + (1|s) + (1|d) + (1|dept), REML.
# Timing: crossaudit's fit with what lmer returns (estimates, SEs,
# criterion; `--estimates`), median of 5 (3) fits, against lmer with its
# defaults, median of 3 (2) fits inside one R session (R's start-up not
# counted). Both single-threaded. Agreement: crossaudit's full fit with
# Satterthwaite df against lme4 run to a tight tolerance (BOBYQA, rhoend
# 1e-12) with lmerTest's Satterthwaite df. Kenward-Roger is not compared
# here: pbkrtest builds n x n matrices (73,421^2 doubles, 43 GB).
# The data are exported by R at run time and not committed.
#   bash benches/mixed/insteval.sh > /tmp/ie.txt && cp /tmp/ie.txt results/benchmarks/insteval_vs_lme4.txt
# (through /tmp: a tracked file rewritten during the build marks it -dirty)
set -euo pipefail
cd "$(dirname "$0")/../.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cargo build --release --quiet --bin crossaudit --example mixed_fit
Rscript -e 'suppressMessages(library(lme4)); d <- InstEval;
  write.csv(data.frame(y = d$y, s = d$s, d = d$d, dept = d$dept), commandArgs(TRUE)[1], row.names = FALSE, quote = FALSE)' \
  "$tmp/insteval.csv"
echo "# $(date -u +%FT%TZ), $(nproc) cores; crossaudit $(${CARGO_TARGET_DIR:-target}/release/crossaudit --version | sed 's/crossaudit //'), $(Rscript -e 'cat("lme4", as.character(packageVersion("lme4")), "lmerTest", as.character(packageVersion("lmerTest")))')"
echo "# InstEval: $(($(wc -l < "$tmp/insteval.csv") - 1)) rows"
for cols in s,d s,d,dept; do
  reps=5; rreps=3
  [ "$cols" = s,d,dept ] && { reps=3; rreps=2; }
  echo "## y ~ 1 + $(echo "$cols" | sed 's/\([a-z]*\)/(1|\1)/g; s/,/ + /g')"
  ${CARGO_TARGET_DIR:-target}/release/examples/mixed_fit "$tmp/insteval.csv" "$reps" --estimates --columns "$cols" \
    | sed -n 's/^crossaudit median_fit_seconds/crossaudit timing median_fit_seconds/p; s/^crossaudit criterion \([^ ]*\) evaluations \(.*\)/crossaudit timing evaluations \2/p'
  ${CARGO_TARGET_DIR:-target}/release/examples/mixed_fit "$tmp/insteval.csv" 1 --satterthwaite --columns "$cols" | grep -v median_fit_seconds
  Rscript - "$tmp/insteval.csv" "$cols" "$rreps" <<'R'
suppressMessages({library(lme4); library(lmerTest)})
a <- commandArgs(TRUE); cols <- strsplit(a[2], ",")[[1]]; reps <- as.integer(a[3])
d <- read.csv(a[1], colClasses = "character"); d$y <- as.numeric(d$y)
form <- as.formula(paste("y ~ 1 +", paste(sprintf("(1 | %s)", cols), collapse = " + ")))
el <- us <- numeric(reps)
for (i in 1:reps) { t <- system.time(m <- lme4::lmer(form, d)); el[i] <- t[["elapsed"]]; us[i] <- t[["user.self"]] }
cat(sprintf("lme4 timing median_fit_seconds %.3f (cpu %.3f) over %d fits, %d evaluations\n",
            median(el), median(us), reps, m@optinfo$feval))
ctl <- lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12, maxfun = 1e5))
m <- lmerTest::lmer(form, d, control = ctl)
vc <- as.data.frame(VarCorr(m))
cat(sprintf("lme4 rows %d intercept %.10f se %.8f residual %.8e\n", nrow(d), fixef(m)[[1]], sqrt(vcov(m)[1, 1]), vc$vcov[vc$grp == "Residual"]))
cat("lme4 theta", sprintf("%.10f", getME(m, "theta")), "\n")
cat(sprintf("lme4 criterion %.10f\n", m@devcomp$cmp[["REML"]]))
cat(sprintf("lme4 satterthwaite_df %.10f\n", summary(m)$coefficients[1, "df"]))
for (i in which(vc$grp != "Residual")) cat(sprintf("lme4 var %s %.8e\n", vc$grp[i], vc$vcov[i]))
R
done > "$tmp/out.txt"
cat "$tmp/out.txt"
echo "## relative differences, crossaudit vs lme4 (tight) + lmerTest"
python3 - "$tmp/out.txt" <<'PY'
import sys
model, vals = None, {}
for line in open(sys.argv[1]):
    f = line.split()
    if line.startswith("## "):
        model = line[3:].strip(); continue
    if len(f) < 3 or f[1] == "timing" or f[0] not in ("crossaudit", "lme4"):
        continue
    tool = f[0]
    if f[1] == "rows":
        pairs = {"intercept": f[4], "se": f[6], "residual": f[8]}
    elif f[1] == "var":
        pairs = {"var " + f[2]: f[3]}
    elif f[1] == "theta":
        pairs = {f"theta {i + 1}": v for i, v in enumerate(f[2:])}
    elif f[1] == "criterion":
        pairs = {"criterion": f[2]}
    else:
        pairs = {f[1]: f[2]}
    for k, v in pairs.items():
        vals.setdefault(model, {}).setdefault(k, {})[tool] = float(v)
for model, qs in vals.items():
    print(f"{model}")
    for k, v in qs.items():
        if "crossaudit" in v and "lme4" in v:
            rel = abs(v["crossaudit"] - v["lme4"]) / abs(v["lme4"])
            print(f"  {k:24s} crossaudit {v['crossaudit']:.10g}  lme4 {v['lme4']:.10g}  relative {rel:.1e}")
PY
