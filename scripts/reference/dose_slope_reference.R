# Reference for crossaudit's trend over doses and its planner
# (`crossaudit plan` on a dose-response design), on the committed
# dose-response run. Run from the repository root:
#
#   Rscript scripts/reference/dose_slope_reference.R > scripts/reference/dose_slope_reference.out
#
# Base R only. For the primary unit (model world, horizon 1 s,
# fa_position_rmse_m) it forms, per recording x seed cell, d at each dose
# (treated - disjoint) and the least-squares slope of d on the dose in
# percentage points, with the disjoint arm as dose 0 and d = 0 there
# (lm(d ~ dose)). The slopes are then analysed as crossaudit's crossed
# method of moments does: the two-way ANOVA without replication
# (anova(lm(slope ~ recording + seed))), components
# s2_rec = max(0, (MS_rec - MS_res) / J), s2_seed = max(0, (MS_seed - MS_res) / I),
# s2_res = MS_res, and SE(I, J) = sqrt(s2_rec / I + s2_seed / J + s2_res / (I J)),
# printed at the pilot's size and at the sizes the test checks.
cat("# R", R.version$major, R.version$minor, "\n")
cells <- read.csv("results/dose_response/cells.csv", stringsAsFactors = FALSE)
u <- cells[cells$model == "world" & cells$horizon_s == 1, ]
r <- u[u$arm == "disjoint", c("recording", "seed", "fa_position_rmse_m")]
t <- u[u$arm != "disjoint", c("recording", "seed", "dose", "fa_position_rmse_m")]
k <- merge(t, r, by = c("recording", "seed"), suffixes = c(".t", ".r"))
stopifnot(nrow(k) == nrow(t))
k$d <- k$fa_position_rmse_m.t - k$fa_position_rmse_m.r
keys <- unique(k[, c("recording", "seed")])
slopes <- data.frame(recording = keys$recording, seed = keys$seed, slope = NA_real_)
for (c in seq_len(nrow(keys))) {
  rows <- k[k$recording == keys$recording[c] & k$seed == keys$seed[c], ]
  x <- c(0, rows$dose); y <- c(0, rows$d)
  slopes$slope[c] <- coef(lm(y ~ x))[[2]]
}
slopes$recording <- factor(slopes$recording); slopes$seed <- factor(slopes$seed)
I <- nlevels(slopes$recording); J <- nlevels(slopes$seed)
stopifnot(nrow(slopes) == I * J)
a <- anova(lm(slope ~ recording + seed, slopes))
ms_rec <- a["recording", "Mean Sq"]; ms_seed <- a["seed", "Mean Sq"]; ms_res <- a["Residuals", "Mean Sq"]
s2 <- c(recording = max(0, (ms_rec - ms_res) / J), seed = max(0, (ms_seed - ms_res) / I), residual = ms_res)
se <- function(i, j) sqrt(s2[["recording"]] / i + s2[["seed"]] / j + s2[["residual"]] / (i * j))
cat("dose_response levels", I, J, "\n")
cat("dose_response mean_slope", format(mean(slopes$slope), digits = 15), "\n")
for (n in names(s2)) cat("dose_response var", n, format(s2[[n]], digits = 15), "\n")
for (ij in list(c(I, J), c(13, 5), c(26, 20), c(52, 40))) {
  cat("dose_response se_at", ij[1], ij[2], format(se(ij[1], ij[2]), digits = 15), "\n")
}
