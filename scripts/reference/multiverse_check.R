# Independent recomputation of a committed multiverse (or draw-replication)
# run from its cells alone, in base R and lme4, sharing no code with
# crossaudit:
#   Rscript scripts/reference/multiverse_check.R RUN_DIR [PRIMARY_SPEC]
# RUN_DIR holds multiverse_cells.csv (columns spec, draw, then the per-cell
# columns). For every specification: d = contaminated - disjoint of the
# world model's failure-aware position RMSE at 1 s per recording x seed;
# the crossed method-of-moments mean, SE (two-way ANOVA without
# replication, variance components truncated at 0) and the t interval with
# J - 1 df; optimism. For every choice (a column of RUN_DIR/report/specs.csv
# between `spec` and `primary`): the paired effect of each alternative
# against the primary's, per recording x seed, with the same estimator.
# Under draw replication: lme4's REML fit of
# d ~ 1 + (1|recording) + (1|seed) + (1|draw) + (1|recording:draw) + (1|seed:draw).
# Writes RUN_DIR/reference/specs_r.csv, choice_effects_r.csv and
# draws_r.csv; tests/multiverse.rs compares crossaudit's analysis with them.
suppressMessages(library(lme4))
suppressMessages(library(pbkrtest))
args <- commandArgs(trailingOnly = TRUE)
dir <- args[1]
cells <- read.csv(file.path(dir, "multiverse_cells.csv"), stringsAsFactors = FALSE,
                  colClasses = c(spec = "character", draw = "character"))
cells$spec[is.na(cells$spec)] <- ""
cells$draw[is.na(cells$draw)] <- ""
specs_csv <- read.csv(file.path(dir, "report", "specs.csv"), stringsAsFactors = FALSE,
                      colClasses = "character")
choices <- names(specs_csv)[seq(2, which(names(specs_csv) == "primary") - 1)]
if (length(choices) == 1 && choices[1] == "primary") choices <- character(0)
out <- file.path(dir, "reference")
dir.create(out, showWarnings = FALSE)

# d per recording x seed of one level, as a matrix (rows: recordings).
# The contrast is contaminated - disjoint unless a `contrast` choice names another.
d_matrix <- function(x, contrast = "contaminated - disjoint") {
  arms <- strsplit(contrast, " - ", fixed = TRUE)[[1]]
  p <- x[x$model == "world" & abs(x$horizon_s - 1) < 1e-9, ]
  t <- p[p$arm == arms[1], c("recording", "seed", "fa_position_rmse_m")]
  r <- p[p$arm == arms[2], c("recording", "seed", "fa_position_rmse_m")]
  m <- merge(t, r, by = c("recording", "seed"), suffixes = c(".t", ".r"))
  m$d <- m$fa_position_rmse_m.t - m$fa_position_rmse_m.r
  w <- reshape(m[, c("recording", "seed", "d")], idvar = "recording", timevar = "seed", direction = "wide")
  rownames(w) <- w$recording
  w <- as.matrix(w[, -1, drop = FALSE])
  list(d = w[order(rownames(w)), order(colnames(w)), drop = FALSE],
       treated = mean(m$fa_position_rmse_m.t), reference = mean(m$fa_position_rmse_m.r))
}

# The crossed MoM from R's own ANOVA table.
mom <- function(w) {
  long <- data.frame(y = as.vector(w), rec = factor(rep(rownames(w), ncol(w))),
                     seed = factor(rep(colnames(w), each = nrow(w))))
  tab <- anova(lm(y ~ rec + seed, data = long))
  I <- nrow(w); J <- ncol(w)
  ms_r <- tab["rec", "Mean Sq"]; ms_s <- tab["seed", "Mean Sq"]; ms_e <- tab["Residuals", "Mean Sq"]
  sa <- max((ms_r - ms_e) / J, 0); sb <- max((ms_s - ms_e) / I, 0)
  se <- sqrt(sa / I + sb / J + ms_e / (I * J))
  q <- qt(0.975, J - 1)
  c(mean = mean(w), se = se, df = J - 1, lower = mean(w) - q * se, upper = mean(w) + q * se)
}

