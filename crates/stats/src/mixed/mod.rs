//! Linear mixed models with a fixed intercept and any number of
//! random-intercept factors, crossed or nested, fitted by REML or ML through
//! the profiled deviance of lme4 (Bates, Maechler, Bolker and Walker 2015,
//! "Fitting linear mixed-effects models using lme4", section 3).
//!
//! The model is y = X beta + Z b + e with b ~ N(0, sigma^2 Lambda Lambda'),
//! e ~ N(0, sigma^2 I), X an intercept and optional categorical fixed
//! effects (treatment contrasts, as R codes them), Lambda diagonal with the
//! relative standard deviation theta_k of factor k on each of its levels.
//! For a given theta the penalized least-squares system
//!
//! ```text
//! [ Lambda'Z'Z Lambda + I   Lambda'Z'X ] [u   ]   [ Lambda'Z'y ]
//! [ X'Z Lambda              X'X        ] [beta] = [ X'y        ]
//! ```
//!
//! is factored as [L 0; R' R_X] after eliminating the levels of the factor
//! with the most levels, whose block is diagonal (see `system`), so the
//! dense Cholesky factorization (faer) is over the other factors' levels
//! and the fixed effects only. The penalized residual sum of squares
//! r^2 = |y - X beta - Z Lambda u|^2 + |u|^2 is computed from the solution
//! itself (y centred first), not as y'y - |c|^2, which loses digits to
//! cancellation. With p fixed effects the profiled deviances are
//!
//! ```text
//! ML:   log|L|^2 + n (1 + log(2 pi r^2 / n))
//! REML: log|L|^2 + log|R_X|^2 + (n - p) (1 + log(2 pi r^2 / (n - p)))
//! ```
//!
//! minimised over theta >= 0 by Nelder-Mead, Newton steps on a
//! finite-difference gradient and Hessian, and a check of every boundary
//! face; sigma^2 = r^2 / n (ML) or r^2 / (n - p) (REML), the factor
//! variances are sigma^2 theta_k^2 and Var(beta) = sigma^2 (R_X'R_X)^-1. A
//! factor whose theta is below 1e-4 makes the fit singular, as lme4's
//! `isSingular` says. Unbalanced data and missing cells need nothing
//! special: the data are rows, not a matrix.
//!
//! ```
//! use crossaudit_stats::mixed::{fit, Criterion, MixedData};
//! // Two crossed factors, balanced 3 x 2, one observation per cell.
//! let y = vec![1.0, 2.0, 2.5, 3.0, 4.0, 6.5];
//! let rows = vec![0, 0, 1, 1, 2, 2];
//! let cols = vec![0, 1, 0, 1, 0, 1];
//! let data = MixedData::new(y, vec![("row".into(), rows), ("col".into(), cols)]).unwrap();
//! let f = fit(&data, Criterion::Reml).unwrap();
//! assert!((f.intercept - 19.0 / 6.0).abs() < 1e-9); // balanced: the grand mean
//! ```

mod data;
pub mod formula;
pub mod glmm;
mod inference;
mod levels;
pub(crate) mod optimize;
mod profile;
pub mod slopes;
mod system;

use serde::Serialize;

pub use data::{MixedData, MAX_DENSE, MAX_DESIGN_VALUES};
pub use profile::{profile_intervals, ProfileInterval};

/// REML (restricted) or ML (full) likelihood.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Criterion {
    /// Restricted maximum likelihood (lme4's default).
    Reml,
    /// Maximum likelihood.
    Ml,
}

