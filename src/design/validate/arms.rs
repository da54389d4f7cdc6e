//! Arms (fit sets and derived, contaminated arms), models and the
//! `train` block.

use std::collections::BTreeMap;

use super::{known, limits, Validator};
use crate::design::ast::{self, *};
use crate::design::*;

impl Validator {
    pub(super) fn arms(&mut self, stmts: &[&Spanned<Statement>]) -> Vec<(Arm, Span)> {
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
            match body {
                ArmBody::Fit { windows, seed, hold_out } => {
                    let kind = ArmKind::Fit {
                        windows: self.count(windows, "fit windows", 1, limits::WINDOWS),
                        seed: seed.as_ref().map(|s| self.nonneg(s, "the fit seed")).unwrap_or(0),
                        hold_out: self.hold_out(hold_out),
                    };
                    out.push((Arm { name: name.node.clone(), kind }, s.span));
                }
                ArmBody::Derived { .. } => self.derived(name, body, s.span, &mut out),
            }
        }
        // Resolve `from` after all arms are known, so order does not matter.
        for s in stmts {
            let Statement::Arm { name, body: ArmBody::Derived { from, percents, .. } } = &s.node else {
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
                    let windows = *windows;
                    for percent in percents {
                        let replaced = percent.node / 100.0 * windows as f64;
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
        }
        out
    }

    /// A derived arm: one arm, or a dose-response family of one arm per
    /// share (or per distance), appended to `out`.
    fn derived(&mut self, name: &Ident, body: &ArmBody, span: Span, out: &mut Vec<(Arm, Span)>) {
        let ArmBody::Derived { from, percents, exclude_starts, distance, seed } = body else { return };
        let percents = self.doses(percents);
        let seed = self.nonneg(seed, "the contamination seed");
        let starts = if *exclude_starts { StartsPolicy::Exclude } else { StartsPolicy::Allow };
        let distances = distance.as_ref().map(|d| self.window_distances(d)).unwrap_or_default();
        if let (true, Some(DistanceClause { least: gaps, .. })) =
            (percents.len() > 1, distance.as_ref().filter(|d| d.least.len() > 1))
        {
            self.err_help(
                "doses on two axes",
                gaps[1].span,
                "an arm declares several shares and several distances",
                "vary one: several shares at one distance, or one share at several distances",
            );
        }
        // One share at one distance: an arm of that name. Several shares (or
        // distances): a dose-response family, one arm per dose.
        let by_distance = distances.len() > 1;
        let family = (percents.len() > 1 || by_distance).then(|| name.node.clone());
        let doses: Vec<(Number, Option<WindowDistance>)> = if by_distance {
            distances.iter().map(|&d| (percents[0].clone(), Some(d))).collect()
        } else {
            percents.iter().map(|p| (p.clone(), distances.first().copied())).collect()
        };
        for (percent, distance) in doses {
            let arm_name = match (&family, distance) {
                (Some(f), Some(d)) if by_distance => distance_arm_name(f, d.min_s),
                (Some(f), _) => dose_arm_name(f, percent.node),
                (None, _) => name.node.clone(),
            };
            if out.iter().any(|(a, _)| a.name == arm_name) {
                self.err(
                    "duplicate name",
                    percent.span,
                    format!("this dose's arm `{arm_name}` has the name of another arm"),
                );
            }
            let from = from.node.clone();
            let kind = ArmKind::Derived { from, percent: percent.node, starts, distance, seed, family: family.clone() };
            out.push((Arm { name: arm_name, kind }, span));
        }
    }

    /// The models; `actions` is the train block's action scaling, which a
    /// model's own `actions` clause overrides.
    pub(super) fn models(&mut self, stmts: &[&Spanned<Statement>], actions: ActionScaling) -> Vec<(Model, Span)> {
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
                ast::ModelSyntax::Mlp { widths: spans, inputs, actions: own, restore } => {
                    let widths: Vec<usize> =
                        spans.iter().map(|w| self.count(w, "a layer width", 1, MLP_MAX_WIDTH as u64)).collect();
                    // A width out of range has its own error at its column.
                    let widths_fit = spans.iter().all(|w| (1..=MLP_MAX_WIDTH as i64).contains(&w.node));
                    if let Some(why) = mlp_unsupported(&widths).filter(|_| widths_fit) {
                        let span = Span {
                            start: spans.first().map(|w| w.span.start).unwrap_or(name.span.start),
                            end: spans.last().map(|w| w.span.end).unwrap_or(name.span.end),
                        };
                        self.err_help(
                            "unsupported architecture",
                            span,
                            format!(
                                "mlp({}): {why}",
                                widths.iter().map(|w| w.to_string()).collect::<Vec<_>>().join(", ")
                            ),
                            format!(
                                "1 to {MLP_MAX_LAYERS} hidden ReLU layers, each 1 to {MLP_MAX_WIDTH} wide, e.g. mlp(64, 64) or mlp(256, 128, 64)"
                            ),
                        );
                    }
                    let inputs = if inputs.node == "world" { InputMap::World } else { InputMap::Relative };
                    let actions = own.as_ref().map(|a| action_scaling(&a.node)).unwrap_or(actions);
                    let restore_final = restore.as_ref().is_some_and(|r| r.node == "final");
                    crate::design::ModelKind::Mlp { widths, inputs, actions, restore_final }
                }
                ast::ModelSyntax::External { inputs, actions: own, history } => {
                    let inputs = if inputs.node == "world" { InputMap::World } else { InputMap::Relative };
                    let actions = own.as_ref().map(|a| action_scaling(&a.node)).unwrap_or(actions);
                    let history = history.as_ref().map(|h| self.count(h, "a history length", 1, 1000)).unwrap_or(0);
                    crate::design::ModelKind::External { inputs, actions, history }
                }
                ast::ModelSyntax::Linear { inputs, actions: own, ridge } => {
                    let inputs = if inputs.node == "world" { InputMap::World } else { InputMap::Relative };
                    let actions = own.as_ref().map(|a| action_scaling(&a.node)).unwrap_or(actions);
                    let ridge = ridge.as_ref().map(|r| {
                        if !(r.node >= 0.0 && r.node.is_finite()) {
                            self.err(
                                "invalid penalty",
                                r.span,
                                format!("a ridge penalty is a finite number >= 0, found {}", r.node),
                            );
                        }
                        r.node
                    });
                    crate::design::ModelKind::Linear { inputs, actions, ridge }
                }
                ast::ModelSyntax::Baseline(b) => {
                    if b.node == "persistence" {
                        crate::design::ModelKind::Persistence
                    } else {
                        crate::design::ModelKind::ConstantVelocity
                    }
                }
            };
            out.push((Model { name: name.node.clone(), kind }, name.span));
        }
        out
    }

    /// The action noise's SD: at least 0, and at most 1e6 in the actions'
    /// own units (beyond it, noise drowns every action).
    fn action_noise(&mut self, x: &Number) -> f64 {
        if x.node < 0.0 {
            self.err("negative value", x.span, format!("action noise sd must be >= 0, found {}", x.node));
        } else if x.node > 1e6 {
            self.err_help(
                "value out of range",
                x.span,
                format!("action noise sd {:e} is above 1e6, in the actions' own units", x.node),
                "noise this large would drown every action a flight log holds (and past 1e154 its square overflows the loss); write it in the units of the actions as the model sees them",
            );
        }
        x.node
    }

    /// A learning rate above 0 that training, in 32-bit floats, holds as
    /// a normal number: below about 1.2e-38 it becomes 0 or loses its
    /// digits there (no step would move a weight), above about 3.4e38 it
    /// becomes infinite.
    fn learning_rate(&mut self, rate: &Number) -> f64 {
        let lr = self.positive(rate, "the learning rate");
        if lr > 0.0 && !(lr as f32).is_normal() {
            let there = match lr < 1.0 {
                true => "0 or a number with its digits lost: no step would move a weight",
                false => "infinite",
            };
            self.err_help(
                "learning rate out of range",
                rate.span,
                format!("training computes in 32-bit floats, where a learning rate of {lr:e} is {there}"),
                "a learning rate between 1.2e-38 and 3.4e38 (Adam's usual range is 1e-4 to 1e-2)",
            );
        }
        lr
    }

    pub(super) fn training(&mut self, items: &[Spanned<TrainItem>], span: Span) -> Option<Training> {
        let mut seen = BTreeMap::new();
        let (mut lr, mut batch, mut epochs, mut schedule, mut patience, mut noise) =
            (None, None, None, None, None, None);
        let mut target = TargetKind::StateScaled;
        for item in items {
            match &item.node {
                TrainItem::Optimizer { lr: rate, .. } => {
                    self.once(&mut seen, "optimizer", item.span);
                    lr = Some(self.learning_rate(rate));
                }
                TrainItem::Batch(n) => {
                    self.once(&mut seen, "batch", item.span);
                    batch = Some(self.count(n, "the batch size", 1, limits::BATCH));
                }
                TrainItem::Epochs(n) => {
                    self.once(&mut seen, "epochs", item.span);
                    epochs = Some(self.count(n, "the epoch cap", 1, limits::EPOCHS));
                }
                TrainItem::Schedule(s) => {
                    self.once(&mut seen, "schedule", item.span);
                    schedule = Some(if s.node == "cosine" { Schedule::Cosine } else { Schedule::Constant });
                }
                TrainItem::Patience(n) => {
                    self.once(&mut seen, "patience", item.span);
                    patience = Some(self.count(n, "the early-stopping patience", 1, limits::EPOCHS));
                }
                TrainItem::ActionNoise(x) => {
                    self.once(&mut seen, "action_noise", item.span);
                    noise = Some(self.action_noise(x));
                }
                TrainItem::Target(t) => {
                    self.once(&mut seen, "target", item.span);
                    target = if t.node == "standardized" { TargetKind::Standardized } else { TargetKind::StateScaled };
                }
                TrainItem::Actions(_) => self.once(&mut seen, "actions", item.span),
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
            target,
            restore_final: false,
        })
    }
}

