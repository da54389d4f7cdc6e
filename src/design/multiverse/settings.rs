//! The settings a multiverse's choices may set (`SETTINGS`: where each
//! goes and whether it is trained or analysis-only), and the choices a
//! design declares, read from its syntax tree (`declared`).

use super::super::ast::*;
use super::super::diagnostic::Diagnostic;
use crate::design::types::{Choice, ChoiceRole, Combine, MAX_SPECS};

/// Where a setting goes when a specification writes it.
#[derive(Clone, Copy)]
pub(super) enum Target {
    Data,
    Train,
    Generator,
    Draws,
    EstimateKind,
    EstimateLevel,
    Contrast,
    Cap,
}

/// The settings a choice may name: (setting, where it goes, role, what
/// its alternatives are).
const SETTINGS: [(&str, Target, ChoiceRole, &str); 19] = [
    ("state", Target::Data, ChoiceRole::Run, "a state preset (motion_capture, onboard)"),
    ("tails", Target::Data, ChoiceRole::Run, "keep, exclude or truncate"),
    ("duplicates", Target::Data, ChoiceRole::Run, "group, first or keep"),
    ("implausible", Target::Data, ChoiceRole::Run, "pooled, per_column or none"),
    ("target", Target::Train, ChoiceRole::Run, "state_scaled or standardized"),
    ("actions", Target::Train, ChoiceRole::Run, "raw or standardized"),
    ("action_noise", Target::Train, ChoiceRole::Run, "a noise SD (a number)"),
    ("lr", Target::Train, ChoiceRole::Run, "a learning rate (a number)"),
    ("batch", Target::Train, ChoiceRole::Run, "a batch size (a whole number)"),
    ("epochs", Target::Train, ChoiceRole::Run, "an epoch cap (a whole number)"),
    ("patience", Target::Train, ChoiceRole::Run, "an early-stopping patience (a whole number)"),
    ("schedule", Target::Train, ChoiceRole::Run, "cosine or constant"),
    ("universe", Target::Data, ChoiceRole::Run, "csv or metadata"),
    ("cap", Target::Cap, ChoiceRole::Run, "a divergence cap in metres (a number)"),
    ("generator", Target::Generator, ChoiceRole::Run, "chacha8 or numpy_legacy"),
    ("draws", Target::Draws, ChoiceRole::Run, "coupled or independent"),
    ("estimate", Target::EstimateKind, ChoiceRole::Analysis, "an estimator (crossed_mom, reml, ...)"),
    ("level", Target::EstimateLevel, ChoiceRole::Analysis, "a confidence level (a number)"),
    ("contrast", Target::Contrast, ChoiceRole::Analysis, "a contrast (`treated - reference`)"),
];

pub(super) fn setting(name: &str) -> Option<(Target, ChoiceRole)> {
    SETTINGS.iter().find(|s| s.0 == name).map(|s| (s.1, s.2))
}

/// The choices of an AST, their primary specification and combination,
/// checked; None when the design declares no choices (after reporting a
/// `primary specification` or a combination that has nothing to refer to).
pub(in crate::design) struct Declared {
    pub choices: Vec<(Choice, Spanned<ChoiceAst>)>,
    pub primary: Vec<usize>,
    pub combine: Combine,
}

