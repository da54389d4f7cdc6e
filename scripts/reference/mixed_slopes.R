# Reference fits for crossaudit's random-slope models (stats::mixed::slopes),
# from lme4 and lmerTest, on data sets of R's own packages and on simulated
# crossed designs. Run from the repository root:
#
#   Rscript scripts/reference/mixed_slopes.R > scripts/reference/mixed_slopes.out
#
# R, lme4 and lmerTest from Debian: apt-get install r-base-core r-cran-lme4
# r-cran-lmertest (nlme and datasets come with R). Writes
# tests/fixtures/slopes_*.csv (the columns each model uses) and prints, for
# each fit, lines `<fit> <what> <values...>`:
#   formula, criterion (REML criterion or ML deviance), theta, vc (grp var1
#   var2 vcov sdcor, as as.data.frame(VarCorr) gives them; var2 NA for a
#   variance), fixef (name estimate se), df (name Satterthwaite df, REML
#   fits, lmerTest), kr (name, Kenward-Roger SE and df, REML fits of at
#   most 1,000 observations: pbkrtest's vcovAdj and Lb_ddf), singular.
# BOBYQA is run to a tight tolerance so that the optimum, not the optimizer,
# is compared.
suppressMessages({
  library(lme4)
  library(lmerTest)
  library(nlme)
  library(pbkrtest)
})
ctl <- lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12, maxfun = 1e6),
                   check.conv.singular = "ignore", check.conv.grad = "ignore",
                   check.conv.hess = "ignore")
cat("# lme4", as.character(packageVersion("lme4")), "lmerTest", as.character(packageVersion("lmerTest")),
    "pbkrtest", as.character(packageVersion("pbkrtest")),
    "R", R.version$major, R.version$minor, "\n")
fmt <- function(x) format(x, digits = 17)
show_fit <- function(name, formula, data, reml = TRUE, weights = NULL) {
  w <- if (is.null(weights)) NULL else data[[weights]]
  # do.call passes the weights' values (lmer looks a name up in data).
  m <- do.call(lmerTest::lmer, list(formula, data = data, REML = reml, control = ctl, weights = w))
  cat(name, "formula", deparse(formula, width.cutoff = 500L), "\n")
  cat(name, "reml", reml, "\n")
  if (!is.null(weights)) cat(name, "weights", weights, "\n")
  crit <- if (reml) m@devcomp$cmp[["REML"]] else deviance(m)
  cat(name, "criterion", fmt(crit), "\n")
  cat(name, "theta", fmt(getME(m, "theta")), "\n")
  vc <- as.data.frame(VarCorr(m))
  for (i in seq_len(nrow(vc))) {
    cat(name, "vc", vc$grp[i], vc$var1[i], vc$var2[i], fmt(vc$vcov[i]), fmt(vc$sdcor[i]), "\n")
  }
  co <- summary(m)$coefficients
  for (i in seq_len(nrow(co))) {
    cat(name, "fixef", rownames(co)[i], fmt(co[i, "Estimate"]), fmt(co[i, "Std. Error"]), "\n")
    if (reml) cat(name, "df", rownames(co)[i], fmt(co[i, "df"]), "\n")
  }
  if (reml && nrow(data) <= 1000 && is.null(weights)) {
    V <- vcovAdj(m)
    for (i in seq_len(nrow(co))) {
      L <- matrix(0, nrow = 1, ncol = nrow(co)); L[1, i] <- 1
      cat(name, "kr", rownames(co)[i], fmt(sqrt(as.matrix(V)[i, i])), fmt(Lb_ddf(L, as.matrix(vcov(m)), V)), "\n")
    }
  }
  cat(name, "singular", isSingular(m), "\n")
}
write_fixture <- function(d, file) {
  write.csv(d, file.path("tests/fixtures", file), row.names = FALSE, quote = FALSE)
}

# 1. lme4's sleepstudy: reaction times over 10 days of sleep deprivation.
sleep <- data.frame(Reaction = sleepstudy$Reaction, Days = sleepstudy$Days, Subject = sleepstudy$Subject,
                    w = 1 + sleepstudy$Days %% 3)
write_fixture(sleep, "slopes_sleepstudy.csv")
show_fit("sleepstudy_reml", Reaction ~ Days + (Days | Subject), sleep)
show_fit("sleepstudy_ml", Reaction ~ Days + (Days | Subject), sleep, reml = FALSE)
show_fit("sleepstudy_uncorrelated", Reaction ~ Days + (Days || Subject), sleep)
show_fit("sleepstudy_slope_only", Reaction ~ Days + (0 + Days | Subject), sleep)
# An offset (issue 75): a term with its coefficient fixed at 1.
show_fit("sleepstudy_offset", Reaction ~ Days + offset(Days) + (Days | Subject), sleep)
# Prior weights (issue 75): residual variance sigma^2 / w.
show_fit("sleepstudy_weights", Reaction ~ Days + (Days | Subject), sleep, weights = "w")
show_fit("sleepstudy_weightsml", Reaction ~ Days + (Days | Subject), sleep, reml = FALSE, weights = "w")

