//! The analysis half of a design: endpoints, the contrast, the estimator,
//! sensitivity analyses and the decision rule.

use super::*;

/// The role of an endpoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// The one endpoint the decision rule reads.
    Primary,
    /// Reported, never decisive.
    Secondary,
}

/// The per-cell metrics an endpoint can be built on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Metric {
    /// Failure-aware position RMSE (diverged rollouts count at the cap), metres.
    FaPositionRmse,
    /// Position RMSE over non-diverged rollouts only, metres.
    ConditionalPositionRmse,
    /// Fraction of rollouts that diverged.
    DivergenceRate,
    /// Velocity RMSE, m/s.
    VelocityRmse,
    /// Attitude RMSE, degrees.
    AttitudeRmse,
}

impl Metric {
    /// Every metric, in per-cell column order.
    pub const ALL: [Metric; 5] = [
        Metric::FaPositionRmse,
        Metric::ConditionalPositionRmse,
        Metric::DivergenceRate,
        Metric::VelocityRmse,
        Metric::AttitudeRmse,
    ];

    /// The name used in designs.
    pub fn name(self) -> &'static str {
        match self {
            Metric::FaPositionRmse => "fa_position_rmse",
            Metric::ConditionalPositionRmse => "conditional_position_rmse",
            Metric::DivergenceRate => "divergence_rate",
            Metric::VelocityRmse => "velocity_rmse",
            Metric::AttitudeRmse => "attitude_rmse",
        }
    }

    /// The per-cell CSV column holding it.
    pub fn column(self) -> &'static str {
        match self {
            Metric::FaPositionRmse => "fa_position_rmse_m",
            Metric::ConditionalPositionRmse => "conditional_position_rmse_m",
            Metric::DivergenceRate => "divergence_rate",
            Metric::VelocityRmse => "velocity_rmse_mps",
            Metric::AttitudeRmse => "attitude_rmse_deg",
        }
    }

    /// Whether it is taken over finite rollouts only, and so is empty in a
    /// cell whose every start diverged (conditional position, velocity and
    /// attitude errors).
    pub fn over_finite_rollouts(self) -> bool {
        matches!(self, Metric::ConditionalPositionRmse | Metric::VelocityRmse | Metric::AttitudeRmse)
    }

    /// The unit printed after a value (empty for a rate).
    pub fn unit(self) -> &'static str {
        match self {
            Metric::FaPositionRmse | Metric::ConditionalPositionRmse => "m",
            Metric::DivergenceRate => "",
            Metric::VelocityRmse => "m/s",
            Metric::AttitudeRmse => "deg",
        }
    }
}

/// An endpoint: a metric at horizons, for some models.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Endpoint {
    /// Primary or secondary.
    pub role: Role,
    /// The per-cell metric.
    pub metric: Metric,
    /// Rollout horizons, seconds.
    pub horizons: Vec<Seconds>,
    /// Divergence cap in metres.
    pub cap: Meters,
    /// The models it is reported for.
    pub models: Vec<String>,
    /// `glmm binomial` (on `divergence_rate`): the diverged starts of each
    /// cell analysed as failures out of its starts by a crossed binomial
    /// GLMM (arm fixed; recording, seed and recording x seed random
    /// intercepts), beside the crossed estimate of the rate.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub glmm: bool,
}

/// `treated - reference`, e.g. contaminated - disjoint.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Contrast {
    /// The arm whose fit set may leak (e.g. `contaminated`).
    pub treated: String,
    /// The arm it is compared with (e.g. `disjoint`).
    pub reference: String,
}

/// The interval estimator of the crossed design.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Estimator {
    /// The estimator.
    pub kind: EstimatorKind,
    /// Confidence level in (0, 1).
    pub level: f64,
    /// Degrees of freedom of the t quantile.
    pub df: DfRule,
    /// Whether per-cell files may lack cells (`missing allow`; REML only).
    /// Each missing cell is listed in the report.
    pub missing_allowed: bool,
}

/// Estimators the language accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EstimatorKind {
    /// Two-way crossed random effects, method of moments (ANOVA).
    CrossedMom,
    /// The same model by restricted maximum likelihood ([`crossaudit_stats::mixed`]):
    /// unbalanced arrays, Kenward-Roger or Satterthwaite df.
    Reml,
}

pub use crossaudit_stats::DfRule;

/// Sensitivity analyses around the primary interval.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Sensitivity {
    /// The pigeonhole bootstrap, if declared.
    pub bootstrap: Option<BootstrapSpec>,
    /// Whether the recording factor is also analysed by condition group.
    pub grouped: Grouped,
    /// Factors each of whose levels is left out in turn.
    pub leave_one_out: Vec<Factor>,
}

