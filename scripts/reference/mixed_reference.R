# Reference fits for crossaudit's stats::mixed, from lme4 (and the data
# files the tests read). Run from the repository root:
#
#   Rscript scripts/reference/mixed_reference.R > scripts/reference/mixed_reference.out
#
# R and lme4 from Debian: apt-get install r-base-core r-cran-lme4.
# Writes tests/fixtures/{penicillin_unbalanced,pastes,dyestuff2}.csv and
# prints, for each fit, the REML or ML criterion, the variance components,
# the intercept and its standard error, and isSingular. BOBYQA is run to a
# tight tolerance so that the optimum, not the optimizer, is compared.
suppressMessages(library(lme4))
ctl <- lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12, maxfun = 1e6),
                   check.conv.singular = "ignore")
cat("# lme4", as.character(packageVersion("lme4")), "R", R.version$major, R.version$minor, "\n")
show_fit <- function(name, m) {
  vc <- as.data.frame(VarCorr(m))
  cat(name, "criterion", format(if (isREML(m)) m@devcomp$cmp[["REML"]] else deviance(m), digits = 15), "\n")
  for (i in seq_len(nrow(vc))) cat(name, "var", vc$grp[i], format(vc$vcov[i], digits = 15), "\n")
  cat(name, "intercept", format(fixef(m)[[1]], digits = 15), "\n")
  cat(name, "se", format(sqrt(vcov(m)[1, 1]), digits = 15), "\n")
  cat(name, "theta", format(getME(m, "theta"), digits = 15), "\n")
  cat(name, "singular", isSingular(m), "\n")
}
# Penicillin, unbalanced: every cell whose (plate index + 2 * sample index)
# is divisible by 7 removed (24 of 144), deterministic.
P <- Penicillin
pi <- as.integer(P$plate); si <- as.integer(P$sample)
PU <- P[((pi - 1) + 2 * (si - 1)) %% 7 != 0, ]
write.csv(data.frame(diameter = PU$diameter, plate = PU$plate, sample = PU$sample),
          "tests/fixtures/penicillin_unbalanced.csv", row.names = FALSE, quote = FALSE)
show_fit("penicillin_reml", lmer(diameter ~ 1 + (1 | plate) + (1 | sample), P, control = ctl))
show_fit("penicillin_ml", lmer(diameter ~ 1 + (1 | plate) + (1 | sample), P, REML = FALSE, control = ctl))
show_fit("penicillin_unbalanced_reml", lmer(diameter ~ 1 + (1 | plate) + (1 | sample), PU, control = ctl))
show_fit("penicillin_unbalanced_ml", lmer(diameter ~ 1 + (1 | plate) + (1 | sample), PU, REML = FALSE, control = ctl))
# Pastes: casks nested in batches.
write.csv(data.frame(strength = Pastes$strength, batch = Pastes$batch, cask = Pastes$cask),
          "tests/fixtures/pastes.csv", row.names = FALSE, quote = FALSE)
show_fit("pastes_reml", lmer(strength ~ 1 + (1 | batch) + (1 | batch:cask), Pastes, control = ctl))
# Dyestuff2: the batch variance is estimated at zero (a singular fit).
write.csv(data.frame(Yield = Dyestuff2$Yield, Batch = Dyestuff2$Batch),
          "tests/fixtures/dyestuff2.csv", row.names = FALSE, quote = FALSE)
show_fit("dyestuff2_reml", lmer(Yield ~ 1 + (1 | Batch), Dyestuff2, control = ctl))
# Satterthwaite df of the intercept (lmerTest), REML fits.
suppressMessages(library(lmerTest))
sat <- function(name, f, d) {
  m <- lmerTest::lmer(f, d, control = ctl)
  cat(name, "satterthwaite_df", format(summary(m)$coefficients[1, "df"], digits = 15), "\n")
}
sat("penicillin_reml", diameter ~ 1 + (1 | plate) + (1 | sample), P)
sat("penicillin_unbalanced_reml", diameter ~ 1 + (1 | plate) + (1 | sample), PU)
sat("pastes_reml", strength ~ 1 + (1 | batch) + (1 | batch:cask), Pastes)
sat("dyestuff2_reml", Yield ~ 1 + (1 | Batch), Dyestuff2)
# Kenward-Roger (pbkrtest): the adjusted SE of the intercept (vcovAdj) and
# its denominator df (Lb_ddf with L = 1), REML fits.
suppressMessages(library(pbkrtest))
cat("# pbkrtest", as.character(packageVersion("pbkrtest")), "lmerTest", as.character(packageVersion("lmerTest")), "\n")
kr <- function(name, f, d) {
  m <- lme4::lmer(f, d, control = ctl)
  V <- vcovAdj(m)
  cat(name, "kr_se", format(sqrt(as.matrix(V)[1, 1]), digits = 15), "\n")
  cat(name, "kr_df", format(Lb_ddf(matrix(1, 1, 1), vcov(m), V), digits = 15), "\n")
}
kr("penicillin_reml", diameter ~ 1 + (1 | plate) + (1 | sample), P)
kr("penicillin_unbalanced_reml", diameter ~ 1 + (1 | plate) + (1 | sample), PU)
kr("pastes_reml", strength ~ 1 + (1 | batch) + (1 | batch:cask), Pastes)
kr("dyestuff2_reml", Yield ~ 1 + (1 | Batch), Dyestuff2)
# Three factors, crossed and nested, unbalanced: a (8 levels) crossed with
# b (6 levels), c nested in a (3 per a), one observation per a:c x b cell,
# 10% of the cells removed; simulated with set.seed(7).
set.seed(7)
T3 <- expand.grid(c = 1:3, a = 1:8, b = 1:6)
ea <- rnorm(8, sd = 1.0); eb <- rnorm(6, sd = 0.7); ec <- rnorm(24, sd = 0.5)
T3$y <- 10 + ea[T3$a] + eb[T3$b] + ec[(T3$a - 1) * 3 + T3$c] + rnorm(nrow(T3), sd = 0.4)
T3 <- T3[-sample(nrow(T3), 14), ]
write.csv(data.frame(y = T3$y, a = T3$a, b = T3$b, c = T3$c), "tests/fixtures/three_factor.csv",
          row.names = FALSE, quote = FALSE)
