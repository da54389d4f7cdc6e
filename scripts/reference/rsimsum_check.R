# rsimsum on crossaudit's tidy replications: every performance measure
# rsimsum computes, against crossaudit's coverage.csv, for every setting,
# true mean, level and estimator of results/coverage_rsimsum
# (specs/coverage_rsimsum.json, written by
#   crossaudit coverage specs/coverage_rsimsum.json --out results/coverage_rsimsum --replications).
# Run from the repository root:
#
#   Rscript scripts/reference/rsimsum_check.R > scripts/reference/rsimsum_check.out
#
# rsimsum 0.13.0 is not packaged by Debian: fetch github.com/ellessenne/rsimsum,
# check out its 0.13.0 release commit (c62b605; later ones need rlang >= 1.2)
# and `R CMD INSTALL` it (its dependencies are Debian's r-cran-*, with
# r-cran-ggridges). Each group is one simsum() call with the setting's first
# estimator as `ref` (crossaudit's reference for the relative precision)
# and the intervals as `ci.limits`; rsimsum's power is its Wald z test at
# the group's level. Prints, per measure, how many values were compared and
# the largest absolute difference (estimates and MCSEs), the MCSEs not
# compared and why, then the largest difference over all.
suppressMessages(library(rsimsum))
reps <- read.csv("results/coverage_rsimsum/replications.csv", stringsAsFactors = FALSE)
ours <- read.csv("results/coverage_rsimsum/coverage.csv", stringsAsFactors = FALSE)
cat("# rsimsum", as.character(packageVersion("rsimsum")), "R", R.version$major, R.version$minor, "\n")
# rsimsum stat -> crossaudit column (estimate, MCSE)
map <- list(nsim = c("reps", NA), bias = c("bias", "bias_mcse"), rbias = c("rel_bias", "rel_bias_mcse"),
            empse = c("emp_se", "emp_se_mcse"), mse = c("mse", "mse_mcse"),
            relprec = c("rel_precision", "rel_precision_mcse"), modelse = c("mod_se", "mod_se_mcse"),
            relerror = c("rel_error_mod_se_pct", "rel_error_mod_se_mcse"), cover = c("coverage", "coverage_mcse"),
            becover = c("be_coverage", "be_coverage_mcse"), power = c("power", "power_mcse"))
worst <- setNames(rep(0, length(map)), names(map)); count <- setNames(rep(0, length(map)), names(map))
skipped <- character(0)
groups <- unique(reps[, c("setting", "true_mean", "level")])
for (g in seq_len(nrow(groups))) {
  key <- groups[g, ]
  d <- reps[reps$setting == key$setting & reps$true_mean == key$true_mean & reps$level == key$level, ]
  methods <- unique(d$method)
  s <- simsum(data = d, estvarname = "estimate", se = "se", true = key$true_mean, methodvar = "method",
              ref = methods[1], ci.limits = c("ci_lower", "ci_upper"), control = list(level = key$level))
  t <- tidy(s)
  o <- ours[ours$setting == key$setting & ours$true_mean == key$true_mean & ours$level == key$level, ]
  ref <- d$estimate[d$method == methods[1]]
  for (stat in names(map)) {
    if (stat == "rbias" && key$true_mean == 0) next  # undefined (NaN in both)
    for (m in methods) {
      r <- t[t$stat == stat & t$method == m, ]
      c <- o[o$method == m, ]
      worst[stat] <- max(worst[stat], abs(r$est - c[[map[[stat]][1]]]))
      count[stat] <- count[stat] + 1
      if (is.na(map[[stat]][2])) next
      mine <- d$estimate[d$method == m]
      if (stat == "relprec" && isTRUE(all.equal(ref, mine, tolerance = 1e-12))) {
        # Equal estimates: rho = 1 and the MCSE is 0; R's cor() rounds rho
        # to 1 - 1e-16, and sqrt(1 - rho^2) turns that into 2e-7 or NaN.
        skipped <- c(skipped, "relprec MCSE of an estimator whose estimates equal the reference's (0 by definition)")
        next
      }
      if (is.na(r$mcse)) {
        # rsimsum's rbias MCSE is sd() without na.rm: NA when any replication is.
        skipped <- c(skipped, sprintf("%s MCSE that rsimsum leaves NA", stat))
        next
      }
      worst[stat] <- max(worst[stat], abs(r$mcse - c[[map[[stat]][2]]]))
    }
  }
}
for (stat in names(map)) cat(sprintf("%-9s compared %4d  max |rsimsum - crossaudit| %.3e\n", stat, count[stat], worst[stat]))
for (why in unique(skipped)) cat(sprintf("not compared (%d): %s\n", sum(skipped == why), why))
cat(sprintf("overall max |rsimsum - crossaudit| %.3e over %d groups\n", max(worst), nrow(groups)))
