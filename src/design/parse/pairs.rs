//! The pest parser of the `.design` grammar (`DesignParser`, its `Rule`)
//! and the helpers that turn its pairs into the owned syntax tree's leaves
//! (names, numbers, strings, spans), shared by every part of the parse.

use pest::iterators::Pair;

use crate::design::ast::*;
use crate::design::diagnostic::Diagnostic;

#[derive(pest_derive::Parser)]
#[grammar = "../grammar/design.pest"]
pub(super) struct DesignParser;

/// The pair's span without trailing whitespace or comments, which pest
/// may include when a repetition at the end of a rule fails.
pub(super) fn span_of(pair: &Pair<Rule>) -> Span {
    let s = pair.as_span();
    let mut text = s.as_str();
    loop {
        let trimmed = text.trim_end();
        // A trailing comment line: drop it and trim again.
        match trimmed.rfind('\n') {
            Some(k) if trimmed[k + 1..].trim_start().starts_with('#') => text = &trimmed[..k],
            _ => {
                text = trimmed;
                break;
            }
        }
    }
    Span { start: s.start(), end: s.start() + text.len() }
}

pub(super) fn ident(pair: Pair<Rule>) -> Ident {
    Spanned::new(pair.as_str().to_string(), span_of(&pair))
}

pub(super) fn strings(pair: Pair<Rule>) -> Vec<Spanned<String>> {
    pair.into_inner().map(string).collect()
}

/// A column name, bare or quoted.
pub(super) fn col(pair: Pair<Rule>) -> Ident {
    if pair.as_rule() == Rule::string {
        string(pair)
    } else {
        ident(pair)
    }
}

pub(super) fn cols(pair: Pair<Rule>) -> Vec<Ident> {
    pair.into_inner().map(col).collect()
}

pub(super) fn idents(pair: Pair<Rule>) -> Vec<Ident> {
    pair.into_inner().map(ident).collect()
}

pub(super) fn int(pair: Pair<Rule>) -> Result<Int, Diagnostic> {
    let span = span_of(&pair);
    let text: String = pair.as_str().chars().filter(|c| *c != '_').collect();
    text.parse::<i64>().map(|v| Spanned::new(v, span)).map_err(|_| {
        Diagnostic::new("integer out of range", span, "does not fit in a 64-bit signed integer").with_help(format!(
            "a design's integers run from {} to {}",
            i64::MIN,
            i64::MAX
        ))
    })
}

pub(super) fn number(pair: Pair<Rule>) -> Result<Number, Diagnostic> {
    let span = span_of(&pair);
    let text = pair.as_str();
    let mantissa = text.split(['e', 'E']).next().unwrap_or(text);
    match text.parse::<f64>() {
        // 1e-400 is read as 0: a threshold written nonzero would decide as 0.
        Ok(v) if v == 0.0 && mantissa.chars().any(|c| ('1'..='9').contains(&c)) => Err(Diagnostic::new(
            "number out of range",
            span,
            "is too small for double precision: it would be read as 0",
        )),
        Ok(v) if v.is_finite() => Ok(Spanned::new(v, span)),
        _ => Err(Diagnostic::new("number out of range", span, "is not a finite number")),
    }
}

pub(super) fn string(pair: Pair<Rule>) -> Spanned<String> {
    let span = span_of(&pair);
    let inner = pair.into_inner().next().map(|p| p.as_str()).unwrap_or("");
    Spanned::new(inner.to_string(), span)
}

pub(super) fn cmp(pair: Pair<Rule>) -> Spanned<Cmp> {
    let c = match pair.as_str() {
        ">=" => Cmp::Ge,
        "<=" => Cmp::Le,
        ">" => Cmp::Gt,
        _ => Cmp::Lt,
    };
    Spanned::new(c, span_of(&pair))
}

/// Children of a pair, in order.
pub(super) struct Kids<'i>(pub(super) pest::iterators::Pairs<'i, Rule>);

impl<'i> Kids<'i> {
    /// The next child.
    pub(super) fn next(&mut self) -> Pair<'i, Rule> {
        self.0.next().expect("grammar guarantees this child")
    }
    /// The next child's rule, if any.
    pub(super) fn peek_rule(&self) -> Option<Rule> {
        self.0.peek().map(|p| p.as_rule())
    }
}

pub(super) fn kids(pair: Pair<'_, Rule>) -> Kids<'_> {
    Kids(pair.into_inner())
}
