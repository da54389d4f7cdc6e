//! Stage 1: design text -> [`Ast`] (pest, with spans) -> validated [`Design`].
//!
//! The [`Design`] is the whole preregistered study in typed form: the parts
//! run by later stages (data, split, training) and the analysis compiled by
//! [`crate::pipeline::compile`].

pub mod ast;
mod diagnostic;
pub mod lock;
mod parse;
mod validate;

use std::path::Path;

use serde::Serialize;

pub use ast::{Ast, Cmp, Span};
pub use diagnostic::{DesignError, Diagnostic};
pub use lock::{LockFile, LockStatus};

/// A training seed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(transparent)]
pub struct Seed(pub u64);

/// A duration in seconds.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Serialize)]
#[serde(transparent)]
pub struct Seconds(pub f64);

/// A distance in metres.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Serialize)]
#[serde(transparent)]
pub struct Meters(pub f64);

/// The validated study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Design {
    pub study: String,
    pub data: DataSpec,
    pub recording: RecordingFactor,
    pub seeds: Vec<Seed>,
    pub validation: ValidationSpec,
    pub arms: Vec<Arm>,
    pub models: Vec<Model>,
    /// Present whenever a model has parameters to fit.
    pub training: Option<Training>,
    pub endpoints: Vec<Endpoint>,
    pub contrast: Contrast,
    pub estimator: Estimator,
    pub sensitivity: Sensitivity,
    pub interaction: Option<Interaction>,
    pub decision: DecisionRule,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DataSpec {
    pub source: DataSource,
    pub path: Option<String>,
    pub rate_hz: f64,
    /// Inclusion rules in the order declared; applied in that order.
    pub rules: Vec<InclusionRule>,
    pub duplicates: DuplicatePolicy,
    pub strictness: Strictness,
    pub state_columns: Vec<String>,
    pub action_columns: Vec<String>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DataSource {
    Nanobench,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "rule")]
