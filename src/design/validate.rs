//! [`Ast`] -> [`Design`]: names resolve, counts and ranges make sense, and
//! every problem is reported at the span that caused it. All problems are
//! collected, not just the first.

use std::collections::BTreeMap;

use super::ast::{self, *};
use super::diagnostic::Diagnostic;
use super::*;

/// More training seeds than anyone will train; bounds the memory a seed
/// range can ask for (found by fuzzing: `factor seed = 1..44444444444`).
const MAX_SEEDS: u64 = 100_000;

/// Tolerance for "this many seconds is a whole number of samples".
const SAMPLE_EPS: f64 = 1e-9;

pub fn validate(ast: &Ast) -> Result<Design, Vec<Diagnostic>> {
    let mut v = Validator::default();
    let design = v.design(ast);
    match design {
        Some(d) if v.diags.is_empty() => Ok(d),
        _ => Err(v.diags),
    }
}

#[derive(Default)]
struct Validator {
    diags: Vec<Diagnostic>,
}

impl Validator {
    fn err(&mut self, title: &str, span: Span, label: impl Into<String>) {
        self.diags.push(Diagnostic::new(title, span, label));
    }

    fn err_help(&mut self, title: &str, span: Span, label: impl Into<String>, help: impl Into<String>) {
        self.diags.push(Diagnostic::new(title, span, label).with_help(help));
    }

    /// A non-negative integer (seeds).
    fn nonneg(&mut self, i: &Int, what: &str) -> u64 {
        if i.node < 0 {
            self.err("negative value", i.span, format!("{what} must be >= 0, found {}", i.node));
            0
        } else {
            i.node as u64
        }
    }

    /// A count that must be at least `min`.
    fn count(&mut self, i: &Int, what: &str, min: i64) -> usize {
        if i.node < min {
            let title = if min == 1 { "non-positive value" } else { "value too small" };
            self.err(title, i.span, format!("{what} must be >= {min}, found {}", i.node));
            min.max(0) as usize
        } else {
            i.node as usize
        }
    }

    fn positive(&mut self, n: &Number, what: &str) -> f64 {
        if n.node <= 0.0 {
            self.err("non-positive value", n.span, format!("{what} must be > 0, found {}", n.node));
        }
        n.node
    }

    /// Remembers the first span of a clause and reports a second one.
    fn once(&mut self, seen: &mut BTreeMap<&'static str, Span>, key: &'static str, span: Span) {
        if let Some(first) = seen.get(key) {
            let _ = first;
            self.err_help(
                "declared twice",
                span,
                format!("a second `{key}`"),
                format!("`{key}` was already given earlier in this block; keep one"),
            );
        } else {
            seen.insert(key, span);
        }
    }

