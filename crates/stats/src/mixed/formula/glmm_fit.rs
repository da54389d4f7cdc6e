//! A generalized formula (`family binomial` or `poisson`) fitted to a
//! table, and its summary as lme4's `glmer` prints it.

use std::fmt::Write;

use super::fit::r_pvalue;
use super::table::{group_codes, numbers, present, random_terms, term_columns};
use super::{parse, Formula, FormulaError, Table};
use crate::mixed::glmm::{fit_glmm, profile_fixed, Family, FixedProfile, GlmmData, GlmmFit};

/// Six decimals, or four significant digits in scientific notation for a
/// number below 1e-3 that six decimals would print as zero.
fn six(v: f64) -> String {
    if v != 0.0 && v.abs() < 1e-3 {
        format!("{v:.4e}")
    } else {
        format!("{v:.6}")
    }
}

/// A GLMM fitted from a formula and a table.
#[derive(Debug, Clone, serde::Serialize)]
pub struct GlmmFormulaFit {
    /// The formula as given.
    pub formula: String,
    /// The fit.
    pub fit: GlmmFit,
    /// Profile-likelihood intervals of the fixed effects, when asked: the
    /// level and one interval per fixed effect.
    pub profile: Option<(f64, Vec<FixedProfile>)>,
}

/// The data `formula` describes on `table` for `family`: the response
/// `cbind(successes, failures)` or a 0/1 column (binomial), or a count
/// column (Poisson); the fixed and random terms as for a linear model.
pub fn build_glmm(formula_text: &str, table: &Table, family: Family) -> Result<GlmmData, FormulaError> {
    build_glmm_with(formula_text, table, family, &GlmmOptions::default())
}

/// What glmer takes beside the formula and the data.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GlmmOptions {
    /// Prior weights (a column): the trials of a binomial response of
    /// proportions.
    pub weights: Option<String>,
    /// Quadrature nodes per level (glmer's `nAGQ`); 0 or 1: the Laplace
    /// approximation.
    pub nagq: usize,
}

/// [`build_glmm`] with glmer's prior `weights` (for a binomial model, the
/// column of trials behind a response of proportions: successes =
/// proportion x weight, a whole number; refused for a Poisson model, whose
/// exposure is an offset, `offset(log(t))`) and `nagq`.
pub fn build_glmm_with(
    formula_text: &str,
    table: &Table,
    family: Family,
    options: &GlmmOptions,
) -> Result<GlmmData, FormulaError> {
    build_glmm_parsed(&parse(formula_text)?, table, family, options)
}

/// [`build_glmm_with`] of a parsed formula.
fn build_glmm_parsed(
    formula: &super::Formula,
    table: &Table,
    family: Family,
    options: &GlmmOptions,
) -> Result<GlmmData, FormulaError> {
    let (k, trials) = match options.weights.as_deref() {
        Some(w) => weighted(family, formula, table, w)?,
        None if formula.divisor.is_some() => return Err(super::divided_response(formula)),
        None => {
            let k = whole_counts(table, &formula.response)?;
            let trials = trials(family, formula, table, &k)?;
            (k, trials)
        }
    };
    let n = k.len();
    let mut factors: Vec<(String, Vec<usize>)> = Vec::new();
    for term in &formula.random {
        if !factors.iter().any(|(name, _)| *name == term.name) {
            factors.push((term.name.clone(), group_codes(table, &term.columns, n)?));
        }
    }
    let columns = term_columns(&formula.fixed, true, table, n)?;
    let terms = random_terms(formula, table, &factors, n)?;
    let offset = super::table::offset_values(formula, table)?;
    let data = match family {
        Family::Binomial => GlmmData::binomial(k, trials, columns, terms)?,
        Family::Poisson => GlmmData::poisson(k, columns, terms)?,
    };
    let data = match offset {
        Some(o) => data.with_offset(o)?,
        None => data,
    };
    Ok(data.with_nagq(options.nagq.max(1))?)
}

/// Fits `formula` to `table` as a GLMM of `family` (maximum likelihood,
/// Laplace approximation), with `profile`, the profile-likelihood
/// intervals of the scalar random effects' standard deviations and of the
/// fixed effects at that level.
pub fn fit_glmm_table(
    formula: &str,
    table: &Table,
    family: Family,
    profile: Option<f64>,
) -> Result<GlmmFormulaFit, FormulaError> {
    fit_glmm_with(formula, table, family, profile, &GlmmOptions::default())
}

/// [`fit_glmm_table`] with glmer's prior weights and nAGQ (see
/// [`build_glmm_with`]).
pub fn fit_glmm_with(
    formula: &str,
    table: &Table,
    family: Family,
    profile: Option<f64>,
    options: &GlmmOptions,
) -> Result<GlmmFormulaFit, FormulaError> {
    if let Some(level) = profile {
        if !(level > 0.0 && level < 1.0) {
            return Err(crate::mixed::MixedError::Level(level).into());
        }
    }
    let parsed = parse(formula)?;
    let data = build_glmm_parsed(&parsed, table, family, options)?;
    let mut fit = fit_glmm(&data)?;
    fit.notes.extend(parsed.merged_note());
    let profile = match profile {
        Some(level) => Some((level, profile_fixed(&data, &fit, level)?)),
        None => None,
    };
    Ok(GlmmFormulaFit { formula: formula.to_string(), fit, profile })
}

