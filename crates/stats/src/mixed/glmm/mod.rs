//! Generalized linear mixed models: binomial (logit link) and Poisson
//! (log link) responses with any random-effect terms of
//! [`crate::mixed::slopes`] (intercepts, slopes, crossed, nested), fitted
//! by maximum likelihood under the Laplace approximation, as lme4's
//! `glmer` fits them by default (`nAGQ = 1`).
//!
//! The objective is lme4's: -2 log p(y | u*) + |u*|^2 + log|L|^2 at the
//! conditional mode u* (see `laplace`), minimised over (theta, beta)
//! jointly by the search the random-slope models use (Nelder-Mead, then
//! Newton on difference derivatives, over all of R^m: the objective is
//! even in each column of each T, so theta's boundary is an ordinary
//! point, and the result is put in lme4's parameterization). The
//! certificate is the unconstrained one.
//!
//! The fixed effects' standard errors are lme4's default for `glmer`
//! (`vcov(use.hessian = TRUE)`): the beta block of 2 H^-1, H the Hessian
//! of the objective in (theta, beta) by central differences, which counts
//! the uncertainty of theta; the R_X form (`use.hessian = FALSE`, the
//! linear model's formula with the GLM weights at the mode) is reported
//! beside it. Wald z tests use the first.
//!
//! ```
//! use crossaudit_stats::prelude::*;
//! // Failures out of 20 starts in 10 recordings x 4 seeds, two arms.
//! let mut csv = String::from("failed,held,arm,recording,seed\n");
//! for r in 0..10 {
//!     for s in 0..4 {
//!         for (arm, extra) in [("clean", 0), ("leaky", 2)] {
//!             let failed = (r * 3 + s * 5) % 6 + extra;
//!             csv.push_str(&format!("{failed},{},{arm},r{r},s{s}\n", 20 - failed));
//!         }
//!     }
//! }
//! let table = read_csv(&csv).unwrap();
//! let formula = "cbind(failed, held) ~ arm + (1 | recording) + (1 | seed)";
//! let f = fit_glmm_table(formula, &table, Family::Binomial, None).unwrap();
//! assert!(f.fit.certificate.certified);
//! assert_eq!(f.fit.fixed[1].name, "armleaky");
//! assert!(f.fit.fixed[1].estimate > 0.0); // the leaky arm fails more often
//! ```

mod family;
mod laplace;
mod profile;
mod quadrature;
mod separation;

pub use family::Family;
pub use profile::{profile_fixed, FixedProfile};

use faer::linalg::solvers::Solve;
use serde::Serialize;

use super::slopes::structure::Structure;
use super::slopes::{self, SlopeCertificate, Term, TermFit};
use super::sparse::Sparse;
use super::{MixedData, MixedError};

/// A GLMM's data: the fixed effects (as [`MixedData`] holds them, its
/// response the proportion of successes or the count), the trials, and
/// the random-effect terms.
#[derive(Debug, Clone, PartialEq)]
pub struct GlmmData {
    base: MixedData,
    trials: Vec<f64>,
    /// A term of the linear predictor with its coefficient fixed at 1
    /// (zeros without one).
    offset: Vec<f64>,
    /// Quadrature nodes per level (glmer's nAGQ): 1 is the Laplace
    /// approximation.
    nagq: usize,
    terms: Vec<Term>,
    family: Family,
}

impl GlmmData {
    /// Binomial data: `successes` of `trials` per observation (0/1 data
    /// have one trial each), with the fixed effects of `columns` beside
    /// the intercept and the random terms `terms`.
    pub fn binomial(
        successes: Vec<f64>,
        trials: Vec<f64>,
        columns: Vec<(String, Vec<f64>)>,
        terms: Vec<Term>,
    ) -> Result<GlmmData, MixedError> {
        for (i, (&k, &m)) in successes.iter().zip(&trials).enumerate() {
            let whole = |v: f64| v.is_finite() && v.fract() == 0.0 && v >= 0.0;
            if !whole(k) || !whole(m) || m < 1.0 || k > m {
                return Err(MixedError::Glmm(format!(
                    "observation {}: {k} successes of {m} trials; a binomial response is a whole number of successes between 0 and its trials (at least 1)",
                    i + 1
                )));
            }
        }
        let y: Vec<f64> = successes.iter().zip(&trials).map(|(k, m)| k / m).collect();
        GlmmData::with(y, trials, columns, terms, Family::Binomial)
    }

