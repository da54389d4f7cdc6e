//! A [`Design`] put together from its statements: sorted by kind, then
//! validated in the order whose checks a design's errors follow (what is
//! measured, the treatments, the analysis, the outer factors, the
//! decision), each part from those before it.

use std::collections::BTreeMap;

use super::published::Pinned;
use super::{arms, outer, Validator};
use crate::design::ast::*;
use crate::design::*;

/// A design's statements sorted by kind.
struct Statements<'a> {
    singles: BTreeMap<&'static str, &'a Spanned<Statement>>,
    arms: Vec<&'a Spanned<Statement>>,
    models: Vec<&'a Spanned<Statement>>,
    endpoints: Vec<&'a Spanned<Statement>>,
}

/// What a design measures and how it is drawn: the study, its data, the
/// published split, the recording factor, the seeds, the validation
/// recordings and the generator (None where the statement is missing or
/// refused).
struct Sampling {
    study: Option<String>,
    data: Option<DataSpec>,
    published: Option<Pinned>,
    /// The design has a `split published` statement (read or not).
    pinned_by_split: bool,
    recording: Option<RecordingFactor>,
    seeds: Option<Vec<Seed>>,
    validation: Option<ValidationSpec>,
    generator: Generator,
}

/// The arms, models, training and endpoints, each with its span.
struct Treatments {
    arms: Vec<(Arm, Span)>,
    models: Vec<(Model, Span)>,
    training: Option<Training>,
    endpoints: Vec<(Endpoint, Span)>,
}

/// The contrast and how it is estimated.
struct Analysis {
    contrast: Option<Contrast>,
    estimator: Option<Estimator>,
    sensitivity: Option<Sensitivity>,
    interaction: Option<Interaction>,
}

/// The outer factors (splits and draws) and what the decision target
/// reads from them.
struct Outer {
    splits: Option<Vec<u64>>,
    coupled: bool,
    draws: Option<Vec<u64>>,
    per_seed_draws: bool,
    /// The design replicates its split (`factor split` of some values).
    multi_split: bool,
    /// The treated arm of the contrast is a dose family.
    dosed: bool,
}

