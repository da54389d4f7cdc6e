//! Stage 1: design text -> [`Ast`] (pest, with spans) -> validated [`Design`].
//!
//! The [`Design`] is the whole preregistered study in typed form: the parts
//! run by later stages (data, split, training) and the analysis compiled by
//! [`crate::plan::compile`].

mod ast;
mod diagnostic;
pub mod lock;
mod parse;
mod validate;

use std::path::Path;

use serde::{Deserialize, Serialize};

pub use ast::{Ast, Cmp, Span};
pub use diagnostic::{DesignError, Diagnostic};
pub use lock::{LockFile, LockStatus};

/// A training seed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
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
    /// The study name (`study NAME`).
    pub study: String,
    /// The data declaration.
    pub data: DataSpec,
    /// The recording factor: evaluation size, starts, horizon, conditions.
    pub recording: RecordingFactor,
    /// The seed factor, in declaration order.
    pub seeds: Vec<Seed>,
    /// The shared validation set.
    pub validation: ValidationSpec,
    /// The arms, in declaration order.
    pub arms: Vec<Arm>,
    /// The models, in declaration order.
    pub models: Vec<Model>,
    /// Present whenever a model has parameters to fit.
    pub training: Option<Training>,
    /// Primary and secondary endpoints.
    pub endpoints: Vec<Endpoint>,
    /// The arm contrast of every endpoint.
    pub contrast: Contrast,
    /// The interval estimator of every endpoint.
    pub estimator: Estimator,
    /// Sensitivity analyses around the primary.
    pub sensitivity: Sensitivity,
    /// The model difference of the contrast, if declared.
    pub interaction: Option<Interaction>,
    /// The preregistered decision rule on the primary endpoint.
    pub decision: DecisionRule,
    /// The generator of every split draw.
    pub generator: Generator,
    /// A benchmark's published split, when the design pins one instead of
    /// drawing (`split published "FILE" { ... }`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub published: Option<PublishedPin>,
    /// The split factor (`factor split = 42..46`): one whole split per
    /// value; empty for a single-split design.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub splits: Vec<u64>,
}

impl Design {
    /// The single-split design that split `split` of a multi-split design
    /// runs: its evaluation draw seeded with `split`, and the validation,
    /// fit and contamination seeds each shifted by `split - split_seed`, so
    /// that the split equal to `split_seed` is the single-split design
    /// itself. Validation keeps every shifted seed in range.
    pub fn for_split(&self, split: u64) -> Design {
        let shift = |seed: u64| -> u64 { (seed as i128 + split as i128 - self.recording.split_seed as i128) as u64 };
        let mut d = self.clone();
        d.splits = Vec::new();
        d.recording.split_seed = split;
        d.validation.seed = shift(self.validation.seed);
        for a in &mut d.arms {
            match &mut a.kind {
                ArmKind::Fit { seed, .. } | ArmKind::Derived { seed, .. } => *seed = shift(*seed),
            }
        }
        d
    }

    /// The dose-response arms of the contrast's treated family, by
    /// increasing dose: (arm name, percent). Empty unless the treated arm
    /// was declared with several doses.
    pub fn doses(&self) -> Vec<(String, f64)> {
        let mut out: Vec<(String, f64)> = self
            .arms
            .iter()
            .filter_map(|a| match &a.kind {
                ArmKind::Derived { percent, family: Some(f), .. } if *f == self.contrast.treated => {
                    Some((a.name.clone(), *percent))
                }
                _ => None,
            })
            .collect();
        out.sort_by(|a, b| a.1.total_cmp(&b.1));
        out
    }
}

/// The arm name of one dose of a dose-response family: `contaminated` at
/// 5% is `contaminated_5pct`, at 2.5% `contaminated_2p5pct`.
pub fn dose_arm_name(family: &str, percent: f64) -> String {
    format!("{family}_{}pct", percent.to_string().replace('.', "p"))
}

/// What a pinned published split does with a fit recording that is
/// byte-identical to an evaluation or validation recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LeakPolicy {
    /// Such a split is an error (the default).
    Refuse,
    /// The copy leaves the fit pool; manifests/fit_leaked_dropped.csv lists it.
    Drop,
}

