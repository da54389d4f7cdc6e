//! Located design errors, rendered once at the boundary in the rustc
//! layout: headline, `--> file:line:column`, the source line and a caret
//! under the offending span. Plain text unless colour is asked for.
//!
//! Hand-written rather than ariadne: ariadne draws no caret under
//! one-character spans, and most of our spans are single digits.

use std::fmt;

use super::ast::Span;

/// One problem in a design, with the span it points at.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    /// Short headline, e.g. "unknown arm".
    pub title: String,
    /// Where in the source it points.
    pub span: Span,
    /// What is wrong at the span.
    pub label: String,
    /// How to fix it, when there is something useful to say.
    pub help: Option<String>,
}

impl Diagnostic {
    /// A diagnostic with no help text.
    pub fn new(title: impl Into<String>, span: Span, label: impl Into<String>) -> Self {
        Diagnostic { title: title.into(), span, label: label.into(), help: None }
    }

    /// Adds a help line.
    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }
}

/// Every problem found in one design file, with the text needed to show them.
#[derive(Debug, Clone)]
pub struct DesignError {
    /// The design file's name as shown.
    pub file: String,
    /// The design text, for quoting source lines.
    pub source_text: String,
    /// Every problem, in source order.
    pub diagnostics: Vec<Diagnostic>,
}

impl DesignError {
    /// Every diagnostic as JSON, in source order: headline, file, 1-based
    /// line and column (in characters), label and help (`crossaudit check
    /// --json`).
    pub fn to_json(&self) -> serde_json::Value {
        let items: Vec<serde_json::Value> = self
            .diagnostics
            .iter()
            .map(|d| {
                let loc = locate(&self.source_text, d.span);
                serde_json::json!({
                    "title": d.title,
                    "file": self.file,
                    "line": loc.line,
                    "column": loc.col,
                    "label": d.label,
                    "help": d.help,
                })
            })
            .collect();
        serde_json::Value::Array(items)
    }

    /// Renders all diagnostics as plain text (`color = false`) or with ANSI
    /// colours for a terminal.
    pub fn render(&self, color: bool) -> String {
        let mut out = String::new();
        for d in &self.diagnostics {
            render_one(&mut out, &self.file, &self.source_text, d, color);
        }
        out
    }
}

/// 1-based line and column (in characters) of a byte offset, the line's
/// text, and the column where the span stops on that line.
struct Location {
    line: usize,
    col: usize,
    /// The line as shown: all of it, or a window around the span.
    text: String,
    /// The span's first and last-plus-one columns in `text`.
    shown_col: usize,
    end_col: usize,
}

/// The most characters of a source line quoted: a design that writes a
/// 100,000-seed list on one line is quoted around its error, not whole.
const MAX_QUOTED: usize = 120;

/// `loc` with its line cut to [`MAX_QUOTED`] characters around the span
/// (`...` marks what is left out), the span's carets at most that wide.
fn shorten(loc: Location) -> Location {
    let chars: Vec<char> = loc.text.chars().collect();
    if chars.len() <= MAX_QUOTED {
        return loc;
    }
    let from = (loc.col - 1).saturating_sub(MAX_QUOTED / 3);
    let to = (from + MAX_QUOTED).min(chars.len());
    let head = if from > 0 { "..." } else { "" };
    let tail = if to < chars.len() { "..." } else { "" };
    let text = format!("{head}{}{tail}", chars[from..to].iter().collect::<String>());
    let shown_col = loc.col - from + head.len();
    let end_col = (loc.end_col - from + head.len()).min(to - from + head.len() + 1).max(shown_col + 1);
    Location { text, shown_col, end_col, ..loc }
}

fn locate(source: &str, span: Span) -> Location {
    let start = floor_char_boundary(source, span.start.min(source.len()));
    let end = floor_char_boundary(source, span.end.clamp(start, source.len()));
    let line_start = source[..start].rfind('\n').map(|k| k + 1).unwrap_or(0);
    let line_end = source[start..].find('\n').map(|k| start + k).unwrap_or(source.len());
    let text = source[line_start..line_end].trim_end_matches('\r');
    let line = source[..start].matches('\n').count() + 1;
    let col = source[line_start..start].chars().count() + 1;
    let end_on_line = end.min(line_start + text.len()).max(start);
    let width = source[start..end_on_line].chars().count().max(1);
    Location { line, col, text: text.to_string(), shown_col: col, end_col: col + width }
}

fn floor_char_boundary(s: &str, mut k: usize) -> usize {
    while k > 0 && !s.is_char_boundary(k) {
        k -= 1;
    }
    k
}

/// `text` with each control character but a tab replaced by one visible
/// character (its Unicode control picture, `␛` for ESC; `�` for the C1
/// controls), so a quoted line keeps its columns and sends the terminal
/// nothing.
///
/// ```
/// # use crossaudit::design::diagnostic_visible as visible;
/// assert_eq!(visible("a\u{1b}[2Jb\tc"), "a\u{241b}[2Jb\tc");
/// assert_eq!(visible("x\u{7f}\u{9b}"), "x\u{2421}\u{fffd}");
/// ```
pub fn visible(text: &str) -> String {
    text.chars()
        .map(|c| match c {
            '\t' => c,
            '\u{0}'..='\u{1f}' => char::from_u32(0x2400 + c as u32).unwrap_or('\u{fffd}'),
            '\u{7f}' => '\u{2421}',
            '\u{80}'..='\u{9f}' => '\u{fffd}',
            _ => c,
        })
        .collect()
}

fn render_one(out: &mut String, file: &str, source: &str, d: &Diagnostic, color: bool) {
    use fmt::Write as _;
    let paint = |code: &str, text: &str| {
        if color {
            format!("\x1b[{code}m{text}\x1b[0m")
        } else {
            text.to_string()
        }
    };
    let loc = shorten(locate(source, d.span));
    let gutter = " ".repeat(loc.line.to_string().len());
    let bar = paint("1;34", "|");
    let _ = writeln!(out, "{}: {}", paint("1;31", "error"), paint("1", &d.title));
    let _ = writeln!(out, "{gutter}{} {file}:{}:{}", paint("1;34", "-->"), loc.line, loc.col);
    let _ = writeln!(out, "{gutter} {bar}");
    // The quoted line with its control characters shown, never sent: a
    // raw ESC in a design must not drive the terminal.
    let _ = writeln!(out, "{} {bar} {}", paint("1;34", &loc.line.to_string()), visible(&loc.text));
    // Keep tabs under tabs so the caret lines up however tabs are shown.
    let pad: String = loc.text.chars().take(loc.shown_col - 1).map(|c| if c == '\t' { '\t' } else { ' ' }).collect();
    let carets = "^".repeat(loc.end_col - loc.shown_col);
    let _ = writeln!(out, "{gutter} {bar} {pad}{} {}", paint("1;31", &carets), paint("1;31", &visible(&d.label)));
    if let Some(help) = &d.help {
        let _ = writeln!(out, "{gutter} {bar}");
        let _ = writeln!(out, "{gutter} = help: {}", visible(help));
    }
    out.push('\n');
}

impl fmt::Display for DesignError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.render(false))
    }
}

impl std::error::Error for DesignError {}
