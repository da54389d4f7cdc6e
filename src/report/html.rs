//! report.html: the report as one self-contained page. A banner with the
//! decision and the preregistration status first, then report.md's own
//! sections (the same text, so the two cannot drift) with every figure
//! drawn inline as SVG. No script, no external style sheet, no network.
//!
//! report.md is parsed by pulldown-cmark (CommonMark and GitHub tables);
//! the HTML is written here from its events, so nothing from the text
//! reaches the page as markup: raw HTML is shown as text, only relative
//! and http(s) links are live, and an image is a figure given inline (the
//! page loads nothing). Names from input are also escaped for Markdown
//! where report.md writes them (`super::md`).

use std::fmt::Write as _;

use super::format::decision_line;
use crate::analysis::Analysis;

const STYLE: &str = "body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,sans-serif;max-width:78rem;margin:0 auto;padding:0 1rem 3rem;color:#1b1f23;line-height:1.45}\
.banner{margin:1rem 0;padding:.9rem 1.1rem;border-radius:6px;border-left:8px solid}\
.banner.holds{background:#e6f4ea;border-color:#1e7e34}.banner.fails{background:#fdecea;border-color:#b3261e}.banner.descriptive{background:#f6f8fa;border-color:#6e7781}\
.banner .verdict{font-size:1.4rem;font-weight:700;display:block}.banner .status{display:block;margin-top:.3rem;font-weight:600}\
table{border-collapse:collapse;margin:.6rem 0 1.2rem;font-size:.88rem}th,td{border:1px solid #d0d7de;padding:.25rem .5rem}\
th{background:#f6f8fa}td.num{text-align:right;font-variant-numeric:tabular-nums}\
code{background:#f6f8fa;padding:0 .2rem;border-radius:3px}figure{margin:1rem 0}figure svg{max-width:100%;height:auto}\
h1{font-size:1.6rem}h2{border-bottom:1px solid #d0d7de;padding-bottom:.2rem;margin-top:2rem}\
.banner h1.verdict{margin:0 0 .3rem;font-size:1.5rem}.banner .warnings{margin-top:.5rem;font-size:.92rem}.banner .guards p{margin:.4rem 0 0}.banner .warnings ul{margin:.2rem 0 0;padding-left:1.2rem}\
nav.toc{font-size:.92rem;margin:.5rem 0 1rem}nav.toc ul{columns:2;margin:.2rem 0;padding-left:1.2rem}";

/// Escapes text for HTML.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// Whether a link target may become a live link: `http(s)` or a relative
/// path (no scheme, not starting with `/` or `\`, no whitespace or control
/// characters). Anything else (`javascript:`, `data:`, `//host`, `file:`)
/// is rendered as its text only.
pub(crate) fn safe_link(target: &str) -> bool {
    if target.is_empty() || target.chars().any(|c| c.is_control() || c.is_whitespace()) {
        return false;
    }
    let lower = target.to_ascii_lowercase();
    if lower.starts_with("http://") || lower.starts_with("https://") {
        return true;
    }
    let first_delim = target.find(['/', '?', '#']).unwrap_or(target.len());
    !target.starts_with(['/', '\\']) && !target[..first_delim].contains(':')
}

/// The figure inlined for `![alt](file)`; a figure it was not given is
/// named in text (the page loads nothing from elsewhere).
fn image(alt: &str, file: &str, figures: &[(String, String)]) -> String {
    match figures.iter().find(|(name, _)| name == file) {
        Some((_, svg)) => {
            let body = svg.trim_start();
            let body = match body.strip_prefix("<?xml") {
                Some(r) => r.split_once("?>").map(|(_, b)| b.trim_start()).unwrap_or(body),
                None => body,
            };
            format!("<figure data-figure=\"{}\" aria-label=\"{}\">\n{body}\n</figure>\n", esc(file), esc(alt))
        }
        None => format!("<p>[figure not included: {}]</p>\n", esc(alt)),
    }
}