# 2. nlme's Orthodont: growth of 27 children, with a fixed effect of sex.
orth <- data.frame(distance = Orthodont$distance, age = Orthodont$age,
                   Subject = as.character(Orthodont$Subject), Sex = as.character(Orthodont$Sex))
write_fixture(orth, "slopes_orthodont.csv")
show_fit("orthodont_reml", distance ~ age + Sex + (age | Subject), orth)
show_fit("orthodont_ml", distance ~ age * Sex + (1 + age | Subject), orth, reml = FALSE)

# 3. nlme's Machines: a factor's slopes, three machines per worker (3 x 3
# covariance), and without the intercept (every machine's own column).
mach <- data.frame(score = Machines$score, Machine = as.character(Machines$Machine),
                   Worker = as.character(Machines$Worker))
write_fixture(mach, "slopes_machines.csv")
show_fit("machines_reml", score ~ Machine + (Machine | Worker), mach)
show_fit("machines_no_intercept", score ~ Machine + (0 + Machine | Worker), mach)

# 4. datasets' ChickWeight: growth of 50 chicks.
chick <- data.frame(weight = ChickWeight$weight, Time = ChickWeight$Time, Chick = as.character(ChickWeight$Chick))
write_fixture(chick, "slopes_chickweight.csv")
show_fit("chickweight_reml", weight ~ Time + (Time | Chick), chick)

# 5. nlme's Oxboys: heights of 26 boys.
ox <- data.frame(height = Oxboys$height, age = Oxboys$age, Subject = as.character(Oxboys$Subject))
write_fixture(ox, "slopes_oxboys.csv")
show_fit("oxboys_reml", height ~ age + (age | Subject), ox)

# 6. nlme's MathAchieve: 7,185 students in 160 schools.
math <- data.frame(MathAch = MathAchieve$MathAch, SES = MathAchieve$SES, School = as.character(MathAchieve$School))
write_fixture(math, "slopes_mathachieve.csv")
show_fit("mathachieve_reml", MathAch ~ SES + (SES | School), math)

# 7. lme4's cake: a slope in temperature per recipe and replicate (an
# interaction grouping factor).
cake_d <- data.frame(angle = cake$angle, temp = cake$temp, recipe = as.character(cake$recipe),
                     replicate = as.character(cake$replicate))
write_fixture(cake_d, "slopes_cake.csv")
show_fit("cake_reml", angle ~ recipe + temp + (temp | recipe:replicate), cake_d)

# 8. nlme's Oats: nitrogen slopes per block and per variety within block
# (nested, lme4's (x | a/b) = (x | a) + (x | b:a)).
oats <- data.frame(yield = Oats$yield, nitro = Oats$nitro, Block = as.character(Oats$Block),
                   Variety = as.character(Oats$Variety))
write_fixture(oats, "slopes_oats.csv")
show_fit("oats_nested", yield ~ nitro + (nitro | Block/Variety), oats)

# 9. nlme's Pixel: pixel intensity over days per dog, uncorrelated.
pix <- data.frame(pixel = Pixel$pixel, day = Pixel$day, Dog = as.character(Pixel$Dog), Side = as.character(Pixel$Side))
write_fixture(pix, "slopes_pixel.csv")
show_fit("pixel_uncorrelated", pixel ~ day + (day || Dog) + (1 | Side:Dog), pix)

# 10. Simulated: crossed slopes, 24 recordings x 10 seeds, two arms (x = 0,
# 1) per cell, with recording and seed slopes, correlated.
set.seed(20261129)
I <- 24; J <- 10
d <- expand.grid(arm = 0:1, seed = 1:J, recording = 1:I)
ua <- MASS::mvrnorm(I, c(0, 0), matrix(c(1, 0.3, 0.3, 0.5), 2))
ub <- MASS::mvrnorm(J, c(0, 0), matrix(c(0.4, -0.1, -0.1, 0.2), 2))
d$y <- 2 + 0.5 * d$arm + ua[d$recording, 1] + ua[d$recording, 2] * d$arm +
  ub[d$seed, 1] + ub[d$seed, 2] * d$arm + rnorm(nrow(d), sd = 0.6)
sim <- data.frame(y = round(d$y, 6), arm = d$arm, recording = paste0("r", d$recording), seed = paste0("s", d$seed))
write_fixture(sim, "slopes_crossed.csv")
show_fit("crossed_reml", y ~ arm + (arm | recording) + (arm | seed), sim)
show_fit("crossed_ml", y ~ arm + (arm | recording) + (arm | seed), sim, reml = FALSE)

# 11. Simulated: no slope variance at all (a singular fit, correlation
# at the boundary or a zero variance).
set.seed(7)
g <- rep(1:15, each = 8); x <- rep(seq(-1, 1, length.out = 8), 15)
y <- 1 + 0.3 * x + rnorm(15)[g] + rnorm(120, sd = 0.5)
sing <- data.frame(y = round(y, 6), x = round(x, 6), g = paste0("g", g))
write_fixture(sing, "slopes_singular.csv")
show_fit("singular_reml", y ~ x + (x | g), sing)