/// Why a model cannot be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MixedError {
    /// Fewer than two observations.
    #[error("a mixed model needs at least 2 observations, found {0}")]
    TooFewObservations(usize),
    /// A response that is not finite.
    #[error("observation {row}: the response {value} is not finite")]
    NonFinite {
        /// 0-based row.
        row: usize,
        /// The value.
        value: f64,
    },
    /// A factor whose codes do not match the response.
    #[error("factor {factor}: {found} codes for {expected} observations")]
    Length {
        /// Factor name.
        factor: String,
        /// Codes given.
        found: usize,
        /// Observations.
        expected: usize,
    },
    /// Every observation equal: there is no variance to partition.
    #[error("every observation is {0}: a constant response has no variance to partition")]
    ConstantResponse(f64),
    /// The factors explain the response exactly: REML's optimum is at a
    /// zero residual variance, where the likelihood is unbounded.
    #[error("the random factors reproduce the response exactly (residual variance {residual:e} of a total {total:e}): the likelihood has no finite optimum")]
    ZeroResidual {
        /// The residual variance where the optimizer stopped.
        residual: f64,
        /// The response's sample variance.
        total: f64,
    },
    /// The fixed-effect columns are linearly dependent (a level of one
    /// fixed factor determined by another's), or leave no residual df.
    #[error("the fixed effects are not estimable: {0}")]
    FixedEffects(String),
    /// A confidence level outside (0, 1).
    #[error("the confidence level must be strictly between 0 and 1, found {0}")]
    Level(f64),
    /// A profile that never crosses its cutoff.
    #[error("profile-likelihood interval: {0}")]
    Profile(String),
    /// The optimizer's certificate failed after every restart: the point
    /// it stopped at may not be the optimum.
    #[error("the REML/ML optimizer could not certify its optimum (largest gradient {gradient:.3e}, predicted decrease {predicted_decrease:.3e}) after {restarts} restarts; no estimate is reported")]
    NotCertified {
        /// Largest |gradient| off the boundary.
        gradient: f64,
        /// Decrease a Newton step would still give.
        predicted_decrease: f64,
        /// Restarts tried.
        restarts: usize,
    },
    /// A model whose dense matrices would not fit in memory.
    #[error("the model is too large: {0}")]
    TooLarge(String),
    /// A random factor whose variance the data cannot identify.
    #[error("factor {factor} is not identifiable: {reason}")]
    Unidentifiable {
        /// Factor name.
        factor: String,
        /// Why.
        reason: String,
    },
    /// No random factor.
    #[error("a mixed model needs at least one random factor")]
    NoFactor,
    /// A factor with a single level carries no variance.
    #[error("factor {factor} has {levels} level(s); a random factor needs at least 2")]
    TooFewLevels {
        /// Factor name.
        factor: String,
        /// Its number of levels.
        levels: usize,
    },
    /// A generalized model's data or fit (its own message says what).
    #[error("{0}")]
    Glmm(String),
    /// The penalized system could not be factored (it is positive definite
    /// for every theta, so this means non-finite input slipped through).
    #[error("the penalized least-squares system is not positive definite at theta = {theta:?}")]
    NotPositiveDefinite {
        /// Where.
        theta: Vec<f64>,
    },
}

/// How much inference [`fit_with`] computes beyond the estimates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Inference {
    /// Satterthwaite and Kenward-Roger df and the shares (REML), as [`fit`].
    Full,
    /// Estimates, standard errors and the deviance only, as `lme4::lmer`
    /// returns them: no df, no shares. Kenward-Roger costs a few dozen
    /// deviance evaluations more than Satterthwaite.
    Estimates,
    /// The estimates and Satterthwaite df (REML; a few dozen deviance
    /// evaluations), without Kenward-Roger and the shares.
    Satterthwaite,
}

/// One fixed-effect coefficient.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FixedEffect {
    /// R's name: `(Intercept)` or factor name and level.
    pub name: String,
    /// The estimate.
    pub estimate: f64,
    /// Its model-based standard error, sigma sqrt((R_X'R_X)^-1).
    pub se: f64,
    /// Satterthwaite df (REML with [`Inference::Full`]).
    pub df_satterthwaite: Option<f64>,
    /// Whether `df_satterthwaite` is the stated fallback, the df not being
    /// computable reliably (see [`MixedFit::notes`]).
    pub satterthwaite_fallback: bool,
    /// Kenward-Roger SE and df (REML with [`Inference::Full`]).
    pub kenward_roger: Option<KenwardRoger>,
}

impl MixedFit {
    /// The fit, or [`MixedError::NotCertified`] when its certificate failed:
    /// for callers that must not go on from a point that may not be the
    /// optimum.
    pub fn certified(self) -> Result<MixedFit, MixedError> {
        let c = &self.certificate;
        if c.certified {
            Ok(self)
        } else {
            Err(MixedError::NotCertified {
                gradient: c.gradient,
                predicted_decrease: c.predicted_decrease,
                restarts: c.restarts,
            })
        }
    }