    /// Poisson data: a count per observation.
    pub fn poisson(
        counts: Vec<f64>,
        columns: Vec<(String, Vec<f64>)>,
        terms: Vec<Term>,
    ) -> Result<GlmmData, MixedError> {
        if let Some(i) = counts.iter().position(|&k| !(k.is_finite() && k.fract() == 0.0 && k >= 0.0)) {
            return Err(MixedError::Glmm(format!(
                "observation {}: {} is not a count; a Poisson response is a whole number of at least 0",
                i + 1,
                counts[i]
            )));
        }
        let trials = vec![1.0; counts.len()];
        GlmmData::with(counts, trials, columns, terms, Family::Poisson)
    }

    fn with(
        y: Vec<f64>,
        trials: Vec<f64>,
        columns: Vec<(String, Vec<f64>)>,
        terms: Vec<Term>,
        family: Family,
    ) -> Result<GlmmData, MixedError> {
        let n = y.len();
        if n < 2 {
            return Err(MixedError::TooFewObservations(n));
        }
        if trials.len() != n {
            return Err(MixedError::Length { factor: "trials".into(), found: trials.len(), expected: n });
        }
        if terms.is_empty() {
            return Err(MixedError::NoFactor);
        }
        // Every observation a failure (or a zero count) leaves the
        // intercept at minus infinity.
        let all = |v: f64| y.iter().all(|y| *y == v);
        let degenerate = match family {
            Family::Binomial if all(0.0) => Some("no trial is a success"),
            Family::Binomial if all(1.0) => Some("every trial is a success"),
            Family::Poisson if all(0.0) => Some("every count is 0"),
            _ => None,
        };
        if let Some(what) = degenerate {
            return Err(MixedError::Glmm(format!(
                "{what}, so the fixed intercept's maximum-likelihood estimate is infinite and the model has no fit"
            )));
        }
        for t in &terms {
            if t.levels < 2 {
                return Err(MixedError::TooFewLevels { factor: t.group.clone(), levels: t.levels });
            }
        }
        let base = MixedData::fixed_only(y, columns)?;
        let terms = slopes::ordered(terms);
        let offset = vec![0.0; n];
        Ok(GlmmData { base, trials, offset, nagq: 1, terms, family })
    }

    /// The data with `offset` added to the linear predictor (glmer's
    /// `offset(o)`: `offset(log(t))` makes a Poisson model one of rates
    /// per unit of t).
    pub fn with_offset(mut self, offset: Vec<f64>) -> Result<GlmmData, MixedError> {
        let n = self.trials.len();
        if offset.len() != n {
            return Err(MixedError::Length { factor: "offset".into(), found: offset.len(), expected: n });
        }
        if let Some(i) = offset.iter().position(|v| !v.is_finite() || v.abs() > 700.0) {
            return Err(MixedError::Glmm(format!(
                "observation {}: the offset {} is not finite or beyond +-700, where e^offset overflows",
                i + 1,
                offset[i]
            )));
        }
        self.offset = offset;
        Ok(self)
    }

    /// The data fitted by adaptive Gauss-Hermite quadrature with `nagq`
    /// nodes per level (glmer's `nAGQ`), which glmer allows for one scalar
    /// random-effect term only (`(1|g)`); 1 is the Laplace approximation.
    pub fn with_nagq(mut self, nagq: usize) -> Result<GlmmData, MixedError> {
        if !(1..=quadrature::MAX_NAGQ).contains(&nagq) {
            return Err(MixedError::Glmm(format!(
                "nAGQ = {nagq}: the quadrature has 1 to {} nodes (1 is the Laplace approximation)",
                quadrature::MAX_NAGQ
            )));
        }
        if nagq > 1 && !(self.terms.len() == 1 && self.terms[0].columns.len() == 1) {
            return Err(MixedError::Glmm(format!(
                "nAGQ = {nagq} is defined for one scalar random effect, a single term (1|g), as glmer allows it; this model has {} random-effect terms with {} columns",
                self.terms.len(),
                self.terms.iter().map(|t| t.columns.len()).sum::<usize>()
            )));
        }
        self.nagq = nagq;
        Ok(self)
    }

    /// The family.
    pub fn family(&self) -> Family {
        self.family
    }

    /// The terms, in lme4's order.
    pub fn terms(&self) -> &[Term] {
        &self.terms
    }
}

