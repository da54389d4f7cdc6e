//! What a mixed-model fit is: its criterion, inference, result
//! (`MixedFit` and its parts, the optimizer's `Certificate`, Kenward-Roger's
//! adjustment) and errors, shared by the fit and its parts.

use serde::Serialize;

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

/// How much inference `fit_with` computes beyond the estimates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Inference {
    /// Satterthwaite and Kenward-Roger df and the shares (REML), as `fit`.
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