/// `raw` or `standardized` (the grammar admits nothing else).
pub(super) fn action_scaling(word: &str) -> ActionScaling {
    if word == "standardized" {
        ActionScaling::Standardized
    } else {
        ActionScaling::Raw
    }
}

/// The train block's `actions` clause, or the paper's raw actions.
pub(super) fn declared_actions(train: Option<&Spanned<Statement>>) -> ActionScaling {
    let Some(Statement::Train(items)) = train.map(|s| &s.node) else { return ActionScaling::Raw };
    items
        .iter()
        .find_map(|i| match &i.node {
            TrainItem::Actions(a) => Some(action_scaling(&a.node)),
            _ => None,
        })
        .unwrap_or(ActionScaling::Raw)
}

impl Validator {
    /// `hold out trajectory, speed`: condition labels, each once.
    fn hold_out(&mut self, names: &[Ident]) -> Vec<Condition> {
        let mut out = Vec::new();
        for n in names {
            let c = match n.node.as_str() {
                "trajectory" => Condition::Trajectory,
                "speed" => Condition::Speed,
                _ => {
                    self.err_help(
                        "unknown holdout",
                        n.span,
                        format!("`{}` is not a recording label", n.node),
                        "a fit set can hold out every recording sharing an evaluation recording's `trajectory` or `speed`",
                    );
                    continue;
                }
            };
            if out.contains(&c) {
                self.err("duplicate name", n.span, format!("`{}` is listed twice", n.node));
            } else {
                out.push(c);
            }
        }
        out
    }