/// Reads and checks `choices`, `primary specification` and the decision's
/// combination. Errors go to `diags`.
pub(in crate::design) fn declared(ast: &Ast, diags: &mut Vec<Diagnostic>) -> Option<Declared> {
    let mut choices_stmt = None;
    let mut primary_stmt = None;
    let mut combine = None;
    let twice = |what: &str, span: Span| {
        Diagnostic::new("declared twice", span, format!("a second `{what}` statement"))
            .with_help(format!("a design has one `{what}` statement"))
    };
    for s in &ast.statements {
        match &s.node {
            Statement::Choices(_) if choices_stmt.is_some() => diags.push(twice("choices", s.span)),
            Statement::Choices(c) => choices_stmt = Some((c, s.span)),
            Statement::PrimarySpec(_) if primary_stmt.is_some() => diags.push(twice("primary specification", s.span)),
            Statement::PrimarySpec(p) => primary_stmt = Some((p.as_slice(), s.span)),
            Statement::Decide { combine: Some(c), .. } => combine = Some(c.clone()),
            _ => {}
        }
    }
    let Some((list, span)) = choices_stmt else {
        no_choices(primary_stmt.map(|(_, span)| span), combine, diags);
        return None;
    };
    let before = diags.len();
    let mut out: Vec<(Choice, Spanned<ChoiceAst>)> = Vec::new();
    if list.is_empty() {
        diags.push(
            Diagnostic::new("no choices", span, "the `choices` block is empty")
                .with_help("list each open setting with its alternatives, e.g. `state motion_capture | onboard`"),
        );
    }
    for c in list {
        let name = &c.node.setting;
        let Some((_, role)) = setting(&name.node) else {
            let known: Vec<&str> = SETTINGS.iter().map(|s| s.0).collect();
            diags.push(
                Diagnostic::new(
                    "unknown choice",
                    name.span,
                    format!("`{}` is not a setting a choice can take", name.node),
                )
                .with_help(format!("settings a choice can take: {}", known.join(", "))),
            );
            continue;
        };
        if let Some((first, _)) = out.iter().find(|(o, _)| o.setting == name.node) {
            diags.push(Diagnostic::new("declared twice", name.span, format!("a second choice of `{}`", first.setting)));
            continue;
        }
        duplicate_alternatives(&c.node.alternatives, diags);
        let alternatives = c.node.alternatives.iter().map(|a| a.node.text().to_string()).collect();
        out.push((Choice { setting: name.node.clone(), alternatives, role }, c.clone()));
    }
    let count = out.iter().fold(1usize, |n, (c, _)| n.saturating_mul(c.alternatives.len()));
    if count > MAX_SPECS {
        diags.push(
            Diagnostic::new("too many specifications", span, format!("these choices span {count} specifications"))
                .with_help(format!("a multiverse may have at most {MAX_SPECS} specifications, each a complete run")),
        );
    }
    alternative_kinds(&out, diags);
    declared_elsewhere(ast, &out, diags);
    let primary = primary_values(&out, primary_stmt, span, diags);
    let combine = combination(combine, diags);
    if diags.len() > before {
        return None;
    }
    Some(Declared { choices: out, primary: primary?, combine })
}

/// A design without choices: a `primary specification` (at `primary`)
/// or a combination other than `in primary` has nothing to refer to.
fn no_choices(primary: Option<Span>, combine: Option<Spanned<CombineAst>>, diags: &mut Vec<Diagnostic>) {
    if let Some(span) = primary {
        diags.push(
            Diagnostic::new("no choices", span, "a primary specification needs a `choices { ... }` block")
                .with_help("declare the open choices, or drop `primary specification`"),
        );
    }
    if let Some(c) = combine.filter(|c| c.node != CombineAst::Primary) {
        diags.push(
            Diagnostic::new("no choices", c.span, "there is one specification to decide in")
                .with_help("declare the open choices with `choices { ... }`, or drop this clause"),
        );
    }
}

/// A choice's alternatives compared as values: one listed twice, or two
/// spellings of one number, is refused.
fn duplicate_alternatives(alternatives: &[Spanned<Alternative>], diags: &mut Vec<Diagnostic>) {
    let mut seen: Vec<&str> = Vec::new();
    for a in alternatives {
        let text = a.node.text();
        match seen.iter().find(|s| same_value(s, text)) {
            Some(s) if *s == text => {
                diags.push(Diagnostic::new("duplicate alternative", a.span, format!("`{text}` is listed twice")))
            }
            Some(s) => diags.push(
                Diagnostic::new("duplicate alternative", a.span, format!("`{text}` is the same value as `{s}`"))
                    .with_help("alternatives are compared as values: two spellings of one number would run one specification twice"),
            ),
            None => seen.push(text),
        }
    }
}

