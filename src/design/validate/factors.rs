//! The crossed factors: the recording factor (evaluation recordings,
//! starts, horizon, conditions) and the training seeds.

use std::collections::BTreeMap;

use super::{limits, Validator, MAX_SEEDS};
use crate::design::ast::*;
use crate::design::*;

impl Validator {
    /// `published`: the design has a `split published` statement, whose
    /// evaluation names are `pinned` (None when the split file could not be read).
    pub(super) fn recording(
        &mut self,
        items: &[Spanned<RecordingItem>],
        span: Span,
        published: bool,
        pinned: Option<Vec<ListedName>>,
    ) -> Option<RecordingFactor> {
        let RecordingParts {
            mut evaluation,
            split_seed,
            starts,
            starts_within_pct,
            horizon,
            mut conditions,
            mut listed,
            stratify,
        } = self.recording_items(items, published);
        if published {
            listed = pinned.unwrap_or_default();
            if listed.len() as u64 > limits::RECORDINGS {
                let what = "evaluation recordings of the published split";
                self.too_large(span, what, listed.len() as u64, limits::RECORDINGS);
                return None;
            }
            evaluation = Some(listed.len().max(2));
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
        if let Some((_, at)) = &stratify {
            if !listed.is_empty() {
                self.err_help(
                    "stratify with a fixed evaluation set",
                    *at,
                    "`stratify` shapes a drawn evaluation set, and this one is pinned",
                    "remove `stratify`, or draw the evaluation recordings (`evaluation N`)",
                );
            }
        }
        if let (Some(e), Some(s), Some(h)) = (evaluation, starts, horizon) {
            self.rollout_size((e, s, h), span);
        }
        Some(RecordingFactor {
            evaluation: evaluation?,
            split_seed: split_seed?,
            starts: starts?,
            starts_within_pct,
            horizon: horizon?,
            conditions,
            listed,
            stratify: stratify.map(|(s, _)| s),
        })
    }

    /// The recording factor's clauses, each given once; with a published
    /// split, the evaluation recordings are its own and a clause giving
    /// them is refused.
    fn recording_items(&mut self, items: &[Spanned<RecordingItem>], published: bool) -> RecordingParts {
        let mut seen = BTreeMap::new();
        let mut parts = RecordingParts::default();
        for item in items {
            if published && matches!(item.node, RecordingItem::Evaluation(_) | RecordingItem::EvaluationList(_)) {
                self.err_help(
                    "evaluation recordings given twice",
                    item.span,
                    "the published split's evaluation roles give the evaluation recordings",
                    "remove this clause: with `split published` the recording factor declares split_seed, starts, horizon and conditions",
                );
                continue;
            }
            match &item.node {
                RecordingItem::Evaluation(n) => {
                    self.once(&mut seen, "evaluation", item.span);
                    parts.evaluation =
                        Some(self.count(n, "the number of evaluation recordings", 2, limits::RECORDINGS));
                }
                RecordingItem::EvaluationList(names) => {
                    self.once(&mut seen, "evaluation", item.span);
                    parts.listed = self.listed(names, "evaluation");
                    parts.evaluation = Some(parts.listed.len());
                    if parts.listed.len() < 2 {
                        self.err(
                            "too few recordings",
                            item.span,
                            "a crossed design needs at least 2 evaluation recordings",
                        );
                    }
                }
                RecordingItem::SplitSeed(n) => {
                    self.once(&mut seen, "split_seed", item.span);
                    parts.split_seed = Some(self.nonneg(n, "the split seed"));
                }
                RecordingItem::Starts(n, within) => {
                    self.once(&mut seen, "starts", item.span);
                    parts.starts = Some(self.count(n, "rollout starts per recording", 1, limits::STARTS));
                    parts.starts_within_pct =
                        within.as_ref().and_then(|p| self.share(p, "the share of each recording holding starts"));
                }
                RecordingItem::Horizon(n) => {
                    self.once(&mut seen, "horizon", item.span);
                    parts.horizon = Some(self.count(n, "the rollout horizon (samples)", 1, limits::HORIZON_SAMPLES));
                }
                RecordingItem::Conditions(names) => {
                    self.once(&mut seen, "conditions", item.span);
                    parts.conditions = self.condition_labels(names);
                }
                RecordingItem::Stratify { conditions: names, keep } => {
                    self.once(&mut seen, "stratify", item.span);
                    let by = self.condition_labels(names);
                    let keep =
                        keep.as_ref().map(|k| self.count(k, "the recordings kept for fitting", 1, limits::RECORDINGS));
                    let s = Stratify { conditions: by, keep: keep.unwrap_or(1), offset: item.span.start };
                    parts.stratify = Some((s, item.span));
                }
            }
        }
        parts
    }

    /// Every job holds its rollouts' traces in memory: `e` recordings x `s`
    /// starts x `h` samples at most [`limits::ROLLOUT_STEPS`].
    fn rollout_size(&mut self, (e, s, h): (usize, usize, usize), span: Span) {
        let steps = (e as u64).saturating_mul(s as u64).saturating_mul(h as u64);
        if steps > limits::ROLLOUT_STEPS {
            self.err_help(
                "rollouts too large",
                span,
                format!("{e} recordings x {s} starts x {h} samples is {steps} model steps per job"),
                format!("a job's rollouts may take at most {} model steps (held in memory); lower evaluation, starts or horizon", limits::ROLLOUT_STEPS),
            );
        }
    }

    /// A share in (0, 100] percent.
    fn share(&mut self, p: &Number, what: &str) -> Option<f64> {
        if p.node > 0.0 && p.node <= 100.0 {
            return Some(p.node);
        }
        self.err_help(
            "percentage out of range",
            p.span,
            format!("{what}, {}%, is outside (0, 100]", p.node),
            "write a share such as `within first 50%`",
        );
        None
    }

    /// Condition labels (`trajectory`, `speed`), each once.
    fn condition_labels(&mut self, names: &[Ident]) -> Vec<Condition> {
        self.no_duplicate_names(names, "condition");
        let mut out = Vec::new();
        for n in names {
            match n.node.as_str() {
                "trajectory" => out.push(Condition::Trajectory),
                "speed" => out.push(Condition::Speed),
                other => self.err_help(
                    "unknown condition",
                    n.span,
                    format!("`{other}` is not a condition label"),
                    "recordings carry the conditions: trajectory, speed",
                ),
            }
        }
        out
    }

    /// The seed factor: at least two seeds.
    pub(super) fn seeds(&mut self, spec: &SeedSpec, span: Span) -> Option<Vec<Seed>> {
        let seeds = self.values(spec, "seed")?;
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

    /// The values of a seed, split or draw factor (`noun` names one in
    /// messages), a range or a list, each checked; how many it needs is
    /// the caller's to say.
    pub(super) fn values(&mut self, spec: &SeedSpec, noun: &str) -> Option<Vec<Seed>> {
        let a_noun = format!("a {noun}");
        let seeds: Vec<Seed> = match spec {
            SeedSpec::Range { first, last } => {
                let a = self.nonneg(first, &a_noun);
                let b = self.nonneg(last, &a_noun);
                if first.node > last.node {
                    let range = Span { start: first.span.start, end: last.span.end };
                    self.err_help(
                        &format!("empty {noun} range"),
                        range,
                        format!("{}..{} contains no {noun}", first.node, last.node),
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
                // The same limit as a range: a list is no way around it.
                if let Some(first_over) = list.get(MAX_SEEDS as usize) {
                    self.err_help(
                        "too many seeds",
                        first_over.span,
                        format!("seed number {} of a list of {}", MAX_SEEDS + 1, list.len()),
                        format!("a design may declare at most {MAX_SEEDS} seeds, listed or as a range"),
                    );
                    return None;
                }
                let mut seen = std::collections::BTreeSet::new();
                let mut out = Vec::new();
                for s in list {
                    if !seen.insert(s.node) {
                        self.err(&format!("duplicate {noun}"), s.span, format!("{noun} {} is listed twice", s.node));
                    }
                    out.push(Seed(self.nonneg(s, &a_noun)));
                }
                out
            }
        };
        Some(seeds)
    }

    /// A pinned list of recording names: none empty, none twice.
    pub(super) fn listed(&mut self, names: &[Spanned<String>], what: &str) -> Vec<ListedName> {
        let mut seen = std::collections::BTreeSet::new();
        if let Some(first_over) = names.get(limits::RECORDINGS as usize) {
            let what = format!("the number of listed {what} recordings");
            self.too_large(first_over.span, &what, names.len() as u64, limits::RECORDINGS);
        }
        for n in names.iter().take(limits::RECORDINGS as usize) {
            if n.node.trim().is_empty() {
                self.err("empty name", n.span, format!("an empty {what} recording name"));
            } else if !seen.insert(n.node.as_str()) {
                self.err("duplicate name", n.span, format!("{what} recording `{}` is listed twice", n.node));
            }
        }
        names.iter().map(|n| ListedName { name: n.node.clone(), offset: n.span.start, at: None }).collect()
    }
}

/// The clauses of a recording factor as declared.
#[derive(Default)]
struct RecordingParts {
    evaluation: Option<usize>,
    split_seed: Option<u64>,
    starts: Option<usize>,
    starts_within_pct: Option<f64>,
    horizon: Option<usize>,
    conditions: Vec<Condition>,
    listed: Vec<ListedName>,
    stratify: Option<(Stratify, Span)>,
}
