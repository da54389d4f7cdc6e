//! Stage 2: a validated [`Design`] compiled once into a [`Plan`], the
//! contract every later stage consumes: the training jobs to run, the
//! analysis units over the recording x seed matrix (the primary one by
//! construction), and the typed contrast, estimator, sensitivity analyses
//! and decision rule. No later stage looks at the design's text or
//! re-derives any of this.
//!
//! A study with outer factors (specifications, draws, splits) is compiled
//! once more, level by level, into a [`StudyPlan`] ([`study`]); front ends
//! call [`compile_study`] and nothing else compiles.
//!
//! Architecture Invariant: `plan` imports only `design` and `stats`.

use serde::Serialize;

use crate::design::{
    Arm, Condition, Contrast, DecisionRule, Design, Estimator, Meters, Metric, ModelKind, Role, Seed, Sensitivity,
    Training,
};

/// What a dose-response family varies (re-exported for the stages after
/// the plan).
pub use crate::design::DoseAxis;

mod doses;
pub mod study;
mod text;

pub use doses::{dose_axis, DoseArm};
pub use study::{compile_study, StudyPlan};
pub use text::model_text;

/// One training job: a model fitted on one arm with one seed (or, for a
/// parameter-free baseline, evaluated on it).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrainingJob {
    /// The model's name in the design.
    pub model: String,
    /// What kind of model it is, and its architecture.
    pub kind: ModelKind,
    /// The arm whose fit set it is trained on.
    pub arm: String,
    /// The training seed.
    pub seed: Seed,
    /// Horizons (s) at which it is evaluated: every endpoint naming the model.
    pub horizons_s: Vec<f64>,
    /// The split it belongs to, in a multi-split study (whose split `s`
    /// runs in the directory `split-s` of the study's run directory).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split: Option<u64>,
}

impl TrainingJob {
    /// False for parameter-free baselines, which are evaluated, not fitted.
    pub fn trains(&self) -> bool {
        self.kind.trains()
    }

    /// `model__arm__seed`: the stem of every file the job writes.
    pub fn stem(&self) -> String {
        format!("{}__{}__{}", self.model, self.arm, self.seed.0)
    }

    /// `model/arm/seed` (`split-s model/arm/seed` in a multi-split study),
    /// as used in messages.
    pub fn label(&self) -> String {
        match self.split {
            None => format!("{}/{}/{}", self.model, self.arm, self.seed.0),
            Some(s) => format!("{} {}/{}/{}", split_dir(s), self.model, self.arm, self.seed.0),
        }
    }
}

/// `split-s`: the directory of split `s` inside a multi-split run.
pub fn split_dir(split: u64) -> String {
    format!("split-{split}")
}

/// One analysis unit: a metric at a horizon for a model, contrasted over the
/// I x J recording x seed matrix.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AnalysisUnit {
    /// Primary or secondary endpoint.
    pub role: Role,
    /// The per-cell metric analysed.
    pub metric: Metric,
    /// The rollout horizon in seconds.
    pub horizon_s: f64,
    /// The model whose contrast this is.
    pub model: String,
    /// Whether the unit's diverged starts are also analysed by the crossed
    /// binomial GLMM (`glmm binomial`).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub glmm: bool,
}

impl AnalysisUnit {
    /// `model metric at h s`, as used in messages.
    pub fn label(&self) -> String {
        format!("{} {} at {} s", self.model, self.metric.name(), self.horizon_s)
    }
}

/// The interaction of two models' contrasts at one metric and horizon.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InteractionUnit {
    /// The metric compared.
    pub metric: Metric,
    /// The rollout horizon in seconds.
    pub horizon_s: f64,
    /// `left - right`.
    pub left: String,
    /// `left - right`.
    pub right: String,
}

/// A model of the plan: its name and kind.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlannedModel {
    /// The name used in the per-cell data.
    pub name: String,
    /// Its kind and architecture.
    pub kind: ModelKind,
}

