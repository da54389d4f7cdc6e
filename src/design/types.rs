//! The validated study (`Design`) and its parts, with a multiverse's
//! (`Multiverse`: each specification a `Design` of its own).

use serde::{Deserialize, Serialize};

use super::analysis_spec::{Contrast, DecisionRule, Endpoint, Estimator, Interaction, Sensitivity};
use super::data_spec::{DataSpec, ListedName};
use super::model_spec::{Model, TargetKind};
use super::window_distance::WindowDistance;

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
    /// `draws coupled`: every draw after the evaluation recordings by
    /// priority sampling, so that designs differing in their data share
    /// every start and window that survives in both (see `split`).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub coupled: bool,
    /// The draw factor (`factor draw = 1..3`): one complete run per value,
    /// the evaluation set fixed; empty without draw replication.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub draws: Vec<u64>,
    /// The draw this design runs ([`Design::for_draw`]); None is the
    /// design's own draw.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub draw: Option<u64>,
    /// `draws per seed`: seed j trains on and is evaluated with the draw
    /// `factor draw` would number j - j0 + 1 ([`Design::seed_draws`]).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub per_seed_draws: bool,
    /// The open choices and their specifications (`choices { ... }`); this
    /// design is then the primary specification's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub multiverse: Option<Multiverse>,
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

    /// Under `draws per seed`, each seed and the draw it uses (seed j:
    /// j - j0 + 1, j0 the smallest seed); empty otherwise.
    pub fn seed_draws(&self) -> Vec<(u64, u64)> {
        if !self.per_seed_draws {
            return Vec::new();
        }
        let j0 = self.seeds.iter().map(|s| s.0).min().unwrap_or(0);
        self.seeds.iter().map(|s| (s.0, s.0 - j0 + 1)).collect()
    }

    /// The design one seed runs under `draws per seed`: its draw
    /// ([`Design::for_draw`]) and that seed alone.
    pub fn for_seed_draw(&self, seed: u64, draw: u64) -> Design {
        let mut d = self.for_draw(draw);
        d.per_seed_draws = false;
        d.seeds.retain(|s| s.0 == seed);
        d
    }

    /// Draw `k` of a draw-replicated design: the evaluation recordings as
    /// declared, and every other draw (starts, validation, fit and
    /// contamination) with its seed shifted by `k - 1`, so that draw 1 is
    /// the design itself.
    pub fn for_draw(&self, k: u64) -> Design {
        let shift = |seed: u64| -> u64 { seed.saturating_add(k.saturating_sub(1)) };
        let mut d = self.clone();
        d.draws = Vec::new();
        d.multiverse = None;
        if k <= 1 {
            return d;
        }
        d.draw = Some(k);
        d.validation.seed = shift(self.validation.seed);
        for a in &mut d.arms {
            match &mut a.kind {
                ArmKind::Fit { seed, .. } | ArmKind::Derived { seed, .. } => *seed = shift(*seed),
            }
        }
        d
    }

    /// The dose-response arms of the contrast's treated family, by
    /// increasing dose: (arm name, percent, distance). Empty unless the
    /// treated arm was declared with several doses. In a distance-dose
    /// family (`at least 0 s, 5 s from segments`) every arm replaces the
    /// same percent and the dose is the distance, in s; otherwise the dose
    /// is the percent and the distance None.
    pub fn doses(&self) -> Vec<(String, f64, Option<f64>)> {
        let treated = &self.contrast.treated;
        let by_distance = !self.distance_doses(treated).is_empty();
        let mut out: Vec<(String, f64, Option<f64>)> = self
            .arms
            .iter()
            .filter_map(|a| match &a.kind {
                ArmKind::Derived { percent, family: Some(f), distance, .. } if f == treated => {
                    Some((a.name.clone(), *percent, distance.filter(|_| by_distance).map(|d| d.min_s)))
                }
                _ => None,
            })
            .collect();
        out.sort_by(|a, b| a.2.unwrap_or(a.1).total_cmp(&b.2.unwrap_or(b.1)));
        out
    }

    /// The arms of `family` with their distances, in the design's order,
    /// when it is a distance-dose family (its arms at different
    /// distances); empty for a family of shares or a single arm.
    pub fn distance_doses(&self, family: &str) -> Vec<(String, WindowDistance)> {
        let doses: Vec<(String, WindowDistance)> = self
            .arms
            .iter()
            .filter_map(|a| match &a.kind {
                ArmKind::Derived { family: Some(f), distance: Some(d), .. } if f == family => {
                    Some((a.name.clone(), *d))
                }
                _ => None,
            })
            .collect();
        if doses.windows(2).any(|w| w[0].1.min_s != w[1].1.min_s) {
            doses
        } else {
            Vec::new()
        }
    }
}