/// The decision's combination over specifications (`in primary` when none
/// is given); a share outside (0, 100]% is refused.
fn combination(combine: Option<Spanned<CombineAst>>, diags: &mut Vec<Diagnostic>) -> Combine {
    match combine.map(|c| c.node) {
        None | Some(CombineAst::Primary) => Combine::Primary,
        Some(CombineAst::Every) => Combine::Every,
        Some(CombineAst::AtLeast(p)) => {
            if !(p.node > 0.0 && p.node <= 100.0) {
                diags.push(Diagnostic::new(
                    "share out of range",
                    p.span,
                    format!("a share of specifications must be in (0, 100]%, found {}", p.node),
                ));
            }
            Combine::AtLeast(p.node)
        }
    }
}

/// A setting that is a choice must not also be written in the design.
fn declared_elsewhere(ast: &Ast, choices: &[(Choice, Spanned<ChoiceAst>)], diags: &mut Vec<Diagnostic>) {
    for s in &ast.statements {
        let written: Vec<(&str, Span)> = match &s.node {
            Statement::Data(b) => b
                .items
                .iter()
                .filter_map(|i| match &i.node {
                    DataItem::State(_) => Some(("state", i.span)),
                    DataItem::Tails(_) => Some(("tails", i.span)),
                    DataItem::Duplicates(_) => Some(("duplicates", i.span)),
                    DataItem::ExcludeImplausible(_) => Some(("implausible", i.span)),
                    DataItem::Universe { .. } => Some(("universe", i.span)),
                    _ => None,
                })
                .collect(),
            Statement::Train(items) => items
                .iter()
                .map(|i| {
                    let name = match &i.node {
                        TrainItem::Target(_) => "target",
                        TrainItem::Actions(_) => "actions",
                        TrainItem::ActionNoise(_) => "action_noise",
                        TrainItem::Optimizer { .. } => "lr",
                        TrainItem::Batch(_) => "batch",
                        TrainItem::Epochs(_) => "epochs",
                        TrainItem::Patience(_) => "patience",
                        TrainItem::Schedule(_) => "schedule",
                    };
                    (name, i.span)
                })
                .collect(),
            Statement::Generator(_) => vec![("generator", s.span)],
            Statement::Contrast { treated, .. } => vec![("contrast", treated.span)],
            Statement::Endpoint(e) => e.cap.iter().map(|c| ("cap", c.span)).collect(),
            Statement::Draws(_) => vec![("draws", s.span)],
            Statement::Estimate { kind, items } => std::iter::once(("estimate", kind.span))
                .chain(items.iter().filter_map(|i| match &i.node {
                    EstimateItem::Level(_) => Some(("level", i.span)),
                    _ => None,
                }))
                .collect(),
            _ => Vec::new(),
        };
        for (name, span) in written {
            if let Some((_, c)) = choices.iter().find(|(c, _)| c.setting == name) {
                diags.push(
                    Diagnostic::new(
                        "setting is a choice",
                        span,
                        format!("`{name}` is written here and is also an open choice"),
                    )
                    .with_help(format!(
                        "the choice at byte {} gives every specification its `{name}`; remove this one",
                        c.node.setting.span.start
                    )),
                );
            }
        }
    }
}

/// A choice and its alternative in `primary specification ...`.
type SpecValue = (Ident, Spanned<Alternative>);

