# Reference fits for crossaudit's generalized linear mixed models
# (stats::mixed::glmm), from lme4's glmer (Laplace approximation, nAGQ = 1),
# on data sets of R's packages and on simulated crossed designs. Run from
# the repository root:
#
#   Rscript scripts/reference/glmm_reference.R > scripts/reference/glmm_reference.out
#
# R, lme4 and mlmRev from Debian: apt-get install r-base-core r-cran-lme4
# r-cran-mlmrev (MASS comes with R). Writes tests/fixtures/glmm_*.csv (the
# columns each model uses) and prints, for each fit, lines
# `<fit> <what> <values...>`: formula, family, criterion (-2 logLik),
# objective (the optimizer's value, lme4's deviance function at the
# optimum), theta, beta, vc (grp var1 var2 vcov sdcor, as
# as.data.frame(VarCorr) gives them), fixef (name estimate se se_rx: se is
# vcov()'s default, from the finite-difference Hessian in (theta, beta);
# se_rx is vcov(use.hessian = FALSE)), singular. The optimizers and PIRLS
# are run to tight tolerances, so that the optimum, not the optimizer, is
# compared.
suppressMessages({
  library(lme4)
  library(MASS)
})
make_control <- function(optimizer) {
  glmerControl(optimizer = optimizer, tolPwrss = 1e-12, check.conv.singular = "ignore",
               check.conv.grad = "ignore", check.conv.hess = "ignore",
               optCtrl = if (optimizer == "bobyqa") list(rhoend = 1e-10, maxfun = 1e6)
                         else list(xtol_abs = 1e-12, ftol_abs = 1e-12, maxeval = 1e5))
}
cat("# lme4", as.character(packageVersion("lme4")), "R", R.version$major, R.version$minor, "\n")
fmt <- function(x) format(x, digits = 17)
# Each model is fitted with BOBYQA and with nloptwrap (NLopt's BOBYQA), both
# to tight tolerances, and the fit with the lower -2 logLik is reported
# (they differ on grouseticks, where lme4's BOBYQA stops 4e-3 above the
# optimum).
show_fit <- function(name, formula, data, family, weights = NULL, nAGQ = 1L) {
  optimizers <- c("bobyqa", "nloptwrap")
  w <- if (is.null(weights)) NULL else data[[weights]]
  fits <- lapply(optimizers, function(o) {
    ctl <- make_control(o)
    # do.call passes the weights' values (glmer looks a name up in data).
    do.call(glmer, list(formula, data = data, family = family, control = ctl, weights = w, nAGQ = nAGQ))
  })
  best <- which.min(sapply(fits, function(f) -2 * as.numeric(logLik(f))))
  m <- fits[[best]]
  ctl <- make_control(optimizers[best])
  cat(name, "formula", deparse(formula, width.cutoff = 500L), "\n")
  cat(name, "family", family, "\n")
  if (!is.null(weights)) cat(name, "weights", weights, "\n")
  if (nAGQ > 1) cat(name, "nagq", nAGQ, "\n")
  cat(name, "criterion", fmt(-2 * as.numeric(logLik(m))), "\n")
  dd <- update(m, devFunOnly = TRUE, control = ctl)
  cat(name, "optimizer", optimizers[best], "\n")
  cat(name, "objective", fmt(dd(c(getME(m, "theta"), getME(m, "beta")))), "\n")
  cat(name, "theta", fmt(getME(m, "theta")), "\n")
  cat(name, "beta", fmt(getME(m, "beta")), "\n")
  vc <- as.data.frame(VarCorr(m))
  for (i in seq_len(nrow(vc))) {
    cat(name, "vc", vc$grp[i], vc$var1[i], vc$var2[i], fmt(vc$vcov[i]), fmt(vc$sdcor[i]), "\n")
  }
  se <- sqrt(diag(as.matrix(vcov(m))))
  se_rx <- sqrt(diag(as.matrix(vcov(m, use.hessian = FALSE))))
  b <- fixef(m)
  for (i in seq_along(b)) cat(name, "fixef", names(b)[i], fmt(b[[i]]), fmt(se[[i]]), fmt(se_rx[[i]]), "\n")
  cat(name, "singular", isSingular(m), "\n")
}
write_fixture <- function(d, file) {
  write.csv(d, file.path("tests/fixtures", file), row.names = FALSE, quote = FALSE)
}

