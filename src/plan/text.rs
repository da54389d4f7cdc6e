//! The plan in words: what `crossaudit check` prints of it (the cells,
//! models, arms and split trained; the endpoints, estimator, sensitivity
//! analyses and decision; notes on what a declaration cannot do).

use std::fmt::Write as _;

use super::Plan;
use crate::design::{ArmKind, EstimatorKind, ModelKind, Role, StartsPolicy, TargetKind};
use crossaudit_stats::DfRule;

impl Plan {
    /// The plan as the text `crossaudit check` prints.
    pub fn render_text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "study: {}", self.study);
        self.training_text(&mut s);
        self.analysis_text(&mut s);
        s
    }

    /// `check`'s lines on what is trained: the cells, splits, doses,
    /// models, target, arms and a published split.
    fn training_text(&self, s: &mut String) {
        let trains = self.jobs.iter().filter(|c| c.trains()).count();
        let splits =
            if self.splits.is_empty() { String::new() } else { format!(" x {}", counted(self.splits.len(), "split")) };
        let outside = self.jobs.iter().filter(|c| c.kind.is_external()).count();
        let external = if outside == 0 {
            String::new()
        } else {
            format!(", {outside} of them external: fitted by your own code on `crossaudit export`'s windows")
        };
        let _ = writeln!(
            s,
            "training cells: {} = {} x {} x {}{splits} ({} fitted{external}, {} parameter-free)",
            self.jobs.len(),
            counted(self.models.len(), "model"),
            counted(self.arms.len(), "arm"),
            counted(self.seeds.len(), "seed"),
            trains,
            self.jobs.len() - trains
        );
        if !self.splits.is_empty() {
            let list: Vec<String> = self.splits.iter().map(|s| s.to_string()).collect();
            let _ = writeln!(
                s,
                "splits: {} ({}), each redrawn whole: evaluation seeded with the split, every other draw's seed shifted by (split - split_seed)",
                self.splits.len(),
                list.join(", ")
            );
        }
        if !self.doses.is_empty() {
            let _ = writeln!(s, "{}", self.doses_text());
        }
        for m in &self.models {
            let _ = writeln!(s, "  model {}: {}", m.name, model_text(&m.kind));
            if !m.kind.trains() && self.units().any(|u| u.model == m.name) {
                let _ = writeln!(
                    s,
                    "  note: `{}` is parameter-free, the same model in every arm: its endpoints' contrast is 0 by construction, and the report leaves them out as not estimable (it is a reference level for an interaction)",
                    m.name
                );
            }
        }
        if let Some(t) = &self.training {
            let target = match t.target {
                TargetKind::StateScaled => "state-scaled increment, dz = (x_{t+1} - x_t) / sd_x (the paper's)",
                TargetKind::Standardized => "standardized increment (its own mean and SD)",
            };
            let _ = writeln!(s, "  target: {target}");
            if t.patience >= t.epochs {
                let _ = writeln!(
                    s,
                    "  note: patience {} is at least the {} epochs, so early stopping never stops a model before its last epoch; the best epoch's weights are still restored",
                    t.patience, t.epochs
                );
            }
        }
        for a in &self.arms {
            let _ = writeln!(s, "  arm {}: {}", a.name, arm_text(&a.kind));
        }
        if let Some(p) = &self.published {
            let leaked = match p.leaked {
                crate::design::LeakPolicy::Refuse => "refused",
                crate::design::LeakPolicy::Drop => "dropped from the fit pool",
            };
            let _ = writeln!(
                s,
                "split: published {} (sha256 {}): evaluation {}, validation {}, fit {} ({} recordings); fit copies of held-out recordings {leaked}",
                p.file,
                p.sha256,
                p.evaluation_roles.join(", "),
                if p.validation_roles.is_empty() {
                    "drawn from the fit roles".to_string()
                } else {
                    p.validation_roles.join(", ")
                },
                p.fit_roles.join(", "),
                p.fit.len()
            );
        }
    }

    /// `check`'s lines on the analysis: seeds, contrast, endpoints,
    /// interactions, estimator, bootstrap, required rows and decision.
    fn analysis_text(&self, s: &mut String) {
        let seeds = &self.seeds;
        let (first, last) = (seeds.first().map(|x| x.0).unwrap_or(0), seeds.last().map(|x| x.0).unwrap_or(0));
        let _ = writeln!(s, "seeds: {} ({first}..{last})", seeds.len());
        let _ = writeln!(
            s,
            "contrast: {} - {}, each over a {} recording x {} seed matrix",
            self.contrast.treated,
            self.contrast.reference,
            self.recordings,
            self.seeds.len()
        );
        let _ = writeln!(s, "endpoints:");
        for u in self.units() {
            let role = if u.role == Role::Primary { "primary  " } else { "secondary" };
            let _ = writeln!(s, "  {role} {} at {} s, model {}", u.metric.name(), u.horizon_s, u.model);
        }
        for ix in &self.interactions {
            let _ =
                writeln!(s, "interaction: {} - {} on {} at {} s", ix.left, ix.right, ix.metric.name(), ix.horizon_s);
        }
        let df = self.df(self.recordings, self.seeds.len());
        let df = match (self.estimator.df, df) {
            (DfRule::SeedsMinusOne, Some(v)) => format!("t with J - 1 = {v} df"),
            (DfRule::RecordingsMinusOne, Some(v)) => format!("t with I - 1 = {v} df"),
            (DfRule::Normal, _) => "normal (z)".to_string(),
            (DfRule::KenwardRoger, _) => "Kenward-Roger SE and df".to_string(),
            _ => "t with Satterthwaite df".to_string(),
        };
        let kind = match self.estimator.kind {
            EstimatorKind::CrossedMom => "crossed MoM",
            EstimatorKind::Reml => "REML (recording and seed random intercepts)",
        };
        let _ = writeln!(s, "estimator: {kind}, level {}, {df}", self.estimator.level);
        if self.estimator.missing_allowed {
            let _ = writeln!(s, "missing cells: allowed (each is listed in the report)");
        }
        let finite: Vec<String> = self
            .units()
            .filter(|u| u.metric.over_finite_rollouts())
            .map(|u| format!("{} at {} s", u.metric.name(), u.horizon_s))
            .collect();
        if !finite.is_empty() && self.estimator.kind == EstimatorKind::CrossedMom {
            let _ = writeln!(
                s,
                "note: {} {} over finite rollouts, empty in a cell whose every start diverged; the contrast then stays paired (the pairs with a value in both arms) and is estimated by REML with Kenward-Roger df, since the crossed MoM needs every cell; the report says so",
                finite.join(", "),
                if finite.len() == 1 { "is" } else { "are" }
            );
        }
        if let Some(b) = self.sensitivity.bootstrap {
            let _ = writeln!(s, "bootstrap: pigeonhole, B = {}, seed {}", b.replicates, b.seed);
        }
        let _ = writeln!(s, "per-cell rows required: {}", self.required_rows);
        let _ = writeln!(s, "decision: {}", self.decision);
    }
}

