//! Linear mixed models with random slopes: any number of random-effect
//! terms, each a grouping factor with one or more columns of the design
//! (`(1 + x | g)`, `(0 + x | g)`, a factor's columns), correlated within a
//! term, fitted by REML or ML through lme4's profiled deviance (Bates,
//! Maechler, Bolker and Walker 2015, sections 2-3).
//!
//! The random effects are b = Lambda u, u ~ N(0, sigma^2 I), with Lambda
//! block diagonal: per term t and level of its factor, the same lower
//! triangular k_t x k_t block T_t, whose entries (column by column, lme4's
//! `theta` order) are the parameters. The covariance of a term's effects
//! at one level is sigma^2 T_t T_t'. For a given theta the penalized
//! least-squares system
//!
//! ```text
//! [ Lambda'Z'Z Lambda + I   Lambda'Z'X ] [u   ]   [ Lambda'Z'y ]
//! [ X'Z Lambda              X'X        ] [beta] = [ X'y        ]
//! ```
//!
//! is factored densely (faer's Cholesky) and the profiled deviance is the
//! random-intercept model's (see the parent module). The deviance depends
//! on T_t only through T_t T_t', which is unchanged when a column of T_t
//! changes sign: over all of R^m it is a smooth function with no
//! boundary, so the optimizer searches R^m without constraints
//! (Nelder-Mead, then Newton on difference derivatives) and the
//! certificate is the unconstrained one (gradient, Hessian); at the end
//! each column whose diagonal entry is negative is negated, which gives
//! lme4's parameterization (diagonal >= 0) of the same covariance. A
//! diagonal entry below 1e-4 makes the fit singular, as `isSingular` says.
//!
//! ```
//! use crossaudit_stats::prelude::*;
//! // 8 subjects x 6 days, each subject with its own intercept and slope.
//! let mut csv = String::from("y,day,subject\n");
//! for s in 0..8 {
//!     for d in 0..6 {
//!         let (a, b) = (((s * 7) % 5) as f64 - 2.0, ((s * 3) % 4) as f64 * 0.5);
//!         let noise = (((s * 6 + d) * 37) % 11) as f64 / 10.0 - 0.5;
//!         csv.push_str(&format!("{},{d},s{s}\n", 10.0 + a + (1.0 + b) * d as f64 + noise));
//!     }
//! }
//! let table = read_csv(&csv).unwrap();
//! let f = fit_table("y ~ day + (day | subject)", &table, Criterion::Reml, DfMethod::Satterthwaite, None).unwrap();
//! let slopes = f.fit.slopes().unwrap();
//! assert!(slopes.certificate.certified);
//! assert_eq!(slopes.terms[0].names, ["(Intercept)", "day"]);
//! assert_eq!(slopes.theta.len(), 3); // lme4's theta: the lower triangle of T
//! ```
//!
//! The random-intercept models (every term `(1|g)`) are fitted by
//! [`super::fit`], which eliminates the largest factor; this module is the
//! general case, with the dense system over every level of every term.

mod inference;
mod kenward_roger;
pub(crate) mod optimize;
pub(crate) mod structure;
mod system;
mod types;

use super::{Criterion, MixedData, MixedError};
pub(crate) use types::ordered;
pub use types::{SlopeCertificate, SlopeData, SlopeFit, SlopeFixed, Term, TermFit, MAX_TERM_COLUMNS};

/// Fits the model, with Satterthwaite df for REML fits when
/// `satterthwaite`.
pub fn fit_slopes(data: &SlopeData, criterion: Criterion, satterthwaite: bool) -> Result<SlopeFit, MixedError> {
    data.base.check_design()?;
    let (base, dropped) = data.base.full_rank();
    let base: &MixedData = &base;
    let p = base.p();
    if base.len() <= p {
        return Err(MixedError::FixedEffects(format!("{} observations for {p} fixed-effect columns", base.len())));
    }
    refuse_exact(base, &data.terms)?;
    let s = system::System::new(base, &data.terms, data.weights.as_deref())?;
    let (theta, evaluations, certificate) = optimize::optimum(&s, criterion)?;
    let e = s.evaluate(&theta, criterion)?;
    let total = s.y_scale * s.y_scale;
    if e.sigma2 <= 1e-20 * total {
        return Err(MixedError::ZeroResidual { residual: e.sigma2, total });
    }
    let mut notes = Vec::new();
    if !dropped.is_empty() {
        notes.push(super::rank_message(&dropped));
    }
    let df: Vec<Option<f64>> = if satterthwaite && criterion == Criterion::Reml {
        match inference::satterthwaite(&s, &theta, e.sigma2)? {
            Ok(df) => df.into_iter().map(Some).collect(),
            Err(why) => {
                notes.push(why);
                vec![None; p]
            }
        }
    } else {
        vec![None; p]
    };
    let fixed = base
        .fixed_names()
        .into_iter()
        .enumerate()
        .map(|(c, name)| SlopeFixed {
            name,
            estimate: e.beta[c],
            se: (e.sigma2 * e.rx_inv[(c, c)]).sqrt(),
            df_satterthwaite: df[c],
            kenward_roger: None,
        })
        .collect();
    let terms = term_fits(&data.terms, &theta, e.sigma2);
    let singular = s.structure.diagonal().iter().any(|&j| theta[j] < 1e-4);
    Ok(SlopeFit {
        criterion,
        theta,
        terms,
        residual: e.sigma2,
        fixed,
        deviance: e.deviance,
        singular,
        certificate,
        notes,
        dropped,
        evaluations,
        n: base.len(),
    })
}

