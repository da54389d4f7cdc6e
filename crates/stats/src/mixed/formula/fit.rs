//! A formula fitted to a file or table, and lme4's and lmerTest's
//! summary of it: what `crossaudit mixed` prints.

use super::number::Six;
use super::{build_model, parse, FormulaError, FormulaModel, Table};
use crate::mixed::slopes::SlopeFit;
use crate::mixed::{self, MixedError};

/// Which small-sample df the summary's t tests use (REML fits).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DfMethod {
    /// lmerTest's default.
    Satterthwaite,
    /// pbkrtest's, with its adjusted standard errors.
    KenwardRoger,
}

/// A model fitted from a formula and a table, with what lme4's and
/// lmerTest's summaries print.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FormulaFit {
    /// The formula as given.
    pub formula: String,
    /// The df method of the `fixed` table (`None` for ML fits, which lme4
    /// summarises with t values only).
    pub df_method: Option<DfMethod>,
    /// The fit.
    pub fit: Fitted,
    /// Per fixed effect: name, estimate, SE (Kenward-Roger's adjusted SE
    /// under that method), df, t and two-sided p.
    pub fixed: Vec<FixedRow>,
    /// Profile-likelihood intervals of the standard deviations, when asked.
    pub profile: Option<(f64, Vec<mixed::ProfileInterval>)>,
    /// logLik, AIC, BIC as lme4's `logLik()`, `AIC()` and `BIC()` give
    /// them (of the REML criterion for a REML fit).
    pub likelihood: Likelihood,
}

/// A fit of random intercepts or of random slopes.
#[derive(Debug, Clone, serde::Serialize)]
#[serde(untagged)]
#[non_exhaustive]
pub enum Fitted {
    /// Every random term `(1|g)`.
    Intercepts(mixed::MixedFit),
    /// Some random term with slopes (or intercepts whose crossed factors
    /// are too many for the intercept engine's dense reduced system).
    Slopes(SlopeFit),
}

impl Fitted {
    /// Whether the optimizer certified its point as the optimum.
    pub fn certified(&self) -> bool {
        match self {
            Fitted::Intercepts(f) => f.certificate.certified,
            Fitted::Slopes(f) => f.certificate.certified,
        }
    }

    /// What the reader must know about the fit (printed under its
    /// fixed effects).
    pub fn notes(&self) -> &[String] {
        match self {
            Fitted::Intercepts(f) => &f.notes,
            Fitted::Slopes(f) => &f.notes,
        }
    }

    /// The random-intercept fit, if it is one.
    pub fn intercepts(&self) -> Option<&mixed::MixedFit> {
        match self {
            Fitted::Intercepts(f) => Some(f),
            Fitted::Slopes(_) => None,
        }
    }

    /// The random-slope fit, if it is one.
    pub fn slopes(&self) -> Option<&SlopeFit> {
        match self {
            Fitted::Slopes(f) => Some(f),
            Fitted::Intercepts(_) => None,
        }
    }
}

/// lme4's likelihood summary of a fit: `logLik()` (with its `df`, the
/// number of parameters: fixed effects, one theta per random term and
/// sigma), `AIC()`, `BIC()`, the deviance (ML) or REML criterion (REML),
/// and `df.residual()`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Likelihood {
    /// Parameters: fixed-effect coefficients (after any dropped), random
    /// terms, and the residual SD.
    pub npar: usize,
    /// The (restricted, for REML) log-likelihood at the optimum.
    pub loglik: f64,
    /// -2 logLik + 2 npar.
    pub aic: f64,
    /// -2 logLik + log(n) npar.
    pub bic: f64,
    /// -2 logLik of an ML fit (`None` for REML).
    pub deviance: Option<f64>,
    /// -2 logLik of a REML fit, the REML criterion (`None` for ML).
    pub reml_criterion: Option<f64>,
    /// Observations less parameters.
    pub df_resid: i64,
}

impl Likelihood {
    /// The summary of `fit`.
    pub fn of(fit: &mixed::MixedFit) -> Likelihood {
        Likelihood::with(fit.fixed.len() + fit.theta.len() + 1, fit.deviance, fit.n, fit.criterion)
    }