/// The model as the design writes it (`mlp(256, 256, 256) inputs world actions raw`, `constant_velocity`).
pub fn model_text(kind: &ModelKind) -> String {
    match kind {
        ModelKind::External { inputs, actions, history } => format!(
            "external inputs {} actions {}{}",
            inputs.name(),
            actions.name(),
            if *history > 0 { format!(" history {history}") } else { String::new() }
        ),
        ModelKind::Mlp { widths, inputs, actions, restore_final } => format!(
            "mlp({}) inputs {} actions {}{}",
            widths.iter().map(|w| w.to_string()).collect::<Vec<_>>().join(", "),
            inputs.name(),
            actions.name(),
            if *restore_final { " restore final" } else { "" }
        ),
        ModelKind::Linear { inputs, actions, ridge } => format!(
            "linear inputs {} actions {} ridge {}",
            inputs.name(),
            actions.name(),
            ridge.map_or("auto".to_string(), |r| r.to_string())
        ),
        ModelKind::Persistence => "persistence".to_string(),
        ModelKind::ConstantVelocity => "constant_velocity".to_string(),
    }
}

fn arm_text(kind: &ArmKind) -> String {
    match kind {
        ArmKind::Fit { windows, seed, hold_out } if hold_out.is_empty() => {
            format!("fit {windows} windows (seed {seed})")
        }
        ArmKind::Fit { windows, seed, hold_out } => {
            let held: Vec<&str> = hold_out.iter().map(|c| c.name()).collect();
            format!(
                "fit {windows} windows (seed {seed}) from recordings sharing no {} with any evaluation recording",
                held.join(" or ")
            )
        }
        ArmKind::Derived { from, percent, starts, seed, distance, .. } => format!(
            "{from} with {percent}% replaced by evaluation windows{}{} (seed {seed})",
            if *starts == StartsPolicy::Exclude { ", registered starts excluded" } else { "" },
            distance.map(|d| format!(", {}", d.describe())).unwrap_or_default()
        ),
    }
}

/// `n` and the noun, plural but for one: "1 model", "2 models".
fn counted(n: usize, noun: &str) -> String {
    format!("{n} {noun}{}", if n == 1 { "" } else { "s" })
}