    fn design(&mut self, ast: &Ast) -> Option<Design> {
        let end = ast.statements.last().map(|s| Span { start: s.span.end, end: s.span.end }).unwrap_or_default();
        let mut singles: BTreeMap<&'static str, &Spanned<Statement>> = BTreeMap::new();
        let mut arms = Vec::new();
        let mut models = Vec::new();
        let mut endpoints = Vec::new();
        for s in &ast.statements {
            match &s.node {
                Statement::Arm { .. } => arms.push(s),
                Statement::Model { .. } => models.push(s),
                Statement::Endpoint(_) => endpoints.push(s),
                other => {
                    let key = other.keyword();
                    if singles.contains_key(key) {
                        self.err_help(
                            "declared twice",
                            s.span,
                            format!("a second `{key}` statement"),
                            format!("a design has one `{key}` statement"),
                        );
                    } else {
                        singles.insert(key, s);
                    }
                }
            }
        }
        for key in ["study", "data", "factor recording", "factor seed", "validation", "contrast", "decide"] {
            if !singles.contains_key(key) {
                self.err_help(
                    "missing statement",
                    end,
                    format!("the design ends here without a `{key}` statement"),
                    format!("every design declares `{key}`"),
                );
            }
        }
        if arms.is_empty() {
            self.err("missing statement", end, "the design ends here without any `arm`");
        }
        if models.is_empty() {
            self.err("missing statement", end, "the design ends here without any `model`");
        }
        if endpoints.is_empty() {
            self.err("missing statement", end, "the design ends here without any `endpoint`");
        }

        let study = singles.get("study").and_then(|s| match &s.node {
            Statement::Study(name) => {
                if name.node.trim().is_empty() {
                    self.err("empty study name", name.span, "the study needs a name");
                }
                Some(name.node.clone())
            }
            _ => None,
        });
        let data = singles.get("data").and_then(|s| match &s.node {
            Statement::Data(block) => self.data(block),
            _ => None,
        });
        let recording = singles.get("factor recording").and_then(|s| match &s.node {
            Statement::FactorRecording(items) => self.recording(items, s.span),
            _ => None,
        });
        let seeds = singles.get("factor seed").and_then(|s| match &s.node {
            Statement::FactorSeed(spec) => self.seeds(spec, s.span),
            _ => None,
        });
        let validation = singles.get("validation").and_then(|s| match &s.node {
            Statement::Validation { windows, recordings, seed } => Some(ValidationSpec {
                windows: self.count(windows, "validation windows", 1),
                recordings: self.count(recordings, "validation recordings", 1),
                seed: self.nonneg(seed, "validation seed"),
            }),
            _ => None,
        });
        let arms = self.arms(&arms);
        let models = self.models(&models);
        let training = match singles.get("train") {
            Some(s) => match &s.node {
                Statement::Train(items) => self.training(items, s.span),
                _ => None,
            },
            None => {
                if let Some(m) = models.iter().find(|m| m.0.kind.trains()) {
                    self.err_help(
                        "missing statement",
                        m.1,
                        format!("model `{}` has parameters to fit, but the design has no `train` block", m.0.name),
                        "add `train { adam lr ... batch ... epochs ... cosine patience ... action_noise ... }`",
                    );
                }
                None
            }
        };
        let rate = data.as_ref().map(|d: &DataSpec| d.rate_hz).unwrap_or(100.0);
        let horizon = recording.as_ref().map(|r: &RecordingFactor| r.horizon);
        let endpoints = self.endpoints(&endpoints, &models, rate, horizon, end);
        let contrast = singles.get("contrast").and_then(|s| match &s.node {
            Statement::Contrast { treated, reference } => self.contrast(treated, reference, &arms),
            _ => None,
        });
        let n_seeds = seeds.as_ref().map(|s: &Vec<Seed>| s.len());
        let estimator = match singles.get("estimate") {
            Some(s) => match &s.node {
                Statement::Estimate { kind, items } => self.estimator(kind, items),
                _ => None,
            },
            None => Some(Estimator { kind: EstimatorKind::CrossedMom, level: 0.95, df: DfRule::SeedsMinusOne }),
        };
        let conditions = recording.as_ref().map(|r| r.conditions.clone()).unwrap_or_default();
        let sensitivity = match singles.get("sensitivity") {
            Some(s) => match &s.node {
                Statement::Sensitivity(items) => self.sensitivity(items, &conditions, n_seeds, recording.as_ref()),
                _ => None,
            },
            None => Some(Sensitivity { bootstrap: None, grouped: Grouped::Off, leave_one_out: Vec::new() }),
        };
        let interaction = match singles.get("interaction") {
            Some(s) => match &s.node {
                Statement::Interaction { left, right } => self.interaction(left, right, &models, &endpoints),
                _ => None,
            },
            None => None,
        };
        let decision = singles.get("decide").and_then(|s| match &s.node {
            Statement::Decide { name, conditions } => self.decision(name, conditions),
            _ => None,
        });

        Some(Design {
            study: study?,
            data: data?,
            recording: recording?,
            seeds: seeds?,
            validation: validation?,
            arms: arms.into_iter().map(|a| a.0).collect(),
            models: models.into_iter().map(|m| m.0).collect(),
            training,
            endpoints: endpoints.into_iter().map(|e| e.0).collect(),
            contrast: contrast?,
            estimator: estimator?,
            sensitivity: sensitivity?,
            interaction,
            decision: decision?,
        })
    }

