# rsimsum against `crossaudit simsum`.
#
#   Rscript scripts/reference/simsum_check.R > scripts/reference/simsum_check.out
#
# Run from the repository root after `cargo build --release`. Two parts:
#
# 1. crossaudit's own tidy replications (results/coverage_rsimsum/replications.csv,
#    committed): one simsum() per setting x true mean x level, the setting's
#    first method as `ref`, the intervals as `ci.limits`. Every measure's
#    estimate and MCSE is written to scripts/reference/simsum_check.csv, which
#    tests/simsum.rs compares with what the binary writes from the same file.
# 2. rsimsum's own example studies MIsim and relhaz (GPL-3 data shipped with
#    rsimsum, so not committed here): written to a temporary folder, run
#    through target/release/crossaudit simsum, and compared here; the largest
#    differences are printed below. Neither has replication ids repeated in
#    a different order, so pairing by id and by order agree.
suppressMessages(library(rsimsum))
cat("# rsimsum", as.character(packageVersion("rsimsum")), "R", R.version$major, R.version$minor, "\n")
stats <- c("nsim", "bias", "rbias", "empse", "mse", "relprec", "modelse", "relerror", "cover", "becover", "power")

reps <- read.csv("results/coverage_rsimsum/replications.csv", stringsAsFactors = FALSE)
groups <- unique(reps[, c("setting", "true_mean", "level")])
rows <- list()
for (g in seq_len(nrow(groups))) {
  key <- groups[g, ]
  d <- reps[reps$setting == key$setting & reps$true_mean == key$true_mean & reps$level == key$level, ]
  s <- simsum(data = d, estvarname = "estimate", se = "se", true = key$true_mean, methodvar = "method",
              ref = unique(d$method)[1], ci.limits = c("ci_lower", "ci_upper"), control = list(level = key$level))
  t <- tidy(s)
  t <- t[t$stat %in% stats, ]
  rows[[g]] <- data.frame(setting = key$setting, true = key$true_mean, level = key$level, method = t$method,
                          stat = t$stat, est = t$est, mcse = t$mcse)
}
out <- do.call(rbind, rows)
write.csv(out, "scripts/reference/simsum_check.csv", row.names = FALSE)
cat("part 1: wrote", nrow(out), "rsimsum values for", nrow(groups), "groups to scripts/reference/simsum_check.csv\n")

compare <- function(name, data, args, simsum_args) {
  dir <- tempfile()
  dir.create(dir)
  path <- file.path(dir, paste0(name, ".csv"))
  write.csv(data, path, row.names = FALSE, na = "NA")
  status <- system2("target/release/crossaudit", c("simsum", path, args, "--out", file.path(dir, "out")),
                    stdout = FALSE, stderr = FALSE)
  if (status != 0) stop(name, ": crossaudit simsum failed")
  ours <- read.csv(file.path(dir, "out", "simsum.csv"), stringsAsFactors = FALSE)
  theirs <- tidy(do.call(simsum, c(list(data = data), simsum_args)))
  worst <- 0
  n <- 0
  by <- simsum_args$by
  for (k in seq_len(nrow(theirs))) {
    r <- theirs[k, ]
    if (!(r$stat %in% stats)) next
    m <- ours$method == r[[simsum_args$methodvar]] & ours$stat == r$stat
    for (b in by) m <- m & ours[[b]] == r[[b]]
    o <- ours[m, ]
    if (nrow(o) != 1) stop(name, ": ", nrow(o), " rows for ", r[[simsum_args$methodvar]], " ", r$stat)
    for (f in c("est", "mcse")) {
      if (is.na(r[[f]]) && is.na(o[[f]])) next
      worst <- max(worst, abs(r[[f]] - o[[f]]))
      n <- n + 1
    }
  }
  cat(sprintf("part 2: %s: %d values compared, largest absolute difference %.3g\n", name, n, worst))
}
data(MIsim, package = "rsimsum")
compare("MIsim", as.data.frame(MIsim), c("--estimate", "b", "--se", "se", "--method", "method", "--rep", "dataset",
        "--true", "0.5", "--ref", "CC"),
        list(estvarname = "b", se = "se", true = 0.5, methodvar = "method", ref = "CC"))
data(relhaz, package = "rsimsum")
compare("relhaz", relhaz, c("--estimate", "theta", "--se", "se", "--method", "model", "--rep", "dataset",
        "--by", "n,baseline", "--true=-0.5", "--ref", "Cox"),
        list(estvarname = "theta", se = "se", true = -0.5, methodvar = "model", ref = "Cox", by = c("n", "baseline")))
