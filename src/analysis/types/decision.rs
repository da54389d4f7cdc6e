//! The decision rule's outcome in `results.json`: the rule applied to the
//! primary unit condition by condition, its margins, and, for one
//! contrast of a family, the family it belongs to.

use serde::{Serialize, Serializer};

use crate::design::{DecisionCondition, DecisionRule, Quantity};

/// The decision rule applied to the primary unit.
#[derive(Debug, Clone, Serialize)]
pub struct Decision {
    /// The rule's name (e.g. `confirmed`).
    pub name: String,
    /// The rule as data; written in the design's own syntax.
    #[serde(serialize_with = "as_text")]
    pub rule: DecisionRule,
    /// The primary unit's label.
    pub unit: String,
    /// The unit of the mean and the interval the rule reads: the metric's
    /// (`m`), or per percentage point of dose for a slope (`m/pp`); empty
    /// for a rate.
    pub value_unit: String,
    /// The unit of the optimism the rule reads: `%`, or `%/pp` for a slope.
    pub optimism_unit: String,
    /// Whether every condition holds.
    pub holds: bool,
    /// Each condition with the observed value.
    pub conditions: Vec<ConditionOutcome>,
    /// The conditions whose threshold lies inside the interval of the
    /// quantity they read: the verdict is the rule's, but the
    /// data do not determine on which side of that threshold the quantity
    /// lies.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub margins: Vec<Margin>,
    /// When the rule holds without reading any interval bound (`lower`,
    /// `upper`) while the interval of d contains 0: that interval.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unguarded: Option<[f64; 2]>,
    /// Where this is one contrast of a family (a dose, a split): what the
    /// family's rule decides on, and its verdict. The rule applied to this
    /// contrast alone is then descriptive: no verdict is this contrast's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub member_of: Option<MemberOf>,
}

/// The family a descriptive contrast belongs to ([`Decision::member_of`]).
#[derive(Debug, Clone, Serialize)]
pub struct MemberOf {
    /// This contrast in the family: `dose contaminated_5pct`, `split 42`.
    pub contrast: String,
    /// What the family's rule reads (`slope over doses: world ...`).
    pub decides_on: String,
    /// The family's verdict (`NOT GROWS`).
    pub verdict: String,
    /// The family's report.md, relative to this contrast's report folder.
    pub report: String,
}

/// A condition whose threshold the data do not place on one side.
#[derive(Debug, Clone, Serialize)]
pub struct Margin {
    /// The condition as written.
    #[serde(serialize_with = "as_text")]
    pub condition: DecisionCondition,
    /// The interval of the quantity it reads, in its unit; `None` for a
    /// bound the data do not give (Fieller's set unbounded).
    pub lower: Option<f64>,
    /// Upper bound, as `lower`.
    pub upper: Option<f64>,
    /// Which interval: `fieller` (optimism) or `crossed` (the mean's).
    pub interval: &'static str,
}

/// One condition of the rule and what was observed.
#[derive(Debug, Clone, Serialize)]
pub struct ConditionOutcome {
    /// The condition as data; written in the design's own syntax.
    #[serde(serialize_with = "as_text")]
    pub condition: DecisionCondition,
    /// The quantity it names.
    pub quantity: Quantity,
    /// The observed value of that quantity.
    pub value: f64,
    /// Whether the condition holds.
    pub holds: bool,
}

fn as_text<T: std::fmt::Display, S: Serializer>(value: &T, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(value)
}