    /// The intercept's interval at `level`: with `kenward_roger`,
    /// Kenward-Roger's adjusted SE and df where they are finite, otherwise
    /// the model SE with Satterthwaite's df. Returns (SE, df, the df rule
    /// used: `kenward_roger` or `satterthwaite`, lower, upper).
    pub fn intercept_interval(
        &self,
        kenward_roger: bool,
        level: f64,
    ) -> Result<(f64, f64, &'static str, f64, f64), crate::StatsError> {
        let (se, df, rule) = match (kenward_roger, self.kenward_roger, self.df_satterthwaite) {
            (true, Some(kr), _) if kr.df.is_finite() => (kr.se, kr.df, "kenward_roger"),
            (_, _, Some(df)) if df.is_finite() => (self.se, df, "satterthwaite"),
            _ => return Err(crate::StatsError::Invalid("the Satterthwaite df are undefined at this fit".to_string())),
        };
        let q = crate::critical_value(level, df)?;
        Ok((se, df, rule, self.intercept - q * se, self.intercept + q * se))
    }
}

/// A fitted model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MixedFit {
    /// REML or ML.
    pub criterion: Criterion,
    /// Factor names, in the order given.
    pub factors: Vec<String>,
    /// Levels per factor.
    pub levels: Vec<usize>,
    /// Relative standard deviations theta_k (factor SD / residual SD).
    pub theta: Vec<f64>,
    /// Factor variances sigma^2 theta_k^2.
    pub variances: Vec<f64>,
    /// Residual variance sigma^2.
    pub residual: f64,
    /// The fixed intercept (the reference level's mean when there are
    /// fixed factors).
    pub intercept: f64,
    /// Its standard error, sqrt(sigma^2 / R_X^2).
    pub se: f64,
    /// The profiled deviance at the optimum (-2 log-likelihood, REML or ML).
    pub deviance: f64,
    /// A factor's theta below 1e-4: a boundary fit, as lme4 flags it.
    pub singular: bool,
    /// Satterthwaite degrees of freedom of the intercept (REML fits; `None`
    /// for ML), as lmerTest computes them: 2 Var(mu)^2 / (g' A g), with g
    /// the gradient of Var(mu) in the variance parameters and A their
    /// asymptotic covariance, twice the inverse Hessian of the REML
    /// deviance (both by central differences). Components estimated at
    /// zero are held there. Also `None` where that Hessian is not positive
    /// definite.
    pub df_satterthwaite: Option<f64>,
    /// Kenward-Roger (1997) inference for the intercept (REML fits; `None`
    /// for ML), as pbkrtest computes it.
    pub kenward_roger: Option<KenwardRoger>,
    /// Var(mu) split by source: factors in order, then the residual. Var(mu)
    /// is homogeneous of degree 1 in the variances, so by Euler's theorem
    /// the terms phi_k dVar(mu)/dphi_k add up to it; on a balanced crossed
    /// array they are sa/I, sb/J and se/(IJ). Fractions of Var(mu).
    pub shares: Vec<f64>,
    /// Every fixed-effect coefficient, the intercept first.
    pub fixed: Vec<FixedEffect>,
    /// What the reader must know about the inference: a df that could not
    /// be computed reliably, and the fallback used instead.
    pub notes: Vec<String>,
    /// Why the optimum is one: the first-order conditions checked where
    /// the optimizer stopped.
    pub certificate: Certificate,
    /// Fixed-effect columns dropped before the fit because they are linear
    /// combinations of earlier ones (lme4: "fixed-effect model matrix is
    /// rank deficient so dropping 1 column / coefficient"), by R's name.
    pub dropped: Vec<String>,
    /// Deviance evaluations used.
    pub evaluations: usize,
    /// Observations.
    pub n: usize,
}

/// The optimizer's certificate: the first-order (Karush-Kuhn-Tucker)
/// conditions of a minimum of the profiled deviance over theta >= 0,
/// checked by differences at the point returned. Off the boundary the
/// gradient must vanish; on it (theta_k = 0) leaving the boundary must not
/// lower the deviance. The deviance depends on theta_k only through
/// theta_k^2, so its derivative in theta_k is zero at zero whatever the
/// optimum: the boundary condition is on the derivative in the variance,
/// theta_k^2, and on the deviance along a ladder of thetas from 0.01 to 3.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Certificate {
    /// Largest |d deviance / d theta_k| over the thetas off the boundary
    /// (central differences); 0 when every theta is at zero.
    pub gradient: f64,
    /// The decrease of the deviance a Newton step on the diagonal
    /// curvature would still give, sum g_k^2 / (2 H_kk): how far from the
    /// optimum the point can be, in deviance units.
    pub predicted_decrease: f64,
    /// Per factor, the one-sided derivative d deviance / d(theta_k^2) at
    /// the boundary (non-negative at a boundary optimum); `None` for a
    /// factor off the boundary.
    pub boundary: Vec<Option<f64>>,
    /// Whether every condition holds: predicted decrease below 1e-7 of the
    /// deviance (and 1e-6 absolute), every boundary derivative
    /// non-negative (to rounding) and no point of the ladder lower.
    pub certified: bool,
    /// Optimizer restarts the certificate asked for (0 when the first
    /// search was certified).
    pub restarts: usize,
}

