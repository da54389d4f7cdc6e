# The divergence endpoint's binomial GLMM, by lme4's glmer, on the
# committed per-cell data of the confirmatory NanoBench run
# (results/nanobench_confirmatory/cells.csv): model world at 1.0 s, each
# cell's diverged starts out of its starts, the arm fixed (contaminated
# against disjoint), recording, seed and recording x seed random
# intercepts. Run from the repository root:
#
#   Rscript scripts/reference/divergence_glmm.R > scripts/reference/divergence_glmm.out
#
# R and lme4 from Debian (apt-get install r-base-core r-cran-lme4). The
# optimizers and PIRLS run to tight tolerances; the lower -2 logLik of
# BOBYQA and nloptwrap is reported. Lines: `<what> <values>`.
suppressMessages(library(lme4))
cells <- read.csv("results/nanobench_confirmatory/cells.csv")
d <- subset(cells, model == "world" & horizon_s == 1.0)
d$arm <- factor(d$arm, levels = c("disjoint", "contaminated"))
d$recording <- factor(d$recording)
d$seed <- factor(d$seed)
f <- cbind(n_divergent, n_starts - n_divergent) ~ arm + (1 | recording) + (1 | seed) + (1 | recording:seed)
fits <- lapply(c("bobyqa", "nloptwrap"), function(o) {
  ctl <- glmerControl(optimizer = o, tolPwrss = 1e-12, check.conv.singular = "ignore",
                      check.conv.grad = "ignore", check.conv.hess = "ignore",
                      optCtrl = if (o == "bobyqa") list(rhoend = 1e-10, maxfun = 1e6)
                                else list(xtol_abs = 1e-12, ftol_abs = 1e-12, maxeval = 1e5))
  glmer(f, d, family = binomial, control = ctl)
})
m <- fits[[which.min(sapply(fits, function(x) -2 * as.numeric(logLik(x))))]]
fmt <- function(x) format(x, digits = 17)
cat("# lme4", as.character(packageVersion("lme4")), "R", R.version$major, R.version$minor, "\n")
cat("rows", nrow(d), "\n")
cat("diverged", sum(d$n_divergent[d$arm == "contaminated"]), sum(d$n_starts[d$arm == "contaminated"]),
    sum(d$n_divergent[d$arm == "disjoint"]), sum(d$n_starts[d$arm == "disjoint"]), "\n")
cat("deviance", fmt(-2 * as.numeric(logLik(m))), "\n")
b <- fixef(m)[["armcontaminated"]]
se <- sqrt(diag(as.matrix(vcov(m))))[2]
cat("log_odds_ratio", fmt(b), "\n")
cat("se", fmt(se), "\n")
z <- qnorm(0.975)
cat("odds_ratio", fmt(exp(b)), fmt(exp(b - z * se)), fmt(exp(b + z * se)), "\n")
vc <- as.data.frame(VarCorr(m))
for (i in seq_len(nrow(vc))) cat("sd", vc$grp[i], fmt(vc$sdcor[i]), "\n")
