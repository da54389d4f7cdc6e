//! Training that ended early: how many fitted models reached their best
//! validation loss (the weights the rollouts use) in the first tenth of
//! the planned epochs, per arm, and whether the seeds with such a model
//! have a different primary d from the seeds without one.

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;

use crate::cells::Cell;
use crate::plan::Plan;

/// One fitted model's best validation epoch.
#[derive(Debug, Clone)]
pub struct BestEpoch {
    /// The model's name.
    pub model: String,
    /// Its arm.
    pub arm: String,
    /// Its training seed.
    pub seed: u64,
    /// The epoch with the lowest validation loss.
    pub epoch: f64,
    /// The last epoch it trained (the budget, or where early stopping
    /// ended it).
    pub last: f64,
}

/// Early best epochs in one study (or one specification).
#[derive(Debug, Clone, Serialize)]
pub struct EarlyTraining {
    /// The first tenth of the planned epochs (rounded up).
    pub first_epochs: usize,
    /// The planned epochs.
    pub planned: usize,
    /// Per arm (design order): models with an early best epoch, fitted models.
    pub per_arm: Vec<(String, usize, usize)>,
    /// The earliest and latest early best epoch.
    pub epochs: Option<(f64, f64)>,
    /// Seeds where a model of the primary endpoint (either arm of the
    /// contrast) reached its best epoch early.
    pub seeds_with: Vec<u64>,
    /// Mean primary d over those seeds, and over the others (None for an
    /// empty group).
    pub mean_d_with: Option<f64>,
    /// Mean primary d over the seeds without an early model.
    pub mean_d_without: Option<f64>,
    /// Seeds without such a model: both arms' curves of the primary
    /// endpoint's model recorded, neither early.
    pub seeds_without: usize,
    /// Seeds in neither group: no early curve, and a curve of the primary
    /// endpoint's early-stopped model missing in an arm of the contrast
    /// (its best epoch unknown).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub seeds_unknown: Vec<u64>,
    /// The share of the summed primary d that the seeds with such a model
    /// carry (None when the summed d is 0).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub share_of_d_with: Option<f64>,
}

impl EarlyTraining {
    /// Models with an early best epoch, over every arm.
    pub fn early(&self) -> usize {
        self.per_arm.iter().map(|a| a.1).sum()
    }

    /// The sentence the reports give, or None when no model stopped early.
    pub fn warning(&self) -> Option<String> {
        let (lo, hi) = self.epochs?;
        let fitted: usize = self.per_arm.iter().map(|a| a.2).sum();
        let arms: Vec<String> = self.per_arm.iter().map(|(a, e, n)| format!("{a} {e} of {n}")).collect();
        let d = |x: Option<f64>| x.map(|v| format!("{v:.4}")).unwrap_or_else(|| "-".to_string());
        let seeds = match (self.seeds_with.len(), self.seeds_without) {
            (0, 0) if !self.seeds_unknown.is_empty() => String::new(),
            (0, _) => "no model of the primary endpoint is among them".to_string(),
            (n, 0) if self.seeds_unknown.is_empty() => format!("every one of the {n} seeds has such a model of the primary endpoint (mean primary d {})", d(self.mean_d_with)),
            (n, 0) => format!("mean primary d {} over the {n} seed(s) with such a model of the primary endpoint", d(self.mean_d_with)),
            (n, m) => format!(
                "mean primary d {} over the {n} seed(s) with such a model of the primary endpoint, {} over the {m} without{}",
                d(self.mean_d_with),
                d(self.mean_d_without),
                self.share_of_d_with
                    .map(|s| format!("; those seeds carry {:.1}% of the summed primary d", 100.0 * s))
                    .unwrap_or_default()
            ),
        };
        let unknown = match self.seeds_unknown.as_slice() {
            [] => String::new(),
            u => format!(
                "{}the training curves of the primary endpoint's model are missing for {} seed(s) ({}), counted in neither group: their best epochs are unknown",
                if seeds.is_empty() { "" } else { "; " },
                u.len(),
                u.iter().map(u64::to_string).collect::<Vec<_>>().join(", ")
            ),
        };
        Some(format!(
            "early best epochs: {} of {fitted} fitted models reach their best validation loss within the first {} of {} epochs (epochs {lo} to {hi}; {}); their restored weights are barely trained (training curves figure); {seeds}{unknown}",
            self.early(),
            self.first_epochs,
            self.planned,
            arms.join(", "),
        ))
    }
}