    fn data(&mut self, block: &DataBlock) -> Option<DataSpec> {
        let source = match block.source.node.as_str() {
            "nanobench" => Some(DataSource::Nanobench),
            "simulated" => Some(DataSource::Simulated),
            other => {
                self.err_help(
                    "unknown data source",
                    block.source.span,
                    format!("`{other}` is not a data source"),
                    "known sources: nanobench, simulated",
                );
                None
            }
        };
        let (mut sim_n, mut sim_seed, mut sim_strength, mut sim_duration) = (None, None, None, None);
        let mut seen = BTreeMap::new();
        let mut spec = DataSpec {
            source: DataSource::Nanobench,
            path: None,
            rate_hz: 100.0,
            rules: Vec::new(),
            duplicates: DuplicatePolicy::Keep,
            strictness: Strictness::Lenient,
            state_columns: DEFAULT_STATE_COLUMNS.iter().map(|s| s.to_string()).collect(),
            action_columns: DEFAULT_ACTION_COLUMNS.iter().map(|s| s.to_string()).collect(),
            simulated: None,
        };
        for item in &block.items {
            match &item.node {
                DataItem::Path(p) => {
                    self.once(&mut seen, "path", item.span);
                    if p.node.is_empty() {
                        self.err("empty path", p.span, "the data path is empty");
                    }
                    spec.path = Some(p.node.clone());
                }
                DataItem::Rate(r) => {
                    self.once(&mut seen, "rate", item.span);
                    spec.rate_hz = self.positive(r, "the sample rate");
                }
                DataItem::IncludeActive { column, cmp, threshold, min_samples } => {
                    self.once(&mut seen, "include", item.span);
                    spec.rules.push(InclusionRule::Active {
                        column: column.node.clone(),
                        cmp: cmp.node,
                        threshold: threshold.node,
                        min_samples: self.count(min_samples, "the active-sample minimum", 1) as u64,
                    });
                }
                DataItem::ExcludeImplausible => {
                    self.once(&mut seen, "exclude", item.span);
                    spec.rules.push(InclusionRule::Implausible);
                }
                DataItem::Duplicates(p) => {
                    self.once(&mut seen, "duplicates", item.span);
                    spec.duplicates = match p.node.as_str() {
                        "group" => DuplicatePolicy::Group,
                        "first" => DuplicatePolicy::First,
                        _ => DuplicatePolicy::Keep,
                    };
                }
                DataItem::Strict => {
                    self.once(&mut seen, "strict", item.span);
                    spec.strictness = Strictness::Strict;
                }
                DataItem::State(cols) => {
                    self.once(&mut seen, "state", item.span);
                    spec.state_columns = self.columns(cols, 14, "state", item.span);
                }
                DataItem::Action(cols) => {
                    self.once(&mut seen, "action", item.span);
                    spec.action_columns = self.columns(cols, 4, "action", item.span);
                }
                DataItem::SimRecordings(n) => {
                    self.once(&mut seen, "recordings", item.span);
                    sim_n = Some(self.count(n, "the number of simulated recordings", 2));
                }
                DataItem::SimSeed(n) => {
                    self.once(&mut seen, "seed", item.span);
                    sim_seed = Some(self.nonneg(n, "the simulation seed"));
                }
                DataItem::SimStrength(x) => {
                    self.once(&mut seen, "strength", item.span);
                    if x.node < 0.0 {
                        self.err("negative value", x.span, format!("strength must be >= 0, found {}", x.node));
                    }
                    sim_strength = Some(x.node);
                }
                DataItem::SimDuration(x) => {
                    self.once(&mut seen, "duration", item.span);
                    sim_duration = Some(self.positive(x, "the simulated duration"));
                }
            }
        }
        let sim_given = sim_n.is_some() || sim_seed.is_some() || sim_strength.is_some() || sim_duration.is_some();
        match source {
            Some(DataSource::Simulated) => match (sim_n, sim_seed, sim_strength, sim_duration) {
                (Some(recordings), Some(seed), Some(strength), Some(duration_s)) => {
                    spec.simulated = Some(SimSpec { recordings, seed, strength, duration_s });
                }
                _ => self.err_help(
                    "incomplete simulated data",
                    block.source.span,
                    "simulated data needs `recordings`, `seed`, `strength` and `duration`",
                    "e.g. `data simulated { recordings 40 seed 7 strength 1.0 duration 20 s }`",
                ),
            },
            Some(DataSource::Nanobench) if sim_given => self.err_help(
                "simulation settings on real data",
                block.source.span,
                "`recordings`, `seed`, `strength` and `duration` only apply to `data simulated`",
                "remove them, or switch the source to `simulated`",
            ),
            _ => {}
        }
        source.map(|source| DataSpec { source, ..spec })
    }

    fn columns(&mut self, cols: &[Ident], want: usize, what: &str, span: Span) -> Vec<String> {
        if cols.len() != want {
            self.err("wrong number of columns", span, format!("the {what} has {want} columns, {} given", cols.len()));
        }
        self.no_duplicate_names(cols, "column");
        cols.iter().map(|c| c.node.clone()).collect()
    }

    fn no_duplicate_names(&mut self, names: &[Ident], what: &str) {
        for (i, n) in names.iter().enumerate() {
            if names[..i].iter().any(|m| m.node == n.node) {
                self.err("duplicate name", n.span, format!("{what} `{}` is listed twice", n.node));
            }
        }
    }