# A column whose every value is a number is numeric when the CSV is read
# (by R's read.csv and by crossaudit): the formulas say factor() where a
# numeric code is a category.
# 1. lme4's cbpp: contagious bovine pleuropneumonia, cases of herd size per
# period, with and without an observation-level effect (lme4's example).
cb <- data.frame(incidence = cbpp$incidence, healthy = cbpp$size - cbpp$incidence,
                 period = as.integer(as.character(cbpp$period)), herd = as.character(cbpp$herd),
                 obs = seq_len(nrow(cbpp)), size = cbpp$size, prop = cbpp$incidence / cbpp$size)
write_fixture(cb, "glmm_cbpp.csv")
show_fit("cbpp_herd", cbind(incidence, healthy) ~ factor(period) + (1 | herd), cb, "binomial")
show_fit("cbpp_obs", cbind(incidence, healthy) ~ factor(period) + (1 | herd) + (1 | obs), cb, "binomial")
# glmer's formulas (issue 75): the failures as arithmetic in cbind( ), and
# the herd sizes as a Poisson exposure, offset(log(size)) (cases per
# animal), with and without an observation-level effect.
show_fit("cbpp_trials", cbind(incidence, size - incidence) ~ factor(period) + (1 | herd), cb, "binomial")
show_fit("cbpp_exposure", incidence ~ factor(period) + offset(log(size)) + (1 | herd), cb, "poisson")
# lme4's own example of prior weights: the proportion of cases with the
# herd sizes as weights (the trials).
show_fit("cbpp_agq", cbind(incidence, healthy) ~ factor(period) + (1 | herd), cb, "binomial", nAGQ = 9L)
show_fit("cbpp_weights", prop ~ factor(period) + (1 | herd), cb, "binomial", weights = "size")
# ... and as lme4's example writes it, the proportion as arithmetic in the
# response.
show_fit("cbpp_ratio", incidence / size ~ factor(period) + (1 | herd), cb, "binomial", weights = "size")
show_fit("cbpp_exposureobs", incidence ~ factor(period) + offset(log(size)) + (1 | herd) + (1 | obs), cb, "poisson")

# 2. lme4's grouseticks: ticks on grouse chicks, an observation-level
# effect inside broods inside locations (crossed in the data's coding).
gt <- data.frame(TICKS = grouseticks$TICKS, YEAR = as.integer(as.character(grouseticks$YEAR)),
                 cHEIGHT = round(grouseticks$cHEIGHT, 6), BROOD = as.character(grouseticks$BROOD),
                 INDEX = as.character(grouseticks$INDEX), LOCATION = as.character(grouseticks$LOCATION))
write_fixture(gt, "glmm_grouseticks.csv")
show_fit("grouseticks_poisson", TICKS ~ factor(YEAR) + cHEIGHT + (1 | BROOD) + (1 | INDEX) + (1 | LOCATION), gt, "poisson")

# 3. lme4's VerbAgg: 0/1 responses of 316 people to 24 items, crossed.
va <- data.frame(r2 = as.integer(VerbAgg$r2 == "Y"), Anger = VerbAgg$Anger, Gender = as.character(VerbAgg$Gender),
                 btype = as.character(VerbAgg$btype), situ = as.character(VerbAgg$situ),
                 id = as.character(VerbAgg$id), item = as.character(VerbAgg$item))
write_fixture(va, "glmm_verbagg.csv")
show_fit("verbagg_crossed", r2 ~ Anger + Gender + btype + situ + (1 | id) + (1 | item), va, "binomial")