/// The early-training summary of `best` (every fitted model's best epoch)
/// against the primary d of `cells`; None for a plan without training.
pub fn early_training(plan: &Plan, best: &[BestEpoch], cells: &[Cell]) -> Option<EarlyTraining> {
    let planned = plan.training.as_ref()?.epochs;
    let first = planned.div_ceil(10).max(1);
    let is_early = |b: &BestEpoch| b.epoch <= first as f64;
    let mut arms: Vec<String> = Vec::new();
    for b in best {
        if !arms.contains(&b.arm) {
            arms.push(b.arm.clone());
        }
    }
    let per_arm = arms
        .iter()
        .map(|a| {
            let of: Vec<&BestEpoch> = best.iter().filter(|b| &b.arm == a).collect();
            (a.clone(), of.iter().filter(|b| is_early(b)).count(), of.len())
        })
        .collect();
    let early: Vec<f64> = best.iter().filter(|b| is_early(b)).map(|b| b.epoch).collect();
    let epochs = (!early.is_empty())
        .then(|| (early.iter().copied().fold(f64::INFINITY, f64::min), early.iter().copied().fold(0.0, f64::max)));
    let contrast = [&plan.contrast.treated, &plan.contrast.reference];
    let seeds_with: BTreeSet<u64> = best
        .iter()
        .filter(|b| is_early(b) && b.model == plan.primary.model && contrast.contains(&&b.arm))
        .map(|b| b.seed)
        .collect();
    // Seeds whose primary-endpoint curves are recorded in both arms of the
    // contrast: only they can be known to have no early model (a model
    // not early-stopped has no best epoch to know).
    let stopped = plan.restores_best_epoch(&plan.primary.model);
    let recorded = |seed: u64| {
        contrast
            .iter()
            .all(|arm| best.iter().any(|b| b.seed == seed && b.model == plan.primary.model && &&b.arm == arm))
    };
    // Mean primary d per seed.
    let d = crate::analysis::diff::Diff::of(plan, cells);
    let mut per_seed: BTreeMap<u64, (f64, usize)> = BTreeMap::new();
    for (_, seed, v) in d.iter() {
        let e = per_seed.entry(seed).or_insert((0.0, 0));
        e.0 += v;
        e.1 += 1;
    }
    let seeds_unknown: Vec<u64> =
        per_seed.keys().copied().filter(|s| stopped && !seeds_with.contains(s) && !recorded(*s)).collect();
    let group = |s: &u64, with: bool| {
        if with {
            seeds_with.contains(s)
        } else {
            !seeds_with.contains(s) && !seeds_unknown.contains(s)
        }
    };
    let mean = |with: bool| -> Option<f64> {
        let ds: Vec<f64> =
            per_seed.iter().filter(|(s, _)| group(s, with)).map(|(_, (sum, n))| sum / *n as f64).collect();
        (!ds.is_empty()).then(|| ds.iter().sum::<f64>() / ds.len() as f64)
    };
    let seeds_without = per_seed.keys().filter(|s| group(s, false)).count();
    let total: f64 = per_seed.values().map(|(s, _)| s).sum();
    let with: f64 = per_seed.iter().filter(|(s, _)| seeds_with.contains(s)).map(|(_, (sum, _))| sum).sum();
    let share_of_d_with = (total != 0.0 && !seeds_with.is_empty()).then(|| with / total);
    Some(EarlyTraining {
        first_epochs: first,
        planned,
        per_arm,
        epochs,
        mean_d_with: mean(true),
        mean_d_without: mean(false),
        seeds_with: seeds_with.into_iter().collect(),
        seeds_without,
        seeds_unknown,
        share_of_d_with,
    })
}

/// The warning for models whose best epoch is the last one they trained:
/// training ran to the end of its budget still improving, so the budget,
/// not early stopping, chose their weights; per arm, in design order.
/// None when no model did.
pub fn budget_training(plan: &Plan, best: &[BestEpoch]) -> Option<String> {
    let planned = plan.training.as_ref()?.epochs;
    let at_last = |b: &BestEpoch| b.epoch >= b.last;
    let n = best.iter().filter(|b| at_last(b)).count();
    if n == 0 {
        return None;
    }
    let mut arms: Vec<&str> = Vec::new();
    for b in best {
        if !arms.contains(&b.arm.as_str()) {
            arms.push(&b.arm);
        }
    }
    let per_arm: Vec<String> = arms
        .iter()
        .map(|a| {
            let of: Vec<&BestEpoch> = best.iter().filter(|b| b.arm == *a).collect();
            format!("{a} {} of {}", of.iter().filter(|b| at_last(b)).count(), of.len())
        })
        .collect();
    Some(format!(
        "best epoch = last epoch: {n} of {} fitted models reach their lowest validation loss at the last epoch they trained ({}; a budget of {planned} epochs): the epoch budget, not early stopping, chose their weights, and a larger budget might change them (training curves figure)",
        best.len(),
        per_arm.join(", ")
    ))
}