    /// The summary of a random-slope fit.
    pub fn of_slopes(fit: &SlopeFit) -> Likelihood {
        Likelihood::with(fit.fixed.len() + fit.theta.len() + 1, fit.deviance, fit.n, fit.criterion)
    }

    /// The summary of a fit with `npar` parameters and `deviance` on `n`
    /// observations.
    fn with(npar: usize, deviance: f64, n: usize, criterion: mixed::Criterion) -> Likelihood {
        let reml = criterion == mixed::Criterion::Reml;
        Likelihood {
            npar,
            loglik: -0.5 * deviance,
            aic: deviance + 2.0 * npar as f64,
            bic: deviance + (n as f64).ln() * npar as f64,
            deviance: (!reml).then_some(deviance),
            reml_criterion: reml.then_some(deviance),
            df_resid: n as i64 - npar as i64,
        }
    }
}

/// A likelihood-ratio test of two nested models, as lme4's
/// `anova(m1, m2)`: both fitted by ML (`anova` refits REML fits by ML),
/// ordered by their number of parameters; the second row tests the larger
/// model against the smaller.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Comparison {
    /// The two models, fewer parameters first.
    pub models: Vec<ComparedModel>,
}

/// One row of [`Comparison`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct ComparedModel {
    /// The formula.
    pub formula: String,
    /// Parameters.
    pub npar: usize,
    /// AIC of the ML fit.
    pub aic: f64,
    /// BIC of the ML fit.
    pub bic: f64,
    /// ML log-likelihood.
    pub loglik: f64,
    /// ML deviance, -2 logLik.
    pub deviance: f64,
    /// 2 (logLik - the previous row's logLik), at least 0 (`None` in the
    /// first row).
    pub chisq: Option<f64>,
    /// Parameters more than the previous row (`None` in the first row).
    pub df: Option<i64>,
    /// P(chi-square on `df` > `chisq`) (`None` in the first row, or where
    /// `df` is 0).
    pub p: Option<f64>,
    /// Whether the optimizer certified the ML fit.
    pub certified: bool,
    /// The ML fit's notes.
    pub notes: Vec<String>,
}

/// Fits `formula` and `other` to `table` by ML and tests one against the
/// other, as lme4's `anova(m1, m2)` (see [`Comparison`]). The models must
/// be nested for the test to mean anything; as in lme4, that is the
/// user's to ensure, but both must model the same response.
pub fn compare_table(formula: &str, other: &str, table: &Table) -> Result<Comparison, FormulaError> {
    let (a, b) = (parse(formula)?, parse(other)?);
    if a.response != b.response {
        return Err(FormulaError::Compare(format!(
            "the two formulas model different responses (`{}` and `{}`); a likelihood-ratio test compares models of the same response",
            a.response, b.response
        )));
    }
    let mut rows = Vec::new();
    for text in [formula, other] {
        let fit = fit_table(text, table, mixed::Criterion::Ml, DfMethod::Satterthwaite, None)?;
        let l = fit.likelihood;
        rows.push(ComparedModel {
            formula: text.to_string(),
            npar: l.npar,
            aic: l.aic,
            bic: l.bic,
            loglik: l.loglik,
            deviance: -2.0 * l.loglik,
            chisq: None,
            df: None,
            p: None,
            certified: fit.fit.certified(),
            notes: fit.fit.notes().to_vec(),
        });
    }
    rows.sort_by_key(|r| r.npar);
    let (loglik0, npar0) = (rows[0].loglik, rows[0].npar as i64);
    let second = &mut rows[1];
    let chisq = (2.0 * (second.loglik - loglik0)).max(0.0);
    let df = second.npar as i64 - npar0;
    second.chisq = Some(chisq);
    second.df = Some(df);
    second.p = (df > 0).then(|| statrs::function::gamma::gamma_ur(df as f64 / 2.0, chisq / 2.0));
    Ok(Comparison { models: rows })
}