/// The pigeonhole bootstrap's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct BootstrapSpec {
    /// Number of replicates B.
    pub replicates: usize,
    /// ChaCha8 seed.
    pub seed: u64,
}

/// Whether the grouped sensitivity runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Grouped {
    /// Recordings grouped by the declared conditions.
    ByConditions,
    /// Not run.
    Off,
}

/// A factor of the crossed design.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Factor {
    /// The training seed (columns).
    Seed,
    /// The evaluation recording (rows).
    Recording,
}

/// `left - right`: the model difference of the contrast.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Interaction {
    /// The first model.
    pub left: String,
    /// The model subtracted from it.
    pub right: String,
}

/// The decision rule: a name and the conditions that must all hold.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DecisionRule {
    /// What the study concludes when every condition holds, e.g. `confirmed`.
    pub name: String,
    /// The estimate the rule is evaluated on.
    #[serde(skip_serializing_if = "DecisionTarget::is_primary")]
    pub on: DecisionTarget,
    /// Conditions joined by `and`.
    pub conditions: Vec<DecisionCondition>,
}

/// One condition of a decision rule, e.g. `upper < 0`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DecisionCondition {
    /// The quantity compared.
    pub quantity: Quantity,
    /// The comparison.
    pub cmp: Cmp,
    /// The value compared with (percent for `optimism`).
    pub value: f64,
}

impl DecisionCondition {
    /// Whether an observed `value` of this condition's quantity meets it.
    pub fn holds(&self, value: f64) -> bool {
        self.cmp.holds(value, self.value)
    }
}

/// The condition as written in a design: `optimism >= 10%`, `upper < 0`.
impl std::fmt::Display for DecisionCondition {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let pct = if self.quantity == Quantity::Optimism { "%" } else { "" };
        write!(f, "{} {} {}{}", self.quantity.name(), self.cmp.symbol(), threshold_text(self.value), pct)
    }
}

/// A threshold as a design would write it: `10`, `0.05`, `-0.02`; in
/// scientific notation where plain digits would run long (`1e300`, not
/// 301 digits; `1e-9`).
fn threshold_text(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-6..1e15).contains(&a) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

impl DecisionRule {
    /// The threshold of the rule's `optimism` condition, if it has one.
    pub fn optimism_threshold(&self) -> Option<f64> {
        self.conditions.iter().find(|c| c.quantity == Quantity::Optimism).map(|c| c.value)
    }
}

/// The rule as written in a design: `confirmed when optimism >= 10% and upper < 0`.
///
/// ```
/// let d = crossaudit::design::from_str("t", include_str!("../../tests/designs/minimal.design")).unwrap();
/// assert!(d.decision.to_string().contains(" when "));
/// ```
impl std::fmt::Display for DecisionRule {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.on {
            DecisionTarget::Primary => write!(f, "{} when ", self.name)?,
            DecisionTarget::Pooled => write!(f, "{} on pooled when ", self.name)?,
            DecisionTarget::Slope => write!(f, "{} on slope when ", self.name)?,
            DecisionTarget::Divergence => write!(f, "{} on divergence when ", self.name)?,
        }
        for (k, c) in self.conditions.iter().enumerate() {
            if k > 0 {
                f.write_str(" and ")?;
            }
            write!(f, "{c}")?;
        }
        Ok(())
    }
}

/// The estimate a decision rule is evaluated on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DecisionTarget {
    /// The primary endpoint's crossed estimate (single split, single dose).
    Primary,
    /// The pooled estimate over splits (`decide NAME on pooled when ...`).
    Pooled,
    /// The slope over doses (`decide NAME on slope when ...`), pooled over
    /// splits in a multi-split design: `mean`, `lower` and `upper` are the
    /// slope of the difference per percentage point of dose, `optimism`
    /// the slope of optimism in percentage points per percentage point.
    Slope,
    /// The binomial GLMM of the divergence endpoint declared `glmm
    /// binomial` (`decide NAME on divergence when ...`): `mean`, `lower`
    /// and `upper` are the log odds ratio of a diverged rollout, treated
    /// arm over reference, and its Wald interval at the estimate's level.
    Divergence,
}

impl DecisionTarget {
    /// Whether the rule is on the primary estimate (the default).
    pub fn is_primary(&self) -> bool {
        *self == DecisionTarget::Primary
    }
}

/// Quantities of the primary endpoint a decision rule may name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// Apparent optimism in percent.
    Optimism,
    /// Mean difference treated - reference.
    Mean,
    /// Lower interval bound of the primary contrast.
    Lower,
    /// Upper interval bound of the primary contrast.
    Upper,
}

impl Quantity {
    /// The name used in designs.
    pub fn name(self) -> &'static str {
        match self {
            Quantity::Optimism => "optimism",
            Quantity::Mean => "mean",
            Quantity::Lower => "lower",
            Quantity::Upper => "upper",
        }
    }
}