pub enum InclusionRule {
    /// At least `min_samples` rows with `column cmp threshold`.
    Active { column: String, cmp: Cmp, threshold: f64, min_samples: u64 },
    /// The upstream 0.5/99.5 percentile bounds on battery, setpoint z and PWM.
    Implausible,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DuplicatePolicy {
    /// Identical recordings form one deployment unit for the split.
    Group,
    /// Keep the first of each identical group, exclude the rest.
    First,
    /// Treat identical recordings as independent (the groups are still reported).
    Keep,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Strictness {
    /// Unreadable or corrupt files are excluded with a reason.
    Lenient,
    /// Any exclusion other than a declared rule is an error.
    Strict,
}

/// NanoBench task-2 state convention (shared/nanobench/README.md).
pub const DEFAULT_STATE_COLUMNS: [&str; 14] = [
    "px",
    "py",
    "pz",
    "est_stateEstimate_vx",
    "est_stateEstimate_vy",
    "est_stateEstimate_vz",
    "att_stateEstimate_qw",
    "att_stateEstimate_qx",
    "att_stateEstimate_qy",
    "att_stateEstimate_qz",
    "sp_ctrltarget_x",
    "sp_ctrltarget_y",
    "sp_ctrltarget_z",
    "pwr_pm_vbat",
];

/// NanoBench task-2 action convention: motor PWM / 65535, clipped to [0, 1].
pub const DEFAULT_ACTION_COLUMNS: [&str; 4] = ["motor_motor_m1", "motor_motor_m2", "motor_motor_m3", "motor_motor_m4"];

/// Condition labels a recording carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Condition {
    Trajectory,
    Speed,
}

impl Condition {
    pub fn name(self) -> &'static str {
        match self {
            Condition::Trajectory => "trajectory",
            Condition::Speed => "speed",
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RecordingFactor {
    /// Number of evaluation recordings I.
    pub evaluation: usize,
    pub split_seed: u64,
    /// Rollout starts per evaluation recording.
    pub starts: usize,
    /// Rollout horizon in samples.
    pub horizon: usize,
    pub conditions: Vec<Condition>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ValidationSpec {
    pub windows: usize,
    pub recordings: usize,
    pub seed: u64,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Arm {
    pub name: String,
    pub kind: ArmKind,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum ArmKind {
    /// Windows drawn from recordings outside evaluation and validation.
    Fit { windows: usize, seed: u64 },
    /// Another arm with `percent`% of its windows replaced by evaluation windows.
    Derived { from: String, percent: f64, starts: StartsPolicy, seed: u64 },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StartsPolicy {
    /// Registered rollout starts are never used as contaminating windows.
    Exclude,
    Allow,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Model {
    pub name: String,
    pub kind: ModelKind,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum ModelKind {
    Mlp { widths: Vec<usize>, inputs: InputMap },
    Persistence,
    ConstantVelocity,
}

impl ModelKind {
    pub fn trains(&self) -> bool {
        matches!(self, ModelKind::Mlp { .. })
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InputMap {
    World,
    Relative,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Training {
    pub optimizer: Optimizer,
    pub lr: f64,
    pub batch: usize,
    pub epochs: usize,
    pub schedule: Schedule,
    pub patience: usize,
    pub action_noise: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Optimizer {
    Adam,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Schedule {
    Cosine,
    Constant,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    Primary,
    Secondary,
}

/// The per-cell metrics an endpoint can be built on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Metric {
    FaPositionRmse,
    ConditionalPositionRmse,
    DivergenceRate,
    VelocityRmse,
    AttitudeRmse,
}

impl Metric {
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

    pub fn unit(self) -> &'static str {
        match self {
            Metric::FaPositionRmse | Metric::ConditionalPositionRmse => "m",
            Metric::DivergenceRate => "",
            Metric::VelocityRmse => "m/s",
            Metric::AttitudeRmse => "deg",
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Endpoint {
    pub role: Role,
    pub metric: Metric,
    pub horizons: Vec<Seconds>,
    /// Divergence cap in metres.
    pub cap: Meters,
    pub models: Vec<String>,
}

/// `treated - reference`, e.g. contaminated - disjoint.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Contrast {
    pub treated: String,
    pub reference: String,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Estimator {
    pub kind: EstimatorKind,
    pub level: f64,
    pub df: DfRule,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EstimatorKind {
    /// Two-way crossed random effects, method of moments (ANOVA).
    CrossedMom,
}

pub use crate::stats::DfRule;

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Sensitivity {
    pub bootstrap: Option<BootstrapSpec>,
    pub grouped: Grouped,
    pub leave_one_out: Vec<Factor>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct BootstrapSpec {
    pub replicates: usize,
    pub seed: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Grouped {
    ByConditions,
    Off,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Factor {
    Seed,
    Recording,
}

/// `left - right`: the model difference of the contrast.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Interaction {
    pub left: String,
    pub right: String,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DecisionRule {
    pub name: String,
    pub conditions: Vec<DecisionCondition>,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DecisionCondition {
    pub quantity: Quantity,
    pub cmp: Cmp,
    pub value: f64,
}

/// Quantities of the primary endpoint a decision rule may name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// Apparent optimism in percent.
    Optimism,
    /// Mean difference treated - reference.
    Mean,
    Lower,
    Upper,
}

impl Quantity {
    pub fn name(self) -> &'static str {
        match self {
            Quantity::Optimism => "optimism",
            Quantity::Mean => "mean",
            Quantity::Lower => "lower",
            Quantity::Upper => "upper",
        }
    }
}

/// Parses design text; `file` names it in diagnostics.
pub fn parse(file: &str, source: &str) -> Result<Ast, DesignError> {
    parse::parse(source).map_err(|diagnostics| DesignError {
        file: file.to_string(),
        source_text: source.to_string(),
        diagnostics,
    })
}

/// Validates a parsed design.
pub fn validate(file: &str, source: &str, ast: &Ast) -> Result<Design, DesignError> {
    validate::validate(ast).map_err(|diagnostics| DesignError {
        file: file.to_string(),
        source_text: source.to_string(),
        diagnostics,
    })
}

/// Parse and validate in one call.
pub fn from_str(file: &str, source: &str) -> Result<Design, DesignError> {
    let ast = parse(file, source)?;
    validate(file, source, &ast)
}

/// A design file read from disk, with its bytes kept for hashing and locking.
#[derive(Debug, Clone)]
pub struct DesignFile {
    pub path: std::path::PathBuf,
    pub source: String,
    pub design: Design,
    /// SHA-256 of the file's bytes, lowercase hex.
    pub sha256: String,
}

#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error("cannot read design file {path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{0}")]
    Design(#[from] DesignError),
}

/// Reads, parses and validates a design file.
pub fn load(path: &Path) -> Result<DesignFile, LoadError> {
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io { path: path.display().to_string(), source })?;
    let sha256 = lock::sha256_hex(&bytes);
    let source = String::from_utf8(bytes).map_err(|e| LoadError::Io {
        path: path.display().to_string(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, format!("not UTF-8: {e}")),
    })?;
    let design = from_str(&path.display().to_string(), &source)?;
    Ok(DesignFile { path: path.to_path_buf(), source, design, sha256 })
}
