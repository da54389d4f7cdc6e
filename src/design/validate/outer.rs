//! The outer factors of a design: the multiverse's specifications (each
//! validated as a design of its own), the draw factor, the split factor
//! and the decision target they call for.

use std::path::Path;

use super::super::ast::Statement;
use super::super::ast::*;
use super::super::diagnostic::Diagnostic;
use super::super::multiverse;
use super::super::*;
use super::{limits, validate_single, Validator};

/// Validates a design: a single study, or a multiverse expanded into its
/// specifications (each validated as a single study).
pub fn validate(ast: &Ast, base: &Path) -> Result<Design, Vec<Diagnostic>> {
    if let Some(s) = ast.statements.get(limits::STATEMENTS) {
        let mut v = Validator::default();
        let n = ast.statements.len();
        v.too_large(s.span, "the number of statements", n as u64, limits::STATEMENTS as u64);
        return Err(v.diags);
    }
    let mut diags = Vec::new();
    let Some(declared) = multiverse::declared(ast, &mut diags) else {
        if !diags.is_empty() && ast.statements.iter().any(|s| matches!(s.node, Statement::Choices(_))) {
            // The choices could not be read: the design without them would
            // miss the settings they supply, and say so in errors of its own.
            return Err(diags);
        }
        let single = validate_single(ast, base);
        return match (single, diags.is_empty()) {
            (Ok(d), true) => Ok(d),
            (Ok(_), false) => Err(diags),
            (Err(mut more), _) => {
                diags.append(&mut more);
                diags.sort_by_key(|d| d.span.start);
                Err(diags)
            }
        };
    };
    expand(ast, base, &declared, diags)
}

/// Every specification of a multiverse, validated as a design of its own,
/// and the primary's design carrying the multiverse.
pub(super) fn expand(
    ast: &Ast,
    base: &Path,
    declared: &multiverse::Declared,
    mut diags: Vec<Diagnostic>,
) -> Result<Design, Vec<Diagnostic>> {
    let choices: Vec<multiverse::Choice> = declared.choices.iter().map(|(c, _)| c.clone()).collect();
    let combos = multiverse::combinations(&choices);
    let mut specs = Vec::new();
    let mut failed: Vec<(String, Vec<Diagnostic>)> = Vec::new();
    for (k, values) in combos.iter().enumerate() {
        let spec_ast = multiverse::spec_ast(ast, declared, values);
        let label: Vec<String> =
            choices.iter().zip(values).map(|(c, &i)| format!("{} {}", c.setting, c.alternatives[i])).collect();
        match validate_single(&spec_ast, base) {
            Ok(d) => specs.push(multiverse::Specification {
                id: multiverse::spec_id(k, combos.len()),
                values: choices.iter().zip(values).map(|(c, &i)| c.alternatives[i].clone()).collect(),
                design: Box::new(d),
            }),
            Err(found) => failed.push((label.join(", "), found)),
        }
    }
    // An error every specification makes is the design's; one only some
    // make names the first specification it was found in.
    for (label, found) in &failed {
        for d in found {
            if diags.iter().any(|o: &Diagnostic| o.title == d.title && o.span == d.span) {
                continue;
            }
            let everywhere = failed.len() == combos.len()
                && failed.iter().all(|(_, f)| f.iter().any(|o| o.title == d.title && o.span == d.span));
            let mut d = d.clone();
            if !everywhere {
                d.label = format!("{} (in the specification {label})", d.label);
            }
            diags.push(d);
        }
    }
    if !diags.is_empty() {
        diags.sort_by_key(|d| d.span.start);
        return Err(diags);
    }
    // Each specification is one crossed contrast: a multiverse of
    // multi-split or dose-response designs would need a family analysis
    // per specification, which the combined analysis does not do.
    if specs.iter().any(|s| !s.design.splits.is_empty() || !s.design.doses().is_empty()) {
        let span = declared.choices.first().map(|c| c.1.span).unwrap_or_default();
        diags.push(
            Diagnostic::new(
                "choices with splits or doses",
                span,
                "a multiverse's specifications must each be one crossed contrast",
            )
            .with_help("drop `factor split` or the doses, or run each specification's family as its own design"),
        );
        return Err(diags);
    }
    let primary = combos.iter().position(|v| *v == declared.primary).unwrap_or(0);
    let mut design = (*specs[primary].design).clone();
    design.multiverse = Some(multiverse::Multiverse { choices, specs, primary, combine: declared.combine });
    Ok(design)
}

