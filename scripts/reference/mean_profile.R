# Profile-likelihood intervals for the grand mean of crossed arrays, from
# lme4 (issue 44), for src/stats/mean_profile.rs. lme4 profiles the ML
# deviance for a fixed effect (confint(method = "profile") on a REML fit
# refits with ML), and interpolates the profile by a spline (to about
# 1e-4). Here each limit is exact to lme4's optimizer instead: the
# profiled ML deviance at mu is lmer(y ~ 0 + (1|row) + (1|col), offset = mu,
# REML = FALSE) (BOBYQA, rhoend 1e-12), and each limit is the root of
# deviance(mu) - deviance at the ML fit - qnorm(0.975)^2 by uniroot
# (tol 1e-11). lme4's own confint limits are printed beside them.
# Arrays: the first 25 of each of the two settings of
# tests/fixtures/coverage_small/arrays.csv (10 x 4).
# Run from the repository root:
#   Rscript scripts/reference/mean_profile.R > scripts/reference/mean_profile.out
suppressPackageStartupMessages(library(lme4))
arrays <- read.csv("tests/fixtures/coverage_small/arrays.csv")
ctl <- lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12), calc.derivs = FALSE,
                   check.conv.singular = "ignore")
z2 <- qnorm(0.975)^2
cat("# R", R.version$major, R.version$minor, "lme4", as.character(packageVersion("lme4")), "\n")
cat("# setting rep lower upper lme4_confint_lower lme4_confint_upper\n")
for (k in 0:1) for (r in 0:24) {
  a <- arrays[arrays$setting == k & arrays$rep == r, ]
  a$row <- factor(a$row); a$col <- factor(a$col)
  dev_at <- function(mu) deviance(lmer(y ~ 0 + (1|row) + (1|col), data = a, offset = rep(mu, nrow(a)),
                                       REML = FALSE, control = ctl))
  ml <- lmer(y ~ 1 + (1|row) + (1|col), data = a, REML = FALSE, control = ctl)
  mu <- unname(fixef(ml)); d0 <- deviance(ml)
  w <- 4 * sqrt(vcov(ml)[1, 1]) + 1e-3
  f <- function(m) dev_at(m) - d0 - z2
  while (f(mu + w) < 0) w <- 2 * w
  lo <- uniroot(f, c(mu - w, mu), tol = 1e-11)$root
  hi <- uniroot(f, c(mu, mu + w), tol = 1e-11)$root
  ci <- suppressMessages(suppressWarnings(confint(lmer(y ~ 1 + (1|row) + (1|col), data = a),
                                                  parm = "(Intercept)", method = "profile")))
  cat(sprintf("%d %d %.12e %.12e %.8e %.8e\n", k, r, lo, hi, ci[1], ci[2]))
}
