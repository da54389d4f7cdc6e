# Stress test of crossaudit's REML optimizer against lme4: 400 random
# random-intercept designs (crossed, nested, crossed plus nested, with and
# without fixed effects: categorical within and between groups, numeric,
# and a factor-by-numeric interaction), about a quarter of the variance
# components zero in truth so that many optima lie on the boundary, and
# two named cases: lme4's `cake` data with
# angle ~ recipe:temp + (1|replicate) + (1|recipe:replicate) (written
# y ~ f:x + (1|a) + (1|f:a) in the shared columns), and a
# synthetic three-crossed-plus-nested set with a between-group fixed
# effect. Run from the repository root (R, lme4 from Debian:
# apt-get install r-base-core r-cran-lme4):
#
#   Rscript scripts/reference/mixed_stress.R
#
# Writes tests/fixtures/mixed_stress/data.csv.gz (every design's rows:
# id, y, a, b, c, f, x) and tests/fixtures/mixed_stress/lme4.csv (per
# design: id, formula, the best REML criterion lme4 reached over three
# optimizers, each tightly converged: BOBYQA to rhoend 1e-12, Nelder-Mead
# to ftol 1e-14 and nloptwrap's BOBYQA to xtol 1e-12; isSingular; or the
# error lme4 gave). tests/stats_stress.rs fits every design with
# crossaudit's formula front end and checks that its criterion is never
# worse than lme4's by more than 1e-6 relative.
suppressMessages(library(lme4))
set.seed(20261123)
dir.create("tests/fixtures/mixed_stress", showWarnings = FALSE, recursive = TRUE)

ctls <- list(
  bobyqa = lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12, maxfun = 1e6),
                       check.conv.singular = "ignore", calc.derivs = FALSE),
  nm = lmerControl(optimizer = "Nelder_Mead", optCtrl = list(FtolAbs = 1e-14, FtolRel = 1e-15, XtolRel = 1e-12, maxfun = 1e6),
                   check.conv.singular = "ignore", calc.derivs = FALSE),
  nlopt = lmerControl(optimizer = "nloptwrap", optCtrl = list(xtol_abs = 1e-12, ftol_abs = 1e-14, maxeval = 1e6),
                      check.conv.singular = "ignore", calc.derivs = FALSE)
)

# A component: zero with probability 0.25, else log-normal.
component <- function() if (runif(1) < 0.25) 0 else exp(rnorm(1, 0, 1))

one_design <- function(i) {
  type <- sample(c("crossed2", "nested", "crossed3", "crossed_nested"), 1)
  fixed <- sample(c("none", "f_within", "f_between", "x", "fx"), 1, prob = c(0.3, 0.2, 0.2, 0.15, 0.15))
  na <- sample(3:12, 1); nb <- sample(3:8, 1); nc <- sample(2:5, 1)
  reps <- sample(1:3, 1)
  if (type == "crossed2") {
    g <- expand.grid(a = seq_len(na), b = seq_len(nb), r = seq_len(reps)); g$c <- 1
  } else if (type == "nested") {
    g <- expand.grid(a = seq_len(na), c = seq_len(nc), r = seq_len(reps + 1)); g$b <- 1
  } else if (type == "crossed3") {
    g <- expand.grid(a = seq_len(min(na, 6)), b = seq_len(nb), c = seq_len(nc), r = 1)
  } else {
    g <- expand.grid(a = seq_len(na), b = seq_len(nb), c = seq_len(nc), r = 1)
  }
  # Unbalanced: up to 30% of the rows deleted at random.
  keep <- runif(nrow(g)) >= runif(1, 0, 0.3)
  g <- g[keep, ]
  n <- nrow(g)
  sa <- component(); sb <- component(); sc <- component(); se <- exp(rnorm(1, 0, 0.5))
  ea <- rnorm(max(g$a), 0, sqrt(sa)); eb <- rnorm(max(g$b), 0, sqrt(sb))
  ec <- rnorm(max(g$a) * max(g$c), 0, sqrt(sc))
  y <- 10 + ea[g$a] + eb[g$b] + rnorm(n, 0, sqrt(se))
  g$f <- "none"; g$x <- 0
  if (fixed %in% c("f_within", "fx")) {
    g$f <- sample(c("p", "q", "r"), n, replace = TRUE)
    y <- y + c(p = 0, q = 0.5, r = -1)[g$f]
  } else if (fixed == "f_between") {
    lev <- sample(c("p", "q"), max(g$a), replace = TRUE)
    g$f <- lev[g$a]
    y <- y + ifelse(g$f == "q", 1.5, 0)
  }
  if (fixed %in% c("x", "fx")) {
    g$x <- round(rnorm(n, 5, 2), 3)
    y <- y + 0.3 * g$x
  }
  rand <- switch(type,
    crossed2 = "(1|a) + (1|b)",
    nested = "(1|a) + (1|a:c)",
    crossed3 = "(1|a) + (1|b) + (1|c)",
    crossed_nested = "(1|a) + (1|b) + (1|a:c)")
  if (type %in% c("nested", "crossed_nested")) y <- y + ec[(g$a - 1) * max(g$c) + g$c]
  else if (type == "crossed3") y <- y + rnorm(max(g$c), 0, sqrt(sc))[g$c]
  fix <- switch(fixed, none = "1", f_within = "f", f_between = "f", x = "x", fx = "f + x + f:x")
  # A between-group effect needs both levels present.
  if (fixed == "f_between" && length(unique(g$f)) < 2) fix <- "1"
  if (fixed %in% c("f_within", "fx") && length(unique(g$f)) < 2) fix <- "1"
  list(id = sprintf("r%03d", i), formula = paste("y ~", fix, "+", rand),
       data = data.frame(a = g$a, b = g$b, c = g$c, f = g$f, x = g$x, y = round(y, 6)))
}