/// A published split pinned by the design: its evaluation and validation
/// roles fill [`RecordingFactor::listed`] and [`ValidationSpec::listed`],
/// its fit roles [`PublishedPin::fit`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PublishedPin {
    /// The split file as written in the design.
    pub file: String,
    /// SHA-256 of the split file when the design was loaded.
    pub sha256: String,
    /// The split file's format.
    pub format: crate::published::Format,
    /// Roles whose recordings are evaluated.
    pub evaluation_roles: Vec<String>,
    /// Roles whose recordings give the validation windows.
    pub validation_roles: Vec<String>,
    /// Roles whose recordings the fit windows come from.
    pub fit_roles: Vec<String>,
    /// Roles left out of the study.
    pub ignored_roles: Vec<String>,
    /// Fit recordings identical to an evaluation or validation one.
    pub leaked: LeakPolicy,
    /// The fit recordings, in file order.
    pub fit: Vec<ListedName>,
}

/// The generator of the split's draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Generator {
    /// ChaCha8 streams seeded from the design (one stream per draw).
    Chacha8,
    /// numpy's legacy `RandomState(seed)`, bit for bit: one state per
    /// declared seed, its draws made in a fixed order (see `split`).
    NumpyLegacy,
}

/// A recording name written in the design, with its byte offset there (for
/// located errors when the data do not hold it).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ListedName {
    /// The recording name.
    pub name: String,
    /// Byte offset of the quoted name in the design source.
    #[serde(skip)]
    pub offset: usize,
    /// For a name read from a published split file: the file, line and column.
    #[serde(skip)]
    pub at: Option<(String, usize, usize)>,
}

/// The design's `data` block: where the logs come from and which rows count.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DataSpec {
    /// NanoBench logs on disk or the built-in simulator.
    pub source: DataSource,
    /// Data directory as written in the design, if any.
    pub path: Option<String>,
    /// Sample rate the logs are read at, Hz.
    pub rate_hz: f64,
    /// Inclusion rules in the order declared; applied in that order.
    pub rules: Vec<InclusionRule>,
    /// How byte-identical recordings are treated.
    pub duplicates: DuplicatePolicy,
    /// Whether unreadable files are excluded or an error.
    pub strictness: Strictness,
    /// The 14 state columns, in model order.
    pub state_columns: Vec<String>,
    /// The 4 action columns, in model order.
    pub action_columns: Vec<String>,
    /// The named state preset, when the design used one.
    pub state_preset: Option<StatePreset>,
    /// What to do with extrapolated onboard tails.
    pub tails: TailPolicy,
    /// Where the speed labels come from.
    pub speed: SpeedLabels,
    /// How the plausibility rule takes the motor percentiles.
    pub plausibility: Pooling,
    /// Which recordings a split draws from, in which order.
    pub universe: Universe,
    /// Whether drawn evaluation or validation recordings without a CSV may
    /// be left out (`missing csv allow`) instead of stopping the study.
    pub missing_csv_allowed: bool,
    /// For `data simulated`: what to generate.
    pub simulated: Option<SimSpec>,
}

impl DataSpec {
    /// The rules of upstream NanoBench's task-2 loader
    /// (shared/nanobench/README.md): rows with `motor_motor_m1 > 1000` are
    /// active, a file needs at least one, and whole files failing the
    /// percentile plausibility bounds (motors pooled) are dropped; the
    /// task-2 state columns; identical files and onboard tails kept; speed
    /// from the file name. What the split audit applies when no design is given.
    pub fn upstream_task2() -> DataSpec {
        DataSpec {
            rules: vec![
                InclusionRule::Active {
                    column: "motor_motor_m1".into(),
                    cmp: Cmp::Gt,
                    threshold: 1000.0,
                    min_samples: 1,
                },
                InclusionRule::Implausible,
            ],
            ..DataSpec::nanobench_defaults()
        }
    }

    /// What a `data nanobench { }` block declares when it says nothing: no
    /// inclusion rule, the task-2 state and action columns, 100 Hz,
    /// identical files and onboard tails kept, speed from the file name, the
    /// included CSVs as the universe in natural order.
    pub fn nanobench_defaults() -> DataSpec {
        DataSpec {
            source: DataSource::Nanobench,
            path: None,
            rate_hz: 100.0,
            rules: Vec::new(),
            duplicates: DuplicatePolicy::Keep,
            strictness: Strictness::Lenient,
            state_columns: DEFAULT_STATE_COLUMNS.iter().map(|c| c.to_string()).collect(),
            action_columns: DEFAULT_ACTION_COLUMNS.iter().map(|c| c.to_string()).collect(),
            state_preset: Some(StatePreset::Onboard),
            tails: TailPolicy::Keep,
            speed: SpeedLabels::Name,
            plausibility: Pooling::Pooled,
            universe: Universe { metadata: false, bytewise: false },
            missing_csv_allowed: false,
            simulated: None,
        }
    }
}