/// Kenward-Roger inference for the intercept: the small-sample adjusted
/// variance and the denominator df (pbkrtest's `vcovAdj` and `Lb_ddf`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct KenwardRoger {
    /// sqrt of the adjusted Var(mu): Phi + 2 Phi U Phi (Kenward and Roger
    /// 1997, eq. 4; no second-derivative term, since V is linear in the
    /// variances).
    pub se: f64,
    /// The denominator df. For one coefficient the KR scaling factor is 1
    /// and the df reduce to 2 / A, A = sum_ij W_ij g_i g_j / Phi^2, g_i the
    /// derivative of its variance in component i and W twice the inverse
    /// expected REML information: Satterthwaite's formula with the expected
    /// rather than the observed information.
    pub df: f64,
    /// Whether `df` is the stated fallback, the df not being computable
    /// reliably (see [`MixedFit::notes`]).
    pub fallback: bool,
}

/// Fits the model by REML or ML, with every inference ([`Inference::Full`]).
pub fn fit(data: &MixedData, criterion: Criterion) -> Result<MixedFit, MixedError> {
    fit_with(data, criterion, Inference::Full)
}

/// Fits the model by REML or ML, with the inference `inference` asks for.
pub fn fit_with(data: &MixedData, criterion: Criterion, inference: Inference) -> Result<MixedFit, MixedError> {
    data.check_size(inference)?;
    // Aliased columns are dropped first, as lme4 drops them.
    let (data, dropped) = data.full_rank();
    let data: &MixedData = &data;
    let p = data.p();
    if data.len() <= p {
        return Err(MixedError::FixedEffects(format!("{} observations for {p} fixed-effect columns", data.len())));
    }
    let mut fit = fit_system(&system::System::new(data), data, criterion, inference)?;
    if !dropped.is_empty() {
        fit.notes.insert(0, rank_message(&dropped));
        fit.dropped = dropped;
    }
    Ok(fit)
}

/// lme4's message for dropped columns, with their names.
fn rank_message(dropped: &[String]) -> String {
    let (k, what) =
        if dropped.len() == 1 { (1, "column / coefficient") } else { (dropped.len(), "columns / coefficients") };
    format!("fixed-effect model matrix is rank deficient so dropping {k} {what}: {}", dropped.join(", "))
}

