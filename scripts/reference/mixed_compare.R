# lme4's likelihood summaries and likelihood-ratio tests (issue 39, task 5).
# For each data set: logLik, AIC, BIC, deviance (ML) or REML criterion
# (REML) and the residual df of the larger model, fitted by REML and by ML,
# as logLik(), AIC(), BIC(), REMLcrit()/deviance() and df.residual() give
# them; and anova(m_small, m_large), which refits both by ML, with npar,
# AIC, BIC, logLik, deviance, Chisq, Df and Pr(>Chisq).
# Run from the repository root (R 4.2.2, lme4 1.1.31):
#   Rscript scripts/reference/mixed_compare.R > scripts/reference/mixed_compare.out
suppressPackageStartupMessages(library(lme4))
sets <- list(
  list("sleepstudy", "Reaction ~ Days + (1|Subject)", "Reaction ~ 1 + (1|Subject)"),
  list("penicillin", "diameter ~ 1 + (1|plate) + (1|sample)", "diameter ~ 1 + (1|plate)"),
  list("machines", "score ~ Machine + (1|Worker) + (1|Worker:Machine)", "score ~ 1 + (1|Worker) + (1|Worker:Machine)"))
ctrl <- lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12))
cat('"dataset","quantity","name","value"\n')
for (s in sets) {
  out <- function(q, n, v) cat(sprintf('"%s","%s","%s","%s"\n', s[[1]], q, n, v))
  num <- function(v) if (is.na(v)) "NA" else sprintf("%.15e", v)
  d <- read.csv(sprintf("tests/fixtures/mixed_published/%s.csv", s[[1]]))
  out("formula", "large", s[[2]])
  out("formula", "small", s[[3]])
  for (reml in c(TRUE, FALSE)) {
    m <- lmer(as.formula(s[[2]]), d, REML = reml, control = ctrl)
    crit <- if (reml) "reml" else "ml"
    ll <- logLik(m)
    out(crit, "logLik", num(as.numeric(ll)))
    out(crit, "npar", attr(ll, "df"))
    out(crit, "AIC", num(AIC(m)))
    out(crit, "BIC", num(BIC(m)))
    out(crit, if (reml) "REMLcrit" else "deviance", num(if (reml) REMLcrit(m) else deviance(m)))
    out(crit, "df.resid", df.residual(m))
  }
  large <- lmer(as.formula(s[[2]]), d, REML = TRUE, control = ctrl)
  small <- lmer(as.formula(s[[3]]), d, REML = TRUE, control = ctrl)
  a <- suppressMessages(anova(small, large))
  rows <- c("small", "large")[match(rownames(a), c("small", "large"))]
  for (i in seq_len(nrow(a))) for (col in c("npar", "AIC", "BIC", "logLik", "deviance", "Chisq", "Df", "Pr(>Chisq)"))
    out(paste0("anova_", rows[i]), col, num(a[i, col]))
}
