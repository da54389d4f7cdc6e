//! The design's `data` block: where the logs come from, which rows and
//! recordings count, the column conventions and the simulator's settings.

use super::*;
use std::collections::BTreeMap;

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
    /// How identical recordings (the same values read) are treated.
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
    /// For `data csv`: the declared columns. `None` for NanoBench and the
    /// simulator, whose logs are read by the NanoBench preset
    /// ([`DataSpec::log_format`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub format: Option<LogFormat>,
    /// `missing values P`: what a non-finite or empty value in a declared
    /// column does; `None`: the file is unreadable.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub missing_values: Option<CutPolicy>,
    /// `gaps over T s P`: what a time gap longer than T does; `None`: a
    /// step longer than [`crate::data::MAX_GAP_STEPS`] samples makes the
    /// file unreadable.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gaps: Option<GapPolicy>,
    /// `require at least N recordings`: the fewest the audit may keep.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub require_kept: Option<u64>,
}

/// How a flight log's columns become a recording: the one reader behind
/// `data csv` and, as a preset, `data nanobench` and `data simulated`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LogFormat {
    /// Whether the header must be NanoBench's 52 columns exactly (the
    /// preset, every field checked as a number), or any header holding the
    /// declared columns (only they are read).
    pub nanobench_header: bool,
    /// The time column, seconds; without one, row k is at k / rate.
    pub time: Option<String>,
    /// The column read into each of the model's state slots: position,
    /// velocity (when declared), quaternion w x y z (when an attitude is
    /// declared), body rates and further predicted columns (the first
    /// [`LogFormat::predicted`]), then the exogenous reference and extra
    /// columns (NanoBench's 14: position, velocity, quaternion, reference,
    /// battery). `None` is the quaternion computed from [`LogFormat::euler`].
    pub state: Vec<Option<String>>,
    /// Whether slots 3..6 are the velocity (`velocity` declared).
    #[serde(skip_serializing_if = "is_true")]
    pub velocity: bool,
    /// Whether an attitude is declared: the four slots after the velocity
    /// (or after the position without one) are its unit quaternion.
    #[serde(skip_serializing_if = "is_true")]
    pub attitude: bool,
    /// State slots the model predicts (the first ones; NanoBench: 10).
    pub predicted: usize,
    /// Whether the three slots after the predicted ones are the position
    /// reference.
    pub reference: bool,
    /// Euler angles (roll, pitch, yaw; Z-Y-X) turned into the quaternion slots.
    pub euler: Option<Euler>,
    /// `norm within T`: a logged quaternion's length may be within T of 1,
    /// and every row's quaternion is divided by its length. Without it the
    /// length must be within 0.01 and is used as logged.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub quaternion_tolerance: Option<f64>,
    /// State slots whose zeros are filled with the reading before them.
    pub fill_zeros: Vec<usize>,
    /// The action columns (NanoBench: 4).
    pub actions: Vec<String>,
    /// Each action is the column's value / this, clipped to [0, 1].
    pub action_scale: f64,
    /// Columns whose final straight run marks an extrapolated tail.
    pub extrapolated: Vec<String>,
    /// The controller every log was flown with (`controller NAME`), for
    /// the audit; without it, NanoBench's names: `_mell` is Mellinger,
    /// anything else its PID.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub controller: Option<String>,
    /// Whether recordings are found in the data folder's subfolders too
    /// (`folders nested`).
    #[serde(skip_serializing_if = "is_false")]
    pub nested_folders: bool,
    /// A CSV table in the data folder giving each recording's trajectory
    /// and speed (`conditions table "FILE"`), instead of the file names.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conditions_table: Option<String>,
    /// A pattern giving each recording's trajectory and speed from its
    /// file name (`conditions name "PATTERN"`; see [`NamePattern`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conditions_name: Option<String>,
    /// The conditions table's columns under other names
    /// (`columns recording = run_id, ...`): role to column.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub conditions_columns: BTreeMap<String, String>,
    /// The condition each recording's first folder gives
    /// (`conditions folder trajectory|speed`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conditions_folder: Option<Condition>,
}

impl LogFormat {
    /// The state and action layout these columns make.
    pub fn slots(&self) -> Slots {
        Slots {
            state: self.state.len(),
            action: self.actions.len(),
            predicted: self.predicted,
            reference: self.reference,
            velocity: self.velocity,
            attitude: self.attitude,
        }
    }
}

/// Euler-angle attitude columns.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Euler {
    /// Roll, pitch and yaw columns.
    pub columns: Vec<String>,
    /// Degrees (else radians).
    pub degrees: bool,
}

/// The columns the NanoBench preset reads for the extrapolated-tail rule:
/// the onboard estimator's velocity and quaternion.
pub const NANOBENCH_EXTRAPOLATED: [&str; 7] = [
    "est_stateEstimate_vx",
    "est_stateEstimate_vy",
    "est_stateEstimate_vz",
    "att_stateEstimate_qw",
    "att_stateEstimate_qx",
    "att_stateEstimate_qy",
    "att_stateEstimate_qz",
];

/// NanoBench's action full scale: 16-bit motor PWM.
pub const NANOBENCH_ACTION_SCALE: f64 = 65535.0;