    fn recording(&mut self, items: &[Spanned<RecordingItem>], span: Span) -> Option<RecordingFactor> {
        let mut seen = BTreeMap::new();
        let (mut evaluation, mut split_seed, mut starts, mut horizon) = (None, None, None, None);
        let mut conditions = Vec::new();
        for item in items {
            match &item.node {
                RecordingItem::Evaluation(n) => {
                    self.once(&mut seen, "evaluation", item.span);
                    evaluation = Some(self.count(n, "the number of evaluation recordings", 2));
                }
                RecordingItem::SplitSeed(n) => {
                    self.once(&mut seen, "split_seed", item.span);
                    split_seed = Some(self.nonneg(n, "the split seed"));
                }
                RecordingItem::Starts(n) => {
                    self.once(&mut seen, "starts", item.span);
                    starts = Some(self.count(n, "rollout starts per recording", 1));
                }
                RecordingItem::Horizon(n) => {
                    self.once(&mut seen, "horizon", item.span);
                    horizon = Some(self.count(n, "the rollout horizon (samples)", 1));
                }
                RecordingItem::Conditions(names) => {
                    self.once(&mut seen, "conditions", item.span);
                    self.no_duplicate_names(names, "condition");
                    for n in names {
                        match n.node.as_str() {
                            "trajectory" => conditions.push(Condition::Trajectory),
                            "speed" => conditions.push(Condition::Speed),
                            other => self.err_help(
                                "unknown condition",
                                n.span,
                                format!("`{other}` is not a condition label"),
                                "recordings carry the conditions: trajectory, speed",
                            ),
                        }
                    }
                }
            }
        }
        let mut missing = Vec::new();
        for (name, present) in [
            ("evaluation", evaluation.is_some()),
            ("split_seed", split_seed.is_some()),
            ("starts", starts.is_some()),
            ("horizon", horizon.is_some()),
        ] {
            if !present {
                missing.push(name);
            }
        }
        if !missing.is_empty() {
            self.err("incomplete recording factor", span, format!("missing: {}", missing.join(", ")));
            return None;
        }
        conditions.dedup();
        Some(RecordingFactor {
            evaluation: evaluation?,
            split_seed: split_seed?,
            starts: starts?,
            horizon: horizon?,
            conditions,
        })
    }

    fn seeds(&mut self, spec: &SeedSpec, span: Span) -> Option<Vec<Seed>> {
        let seeds: Vec<Seed> = match spec {
            SeedSpec::Range { first, last } => {
                let a = self.nonneg(first, "a seed");
                let b = self.nonneg(last, "a seed");
                if first.node > last.node {
                    let range = Span { start: first.span.start, end: last.span.end };
                    self.err_help(
                        "empty seed range",
                        range,
                        format!("{}..{} contains no seed", first.node, last.node),
                        "ranges are inclusive and ascending, e.g. 100..119",
                    );
                    return None;
                }
                if b - a >= MAX_SEEDS {
                    let range = Span { start: first.span.start, end: last.span.end };
                    self.err_help(
                        "seed range too large",
                        range,
                        format!("{}..{} holds {} seeds", first.node, last.node, (b - a).saturating_add(1)),
                        format!("a design may declare at most {MAX_SEEDS} seeds"),
                    );
                    return None;
                }
                (a..=b).map(Seed).collect()
            }
            SeedSpec::List(list) => {
                let mut out = Vec::new();
                for (i, s) in list.iter().enumerate() {
                    if list[..i].iter().any(|t| t.node == s.node) {
                        self.err("duplicate seed", s.span, format!("seed {} is listed twice", s.node));
                    }
                    out.push(Seed(self.nonneg(s, "a seed")));
                }
                out
            }
        };
        if seeds.len() < 2 {
            self.err_help(
                "too few seeds",
                span,
                format!("{} seed declared; the crossed design needs at least 2", seeds.len()),
                "the seed factor is a random effect: its variance needs J >= 2",
            );
        }
        Some(seeds)
    }

    fn arms(&mut self, stmts: &[&Spanned<Statement>]) -> Vec<(Arm, Span)> {
        let mut out: Vec<(Arm, Span)> = Vec::new();
        let mut names: Vec<&Ident> = Vec::new();
        for s in stmts {
            let Statement::Arm { name, body } = &s.node else {
                continue;
            };
            if names.iter().any(|n| n.node == name.node) {
                self.err("duplicate name", name.span, format!("arm `{}` is declared twice", name.node));
                continue;
            }
            names.push(name);
            let kind = match body {
                ArmBody::Fit { windows, seed } => ArmKind::Fit {
                    windows: self.count(windows, "fit windows", 1),
                    seed: seed.as_ref().map(|s| self.nonneg(s, "the fit seed")).unwrap_or(0),
                },
                ArmBody::Derived { from, percent, exclude_starts, seed } => {
                    if !(percent.node > 0.0 && percent.node <= 100.0) {
                        self.err_help(
                            "percentage out of range",
                            percent.span,
                            format!("{}% is outside (0, 100]", percent.node),
                            "the replaced share must be more than 0% and at most 100%",
                        );
                    }
                    ArmKind::Derived {
                        from: from.node.clone(),
                        percent: percent.node,
                        starts: if *exclude_starts { StartsPolicy::Exclude } else { StartsPolicy::Allow },
                        seed: self.nonneg(seed, "the contamination seed"),
                    }
                }
            };
            out.push((Arm { name: name.node.clone(), kind }, s.span));
        }
        // Resolve `from` after all arms are known, so order does not matter.
        for s in stmts {
            let Statement::Arm { name, body: ArmBody::Derived { from, percent, .. } } = &s.node else {
                continue;
            };
            match out.iter().find(|(a, _)| a.name == from.node) {
                None => self.err_help(
                    "unknown arm",
                    from.span,
                    format!("no arm named `{}`", from.node),
                    known("arms", out.iter().map(|a| a.0.name.as_str())),
                ),
                Some((a, _)) if a.name == name.node => self.err(
                    "arm derived from itself",
                    from.span,
                    format!("arm `{}` cannot replace its own windows", a.name),
                ),
                Some((Arm { kind: ArmKind::Derived { .. }, name: base }, _)) => self.err_help(
                    "derived from a derived arm",
                    from.span,
                    format!("`{base}` is itself derived"),
                    "derive contaminated arms from an arm with `fit N windows`",
                ),
                Some((Arm { kind: ArmKind::Fit { windows, .. }, .. }, _)) => {
                    let replaced = percent.node / 100.0 * *windows as f64;
                    if percent.node > 0.0 && percent.node <= 100.0 && (replaced - replaced.round()).abs() > 1e-9 {
                        self.err_help(
                            "fraction of windows is not whole",
                            percent.span,
                            format!("{}% of {} windows is {} windows", percent.node, windows, replaced),
                            "choose a percentage that replaces a whole number of windows",
                        );
                    }
                }
            }
        }
        out
    }

