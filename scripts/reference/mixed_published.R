# Reference output for `crossaudit mixed` on published data sets, from
# lme4, lmerTest (Satterthwaite) and pbkrtest (Kenward-Roger through
# lmerTest). Run from the repository root (Debian: apt-get install
# r-base-core r-cran-lme4 r-cran-lmertest r-cran-pbkrtest):
#
#   Rscript scripts/reference/mixed_published.R
#
# Writes each data set as tests/fixtures/mixed_published/NAME.csv, reads
# it back with read.csv (so R fits exactly the table crossaudit reads:
# text columns become factors with levels in C-locale order) and writes
# tests/fixtures/mixed_published/reference.csv: per data set and
# criterion (REML, ML), the criterion, every variance component, and per
# fixed effect the estimate, SE, Satterthwaite df and p (lmerTest), and the
# Kenward-Roger SE and df (REML only). The formulas are in
# tests/fixtures/mixed_published/formulas.csv. BOBYQA is run to rhoend
# 1e-12 so that the optimum, not the optimizer, is compared.
suppressMessages({ library(lme4); library(lmerTest); library(pbkrtest); library(nlme) })
invisible(Sys.setlocale("LC_COLLATE", "C"))
dir <- "tests/fixtures/mixed_published"
dir.create(dir, showWarnings = FALSE, recursive = TRUE)
ctl <- lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12, maxfun = 1e6),
                   check.conv.singular = "ignore")
plain <- function(d) { d <- as.data.frame(d); for (n in names(d)) if (is.factor(d[[n]])) d[[n]] <- as.character(d[[n]]); d }
sets <- list(
  dyestuff = list(lme4::Dyestuff, "Yield ~ 1 + (1|Batch)"),
  dyestuff2 = list(lme4::Dyestuff2, "Yield ~ 1 + (1|Batch)"),
  penicillin = list(lme4::Penicillin, "diameter ~ 1 + (1|plate) + (1|sample)"),
  pastes = list(lme4::Pastes[, c("strength", "batch", "cask")], "strength ~ 1 + (1|batch) + (1|batch:cask)"),
  cake = list(lme4::cake[, c("angle", "recipe", "replicate", "temp")],
              "angle ~ recipe:temp + (1|replicate) + (1|recipe:replicate)"),
  sleepstudy = list(lme4::sleepstudy, "Reaction ~ Days + (1|Subject)"),
  rail = list(nlme::Rail, "travel ~ 1 + (1|Rail)"),
  oats = list(nlme::Oats, "yield ~ nitro + Variety + (1|Block) + (1|Block:Variety)"),
  machines = list(nlme::Machines, "score ~ Machine + (1|Worker) + (1|Worker:Machine)"),
  ergostool = list(nlme::ergoStool, "effort ~ Type + (1|Subject)"),
  orthodont = list(nlme::Orthodont, "distance ~ age + Sex + (1|Subject)"),
  chickweight = list(datasets::ChickWeight, "weight ~ Time + factor(Diet) + (1|Chick)")
)
out <- list()
add <- function(...) out[[length(out) + 1]] <<- data.frame(...)
formulas <- data.frame(dataset = names(sets), formula = sapply(sets, `[[`, 2))
write.csv(formulas, file.path(dir, "formulas.csv"), row.names = FALSE)
for (name in names(sets)) {
  file <- file.path(dir, paste0(name, ".csv"))
  write.csv(plain(sets[[name]][[1]]), file, row.names = FALSE)
  d <- read.csv(file, stringsAsFactors = TRUE)
  f <- as.formula(sets[[name]][[2]])
  for (reml in c(TRUE, FALSE)) {
    crit <- if (reml) "reml" else "ml"
    m <- lmerTest::lmer(f, data = d, REML = reml, control = ctl)
    value <- if (reml) m@devcomp$cmp[["REML"]] else deviance(m)
    add(dataset = name, criterion = crit, quantity = "criterion", name = "", value = value)
    add(dataset = name, criterion = crit, quantity = "singular", name = "", value = as.numeric(isSingular(m)))
    vc <- as.data.frame(VarCorr(m))
    for (i in seq_len(nrow(vc))) add(dataset = name, criterion = crit, quantity = "variance", name = vc$grp[i], value = vc$vcov[i])
    s <- summary(m, ddf = "Satterthwaite")$coefficients
    for (j in seq_len(nrow(s))) {
      n <- rownames(s)[j]
      add(dataset = name, criterion = crit, quantity = "estimate", name = n, value = s[j, "Estimate"])
      add(dataset = name, criterion = crit, quantity = "se", name = n, value = s[j, "Std. Error"])
      add(dataset = name, criterion = crit, quantity = "df", name = n, value = s[j, "df"])
      add(dataset = name, criterion = crit, quantity = "p", name = n, value = s[j, "Pr(>|t|)"])
    }
    if (reml) {
      k <- summary(m, ddf = "Kenward-Roger")$coefficients
      for (j in seq_len(nrow(k))) {
        n <- rownames(k)[j]
        add(dataset = name, criterion = crit, quantity = "kr_se", name = n, value = k[j, "Std. Error"])
        add(dataset = name, criterion = crit, quantity = "kr_df", name = n, value = k[j, "df"])
      }
    }
  }
}
res <- do.call(rbind, out)
res$value <- format(res$value, digits = 15)
write.csv(res, file.path(dir, "reference.csv"), row.names = FALSE)
cat("# lme4", as.character(packageVersion("lme4")), "lmerTest", as.character(packageVersion("lmerTest")),
    "pbkrtest", as.character(packageVersion("pbkrtest")), "R", R.version$major, R.version$minor, "\n")