# Per-seed draws (`draws per seed`): each seed of a specification has one
# draw of its own, so a specification is one crossed recording x seed
# study and there is no draw replication to pool.
per_spec_seed <- tapply(cells$draw, paste(cells$spec, cells$seed), function(d) length(unique(d)))
if (length(unique(cells$draw)) > 1 && all(per_spec_seed == 1)) cells$draw <- ""
first_draw <- if (all(cells$draw == "")) "" else as.character(min(as.integer(cells$draw)))
ids <- specs_csv$spec
level_of <- function(id, draw) cells[cells$spec == ifelse(id == "-", "", id) & cells$draw == draw, ]
spec_rows <- list(); mats <- list()
contrast_of <- function(id) {
  if ("contrast" %in% names(specs_csv)) specs_csv$contrast[specs_csv$spec == id] else "contaminated - disjoint"
}
# multiverse_cells.csv holds every level's cells, a level that shares
# another's run included (under its own id).
cells_of <- level_of
for (id in ids) {
  x <- d_matrix(cells_of(id, first_draw), contrast_of(id))
  mats[[id]] <- x$d
  e <- mom(x$d)
  spec_rows[[id]] <- data.frame(spec = id, d_m = e[["mean"]], se_m = e[["se"]], df = e[["df"]],
                                lower_m = e[["lower"]], upper_m = e[["upper"]],
                                optimism_pct = 100 * (x$reference - x$treated) / x$reference)
}
write.csv(do.call(rbind, spec_rows), file.path(out, "specs_r.csv"), row.names = FALSE)

if (length(choices) > 0) {
  primary <- specs_csv[specs_csv$primary == "true", ]
  recs <- Reduce(intersect, lapply(mats, rownames)); seeds <- Reduce(intersect, lapply(mats, colnames))
  effects <- list()
  for (ch in choices) {
    for (alt in setdiff(unique(specs_csv[[ch]]), primary[[ch]])) {
      avg <- function(v) Reduce(`+`, lapply(specs_csv$spec[specs_csv[[ch]] == v],
                                            function(s) mats[[s]][recs, seeds])) / sum(specs_csv[[ch]] == v)
      e <- mom(avg(alt) - avg(primary[[ch]]))
      effects[[length(effects) + 1]] <- data.frame(choice = ch, reference = primary[[ch]], alternative = alt,
                                                   effect_m = e[["mean"]], se_m = e[["se"]],
                                                   lower_m = e[["lower"]], upper_m = e[["upper"]])
    }
  }
  write.csv(do.call(rbind, effects), file.path(out, "choice_effects_r.csv"), row.names = FALSE)
}

if (first_draw != "") {
  rows <- list()
  for (id in ids) {
    long <- do.call(rbind, lapply(unique(cells$draw), function(k) {
      w <- d_matrix(cells_of(id, k), contrast_of(id))$d
      data.frame(y = as.vector(w), recording = rep(rownames(w), ncol(w)),
                 seed = rep(colnames(w), each = nrow(w)), draw = k)
    }))
    f <- lmer(y ~ 1 + (1 | recording) + (1 | seed) + (1 | draw) + (1 | recording:draw) + (1 | seed:draw),
              data = long, REML = TRUE, control = lmerControl(optimizer = "bobyqa"))
    vc <- as.data.frame(VarCorr(f))
    # Kenward-Roger (pbkrtest): the adjusted variance and the df, what the
    # decision of a draw-replicated design reads.
    vadj <- vcovAdj(f)
    kr_df <- Lb_ddf(matrix(1, 1, 1), vcov(f), vadj)
    rows[[id]] <- data.frame(spec = id, pooled_m = fixef(f)[[1]], se_m = sqrt(vcov(f)[1, 1]),
                             kr_se_m = sqrt(vadj[1, 1]), kr_df = kr_df,
                             var_recording = vc$vcov[vc$grp == "recording"], var_seed = vc$vcov[vc$grp == "seed"],
                             var_draw = vc$vcov[vc$grp == "draw"],
                             var_recording_draw = vc$vcov[vc$grp == "recording:draw"],
                             var_seed_draw = vc$vcov[vc$grp == "seed:draw"],
                             var_residual = vc$vcov[vc$grp == "Residual"])
  }
  write.csv(do.call(rbind, rows), file.path(out, "draws_r.csv"), row.names = FALSE)
}
cat("wrote", out, "\n")