/// report.md converted to HTML by pulldown-cmark (CommonMark with GitHub
/// tables). Raw HTML in the text is shown as text, never passed through;
/// a link is live only when [`safe_link`] allows its target; an image is
/// the inline SVG of a figure given in `figures`, or its alt text.
fn body(markdown: &str, figures: &[(String, String)]) -> String {
    use pulldown_cmark::{Event, Options, Parser, Tag, TagEnd};
    let events: Vec<Event> = Parser::new_ext(markdown, Options::ENABLE_TABLES).collect();
    let mut out = String::new();
    let mut table = TableState::default();
    // Open links: whether each was rendered live (its end closes an `<a>`).
    let mut links: Vec<bool> = Vec::new();
    let mut k = 0;
    while k < events.len() {
        if table.event(&events[k], &mut out) {
            k += 1;
            continue;
        }
        match &events[k] {
            Event::Start(Tag::Paragraph) => {
                // A paragraph that is only an image is the figure itself.
                if let Some(j) = lone_image(&events, k) {
                    out.push_str(&image_at(&events, k + 1, j, figures));
                    k = j + 2;
                    continue;
                }
                out.push_str("<p>");
            }
            Event::End(TagEnd::Paragraph) => out.push_str("</p>\n"),
            Event::Start(Tag::Heading { level, .. }) => out.push_str(&heading_open(*level, &events[k + 1..])),
            Event::End(TagEnd::Heading(level)) => {
                let _ = writeln!(out, "</{level}>");
            }
            Event::Start(Tag::List(Some(n))) if *n != 1 => {
                let _ = writeln!(out, "<ol start=\"{n}\">");
            }
            Event::Start(Tag::List(Some(_))) => out.push_str("<ol>\n"),
            Event::Start(Tag::List(None)) => out.push_str("<ul>\n"),
            Event::End(TagEnd::List(ordered)) => out.push_str(if *ordered { "</ol>\n" } else { "</ul>\n" }),
            Event::Start(Tag::Item) => out.push_str("<li>"),
            Event::End(TagEnd::Item) => out.push_str("</li>\n"),
            Event::Start(Tag::Emphasis) => out.push_str("<em>"),
            Event::End(TagEnd::Emphasis) => out.push_str("</em>"),
            Event::Start(Tag::Strong) => out.push_str("<strong>"),
            Event::End(TagEnd::Strong) => out.push_str("</strong>"),
            Event::Start(Tag::BlockQuote(_)) => out.push_str("<blockquote>\n"),
            Event::End(TagEnd::BlockQuote(_)) => out.push_str("</blockquote>\n"),
            Event::Start(Tag::CodeBlock(_)) => out.push_str("<pre><code>"),
            Event::End(TagEnd::CodeBlock) => out.push_str("</code></pre>\n"),
            Event::Start(Tag::Link { dest_url, .. }) => {
                let live = safe_link(dest_url);
                if live {
                    let _ = write!(out, "<a href=\"{}\">", esc(dest_url));
                }
                links.push(live);
            }
            Event::End(TagEnd::Link) if links.pop() == Some(true) => out.push_str("</a>"),
            Event::Start(Tag::Image { .. }) => {
                // An image inside other text: its alt text only.
                let close = (k + 1..events.len()).find(|&j| matches!(events[j], Event::End(TagEnd::Image)));
                let j = close.unwrap_or(events.len() - 1);
                out.push_str(&esc(&alt_text(&events[k + 1..j])));
                k = j + 1;
                continue;
            }
            Event::Text(t) => out.push_str(&esc(t)),
            Event::Code(t) => {
                let _ = write!(out, "<code>{}</code>", esc(t));
            }
            // Raw HTML is text here: the page carries no markup from input.
            Event::Html(t) | Event::InlineHtml(t) => out.push_str(&esc(t)),
            Event::Start(Tag::HtmlBlock) => out.push_str("<p>"),
            Event::End(TagEnd::HtmlBlock) => out.push_str("</p>\n"),
            Event::SoftBreak => out.push(' '),
            Event::HardBreak => out.push_str("<br>\n"),
            Event::Rule => out.push_str("<hr>\n"),
            // Everything else (footnotes, math, task markers: none enabled)
            // contributes its text only.
            _ => {}
        }
        k += 1;
    }
    out
}

/// Where a table's rendering stands: its columns' alignments, whether in
/// its head, and the cell's column.
#[derive(Default)]
struct TableState {
    align: Vec<pulldown_cmark::Alignment>,
    in_head: bool,
    column: usize,
}