impl Validator {
    /// The design the statements declare, each part validated from those
    /// before it and every problem reported; None where a part the design
    /// needs is missing or refused.
    pub(super) fn design(&mut self, ast: &Ast) -> Option<Design> {
        let end = ast.statements.last().map(|s| Span { start: s.span.end, end: s.span.end }).unwrap_or_default();
        let st = self.statements(ast, end);
        let sampling = self.sampling(ast, &st.singles);
        let treatments = self.treatments(&st, &sampling, end);
        let analysis = self.analysis_statements(&st.singles, &sampling, &treatments);
        let outer = self.outer_factors(&st.singles, &sampling, &treatments.arms, analysis.contrast.as_ref());
        let decision = st.singles.get("decide").and_then(|s| match &s.node {
            Statement::Decide { name, on, conditions, .. } => {
                let on = self.decision_target(
                    on.as_ref(),
                    name,
                    (outer.multi_split, outer.dosed),
                    outer::glmm_units(&treatments.endpoints),
                );
                self.decision(name, conditions).map(|d| self.target_rule(DecisionRule { on, ..d }, conditions))
            }
            _ => None,
        });
        self.study_size(&st.singles, end, &sampling, &treatments, &outer);
        let Sampling { study, data, published, recording, seeds, validation, generator, .. } = sampling;
        let Treatments { arms, models, training, endpoints } = treatments;
        let Analysis { contrast, estimator, sensitivity, interaction } = analysis;
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
            generator,
            published: published.map(|p| p.pin),
            splits: outer.splits?,
            coupled: outer.coupled,
            draws: outer.draws?,
            draw: None,
            per_seed_draws: outer.per_seed_draws,
            multiverse: None,
        })
    }

    /// The study, data, published split, recording factor, seeds,
    /// validation and generator statements, in that order: each later one
    /// reads the earlier ones (the published split pins recordings).
    fn sampling(&mut self, ast: &Ast, singles: &BTreeMap<&'static str, &Spanned<Statement>>) -> Sampling {
        let study = singles.get("study").and_then(|s| match &s.node {
            Statement::Study(name) => self.study(name),
            _ => None,
        });
        let data = singles.get("data").and_then(|s| match &s.node {
            Statement::Data(block) => self.data(block),
            _ => None,
        });
        let published = singles.get("split published").and_then(|s| match &s.node {
            Statement::Published { file, folders, items } => {
                self.published(file, *folders, data.as_ref(), items, s.span)
            }
            _ => None,
        });
        let pinned_by_split = singles.contains_key("split published");
        let recording = singles.get("factor recording").and_then(|s| match &s.node {
            Statement::FactorRecording(items) => {
                let pinned = published.as_ref().map(|p| p.evaluation.clone());
                self.recording(items, s.span, pinned_by_split, pinned)
            }
            _ => None,
        });
        let seeds = singles.get("factor seed").and_then(|s| match &s.node {
            Statement::FactorSeed(spec) => self.seeds(spec, s.span),
            _ => None,
        });
        let validation = singles.get("validation").and_then(|s| match &s.node {
            Statement::Validation { windows, recordings, seed } => {
                let roles = self.validation_roles(published.as_ref(), recordings);
                let pinned = roles.map(|p| p.validation.clone());
                // (`from split` without a role is refused by validation_roles.)
                let from_roles = roles.is_some() || (pinned_by_split && matches!(recordings, ValRecordings::Split(_)));
                Some(self.validation(windows, recordings, seed, from_roles, pinned))
            }
            _ => None,
        });
        let generator = match singles.get("generator").map(|s| &s.node) {
            Some(Statement::Generator(g)) if g.node == "numpy_legacy" => Generator::NumpyLegacy,
            _ => Generator::Chacha8,
        };
        if generator == Generator::NumpyLegacy {
            self.numpy_seeds(ast);
        }
        Sampling { study, data, published, pinned_by_split, recording, seeds, validation, generator }
    }

    /// The arms, models, `train` block and endpoints, then the state the
    /// models and endpoints read checked against the data's columns.
    fn treatments(&mut self, st: &Statements, sampling: &Sampling, end: Span) -> Treatments {
        let arms = self.arms(&st.arms);
        let train = st.singles.get("train").copied();
        let models = self.models(&st.models, arms::declared_actions(train));
        let training = self.train_block(train, &models);
        let rate = sampling.data.as_ref().map(|d: &DataSpec| d.rate_hz).unwrap_or(100.0);
        self.whole_sample_distances(&arms, rate);
        let horizon = sampling.recording.as_ref().map(|r: &RecordingFactor| r.horizon);
        let endpoints = self.endpoints(&st.endpoints, &models, rate, horizon, end);
        if let Some(d) = &sampling.data {
            self.undeclared_state(&d.slots(), &models, &endpoints);
        }
        Treatments { arms, models, training, endpoints }
    }

    /// Every `from segments` distance a whole number of samples at `rate`:
    /// windows lie sample by sample, so 0.005 s at 100 Hz would act as
    /// one sample (0.01 s) without a word.
    fn whole_sample_distances(&mut self, arms: &[(Arm, Span)], rate: f64) {
        for (arm, _) in arms {
            let ArmKind::Derived { distance: Some(d), .. } = &arm.kind else { continue };
            for s in std::iter::once(d.min_s).chain(d.max_s) {
                let samples = s * rate;
                if rate > 0.0 && (samples - samples.round()).abs() > 1e-6 {
                    self.err_help(
                        "distance not a whole number of samples",
                        Span { start: d.offset, end: d.offset + 1 },
                        format!("{s} s is {} samples at {rate} Hz", (samples * 1e3).round() / 1e3),
                        format!("windows lie sample by sample: write a multiple of {} s", 1.0 / rate),
                    );
                }
            }
        }
    }

    /// The contrast, estimate, sensitivity and interaction statements (the
    /// estimate and sensitivity at their defaults where absent).
    fn analysis_statements(
        &mut self,
        singles: &BTreeMap<&'static str, &Spanned<Statement>>,
        sampling: &Sampling,
        treatments: &Treatments,
    ) -> Analysis {
        let Treatments { arms, models, endpoints, .. } = treatments;
        let contrast = singles.get("contrast").and_then(|s| match &s.node {
            Statement::Contrast { treated, reference } => self.contrast(treated, reference, arms),
            _ => None,
        });
        let n_seeds = sampling.seeds.as_ref().map(|s: &Vec<Seed>| s.len());
        let estimator = match singles.get("estimate") {
            Some(s) => match &s.node {
                Statement::Estimate { kind, items } => self.estimator(kind, items),
                _ => None,
            },
            None => Some(Estimator {
                kind: EstimatorKind::CrossedMom,
                level: 0.95,
                df: DfRule::SeedsMinusOne,
                missing_allowed: false,
            }),
        };
        let recording = sampling.recording.as_ref();
        let conditions = recording.map(|r| r.conditions.clone()).unwrap_or_default();
        let sensitivity = match singles.get("sensitivity") {
            Some(s) => match &s.node {
                // A published split that could not be read leaves the number
                // of evaluation recordings unknown: no check counts them (its
                // own error says why; a count of 0 would add a second one).
                Statement::Sensitivity(items) => self.sensitivity(
                    items,
                    &conditions,
                    (n_seeds, estimator.as_ref().map_or(0.95, |e| e.level)),
                    recording.filter(|_| !sampling.pinned_by_split || sampling.published.is_some()),
                ),
                _ => None,
            },
            None => Some(Sensitivity { bootstrap: None, grouped: Grouped::Off, leave_one_out: Vec::new() }),
        };
        let interaction = match singles.get("interaction") {
            Some(s) => match &s.node {
                Statement::Interaction { left, right } => self.interaction(left, right, models, endpoints),
                _ => None,
            },
            None => None,
        };
        Analysis { contrast, estimator, sensitivity, interaction }
    }

    /// The split factor (and the seeds it shifts), the draws, the draw
    /// factor and `draws per seed`.
    fn outer_factors(
        &mut self,
        singles: &BTreeMap<&'static str, &Spanned<Statement>>,
        sampling: &Sampling,
        arms: &[(Arm, Span)],
        contrast: Option<&Contrast>,
    ) -> Outer {
        let Sampling { recording, validation, generator, .. } = sampling;
        let generator = *generator;
        let splits = match singles.get("factor split") {
            Some(s) => match &s.node {
                Statement::FactorSplit(spec) => {
                    self.splits(spec, s.span, recording.as_ref(), sampling.published.is_some())
                }
                _ => None,
            },
            None => Some(Vec::new()),
        };
        if let (Some(splits), Some(rf), Some(val)) = (&splits, recording, validation) {
            let span = singles.get("factor split").map(|s| s.span).unwrap_or_default();
            self.shifted_seeds(splits, rf, val, arms, generator, span);
        }
        let dosed = contrast.is_some_and(|c: &Contrast| {
            arms.iter().any(|(a, _)| matches!(&a.kind, ArmKind::Derived { family: Some(f), .. } if *f == c.treated))
        });
        let multi_split = splits.as_ref().is_some_and(|s| !s.is_empty());
        let coupled = matches!(singles.get("draws").map(|s| &s.node), Some(Statement::Draws(d)) if d.node == "coupled");
        let draws = match singles.get("factor draw") {
            Some(s) => match &s.node {
                Statement::FactorDraw(spec) => self.draw_factor(
                    spec,
                    s.span,
                    (multi_split, dosed),
                    (recording.as_ref(), validation.as_ref()),
                    arms,
                    generator,
                ),
                _ => None,
            },
            None => Some(Vec::new()),
        };
        let per_seed_draws = match (singles.get("draws per seed"), &sampling.seeds) {
            (Some(s), Some(seeds)) => {
                let has_draws = draws.as_ref().is_some_and(|d| !d.is_empty());
                self.per_seed_draws(s.span, seeds, (multi_split, has_draws), validation.as_ref(), arms, generator);
                true
            }
            _ => false,
        };
        Outer { splits, coupled, draws, per_seed_draws, multi_split, dosed }
    }

    /// The study's per-cell rows stay under the limit (`limits::CELLS`), counted once
    /// its seeds, recordings and splits are known.
    fn study_size(
        &mut self,
        singles: &BTreeMap<&'static str, &Spanned<Statement>>,
        end: Span,
        sampling: &Sampling,
        treatments: &Treatments,
        outer: &Outer,
    ) {
        if let (Some(seeds), Some(rf), Some(splits)) = (&sampling.seeds, &sampling.recording, &outer.splits) {
            let span = singles.get("factor seed").map(|s| s.span).unwrap_or(end);
            let endpoints = &treatments.endpoints;
            let horizons: usize = endpoints.iter().map(|(e, _)| e.horizons.len() * e.models.len()).sum();
            let outer = splits.len().max(1) * outer.draws.as_ref().map_or(1, |d| d.len().max(1));
            self.cells_limit(span, [treatments.arms.len(), seeds.len(), outer, rf.evaluation, horizons]);
        }
    }

    /// Sorts the statements into single ones (by keyword) and the repeated
    /// arms, models and endpoints, reporting duplicates and missing ones.
    fn statements<'a>(&mut self, ast: &'a Ast, end: Span) -> Statements<'a> {
        let mut st =
            Statements { singles: BTreeMap::new(), arms: Vec::new(), models: Vec::new(), endpoints: Vec::new() };
        for s in &ast.statements {
            match &s.node {
                Statement::Arm { .. } => st.arms.push(s),
                Statement::Model { .. } => st.models.push(s),
                Statement::Endpoint(_) => st.endpoints.push(s),
                other => {
                    let key = other.keyword();
                    if st.singles.contains_key(key) {
                        self.err_help(
                            "declared twice",
                            s.span,
                            format!("a second `{key}` statement"),
                            format!("a design has one `{key}` statement"),
                        );
                    } else {
                        st.singles.insert(key, s);
                    }
                }
            }
        }
        for key in ["study", "data", "factor recording", "factor seed", "validation", "contrast", "decide"] {
            if !st.singles.contains_key(key) {
                self.err_help(
                    "missing statement",
                    end,
                    format!("the design ends here without a `{key}` statement"),
                    format!("every design declares `{key}`"),
                );
            }
        }
        for (list, what) in [(&st.arms, "arm"), (&st.models, "model"), (&st.endpoints, "endpoint")] {
            if list.is_empty() {
                self.err("missing statement", end, format!("the design ends here without any `{what}`"));
            }
        }
        st
    }
}
