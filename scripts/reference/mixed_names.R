# R's names of fixed-effect columns and random terms (issue 39, task 4):
# an interaction's variables in order of first appearance in the formula
# (`Type + conc:Type` gives `TypeMississippi:conc`), and lme4's expansion
# of `(1|a/b)` into `(1|a) + (1|b:a)` (`(1|a/b/c)`: a, b:a, c:(b:a); `/` binds looser than
# `:`). For each case: the formula, the
# fixed effects (name, estimate, in R's order), the random terms (name,
# variance) and the REML criterion.
# Run from the repository root (R 4.2.2, lme4 1.1.31):
#   Rscript scripts/reference/mixed_names.R > scripts/reference/mixed_names.out
suppressPackageStartupMessages(library(lme4))
cases <- list(
  list("co2_type_conc", "tests/fixtures/mixed_rank/co2.csv", "uptake ~ Type + conc:Type + (1|Plant)"),
  list("co2_three_way", "tests/fixtures/mixed_rank/co2.csv", "uptake ~ conc + Type + Treatment:conc:Type + (1|Plant)"),
  list("co2_later_margin", "tests/fixtures/mixed_rank/co2.csv", "uptake ~ Treatment:Type + conc + (1|Plant)"),
  list("oats_nested", "tests/fixtures/mixed_published/oats.csv", "yield ~ nitro + (1|Block/Variety)"),
  list("pastes_nested", "tests/fixtures/mixed_published/pastes.csv", "strength ~ 1 + (1|batch/cask)"),
  # Simulated: a/b/c, three nested levels (6 a, 3 b per a, 2 c per b, 3 replicates).
  list("three_levels", "tests/fixtures/mixed_names/nested3.csv", "y ~ 1 + (1|a/b/c)"),
  list("slash_binds_looser", "tests/fixtures/mixed_names/nested3.csv", "y ~ 1 + (1|a/b:c)"))
cat('"case","file","quantity","name","value"\n')
for (c in cases) {
  out <- function(q, n, v) cat(sprintf('"%s","%s","%s","%s","%s"\n', c[[1]], c[[2]], q, n, v))
  d <- read.csv(c[[2]])
  m <- suppressMessages(lmer(as.formula(c[[3]]), d, REML = TRUE,
            control = lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12))))
  out("formula", "", c[[3]])
  cf <- fixef(m)
  for (n in names(cf)) out("fixed", n, sprintf("%.15e", cf[[n]]))
  vc <- as.data.frame(VarCorr(m))
  for (i in seq_len(nrow(vc))) out("random", vc$grp[i], sprintf("%.15e", vc$vcov[i]))
  out("criterion", "", sprintf("%.15e", REMLcrit(m)))
}
