//! Stage 2: a validated [`Design`] compiled into a [`Plan`]: the training
//! cells to run and the recording x seed matrices each analysis needs.

use std::fmt::Write as _;

use serde::Serialize;

use crate::design::{Design, Metric, Role, Seed};

/// One training cell: a model fitted on one arm with one seed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrainingCell {
    pub model: String,
    pub arm: String,
    pub seed: Seed,
    /// False for parameter-free baselines, which are evaluated, not fitted.
    pub trains: bool,
}

/// One analysis unit: a metric at a horizon for a model, contrasted over the
/// I x J recording x seed matrix.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Unit {
    pub role: Role,
    pub metric: Metric,
    pub horizon_s: f64,
    pub model: String,
}

impl Unit {
    pub fn label(&self) -> String {
        format!("{} {} at {} s", self.model, self.metric.name(), self.horizon_s)
    }
}

/// The interaction of two models' contrasts at one metric and horizon.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InteractionUnit {
    pub metric: Metric,
    pub horizon_s: f64,
    pub left: String,
    pub right: String,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plan {
    pub study: String,
    pub training_cells: Vec<TrainingCell>,
    /// treated - reference arm.
    pub contrast: (String, String),
    /// I (evaluation recordings) x J (seeds).
    pub matrix: (usize, usize),
    pub units: Vec<Unit>,
    pub interactions: Vec<InteractionUnit>,
    /// Rows the per-cell CSV must hold for the analysis: units x arms x I x J.
    pub required_rows: usize,
    pub decision: String,
}

/// Compiles the design's cell grid and analysis units.
pub fn compile(design: &Design) -> Plan {
    let training_cells = design
        .models
        .iter()
        .flat_map(|m| {
            design.arms.iter().flat_map(move |a| {
                design.seeds.iter().map(move |&seed| TrainingCell {
                    model: m.name.clone(),
                    arm: a.name.clone(),
                    seed,
                    trains: m.kind.trains(),
                })
            })
        })
        .collect();
    let units = units(design);
    let interactions = match &design.interaction {
        None => Vec::new(),
        Some(ix) => {
            let mut out: Vec<InteractionUnit> = Vec::new();
            for u in units.iter().filter(|u| u.model == ix.left) {
                let partner =
                    units.iter().any(|v| v.model == ix.right && v.metric == u.metric && v.horizon_s == u.horizon_s);
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
            out.sort_by(|a, b| (a.metric, a.horizon_s).partial_cmp(&(b.metric, b.horizon_s)).expect("finite horizons"));
            out
        }
    };
    let (i, j) = (design.recording.evaluation, design.seeds.len());
    let required_rows = distinct_rows(&units) * 2 * i * j;
    Plan {
        study: design.study.clone(),
        training_cells,
        contrast: (design.contrast.treated.clone(), design.contrast.reference.clone()),
        matrix: (i, j),
        units,
        interactions,
        required_rows,
        decision: decision_text(design),
    }
}

/// Units in a stable order: the primary first, then by model (design
/// order), metric and horizon.
fn units(design: &Design) -> Vec<Unit> {
    let mut out: Vec<Unit> = Vec::new();
    for e in &design.endpoints {
        for h in &e.horizons {
            for m in &e.models {
                out.push(Unit { role: e.role, metric: e.metric, horizon_s: h.0, model: m.clone() });
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

/// Per-cell rows are keyed by (model, horizon): metrics share a row.
fn distinct_rows(units: &[Unit]) -> usize {
    let mut keys: Vec<(&str, u64)> = units.iter().map(|u| (u.model.as_str(), u.horizon_s.to_bits())).collect();
    keys.sort();
    keys.dedup();
    keys.len()
}

pub fn decision_text(design: &Design) -> String {
    let conds: Vec<String> = design
        .decision
        .conditions
        .iter()
        .map(|c| {
            let pct = if c.quantity == crate::design::Quantity::Optimism { "%" } else { "" };
            format!("{} {} {}{}", c.quantity.name(), c.cmp.symbol(), c.value, pct)
        })
        .collect();
    format!("{} when {}", design.decision.name, conds.join(" and "))
}

impl Plan {
    /// The plan as the text `crossaudit check` prints.
    pub fn render_text(&self, design: &Design) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "study: {}", self.study);
        let trains = self.training_cells.iter().filter(|c| c.trains).count();
        let _ = writeln!(
            s,
            "training cells: {} = {} models x {} arms x {} seeds ({} fitted, {} parameter-free)",
            self.training_cells.len(),
            design.models.len(),
            design.arms.len(),
            design.seeds.len(),
            trains,
            self.training_cells.len() - trains
        );
        for m in &design.models {
            let kind = match &m.kind {
                crate::design::ModelKind::Mlp { widths, inputs } => format!(
                    "mlp({}) inputs {}",
                    widths.iter().map(|w| w.to_string()).collect::<Vec<_>>().join(", "),
                    match inputs {
                        crate::design::InputMap::World => "world",
                        crate::design::InputMap::Relative => "relative",
                    }
                ),
                crate::design::ModelKind::Persistence => "persistence".to_string(),
                crate::design::ModelKind::ConstantVelocity => "constant_velocity".to_string(),
            };
            let _ = writeln!(s, "  model {}: {}", m.name, kind);
        }
        for a in &design.arms {
            let what = match &a.kind {
                crate::design::ArmKind::Fit { windows, seed } => {
                    format!("fit {windows} windows (seed {seed})")
                }
                crate::design::ArmKind::Derived { from, percent, starts, seed } => format!(
                    "{from} with {percent}% replaced by evaluation windows{} (seed {seed})",
                    if *starts == crate::design::StartsPolicy::Exclude { ", registered starts excluded" } else { "" }
                ),
            };
            let _ = writeln!(s, "  arm {}: {}", a.name, what);
        }
        let seeds = &design.seeds;
        let _ = writeln!(
            s,
            "seeds: {} ({}..{})",
            seeds.len(),
            seeds.first().map(|x| x.0).unwrap_or(0),
            seeds.last().map(|x| x.0).unwrap_or(0)
        );
        let _ = writeln!(
            s,
            "contrast: {} - {}, each over a {} recording x {} seed matrix",
            self.contrast.0, self.contrast.1, self.matrix.0, self.matrix.1
        );
        let _ = writeln!(s, "endpoints:");
        for u in &self.units {
            let role = if u.role == Role::Primary { "primary  " } else { "secondary" };
            let _ = writeln!(s, "  {role} {} at {} s, model {}", u.metric.name(), u.horizon_s, u.model);
        }
        for ix in &self.interactions {
            let _ =
                writeln!(s, "interaction: {} - {} on {} at {} s", ix.left, ix.right, ix.metric.name(), ix.horizon_s);
        }
        let est = &design.estimator;
        let df = match est.df {
            crate::stats::DfRule::SeedsMinusOne => format!("t with J - 1 = {} df", self.matrix.1 - 1),
            crate::stats::DfRule::RecordingsMinusOne => format!("t with I - 1 = {} df", self.matrix.0 - 1),
            crate::stats::DfRule::Satterthwaite => "t with Satterthwaite df".to_string(),
            crate::stats::DfRule::Normal => "normal (z)".to_string(),
        };
        let _ = writeln!(s, "estimator: crossed MoM, level {}, {df}", est.level);
        if let Some(b) = design.sensitivity.bootstrap {
            let _ = writeln!(s, "bootstrap: pigeonhole, B = {}, seed {}", b.replicates, b.seed);
        }
        let _ = writeln!(s, "per-cell rows required: {}", self.required_rows);
        let _ = writeln!(s, "decision: {}", self.decision);
        s
    }
}