impl GlmmFormulaFit {
    /// The summary as lme4's `glmer` prints it, with the optimizer's
    /// certificate.
    pub fn summary(&self) -> String {
        let f = &self.fit;
        let mut s = String::new();
        if self.fit.nagq > 1 {
            let _ = writeln!(
                s,
                "Generalized linear mixed model fit by maximum likelihood (Adaptive Gauss-Hermite Quadrature, nAGQ = {})",
                self.fit.nagq
            );
        } else {
            let _ = writeln!(s, "Generalized linear mixed model fit by maximum likelihood (Laplace Approximation)");
        }
        let _ = writeln!(s, " Family: {}", f.family.label());
        let _ = writeln!(s, "Formula: {}\n", self.formula);
        let _ = writeln!(s, "{:>10} {:>10} {:>10} {:>10} {:>8}", "AIC", "BIC", "logLik", "deviance", "df.resid");
        let _ = writeln!(
            s,
            "{:>10.4} {:>10.4} {:>10.4} {:>10.4} {:>8}\n",
            f.aic,
            f.bic,
            f.loglik,
            f.deviance,
            f.n as i64 - f.npar as i64
        );
        s.push_str(&super::slopes_fit::terms_table(&f.terms, None, f.n));
        let _ = writeln!(s, "Fixed effects:");
        let width = f.fixed.iter().map(|r| r.name.len()).max().unwrap_or(0).max(11);
        let _ =
            writeln!(s, "{:<width$} {:>12} {:>12} {:>9} {:>10}", "", "Estimate", "Std. Error", "z value", "Pr(>|z|)");
        for r in &f.fixed {
            let _ = writeln!(
                s,
                "{:<width$} {:>12} {:>12} {:>9.3} {:>10}",
                r.name,
                six(r.estimate),
                six(r.se),
                r.z,
                r_pvalue(r.p)
            );
        }
        for note in &f.notes {
            let _ = writeln!(s, "note: {note}");
        }
        if let Some((level, intervals)) = &self.profile {
            let _ = writeln!(
                s,
                "\nProfile-likelihood intervals of the random effects' standard deviations and the fixed effects ({:.1}%):",
                100.0 * level
            );
            for i in &intervals[..] {
                let _ = writeln!(s, " {:<width$} [{}, {}]", i.name, six(i.lower), six(i.upper));
            }
        }
        if !f.dropped.is_empty() {
            let _ = writeln!(s, "note: fixed-effect columns dropped as aliased: {}", f.dropped.join(", "));
        }
        let c = &f.certificate;
        let _ = writeln!(
            s,
            "\noptimizer: {} ({} evaluations of the Laplace deviance, {} restarts); max |gradient| {:.2e}, predicted decrease {:.2e}",
            if c.certified { "optimum certified" } else { "NOT CERTIFIED" },
            f.evaluations,
            c.restarts,
            c.gradient,
            c.predicted_decrease
        );
        if !c.certified {
            let _ = writeln!(s, "warning: the optimizer could not certify this point as the optimum; do not use it");
        }
        if f.singular {
            let _ = writeln!(s, "boundary (singular) fit: a diagonal entry of theta is estimated at (or within 1e-4 of) zero, as lme4's isSingular says");
        }
        s
    }
}

/// The column `name` of `table` as whole counts of at least 0 (and at most
/// 1e15, where the likelihood's terms still count exactly), or an error at
/// the first row that is not one.
fn whole_counts(table: &Table, name: &str) -> Result<Vec<f64>, FormulaError> {
    present(table, name)?;
    let col = table.column(name)?;
    let values = numbers(table, name)?;
    let bad = |row: usize, what: &str| FormulaError::Value {
        row: row + 1,
        field: name.to_string(),
        message: format!("`{}` is not {what}", col[row].trim()),
    };
    let Some(values) = values else {
        let row = col.iter().position(|v| v.trim().parse::<f64>().is_err()).unwrap_or(0);
        return Err(bad(row, "a whole number of at least 0"));
    };
    if let Some(row) = values.iter().position(|v| v.fract() != 0.0 || *v < 0.0) {
        return Err(bad(row, "a whole number of at least 0"));
    }
    // A whole count so large that its log-likelihood's terms lose
    // their integer precision: named as too large, not as a fraction.
    if let Some(row) = values.iter().position(|v| *v > 1e15) {
        return Err(FormulaError::Value {
            row: row + 1,
            field: name.to_string(),
            message: format!(
                "`{}` is larger than 1e15, beyond the counts the likelihood computes exactly (doubles hold whole numbers exactly to 9e15, their sums less)",
                col[row].trim()
            ),
        });
    }
    Ok(values)
}