impl Comparison {
    /// The table as lme4's `anova()` prints it.
    pub fn summary(&self) -> String {
        use std::fmt::Write;
        let mut s = String::from("Models (refitted by maximum likelihood):\n");
        for (i, m) in self.models.iter().enumerate() {
            let _ = writeln!(s, "m{}: {}", i + 1, m.formula);
        }
        let _ = writeln!(
            s,
            "   {:>5} {:>10} {:>10} {:>10} {:>10} {:>9} {:>3} {:>11}",
            "npar", "AIC", "BIC", "logLik", "deviance", "Chisq", "Df", "Pr(>Chisq)"
        );
        for (i, m) in self.models.iter().enumerate() {
            let chisq = m.chisq.map_or("".into(), |c| format!("{c:.4}"));
            let df = m.df.map_or("".into(), |d| d.to_string());
            let p = m.p.map_or("".into(), r_pvalue);
            let _ = writeln!(
                s,
                "m{} {:>5} {:>10.4} {:>10.4} {:>10.4} {:>10.4} {:>9} {:>3} {:>11}",
                i + 1,
                m.npar,
                m.aic,
                m.bic,
                m.loglik,
                m.deviance,
                chisq,
                df,
                p
            );
        }
        for (i, m) in self.models.iter().enumerate() {
            for note in &m.notes {
                let _ = writeln!(s, "note (m{}): {note}", i + 1);
            }
            if !m.certified {
                let _ = writeln!(
                    s,
                    "warning: the optimizer could not certify the ML fit of m{}; do not use the test",
                    i + 1
                );
            }
        }
        s
    }
}

/// One row of the fixed-effects table.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FixedRow {
    /// R's column name.
    pub name: String,
    /// Estimate.
    pub estimate: f64,
    /// Standard error.
    pub se: f64,
    /// Denominator df (`None` for ML, or where the method is undefined).
    pub df: Option<f64>,
    /// t value.
    pub t: f64,
    /// Whether `df` is the stated fallback (the method's df could not be
    /// computed reliably; the fit's notes say why).
    pub df_fallback: bool,
    /// Two-sided p from t on `df`.
    pub p: Option<f64>,
}

/// Fits `formula` to `table` by `criterion`, with the fixed-effect table
/// on `df` and, with `profile`, profile intervals at that level.
pub fn fit_table(
    formula_text: &str,
    table: &Table,
    criterion: mixed::Criterion,
    df: DfMethod,
    profile: Option<f64>,
) -> Result<FormulaFit, FormulaError> {
    fit_table_weighted(formula_text, table, criterion, df, profile, None)
}

/// [`fit_table`] with lmer's prior `weights` (a column: observation i's
/// residual variance is sigma^2 / w_i), fitted by the sparse engine over
/// every level (random intercepts too) with Satterthwaite df; profile
/// intervals and Kenward-Roger df are refused with weights.
pub fn fit_table_weighted(
    formula_text: &str,
    table: &Table,
    criterion: mixed::Criterion,
    df: DfMethod,
    profile: Option<f64>,
    weights: Option<&str>,
) -> Result<FormulaFit, FormulaError> {
    let formula = parse(formula_text)?;
    let note = formula.merged_note();
    fit_parsed(formula_text, &formula, table, (criterion, df, profile), weights).map(|f| f.noted(note))
}