/// The arm name of one dose of a dose-response family: `contaminated` at
/// 5% is `contaminated_5pct`, at 2.5% `contaminated_2p5pct`.
pub fn dose_arm_name(family: &str, percent: f64) -> String {
    format!("{family}_{}pct", percent.to_string().replace('.', "p"))
}

/// The arm name of one distance of a distance-dose family: `contaminated`
/// at least 5 s from segments is `contaminated_5s`, at 0.5 s `contaminated_0p5s`.
pub fn distance_arm_name(family: &str, seconds: f64) -> String {
    format!("{family}_{}s", seconds.to_string().replace('.', "p"))
}

/// What a dose-response family varies: the share replaced, or the
/// distance of the contaminating windows from the evaluated segments.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DoseAxis {
    /// Percent of the reference arm's windows replaced (the reference arm
    /// is dose 0).
    Percent,
    /// Seconds from the evaluated segments, one share replaced (the
    /// reference arm is off the axis: it holds no contaminating window).
    Distance,
}

impl DoseAxis {
    /// The axis of doses given as (percent, distance): distances where
    /// any dose has one.
    pub fn of_doses(distances: impl IntoIterator<Item = Option<f64>>) -> DoseAxis {
        if distances.into_iter().any(|d| d.is_some()) {
            DoseAxis::Distance
        } else {
            DoseAxis::Percent
        }
    }

    /// Whether the doses are shares.
    pub fn is_percent(&self) -> bool {
        *self == DoseAxis::Percent
    }
}

/// What a pinned published split does with a fit recording that is
/// identical (the same values read) to an evaluation or validation recording.
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
    /// `within first P%`: every registered segment lies in the first P% of
    /// its recording's rows; None: anywhere.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub starts_within_pct: Option<f64>,
    /// Rollout horizon in samples.
    pub horizon: usize,
    /// Condition labels whose groups the grouped sensitivity resamples.
    pub conditions: Vec<Condition>,
    /// A pinned evaluation set (`evaluation recordings "..."`); empty when drawn.
    pub listed: Vec<ListedName>,
    /// A stratified evaluation draw (`stratify trajectory keep 1`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stratify: Option<Stratify>,
}

/// `stratify CONDITIONS keep N`: the evaluation draw keeps, for every
/// condition it draws, at least `keep` recordings (deployment units) of that
/// condition outside the evaluation and validation sets, for fitting.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stratify {
    /// The condition labels that make a condition (trajectory, speed).
    pub conditions: Vec<Condition>,
    /// Recordings of each drawn condition kept for fitting.
    pub keep: usize,
    /// Byte offset of the clause in the design source.
    #[serde(skip)]
    pub offset: usize,
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
        /// Labels whose every recording sharing a value with an evaluation
        /// recording is held out of the fit pool (`hold out trajectory`);
        /// empty: only the evaluation and validation recordings are.
        #[serde(skip_serializing_if = "Vec::is_empty", default)]
        hold_out: Vec<Condition>,
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
        /// How far the contaminating windows lie from the evaluated
        /// segments (`at least 5 s from segments`); None: anywhere.
        #[serde(skip_serializing_if = "Option::is_none", default)]
        distance: Option<WindowDistance>,
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
    /// Set by a job for a `restore final` model: train the full budget
    /// (`patience` unused) and keep the last epoch's weights.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub restore_final: bool,
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

/// Specifications one design may declare: each is a complete run.
pub const MAX_SPECS: usize = 256;