/// Named state-column conventions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StatePreset {
    /// NanoBench task 2: Vicon position, onboard-estimator velocity and attitude.
    Onboard,
    /// Vicon position, velocity and quaternion.
    MotionCapture,
}

impl StatePreset {
    /// The preset's 14 columns.
    pub fn columns(self) -> [&'static str; 14] {
        match self {
            StatePreset::Onboard => DEFAULT_STATE_COLUMNS,
            StatePreset::MotionCapture => MOTION_CAPTURE_STATE_COLUMNS,
        }
    }

    /// The name written in designs.
    pub fn name(self) -> &'static str {
        match self {
            StatePreset::Onboard => "onboard",
            StatePreset::MotionCapture => "motion_capture",
        }
    }
}

/// What happens to a log whose onboard streams end before its last row
/// (the rows after are extrapolated by the upstream merge).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TailPolicy {
    /// Use every row (upstream and the paper).
    Keep,
    /// Exclude the file.
    Exclude,
    /// Cut the log where its onboard streams end.
    Truncate,
}

/// Where a recording's speed label comes from.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "from")]
pub enum SpeedLabels {
    /// The file name's token (slow, medium, fast), `unknown` without one.
    Name,
    /// Metadata `params.speed_mps`: `labels[k]` below `thresholds[k]`, the
    /// last label at or above the last threshold; `unknown` without a speed.
    Metadata {
        /// One more label than thresholds.
        labels: Vec<String>,
        /// Ascending thresholds, m/s.
        thresholds: Vec<f64>,
    },
}

impl SpeedLabels {
    /// The label of a metadata speed (or of its absence).
    pub fn label(labels: &[String], thresholds: &[f64], speed_mps: Option<f64>) -> String {
        match speed_mps {
            None => "unknown".to_string(),
            Some(v) => labels[thresholds.iter().take_while(|t| v >= **t).count()].clone(),
        }
    }
}

/// How the plausibility rule treats the four motor columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Pooling {
    /// One percentile over all four motors' values (upstream's `np.nanpercentile` over the N x 4 array).
    Pooled,
    /// One percentile per motor.
    PerColumn,
}

/// The recordings a split draws from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Universe {
    /// Whether names listed only by a metadata file take part.
    pub metadata: bool,
    /// `natural` (rep2 before rep10) or `bytewise` (Python's `sorted`).
    pub bytewise: bool,
}

/// What to simulate (the design's `data simulated { ... }`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SimSpec {
    /// Number of recordings to generate.
    pub recordings: usize,
    /// Seed of the simulator's ChaCha8 streams (one stream per recording).
    pub seed: u64,
    /// Recording-specific structure: 0 = exchangeable recordings.
    pub strength: f64,
    /// Seconds of trajectory per recording (plus take-off and landing).
    pub duration_s: f64,
}

/// Where the recordings come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DataSource {
    /// NanoBench task-2 logs in a directory.
    Nanobench,
    /// Generated by the built-in Crazyflie simulator, in the NanoBench schema.
    Simulated,
}

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
}

/// How byte-identical recordings (one identity group) are treated.
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

/// What happens to files that cannot be read.
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

/// Vicon velocity and quaternion in the task-2 layout (position, velocity,
/// quaternion w-first, setpoint, battery).
pub const MOTION_CAPTURE_STATE_COLUMNS: [&str; 14] = [
    "px",
    "py",
    "pz",
    "vx",
    "vy",
    "vz",
    "qw",
    "qx",
    "qy",
    "qz",
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
    /// By trajectory shape.
    Trajectory,
    /// By speed token.
    Speed,
}

impl Condition {
    /// The name used in designs and reports.
    pub fn name(self) -> &'static str {
        match self {
            Condition::Trajectory => "trajectory",
            Condition::Speed => "speed",
        }
    }
}