/// [`fit_table_weighted`] of the formula `formula_text` parsed.
fn fit_parsed(
    formula_text: &str,
    formula: &super::Formula,
    table: &Table,
    (criterion, df, profile): (mixed::Criterion, DfMethod, Option<f64>),
    weights: Option<&str>,
) -> Result<FormulaFit, FormulaError> {
    if let Some(w) = weights {
        return weighted_table(formula_text, formula, table, (criterion, df, profile), w);
    }
    if formula.failures.is_some() || formula.trials.is_some() {
        return Err(FormulaError::Unsupported(
            "cbind(successes, failures) is the response of a binomial model: add --family binomial".into(),
        ));
    }
    if formula.divisor.is_some() {
        return Err(super::divided_response(formula));
    }
    if let Some(level) = profile {
        if level.is_nan() || level <= 0.0 || level >= 1.0 {
            return Err(MixedError::Level(level).into());
        }
    }
    // Kenward-Roger (and the shares) need the q x q matrices over every
    // level; Satterthwaite needs only deviance evaluations.
    let inference = match (criterion, df) {
        (mixed::Criterion::Reml, DfMethod::KenwardRoger) => mixed::Inference::Full,
        (mixed::Criterion::Reml, DfMethod::Satterthwaite) => mixed::Inference::Satterthwaite,
        (mixed::Criterion::Ml, _) => mixed::Inference::Estimates,
    };
    let data = match build_model(formula, table)? {
        // Crossed factors too many for the dense reduced system (every
        // factor's levels but the largest's): the same model by the sparse
        // factor of the slope engine, as lme4 fits every model. Its
        // profile intervals and Kenward-Roger df stay the intercept
        // engine's, which refuses them by size.
        FormulaModel::Intercepts(data)
            if !data.dense_fits() && profile.is_none() && inference != mixed::Inference::Full =>
        {
            return sparse_intercepts(formula_text, formula, table, criterion, df);
        }
        FormulaModel::Intercepts(data) => data,
        FormulaModel::Slopes(data) => return slopes_table(formula_text, &data, criterion, df, profile),
    };
    let fit = mixed::fit_with(&data, criterion, inference)?;
    let reml = criterion == mixed::Criterion::Reml;
    let fixed = fixed_rows(&fit, reml, df);
    let profile = match profile {
        Some(level) => Some((level, mixed::profile_intervals(&data, criterion, level)?)),
        None => None,
    };
    let likelihood = Likelihood::of(&fit);
    Ok(FormulaFit {
        formula: formula_text.to_string(),
        df_method: reml.then_some(df),
        fit: Fitted::Intercepts(fit),
        fixed,
        profile,
        likelihood,
    })
}

/// The fixed-effect table of an intercept-engine fit: Satterthwaite or
/// Kenward-Roger SE and df for a REML fit, none for ML.
fn fixed_rows(fit: &mixed::MixedFit, reml: bool, df: DfMethod) -> Vec<FixedRow> {
    fit.fixed
        .iter()
        .map(|f| {
            let (se, dof) = match (reml, df) {
                (false, _) => (f.se, None),
                (true, DfMethod::Satterthwaite) => (f.se, f.df_satterthwaite),
                (true, DfMethod::KenwardRoger) => match f.kenward_roger {
                    Some(kr) => (kr.se, Some(kr.df)),
                    None => (f.se, None),
                },
            };
            let df_fallback = match (reml, df) {
                (false, _) => false,
                (true, DfMethod::Satterthwaite) => f.satterthwaite_fallback,
                (true, DfMethod::KenwardRoger) => f.kenward_roger.is_some_and(|kr| kr.fallback),
            };
            FixedRow::new(&f.name, f.estimate, se, dof, df_fallback)
        })
        .collect()
}

/// [`fit_table_weighted`] with its weights' column `w`.
fn weighted_table(
    formula_text: &str,
    formula: &super::Formula,
    table: &Table,
    (criterion, df, profile): (mixed::Criterion, DfMethod, Option<f64>),
    w: &str,
) -> Result<FormulaFit, FormulaError> {
    if profile.is_some() || df == DfMethod::KenwardRoger {
        return Err(FormulaError::Unsupported(format!(
            "--weights {w} with {}: a weighted linear mixed model is fitted with Satterthwaite df and no profile intervals",
            if profile.is_some() { "--profile" } else { "--df kenward-roger" }
        )));
    }
    if formula.failures.is_some() || formula.trials.is_some() || formula.divisor.is_some() {
        return Err(FormulaError::Unsupported(
            "cbind( ) or a / b with --weights is a binomial model's response: add --family binomial".into(),
        ));
    }
    let data = super::table::build_sparse(formula, table)?;
    super::table::present(table, w)?;
    let col = table.column(w)?;
    let values = super::table::numbers(table, w)?.unwrap_or_default();
    if let Some(row) = (0..col.len()).find(|&i| values.get(i).is_none_or(|v| !(v.is_finite() && *v > 0.0))) {
        return Err(FormulaError::Value {
            row: row + 1,
            field: w.to_string(),
            message: format!(
                "`{}` is not a weight above 0 (a weight of 0 drops its row: remove the row instead)",
                col[row].trim()
            ),
        });
    }
    slopes_table(formula_text, &data.with_weights(values)?, criterion, df, None)
}

