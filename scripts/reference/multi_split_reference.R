# lme4 reference for crossaudit's pooled estimate of a multi-split study,
# on committed per-cell runs. Run from the repository root:
#
#   Rscript scripts/reference/multi_split_reference.R > scripts/reference/multi_split_reference.out
#
# R, lme4, lmerTest and pbkrtest from Debian (r-base-core r-cran-lme4
# r-cran-lmertest r-cran-pbkrtest). For each run it takes the primary unit
# (model world, horizon 1 s, fa_position_rmse_m), pairs each split's
# contaminated and disjoint cells by (split, recording, seed), and fits the
# pooled model of crossaudit's report (src/analysis/family.rs):
# d ~ 1 + (1 | split) + (1 | recording) + (1 | seed), REML, with the
# Satterthwaite df of lmerTest, the Kenward-Roger SE and df of pbkrtest,
# and the 95% Satterthwaite interval the report prints.
suppressMessages({ library(lme4); library(lmerTest); library(pbkrtest) })
ctl <- lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12, maxfun = 1e6),
                   check.conv.singular = "ignore")
cat("# lme4", as.character(packageVersion("lme4")), "lmerTest", as.character(packageVersion("lmerTest")),
    "pbkrtest", as.character(packageVersion("pbkrtest")), "R", R.version$major, R.version$minor, "\n")
for (run in c("multi_split", "simulated_family/splits_0", "simulated_family/splits_high")) {
  cells <- read.csv(file.path("results", run, "cells.csv"), stringsAsFactors = FALSE)
  u <- cells[cells$model == "world" & cells$horizon_s == 1, ]
  t <- u[u$arm == "contaminated", c("split", "recording", "seed", "fa_position_rmse_m")]
  r <- u[u$arm == "disjoint", c("split", "recording", "seed", "fa_position_rmse_m")]
  k <- merge(t, r, by = c("split", "recording", "seed"), suffixes = c(".t", ".r"))
  stopifnot(nrow(k) == nrow(t), nrow(k) == nrow(r))
  k$d <- k$fa_position_rmse_m.t - k$fa_position_rmse_m.r
  k$split <- factor(k$split); k$recording <- factor(k$recording); k$seed <- factor(k$seed)
  name <- gsub("/", ".", run)
  f <- lme4::lmer(d ~ 1 + (1 | split) + (1 | recording) + (1 | seed), k, control = ctl)
  vc <- as.data.frame(VarCorr(f))
  cat(name, "cells", nrow(k), "\n")
  cat(name, "levels", nlevels(k$split), nlevels(k$recording), nlevels(k$seed), "\n")
  cat(name, "criterion", format(f@devcomp$cmp[["REML"]], digits = 15), "\n")
  for (i in seq_len(nrow(vc))) cat(name, "var", vc$grp[i], format(vc$vcov[i], digits = 15), "\n")
  cat(name, "intercept", format(fixef(f)[[1]], digits = 15), "\n")
  cat(name, "se", format(sqrt(vcov(f)[1, 1]), digits = 15), "\n")
  cat(name, "singular", isSingular(f), "\n")
  V <- vcovAdj(f)
  cat(name, "kr_se", format(sqrt(as.matrix(V)[1, 1]), digits = 15), "\n")
  cat(name, "kr_df", format(Lb_ddf(matrix(1, 1, 1), vcov(f), V), digits = 15), "\n")
  ft <- lmerTest::lmer(d ~ 1 + (1 | split) + (1 | recording) + (1 | seed), k, control = ctl)
  df <- summary(ft)$coefficients[1, "df"]
  cat(name, "satterthwaite_df", format(df, digits = 15), "\n")
  q <- qt(0.975, df)
  cat(name, "lower", format(fixef(f)[[1]] - q * sqrt(vcov(f)[1, 1]), digits = 15), "\n")
  cat(name, "upper", format(fixef(f)[[1]] + q * sqrt(vcov(f)[1, 1]), digits = 15), "\n")
}