/// Endpoint units (horizons x models) declared `glmm binomial`.
pub(super) fn glmm_units(endpoints: &[(Endpoint, Span)]) -> usize {
    endpoints.iter().filter(|(e, _)| e.glmm).map(|(e, _)| e.horizons.len() * e.models.len()).sum()
}

impl Validator {
    /// The estimate a decision is on: the pooled one in a multi-split
    /// design, the slope in a dose-response design, which the design must
    /// say (`decide NAME on pooled|slope when ...`); the divergence GLMM
    /// where the design says `on divergence` (of its `glmm_units`
    /// endpoint units, which must be one); the primary otherwise.
    pub(super) fn decision_target(
        &mut self,
        on: Option<&Ident>,
        name: &Ident,
        (multi_split, dosed): (bool, bool),
        glmm_units: usize,
    ) -> DecisionTarget {
        match on.map(|o| o.node.as_str()) {
            Some("divergence") => {
                self.divergence_target(on.map(|o| o.span).unwrap_or(name.span), multi_split || dosed, glmm_units)
            }
            Some("slope") if !dosed => {
                let span = on.map(|o| o.span).unwrap_or(name.span);
                self.err_help(
                    "no slope to decide on",
                    span,
                    "`on slope` needs a dose-response contrast",
                    "declare the treated arm with several doses: `replace 1%, 5%, 25% with evaluation windows ...`, or distances: `... at least 0 s, 5 s from segments seed ...`",
                );
                DecisionTarget::Slope
            }
            Some("slope") => DecisionTarget::Slope,
            Some(_) if dosed => {
                let span = on.map(|o| o.span).unwrap_or(name.span);
                self.err_help(
                    "ambiguous decision",
                    span,
                    "a dose-response design has one estimate per dose",
                    "decide on the trend: `decide NAME on slope when ...`",
                );
                DecisionTarget::Pooled
            }
            Some(_) if !multi_split => {
                let span = on.map(|o| o.span).unwrap_or(name.span);
                self.err_help(
                    "no pooled estimate",
                    span,
                    "`on pooled` needs a split factor",
                    "declare several splits (`factor split = 42..46`), or drop `on pooled`",
                );
                DecisionTarget::Pooled
            }
            Some(_) => DecisionTarget::Pooled,
            None => self.unstated_target(name, (multi_split, dosed)),
        }
    }

    /// `on divergence` at `span`: one binomial GLMM endpoint
    /// (`glmm_units` of them) of a single split and dose (`family`: the
    /// design has several).
    fn divergence_target(&mut self, span: Span, family: bool, glmm_units: usize) -> DecisionTarget {
        if family {
            self.err_help(
                "divergence decision in a family of estimates",
                span,
                "`on divergence` reads one binomial GLMM, of a single split and dose",
                "decide on the pooled estimate or the slope, and report the GLMM beside it",
            );
        } else if glmm_units != 1 {
            self.err_help(
                "no single divergence GLMM",
                span,
                format!("`on divergence` reads the one endpoint declared `glmm binomial`, at one horizon for one model; the design has {glmm_units} such"),
                "declare exactly one: `endpoint secondary divergence_rate at 1.0 s model world glmm binomial`",
            );
        }
        DecisionTarget::Divergence
    }

    /// A decision that names no estimate: the primary, unless the design
    /// has one estimate per dose or per split, where it must say which.
    fn unstated_target(&mut self, name: &Ident, (multi_split, dosed): (bool, bool)) -> DecisionTarget {
        if dosed {
            self.err_help(
                "decision target missing",
                name.span,
                "a dose-response design has one estimate per dose: say which the rule is on",
                "write `decide NAME on slope when ...` (the trend over doses)",
            );
            DecisionTarget::Slope
        } else if multi_split {
            self.err_help(
                "decision target missing",
                name.span,
                "a multi-split design has one estimate per split: say which the rule is on",
                "write `decide NAME on pooled when ...` (the pooled estimate over splits)",
            );
            DecisionTarget::Pooled
        } else {
            DecisionTarget::Primary
        }
    }