    fn models(&mut self, stmts: &[&Spanned<Statement>]) -> Vec<(Model, Span)> {
        let mut out: Vec<(Model, Span)> = Vec::new();
        for s in stmts {
            let Statement::Model { name, kind } = &s.node else {
                continue;
            };
            if out.iter().any(|m| m.0.name == name.node) {
                self.err("duplicate name", name.span, format!("model `{}` is declared twice", name.node));
                continue;
            }
            let kind = match kind {
                ast::ModelKind::Mlp { widths: spans, inputs } => {
                    let widths: Vec<usize> = spans.iter().map(|w| self.count(w, "a layer width", 1)).collect();
                    if !mlp_supported(&widths) && widths.iter().all(|w| *w >= 1) {
                        let span = Span {
                            start: spans.first().map(|w| w.span.start).unwrap_or(name.span.start),
                            end: spans.last().map(|w| w.span.end).unwrap_or(name.span.end),
                        };
                        self.err_help(
                            "unsupported architecture",
                            span,
                            format!(
                                "mlp({}) is not compiled in",
                                widths.iter().map(|w| w.to_string()).collect::<Vec<_>>().join(", ")
                            ),
                            format!(
                                "supported: three hidden layers of one width from {:?}, e.g. mlp(256, 256, 256)",
                                MLP_WIDTHS
                            ),
                        );
                    }
                    let inputs = if inputs.node == "world" { InputMap::World } else { InputMap::Relative };
                    super::ModelKind::Mlp { widths, inputs }
                }
                ast::ModelKind::Baseline(b) => {
                    if b.node == "persistence" {
                        super::ModelKind::Persistence
                    } else {
                        super::ModelKind::ConstantVelocity
                    }
                }
            };
            out.push((Model { name: name.node.clone(), kind }, name.span));
        }
        out
    }

    fn training(&mut self, items: &[Spanned<TrainItem>], span: Span) -> Option<Training> {
        let mut seen = BTreeMap::new();
        let (mut lr, mut batch, mut epochs, mut schedule, mut patience, mut noise) =
            (None, None, None, None, None, None);
        for item in items {
            match &item.node {
                TrainItem::Optimizer { lr: rate, .. } => {
                    self.once(&mut seen, "optimizer", item.span);
                    lr = Some(self.positive(rate, "the learning rate"));
                }
                TrainItem::Batch(n) => {
                    self.once(&mut seen, "batch", item.span);
                    batch = Some(self.count(n, "the batch size", 1));
                }
                TrainItem::Epochs(n) => {
                    self.once(&mut seen, "epochs", item.span);
                    epochs = Some(self.count(n, "the epoch cap", 1));
                }
                TrainItem::Schedule(s) => {
                    self.once(&mut seen, "schedule", item.span);
                    schedule = Some(if s.node == "cosine" { Schedule::Cosine } else { Schedule::Constant });
                }
                TrainItem::Patience(n) => {
                    self.once(&mut seen, "patience", item.span);
                    patience = Some(self.count(n, "the early-stopping patience", 1));
                }
                TrainItem::ActionNoise(x) => {
                    self.once(&mut seen, "action_noise", item.span);
                    if x.node < 0.0 {
                        self.err("negative value", x.span, format!("action noise sd must be >= 0, found {}", x.node));
                    }
                    noise = Some(x.node);
                }
            }
        }
        let missing: Vec<&str> = [
            ("adam lr", lr.is_none()),
            ("batch", batch.is_none()),
            ("epochs", epochs.is_none()),
            ("cosine|constant", schedule.is_none()),
            ("patience", patience.is_none()),
            ("action_noise", noise.is_none()),
        ]
        .into_iter()
        .filter(|(_, m)| *m)
        .map(|(n, _)| n)
        .collect();
        if !missing.is_empty() {
            self.err_help(
                "incomplete training block",
                span,
                format!("missing: {}", missing.join(", ")),
                "a preregistered training protocol states every setting",
            );
            return None;
        }
        Some(Training {
            optimizer: Optimizer::Adam,
            lr: lr?,
            batch: batch?,
            epochs: epochs?,
            schedule: schedule?,
            patience: patience?,
            action_noise: noise?,
        })
    }

