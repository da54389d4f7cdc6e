# Independent Monte Carlo references for the resampling intervals of
# src/stats/resampling.rs (issue 44), with R's own random numbers, on the
# first three arrays (10 x 4) of tests/fixtures/coverage_small/arrays.csv:
#
# 1. Owen & Eckles' product weights: row and column weights rexp(1), the
#    replicate the weighted mean; the variance of 200,000 replicates.
# 2. The parametric bootstrap-t: 200,000 whole arrays drawn cell by cell
#    (rnorm) from the crossed normal model with the array's MoM components
#    (truncated at 0), t* = (mean* - mean) / SE*_MoM; its 2.5% and 97.5%
#    quantiles (crossaudit draws the mean and the sums of squares from their
#    sampling distributions instead, so this checks that route too).
#
# Each number is printed with its Monte Carlo SE (the variance's from the
# replicates' squared deviations; a quantile's from 50 batches).
# Run from the repository root:
#   Rscript scripts/reference/resampling_check.R > scripts/reference/resampling_check.out
set.seed(44)
B <- 200000
arrays <- read.csv("tests/fixtures/coverage_small/arrays.csv")
cat("# R", R.version$major, R.version$minor, "B =", B, "\n")
cat("# setting rep | product-weight variance (MCSE) | parametric t* 2.5% (MCSE) | 97.5% (MCSE)\n")
mom_se2 <- function(msr, msc, mse, I, J) pmax(0, (msr - mse) / J) / I + pmax(0, (msc - mse) / I) / J + mse / (I * J)
batch_q <- function(x, p) {
  q <- quantile(x, p, type = 7, names = FALSE)
  b <- sapply(split(x, rep(1:50, length.out = length(x))), quantile, probs = p, type = 7, names = FALSE)
  c(q, sd(b) / sqrt(50))
}
for (r in 0:2) {
  a <- arrays[arrays$setting == 0 & arrays$rep == r, ]
  I <- max(a$row) + 1; J <- max(a$col) + 1
  y <- matrix(NA, I, J); y[cbind(a$row + 1, a$col + 1)] <- a$y
  m <- mean(y); d <- y - m
  # 1. Product weights.
  W <- matrix(rexp(B * I), B, I); V <- matrix(rexp(B * J), B, J)
  t_pw <- rowSums((W %*% d) * V) / (rowSums(W) * rowSums(V))
  v_pw <- mean((t_pw - mean(t_pw))^2) * B / (B - 1)
  v_mcse <- sd((t_pw - mean(t_pw))^2) / sqrt(B)
  # 2. Parametric bootstrap-t, whole arrays.
  rm <- rowMeans(y); cm <- colMeans(y)
  msr <- J * sum((rm - m)^2) / (I - 1); msc <- I * sum((cm - m)^2) / (J - 1)
  mse <- sum((y - outer(rm, cm, "+") + m)^2) / ((I - 1) * (J - 1))
  sa <- max(0, (msr - mse) / J); sb <- max(0, (msc - mse) / I)
  se <- sqrt(mom_se2(msr, msc, mse, I, J))
  tt <- numeric(0)
  for (chunk in 1:20) {
    n <- B / 20
    ys <- array(rnorm(n * I * J, sd = sqrt(mse)), c(n, I, J)) +
      array(rnorm(n * I, sd = sqrt(sa)), c(n, I, J)) +
      aperm(array(rnorm(n * J, sd = sqrt(sb)), c(n, J, I)), c(1, 3, 2))
    g <- apply(ys, 1, mean)
    rms <- apply(ys, c(1, 2), mean); cms <- apply(ys, c(1, 3), mean)
    ssr <- J * rowSums((rms - g)^2); ssc <- I * rowSums((cms - g)^2)
    sst <- apply((ys - g)^2, 1, sum)
    sse <- sst - ssr - ssc
    se_star <- sqrt(mom_se2(ssr / (I - 1), ssc / (J - 1), sse / ((I - 1) * (J - 1)), I, J))
    tt <- c(tt, g / se_star)   # the model's mean is 0 here: mean* - mean
  }
  lo <- batch_q(tt, 0.025); hi <- batch_q(tt, 0.975)
  cat(sprintf("0 %d | %.10e %.3e | %.6f %.6f | %.6f %.6f\n", r, v_pw, v_mcse, lo[1], lo[2], hi[1], hi[2]))
}
