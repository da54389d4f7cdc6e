//! A random-slope model and its fit: the terms (`Term`), the data
//! (`SlopeData`), and what a fit holds (`SlopeFit`, its terms' and fixed
//! effects' estimates, the optimizer's `SlopeCertificate`), with the bounds
//! on the dense system; shared by the fit and its parts.

use serde::Serialize;

use crate::mixed::{Criterion, MixedData, MixedError};

/// The most columns one random-effect term may have (a factor's levels
/// with `(f | g)`): 8 columns are 36 covariance parameters.
pub const MAX_TERM_COLUMNS: usize = 8;

/// One random-effect term: a grouping factor and the columns whose
/// coefficients vary over its levels.
#[derive(Debug, Clone, PartialEq)]
pub struct Term {
    /// lme4's name of the grouping factor (`Subject`, `h:g`); in a fitted
    /// model's data, its name in `VarCorr` ([`TermFit::group`]).
    pub group: String,
    /// The grouping factor's name.
    pub factor: String,
    /// Level code per observation, dense from 0.
    pub codes: Vec<usize>,
    /// Levels.
    pub levels: usize,
    /// R's name of each column: `(Intercept)`, `Days`, `MachineB`.
    pub names: Vec<String>,
    /// Each column's value per observation.
    pub columns: Vec<Vec<f64>>,
}

/// A model with random slopes: the response and fixed effects (as
/// [`MixedData`] holds them) and the random-effect terms.
#[derive(Debug, Clone, PartialEq)]
pub struct SlopeData {
    pub(super) base: MixedData,
    pub(super) terms: Vec<Term>,
    /// Prior weights (lmer's `weights`: observation i's residual variance
    /// is sigma^2 / w_i); `None`: all 1.
    pub(super) weights: Option<Vec<f64>>,
}

impl SlopeData {
    /// `base`: the response and fixed effects (its factors are the terms'
    /// grouping factors, which it has validated); `terms`: in the order
    /// written. The terms are put in lme4's order: by decreasing number
    /// of levels when they are not in it already (`mkReTrms`:
    /// `rev(order(nl))`, which reverses ties).
    pub fn new(base: MixedData, terms: Vec<Term>) -> Result<SlopeData, MixedError> {
        let n = base.len();
        for t in &terms {
            if t.codes.len() != n || t.columns.iter().any(|c| c.len() != n) {
                return Err(MixedError::Length { factor: t.group.clone(), found: t.codes.len(), expected: n });
            }
            if t.columns.is_empty() || t.columns.len() > MAX_TERM_COLUMNS {
                return Err(MixedError::TooLarge(format!(
                    "the random term of {} has {} columns; a term may have 1 to {MAX_TERM_COLUMNS}",
                    t.group,
                    t.columns.len()
                )));
            }
            // lme4's check.nobs.vs.nRE: as many random effects as
            // observations cannot be told apart from the residual.
            let effects = t.levels * t.columns.len();
            if effects >= n {
                return Err(MixedError::Unidentifiable {
                    factor: t.group.clone(),
                    reason: format!(
                        "its term has {effects} random effects ({} levels x {} columns) for {n} observations, so they cannot be told apart from the residual (lme4 refuses this too: the number of observations must be > the number of random effects)",
                        t.levels,
                        t.columns.len()
                    ),
                });
            }
        }
        let terms = ordered(terms);
        Ok(SlopeData { base, terms, weights: None })
    }

    /// The data with lmer's prior `weights`: observation i's residual
    /// variance is sigma^2 / w_i. Each weight is finite and above 0 (a
    /// weight of 0 would drop the row: remove it instead).
    pub fn with_weights(mut self, weights: Vec<f64>) -> Result<SlopeData, MixedError> {
        let n = self.base.len();
        if weights.len() != n {
            return Err(MixedError::Length { factor: "weights".into(), found: weights.len(), expected: n });
        }
        if let Some(i) = weights.iter().position(|w| !(w.is_finite() && *w > 0.0 && *w < 1e150)) {
            return Err(MixedError::FixedEffects(format!(
                "observation {}: the weight {} is not a number above 0 (a weight of 0 drops its row: remove the row instead)",
                i + 1,
                weights[i]
            )));
        }
        self.weights = Some(weights);
        Ok(self)
    }

    /// Whether the data carry prior weights.
    pub fn weighted(&self) -> bool {
        self.weights.is_some()
    }

    /// Number of covariance parameters (theta).
    pub fn parameters(&self) -> usize {
        self.terms.iter().map(|t| t.columns.len() * (t.columns.len() + 1) / 2).sum()
    }

    /// The terms, in lme4's order.
    pub fn terms(&self) -> &[Term] {
        &self.terms
    }
}

