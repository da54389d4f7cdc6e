# lmer on the crossed 30,000 x 30,000 random-intercept set of
# tests/mixed_cli.rs (a_model_too_large_for_memory_is_refused_up_front),
# built here by the same arithmetic: crossaudit fits it with the sparse
# factor (the intercept engine's dense reduced system would be 30,001
# square). Run from the repository root:
#
#   Rscript scripts/reference/mixed_sparse_intercepts.R > scripts/reference/mixed_sparse_intercepts.out
suppressMessages(library(lme4))
i <- 0:59999
d <- data.frame(y = (i * 37) %% 101, a = factor(i %% 30000), b = factor((i * 7 + i %/% 30000) %% 30000))
m <- lmer(y ~ 1 + (1 | a) + (1 | b), d, control = lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-10)))
cat("# lme4", as.character(packageVersion("lme4")), "R", R.version$major, R.version$minor, "\n")
cat("reml", format(REMLcrit(m), digits = 17), "\n")
cat("intercept", format(fixef(m)[[1]], digits = 17), format(sqrt(vcov(m)[1, 1]), digits = 17), "\n")
vc <- as.data.frame(VarCorr(m))
for (k in seq_len(nrow(vc))) cat("vcov", vc$grp[k], format(vc$vcov[k], digits = 17), "\n")