/// The compiled study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plan {
    /// The study's name.
    pub study: String,
    /// The published split the design pins, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub published: Option<crate::design::PublishedPin>,
    /// Every training job, models x arms x seeds in design order.
    #[serde(rename = "training_cells")]
    pub jobs: Vec<TrainingJob>,
    /// The models, in design order.
    pub models: Vec<PlannedModel>,
    /// The arms, in design order.
    pub arms: Vec<Arm>,
    /// The seeds J, in design order.
    pub seeds: Vec<Seed>,
    /// Number of evaluation recordings I.
    pub recordings: usize,
    /// Rollout starts per evaluation recording (`starts N`): the `n_starts`
    /// of every cell a run of the design writes.
    pub starts: usize,
    /// The pinned evaluation recordings (`evaluation recordings "..."`, or
    /// a published split's evaluation roles); empty when they are drawn.
    #[serde(skip)]
    pub pinned_recordings: Vec<String>,
    /// Every speed label the design's data block can give a recording
    /// (the file name's token, or the metadata speed's labels, and
    /// `unknown`).
    #[serde(skip)]
    pub speed_labels: Vec<String>,
    /// Whether evaluation recordings without a CSV may be left out
    /// (`missing csv allow`): the cells then hold at least 2 and at most I.
    pub recordings_may_be_absent: bool,
    /// Condition labels the grouped sensitivity groups recordings by.
    pub conditions: Vec<Condition>,
    /// treated - reference arm.
    pub contrast: Contrast,
    /// The primary endpoint's unit (the decision is taken on it).
    pub primary: AnalysisUnit,
    /// Secondary units: by model (design order), metric and horizon.
    pub secondary: Vec<AnalysisUnit>,
    /// Model interactions of the contrast.
    pub interactions: Vec<InteractionUnit>,
    /// Divergence cap of the endpoints (validation makes it one for all).
    pub cap: Meters,
    /// The crossed estimator's kind, level and df rule.
    pub estimator: Estimator,
    /// Bootstrap, grouped and leave-one-out sensitivity analyses.
    pub sensitivity: Sensitivity,
    /// The preregistered decision rule, on the primary unit.
    pub decision: DecisionRule,
    /// Training hyperparameters, when a model is fitted.
    pub training: Option<Training>,
    /// Log rate (Hz), which turns horizons in seconds into steps.
    pub rate_hz: f64,
    /// The state and action layout the data declares (the models' widths).
    #[serde(skip)]
    pub slots: crate::design::Slots,
    /// For `data csv`: the state slots' and actions' declared column names
    /// (a quaternion computed from Euler angles has empty names).
    #[serde(skip)]
    pub declared_columns: Option<(Vec<String>, Vec<String>)>,
    /// Rows the per-cell CSV must hold for the analysis: units x arms x I x J
    /// (x splits).
    pub required_rows: usize,
    /// The split factor's values; empty for a single-split study.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub splits: Vec<u64>,
    /// Under `draws per seed`, each seed and the draw it uses (its run
    /// directory `draw-K`); empty otherwise.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub seed_draws: Vec<(u64, u64)>,
    /// The doses of a dose-response contrast, increasing; empty when the
    /// treated arm is one arm.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub doses: Vec<DoseArm>,
}

