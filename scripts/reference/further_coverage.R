# An independent simulation of the further estimators' coverage (R's own
# random numbers, R's qt), for comparison with crossaudit's coverage study
# of the same settings (results/coverage/coverage.csv, specs/coverage_paper.json:
# I = 26, normal effects, true mean 0, SE of the complete array's mean 1,
# 2,000 replications). Run from the repository root:
#
#   Rscript scripts/reference/further_coverage.R > scripts/reference/further_coverage.out
#
# Prints per setting and estimator R's coverage and MCSE, crossaudit's,
# and z = the difference over the combined MCSE. The two simulations share
# no random numbers, so |z| below about 3 is agreement.
set.seed(20261127)
reps <- 2000
ours <- read.csv("results/coverage/coverage.csv", stringsAsFactors = FALSE)
cat("# R", R.version$major, R.version$minor, "\n")
cat("# setting | method | R coverage (MCSE) | crossaudit coverage (MCSE) | z\n")
settings <- list(list(I = 26, J = 20, s = c(0.959, 0.011, 0.030)), list(I = 26, J = 20, s = c(0.334, 0.333, 0.333)),
                 list(I = 26, J = 20, s = c(0.05, 0.90, 0.05)), list(I = 26, J = 5, s = c(0.959, 0.011, 0.030)),
                 list(I = 26, J = 5, s = c(0.334, 0.333, 0.333)), list(I = 26, J = 5, s = c(0.05, 0.90, 0.05)))
worst <- 0
for (st in settings) {
  I <- st$I; J <- st$J; n <- I * J
  sa <- st$s[1] * I; sb <- st$s[2] * J; se <- st$s[3] * I * J
  hit <- matrix(NA, reps, 3, dimnames = list(NULL, c("TwoWayCluster", "SumOfMargins", "MomUntruncated")))
  for (r in seq_len(reps)) {
    y <- outer(rnorm(I, sd = sqrt(sa)), rnorm(J, sd = sqrt(sb)), "+") + matrix(rnorm(n, sd = sqrt(se)), I, J)
    m <- mean(y); rm <- rowMeans(y); cm <- colMeans(y); e <- y - m
    cgm <- I / (I - 1) * sum(rowSums(e)^2) / n^2 + J / (J - 1) * sum(colSums(e)^2) / n^2 - n / (n - 1) * sum(e^2) / n^2
    mar <- var(rm) / I + var(cm) / J
    msr <- J * sum((rm - m)^2) / (I - 1); msc <- I * sum((cm - m)^2) / (J - 1)
    mse <- sum((y - outer(rm, cm, "+") + m)^2) / ((I - 1) * (J - 1))
    unt <- (msr + msc - mse) / n
    ci <- function(v, df) if (v > 0) abs(m) <= qt(0.975, df) * sqrt(v) else NA
    hit[r, ] <- c(ci(cgm, min(I, J) - 1), ci(mar, min(I, J) - 1), ci(unt, J - 1))
  }
  label <- sprintf("I=%d J=%d shares %.1f/%.1f/%.1f Normal", I, J, 100 * st$s[1], 100 * st$s[2], 100 * st$s[3])
  for (k in colnames(hit)) {
    h <- hit[!is.na(hit[, k]), k]; p <- mean(h); mc <- sqrt(p * (1 - p) / length(h))
    o <- ours[ours$setting == label & ours$method == k, ]
    z <- (p - o$coverage) / sqrt(mc^2 + o$coverage_mcse^2)
    worst <- max(worst, abs(z))
    cat(sprintf("%s | %s | %.4f (%.4f) | %.4f (%.4f) | %.2f\n", label, k, p, mc, o$coverage, o$coverage_mcse, z))
  }
}
cat(sprintf("largest |z| %.2f\n", worst))