impl TableState {
    /// Writes a table's event (the table, its head, a row, a cell) to
    /// `out`; false for every other event, left to [`body`].
    fn event(&mut self, event: &pulldown_cmark::Event, out: &mut String) -> bool {
        use pulldown_cmark::{Alignment, Event, Tag, TagEnd};
        match event {
            Event::Start(Tag::Table(a)) => {
                self.align = a.clone();
                out.push_str("<table>\n");
            }
            Event::End(TagEnd::Table) => out.push_str("</tbody>\n</table>\n"),
            Event::Start(Tag::TableHead) => {
                self.in_head = true;
                self.column = 0;
                out.push_str("<thead><tr>");
            }
            Event::End(TagEnd::TableHead) => {
                self.in_head = false;
                out.push_str("</tr></thead>\n<tbody>\n");
            }
            Event::Start(Tag::TableRow) => {
                self.column = 0;
                out.push_str("<tr>");
            }
            Event::End(TagEnd::TableRow) => out.push_str("</tr>\n"),
            Event::Start(Tag::TableCell) => {
                let right = self.align.get(self.column) == Some(&Alignment::Right);
                out.push_str(match (self.in_head, right) {
                    (true, _) => "<th>",
                    (false, true) => "<td class=\"num\">",
                    (false, false) => "<td>",
                });
            }
            Event::End(TagEnd::TableCell) => {
                out.push_str(if self.in_head { "</th>" } else { "</td>" });
                self.column += 1;
            }
            _ => return false,
        }
        true
    }
}

/// Where the image ends when the paragraph starting at `k` is that image
/// alone.
fn lone_image(events: &[pulldown_cmark::Event], k: usize) -> Option<usize> {
    use pulldown_cmark::{Event, Tag, TagEnd};
    if let Some(Event::Start(Tag::Image { .. })) = events.get(k + 1) {
        let close = (k + 2..events.len()).find(|&j| matches!(events[j], Event::End(TagEnd::Image)));
        return close.filter(|&j| matches!(events.get(j + 1), Some(Event::End(TagEnd::Paragraph))));
    }
    None
}

/// A heading's opening tag; an `h2` carries an anchor made of its own
/// text (`rest`: the events after its start).
fn heading_open(level: pulldown_cmark::HeadingLevel, rest: &[pulldown_cmark::Event]) -> String {
    use pulldown_cmark::{Event, TagEnd};
    if level == pulldown_cmark::HeadingLevel::H2 {
        // The heading's own text, for its anchor.
        let text: String = rest
            .iter()
            .take_while(|e| !matches!(e, Event::End(TagEnd::Heading(_))))
            .filter_map(|e| match e {
                Event::Text(t) | Event::Code(t) => Some(t.to_string()),
                _ => None,
            })
            .collect();
        format!("<{level} id=\"{}\">", slug(&text))
    } else {
        format!("<{level}>")
    }
}

/// The plain text of events (an image's alt text).
fn alt_text(events: &[pulldown_cmark::Event]) -> String {
    use pulldown_cmark::Event;
    events
        .iter()
        .filter_map(|e| match e {
            Event::Text(t) | Event::Code(t) => Some(t.as_ref()),
            Event::SoftBreak | Event::HardBreak => Some(" "),
            _ => None,
        })
        .collect()
}

/// The figure for the image whose start is `events[start]` and end `events[end]`.
fn image_at(events: &[pulldown_cmark::Event], start: usize, end: usize, figures: &[(String, String)]) -> String {
    let pulldown_cmark::Event::Start(pulldown_cmark::Tag::Image { dest_url, .. }) = &events[start] else {
        return String::new();
    };
    image(&alt_text(&events[start + 1..end]), dest_url, figures)
}

/// What a page's banner says: the verdict (`CONFIRMED`, `NOT GROWS`),
/// whether it holds, the decision line and the preregistration status.
pub struct Banner {
    /// The verdict in capitals.
    pub verdict: String,
    /// Whether the rule holds (the banner's colour).
    pub holds: bool,
    /// The decision line, with the observed values.
    pub line: String,
    /// The preregistration status, as a sentence.
    pub status: String,
    /// The verdict's guards, each a Markdown paragraph: the banner gives
    /// them in full, and the page's body no longer repeats them.
    pub guards: Vec<String>,
    /// One contrast of a family, on which no rule decides: a grey banner.
    pub descriptive: bool,
}

impl Banner {
    /// The banner of a rule named `name` that holds or not, with its
    /// decision line and the analysis's lock state.
    pub fn new(name: &str, holds: bool, line: String, standing: &crate::analysis::Standing) -> Banner {
        Banner {
            verdict: super::format::verdict_word(name, holds),
            holds,
            line,
            status: standing.sentence(),
            guards: Vec::new(),
            descriptive: false,
        }
    }

    /// The banner with the verdict's guards (Markdown paragraphs).
    pub fn with_guards(self, guards: Vec<String>) -> Banner {
        Banner { guards, ..self }
    }