/// Compiles the design's training jobs and analysis units.
///
/// ```
/// let d = crossaudit::design::from_str("t", include_str!("../../tests/designs/minimal.design")).unwrap();
/// let plan = crossaudit::plan::compile(&d);
/// assert_eq!(plan.primary.role, crossaudit::design::Role::Primary);
/// assert_eq!(plan.jobs.len(), d.models.len() * d.arms.len() * d.seeds.len());
/// ```
pub fn compile(design: &Design) -> Plan {
    let mut jobs = Vec::new();
    let splits: Vec<Option<u64>> =
        if design.splits.is_empty() { vec![None] } else { design.splits.iter().copied().map(Some).collect() };
    for &split in &splits {
        for m in &design.models {
            let horizons_s = horizons_for(design, &m.name);
            for a in &design.arms {
                for &seed in &design.seeds {
                    let (model, kind, arm, horizons_s) =
                        (m.name.clone(), m.kind.clone(), a.name.clone(), horizons_s.clone());
                    jobs.push(TrainingJob { model, kind, arm, seed, horizons_s, split });
                }
            }
        }
    }
    let doses: Vec<DoseArm> =
        design.doses().into_iter().map(|(arm, percent, distance_s)| DoseArm { arm, percent, distance_s }).collect();
    let mut units = units(design).into_iter();
    let primary = units.next().expect("a validated design has exactly one primary endpoint");
    let secondary: Vec<AnalysisUnit> = units.collect();
    let interactions = interactions(design, std::iter::once(&primary).chain(&secondary));
    let required_rows = distinct_rows(std::iter::once(&primary).chain(&secondary))
        * (1 + doses.len().max(1))
        * design.recording.evaluation
        * design.seeds.len()
        * splits.len();
    Plan {
        study: design.study.clone(),
        published: design.published.clone(),
        jobs,
        models: design.models.iter().map(|m| PlannedModel { name: m.name.clone(), kind: m.kind.clone() }).collect(),
        arms: design.arms.clone(),
        seeds: design.seeds.clone(),
        recordings: design.recording.evaluation,
        starts: design.recording.starts,
        pinned_recordings: design.recording.listed.iter().map(|l| l.name.clone()).collect(),
        speed_labels: design.data.speed_labels(),
        recordings_may_be_absent: design.data.missing_csv_allowed,
        conditions: design.recording.conditions.clone(),
        contrast: design.contrast.clone(),
        primary,
        secondary,
        interactions,
        // Validation refuses conflicting caps; 2 m is the language default.
        cap: Meters(design.endpoints.iter().map(|e| e.cap.0).find(|c| c.is_finite()).unwrap_or(2.0)),
        estimator: design.estimator.clone(),
        sensitivity: design.sensitivity.clone(),
        decision: design.decision.clone(),
        training: design.training.clone(),
        rate_hz: design.data.rate_hz,
        slots: design.data.slots(),
        declared_columns: design
            .data
            .format
            .as_ref()
            .map(|_| (design.data.state_columns.clone(), design.data.action_columns.clone())),
        required_rows,
        splits: design.splits.clone(),
        seed_draws: design.seed_draws(),
        doses,
    }
}

/// Horizons (s) at which `model` is evaluated: every endpoint naming it.
fn horizons_for(design: &Design, model: &str) -> Vec<f64> {
    let mut h: Vec<f64> = design
        .endpoints
        .iter()
        .filter(|e| e.models.iter().any(|m| m == model))
        .flat_map(|e| e.horizons.iter().map(|s| s.0))
        .collect();
    h.sort_by(f64::total_cmp);
    h.dedup();
    h
}

/// Units in a stable order: the primary first, then by model (design
/// order), metric and horizon.
fn units(design: &Design) -> Vec<AnalysisUnit> {
    let mut out: Vec<AnalysisUnit> = Vec::new();
    for e in &design.endpoints {
        for h in &e.horizons {
            for m in &e.models {
                let (role, metric, model) = (e.role, e.metric, m.clone());
                out.push(AnalysisUnit { role, metric, horizon_s: h.0, model, glmm: e.glmm });
            }
        }
    }
    let model_rank = |name: &str| design.models.iter().position(|m| m.name == name).unwrap_or(usize::MAX);
    out.sort_by(|a, b| {
        (a.role, model_rank(&a.model), a.metric)
            .cmp(&(b.role, model_rank(&b.model), b.metric))
            .then(a.horizon_s.total_cmp(&b.horizon_s))
    });
    out
}