/// The open choices and the specifications they span.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Multiverse {
    /// The choices, in declaration order.
    pub choices: Vec<Choice>,
    /// Every combination of alternatives, the first choice varying slowest.
    pub specs: Vec<Specification>,
    /// Index of the primary specification in `specs`.
    pub primary: usize,
    /// How the specifications combine into the decision.
    pub combine: Combine,
}

/// One open choice.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Choice {
    /// The setting, as written (`state`, `tails`, `estimate`, ...).
    pub setting: String,
    /// Its alternatives, as written.
    pub alternatives: Vec<String>,
    /// Whether the choice changes what is trained or only the analysis.
    pub role: ChoiceRole,
}

/// What a choice changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ChoiceRole {
    /// The data, the split or the training: its alternatives train models of their own.
    Run,
    /// Only the analysis of the same cells: nothing is retrained.
    Analysis,
}

/// One specification: an alternative for every choice.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Specification {
    /// `s1`, `s2`, ... (zero-padded to the widest).
    pub id: String,
    /// The alternative taken for each choice, in choice order.
    pub values: Vec<String>,
    /// The complete design of this specification.
    #[serde(skip)]
    pub design: Box<Design>,
}

/// How the specifications combine into the decision.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind", content = "percent")]
pub enum Combine {
    /// The primary specification decides; the others are reported.
    Primary,
    /// The rule must hold in every specification.
    Every,
    /// The rule must hold in at least this percentage of them.
    AtLeast(f64),
}

impl Combine {
    /// As written after `decide ... when ...`.
    pub fn describe(&self) -> String {
        match self {
            Combine::Primary => "in the primary specification (the others are reported)".to_string(),
            Combine::Every => "in every specification".to_string(),
            Combine::AtLeast(p) => format!("in at least {p}% of specifications"),
        }
    }
}

impl Multiverse {
    /// `state=motion_capture, tails=keep` for specification `k`.
    pub fn label(&self, k: usize) -> String {
        let spec = &self.specs[k];
        self.choices.iter().zip(&spec.values).map(|(c, v)| format!("{}={v}", c.setting)).collect::<Vec<_>>().join(", ")
    }

    /// The primary specification.
    pub fn primary_spec(&self) -> &Specification {
        &self.specs[self.primary]
    }

    /// For each specification, the earlier one whose run it shares (same
    /// data, split, arms, models, training and endpoints), or itself.
    pub fn run_of(&self) -> Vec<usize> {
        let keys: Vec<String> = self.specs.iter().map(|s| run_key(&s.design)).collect();
        keys.iter().map(|k| keys.iter().position(|o| o == k).unwrap_or(0)).collect()
    }
}

/// What decides the trained cells of a design: everything but the
/// analysis (estimator, sensitivity, interaction, decision) and the name.
pub fn run_key(d: &Design) -> String {
    #[derive(Serialize)]
    struct RunPart<'a> {
        data: &'a super::DataSpec,
        recording: &'a super::RecordingFactor,
        seeds: &'a [super::Seed],
        validation: &'a super::ValidationSpec,
        arms: &'a [super::Arm],
        models: &'a [super::Model],
        training: &'a Option<super::Training>,
        endpoints: Vec<(f64, Vec<f64>, Vec<&'a str>)>,
        generator: super::Generator,
        published: &'a Option<super::PublishedPin>,
        splits: &'a [u64],
        coupled: bool,
        draw: Option<u64>,
    }
    let endpoints = d
        .endpoints
        .iter()
        .map(|e| (e.cap.0, e.horizons.iter().map(|h| h.0).collect(), e.models.iter().map(|m| m.as_str()).collect()))
        .collect();
    let part = RunPart {
        data: &d.data,
        recording: &d.recording,
        seeds: &d.seeds,
        validation: &d.validation,
        arms: &d.arms,
        models: &d.models,
        training: &d.training,
        endpoints,
        generator: d.generator,
        published: &d.published,
        splits: &d.splits,
        coupled: d.coupled,
        draw: d.draw.filter(|&k| k > 1),
    };
    crate::io::sha256_hex(serde_json::to_string(&part).unwrap_or_default().as_bytes())
}