/// [`fit_with`] on the products of `data` already computed.
fn fit_system(
    s: &system::System,
    data: &MixedData,
    criterion: Criterion,
    inference: Inference,
) -> Result<MixedFit, MixedError> {
    let p = data.p();
    // Rank of X: a Cholesky pivot below 1e-10 of its column's X'X diagonal
    // (exact aliasing leaves a rounding residue, positive or negative).
    let aliased = match s.xtx.llt(faer::Side::Lower) {
        Err(_) => true,
        Ok(llt) => (0..p).any(|c| llt.L()[(c, c)].powi(2) <= 1e-10 * s.xtx[(c, c)]),
    };
    if aliased {
        return Err(MixedError::FixedEffects(format!("the columns {:?} are linearly dependent", data.fixed_names())));
    }
    let (mut best, _, evaluations, mut certificate) = optimize::optimum(s, criterion)?;
    // The reduced system is exact in the eliminated factor whatever its
    // variance; another factor's large variance still costs digits in the
    // dense Cholesky factor (log10(theta^2 n) of them). Where another
    // factor's theta dominates, the optimum is polished, certified and
    // the inference computed with that factor eliminated instead.
    let dominant = (0..best.len()).max_by(|&a, &b| best[a].total_cmp(&best[b])).unwrap_or(s.first);
    let rebuilt;
    let s = if dominant != s.first
        && best[dominant] > 10.0
        && best[dominant] > 2.0 * best[s.first]
        && s.factors() > 1
        && data.levels_but(dominant) + p <= MAX_DENSE
    {
        rebuilt = system::System::eliminating(data, dominant);
        let mut dev = |theta: &[f64]| rebuilt.evaluate(theta, criterion).map(|e| e.deviance).unwrap_or(f64::INFINITY);
        let d0 = dev(&best);
        let (t, _, _) = optimize::newton_one_by_one(&mut dev, best.clone(), d0, 8);
        best = t;
        let d = dev(&best);
        let c = optimize::certify(&mut |xs: &[Vec<f64>]| xs.iter().map(|x| dev(x)).collect(), &best, d);
        certificate = Certificate {
            gradient: c.gradient,
            predicted_decrease: c.predicted_decrease,
            boundary: c.boundary,
            certified: c.certified,
            restarts: certificate.restarts,
        };
        &rebuilt
    } else {
        s
    };
    let e = s.evaluate(&best, criterion)?;
    // The standardized response has variance 1: the total is its scale's square.
    let total = s.y_scale * s.y_scale;
    if e.sigma2 <= 1e-20 * total {
        return Err(MixedError::ZeroResidual { residual: e.sigma2, total });
    }
    let mut notes = Vec::new();
    let names = data.fixed_names();
    // Where a df cannot be computed reliably the fit says so and uses a
    // stated, conservative df: the fewest levels of any random factor
    // less one (the df of the intercept's test when that factor's
    // variance dominates, at most the containment df of any effect).
    let fallback = (data.factors.iter().map(|f| f.levels).min().unwrap_or(2) as f64 - 1.0).max(1.0);
    let mut resolve = |method: &str, c: usize, df: inference::Df| -> (f64, bool) {
        match df {
            inference::Df::Value(v) => (v, false),
            inference::Df::NotPositiveDefinite => {
                notes.push(format!("{method} df of {}: the Hessian of the REML criterion is not positive definite at the optimum, so the df cannot be computed; using {fallback} (the fewest levels of a random factor less one)", names[c]));
                (fallback, true)
            }
            inference::Df::Unreliable(v) => {
                notes.push(format!("{method} df of {}: the difference derivatives do not agree between step sizes (estimate {v:.4e}), so the df cannot be computed reliably; using {fallback} (the fewest levels of a random factor less one)", names[c]));
                (fallback, true)
            }
        }
    };
    let (kr, shares, df) = match (criterion, inference) {
        (Criterion::Reml, Inference::Full) => {
            let (kr, shares) = inference::kenward_roger(s, &best, e.sigma2)?;
            let kr: Vec<Option<KenwardRoger>> = kr
                .into_iter()
                .enumerate()
                .map(|(c, (kr, verdict))| {
                    let (df, fallback) = resolve("Kenward-Roger", c, verdict);
                    Some(KenwardRoger { se: kr.se, df, fallback })
                })
                .collect();
            let df = inference::satterthwaite(s, &best, e.sigma2)?;
            let df = df.into_iter().enumerate().map(|(c, d)| Some(resolve("Satterthwaite", c, d))).collect();
            (kr, shares, df)
        }
        (Criterion::Reml, Inference::Satterthwaite) => {
            let df = inference::satterthwaite(s, &best, e.sigma2)?;
            let df = df.into_iter().enumerate().map(|(c, d)| Some(resolve("Satterthwaite", c, d))).collect();
            (vec![None; p], Vec::new(), df)
        }
        _ => (vec![None; p], Vec::new(), vec![None; p]),
    };
    let fixed: Vec<FixedEffect> = data
        .fixed_names()
        .into_iter()
        .enumerate()
        .map(|(c, name)| FixedEffect {
            name,
            estimate: e.beta[c],
            se: (e.sigma2 * e.rx_inv[(c, c)]).sqrt(),
            df_satterthwaite: df[c].map(|d: (f64, bool)| d.0),
            satterthwaite_fallback: df[c].is_some_and(|d| d.1),
            kenward_roger: kr[c],
        })
        .collect();
    Ok(MixedFit {
        shares,
        df_satterthwaite: df[0].map(|d| d.0),
        kenward_roger: kr[0],
        notes,
        criterion,
        factors: data.factors.iter().map(|f| f.name.clone()).collect(),
        levels: data.factors.iter().map(|f| f.levels).collect(),
        variances: best.iter().map(|t| e.sigma2 * t * t).collect(),
        singular: best.iter().any(|t| *t < 1e-4),
        theta: best,
        residual: e.sigma2,
        intercept: fixed[0].estimate,
        se: fixed[0].se,
        fixed,
        deviance: e.deviance,
        certificate,
        evaluations,
        dropped: Vec::new(),
        n: data.len(),
    })
}