/// The recording factor of the crossed design.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RecordingFactor {
    /// Number of evaluation recordings I.
    pub evaluation: usize,
    /// Seed of the evaluation-recording draw.
    pub split_seed: u64,
    /// Rollout starts per evaluation recording.
    pub starts: usize,
    /// Rollout horizon in samples.
    pub horizon: usize,
    /// Condition labels whose groups the grouped sensitivity resamples.
    pub conditions: Vec<Condition>,
    /// A pinned evaluation set (`evaluation recordings "..."`); empty when drawn.
    pub listed: Vec<ListedName>,
}

/// The shared early-stopping validation set.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ValidationSpec {
    /// Number of one-step windows.
    pub windows: usize,
    /// Number of recordings they are drawn from.
    pub recordings: usize,
    /// Seed of the draw.
    pub seed: u64,
    /// Pinned validation recordings; empty when drawn.
    pub listed: Vec<ListedName>,
}

/// A training-data arm.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Arm {
    /// Arm name, e.g. `disjoint`.
    pub name: String,
    /// How its fit set is built.
    pub kind: ArmKind,
}

/// How an arm's fit set is built.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum ArmKind {
    /// Windows drawn from recordings outside evaluation and validation.
    /// `windows` drawn with `seed` from the fitting recordings.
    Fit {
        /// Number of fit windows.
        windows: usize,
        /// ChaCha8 seed of the draw.
        seed: u64,
    },
    /// Another arm with `percent`% of its windows replaced by evaluation windows.
    /// Arm `from` with `percent`% of its windows replaced (ChaCha8 `seed`).
    Derived {
        /// The arm it is derived from.
        from: String,
        /// Percentage of windows replaced.
        percent: f64,
        /// Whether registered starts may be used.
        starts: StartsPolicy,
        /// ChaCha8 seed of the draw.
        seed: u64,
        /// The dose-response family the arm belongs to (`replace 1%, 5%`
        /// declares one arm per dose, named by [`dose_arm_name`]): the
        /// family's doses are nested, each replacing a prefix of one draw.
        #[serde(skip_serializing_if = "Option::is_none")]
        family: Option<String>,
    },
}

/// Whether contaminating windows may start at registered rollout starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StartsPolicy {
    /// Registered rollout starts are never used as contaminating windows.
    Exclude,
    /// Any evaluation window may be used.
    Allow,
}

/// A dynamics model to evaluate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Model {
    /// Model name, e.g. `world`.
    pub name: String,
    /// What the model is.
    pub kind: ModelKind,
}

/// The kinds of model the language knows.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum ModelKind {
    /// A trained MLP with hidden `widths`, fed through `inputs`.
    Mlp {
        /// Hidden-layer widths.
        widths: Vec<usize>,
        /// The input map.
        inputs: InputMap,
        /// How the actions enter.
        actions: ActionScaling,
    },
    /// Predicts no change.
    Persistence,
    /// Integrates the current velocity.
    ConstantVelocity,
}

/// Hidden-layer widths the language accepts: an `mlp(w, w, w)` of three
/// equal widths from this list. Part of the language so that validation
/// needs no model code; `model::net` has one network type per entry.
pub const MLP_WIDTHS: [usize; 3] = [32, 64, 256];

/// Whether `widths` is an architecture the language accepts.
pub fn mlp_supported(widths: &[usize]) -> bool {
    widths.len() == 3 && widths.iter().all(|w| *w == widths[0]) && MLP_WIDTHS.contains(&widths[0])
}

impl ModelKind {
    /// Whether the model has parameters to fit (one training job per arm x seed).
    pub fn trains(&self) -> bool {
        matches!(self, ModelKind::Mlp { .. })
    }
}

/// The input map of an MLP.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InputMap {
    /// Absolute world-frame state.
    World,
    /// Position-free, body-relative state.
    Relative,
}

/// How the actions u in [0, 1] enter a network.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ActionScaling {
    /// As they are (the paper).
    Raw,
    /// Through the model's input standardizer.
    Standardized,
}

/// What the network predicts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TargetKind {
    /// The paper's dz = S(x_{t+1}) - S(x_t) = (x_{t+1} - x_t) / sd_x.
    StateScaled,
    /// The increment through its own mean and SD.
    Standardized,
}