/// [`fit_table`] of a random-intercept model whose crossed factors are too
/// many for the intercept engine's dense reduced system: the same model
/// by the slope engine's sparse factor, with a note that says so.
fn sparse_intercepts(
    formula_text: &str,
    formula: &super::Formula,
    table: &Table,
    criterion: mixed::Criterion,
    df: DfMethod,
) -> Result<FormulaFit, FormulaError> {
    let sparse = super::table::build_sparse(formula, table)?;
    let mut fit = slopes_table(formula_text, &sparse, criterion, df, None)?;
    if let Fitted::Slopes(f) = &mut fit.fit {
        f.notes.push(format!(
            "the random factors but the largest have more than {} levels, over the dense reduced system's limit, so the model is fitted with the sparse Cholesky factor over every level (the same model and criterion, as lme4 fits it)",
            mixed::MAX_DENSE
        ));
    }
    Ok(fit)
}

/// [`fit_table`] of a model with random slopes (Satterthwaite df).
fn slopes_table(
    formula: &str,
    data: &crate::mixed::slopes::SlopeData,
    criterion: mixed::Criterion,
    df: DfMethod,
    profile: Option<f64>,
) -> Result<FormulaFit, FormulaError> {
    let fit = super::slopes_fit::fit_checked(data, criterion, df == DfMethod::KenwardRoger, profile)?;
    let row = |f: &crate::mixed::slopes::SlopeFixed| match f.kenward_roger {
        Some(kr) => FixedRow::new(&f.name, f.estimate, kr.se, Some(kr.df), false),
        None => FixedRow::new(&f.name, f.estimate, f.se, f.df_satterthwaite, false),
    };
    let fixed = fit.fixed.iter().map(row).collect();
    let reml = criterion == mixed::Criterion::Reml;
    let likelihood = Likelihood::of_slopes(&fit);
    Ok(FormulaFit {
        formula: formula.to_string(),
        df_method: reml.then_some(df),
        fit: Fitted::Slopes(fit),
        fixed,
        profile: None,
        likelihood,
    })
}

impl FixedRow {
    /// The row of a coefficient: t = estimate / se, and the two-sided p
    /// on `df` where there is one.
    fn new(name: &str, estimate: f64, se: f64, df: Option<f64>, df_fallback: bool) -> FixedRow {
        let t = estimate / se;
        let p = df.filter(|d| *d > 0.0).map(|d| crate::t_two_sided_p(t, d)).filter(|p| !p.is_nan());
        FixedRow { name: name.to_string(), estimate, se, df, df_fallback, t, p }
    }
}

impl FormulaFit {
    /// The fit with `note` added to its notes.
    fn noted(mut self, note: Option<String>) -> FormulaFit {
        match &mut self.fit {
            Fitted::Intercepts(f) => f.notes.extend(note),
            Fitted::Slopes(f) => f.notes.extend(note),
        }
        self
    }

