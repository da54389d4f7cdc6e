//! Located design errors, rendered once at the boundary with the source line
//! and a caret (ariadne, ASCII, no colour unless asked).

use std::fmt;

use ariadne::{CharSet, Config, IndexType, Label, Report, ReportKind, Source};

use super::ast::Span;

/// One problem in a design, with the span it points at.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    /// Short headline, e.g. "unknown arm".
    pub title: String,
    pub span: Span,
    /// What is wrong at the span.
    pub label: String,
    /// How to fix it, when there is something useful to say.
    pub help: Option<String>,
}

impl Diagnostic {
    pub fn new(title: impl Into<String>, span: Span, label: impl Into<String>) -> Self {
        Diagnostic { title: title.into(), span, label: label.into(), help: None }
    }

    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }
}

/// Every problem found in one design file, with the text needed to show them.
#[derive(Debug, Clone)]
pub struct DesignError {
    pub file: String,
    pub source_text: String,
    pub diagnostics: Vec<Diagnostic>,
}

impl DesignError {
    /// Renders all diagnostics as plain text (`color = false`) or with ANSI
    /// colours for a terminal.
    pub fn render(&self, color: bool) -> String {
        let mut out = Vec::new();
        for d in &self.diagnostics {
            let span = clamp(d.span, self.source_text.len());
            let config = Config::default()
                .with_color(color)
                .with_char_set(if color { CharSet::Unicode } else { CharSet::Ascii })
                .with_index_type(IndexType::Byte);
            let id = self.file.as_str();
            let mut report = Report::build(ReportKind::Error, id, span.start)
                .with_config(config)
                .with_message(&d.title)
                .with_label(Label::new((id, span.range())).with_message(&d.label));
            if let Some(help) = &d.help {
                report = report.with_help(help);
            }
            // Writing into a Vec cannot fail.
            let _ = report.finish().write((id, Source::from(self.source_text.as_str())), &mut out);
        }
        // ariadne pads label lines with spaces; trim them so the text is
        // stable to compare and copy.
        let text = String::from_utf8_lossy(&out);
        let mut trimmed: String = text.lines().map(|l| l.trim_end()).collect::<Vec<_>>().join("\n");
        trimmed.push('\n');
        trimmed
    }
}

/// Keeps a span inside the source so that a caret at end of file still renders.
fn clamp(span: Span, len: usize) -> Span {
    let start = span.start.min(len);
    let end = span.end.clamp(start, len);
    Span { start, end }
}

impl fmt::Display for DesignError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.render(false))
    }
}

impl std::error::Error for DesignError {}
