//! One specification's design text: the choices, the primary
//! specification and the combination removed, and each choice's
//! alternative written where its setting belongs.

use super::super::ast::*;
use super::settings::{setting, Declared, Target};
use crate::design::types::Choice;

/// Every combination of alternatives, the first choice varying slowest.
pub(in crate::design) fn combinations(choices: &[Choice]) -> Vec<Vec<usize>> {
    let mut out = vec![Vec::new()];
    for c in choices {
        out = out
            .into_iter()
            .flat_map(|prefix| {
                (0..c.alternatives.len()).map(move |i| {
                    let mut p = prefix.clone();
                    p.push(i);
                    p
                })
            })
            .collect();
    }
    out
}

/// The AST of one specification: the choices, the primary specification
/// and the combination removed, and each choice's alternative written
/// where the setting belongs (with the alternative's span, so that errors
/// point at it).
pub(in crate::design) fn spec_ast(ast: &Ast, declared: &Declared, values: &[usize]) -> Ast {
    let mut statements: Vec<Spanned<Statement>> = ast
        .statements
        .iter()
        .filter(|s| !matches!(s.node, Statement::Choices(_) | Statement::PrimarySpec(_)))
        .cloned()
        .map(|mut s| {
            if let Statement::Decide { combine, .. } = &mut s.node {
                *combine = None;
            }
            s
        })
        .collect();
    for ((choice, c), &i) in declared.choices.iter().zip(values) {
        let alt = &c.node.alternatives[i];
        let ident = Spanned::new(alt.node.text().to_string(), alt.span);
        let number = match alt.node {
            Alternative::Number(v, _) => v,
            Alternative::Name(_) => f64::NAN,
        };
        let Some((target, _)) = setting(&choice.setting) else { continue };
        let item_span = alt.span;
        match target {
            Target::Data => {
                let item = data_choice(&choice.setting, ident);
                for s in &mut statements {
                    if let (Statement::Data(b), Some(item)) = (&mut s.node, item.clone()) {
                        b.items.push(Spanned::new(item, item_span));
                    }
                }
            }
            Target::Train => {
                let item = train_choice(&choice.setting, ident, number, alt.span);
                for s in &mut statements {
                    if let Statement::Train(items) = &mut s.node {
                        items.push(Spanned::new(item.clone(), item_span));
                    }
                }
            }
            Target::Generator => statements.push(Spanned::new(Statement::Generator(ident), item_span)),
            Target::Cap => {
                for s in &mut statements {
                    if let Statement::Endpoint(e) = &mut s.node {
                        e.cap = Some(Spanned::new(number, alt.span));
                    }
                }
            }
            Target::Contrast => {
                let text = alt.node.text();
                let (treated, reference) = text.split_once(" - ").unwrap_or((text, ""));
                let at = |s: &str| Spanned::new(s.to_string(), item_span);
                statements.push(Spanned::new(
                    Statement::Contrast { treated: at(treated), reference: at(reference) },
                    item_span,
                ));
            }
            Target::Draws => statements.push(Spanned::new(Statement::Draws(ident), item_span)),
            Target::EstimateKind => estimate_kind(&mut statements, ident, item_span),
            Target::EstimateLevel => {
                let level = Spanned::new(EstimateItem::Level(Spanned::new(number, alt.span)), item_span);
                estimate_level(&mut statements, level, item_span);
            }
        }
    }
    Ast { statements }
}

/// The data item a choice of the data block sets: a state preset, a tails,
/// duplicates or universe policy, or the implausibility rule's pooling
/// (`none`: no item).
fn data_choice(setting: &str, ident: Ident) -> Option<DataItem> {
    match setting {
        "state" => Some(DataItem::State(vec![ident])),
        "tails" => Some(DataItem::Tails(ident)),
        "duplicates" => Some(DataItem::Duplicates(ident)),
        "universe" => Some(DataItem::Universe { kind: ident, order: None }),
        _ if ident.node == "none" => None,
        _ => Some(DataItem::ExcludeImplausible(Some(ident))),
    }
}

/// The training item a choice of the train block sets, its alternative
/// as a name (`ident`) or a number, at `span`.
fn train_choice(setting: &str, ident: Ident, number: f64, span: Span) -> TrainItem {
    let int = Spanned::new(number as i64, span);
    match setting {
        "target" => TrainItem::Target(ident),
        "actions" => TrainItem::Actions(ident),
        "schedule" => TrainItem::Schedule(ident),
        "batch" => TrainItem::Batch(int),
        "epochs" => TrainItem::Epochs(int),
        "patience" => TrainItem::Patience(int),
        "lr" => TrainItem::Optimizer { kind: Spanned::new("adam".to_string(), span), lr: Spanned::new(number, span) },
        _ => TrainItem::ActionNoise(Spanned::new(number, span)),
    }
}

/// The estimator a choice names, written into every `estimate` statement
/// (one with no clauses is added when there is none).
fn estimate_kind(statements: &mut Vec<Spanned<Statement>>, ident: Ident, span: Span) {
    let mut found = false;
    for s in statements.iter_mut() {
        if let Statement::Estimate { kind, .. } = &mut s.node {
            *kind = ident.clone();
            found = true;
        }
    }
    if !found {
        statements.push(Spanned::new(Statement::Estimate { kind: ident, items: Vec::new() }, span));
    }
}

/// The confidence level a choice gives, added to every `estimate`
/// statement (a `crossed_mom` one is added when there is none).
fn estimate_level(statements: &mut Vec<Spanned<Statement>>, level: Spanned<EstimateItem>, span: Span) {
    let mut found = false;
    for s in statements.iter_mut() {
        if let Statement::Estimate { items, .. } = &mut s.node {
            items.push(level.clone());
            found = true;
        }
    }
    if !found {
        let kind = Spanned::new("crossed_mom".to_string(), span);
        statements.push(Spanned::new(Statement::Estimate { kind, items: vec![level] }, span));
    }
}

/// Zero-padded specification ids: `s1`..`s8`, or `s01`..`s12`.
pub(in crate::design) fn spec_id(k: usize, count: usize) -> String {
    let width = count.to_string().len();
    format!("s{:0width$}", k + 1)
}