cake_design <- function() {
  d <- lme4::cake
  # f = recipe, x = temp, a = replicate.
  list(id = "cake", formula = "y ~ f:x + (1|a) + (1|f:a)",
       data = data.frame(a = as.integer(d$replicate), b = 1, c = 1, f = as.character(d$recipe),
                         x = d$temp, y = d$angle))
}

# Three crossed factors (a, b, c) plus c nested in a, and a fixed effect f
# that is constant within each level of a (between-group).
three_nested_design <- function() {
  g <- expand.grid(a = 1:10, b = 1:8, c = 1:4, r = 1:2)
  g <- g[runif(nrow(g)) > 0.15, ]
  lev <- rep(c("p", "q"), 5)
  g$f <- lev[g$a]
  ea <- rnorm(10, 0, 1.2); eb <- rnorm(8, 0, 0.7); ec <- rnorm(4, 0, 0.5); eac <- rnorm(40, 0, 0.9)
  y <- 5 + ifelse(g$f == "q", 0.8, 0) + ea[g$a] + eb[g$b] + ec[g$c] + eac[(g$a - 1) * 4 + g$c] +
    rnorm(nrow(g), 0, 1)
  list(id = "three_nested", formula = "y ~ f + (1|a) + (1|b) + (1|c) + (1|a:c)",
       data = data.frame(a = g$a, b = g$b, c = g$c, f = g$f, x = 0, y = round(y, 6)))
}

designs <- c(list(cake_design(), three_nested_design()), lapply(1:400, one_design))
rows <- list(); out <- list()
for (d in designs) {
  dat <- d$data
  best <- NA; singular <- NA; err <- ""; which <- ""
  for (nm in names(ctls)) {
    m <- tryCatch(suppressWarnings(lmer(as.formula(d$formula), data = transform(dat, a = factor(a), b = factor(b),
                                                                            c = factor(c), f = factor(f)),
                                        REML = TRUE, control = ctls[[nm]])),
                  error = function(e) conditionMessage(e))
    if (is.character(m)) { err <- gsub("[\n,]", " ", m); next }
    crit <- m@devcomp$cmp[["REML"]]
    if (is.na(best) || crit < best) { best <- crit; singular <- isSingular(m); which <- nm }
  }
  out[[length(out) + 1]] <- data.frame(id = d$id, formula = d$formula, n = nrow(dat),
                                       reml = if (is.na(best)) "" else format(best, digits = 16),
                                       optimizer = which, singular = singular,
                                       error = if (is.na(best)) err else "")
  rows[[length(rows) + 1]] <- data.frame(id = d$id, y = dat$y, a = dat$a, b = dat$b, c = dat$c,
                                         f = dat$f, x = dat$x)
}
con <- gzfile("tests/fixtures/mixed_stress/data.csv.gz", "w")
write.csv(do.call(rbind, rows), con, row.names = FALSE, quote = FALSE)
close(con)
res <- do.call(rbind, out)
write.csv(res, "tests/fixtures/mixed_stress/lme4.csv", row.names = FALSE, quote = TRUE)
cat("# lme4", as.character(packageVersion("lme4")), "R", R.version$major, R.version$minor, "\n")
cat("designs", nrow(res), "fitted", sum(res$reml != ""), "singular", sum(res$singular %in% TRUE), "\n")
