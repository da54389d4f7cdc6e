# An independent simulation of the resampling intervals' coverage (R's own
# random numbers, R's own bootstrap code), for comparison with crossaudit's
# coverage study of the same settings (results/coverage/coverage.csv,
# specs/coverage_paper.json: I = 26, normal effects, true mean 0, SE of the
# complete array's mean 1, B = 999). Estimators, as docs/statistics.md
# defines them:
#   PigeonholeSe             mean +- z SD of pigeonhole replicate means
#   PigeonholeT              pigeonhole bootstrap-t, t* = (mean* - mean) / SE*_MoM
#   ProductWeightsSe         mean +- z SD of Exp(1) product-weight means
#   ProductWeightsPercentile their type-7 percentile interval
#   ParametricT              parametric bootstrap-t, whole arrays drawn from
#                            the MoM's components (here cell by cell, not
#                            through the sufficient statistics)
# Run from the repository root:
#   Rscript scripts/reference/resampling_coverage.R > scripts/reference/resampling_coverage.out
# Prints per setting and estimator R's coverage and MCSE, crossaudit's,
# and z = the difference over the combined MCSE; |z| below about 3 is
# agreement. 2,000 replications per setting, as in crossaudit's.
set.seed(44044)
reps <- 2000
B <- 999
ours <- read.csv("results/coverage/coverage.csv", stringsAsFactors = FALSE)
cat("# R", R.version$major, R.version$minor, "\n")
cat("# setting | method | R coverage (MCSE) | crossaudit coverage (MCSE) | z\n")
settings <- list(list(I = 26, J = 20, s = c(0.959, 0.011, 0.030)), list(I = 26, J = 20, s = c(0.334, 0.333, 0.333)),
                 list(I = 26, J = 20, s = c(0.05, 0.90, 0.05)), list(I = 26, J = 5, s = c(0.959, 0.011, 0.030)),
                 list(I = 26, J = 5, s = c(0.334, 0.333, 0.333)), list(I = 26, J = 5, s = c(0.05, 0.90, 0.05)))
mom_se2 <- function(msr, msc, mse, I, J) pmax(0, (msr - mse) / J) / I + pmax(0, (msc - mse) / I) / J + mse / (I * J)
z <- qnorm(0.975)
q7 <- function(x, p) quantile(x, p, type = 7, names = FALSE)
worst <- 0
methods <- c("PigeonholeSe", "PigeonholeT", "ProductWeightsSe", "ProductWeightsPercentile", "ParametricT")
for (st in settings) {
  I <- st$I; J <- st$J; n <- I * J
  sa <- st$s[1] * I; sb <- st$s[2] * J; se <- st$s[3] * I * J
  hit <- matrix(NA, reps, length(methods), dimnames = list(NULL, methods))
  row_of <- outer(rep(1:I, J), 1:I, "==") + 0    # n x I: cell -> its row
  col_of <- outer(rep(1:J, each = I), 1:J, "==") + 0
  for (r in seq_len(reps)) {
    y <- outer(rnorm(I, sd = sqrt(sa)), rnorm(J, sd = sqrt(sb)), "+") + matrix(rnorm(n, sd = sqrt(se)), I, J)
    m <- mean(y); d <- y - m; rm <- rowMeans(y); cm <- colMeans(y)
    msr <- J * sum((rm - m)^2) / (I - 1); msc <- I * sum((cm - m)^2) / (J - 1)
    mse <- sum((y - outer(rm, cm, "+") + m)^2) / ((I - 1) * (J - 1))
    s_hat <- sqrt(mom_se2(msr, msc, mse, I, J))
    # Pigeonhole: draw counts, rows I x B and columns J x B.
    ri <- matrix(sample.int(I, I * B, replace = TRUE), I, B)
    N <- matrix(tabulate(ri + I * (col(ri) - 1), I * B), I, B)
    ci <- matrix(sample.int(J, J * B, replace = TRUE), J, B)
    C <- matrix(tabulate(ci + J * (col(ci) - 1), J * B), J, B)
    DC <- d %*% C                                   # I x B: row sums over drawn columns
    g <- colSums(N * DC) / n
    ssr <- J * colSums(N * sweep(DC / J, 2, g)^2)
    NY <- crossprod(N, d)                           # B x J: column sums over drawn rows
    ssc <- I * rowSums(t(C) * sweep(NY / I, 1, g)^2)
    sst <- colSums(N * ((d * d) %*% C)) - n * g^2
    sse <- pmax(0, sst - ssr - ssc)
    tt <- g / sqrt(mom_se2(ssr / (I - 1), ssc / (J - 1), sse / ((I - 1) * (J - 1)), I, J))
    ph_se <- sd(g)
    ph_t <- c(m - q7(tt, 0.975) * s_hat, m - q7(tt, 0.025) * s_hat)
    # Product weights.
    W <- matrix(rexp(B * I), B, I); V <- matrix(rexp(B * J), B, J)
    pw <- rowSums((W %*% d) * V) / (rowSums(W) * rowSums(V))
    # Parametric bootstrap-t, whole arrays from the MoM components.
    ca <- max(0, (msr - mse) / J); cb <- max(0, (msc - mse) / I)
    # B x n, cell (i, j) in column i + I (j - 1).
    ys <- matrix(rnorm(B * n, sd = sqrt(mse)), B, n) + matrix(rnorm(B * I, sd = sqrt(ca)), B, n) +
      matrix(rnorm(B * J, sd = sqrt(cb)), B, J)[, rep(1:J, each = I)]
    gs <- rowMeans(ys)
    rms <- ys %*% row_of / J; cms <- ys %*% col_of / I
    ssr_p <- J * rowSums((rms - gs)^2); ssc_p <- I * rowSums((cms - gs)^2)
    sse_p <- rowSums((ys - gs)^2) - ssr_p - ssc_p
    tp <- gs / sqrt(mom_se2(ssr_p / (I - 1), ssc_p / (J - 1), sse_p / ((I - 1) * (J - 1)), I, J))
    pt <- c(m - q7(tp, 0.975) * s_hat, m - q7(tp, 0.025) * s_hat)
    covers <- function(lo, hi) lo <= 0 && 0 <= hi
    hit[r, ] <- c(abs(m) <= z * ph_se, covers(ph_t[1], ph_t[2]), abs(m) <= z * sd(pw),
                  covers(m + q7(pw, 0.025), m + q7(pw, 0.975)), covers(pt[1], pt[2]))
  }
  label <- sprintf("I=%d J=%d shares %.1f/%.1f/%.1f Normal", I, J, 100 * st$s[1], 100 * st$s[2], 100 * st$s[3])
  for (k in methods) {
    h <- hit[!is.na(hit[, k]), k]; p <- mean(h); mc <- sqrt(p * (1 - p) / length(h))
    o <- ours[ours$setting == label & ours$method == k, ]
    zz <- (p - o$coverage) / sqrt(mc^2 + o$coverage_mcse^2)
    worst <- max(worst, abs(zz))
    cat(sprintf("%s | %s | %.4f (%.4f) | %.4f (%.4f) | %.2f\n", label, k, p, mc, o$coverage, o$coverage_mcse, zz))
  }
}
cat(sprintf("largest |z| %.2f\n", worst))