/// Successes and trials of a binomial response of proportions with
/// prior weights `w` (glmer's `weights`: the trials): each proportion
/// between 0 and 1, each weight a whole number of at least 1, their
/// product a whole number of successes (glmer warns of a non-integer one
/// and fits it anyway; crossaudit refuses it at its row).
fn weighted(family: Family, formula: &Formula, table: &Table, w: &str) -> Result<(Vec<f64>, Vec<f64>), FormulaError> {
    if family != Family::Binomial {
        return Err(FormulaError::Unsupported(format!(
            "--weights {w}: prior weights are the trials of a binomial response of proportions; a Poisson model's exposure is an offset, `offset(log({w}))`, and a linear model's weights are not supported"
        )));
    }
    if formula.failures.is_some() || formula.trials.is_some() {
        return Err(FormulaError::Unsupported(format!(
            "--weights {w} with cbind( ): the trials are given twice; write the proportion as the response with --weights, or cbind( ) alone"
        )));
    }
    let trials = whole_counts(table, w)?;
    present(table, &formula.response)?;
    let col = table.column(&formula.response)?;
    let Some(mut y) = numbers(table, &formula.response)? else {
        let row = col.iter().position(|v| v.trim().parse::<f64>().is_err()).unwrap_or(0);
        return Err(FormulaError::Value {
            row: row + 1,
            field: formula.response.clone(),
            message: format!("`{}` is not a proportion between 0 and 1", col[row].trim()),
        });
    };
    // `a / b`: the proportion computed here (glmer's `incidence / size`).
    if let Some(d) = &formula.divisor {
        present(table, d)?;
        let dcol = table.column(d)?;
        let denominators = numbers(table, d)?;
        for (row, p) in y.iter_mut().enumerate() {
            let b = denominators.as_ref().map_or(f64::NAN, |v| v[row]);
            if !(b.is_finite() && b > 0.0) {
                return Err(FormulaError::Value {
                    row: row + 1,
                    field: d.clone(),
                    message: format!("`{}` is not a denominator above 0", dcol[row].trim()),
                });
            }
            *p /= b;
        }
    }
    let mut k = Vec::with_capacity(y.len());
    for (row, (&p, &m)) in y.iter().zip(&trials).enumerate() {
        let bad =
            |field: &str, message: String| FormulaError::Value { row: row + 1, field: field.to_string(), message };
        if !(0.0..=1.0).contains(&p) {
            return Err(bad(&formula.response, format!("`{}` is not a proportion between 0 and 1", col[row].trim())));
        }
        if m < 1.0 {
            return Err(bad(w, "a weight of 0: an observation needs at least one trial".into()));
        }
        let successes = p * m;
        if (successes - successes.round()).abs() > 1e-8 * m.max(1.0) {
            return Err(bad(
                &formula.response,
                format!("the proportion {p} of {m} trials is {successes} successes, not a whole number"),
            ));
        }
        k.push(successes.round());
    }
    Ok((k, trials))
}

/// Each observation's number of trials: successes plus failures for
/// `cbind(successes, failures)`, 1 for a binomial 0/1 column (whose
/// values `k` must be 0 or 1) and for a Poisson count.
fn trials(family: Family, formula: &Formula, table: &Table, k: &[f64]) -> Result<Vec<f64>, FormulaError> {
    let n = k.len();
    if let Some(size) = &formula.trials {
        if family != Family::Binomial {
            return Err(FormulaError::Unsupported(format!(
                "cbind(successes, {size} - successes) is a binomial response; a Poisson response is one column of counts"
            )));
        }
        let trials = whole_counts(table, size)?;
        if let Some(row) = (0..n).find(|&i| k[i] > trials[i] || trials[i] < 1.0) {
            return Err(FormulaError::Value {
                row: row + 1,
                field: size.clone(),
                message: format!(
                    "{} trials for {} successes: the trials are at least 1 and at least the successes",
                    trials[row], k[row]
                ),
            });
        }
        return Ok(trials);
    }
    Ok(match (family, &formula.failures) {
        (Family::Binomial, Some(f)) => {
            let failures = whole_counts(table, f)?;
            let trials: Vec<f64> = k.iter().zip(&failures).map(|(a, b)| a + b).collect();
            if let Some(row) = trials.iter().position(|t| *t < 1.0) {
                return Err(FormulaError::Value {
                    row: row + 1,
                    field: f.clone(),
                    message: "no successes and no failures: an observation needs at least one trial".into(),
                });
            }
            trials
        }
        (Family::Binomial, None) => {
            if let Some(row) = k.iter().position(|v| *v > 1.0) {
                return Err(FormulaError::Value {
                row: row + 1,
                field: formula.response.clone(),
                message: format!(
                    "`{}`: a binomial response of one column is 0 or 1; for counts of successes write cbind(successes, failures)",
                    k[row]
                ),
            });
            }
            vec![1.0; n]
        }
        (Family::Poisson, Some(_)) => {
            return Err(FormulaError::Unsupported(
                "cbind(successes, failures) is a binomial response; a Poisson response is one column of counts".into(),
            ))
        }
        (Family::Poisson, None) => vec![1.0; n],
    })
}
