# Profile-likelihood intervals of GLMM fixed effects and random-effect
# standard deviations, by lme4's
# confint(method = "profile"), on three fits of glmm_reference.R (cbpp,
# bacteria, epil), read from the fixtures that script writes. Run from the
# repository root:
#
#   Rscript scripts/reference/glmm_profile.R > scripts/reference/glmm_profile.out
#
# Lines: `<fit> <coefficient> <lower> <upper>` at level 0.95. lme4
# interpolates a spline through its profile grid, so its bounds carry that
# interpolation's error (about 1e-4 of the interval).
suppressMessages(library(lme4))
ctl <- glmerControl(optimizer = "bobyqa", tolPwrss = 1e-12, optCtrl = list(rhoend = 1e-10, maxfun = 1e6))
cat("# lme4", as.character(packageVersion("lme4")), "R", R.version$major, R.version$minor, "\n")
show <- function(name, formula, file, family) {
  d <- read.csv(file.path("tests/fixtures", file))
  m <- glmer(formula, d, family = family, control = ctl)
  # The standard deviations first (oldNames = FALSE: sd_(Intercept)|herd),
  # then the fixed effects, as confint lists them.
  ci <- suppressMessages(confint(m, method = "profile", level = 0.95, oldNames = FALSE))
  for (i in seq_len(nrow(ci))) {
    cat(name, rownames(ci)[i], format(ci[i, 1], digits = 17), format(ci[i, 2], digits = 17), "\n")
  }
}
show("cbpp_herd", cbind(incidence, healthy) ~ factor(period) + (1 | herd), "glmm_cbpp.csv", "binomial")
show("bacteria_binomial", y ~ trt + week + (1 | ID), "glmm_bacteria.csv", "binomial")
show("epil_poisson", y ~ trt + lbase + lage + V4 + (1 | subject), "glmm_epil.csv", "poisson")