    /// The clause's distance ranges: one, or one per gap of a distance-dose
    /// family (`at least 0 s, 5 s from segments`), each at least 0, listed
    /// once, at most [`limits::DOSES`] of them.
    fn window_distances(&mut self, clause: &DistanceClause) -> Vec<WindowDistance> {
        let DistanceClause { least: gaps, most, after, span } = clause;
        if *after {
            return vec![WindowDistance { min_s: 0.0, max_s: None, after_segments: true, offset: span.start }];
        }
        if let Some(first_over) = gaps.get(limits::DOSES) {
            self.too_large(first_over.span, "the number of distances", gaps.len() as u64, limits::DOSES as u64);
        }
        let gaps = &gaps[..gaps.len().min(limits::DOSES)];
        let mut out = Vec::new();
        for (k, least) in gaps.iter().enumerate() {
            if !(least.node >= 0.0 && least.node.is_finite()) {
                self.err("distance out of range", least.span, format!("{} s is negative", least.node));
                continue;
            }
            if gaps[..k].iter().any(|g| g.node == least.node) {
                self.err("duplicate dose", least.span, format!("{} s is listed twice", least.node));
                continue;
            }
            if let Some(m) = most.as_ref().filter(|m| m.node <= least.node) {
                self.err_help(
                    "distance out of range",
                    m.span,
                    format!("the band ends at {} s, not beyond its start {} s", m.node, least.node),
                    "write the band as `NEAR s to FAR s from segments`, NEAR < FAR",
                );
                continue;
            }
            out.push(WindowDistance {
                min_s: least.node,
                max_s: most.as_ref().map(|m| m.node),
                after_segments: false,
                offset: span.start,
            });
        }
        out
    }

    /// The replaced shares, each in (0, 100] and listed once, at most
    /// [`limits::DOSES`] of them (the rest refused).
    fn doses<'p>(&mut self, percents: &'p [Number]) -> &'p [Number] {
        if let Some(first_over) = percents.get(limits::DOSES) {
            let n = percents.len() as u64;
            self.too_large(first_over.span, "the number of doses", n, limits::DOSES as u64);
        }
        let percents = &percents[..percents.len().min(limits::DOSES)];
        for (k, percent) in percents.iter().enumerate() {
            if !(percent.node > 0.0 && percent.node <= 100.0) {
                self.err_help(
                    "percentage out of range",
                    percent.span,
                    format!("{}% is outside (0, 100]", percent.node),
                    "the replaced share must be more than 0% and at most 100%",
                );
            }
            if percents[..k].iter().any(|p| p.node == percent.node) {
                self.err("duplicate dose", percent.span, format!("{}% is listed twice", percent.node));
            }
        }
        percents
    }
}
