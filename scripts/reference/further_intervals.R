# The coverage study's further variance estimators on every array of the
# small locked study (tests/fixtures/coverage_small/arrays.csv: 200 crossed
# 10 x 4 arrays, crossaudit's own draws, checked by tests/coverage.rs to be
# the study's), computed here by other code. Run from the repository root:
#
#   Rscript scripts/reference/further_intervals.R > scripts/reference/further_intervals.out
#
# R and sandwich from Debian (r-base-core, r-cran-sandwich). Per array:
# - cgm: Cameron-Gelbach-Miller two-way cluster-robust variance of the
#   intercept, sandwich::vcovCL(lm(y ~ 1), cluster = ~ row + col) (its
#   defaults: HC1, cluster adjustment G / (G - 1));
# - margins: var(row means) / I + var(column means) / J;
# - jackknife: the delete-one-row jackknife variance of the mean plus the
#   delete-one-column one, computed by deleting (equal to margins, the
#   identity docs/statistics.md states);
# - untruncated: (MS_row + MS_col - MS_error) / (IJ) from anova() of the
#   two-way additive model.
suppressMessages(library(sandwich))
cat("# R", R.version$major, R.version$minor, "sandwich", as.character(packageVersion("sandwich")), "\n")
cat("# setting rep cgm margins jackknife untruncated\n")
all <- read.csv("tests/fixtures/coverage_small/arrays.csv")
jack <- function(d, by) {
  g <- sort(unique(d[[by]])); k <- length(g)
  th <- vapply(g, function(x) mean(d$y[d[[by]] != x]), numeric(1))
  (k - 1) / k * sum((th - mean(th))^2)
}
for (k in sort(unique(all$setting))) for (r in sort(unique(all$rep[all$setting == k]))) {
  d <- all[all$setting == k & all$rep == r, ]
  I <- length(unique(d$row)); J <- length(unique(d$col))
  cgm <- vcovCL(lm(y ~ 1, data = d), cluster = ~ row + col)[1, 1]
  margins <- var(tapply(d$y, d$row, mean)) / I + var(tapply(d$y, d$col, mean)) / J
  jk <- jack(d, "row") + jack(d, "col")
  a <- anova(lm(y ~ factor(row) + factor(col), data = d))
  ms <- a[["Mean Sq"]]
  untr <- (ms[1] + ms[2] - ms[3]) / (I * J)
  cat(k, r, format(c(cgm, margins, jk, untr), digits = 17), "\n")
}