    fn endpoints(
        &mut self,
        stmts: &[&Spanned<Statement>],
        models: &[(Model, Span)],
        rate: f64,
        horizon_samples: Option<usize>,
        end: Span,
    ) -> Vec<(Endpoint, Span)> {
        let mut out: Vec<(Endpoint, Span)> = Vec::new();
        let mut primary_cap: Option<f64> = None;
        let mut primaries: Vec<Span> = Vec::new();
        let mut seen_cells: Vec<(Metric, u64, String)> = Vec::new();
        // The primary's cap is the study's divergence cap; read it first.
        for s in stmts {
            if let Statement::Endpoint(e) = &s.node {
                if e.role.node == "primary" {
                    primary_cap = primary_cap.or(e.cap.as_ref().map(|c| c.node));
                }
            }
        }
        for s in stmts {
            let Statement::Endpoint(e) = &s.node else {
                continue;
            };
            let role = match e.role.node.as_str() {
                "primary" => Role::Primary,
                _ => Role::Secondary,
            };
            let metric = Metric::ALL.into_iter().find(|m| m.name() == e.metric.node);
            if metric.is_none() {
                self.err_help(
                    "unknown metric",
                    e.metric.span,
                    format!("`{}` is not a metric", e.metric.node),
                    known("metrics", Metric::ALL.iter().map(|m| m.name())),
                );
            }
            let mut horizons = Vec::new();
            for (i, h) in e.horizons.iter().enumerate() {
                if h.node <= 0.0 {
                    self.err("non-positive horizon", h.span, format!("the horizon must be > 0 s, found {} s", h.node));
                    continue;
                }
                if e.horizons[..i].iter().any(|g| g.node == h.node) {
                    self.err("duplicate horizon", h.span, format!("{} s is listed twice", h.node));
                    continue;
                }
                let samples = h.node * rate;
                if (samples - samples.round()).abs() > SAMPLE_EPS {
                    self.err(
                        "horizon between samples",
                        h.span,
                        format!("{} s at {} Hz is {} samples, not a whole number", h.node, rate, samples),
                    );
                }
                if let Some(max) = horizon_samples {
                    if samples.round() > max as f64 {
                        self.err_help(
                            "horizon beyond the rollout",
                            h.span,
                            format!("{} s is {} samples, but rollouts last {} samples", h.node, samples.round(), max),
                            "raise `horizon` in `factor recording` or shorten the endpoint",
                        );
                    }
                }
                horizons.push(Seconds(h.node));
            }
            if let Some(c) = &e.cap {
                if c.node <= 0.0 {
                    self.err(
                        "non-positive cap",
                        c.span,
                        format!("the divergence cap must be > 0 m, found {} m", c.node),
                    );
                } else if let Some(p) = primary_cap {
                    if role == Role::Secondary && c.node != p {
                        self.err_help(
                            "conflicting caps",
                            c.span,
                            format!("cap {} m differs from the primary endpoint's {} m", c.node, p),
                            "rollouts diverge at one cap; give every endpoint the same cap or leave it out",
                        );
                    }
                }
            }
            let mut names = Vec::new();
            self.no_duplicate_names(&e.models, "model");
            for m in &e.models {
                if !models.iter().any(|(x, _)| x.name == m.node) {
                    self.err_help(
                        "unknown model",
                        m.span,
                        format!("no model named `{}`", m.node),
                        known("models", models.iter().map(|x| x.0.name.as_str())),
                    );
                }
                names.push(m.node.clone());
            }
            if role == Role::Primary {
                primaries.push(s.span);
                if primaries.len() == 2 {
                    self.err_help(
                        "two primary endpoints",
                        s.span,
                        "a second primary endpoint",
                        "a preregistration has exactly one primary endpoint; make this one `secondary`",
                    );
                }
                if e.cap.is_none() {
                    self.err(
                        "primary endpoint without a cap",
                        e.metric.span,
                        "the primary endpoint must state `cap <metres> m`",
                    );
                }
                if e.horizons.len() != 1 || e.models.len() != 1 {
                    self.err_help(
                        "ambiguous primary endpoint",
                        s.span,
                        format!("{} horizons x {} models", e.horizons.len(), e.models.len()),
                        "the primary endpoint names exactly one horizon and one model",
                    );
                }
            }
            if let Some(metric) = metric {
                for h in &horizons {
                    for m in &names {
                        let key = (metric, (h.0 * 1e9).round() as u64, m.clone());
                        if seen_cells.contains(&key) {
                            self.err(
                                "duplicate endpoint",
                                s.span,
                                format!("{} at {} s for model `{}` is already an endpoint", metric.name(), h.0, m),
                            );
                        } else {
                            seen_cells.push(key);
                        }
                    }
                }
                let cap = Meters(e.cap.as_ref().map(|c| c.node).or(primary_cap).unwrap_or(f64::NAN));
                out.push((Endpoint { role, metric, horizons, cap, models: names }, s.span));
            }
        }
        if primaries.is_empty() && !stmts.is_empty() {
            self.err_help(
                "no primary endpoint",
                end,
                "the design ends here without a primary endpoint",
                "mark exactly one endpoint `endpoint primary ...`",
            );
        }
        out
    }