    /// The summary's first lines: the method, the formula and the
    /// likelihood table.
    fn header(&self, criterion: mixed::Criterion, deviance: f64) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let (what, crit) = match criterion {
            mixed::Criterion::Reml => ("REML", "REML criterion at convergence"),
            mixed::Criterion::Ml => ("maximum likelihood", ""),
        };
        let df = match self.df_method {
            Some(DfMethod::Satterthwaite) => ". t-tests use Satterthwaite's method",
            Some(DfMethod::KenwardRoger) => ". t-tests use the Kenward-Roger method",
            None => "",
        };
        let _ = writeln!(s, "Linear mixed model fit by {what}{df}");
        let _ = writeln!(s, "Formula: {}\n", self.formula);
        let l = &self.likelihood;
        match criterion {
            mixed::Criterion::Reml => {
                let _ = writeln!(s, "{crit}: {deviance:.4}");
                let _ = writeln!(s, "{:>10} {:>10} {:>10} {:>8}", "AIC", "BIC", "logLik", "df.resid");
                let _ = writeln!(s, "{:>10.4} {:>10.4} {:>10.4} {:>8}\n", l.aic, l.bic, l.loglik, l.df_resid);
            }
            mixed::Criterion::Ml => {
                let _ =
                    writeln!(s, "{:>10} {:>10} {:>10} {:>10} {:>8}", "AIC", "BIC", "logLik", "deviance", "df.resid");
                let _ = writeln!(
                    s,
                    "{:>10.4} {:>10.4} {:>10.4} {:>10.4} {:>8}\n",
                    l.aic, l.bic, l.loglik, deviance, l.df_resid
                );
            }
        }
        s
    }

    /// The fixed-effects table, as lmerTest (REML) or lme4 (ML) prints it.
    fn fixed_table(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = writeln!(s, "Fixed effects:");
        let width = self.fixed.iter().map(|r| r.name.len()).max().unwrap_or(0).max(11);
        let with_df = self.df_method.is_some();
        if with_df {
            let _ = writeln!(
                s,
                "{:<width$} {:>12} {:>12} {:>10} {:>9} {:>10}",
                "", "Estimate", "Std. Error", "df", "t value", "Pr(>|t|)"
            );
        } else {
            let _ = writeln!(s, "{:<width$} {:>12} {:>12} {:>9}", "", "Estimate", "Std. Error", "t value");
        }
        for r in &self.fixed {
            if with_df {
                let dof = r.df.map(|d| format!("{d:.3}")).unwrap_or_else(|| "NA".into());
                let p = r.p.map(r_pvalue).unwrap_or_else(|| "NA".into());
                let _ = writeln!(
                    s,
                    "{:<width$} {:>12} {:>12} {:>10} {:>9.3} {:>10}",
                    r.name,
                    Six(r.estimate),
                    Six(r.se),
                    dof,
                    r.t,
                    p
                );
            } else {
                let _ = writeln!(s, "{:<width$} {:>12} {:>12} {:>9.3}", r.name, Six(r.estimate), Six(r.se), r.t);
            }
        }
        s
    }
    /// The summary as lme4 and lmerTest print it, with the optimizer's
    /// certificate and any warning on their own lines.
    pub fn summary(&self) -> String {
        use std::fmt::Write;
        let f = match &self.fit {
            Fitted::Intercepts(f) => f,
            Fitted::Slopes(f) => {
                let mut s = self.header(f.criterion, f.deviance);
                s.push_str(&super::slopes_fit::random_effects(f));
                s.push_str(&self.fixed_table());
                for note in &f.notes {
                    let _ = writeln!(s, "note: {note}");
                }
                s.push_str(&super::slopes_fit::optimizer_lines(f));
                return s;
            }
        };
        let mut s = self.header(f.criterion, f.deviance);
        let _ = writeln!(s, "Random effects:");
        let width = f.factors.iter().map(|n| n.len()).max().unwrap_or(0).max(8);
        let _ = writeln!(s, " {:<width$} {:<11} {:>12} {:>12}", "Groups", "Name", "Variance", "Std.Dev.");
        for (name, v) in f.factors.iter().zip(&f.variances) {
            let _ = writeln!(s, " {:<width$} {:<11} {:>12} {:>12}", name, "(Intercept)", Six(*v), Six(v.sqrt()));
        }
        let _ =
            writeln!(s, " {:<width$} {:<11} {:>12} {:>12}", "Residual", "", Six(f.residual), Six(f.residual.sqrt()));
        let groups: Vec<String> = f.factors.iter().zip(&f.levels).map(|(n, l)| format!("{n}, {l}")).collect();
        let _ = writeln!(s, "Number of obs: {}, groups:  {}\n", f.n, groups.join("; "));
        s.push_str(&self.fixed_table());
        for note in &f.notes {
            let _ = writeln!(s, "note: {note}");
        }
        if let Some((level, intervals)) = &self.profile {
            let _ = writeln!(s, "\nProfile-likelihood intervals of the standard deviations ({:.1}%):", 100.0 * level);
            for i in intervals {
                let _ = writeln!(s, " {:<20} {:>12.6} [{:.6}, {:.6}]", i.name, i.estimate, i.lower, i.upper);
            }
        }
        let c = &f.certificate;
        let boundary: Vec<String> =
            f.factors.iter().zip(&c.boundary).filter_map(|(n, d)| d.map(|d| format!("{n} {d:.3e}"))).collect();
        let _ = writeln!(
            s,
            "\noptimizer: {} ({} deviance evaluations, {} restarts); max |gradient| {:.2e}, predicted decrease {:.2e}{}",
            if c.certified { "optimum certified" } else { "NOT CERTIFIED" },
            f.evaluations,
            c.restarts,
            c.gradient,
            c.predicted_decrease,
            if boundary.is_empty() {
                String::new()
            } else {
                format!("; boundary d(criterion)/d(theta^2): {}", boundary.join(", "))
            }
        );
        if !c.certified {
            let _ = writeln!(s, "warning: the optimizer could not certify this point as the optimum; do not use it");
        }
        if f.singular {
            let _ = writeln!(
                s,
                "boundary (singular) fit: a variance is estimated at (or within 1e-4 of) zero, as lme4's isSingular says"
            );
            if self.df_method.is_some() {
                let _ = writeln!(s, "note: at a singular fit Satterthwaite holds the zero component fixed while Kenward-Roger keeps it (a generalized inverse), so their df differ");
            }
        }
        s
    }
}