T3 <- read.csv("tests/fixtures/three_factor.csv")  # fit exactly what the test reads
T3$a <- factor(T3$a); T3$b <- factor(T3$b); T3$c <- factor(T3$c)
f3 <- y ~ 1 + (1 | a) + (1 | b) + (1 | a:c)
show_fit("three_factor_reml", lme4::lmer(f3, T3, control = ctl))
sat("three_factor_reml", f3, T3)
kr("three_factor_reml", f3, T3)
# Fixed categorical effects: nlme's Machines (6 workers x 3 machines x 3
# replicates), score ~ Machine + (1 | Worker) + (1 | Worker:Machine), as
# published and with every replicate 3 of worker 1 and replicates 2-3 of
# worker 4 on machine C removed (unbalanced). Each coefficient: estimate,
# SE, lmerTest's Satterthwaite df, pbkrtest's adjusted SE and Lb_ddf for
# that coefficient alone.
data(Machines, package = "nlme")
M <- data.frame(score = Machines$score, Worker = as.character(Machines$Worker),
                Machine = as.character(Machines$Machine))
M$rep <- ave(seq_len(nrow(M)), M$Worker, M$Machine, FUN = seq_along)
MU <- M[!(M$Worker == "1" & M$rep == 3) & !(M$Worker == "4" & M$Machine == "C" & M$rep >= 2), ]
write.csv(M[, 1:3], "tests/fixtures/machines.csv", row.names = FALSE, quote = FALSE)
write.csv(MU[, 1:3], "tests/fixtures/machines_unbalanced.csv", row.names = FALSE, quote = FALSE)
fm <- score ~ Machine + (1 | Worker) + (1 | Worker:Machine)
fixed_rows <- function(name, d) {
  m <- lmerTest::lmer(fm, d, control = ctl)
  show_fit(name, m)
  co <- summary(m)$coefficients
  V <- vcovAdj(as(m, "lmerMod"))
  for (j in seq_len(nrow(co))) {
    L <- matrix(0, 1, nrow(co)); L[1, j] <- 1
    cat(name, paste0("fixed_", rownames(co)[j]),
        format(c(co[j, "Estimate"], co[j, "Std. Error"], co[j, "df"], sqrt(as.matrix(V)[j, j]),
                 Lb_ddf(L, vcov(m), V)), digits = 15), "\n")
  }
}
fixed_rows("machines_reml", M)
fixed_rows("machines_unbalanced_reml", MU)
# Profile-likelihood intervals for the standard deviations (lme4's
# confint(method = "profile"), which profiles the ML deviance whatever the
# fit: devfun2 calls refitML). Rows: the factor's SD, then the residual's.
prof <- function(name, f, d) {
  m <- lme4::lmer(f, d, control = ctl)
  ci <- suppressMessages(confint(m, method = "profile", oldNames = FALSE, level = 0.95))
  for (r in rownames(ci)[grepl("^sd_|^sigma$", rownames(ci))]) {
    g <- if (r == "sigma") "Residual" else sub("^sd_\\(Intercept\\)\\|", "", r)
    cat(name, paste0("profile_", g), format(ci[r, ], digits = 15), "\n")
  }
}
prof("penicillin", diameter ~ 1 + (1 | plate) + (1 | sample), P)
prof("penicillin_unbalanced", diameter ~ 1 + (1 | plate) + (1 | sample), PU)
prof("pastes", strength ~ 1 + (1 | batch) + (1 | batch:cask), Pastes)
prof("machines_unbalanced", fm, MU)
