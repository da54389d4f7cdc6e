# Kenward-Roger (pbkrtest) intervals for the intercept on every array of
# the small locked coverage study (tests/coverage.rs,
# a_small_fixed_seed_study_is_locked: 10 x 4 crossed arrays, shares
# 0.6/0.2/0.2, normal and skewed, 100 replications each, seed 42). The
# arrays are crossaudit's own draws (ChaCha8), written by the test with
# CROSSAUDIT_WRITE_FIXTURE=1 to tests/fixtures/coverage_small/arrays.csv
# and checked by it to be the study's. Run from the repository root:
#
#   Rscript scripts/reference/coverage_small_kr.R > scripts/reference/coverage_small_kr.out
#
# R, lme4 and pbkrtest from Debian (r-cran-lme4, r-cran-pbkrtest). Each fit
# is polished as in mixed_dominant.R (BOBYQA to rhoend 1e-12, then
# Nelder-Mead on the deviance to reltol 1e-16 and lme4's Nelder_Mead from
# there) so that the optimum, not the optimizer, is compared. Prints per
# replication: setting, replication, whether lme4 converged, the KR df
# (Lb_ddf), the KR SE (vcovAdj) and the 95% interval
# estimate -+ qt(0.975, df) SE.
suppressMessages({library(lme4); library(pbkrtest)})
ctl <- lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12, maxfun = 1e6),
                   check.conv.singular = "ignore")
nm <- lmerControl(optimizer = "Nelder_Mead", check.conv.singular = "ignore",
                  optCtrl = list(FtolAbs = 1e-15, FtolRel = 1e-16, XtolRel = 1e-14, maxfun = 1e5))
cat("# lme4", as.character(packageVersion("lme4")), "pbkrtest", as.character(packageVersion("pbkrtest")),
    "R", R.version$major, R.version$minor, "\n")
cat("# setting rep converged kr_df kr_se lower upper\n")
all <- read.csv("tests/fixtures/coverage_small/arrays.csv")
L <- matrix(1, 1, 1)
for (k in sort(unique(all$setting))) for (r in sort(unique(all$rep[all$setting == k]))) {
  d <- all[all$setting == k & all$rep == r, ]
  d$row <- factor(d$row); d$col <- factor(d$col)
  f <- y ~ 1 + (1 | row) + (1 | col)
  m0 <- suppressWarnings(suppressMessages(lme4::lmer(f, d, control = ctl)))
  conv <- is.null(m0@optinfo$conv$lme4$messages) && m0@optinfo$conv$opt == 0
  dev <- lme4::lmer(f, d, devFunOnly = TRUE)
  o <- optim(getME(m0, "theta"), dev, method = "Nelder-Mead", control = list(reltol = 1e-16, maxit = 1e5))
  m <- if (o$value < dev(getME(m0, "theta"))) {
    suppressWarnings(suppressMessages(lme4::lmer(f, d, start = list(theta = pmax(o$par, 0)), control = nm)))
  } else m0
  kr <- tryCatch({
    va <- vcovAdj(m)
    c(Lb_ddf(L, vcov(m), va), sqrt(va[1, 1]))
  }, error = function(e) c(NA, NA))
  est <- fixef(m)[[1]]
  q <- qt(0.975, kr[1])
  cat(k, r, conv, format(kr[1], digits = 15), format(kr[2], digits = 15),
      format(est - q * kr[2], digits = 15), format(est + q * kr[2], digits = 15), "\n")
}