/// The training block shared by every trained model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Training {
    /// The optimizer.
    pub optimizer: Optimizer,
    /// Peak learning rate.
    pub lr: f64,
    /// Minibatch size.
    pub batch: usize,
    /// Maximum number of epochs.
    pub epochs: usize,
    /// Learning-rate schedule.
    pub schedule: Schedule,
    /// Epochs without validation improvement before stopping.
    pub patience: usize,
    /// SD of the Gaussian noise added to actions during training.
    pub action_noise: f64,
    /// What the networks predict.
    pub target: TargetKind,
}

/// Optimizers the language accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Optimizer {
    /// Adam with dfdx's defaults.
    Adam,
}

/// Learning-rate schedules.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Schedule {
    /// Cosine decay from `lr` over `epochs`.
    Cosine,
    /// Constant `lr`.
    Constant,
}

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
    /// The same model by restricted maximum likelihood ([`crate::stats::mixed`]):
    /// unbalanced arrays, Kenward-Roger or Satterthwaite df.
    Reml,
}

pub use crate::stats::DfRule;

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
        write!(f, "{} {} {}{}", self.quantity.name(), self.cmp.symbol(), self.value, pct)
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

/// Parses design text; `file` names it in diagnostics.
pub(crate) fn parse(file: &str, source: &str) -> Result<Ast, DesignError> {
    parse::parse(source).map_err(|diagnostics| DesignError {
        file: file.to_string(),
        source_text: source.to_string(),
        diagnostics,
    })
}

/// Validates a parsed design.
pub(crate) fn validate(file: &str, source: &str, ast: &Ast, base: &Path) -> Result<Design, DesignError> {
    validate::validate(ast, base).map_err(|diagnostics| DesignError {
        file: file.to_string(),
        source_text: source.to_string(),
        diagnostics,
    })
}

/// Parse and validate in one call. A `split published` file is read
/// relative to the current directory.
pub fn from_str(file: &str, source: &str) -> Result<Design, DesignError> {
    from_str_in(file, source, Path::new(""))
}

/// As [`from_str`], reading a `split published` file relative to `base`.
pub fn from_str_in(file: &str, source: &str, base: &Path) -> Result<Design, DesignError> {
    // pest and the diagnostics count lines by `\n`; a file saved with
    // lone `\r` line endings is read as the lines an editor shows.
    let source = &*crate::io::lone_cr_to_lf(source);
    let ast = parse(file, source)?;
    validate(file, source, &ast, base)
}

/// A design file read from disk, with its bytes kept for hashing and locking.
#[derive(Debug, Clone)]
pub struct DesignFile {
    /// Where it was read from.
    pub path: std::path::PathBuf,
    /// Its text.
    pub source: String,
    /// The validated design.
    pub design: Design,
    /// SHA-256 of the file's bytes, lowercase hex.
    pub sha256: String,
}

/// Why a design file could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read.
    #[error("cannot read design file {path}: {source}")]
    Io {
        /// The path.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The text is not a valid design.
    #[error("{0}")]
    Design(#[from] DesignError),
}

/// Reads, parses and validates a design file.
pub fn load(path: &Path) -> Result<DesignFile, LoadError> {
    load_copy(path, path)
}

/// Reads a verbatim copy of the design `original` from `copy`: its bytes
/// and hash are the copy's, while errors, the lock and a `split published`
/// file are looked up as for `original`. A run prepared for a cluster keeps
/// such a copy, so its jobs run the design as it was prepared.
pub fn load_copy(copy: &Path, original: &Path) -> Result<DesignFile, LoadError> {
    let bytes = crate::io::read_input(copy, crate::io::MAX_SMALL_TEXT, "a design file")
        .map_err(|e| LoadError::Io { path: copy.display().to_string(), source: e.into_io() })?;
    let path = original;
    let sha256 = crate::io::sha256_hex(&bytes);
    let source = String::from_utf8(bytes).map_err(|e| LoadError::Io {
        path: path.display().to_string(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, format!("not UTF-8: {e}")),
    })?;
    // Editors that save a UTF-8 byte-order mark hide it; columns are
    // counted as the editor shows them, after it. The hash covers the bytes.
    let source = match source.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => source,
    };
    // A published split file is read relative to the design file.
    let base = path.parent().unwrap_or(Path::new(""));
    let design = from_str_in(&path.display().to_string(), &source, base)?;
    Ok(DesignFile { path: path.to_path_buf(), source, design, sha256 })
}
