# Kenward-Roger (pbkrtest) and Satterthwaite (lmerTest) df of the intercept
# on crossed designs where one variance dwarfs the others (issue 43). Run
# from the repository root:
#
#   Rscript scripts/reference/mixed_dominant.R > scripts/reference/mixed_dominant.out
#
# R, lme4, lmerTest and pbkrtest from Debian (r-cran-lme4, r-cran-lmertest,
# r-cran-pbkrtest). Each data set is drawn with set.seed and written to
# tests/fixtures/mixed_dominant/NAME.csv (17 significant digits), so the
# tests fit exactly the data R fitted. y = mu + a_i + b_j + e with a over
# `la` levels, b over `lb`, levels assigned at random, and the SDs given.
# BOBYQA runs to rhoend 1e-12 so that the optimum, not the optimizer, is
# compared. Prints per data set: theta, the variances, the KR df and SE
# (pbkrtest::vcovAdj and Lb_ddf) and the Satterthwaite df (lmerTest).
suppressMessages({library(lme4); library(pbkrtest); library(lmerTest)})
ctl <- lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12, maxfun = 1e6),
                   check.conv.singular = "ignore")
cat("# lme4", as.character(packageVersion("lme4")), "pbkrtest", as.character(packageVersion("pbkrtest")),
    "lmerTest", as.character(packageVersion("lmerTest")), "R", R.version$major, R.version$minor, "\n")
sets <- list(
  list(name = "moderate", seed = 1, n = 200, la = 15, lb = 8, mu = 10, sa = 2, sb = 1, se = 1),
  list(name = "a_1e2", seed = 2, n = 300, la = 20, lb = 10, mu = 50, sa = 10, sb = 0.5, se = 1),
  list(name = "a_1e4", seed = 3, n = 300, la = 20, lb = 10, mu = 0, sa = 100, sb = 1, se = 1),
  list(name = "b_1e4", seed = 4, n = 240, la = 24, lb = 9, mu = 5, sa = 1, sb = 100, se = 1),
  list(name = "small_b", seed = 5, n = 200, la = 12, lb = 10, mu = 1, sa = 3, sb = 0.01, se = 1),
  list(name = "issue43", seed = 43, n = 500, la = 25, lb = 12, mu = 1e6, sa = 1000, sb = 0.01, se = 0.01)
)
L <- matrix(1, 1, 1)
for (s in sets) {
  set.seed(s$seed)
  a <- sample(s$la, s$n, replace = TRUE)
  b <- sample(s$lb, s$n, replace = TRUE)
  y <- s$mu + rnorm(s$la, 0, s$sa)[a] + rnorm(s$lb, 0, s$sb)[b] + rnorm(s$n, 0, s$se)
  d <- data.frame(y = y, a = paste0("a", a), b = paste0("b", b))
  write.csv(data.frame(y = format(y, digits = 17), a = d$a, b = d$b),
            file.path("tests/fixtures/mixed_dominant", paste0(s$name, ".csv")), row.names = FALSE, quote = FALSE)
  d <- read.csv(file.path("tests/fixtures/mixed_dominant", paste0(s$name, ".csv")))
  m0 <- lme4::lmer(y ~ 1 + (1 | a) + (1 | b), d, control = ctl)
  # BOBYQA stops up to 4e-5 of theta short where one variance dwarfs the
  # others (the criterion is flat there): polished by Nelder-Mead on the
  # deviance function to reltol 1e-16, then refitted from that theta by
  # lme4's Nelder_Mead to tight tolerances, so that pbkrtest and lmerTest
  # work at the optimum.
  dev <- lme4::lmer(y ~ 1 + (1 | a) + (1 | b), d, devFunOnly = TRUE)
  o <- optim(getME(m0, "theta"), dev, method = "Nelder-Mead", control = list(reltol = 1e-16, maxit = 1e5))
  nm <- lmerControl(optimizer = "Nelder_Mead", check.conv.singular = "ignore",
                    optCtrl = list(FtolAbs = 1e-15, FtolRel = 1e-16, XtolRel = 1e-14, maxfun = 1e5))
  m <- if (o$value < dev(getME(m0, "theta"))) {
    lme4::lmer(y ~ 1 + (1 | a) + (1 | b), d, start = list(theta = pmax(o$par, 0)), control = nm)
  } else m0
  cat(s$name, "criterion", format(m@devcomp$cmp[["REML"]], digits = 15), "\n")
  vc <- as.data.frame(VarCorr(m))
  cat(s$name, "theta", format(getME(m, "theta"), digits = 15), "\n")
  for (i in seq_len(nrow(vc))) cat(s$name, "var", vc$grp[i], format(vc$vcov[i], digits = 15), "\n")
  cat(s$name, "singular", isSingular(m), "\n")
  # lme4 warns where BOBYQA fails to converge; pbkrtest and lmerTest may
  # stop with an error: NA then, and the tests compare only where R
  # computed a value from a converged fit.
  cat(s$name, "converged", is.null(m0@optinfo$conv$lme4$messages) && m0@optinfo$conv$opt == 0, "\n")
  kr <- tryCatch({
    va <- vcovAdj(m)
    c(Lb_ddf(L, vcov(m), va), sqrt(va[1, 1]))
  }, error = function(e) c(NA, NA))
  cat(s$name, "kr_df", format(kr[1], digits = 15), "\n")
  cat(s$name, "kr_se", format(kr[2], digits = 15), "\n")
  sat <- tryCatch({
    mt <- lmerTest::as_lmerModLmerTest(m)
    summary(mt)$coefficients[1, "df"]
  }, error = function(e) NA)
  cat(s$name, "satterthwaite_df", format(sat, digits = 15), "\n")
}
# Two-sided p-values of t on df, R's pt, for crossaudit's t_two_sided_p.
for (t in c(0.5, 2.295, 6, 20)) for (df in c(3, 30, 1e3, 1e5, 1e6, 1e7, 1e9, 1e12, 8.2e19, Inf)) {
  cat("pt", format(t), format(df), format(2 * pt(-t, df), digits = 15), "\n")
}