/// Adds Kenward-Roger's adjusted SE and df (pbkrtest's) to every fixed
/// effect of `fit`, a REML fit of `data`.
pub fn with_kenward_roger(data: &SlopeData, mut fit: SlopeFit) -> Result<SlopeFit, MixedError> {
    if fit.criterion != Criterion::Reml {
        return Ok(fit);
    }
    if data.weighted() {
        return Err(MixedError::FixedEffects(
            "Kenward-Roger df with prior weights are not computed (pbkrtest's vcovAdj does not take them either); use Satterthwaite df".into(),
        ));
    }
    let (base, _) = data.base.full_rank();
    let covariances: Vec<Vec<f64>> = fit.terms.iter().map(|t| t.covariance.clone()).collect();
    let kr = kenward_roger::kenward_roger(&base, &data.terms, &covariances, fit.residual)?;
    for (f, (se, df)) in fit.fixed.iter_mut().zip(kr) {
        f.kenward_roger = Some(super::KenwardRoger { se, df, fallback: false });
    }
    Ok(fit)
}

/// The deviance (REML criterion or ML deviance) of `data` at `theta`, in
/// lme4's parameterization: what lme4's `devfun` returns there.
pub fn deviance_at(data: &SlopeData, theta: &[f64], criterion: Criterion) -> Result<f64, MixedError> {
    let (base, _) = data.base.full_rank();
    let s = system::System::new(&base, &data.terms, data.weights.as_deref())?;
    if theta.len() != s.structure.parameters() {
        return Err(MixedError::Length {
            factor: "theta".into(),
            found: theta.len(),
            expected: s.structure.parameters(),
        });
    }
    Ok(s.evaluate(theta, criterion)?.deviance)
}

/// Each term's covariance sigma^2 T T', standard deviations and
/// correlations.
pub(crate) fn term_fits(terms: &[Term], theta: &[f64], sigma2: f64) -> Vec<TermFit> {
    let mut at = 0;
    terms
        .iter()
        .map(|t| {
            let k = t.columns.len();
            let lower = structure::lower_triangle(&theta[at..at + k * (k + 1) / 2], k);
            at += k * (k + 1) / 2;
            let covariance: Vec<f64> = (0..k * k)
                .map(|ij| {
                    let (i, j) = (ij / k, ij % k);
                    sigma2 * (0..k).map(|m| lower[i * k + m] * lower[j * k + m]).sum::<f64>()
                })
                .collect();
            let sd: Vec<f64> = (0..k).map(|i| covariance[i * k + i].max(0.0).sqrt()).collect();
            let correlations = (1..k)
                .flat_map(|i| (0..i).map(move |j| (i, j)))
                .map(|(i, j)| (sd[i] > 0.0 && sd[j] > 0.0).then(|| covariance[i * k + j] / (sd[i] * sd[j])))
                .collect();
            TermFit {
                group: t.group.clone(),
                factor: t.factor.clone(),
                levels: t.levels,
                names: t.names.clone(),
                sd,
                correlations,
                covariance,
            }
        })
        .collect()
}

/// [`super::exact`]'s refusal of a response the model reproduces exactly,
/// each term's columns fitted within each of its levels.
fn refuse_exact(base: &MixedData, terms: &[Term]) -> Result<(), MixedError> {
    let blocks: Vec<super::exact::Block> = terms
        .iter()
        .map(|t| super::exact::Block {
            codes: &t.codes,
            levels: t.levels,
            columns: t.columns.iter().map(Vec::as_slice).collect(),
        })
        .collect();
    super::exact::refuse_exact(base, &blocks)
}

#[cfg(test)]
mod tests;