/// A formula fit that failed, with the data file it was on.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {error}")]
pub struct FileError {
    /// The data file.
    pub file: String,
    /// What went wrong.
    pub error: FormulaError,
}

/// A p-value as R's `printCoefmat` prints it (`format.pval` with 3
/// significant digits): fixed notation unless scientific is shorter,
/// trailing zeros dropped, and `<2e-16` below machine epsilon.
pub fn r_pvalue(p: f64) -> String {
    if p.is_nan() {
        return "NA".to_string();
    }
    if p < f64::EPSILON {
        return "<2e-16".to_string();
    }
    let trim = |t: String| -> String {
        if t.contains('.') {
            t.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            t
        }
    };
    // Fixed: enough decimals for 3 significant digits.
    let magnitude = p.abs().log10().floor() as i32;
    let decimals = (2 - magnitude).max(0) as usize;
    let fixed = trim(format!("{p:.decimals$}"));
    let sci = {
        let t = format!("{p:.2e}");
        let (mantissa, exp) = t.split_once('e').unwrap_or((&t, "0"));
        let exp: i32 = exp.parse().unwrap_or(0);
        format!("{}e{}{:02}", trim(mantissa.to_string()), if exp < 0 { '-' } else { '+' }, exp.abs())
    };
    if fixed.len() <= sci.len() {
        fixed
    } else {
        sci
    }
}

#[cfg(test)]
mod tests {
    use super::r_pvalue;

    /// What R 4.x prints for these p-values: `format.pval(p, digits = 3)`,
    /// as printCoefmat formats lmerTest's summary, run on this machine:
    /// `Rscript -e 'for (p in c(0.15938, 0.5, 1, 0.00123, 1.234e-5,
    /// 3.2e-12, 1e-20)) cat(format.pval(p, digits = 3), "\n")'`.
    #[test]
    fn p_values_print_as_r_prints_them() {
        assert_eq!(r_pvalue(0.15938), "0.159");
        assert_eq!(r_pvalue(0.5), "0.5");
        assert_eq!(r_pvalue(1.0), "1");
        assert_eq!(r_pvalue(0.00123), "0.00123");
        assert_eq!(r_pvalue(1.234e-5), "1.23e-05");
        assert_eq!(r_pvalue(3.2e-12), "3.2e-12");
        assert_eq!(r_pvalue(1e-20), "<2e-16");
    }
}
