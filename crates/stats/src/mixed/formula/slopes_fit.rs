//! A formula with random slopes fitted to a table, and its summary as lme4
//! and lmerTest print it (the random effects with their correlations).

use super::number::Six;
use std::fmt::Write;

use super::FormulaError;
use crate::mixed::slopes::{fit_slopes, with_kenward_roger, SlopeData, SlopeFit, TermFit};
use crate::mixed::Criterion;

/// Fits a random-slope model; Satterthwaite or (`kenward_roger`)
/// Kenward-Roger df for REML fits. Profile intervals are computed for
/// random-intercept models only, and asking for them here is refused by
/// name.
pub(super) fn fit_checked(
    data: &SlopeData,
    criterion: Criterion,
    kenward_roger: bool,
    profile: Option<f64>,
) -> Result<SlopeFit, FormulaError> {
    if profile.is_some() {
        return Err(FormulaError::Unsupported(
            "--profile is computed for random-intercept models only; a model with random slopes gets its standard deviations and correlations without profile intervals".into(),
        ));
    }
    let reml = criterion == Criterion::Reml;
    let fit = fit_slopes(data, criterion, reml && !kenward_roger)?;
    Ok(if reml && kenward_roger { with_kenward_roger(data, fit)? } else { fit })
}

/// lme4's random-effects table of a random-slope fit (variance, standard
/// deviation and correlations of each term's columns, the residual) and
/// its line of observations and groups.
pub(super) fn random_effects(f: &SlopeFit) -> String {
    terms_table(&f.terms, Some(f.residual), f.n)
}

/// lme4's random-effects table of `terms` (with the residual's row where
/// the model has one; a GLMM has none) and its line of observations and
/// groups, shared by the linear and the generalized models' summaries.
pub(super) fn terms_table(terms: &[TermFit], residual: Option<f64>, n: usize) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "Random effects:");
    let width = terms.iter().map(|t| t.group.len()).max().unwrap_or(0).max(8);
    let name_width = terms.iter().flat_map(|t| t.names.iter().map(String::len)).max().unwrap_or(0).max(11);
    let _ = writeln!(s, " {:<width$} {:<name_width$} {:>12} {:>12} Corr", "Groups", "Name", "Variance", "Std.Dev.");
    for t in terms {
        let k = t.names.len();
        let mut corr = t.correlations.iter();
        for (i, name) in t.names.iter().enumerate() {
            let group = if i == 0 { t.group.as_str() } else { "" };
            let variance = t.covariance[i * k + i];
            let mut line = format!(" {group:<width$} {name:<name_width$} {:>12} {:>12}", Six(variance), Six(t.sd[i]));
            for _ in 0..i {
                match corr.next() {
                    Some(Some(r)) => line.push_str(&format!(" {r:>6.3}")),
                    _ => line.push_str("    NaN"),
                }
            }
            let _ = writeln!(s, "{line}");
        }
    }
    if let Some(residual) = residual {
        let _ = writeln!(
            s,
            " {:<width$} {:<name_width$} {:>12} {:>12}",
            "Residual",
            "",
            Six(residual),
            Six(residual.sqrt())
        );
    }
    let mut groups: Vec<String> = Vec::new();
    for t in terms {
        let g = format!("{}, {}", t.factor, t.levels);
        if !groups.contains(&g) {
            groups.push(g);
        }
    }
    let _ = writeln!(s, "Number of obs: {n}, groups:  {}\n", groups.join("; "));
    s
}

/// The optimizer's certificate, theta, and the singular-fit flag.
pub(super) fn optimizer_lines(f: &SlopeFit) -> String {
    let mut s = String::new();
    let c = &f.certificate;
    let _ = writeln!(
        s,
        "\noptimizer: {} ({} deviance evaluations, {} restarts); max |gradient| {:.2e}, predicted decrease {:.2e}, smallest curvature {:.2e} of the largest",
        if c.certified { "optimum certified" } else { "NOT CERTIFIED" },
        f.evaluations,
        c.restarts,
        c.gradient,
        c.predicted_decrease,
        c.smallest_curvature
    );
    let _ = writeln!(s, "theta: {}", f.theta.iter().map(|t| format!("{t:.6}")).collect::<Vec<_>>().join(" "));
    if !c.certified {
        let _ = writeln!(s, "warning: the optimizer could not certify this point as the optimum; do not use it");
    }
    if f.singular {
        let _ = writeln!(
            s,
            "boundary (singular) fit: a diagonal entry of theta is estimated at (or within 1e-4 of) zero (a variance at zero or a correlation of +-1), as lme4's isSingular says"
        );
    }
    s
}
