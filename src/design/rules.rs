//! The rules that decide which recordings and rows count: the inclusion
//! rules applied in order, and the declared policies for missing values
//! and time gaps.

use serde::Serialize;

/// A rule a recording must pass to be included.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "rule")]
pub enum InclusionRule {
    /// At least `min_samples` rows with `column cmp threshold`.
    Active {
        /// Schema column tested.
        column: String,
        /// The comparison.
        cmp: Cmp,
        /// The threshold.
        threshold: f64,
        /// Minimum number of rows that must meet it.
        min_samples: u64,
    },
    /// The upstream 0.5/99.5 percentile bounds on battery, setpoint z and PWM.
    Implausible,
    /// Recordings left out by name (`exclude recordings`).
    Named {
        /// The recording names.
        names: Vec<String>,
    },
    /// A position unchanged for `seconds` of active rows while an action
    /// changes (`exclude frozen position for T s`).
    Frozen {
        /// The shortest frozen stretch that excludes, seconds.
        seconds: f64,
    },
    /// An active row beyond a bound (`exclude beyond position L m`,
    /// `exclude beyond speed L m/s`, `exclude beyond rate L rad/s`).
    Beyond {
        /// What is bounded.
        quantity: Bound,
        /// The bound, in the quantity's unit.
        limit: f64,
    },
}

/// What an `exclude beyond` rule bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Bound {
    /// Each position component's magnitude, metres.
    Position,
    /// The speed, metres per second.
    Speed,
    /// The attitude's rate of turn, radians per second.
    Rate,
}

impl Bound {
    /// The keyword and unit as the design writes them.
    pub fn words(self) -> (&'static str, &'static str) {
        match self {
            Bound::Position => ("position", "m"),
            Bound::Speed => ("speed", "m/s"),
            Bound::Rate => ("rate", "rad/s"),
        }
    }
}

/// What a declared policy does with a missing value or a time gap.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CutPolicy {
    /// Stop the audit at the line and column.
    Refuse,
    /// Leave the recording out by this rule, listed in the audit.
    Exclude,
    /// Keep the recording; the affected rows start and end no window, so
    /// it is used as segments (never split across arms: one recording).
    Segment,
}

impl CutPolicy {
    /// The keyword as the design writes it.
    pub fn word(self) -> &'static str {
        match self {
            CutPolicy::Refuse => "refuse",
            CutPolicy::Exclude => "exclude",
            CutPolicy::Segment => "segment",
        }
    }
}

/// `gaps over T s P`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GapPolicy {
    /// The longest step between rows that is not a gap, seconds.
    pub over_s: f64,
    /// What a longer one does.
    pub policy: CutPolicy,
}

/// A comparison operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Cmp {
    /// `>=`
    #[serde(rename = ">=")]
    Ge,
    /// `<=`
    #[serde(rename = "<=")]
    Le,
    /// `>`
    #[serde(rename = ">")]
    Gt,
    /// `<`
    #[serde(rename = "<")]
    Lt,
}

impl Cmp {
    /// Whether `lhs <op> rhs`.
    pub fn holds(self, lhs: f64, rhs: f64) -> bool {
        match self {
            Cmp::Ge => lhs >= rhs,
            Cmp::Le => lhs <= rhs,
            Cmp::Gt => lhs > rhs,
            Cmp::Lt => lhs < rhs,
        }
    }

    /// The operator as written.
    pub fn symbol(self) -> &'static str {
        match self {
            Cmp::Ge => ">=",
            Cmp::Le => "<=",
            Cmp::Gt => ">",
            Cmp::Lt => "<",
        }
    }
}