    fn contrast(&mut self, treated: &Ident, reference: &Ident, arms: &[(Arm, Span)]) -> Option<Contrast> {
        let mut ok = true;
        for a in [treated, reference] {
            if !arms.iter().any(|(x, _)| x.name == a.node) {
                self.err_help(
                    "unknown arm",
                    a.span,
                    format!("no arm named `{}`", a.node),
                    known("arms", arms.iter().map(|x| x.0.name.as_str())),
                );
                ok = false;
            }
        }
        if treated.node == reference.node {
            self.err("arm contrasted with itself", reference.span, "the contrast needs two different arms");
            ok = false;
        }
        ok.then(|| Contrast { treated: treated.node.clone(), reference: reference.node.clone() })
    }

    fn estimator(&mut self, kind: &Ident, items: &[Spanned<EstimateItem>]) -> Option<Estimator> {
        if kind.node != "crossed_mom" {
            self.err_help(
                "unknown estimator",
                kind.span,
                format!("`{}` is not an estimator", kind.node),
                "known estimators: crossed_mom",
            );
        }
        let mut seen = BTreeMap::new();
        let mut level = 0.95;
        let mut df = DfRule::SeedsMinusOne;
        for item in items {
            match &item.node {
                EstimateItem::Level(l) => {
                    self.once(&mut seen, "level", item.span);
                    if !(l.node > 0.0 && l.node < 1.0) {
                        self.err_help(
                            "level out of range",
                            l.span,
                            format!("{} is outside (0, 1)", l.node),
                            "write the confidence level as a fraction, e.g. 0.95",
                        );
                    }
                    level = l.node;
                }
                EstimateItem::DfFactorMinus { factor, minus } => {
                    self.once(&mut seen, "df", item.span);
                    match factor.node.as_str() {
                        "seed" => df = DfRule::SeedsMinusOne,
                        "recording" => df = DfRule::RecordingsMinusOne,
                        other => self.err_help(
                            "unknown factor",
                            factor.span,
                            format!("`{other}` is not a factor"),
                            "df rules: seed - 1, recording - 1, satterthwaite, z",
                        ),
                    }
                    if minus.node != 1 {
                        self.err("unsupported df rule", minus.span, format!("only `{} - 1` is supported", factor.node));
                    }
                }
                EstimateItem::DfNamed(n) => {
                    self.once(&mut seen, "df", item.span);
                    df = if n.node == "z" { DfRule::Normal } else { DfRule::Satterthwaite };
                }
            }
        }
        Some(Estimator { kind: EstimatorKind::CrossedMom, level, df })
    }