    /// A rule's conditions against what its target can be: on the
    /// divergence GLMM, which reads a log odds ratio, `optimism` has no
    /// meaning; on the primary estimate, optimism is at most 100% (it is
    /// 100 x (reference - treated) / reference, of errors that are never
    /// negative), so a condition asking for more can never hold.
    pub(super) fn target_rule(&mut self, rule: DecisionRule, conditions: &[Spanned<ConditionAst>]) -> DecisionRule {
        if rule.on == DecisionTarget::Primary {
            for (c, ast) in rule.conditions.iter().zip(conditions) {
                let beyond = match c.cmp {
                    Cmp::Gt => c.value >= 100.0,
                    Cmp::Ge => c.value > 100.0,
                    Cmp::Lt | Cmp::Le => false,
                };
                if c.quantity == Quantity::Optimism && beyond {
                    self.err_help(
                        "a condition that can never hold",
                        ast.span,
                        format!("`{c}` asks for more than 100%: optimism is 100 x (reference - treated) / reference, and the treated arm's errors are never negative, so it is at most 100% (100% only where they are all 0)"),
                        "a threshold below 100%: `optimism >= 10%` confirms where the treated arm's error is at least 10% below the reference arm's",
                    );
                }
            }
        }
        if rule.on == DecisionTarget::Divergence {
            for (c, ast) in rule.conditions.iter().zip(conditions) {
                if c.quantity == Quantity::Optimism {
                    self.err_help(
                        "optimism of a divergence GLMM",
                        ast.span,
                        "a rule `on divergence` reads the log odds ratio of a diverged rollout, which has no optimism",
                        "use mean, lower or upper (log odds ratio, treated over reference): `upper < 0` says the treated arm diverges less",
                    );
                }
            }
        }
        rule
    }

    /// `factor split = ...`: at least 2 distinct values, on a drawn split.
    pub(super) fn splits(
        &mut self,
        spec: &SeedSpec,
        span: Span,
        recording: Option<&RecordingFactor>,
        published: bool,
    ) -> Option<Vec<u64>> {
        let values: Vec<u64> = self.values(spec, "split")?.into_iter().map(|s| s.0).collect();
        if values.len() as u64 > limits::SPLITS {
            self.too_large(span, "the number of splits", values.len() as u64, limits::SPLITS);
            return None;
        }
        if values.len() < 2 {
            self.err_help(
                "one split",
                span,
                "split replication needs at least two splits",
                "write `factor split = 1..5`, or drop the factor for the design's one split",
            );
        }
        if published {
            self.err_help(
                "split factor on a published split",
                span,
                "a published split is one fixed split; there is nothing to redraw",
                "drop `factor split`, or draw the split (`evaluation N split_seed S`)",
            );
        }
        if recording.is_some_and(|r| !r.listed.is_empty()) {
            self.err_help(
                "split factor on pinned recordings",
                span,
                "the evaluation recordings are pinned (`evaluation recordings ...`), so every split would be the same",
                "draw them instead: `evaluation N split_seed S`",
            );
        }
        Some(values)
    }

    /// `factor draw = ...`: at least 2 distinct values from 1, each shift
    /// keeping every seed in range; not with a split factor or doses.
    pub(super) fn draw_factor(
        &mut self,
        spec: &SeedSpec,
        span: Span,
        (multi_split, dosed): (bool, bool),
        (recording, validation): (Option<&RecordingFactor>, Option<&ValidationSpec>),
        arms: &[(Arm, Span)],
        generator: Generator,
    ) -> Option<Vec<u64>> {
        let values: Vec<u64> = self.values(spec, "draw")?.into_iter().map(|s| s.0).collect();
        if values.len() as u64 > limits::SPLITS {
            self.too_large(span, "the number of draws", values.len() as u64, limits::SPLITS);
            return None;
        }
        if values.len() < 2 {
            self.err_help("one draw", span, "draw replication needs at least two draws", "write `factor draw = 1..3`");
        }
        if values.contains(&0) {
            self.err_help(
                "draw 0",
                span,
                "draws are numbered from 1 (draw 1 is the design's own draw)",
                "write `factor draw = 1..3`",
            );
        }
        if multi_split {
            self.err_help(
                "draw and split factors together",
                span,
                "a split factor already redraws every draw with its evaluation set",
                "keep one: `factor split` redraws the evaluation set too, `factor draw` keeps it fixed",
            );
        }
        if dosed {
            self.err_help(
                "draw factor with doses",
                span,
                "draw replication of a dose-response family is not supported",
                "replicate the draws of one dose, or drop `factor draw`",
            );
        }
        let last = values.iter().copied().max().unwrap_or(1);
        if let Some((what, seed, max)) = shifted_out_of_range(recording, validation, arms, generator, last) {
            self.err_help(
                "draw shifts a seed out of range",
                span,
                format!("draw {last} shifts {what} ({seed}) by {}", last - 1),
                format!("draw k draws with each declared seed plus k - 1; keep every seed from 0 to {max}"),
            );
            return None;
        }
        Some(values)
    }