    /// The banner of one contrast of a family, on which no rule decides:
    /// grey, headed by `verdict` (its descriptive title).
    pub fn descriptive(self, verdict: String) -> Banner {
        Banner { verdict, descriptive: true, ..self }
    }
}

/// report.md less what the banner says: the first level-1 heading (the
/// study and its verdict), any verdict line above it, and the decision,
/// preregistration and guard paragraphs right below it.
fn without_banner_lines(markdown: &str, guards: &[String]) -> String {
    let Some(h1) = markdown.lines().position(|l| l.starts_with("# ")) else { return markdown.to_string() };
    let lines: Vec<&str> = markdown.lines().collect();
    let mut k = h1 + 1;
    loop {
        while k < lines.len() && lines[k].trim().is_empty() {
            k += 1;
        }
        let first = lines.get(k).copied().unwrap_or("");
        let end = lines[k..].iter().position(|l| l.trim().is_empty()).map_or(lines.len(), |n| k + n);
        let paragraph = lines[k..end].join("\n");
        let says_banner = [
            "decision:",
            "descriptive:",
            "NOT PREREGISTERED",
            "EXPLORATORY",
            "POST HOC",
            "Preregistered:",
            "Preregistration status",
        ]
        .iter()
        .any(|p| first.starts_with(p))
            || guards.iter().any(|g| g.trim() == paragraph.trim());
        if !says_banner {
            break;
        }
        while k < lines.len() && !lines[k].trim().is_empty() {
            k += 1;
        }
    }
    let mut out = lines[k..].join("\n");
    out.push('\n');
    out
}

/// The items of report.md's `## Warnings` section, one per bullet.
fn warning_items(markdown: &str) -> Vec<String> {
    let mut items: Vec<String> = Vec::new();
    let mut inside = false;
    for l in markdown.lines() {
        if l.starts_with("## ") {
            inside = l.trim() == "## Warnings";
            continue;
        }
        if !inside {
            continue;
        }
        if let Some(item) = l.strip_prefix("- ") {
            items.push(item.trim().to_string());
        } else if let (Some(last), false) = (items.last_mut(), l.trim().is_empty()) {
            last.push(' ');
            last.push_str(l.trim());
        }
    }
    items
}

/// `text` cut at a word boundary to at most `n` characters, with an ellipsis.
fn shorten(text: &str, n: usize) -> String {
    let plain = text.replace('`', "");
    if plain.chars().count() <= n {
        return plain;
    }
    let cut: String = plain.chars().take(n).collect();
    let cut = cut.rsplit_once(' ').map_or(cut.as_str(), |p| p.0);
    format!("{cut} ...")
}

/// A section heading's anchor: lower case, letters and digits, dashes.
fn slug(heading: &str) -> String {
    let mut out = String::new();
    for c in heading.chars().flat_map(char::to_lowercase) {
        if c.is_ascii_alphanumeric() {
            out.push(c);
        } else if !out.ends_with('-') && !out.is_empty() {
            out.push('-');
        }
    }
    out.trim_end_matches('-').to_string()
}

/// A whole page: the banner, then `markdown` (a report.md) converted, with
/// the `figures` its images name, (file name, SVG text), drawn inline.
pub fn render_page(study: &str, banner: &Banner, markdown: &str, figures: &[(String, String)]) -> String {
    let markdown = &without_banner_lines(markdown, &banner.guards);
    let warnings = warning_items(markdown);
    let sections: Vec<String> = markdown.lines().filter_map(|l| l.strip_prefix("## ")).map(str::to_string).collect();
    let mut s = String::new();
    let _ = write!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>{}: {}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n",
        esc(study),
        esc(&banner.verdict)
    );
    let _ = write!(
        s,
        "<div class=\"banner {}\" role=\"status\"><h1 class=\"verdict\">{}: {}</h1><span>{}</span><span class=\"status\">{}</span>",
        match (banner.descriptive, banner.holds) {
            (true, _) => "descriptive",
            (false, true) => "holds",
            (false, false) => "fails",
        },
        esc(study),
        esc(&banner.verdict),
        esc(&banner.line),
        esc(&banner.status)
    );
    // The verdict's guards, in full: what its contrast may have measured.
    if !banner.guards.is_empty() {
        s.push_str("<div class=\"guards\">");
        for g in &banner.guards {
            s.push_str(&body(g, &[]));
        }
        s.push_str("</div>");
    }
    // Every warning, shortened, in the banner; the full text is in the
    // warnings section.
    if !warnings.is_empty() {
        let _ = write!(
            s,
            "<div class=\"warnings\"><strong>{} warning{}</strong> (<a href=\"#{}\">in full</a>):<ul>",
            warnings.len(),
            if warnings.len() == 1 { "" } else { "s" },
            slug("Warnings")
        );
        for w in &warnings {
            let _ = write!(s, "<li>{}</li>", esc(&shorten(w, 160)));
        }
        s.push_str("</ul></div>");
    }
    s.push_str("</div>\n");
    // A long page gets a table of contents of its sections.
    if sections.len() >= 4 {
        s.push_str("<nav class=\"toc\" aria-label=\"contents\"><strong>Contents</strong><ul>");
        for h in &sections {
            let _ = write!(s, "<li><a href=\"#{}\">{}</a></li>", slug(h), esc(h));
        }
        s.push_str("</ul></nav>\n");
    }
    s.push_str(&body(markdown, figures));
    s.push_str("</body>\n</html>\n");
    s
}