    fn sensitivity(
        &mut self,
        items: &[Spanned<SensitivityItem>],
        conditions: &[Condition],
        n_seeds: Option<usize>,
        recording: Option<&RecordingFactor>,
    ) -> Option<Sensitivity> {
        let mut seen = BTreeMap::new();
        let mut out = Sensitivity { bootstrap: None, grouped: Grouped::Off, leave_one_out: Vec::new() };
        for item in items {
            match &item.node {
                SensitivityItem::Bootstrap { kind, replicates, seed } => {
                    self.once(&mut seen, "bootstrap", item.span);
                    if kind.node != "pigeonhole" {
                        self.err_help(
                            "unknown bootstrap",
                            kind.span,
                            format!("`{}` is not a bootstrap scheme", kind.node),
                            "known schemes: pigeonhole (rows and columns resampled independently)",
                        );
                    }
                    out.bootstrap = Some(BootstrapSpec {
                        replicates: self.count(replicates, "bootstrap replicates", 1),
                        seed: self.nonneg(seed, "the bootstrap seed"),
                    });
                }
                SensitivityItem::Grouped => {
                    self.once(&mut seen, "grouped", item.span);
                    if conditions.is_empty() && recording.is_some() {
                        self.err_help(
                            "grouped sensitivity without conditions",
                            item.span,
                            "there are no condition labels to group by",
                            "declare `conditions trajectory, speed` in `factor recording`",
                        );
                    }
                    out.grouped = Grouped::ByConditions;
                }
                SensitivityItem::LeaveOneOut(factors) => {
                    self.once(&mut seen, "leave_one_out", item.span);
                    self.no_duplicate_names(factors, "factor");
                    for f in factors {
                        let factor = match f.node.as_str() {
                            "seed" => Factor::Seed,
                            "recording" => Factor::Recording,
                            other => {
                                self.err_help(
                                    "unknown factor",
                                    f.span,
                                    format!("`{other}` is not a factor"),
                                    "leave_one_out takes: seed, recording",
                                );
                                continue;
                            }
                        };
                        let n = match factor {
                            Factor::Seed => n_seeds,
                            Factor::Recording => recording.map(|r| r.evaluation),
                        };
                        if let Some(n) = n {
                            if n < 3 {
                                self.err(
                                    "too few levels to leave one out",
                                    f.span,
                                    format!("leaving one of {n} {}s out leaves fewer than 2", f.node),
                                );
                            }
                        }
                        if !out.leave_one_out.contains(&factor) {
                            out.leave_one_out.push(factor);
                        }
                    }
                }
            }
        }
        Some(out)
    }

    fn interaction(
        &mut self,
        left: &Ident,
        right: &Ident,
        models: &[(Model, Span)],
        endpoints: &[(Endpoint, Span)],
    ) -> Option<Interaction> {
        let mut ok = true;
        for m in [left, right] {
            if !models.iter().any(|(x, _)| x.name == m.node) {
                self.err_help(
                    "unknown model",
                    m.span,
                    format!("no model named `{}`", m.node),
                    known("models", models.iter().map(|x| x.0.name.as_str())),
                );
                ok = false;
            }
        }
        if left.node == right.node {
            self.err("model contrasted with itself", right.span, "the interaction needs two different models");
            ok = false;
        }
        if ok {
            let covers = |name: &str| {
                endpoints
                    .iter()
                    .flat_map(|(e, _)| e.horizons.iter().map(move |h| (e.metric, h.0, e.models.clone())))
                    .any(|(metric, h, ms)| {
                        ms.iter().any(|m| m == name)
                            && endpoints.iter().any(|(f, _)| {
                                f.metric == metric
                                    && f.horizons.iter().any(|g| g.0 == h)
                                    && f.models.contains(&right.node)
                            })
                    })
            };
            if !covers(&left.node) {
                self.err_help(
                    "interaction without a shared endpoint",
                    Span { start: left.span.start, end: right.span.end },
                    format!("no endpoint measures both `{}` and `{}` at the same horizon", left.node, right.node),
                    "add both models to an endpoint, e.g. `model world, relative`",
                );
                ok = false;
            }
        }
        ok.then(|| Interaction { left: left.node.clone(), right: right.node.clone() })
    }

    fn decision(&mut self, name: &Ident, conditions: &[Spanned<ConditionAst>]) -> Option<DecisionRule> {
        let mut out = Vec::new();
        for c in conditions {
            let c = &c.node;
            let quantity = match c.quantity.node.as_str() {
                "optimism" => Quantity::Optimism,
                "mean" => Quantity::Mean,
                "lower" => Quantity::Lower,
                "upper" => Quantity::Upper,
                other => {
                    self.err_help(
                        "unknown quantity",
                        c.quantity.span,
                        format!("`{other}` is not a quantity of the primary endpoint"),
                        "a decision rule may use: optimism (%), mean, lower, upper",
                    );
                    continue;
                }
            };
            if c.percent && quantity != Quantity::Optimism {
                self.err_help(
                    "percent on a non-percentage",
                    c.value.span,
                    format!("`{}` is a difference in the metric's unit, not a percentage", quantity.name()),
                    "only optimism is a percentage",
                );
            }
            out.push(DecisionCondition { quantity, cmp: c.cmp.node, value: c.value.node });
        }
        Some(DecisionRule { name: name.node.clone(), conditions: out })
    }
}

fn known<'a>(what: &str, names: impl Iterator<Item = &'a str>) -> String {
    let names: Vec<&str> = names.collect();
    if names.is_empty() {
        format!("no {what} are declared")
    } else {
        format!("declared {what}: {}", names.join(", "))
    }
}