/// One interaction per (metric, horizon) that both models of the design's
/// `interaction` are evaluated at.
fn interactions<'a>(design: &Design, units: impl Iterator<Item = &'a AnalysisUnit> + Clone) -> Vec<InteractionUnit> {
    let Some(ix) = &design.interaction else { return Vec::new() };
    let mut out: Vec<InteractionUnit> = Vec::new();
    for u in units.clone().filter(|u| u.model == ix.left) {
        let partner = units.clone().any(|v| v.model == ix.right && v.metric == u.metric && v.horizon_s == u.horizon_s);
        let seen = out.iter().any(|x| x.metric == u.metric && x.horizon_s == u.horizon_s);
        if partner && !seen {
            out.push(InteractionUnit {
                metric: u.metric,
                horizon_s: u.horizon_s,
                left: ix.left.clone(),
                right: ix.right.clone(),
            });
        }
    }
    out.sort_by(|a, b| a.metric.cmp(&b.metric).then(a.horizon_s.total_cmp(&b.horizon_s)));
    out
}

/// Per-cell rows are keyed by (model, horizon): metrics share a row.
fn distinct_rows<'a>(units: impl Iterator<Item = &'a AnalysisUnit>) -> usize {
    let mut keys: Vec<(&str, u64)> = units.map(|u| (u.model.as_str(), u.horizon_s.to_bits())).collect();
    keys.sort();
    keys.dedup();
    keys.len()
}

impl Plan {
    /// The plan of one split of a multi-split study: its jobs (without
    /// their split, since they run in the split's own directory) and rows.
    pub fn for_split(&self, split: u64) -> Plan {
        let mut p = self.clone();
        p.jobs = self
            .jobs
            .iter()
            .filter(|j| j.split == Some(split))
            .map(|j| TrainingJob { split: None, ..j.clone() })
            .collect();
        p.required_rows = self.required_rows / self.splits.len().max(1);
        p.splits = Vec::new();
        p
    }

    /// The two-arm plan of one dose of a dose-response contrast: the dose's
    /// arm against the reference, analysed as a single-dose study (its
    /// decision rule on that contrast's primary estimate).
    pub fn for_dose(&self, dose: &DoseArm) -> Plan {
        let mut p = self.clone();
        p.contrast.treated = dose.arm.clone();
        p.arms.retain(|a| a.name == dose.arm || a.name == self.contrast.reference);
        p.jobs.retain(|j| j.arm == dose.arm || j.arm == self.contrast.reference);
        p.required_rows = self.required_rows / (1 + self.doses.len()) * 2;
        p.doses = Vec::new();
        p.decision.on = crate::design::DecisionTarget::Primary;
        p
    }

    /// Whether the decision rule is on the slope over doses (`decide NAME
    /// on slope when ...`).
    pub fn rule_on_slope(&self) -> bool {
        self.decision.on == crate::design::DecisionTarget::Slope
    }

    /// Whether the network `model` keeps its weights of its best
    /// validation epoch (a network without `restore final`): its best
    /// epoch is where early stopping left it.
    pub fn restores_best_epoch(&self, model: &str) -> bool {
        self.models.iter().any(|m| m.name == model && matches!(m.kind, ModelKind::Mlp { restore_final: false, .. }))
    }

    /// Whether the study is analysed as a family (several splits or
    /// doses) rather than as one crossed contrast.
    pub fn is_family(&self) -> bool {
        !self.splits.is_empty() || !self.doses.is_empty()
    }

    /// Every analysis unit: the primary first, then the secondary ones.
    pub fn units(&self) -> impl Iterator<Item = &AnalysisUnit> {
        std::iter::once(&self.primary).chain(&self.secondary)
    }

    /// The (model, horizon) pairs the per-cell data must hold, in unit order.
    pub fn row_keys(&self) -> Vec<(&str, f64)> {
        let mut out: Vec<(&str, f64)> = Vec::new();
        for u in self.units() {
            if !out.iter().any(|(m, h)| *m == u.model && h.to_bits() == u.horizon_s.to_bits()) {
                out.push((&u.model, u.horizon_s));
            }
        }
        out
    }

    /// The fixed df of the interval for an I x J matrix, when the rule
    /// fixes them (see [`crossaudit_stats::DfRule::df`]).
    pub fn df(&self, rows: usize, cols: usize) -> Option<f64> {
        self.estimator.df.df(rows, cols)
    }
}
