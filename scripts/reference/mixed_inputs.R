# Reference output for the small input classes of issue 39 (task 1):
# R's labels of a numeric column's factor levels, and lme4's fit of a
# factor whose levels are written in several spellings (1, 1.0, 1e0).
# Run from the repository root:
#   Rscript scripts/reference/mixed_inputs.R > scripts/reference/mixed_inputs.out
# (R 4.2.2, lme4 1.1.31.) Output: "quantity","name","value" rows.
suppressPackageStartupMessages(library(lme4))
out <- function(q, n, v) cat(sprintf('"%s","%s","%s"\n', q, n, v))
cat('"quantity","name","value"\n')
# as.character of a double, the label factor() gives a numeric level.
x <- c(1, 2.5, 100000, 123456, 0.0001, 0.1, 1e15, 123456789012, -0, 1/3,
       2.5e-7, 100000.1, -1.5, 1e-300, 123456.7, 1234567890123456, 3e5, 1e5 + 1,
       -2e-5, 99999.99999999999, 1.5e200)
for (v in x) out("label", sprintf("%.17g", v), as.character(v))
# Levels of factor(d) on a column written 1 / 1.0 / 1e0, 2 / 2.00 / 2.0, 10 / 10.0 / 1e1.
d <- read.csv("tests/fixtures/mixed_inputs/spellings.csv")
out("levels", "factor(d)", paste(levels(factor(d$d)), collapse = " "))
m <- lmer(y ~ factor(d) + (1 | g), d, REML = TRUE,
          control = lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12)))
cf <- summary(m)$coefficients
for (i in seq_len(nrow(cf))) {
  out("estimate", rownames(cf)[i], sprintf("%.15e", cf[i, 1]))
  out("se", rownames(cf)[i], sprintf("%.15e", cf[i, 2]))
}
out("criterion", "REML", sprintf("%.15e", REMLcrit(m)))