    /// `draws per seed`: seed j uses draw j - j0 + 1, so every declared
    /// seed a draw shifts must stay in range for the largest; not with a
    /// draw or split factor (they replicate whole runs).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn per_seed_draws(
        &mut self,
        span: Span,
        seeds: &[Seed],
        (multi_split, draws): (bool, bool),
        validation: Option<&ValidationSpec>,
        arms: &[(Arm, Span)],
        generator: Generator,
    ) {
        let help = "`draws per seed` gives each seed its own draw within one run; keep one of the two";
        if draws {
            self.err_help(
                "per-seed draws and a draw factor",
                span,
                "`factor draw` already replicates whole draws",
                help,
            );
        }
        if multi_split {
            self.err_help(
                "per-seed draws and a split factor",
                span,
                "`factor split` already redraws every draw with each split",
                help,
            );
        }
        let j0 = seeds.iter().map(|s| s.0).min().unwrap_or(0);
        let last = seeds.iter().map(|s| s.0 - j0 + 1).max().unwrap_or(1);
        if let Some((what, seed, max)) = shifted_out_of_range(None, validation, arms, generator, last) {
            self.err_help(
                "draw shifts a seed out of range",
                span,
                format!("the last seed's draw ({last}) shifts {what} ({seed}) by {}", last - 1),
                format!("seed j uses draw j - {j0} + 1, which adds j - {j0} to each declared seed; keep every seed from 0 to {max}"),
            );
        }
    }

    /// Every seed a split shifts (see [`Design::for_split`]) must stay in
    /// range: at least 0, and below 2^32 under `numpy_legacy`.
    pub(super) fn shifted_seeds(
        &mut self,
        splits: &[u64],
        rf: &RecordingFactor,
        val: &ValidationSpec,
        arms: &[(Arm, Span)],
        generator: Generator,
        span: Span,
    ) {
        if !val.listed.is_empty() && !splits.is_empty() {
            self.err_help(
                "split factor on pinned recordings",
                span,
                "the validation recordings are pinned, so every split would draw evaluation recordings around the same validation set",
                "draw them instead: `validation N windows from K recordings seed S`",
            );
        }
        // A seed is written as a design integer (at most i64::MAX).
        let max = if generator == Generator::NumpyLegacy { u64::from(u32::MAX) } else { i64::MAX as u64 };
        let mut declared = vec![("the validation seed".to_string(), val.seed)];
        for (a, _) in arms {
            match a.kind {
                ArmKind::Fit { seed, .. } | ArmKind::Derived { seed, .. } => {
                    declared.push((format!("arm {}'s seed", a.name), seed))
                }
            }
        }
        for &split in splits {
            let offset = split as i128 - rf.split_seed as i128;
            for (what, seed) in &declared {
                let shifted = *seed as i128 + offset;
                if shifted < 0 || shifted > max as i128 {
                    self.err_help(
                        "split shifts a seed out of range",
                        span,
                        format!("split {split} shifts {what} ({seed}) by {offset} to {shifted}"),
                        format!("split s draws with each declared seed plus (s - split_seed), here s - {}; choose splits or seeds that keep every seed from 0 to {max}", rf.split_seed),
                    );
                    return;
                }
            }
        }
    }
}

/// The first declared seed (the split seed when `recording` is given, the
/// validation seed, each arm's) that draw `last` (each seed plus
/// `last - 1`) takes out of the generator's range: what it is, its value
/// and the range's top.
fn shifted_out_of_range(
    recording: Option<&RecordingFactor>,
    validation: Option<&ValidationSpec>,
    arms: &[(Arm, Span)],
    generator: Generator,
    last: u64,
) -> Option<(String, u64, u64)> {
    // A seed is written as a design integer (at most i64::MAX).
    let max = if generator == Generator::NumpyLegacy { u64::from(u32::MAX) } else { i64::MAX as u64 };
    let mut declared: Vec<(String, u64)> = Vec::new();
    declared.extend(recording.map(|r| ("the split seed (starts)".to_string(), r.split_seed)));
    declared.extend(validation.map(|v| ("the validation seed".to_string(), v.seed)));
    for (a, _) in arms {
        match a.kind {
            ArmKind::Fit { seed, .. } | ArmKind::Derived { seed, .. } => {
                declared.push((format!("arm {}'s seed", a.name), seed))
            }
        }
    }
    declared
        .into_iter()
        .find(|(_, seed)| seed.checked_add(last - 1).is_none_or(|s| s > max))
        .map(|(what, seed)| (what, seed, max))
}
