# REML references for crossaudit's analysis of committed per-cell runs with
# cells deleted at random. Run from the repository root:
#
#   Rscript scripts/reference/mixed_cells_reference.R > scripts/reference/mixed_cells_reference.out
#
# R, lme4, lmerTest and pbkrtest from Debian (r-base-core r-cran-lme4
# r-cran-lmertest r-cran-pbkrtest). For each run it deletes 26 of the 480
# (recording, seed) cells of the primary unit (model world, horizon 1 s):
# the contaminated row of the first 13 drawn, the disjoint row of the other
# 13, with R's set.seed(15). It writes the deleted rows to
# tests/fixtures/deleted_cells_<run>.csv (the test removes them from the
# committed cells.csv and runs the real CLI on the rest) and prints the REML
# fit of d = contaminated - disjoint over the 454 pairs left:
# y ~ 1 + (1 | recording) + (1 | seed).
suppressMessages({ library(lme4); library(lmerTest); library(pbkrtest) })
ctl <- lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12, maxfun = 1e6),
                   check.conv.singular = "ignore")
cat("# lme4", as.character(packageVersion("lme4")), "lmerTest", as.character(packageVersion("lmerTest")),
    "pbkrtest", as.character(packageVersion("pbkrtest")), "R", R.version$major, R.version$minor, "\n")
for (run in c("nanobench_paper", "nanobench_paper_audited")) {
  cells <- read.csv(file.path("results", run, "cells.csv"), stringsAsFactors = FALSE)
  u <- cells[cells$model == "world" & cells$horizon_s == 1, ]
  t <- u[u$arm == "contaminated", c("recording", "seed", "fa_position_rmse_m")]
  r <- u[u$arm == "disjoint", c("recording", "seed", "fa_position_rmse_m")]
  m <- merge(t, r, by = c("recording", "seed"), suffixes = c(".t", ".r"))
  stopifnot(nrow(m) == 480)  # 24 recordings with a CSV x 20 seeds
  m <- m[order(m$recording, m$seed), ]
  set.seed(15)
  drop <- sample(nrow(m), 26)
  deleted <- data.frame(recording = m$recording[drop], seed = m$seed[drop],
                        arm = rep(c("contaminated", "disjoint"), each = 13))
  write.csv(deleted, file.path("tests/fixtures", paste0("deleted_cells_", run, ".csv")),
            row.names = FALSE, quote = FALSE)
  k <- m[-drop, ]
  k$d <- k$fa_position_rmse_m.t - k$fa_position_rmse_m.r
  k$recording <- factor(k$recording); k$seed <- factor(k$seed)
  f <- lme4::lmer(d ~ 1 + (1 | recording) + (1 | seed), k, control = ctl)
  vc <- as.data.frame(VarCorr(f))
  cat(run, "cells", nrow(k), "\n")
  cat(run, "criterion", format(f@devcomp$cmp[["REML"]], digits = 15), "\n")
  for (i in seq_len(nrow(vc))) cat(run, "var", vc$grp[i], format(vc$vcov[i], digits = 15), "\n")
  cat(run, "intercept", format(fixef(f)[[1]], digits = 15), "\n")
  cat(run, "se", format(sqrt(vcov(f)[1, 1]), digits = 15), "\n")
  cat(run, "singular", isSingular(f), "\n")
  V <- vcovAdj(f)
  cat(run, "kr_se", format(sqrt(as.matrix(V)[1, 1]), digits = 15), "\n")
  cat(run, "kr_df", format(Lb_ddf(matrix(1, 1, 1), vcov(f), V), digits = 15), "\n")
  ft <- lmerTest::lmer(d ~ 1 + (1 | recording) + (1 | seed), k, control = ctl)
  cat(run, "satterthwaite_df", format(summary(ft)$coefficients[1, "df"], digits = 15), "\n")
  # The 95% Kenward-Roger interval, as the report prints it.
  q <- qt(0.975, Lb_ddf(matrix(1, 1, 1), vcov(f), V))
  cat(run, "kr_lower", format(fixef(f)[[1]] - q * sqrt(as.matrix(V)[1, 1]), digits = 15), "\n")
  cat(run, "kr_upper", format(fixef(f)[[1]] + q * sqrt(as.matrix(V)[1, 1]), digits = 15), "\n")
}