/// A fixed effect of a GLMM.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GlmmFixed {
    /// R's name.
    pub name: String,
    /// Estimate (log odds or log rate).
    pub estimate: f64,
    /// lme4's default standard error (from the Hessian in theta and beta).
    pub se: f64,
    /// The standard error from R_X at the mode (`use.hessian = FALSE`).
    pub se_rx: f64,
    /// Wald z = estimate / se.
    pub z: f64,
    /// Two-sided p of z.
    pub p: f64,
}

/// A fitted GLMM.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GlmmFit {
    /// The family.
    pub family: Family,
    /// Quadrature nodes per level: 1 for the Laplace approximation.
    pub nagq: usize,
    /// lme4's theta (diagonal entries non-negative).
    pub theta: Vec<f64>,
    /// Per term, its covariance T T' (a GLMM has no residual variance).
    pub terms: Vec<TermFit>,
    /// Fixed effects, the intercept first.
    pub fixed: Vec<GlmmFixed>,
    /// -2 log-likelihood (Laplace), lme4's `deviance` column of the summary.
    pub deviance: f64,
    /// log-likelihood.
    pub loglik: f64,
    /// -2 logLik + 2 npar.
    pub aic: f64,
    /// -2 logLik + log(n) npar.
    pub bic: f64,
    /// Parameters: fixed effects and theta.
    pub npar: usize,
    /// A diagonal entry of theta below 1e-4.
    pub singular: bool,
    /// The optimizer's certificate.
    pub certificate: SlopeCertificate,
    /// Fixed-effect columns dropped as aliased.
    pub dropped: Vec<String>,
    /// The fixed effects whose estimates are infinite (the data separate
    /// them: found by linear programming from the data), empty where
    /// every estimate is finite.
    pub separated: Vec<String>,
    /// Notes on the inference.
    pub notes: Vec<String>,
    /// Objective evaluations.
    pub evaluations: usize,
    /// Observations.
    pub n: usize,
}

/// The evaluation model of `data`, its aliased fixed columns dropped.
fn model(data: &GlmmData) -> Result<(laplace::Model, Vec<String>, Vec<String>), MixedError> {
    let (base, dropped) = data.base.full_rank();
    let n = base.len();
    let k: Vec<f64> = base.y.iter().zip(&data.trials).map(|(y, m)| (y * m).round()).collect();
    let constant = match data.family {
        Family::Binomial => k
            .iter()
            .zip(&data.trials)
            .map(|(&k, &m)| {
                use statrs::function::gamma::ln_gamma;
                ln_gamma(m + 1.0) - ln_gamma(k + 1.0) - ln_gamma(m - k + 1.0)
            })
            .sum(),
        Family::Poisson => -k.iter().map(|&k| statrs::function::gamma::ln_gamma(k + 1.0)).sum::<f64>(),
    };
    let structure = Structure::new(&data.terms, n);
    let p = base.p();
    let sparse = Sparse::new(&structure.z_rows, structure.q, 0)?;
    let bordered = Sparse::new(&structure.z_rows, structure.q, p)?;
    let m = Model {
        structure,
        sparse,
        bordered,
        family: data.family,
        n,
        p,
        x: base.design(),
        k,
        m: data.trials.clone(),
        offset: data.offset.clone(),
        nodes: quadrature::rule(data.nagq),
        constant,
    };
    Ok((m, base.fixed_names(), dropped))
}

use laplace::Model;

/// The Laplace approximation of `data` at `theta` (lme4's
/// parameterization) and `beta`: lme4's objective, -2 log L, what the
/// deviance function of `glmer(..., devFunOnly = TRUE)` returns at
/// c(theta, beta), and the fixed effects' standard errors from R_X there
/// (lme4's `vcov(use.hessian = FALSE)`).
pub fn laplace_at(data: &GlmmData, theta: &[f64], beta: &[f64]) -> Result<(f64, Vec<f64>), MixedError> {
    let (m, _, _) = model(data)?;
    if theta.len() != m.structure.parameters() || beta.len() != m.p {
        return Err(MixedError::Length {
            factor: "theta and beta".into(),
            found: theta.len() + beta.len(),
            expected: m.structure.parameters() + m.p,
        });
    }
    let l = m.evaluate(theta, beta, None, true)?;
    let se = l.rx_vcov.map(|v| (0..m.p).map(|c| v[(c, c)].sqrt()).collect()).unwrap_or_default();
    Ok((l.objective, se))
}