/// `terms` in lme4's order (by decreasing number of levels when they
/// are not in it already: `mkReTrms`'s `rev(order(nl))`, which reverses
/// ties), named as `VarCorr` names them.
pub(crate) fn ordered(terms: Vec<Term>) -> Vec<Term> {
    let levels: Vec<usize> = terms.iter().map(|t| t.levels).collect();
    let mut terms = terms;
    if levels.windows(2).any(|w| w[1] > w[0]) {
        let mut order: Vec<usize> = (0..levels.len()).collect();
        order.sort_by_key(|&i| levels[i]);
        order.reverse();
        terms = order.into_iter().map(|i| terms[i].clone()).collect();
    }
    let names = varcorr_names(&terms);
    for (t, name) in terms.iter_mut().zip(names) {
        t.group = name;
    }
    terms
}

/// lme4's names of the terms in `VarCorr`: the grouping factors' names,
/// unless one factor has two terms (`(x || g)`), when R's
/// `make.names(unique = TRUE)` makes them distinct: every character other
/// than a letter, digit, `.` or `_` becomes `.`, and the second and later
/// uses of a name get `.1`, `.2`, ...
fn varcorr_names(terms: &[Term]) -> Vec<String> {
    let groups: Vec<&str> = terms.iter().map(|t| t.group.as_str()).collect();
    let repeated = groups.iter().enumerate().any(|(i, g)| groups[..i].contains(g));
    if !repeated {
        return groups.iter().map(|g| g.to_string()).collect();
    }
    let valid: Vec<String> = groups
        .iter()
        .map(|g| {
            let name: String =
                g.chars().map(|c| if c.is_alphanumeric() || c == '.' || c == '_' { c } else { '.' }).collect();
            let first = name.chars().next();
            let second = name.chars().nth(1);
            let needs_x = match first {
                Some(c) if c.is_ascii_digit() || c == '_' => true,
                Some('.') => second.is_some_and(|c| c.is_ascii_digit()),
                None => true,
                _ => false,
            };
            if needs_x {
                format!("X{name}")
            } else {
                name
            }
        })
        .collect();
    // R's make.unique: a name already used gets the first free suffix.
    let mut used: Vec<String> = Vec::new();
    for name in valid {
        let mut candidate = name.clone();
        let mut k = 1;
        while used.contains(&candidate) {
            candidate = format!("{name}.{k}");
            k += 1;
        }
        used.push(candidate);
    }
    used
}

/// One term's estimated covariance, as lme4's `VarCorr` prints it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TermFit {
    /// lme4's name of the term in `VarCorr` (the grouping factor's name,
    /// made unique where a factor has two terms: `Dog`, `Dog.1`).
    pub group: String,
    /// The grouping factor.
    pub factor: String,
    /// Its levels.
    pub levels: usize,
    /// The columns' names.
    pub names: Vec<String>,
    /// Standard deviation of each column's coefficient.
    pub sd: Vec<f64>,
    /// Correlations, row-major lower triangle without the diagonal: (2,1),
    /// (3,1), (3,2), ... `None` where a standard deviation is zero.
    pub correlations: Vec<Option<f64>>,
    /// The covariance matrix, k x k row-major.
    pub covariance: Vec<f64>,
}

/// A fixed effect of a random-slope fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SlopeFixed {
    /// R's name.
    pub name: String,
    /// Estimate.
    pub estimate: f64,
    /// Model-based standard error.
    pub se: f64,
    /// Satterthwaite df (REML fits, when asked).
    pub df_satterthwaite: Option<f64>,
    /// Kenward-Roger's adjusted SE and df (REML fits, when asked).
    pub kenward_roger: Option<crate::mixed::KenwardRoger>,
}

/// The optimizer's certificate for an unconstrained minimum: the
/// gradient and Hessian of the deviance by central differences at the
/// point returned.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SlopeCertificate {
    /// Largest |d deviance / d theta_j|.
    pub gradient: f64,
    /// The decrease a Newton step would still give, g' H^+ g / 2, in
    /// deviance units.
    pub predicted_decrease: f64,
    /// The smallest eigenvalue of the Hessian relative to its largest (a
    /// small negative one is rounding; the certificate fails where moving
    /// along its eigenvector lowers the deviance).
    pub smallest_curvature: f64,
    /// Predicted decrease below 1e-7 of the deviance (at least 1e-6) and
    /// no direction of lower deviance.
    pub certified: bool,
    /// Restarts the certificate asked for.
    pub restarts: usize,
}

/// A fitted random-slope model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SlopeFit {
    /// REML or ML.
    pub criterion: Criterion,
    /// lme4's theta: per term, the lower triangle of T_t column by column,
    /// every diagonal entry non-negative.
    pub theta: Vec<f64>,
    /// Per term, its covariance.
    pub terms: Vec<TermFit>,
    /// Residual variance sigma^2.
    pub residual: f64,
    /// Fixed effects, the intercept first.
    pub fixed: Vec<SlopeFixed>,
    /// REML criterion or ML deviance at the optimum.
    pub deviance: f64,
    /// A diagonal entry of theta below 1e-4.
    pub singular: bool,
    /// The optimizer's certificate.
    pub certificate: SlopeCertificate,
    /// Notes on the inference (a df that could not be computed).
    pub notes: Vec<String>,
    /// Fixed-effect columns dropped as aliased (lme4's rank check).
    pub dropped: Vec<String>,
    /// Deviance evaluations.
    pub evaluations: usize,
    /// Observations.
    pub n: usize,
}