# 4. lme4's Arabidopsis: fruit counts, populations crossed with genotypes.
ar <- data.frame(total.fruits = Arabidopsis$total.fruits, nutrient = Arabidopsis$nutrient,
                 amd = as.character(Arabidopsis$amd), popu = as.character(Arabidopsis$popu),
                 gen = as.character(Arabidopsis$gen))
write_fixture(ar, "glmm_arabidopsis.csv")
show_fit("arabidopsis_poisson", total.fruits ~ nutrient + amd + (1 | popu) + (1 | gen), ar, "poisson")

# 5. MASS's epil: seizure counts of 59 epileptics over four visits.
ep <- data.frame(y = epil$y, trt = as.character(epil$trt), lbase = round(epil$lbase, 6),
                 lage = round(epil$lage, 6), V4 = epil$V4, subject = epil$subject)
write_fixture(ep, "glmm_epil.csv")
show_fit("epil_poisson", y ~ trt + lbase + lage + V4 + (1 | subject), ep, "poisson")

# 6. MASS's bacteria: presence of H. influenzae (0/1) over weeks, per child.
ba <- data.frame(y = as.integer(bacteria$y == "y"), trt = as.character(bacteria$trt), week = bacteria$week,
                 ID = as.character(bacteria$ID))
write_fixture(ba, "glmm_bacteria.csv")
show_fit("bacteria_binomial", y ~ trt + week + (1 | ID), ba, "binomial")
# Adaptive Gauss-Hermite quadrature (glmer's nAGQ), for one scalar term.
show_fit("bacteria_agq", y ~ trt + week + (1 | ID), ba, "binomial", nAGQ = 25L)

# 7. mlmRev's Contraception: use by 1,934 women in 60 districts, with a
# random slope of urban residence per district (correlated).
library(mlmRev)
co <- data.frame(use = as.integer(Contraception$use == "Y"), age = round(Contraception$age, 6),
                 urban = as.character(Contraception$urban), livch = as.character(Contraception$livch),
                 district = as.character(Contraception$district))
write_fixture(co, "glmm_contraception.csv")
show_fit("contraception_intercept", use ~ age + urban + livch + (1 | district), co, "binomial")
show_fit("contraception_slope", use ~ age + urban + livch + (urban | district), co, "binomial")

# 8. Simulated: the study's divergence endpoint, failed rollouts out of 20
# starts per recording x seed cell and arm, crossed recording and seed
# intercepts and their interaction.
set.seed(20261129)
I <- 20; J <- 8
d <- expand.grid(arm = c("clean", "leaky"), seed = 1:J, recording = 1:I)
eta <- -1.5 + 0.4 * (d$arm == "leaky") + rnorm(I, sd = 0.8)[d$recording] + rnorm(J, sd = 0.3)[d$seed] +
  rnorm(I * J, sd = 0.4)[(d$recording - 1) * J + d$seed]
failed <- rbinom(nrow(d), 20, plogis(eta))
dv <- data.frame(failed = failed, held = 20 - failed, arm = d$arm, recording = paste0("r", d$recording),
                 seed = paste0("s", d$seed))
write_fixture(dv, "glmm_divergence.csv")
show_fit("divergence_crossed", cbind(failed, held) ~ arm + (1 | recording) + (1 | seed) + (1 | recording:seed), dv, "binomial")

# 9. Simulated: Poisson counts with a correlated random slope per group and
# a crossed intercept.
set.seed(11)
g <- rep(1:30, each = 12); h <- rep(1:6, times = 60); x <- rep(seq(-1, 1, length.out = 12), 30)
b0 <- rnorm(30, sd = 0.5); b1 <- 0.5 * b0 + rnorm(30, sd = 0.3)
mu <- exp(1 + 0.4 * x + b0[g] + b1[g] * x + rnorm(6, sd = 0.3)[h])
ps <- data.frame(count = rpois(length(mu), mu), x = round(x, 6), g = paste0("g", g), h = paste0("h", h))
write_fixture(ps, "glmm_poisson.csv")
show_fit("poisson_slope", count ~ x + (x | g) + (1 | h), ps, "poisson")
