# lme4 on rank-deficient fixed effects (issue 39, task 3): lmer drops the
# aliased columns (chkRank.drop.cols: qr(X, tol = 1e-7), LINPACK's limited
# pivoting) with the message "fixed-effect model matrix is rank deficient
# so dropping k column(s) / coefficient(s)" and fits the rest.
# Run from the repository root (R 4.2.2, lme4 1.1.31):
#   Rscript scripts/reference/mixed_rank.R > scripts/reference/mixed_rank.out
# Data: lme4's cake without the cell recipe C x temp 215 (an empty cell of
# recipe * factor(temp)), and R's CO2 with Type:Treatment without its
# margins; both read from the committed CSV files, as crossaudit reads them.
suppressPackageStartupMessages(library(lme4))
sets <- list(
  list(name = "cake_empty_cell", file = "tests/fixtures/mixed_rank/cake_empty_cell.csv",
       formula = "angle ~ recipe * factor(temp) + (1|replicate)"),
  list(name = "co2_no_margins", file = "tests/fixtures/mixed_rank/co2.csv",
       formula = "uptake ~ Type:Treatment + (1|Plant)"))
cat('"dataset","criterion","quantity","name","value"\n')
out <- function(set, crit, q, n, v) cat(sprintf('"%s","%s","%s","%s","%s"\n', set, crit, q, n, v))
for (set in sets) for (reml in c(TRUE, FALSE)) {
  d <- read.csv(set$file)
  crit <- if (reml) "reml" else "ml"
  msg <- NULL
  m <- withCallingHandlers(
    lmer(as.formula(set$formula), d, REML = reml,
         control = lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12))),
    message = function(c) { msg <<- c(msg, trimws(conditionMessage(c))); invokeRestart("muffleMessage") })
  for (one in msg) out(set$name, crit, "message", "", one)
  for (n in names(attr(getME(m, "X"), "col.dropped"))) out(set$name, crit, "dropped", n, "")
  cf <- summary(m)$coefficients
  for (i in seq_len(nrow(cf))) {
    out(set$name, crit, "estimate", rownames(cf)[i], sprintf("%.15e", cf[i, 1]))
    out(set$name, crit, "se", rownames(cf)[i], sprintf("%.15e", cf[i, 2]))
  }
  out(set$name, crit, "criterion", "", sprintf("%.15e", if (reml) REMLcrit(m) else deviance(m)))
}
