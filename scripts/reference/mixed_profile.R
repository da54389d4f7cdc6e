# Exact profile-likelihood intervals of the standard deviations (issue 39,
# task 2), computed without lme4's profile() (which steps along each
# profile and interpolates zeta by a spline, to about 1e-4):
#
# 1. D(s_1..s_k, sigma) is the REML (or ML) deviance not profiled over
#    sigma, built from lme4's own deviance function (lmer(devFunOnly =
#    TRUE)) at theta_j = s_j / sigma:
#      REML: log|L|^2 + log|R_X|^2 + (n - p) log(2 pi sigma^2) + pwrss / sigma^2
#      ML:   log|L|^2 +              n log(2 pi sigma^2) + pwrss / sigma^2
#    (pp$ldL2(), pp$ldRX2(), pwrss = resp$wrss() + pp$sqrL(1)).
# 2. The profile of one SD at v: D minimised over the other SDs (and sigma)
#    with that SD held at v, by BOBYQA (minqa, lower bound 0, rhoend 1e-12),
#    restarted from the best point until it no longer improves.
# 3. zeta(v) = sign(v - estimate) sqrt(profile(v) - D_min), as lme4's
#    profile defines it; each limit is the root of zeta(v) = -+z (z the
#    normal quantile of the level) by uniroot to tol 1e-13; a lower limit is
#    0 when profile(0) - D_min <= z^2.
# Run from the repository root (R 4.2.2, lme4 1.1.31, minqa):
#   Rscript scripts/reference/mixed_profile.R > scripts/reference/mixed_profile.out
suppressPackageStartupMessages({ library(lme4); library(minqa) })
sets <- list(
  list(name = "gun", file = "tests/fixtures/mixed_profile/gun.csv",
       formula = "rounds ~ Method + (1|Team)"),
  list(name = "orchardsprays", file = "tests/fixtures/mixed_profile/orchardsprays.csv",
       formula = "decrease ~ treatment + (1|rowpos) + (1|colpos)"),
  list(name = "assay", file = "tests/fixtures/mixed_profile/assay.csv",
       formula = "logDens ~ sample * factor(dilut) + (1|Block) + (1|Block:sample) + (1|Block:dilut)"))
level <- 0.95
z <- qnorm((1 + level) / 2)
cat('"dataset","criterion","name","estimate","lower","upper"\n')
for (set in sets) for (reml in c(TRUE, FALSE)) {
  d <- read.csv(set$file)
  for (col in c("rowpos", "colpos", "Block")) if (!is.null(d[[col]])) d[[col]] <- factor(d[[col]])
  f <- as.formula(set$formula)
  ctrl <- lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12, maxfun = 1e6))
  m <- lmer(f, d, REML = reml, control = ctrl)
  devfun <- lmer(f, d, REML = reml, control = ctrl, devFunOnly = TRUE)
  env <- environment(devfun)
  n <- nrow(d); p <- ncol(getME(m, "X"))
  D <- function(s, sigma) {
    if (sigma <= 0 || any(s < 0)) return(Inf)
    devfun(s / sigma)
    pwrss <- env$resp$wrss() + env$pp$sqrL(1)
    ld <- env$pp$ldL2() + if (reml) env$pp$ldRX2() else 0
    ld + (if (reml) n - p else n) * log(2 * pi * sigma^2) + pwrss / sigma^2
  }
  k <- length(getME(m, "theta"))
  names_k <- names(getME(m, "flist"))
  # lme4 orders the random terms by decreasing number of levels; the
  # names and SDs below follow its order, the output names the factor.
  vc <- as.data.frame(VarCorr(m))
  est <- c(vc$sdcor[seq_len(k)], sigma(m))
  labels <- c(vc$grp[seq_len(k)], "Residual")
  all <- function(x) D(x[seq_len(k)], x[k + 1])
  best <- function(fn, start) {
    start <- pmax(start, 1e-8)
    val <- Inf; x <- start
    repeat {
      r <- bobyqa(x, fn, lower = rep(0, length(x)),
                  control = list(rhobeg = 0.2 * max(x), rhoend = 1e-12, maxfun = 1e6))
      if (r$fval >= val - 1e-13) break
      val <- r$fval; x <- pmax(r$par, 1e-8)
    }
    list(par = r$par, value = min(val, r$fval))
  }
  d_min <- best(all, est)$value
  prof <- function(j, v) {
    fn <- function(x) { full <- append(x, v, after = j - 1); all(full) }
    best(fn, est[-j])$value
  }
  crit <- if (reml) "reml" else "ml"
  for (j in seq_len(k + 1)) {
    zeta <- function(v) sign(v - est[j]) * sqrt(max(prof(j, v) - d_min, 0))
    upper <- uniroot(function(v) zeta(v) - z, c(est[j], est[j] * 2), extendInt = "upX", tol = 1e-13)$root
    lower <- if (j <= k && prof(j, 0) - d_min <= z^2) 0 else
      uniroot(function(v) zeta(v) + z, c(est[j] * 0.1, est[j]), extendInt = "upX", tol = 1e-13)$root
    cat(sprintf('"%s","%s","%s",%.15e,%.15e,%.15e\n', set$name, crit, labels[j], est[j], lower, upper))
  }
}