impl DataSpec {
    /// Every speed label the data block can give a recording (the file
    /// name's token, or the metadata speed's labels, and `unknown`).
    pub fn speed_labels(&self) -> Vec<String> {
        match &self.speed {
            SpeedLabels::Name => ["slow", "medium", "fast", "unknown"].map(String::from).to_vec(),
            SpeedLabels::Metadata { labels, .. } => {
                labels.iter().cloned().chain(std::iter::once("unknown".to_string())).collect()
            }
        }
    }

    /// The layout of the state and action the data declares: its state
    /// columns and actions, the predicted ones first.
    pub fn slots(&self) -> Slots {
        self.log_format().slots()
    }

    /// Each action is the column's value / this (NanoBench's PWM: 65535).
    pub fn action_scale(&self) -> f64 {
        self.format.as_ref().map_or(NANOBENCH_ACTION_SCALE, |f| f.action_scale)
    }

    /// The format its logs are read in: the declared one (`data csv`), or
    /// the NanoBench preset over the state and action columns (the time
    /// column `t`, the 14 state columns read as they are with the battery
    /// `pwr_pm_vbat`'s zeros filled, PWM / 65535, the onboard columns'
    /// extrapolated tails).
    pub fn log_format(&self) -> LogFormat {
        if let Some(f) = &self.format {
            return f.clone();
        }
        LogFormat {
            nanobench_header: true,
            time: Some("t".into()),
            state: self.state_columns.iter().map(|c| Some(c.clone())).collect(),
            velocity: true,
            attitude: true,
            euler: None,
            quaternion_tolerance: None,
            predicted: 10,
            reference: true,
            fill_zeros: self.state_columns.iter().position(|c| c == "pwr_pm_vbat").into_iter().collect(),
            actions: self.action_columns.clone(),
            action_scale: self.action_scale(),
            // The simulator writes no extrapolated tails (its onboard
            // columns are still at rest after landing: straight, not a tail).
            extrapolated: match self.source {
                DataSource::Nanobench => NANOBENCH_EXTRAPOLATED.iter().map(|c| c.to_string()).collect(),
                _ => Vec::new(),
            },
            controller: None,
            nested_folders: false,
            conditions_table: None,
            conditions_name: None,
            conditions_columns: BTreeMap::new(),
            conditions_folder: None,
        }
    }
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
            format: None,
            missing_values: None,
            gaps: None,
            require_kept: None,
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
    /// Any CSV logs whose columns the design declares.
    Csv,
}

/// How identical recordings (the same values read: one identity group) are treated.
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

/// The state and action layout a model works in, read from the data
/// declaration: slots `0..predicted` are predicted (position 0..3, then
/// velocity 3..6 and quaternion w x y z 6..10 when declared (see
/// [`Slots::velocity_slots`], [`Slots::quaternion_slots`]), then body rates
/// and any other declared state), slots `predicted..state` are exogenous
/// (measured values the rollout writes in after every step: the reference
/// first, when there is one, then any extra columns).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Slots {
    /// State dimensions.
    pub state: usize,
    /// Action dimensions.
    pub action: usize,
    /// Predicted state dimensions (the first ones).
    pub predicted: usize,
    /// Whether the first three exogenous slots are the position reference
    /// (the relative map replaces them by reference - position).
    pub reference: bool,
    /// Whether slots 3..6 are the velocity. Without it there is no
    /// velocity metric and no `constant_velocity` baseline.
    #[serde(default = "yes", skip_serializing_if = "is_true")]
    pub velocity: bool,
    /// Whether four slots after the velocity (or the position) are a unit
    /// quaternion, renormalised after every rollout step. Without it there
    /// is no attitude metric.
    #[serde(default = "yes", skip_serializing_if = "is_true")]
    pub attitude: bool,
}

fn yes() -> bool {
    true
}

fn is_true(b: &bool) -> bool {
    *b
}

fn is_false(b: &bool) -> bool {
    !*b
}

impl Slots {
    /// NanoBench's layout (and the simulator's): 14 state slots, the last
    /// four (reference and battery) exogenous, and four actions.
    pub const NANOBENCH: Slots =
        Slots { state: 14, action: 4, predicted: 10, reference: true, velocity: true, attitude: true };

    /// A layout with position, velocity and quaternion (the paper's
    /// predicted state first), `predicted` predicted slots of `state`, and
    /// `action` actions.
    pub const fn full(state: usize, action: usize, predicted: usize, reference: bool) -> Slots {
        Slots { state, action, predicted, reference, velocity: true, attitude: true }
    }

    /// The velocity's slots, when declared.
    pub fn velocity_slots(&self) -> Option<std::ops::Range<usize>> {
        self.velocity.then_some(3..6)
    }

    /// The quaternion's slots (w, x, y, z), when an attitude is declared.
    pub fn quaternion_slots(&self) -> Option<std::ops::Range<usize>> {
        let start = if self.velocity { 6 } else { 3 };
        self.attitude.then_some(start..start + 4)
    }

    /// Network input dimensions: state and action.
    pub fn input(&self) -> usize {
        self.state + self.action
    }

    /// The exogenous slots.
    pub fn exogenous(&self) -> std::ops::Range<usize> {
        self.predicted..self.state
    }

    /// Whether this is NanoBench's layout.
    pub fn is_nanobench(&self) -> bool {
        *self == Slots::NANOBENCH
    }
}

impl Default for Slots {
    fn default() -> Slots {
        Slots::NANOBENCH
    }
}