/// The search's parameters, as scales of (theta, beta): theta times its
/// [`Structure::scales`], beta times its column's root mean square.
fn search_scales(m: &Model) -> Vec<f64> {
    let x_rms = (0..m.p).map(|c| {
        let r = ((0..m.n).map(|i| m.x[i * m.p + c].powi(2)).sum::<f64>() / m.n as f64).sqrt();
        if r.is_finite() && r > 0.0 {
            r
        } else {
            1.0
        }
    });
    m.structure.scales().iter().copied().chain(x_rms).collect()
}

/// Fits the model by maximum likelihood under the Laplace approximation.
pub fn fit_glmm(data: &GlmmData) -> Result<GlmmFit, MixedError> {
    let (m, names, dropped) = model(data)?;
    if m.n <= m.p {
        return Err(MixedError::FixedEffects(format!("{} observations for {} fixed-effect columns", m.n, m.p)));
    }
    let nt = m.structure.parameters();
    let scales = search_scales(&m);
    let x_rms = scales[nt..].to_vec();
    let unscaled = |t: &[f64]| -> Vec<f64> { t.iter().zip(&scales).map(|(v, d)| v / d).collect() };
    let start_beta = glm_start(&m);
    let mut start: Vec<f64> = m.structure.start();
    start.extend(start_beta.iter().zip(&x_rms).map(|(b, s)| b * s));
    m.evaluate(&unscaled(&start)[..nt], &unscaled(&start)[nt..], None, false)?;
    let one = |par: &[f64]| -> f64 {
        let par = unscaled(par);
        m.evaluate(&par[..nt], &par[nt..], None, false).map(|l| l.objective).unwrap_or(f64::INFINITY)
    };
    let (best, objective, evaluations, certificate) = slopes::optimize::minimize(&one, start);
    let best_scaled = best.clone();
    let best = unscaled(&best);
    let theta = m.structure.normalized(&best[..nt]);
    let beta = best[nt..].to_vec();
    let separated = separated(&m, &names, &beta, &x_rms, data.family);
    // Separated data leave X'WX singular at the optimum (weights of 0 where
    // the fitted probabilities reach 0 or 1): the fit is still reported,
    // named as separated, its standard errors not a number.
    let at = match m.evaluate(&theta, &beta, None, true) {
        Err(MixedError::FixedEffects(_)) if !separated.is_empty() => m.evaluate(&theta, &beta, None, false)?,
        other => other?,
    };
    let rx = at.rx_vcov.clone().unwrap_or_else(|| faer::Mat::from_fn(m.p, m.p, |_, _| f64::NAN));
    let mut notes = Vec::new();
    let hessian_vcov = hessian_vcov(&one, &best_scaled, objective, &scales, nt);
    if hessian_vcov.is_none() {
        notes.push("the Hessian of the objective in (theta, beta) is not positive definite at the optimum, so the standard errors are R_X's (lme4's use.hessian = FALSE)".into());
    }
    let mut certificate = certificate;
    if !separated.is_empty() {
        certificate.certified = false;
        notes.push(separation_note(&separated, data.family));
    }
    let fixed = names
        .into_iter()
        .enumerate()
        .map(|(c, name)| {
            let se_rx = rx[(c, c)].sqrt();
            let se = hessian_vcov.as_ref().map_or(se_rx, |v| v[c].sqrt());
            let z = beta[c] / se;
            let p = crate::t_two_sided_p(z, f64::INFINITY);
            GlmmFixed { name, estimate: beta[c], se, se_rx, z, p }
        })
        .collect();
    let npar = nt + m.p;
    let terms = slopes::term_fits(&data.terms, &theta, 1.0);
    let singular = m.structure.diagonal().iter().any(|&j| theta[j] < 1e-4);
    Ok(GlmmFit {
        family: data.family,
        nagq: data.nagq,
        theta,
        terms,
        fixed,
        deviance: objective,
        loglik: -0.5 * objective,
        aic: objective + 2.0 * npar as f64,
        bic: objective + (m.n as f64).ln() * npar as f64,
        npar,
        singular,
        certificate,
        dropped,
        separated,
        notes,
        evaluations,
        n: m.n,
    })
}

/// The fixed effects the likelihood runs to infinity along, from the data
/// ([`separation::infinite`]). Where the programs did not finish, a
/// coefficient that moves the linear predictor by more than 25 (odds or
/// rates of e^25) over one root mean square of its column is the
/// optimizer running towards an infinite estimate.
fn separated(m: &Model, names: &[String], beta: &[f64], x_rms: &[f64], family: Family) -> Vec<String> {
    match separation::infinite(&m.x, m.p, &m.k, &m.m, family) {
        Some(found) => found.iter().map(|&(c, _)| names[c].clone()).collect(),
        None => (0..m.p).filter(|&c| (beta[c] * x_rms[c]).abs() > 25.0).map(|c| names[c].clone()).collect(),
    }
}

