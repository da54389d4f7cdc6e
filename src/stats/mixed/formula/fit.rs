//! A formula fitted to a file or table, and lme4's and lmerTest's
//! summary of it: what `crossaudit mixed` prints.

use super::{build, parse, read_csv, FormulaError, Table};
use crate::stats::mixed::{self, MixedError};

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
    pub fit: mixed::MixedFit,
    /// Per fixed effect: name, estimate, SE (Kenward-Roger's adjusted SE
    /// under that method), df, t and two-sided p.
    pub fixed: Vec<FixedRow>,
    /// Profile-likelihood intervals of the standard deviations, when asked.
    pub profile: Option<(f64, Vec<mixed::ProfileInterval>)>,
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
    let formula = parse(formula_text)?;
    let data = build(&formula, table)?;
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
    let fit = mixed::fit_with(&data, criterion, inference)?;
    let reml = criterion == mixed::Criterion::Reml;
    let fixed = fit
        .fixed
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
            let t = f.estimate / se;
            let p = dof.filter(|d| *d > 0.0).map(|d| crate::stats::t_two_sided_p(t, d)).filter(|p| !p.is_nan());
            let df_fallback = match (reml, df) {
                (false, _) => false,
                (true, DfMethod::Satterthwaite) => f.satterthwaite_fallback,
                (true, DfMethod::KenwardRoger) => f.kenward_roger.is_some_and(|kr| kr.fallback),
            };
            FixedRow { name: f.name.clone(), estimate: f.estimate, se, df: dof, df_fallback, t, p }
        })
        .collect();
    let profile = match profile {
        Some(level) => Some((level, mixed::profile_intervals(&data, criterion, level)?)),
        None => None,
    };
    Ok(FormulaFit { formula: formula_text.to_string(), df_method: reml.then_some(df), fit, fixed, profile })
}

impl FormulaFit {
    /// The summary as lme4 and lmerTest print it, with the optimizer's
    /// certificate and any warning on their own lines.
    pub fn summary(&self) -> String {
        use std::fmt::Write;
        let f = &self.fit;
        let mut s = String::new();
        let (what, crit) = match f.criterion {
            mixed::Criterion::Reml => ("REML", "REML criterion at convergence"),
            mixed::Criterion::Ml => ("maximum likelihood", "deviance"),
        };
        let df = match self.df_method {
            Some(DfMethod::Satterthwaite) => ". t-tests use Satterthwaite's method",
            Some(DfMethod::KenwardRoger) => ". t-tests use the Kenward-Roger method",
            None => "",
        };
        let _ = writeln!(s, "Linear mixed model fit by {what}{df}");
        let _ = writeln!(s, "Formula: {}\n", self.formula);
        let _ = writeln!(s, "{crit}: {:.4}\n", f.deviance);
        let _ = writeln!(s, "Random effects:");
        let width = f.factors.iter().map(|n| n.len()).max().unwrap_or(0).max(8);
        let _ = writeln!(s, " {:<width$} {:<11} {:>12} {:>12}", "Groups", "Name", "Variance", "Std.Dev.");
        for (name, v) in f.factors.iter().zip(&f.variances) {
            let _ = writeln!(s, " {:<width$} {:<11} {:>12.6} {:>12.6}", name, "(Intercept)", v, v.sqrt());
        }
        let _ = writeln!(s, " {:<width$} {:<11} {:>12.6} {:>12.6}", "Residual", "", f.residual, f.residual.sqrt());
        let groups: Vec<String> = f.factors.iter().zip(&f.levels).map(|(n, l)| format!("{n}, {l}")).collect();
        let _ = writeln!(s, "Number of obs: {}, groups:  {}\n", f.n, groups.join("; "));
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
                let p = r.p.map(|p| format!("{p:.3e}")).unwrap_or_else(|| "NA".into());
                let _ = writeln!(
                    s,
                    "{:<width$} {:>12.6} {:>12.6} {:>10} {:>9.3} {:>10}",
                    r.name, r.estimate, r.se, dof, r.t, p
                );
            } else {
                let _ = writeln!(s, "{:<width$} {:>12.6} {:>12.6} {:>9.3}", r.name, r.estimate, r.se, r.t);
            }
        }
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

/// Reads the tidy CSV at `path` and fits `formula` to it (see
/// [`fit_table`]). A path that is not a regular file (a folder, a FIFO, a
/// device) or is over 1 GiB is refused before it is read
/// ([`crate::io::read_input`]).
pub fn fit_file(
    path: &std::path::Path,
    formula: &str,
    criterion: mixed::Criterion,
    df: DfMethod,
    profile: Option<f64>,
) -> Result<FormulaFit, FileError> {
    let fail = |error: FormulaError| FileError { file: path.display().to_string(), error };
    let read = |message: String| fail(FormulaError::Read(message));
    let bytes =
        crate::io::read_input(path, crate::io::MAX_CELLS_FILE, "a data file").map_err(|e| read(e.to_string()))?;
    let text = String::from_utf8(bytes)
        .map_err(|e| read(format!("not UTF-8 text (byte {} is not)", e.utf8_error().valid_up_to())))?;
    let table = read_csv(&text).map_err(fail)?;
    fit_table(formula, &table, criterion, df, profile).map_err(fail)
}