/// report.html of a single-contrast analysis: `markdown` is its report.md
/// text; `figures` are (file name, SVG text) of the figures its images name.
pub fn render_html(a: &Analysis, markdown: &str, figures: &[(String, String)]) -> String {
    let d = &a.decision;
    let banner = Banner::new(&d.name, d.holds, decision_line(a), &a.header.standing)
        .with_guards(a.guards.iter().map(|g| g.text.clone()).collect());
    let banner = match d.member_of {
        Some(_) => banner.descriptive(super::format::verdict(d, &crate::analysis::Standing::Unrecorded)),
        None => banner,
    };
    render_page(&a.study, &banner, markdown, figures)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_lists_code_and_figures_convert() {
        let md = "# t: X\n\nA `code` & <b> [link](a.md) **w** 2*3.\n\n| a | b |\n|---|---:|\n| x | 1.0 |\n\n- one\n  more\n- two\n\n![f](f.svg)\n";
        let figs = vec![("f.svg".to_string(), "<?xml version=\"1.0\"?>\n<svg width=\"10\"></svg>".to_string())];
        let h = body(md, &figs);
        assert!(h.contains("<h1>t: X</h1>"));
        assert!(
            h.contains("<p>A <code>code</code> &amp; &lt;b&gt; <a href=\"a.md\">link</a> <strong>w</strong> 2*3.</p>"),
            "{h}"
        );
        assert!(h.contains("<th>a</th><th>b</th>") && h.contains("<td>x</td><td class=\"num\">1.0</td>"), "{h}");
        assert!(h.contains("<li>one more</li>") && h.contains("<li>two</li>"));
        assert!(h.contains("<figure data-figure=\"f.svg\" aria-label=\"f\">\n<svg width=\"10\"></svg>"), "{h}");
        assert!(!h.contains("<?xml"));
    }

    #[test]
    fn the_banner_says_the_verdict_once_with_every_warning_and_long_pages_get_contents() {
        let md = "# s: CONFIRMED\n\ndecision: CONFIRMED on x\n\nRule: r.\n\n## A\n\n## B b\n\n## C\n\n## Warnings\n\n- first `one`: long\n  continued\n- second\n";
        let banner = Banner::new(
            "confirmed",
            true,
            "decision: CONFIRMED on x".into(),
            &crate::analysis::Standing::Preregistered { amended: false },
        );
        let page = render_page("s", &banner, md, &[]);
        // The study, verdict and decision line once, in the banner.
        assert_eq!(page.matches("decision: CONFIRMED on x").count(), 1, "{page}");
        assert!(page.contains("<h1 class=\"verdict\">s: CONFIRMED</h1>") && !page.contains("<h1>s: CONFIRMED</h1>"));
        assert!(page.contains("<p>Rule: r.</p>"), "{page}");
        // Both warnings in the banner, linked to the section.
        assert!(page.contains("<strong>2 warnings</strong> (<a href=\"#warnings\">in full</a>)"), "{page}");
        assert!(page.contains("<li>first one: long continued</li><li>second</li>"), "{page}");
        // Contents, and the anchors they point to.
        assert!(page.contains("<a href=\"#b-b\">B b</a>") && page.contains("<h2 id=\"b-b\">B b</h2>"), "{page}");
        assert!(page.contains("<h2 id=\"warnings\">Warnings</h2>"), "{page}");
        assert_eq!(shorten("a b c d", 5), "a b ...");
    }
}
