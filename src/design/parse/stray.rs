//! A syntax error caused by a character that is not ASCII where the
//! language reads only ASCII (a keyword, a name, a number): a zero-width or
//! no-break space pasted from a web page, a Cyrillic `о` that looks like
//! `o`. pest reports such an error at the start of the statement, under a
//! keyword that is itself valid, and the character may be invisible; the
//! diagnostic names the character and points at it instead.

use pest::Parser;

use super::pairs::{DesignParser, Rule};
use crate::design::ast::Span;
use crate::design::diagnostic::Diagnostic;

/// At most this many characters are tried, each with one more parse.
const TRIES: usize = 64;

/// The byte offset a pest error stands at.
pub(super) fn offset(e: &pest::error::Error<Rule>) -> usize {
    match e.location {
        pest::error::InputLocation::Pos(p) => p,
        pest::error::InputLocation::Span((s, _)) => s,
    }
}

/// The diagnostic of the character that is not ASCII and caused a parse of
/// `source` to fail at byte `failed_at`: the first, from the start of that
/// line on, whose replacement (a space for a space, nothing for an
/// invisible character, a letter otherwise) lets the parse get further. `None`
/// where no such character is there (the error is another).
pub(super) fn stray_character(source: &str, failed_at: usize) -> Option<Diagnostic> {
    let line_start = source[..failed_at.min(source.len())].rfind('\n').map_or(0, |i| i + 1);
    let reaches = |text: &str| DesignParser::parse(Rule::design, text).map_or_else(|e| offset(&e), |_| usize::MAX);
    let (at, c) = source[line_start..]
        .char_indices()
        .filter(|(_, c)| !c.is_ascii())
        .take(TRIES)
        .map(|(i, c)| (line_start + i, c))
        .find(|&(at, c)| {
            let fill = match c {
                _ if invisible(c) => String::new(),
                _ if c.is_whitespace() => " ".repeat(c.len_utf8()),
                _ => "x".repeat(c.len_utf8()),
            };
            reaches(&format!("{}{fill}{}", &source[..at], &source[at + c.len_utf8()..])) > failed_at
        })?;
    let shown = match name(c) {
        Some(name) => format!("U+{:04X} {name}", c as u32),
        None => format!("`{c}` (U+{:04X})", c as u32),
    };
    Some(
        Diagnostic::new(
            "character that is not ASCII",
            Span { start: at, end: at + c.len_utf8() },
            format!("{shown} stands where the language reads only ASCII (keywords, names, numbers)"),
        )
        .with_help(
            "retype the word around it in plain ASCII (a character pasted from a web page or a document may look like a space or a letter and be neither); other characters belong only in quoted strings and comments",
        ),
    )
}

/// Whether `c` shows as nothing (taken out rather than replaced).
fn invisible(c: char) -> bool {
    matches!(c, '\u{200B}'..='\u{200D}' | '\u{2060}' | '\u{FEFF}' | '\u{00AD}')
}

/// The Unicode name of a character one cannot tell apart from ASCII or see.
fn name(c: char) -> Option<&'static str> {
    Some(match c {
        '\u{00A0}' => "NO-BREAK SPACE",
        '\u{2002}' => "EN SPACE",
        '\u{2003}' => "EM SPACE",
        '\u{2009}' => "THIN SPACE",
        '\u{202F}' => "NARROW NO-BREAK SPACE",
        '\u{3000}' => "IDEOGRAPHIC SPACE",
        '\u{200B}' => "ZERO WIDTH SPACE",
        '\u{200C}' => "ZERO WIDTH NON-JOINER",
        '\u{200D}' => "ZERO WIDTH JOINER",
        '\u{2060}' => "WORD JOINER",
        '\u{FEFF}' => "ZERO WIDTH NO-BREAK SPACE",
        '\u{00AD}' => "SOFT HYPHEN",
        '\u{2010}' => "HYPHEN",
        '\u{2013}' => "EN DASH",
        '\u{2212}' => "MINUS SIGN",
        '\u{2018}' => "LEFT SINGLE QUOTATION MARK",
        '\u{2019}' => "RIGHT SINGLE QUOTATION MARK",
        '\u{201C}' => "LEFT DOUBLE QUOTATION MARK",
        '\u{201D}' => "RIGHT DOUBLE QUOTATION MARK",
        _ => return None,
    })
}