/// What a fit says of its `separated` fixed effects.
fn separation_note(separated: &[String], family: Family) -> String {
    format!(
        "the data separate {}: the likelihood rises without bound as {} along a direction where no observation's fit gets worse (a level or a side of a predictor with no {} or none else), so the estimates and standard errors of {} are not estimates; remove or merge what separates the data",
        separated.join(", "),
        if separated.len() == 1 { "it runs" } else { "they run together" },
        if family == Family::Binomial { "success" } else { "count" },
        separated.join(", "),
    )
}

/// The beta block of 2 H^-1, H the Hessian of `one` at `x` (scaled
/// parameters, value `fx`) by central differences with Richardson
/// extrapolation, carried back to beta's own scale; `None` where H is not
/// positive definite.
fn hessian_vcov(
    one: &(dyn Fn(&[f64]) -> f64 + Sync),
    x: &[f64],
    fx: f64,
    scales: &[f64],
    nt: usize,
) -> Option<Vec<f64>> {
    use rayon::prelude::*;
    let m = x.len();
    let mut batch = |points: &[Vec<f64>]| -> Vec<f64> { points.par_iter().map(|p| one(p)).collect() };
    let mut hessian = |rel: f64| -> faer::Mat<f64> {
        let h: Vec<f64> = x.iter().map(|v| rel * v.abs().max(0.1)).collect();
        slopes::optimize::derivatives(&mut batch, x, fx, &h).1
    };
    let (h1, h2) = (hessian(2e-3), hessian(1e-3));
    let hess = faer::Mat::<f64>::from_fn(m, m, |i, j| (4.0 * h2[(i, j)] - h1[(i, j)]) / 3.0);
    let llt = hess.llt(faer::Side::Lower).ok()?;
    let inverse = llt.solve(faer::Mat::<f64>::identity(m, m));
    // Var(beta_c) = 2 (H^-1)_cc in the scaled parameters, divided by the
    // square of beta_c's scale.
    let out: Vec<f64> = (nt..m).map(|i| 2.0 * inverse[(i, i)] / (scales[i] * scales[i])).collect();
    out.iter().all(|v| v.is_finite() && *v > 0.0).then_some(out)
}

/// A start for beta: the GLM without random effects, by iteratively
/// reweighted least squares from the intercept at the pooled rate.
fn glm_start(m: &Model) -> Vec<f64> {
    let (n, p) = (m.n, m.p);
    let total_k: f64 = m.k.iter().sum();
    let total_m: f64 = m.m.iter().sum();
    let rate = (total_k / total_m).clamp(1e-6, 1.0 - 1e-6);
    let mut beta = vec![0.0; p];
    // With an offset, the rate per unit of e^offset (Poisson) or the
    // pooled log odds less the offset's mean (binomial).
    let mean_offset = m.offset.iter().sum::<f64>() / n as f64;
    let exposure: f64 = m.offset.iter().map(|o| (o - mean_offset).exp()).sum();
    beta[0] = match m.family {
        Family::Binomial => (rate / (1.0 - rate)).ln() - mean_offset,
        Family::Poisson => (total_k / exposure).max(1e-6).ln() - mean_offset,
    };
    for _ in 0..25 {
        let mut xtwx = faer::Mat::<f64>::zeros(p, p);
        let mut score = faer::Mat::<f64>::zeros(p, 1);
        for i in 0..n {
            let xi = &m.x[i * p..(i + 1) * p];
            let eta: f64 = m.offset[i] + xi.iter().zip(&beta).map(|(a, b)| a * b).sum::<f64>();
            // The GLM weight and score term of the Laplace's PIRLS.
            let (w, r, _) = m.observation(i, eta);
            for c in 0..p {
                score[(c, 0)] += xi[c] * r;
                for d in 0..=c {
                    xtwx[(c, d)] += w * xi[c] * xi[d];
                }
            }
        }
        let Ok(llt) = xtwx.llt(faer::Side::Lower) else { break };
        let step = llt.solve(&score);
        let size: f64 = (0..p).map(|c| step[(c, 0)].abs()).fold(0.0, f64::max);
        if !size.is_finite() || size > 50.0 {
            break;
        }
        for c in 0..p {
            beta[c] += step[(c, 0)];
        }
        if size < 1e-10 {
            break;
        }
    }
    beta
}