/// The alternative index of each choice in the primary specification.
fn primary_values(
    choices: &[(Choice, Spanned<ChoiceAst>)],
    stmt: Option<(&[SpecValue], Span)>,
    choices_span: Span,
    diags: &mut Vec<Diagnostic>,
) -> Option<Vec<usize>> {
    let Some((values, span)) = stmt else {
        diags.push(
            Diagnostic::new(
                "no primary specification",
                choices_span,
                "a multiverse must say which specification is primary",
            )
            .with_help("add `primary specification SETTING ALTERNATIVE, ...` naming one alternative of every choice"),
        );
        return None;
    };
    let mut out = vec![None; choices.len()];
    for (name, alt) in values {
        let Some(k) = choices.iter().position(|(c, _)| c.setting == name.node) else {
            diags.push(Diagnostic::new(
                "unknown choice",
                name.span,
                format!("`{}` is not one of the choices", name.node),
            ));
            continue;
        };
        if out[k].is_some() {
            diags.push(Diagnostic::new("declared twice", name.span, format!("`{}` is given twice", name.node)));
            continue;
        }
        match choices[k].0.alternatives.iter().position(|a| same_value(a, alt.node.text())) {
            Some(i) => out[k] = Some(i),
            None => diags.push(
                Diagnostic::new(
                    "unknown alternative",
                    alt.span,
                    format!("`{}` is not an alternative of `{}`", alt.node.text(), name.node),
                )
                .with_help(format!("alternatives: {}", choices[k].0.alternatives.join(" | "))),
            ),
        }
    }
    for (k, v) in out.iter().enumerate() {
        if v.is_none() && !diags.iter().any(|d| d.span.start >= span.start && d.span.end <= span.end) {
            diags.push(
                Diagnostic::new(
                    "incomplete primary specification",
                    span,
                    format!("no alternative given for `{}`", choices[k].0.setting),
                )
                .with_help("the primary specification names one alternative of every choice"),
            );
        }
    }
    out.into_iter().collect()
}

/// A number alternative where a name is expected, or a name where a number is.
fn alternative_kinds(choices: &[(Choice, Spanned<ChoiceAst>)], diags: &mut Vec<Diagnostic>) {
    for (choice, c) in choices {
        let numeric = matches!(
            choice.setting.as_str(),
            "action_noise" | "level" | "lr" | "batch" | "epochs" | "patience" | "cap"
        );
        let whole = matches!(choice.setting.as_str(), "batch" | "epochs" | "patience");
        let names: &[&str] = match choice.setting.as_str() {
            "state" => &["motion_capture", "onboard"],
            "tails" => &["keep", "exclude", "truncate"],
            "duplicates" => &["group", "first", "keep"],
            "implausible" => &["pooled", "per_column", "none"],
            "target" => &["state_scaled", "standardized"],
            "actions" => &["raw", "standardized"],
            "generator" => &["chacha8", "numpy_legacy"],
            "draws" => &["coupled", "independent"],
            "schedule" => &["cosine", "constant"],
            "universe" => &["csv", "metadata"],
            _ => &[],
        };
        let contrast = choice.setting == "contrast";
        for a in &c.node.alternatives {
            let ok = match &a.node {
                Alternative::Number(v, _) if whole => v.fract() == 0.0 && *v >= 0.0 && *v < 1e15,
                Alternative::Number(..) => numeric,
                Alternative::Name(n) if contrast || n.contains(" - ") => contrast && n.contains(" - "),
                Alternative::Name(n) => !numeric && (names.is_empty() || names.contains(&n.as_str())),
            };
            if !ok {
                let want = SETTINGS.iter().find(|s| s.0 == choice.setting).map(|s| s.3).unwrap_or("");
                diags.push(
                    Diagnostic::new("wrong alternative", a.span, format!("`{}` is not {want}", a.node.text()))
                        .with_help(format!("`{}` takes {want}", choice.setting)),
                );
            }
        }
    }
}

/// Whether two alternatives as written are the same value: the same text,
/// or two spellings of one number (`1e-3` and `0.001`, `2` and `2.0`).
fn same_value(a: &str, b: &str) -> bool {
    let number = |s: &str| {
        s.starts_with(|c: char| c.is_ascii_digit() || matches!(c, '.' | '+' | '-'))
            .then(|| s.parse::<f64>().ok())
            .flatten()
            .filter(|v| v.is_finite())
    };
    a == b || matches!((number(a), number(b)), (Some(x), Some(y)) if x == y)
}
