//! report.html: the report as one self-contained page. A banner with the
//! decision and the preregistration status first, then report.md's own
//! sections (the same text, so the two cannot drift) with every figure
//! drawn inline as SVG. No script, no external style sheet, no network.
//!
//! The Markdown converter covers what report.md uses: headings, paragraphs,
//! pipe tables (right-aligned columns kept), bullet lists, inline code,
//! links and images; an image of a figure it was given is inlined.

use std::fmt::Write as _;

use super::format::decision_line;
use crate::analysis::Analysis;

const STYLE: &str = "body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,sans-serif;max-width:78rem;margin:0 auto;padding:0 1rem 3rem;color:#1b1f23;line-height:1.45}\
.banner{margin:1rem 0;padding:.9rem 1.1rem;border-radius:6px;border-left:8px solid}\
.banner.holds{background:#e6f4ea;border-color:#1e7e34}.banner.fails{background:#fdecea;border-color:#b3261e}\
.banner .verdict{font-size:1.4rem;font-weight:700;display:block}.banner .status{display:block;margin-top:.3rem;font-weight:600}\
table{border-collapse:collapse;margin:.6rem 0 1.2rem;font-size:.88rem}th,td{border:1px solid #d0d7de;padding:.25rem .5rem}\
th{background:#f6f8fa}td.num{text-align:right;font-variant-numeric:tabular-nums}\
code{background:#f6f8fa;padding:0 .2rem;border-radius:3px}figure{margin:1rem 0}figure svg{max-width:100%;height:auto}\
h1{font-size:1.6rem}h2{border-bottom:1px solid #d0d7de;padding-bottom:.2rem;margin-top:2rem}";

/// Escapes text for HTML.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// Inline Markdown: `code`, [links](target) and plain text, escaped.
fn inline(s: &str) -> String {
    let mut out = String::new();
    let mut rest = s;
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix('`') {
            if let Some(end) = r.find('`') {
                let _ = write!(out, "<code>{}</code>", esc(&r[..end]));
                rest = &r[end + 1..];
                continue;
            }
        }
        if let Some(r) = rest.strip_prefix("**") {
            if let Some(end) = r.find("**") {
                let _ = write!(out, "<strong>{}</strong>", inline(&r[..end]));
                rest = &r[end + 2..];
                continue;
            }
        }
        if let Some(r) = rest.strip_prefix('[') {
            if let Some(close) = r.find("](") {
                if let Some(end) = r[close + 2..].find(')') {
                    let (text, target) = (&r[..close], &r[close + 2..close + 2 + end]);
                    let _ = write!(out, "<a href=\"{}\">{}</a>", esc(target), inline(text));
                    rest = &r[close + 3 + end..];
                    continue;
                }
            }
        }
        let next = rest.find(['`', '[', '*']).map(|k| if k == 0 { 1 } else { k }).unwrap_or(rest.len());
        out.push_str(&esc(&rest[..next]));
        rest = &rest[next..];
    }
    out
}

fn cells(line: &str) -> Vec<&str> {
    let t = line.trim().trim_start_matches('|').trim_end_matches('|');
    t.split('|').map(str::trim).collect()
}

/// The figure inlined for `![alt](file)`, or an `<img>` of the file.
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
        None => format!("<figure><img src=\"{}\" alt=\"{}\"></figure>\n", esc(file), esc(alt)),
    }
}

/// report.md converted to HTML.
fn body(markdown: &str, figures: &[(String, String)]) -> String {
    let lines: Vec<&str> = markdown.lines().collect();
    let mut out = String::new();
    let mut k = 0;
    while k < lines.len() {
        let line = lines[k];
        let t = line.trim();
        if t.is_empty() {
            k += 1;
        } else if let Some(h) = t.strip_prefix("## ") {
            let _ = writeln!(out, "<h2>{}</h2>", inline(h));
            k += 1;
        } else if let Some(h) = t.strip_prefix("# ") {
            let _ = writeln!(out, "<h1>{}</h1>", inline(h));
            k += 1;
        } else if let Some(img) = t.strip_prefix("![") {
            let (alt, file) = img.split_once("](").map(|(a, f)| (a, f.trim_end_matches(')'))).unwrap_or((img, ""));
            out.push_str(&image(alt, file, figures));
            k += 1;
        } else if t.starts_with('|') {
            let header = cells(t);
            let align: Vec<bool> =
                lines.get(k + 1).map(|l| cells(l).iter().map(|c| c.ends_with(':')).collect()).unwrap_or_default();
            out.push_str("<table>\n<thead><tr>");
            for h in &header {
                let _ = write!(out, "<th>{}</th>", inline(h));
            }
            out.push_str("</tr></thead>\n<tbody>\n");
            k += 2;
            while k < lines.len() && lines[k].trim().starts_with('|') {
                out.push_str("<tr>");
                for (j, c) in cells(lines[k]).iter().enumerate() {
                    let class = if align.get(j).copied().unwrap_or(false) { " class=\"num\"" } else { "" };
                    let _ = write!(out, "<td{class}>{}</td>", inline(c));
                }
                out.push_str("</tr>\n");
                k += 1;
            }
            out.push_str("</tbody>\n</table>\n");
        } else if t.starts_with("- ") {
            out.push_str("<ul>\n");
            while k < lines.len() && lines[k].trim().starts_with("- ") {
                let mut item = lines[k].trim()[2..].to_string();
                k += 1;
                while k < lines.len() && lines[k].starts_with("  ") && !lines[k].trim().starts_with("- ") {
                    item.push(' ');
                    item.push_str(lines[k].trim());
                    k += 1;
                }
                let _ = writeln!(out, "<li>{}</li>", inline(&item));
            }
            out.push_str("</ul>\n");
        } else {
            let mut para = t.to_string();
            k += 1;
            while k < lines.len() {
                let n = lines[k].trim();
                if n.is_empty()
                    || n.starts_with('#')
                    || n.starts_with('|')
                    || n.starts_with("- ")
                    || n.starts_with("![")
                {
                    break;
                }
                para.push(' ');
                para.push_str(n);
                k += 1;
            }
            let _ = writeln!(out, "<p>{}</p>", inline(&para));
        }
    }
    out
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
    pub status: &'static str,
}

impl Banner {
    /// The banner of a rule named `name` that holds or not, with its
    /// decision line and the analysis's lock state.
    pub fn new(name: &str, holds: bool, line: String, exploratory: bool, preregistered: Option<bool>) -> Banner {
        Banner {
            verdict: super::format::verdict_word(name, holds),
            holds,
            line,
            status: status_sentence(exploratory, preregistered),
        }
    }
}

/// The preregistration status as the banner states it.
fn status_sentence(exploratory: bool, preregistered: Option<bool>) -> &'static str {
    if exploratory {
        "EXPLORATORY: the design changed after it was locked"
    } else {
        match preregistered {
            Some(true) => "Preregistered: the design was locked before this run and is unchanged",
            Some(false) => "NOT PREREGISTERED: the design was not locked before it ran",
            None => "Preregistration status not recorded (an analysis without its design's lock)",
        }
    }
}

/// A whole page: the banner, then `markdown` (a report.md) converted, with
/// the `figures` its images name, (file name, SVG text), drawn inline.
pub fn render_page(study: &str, banner: &Banner, markdown: &str, figures: &[(String, String)]) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>{}: {}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n",
        esc(study),
        esc(&banner.verdict)
    );
    let _ = writeln!(
        s,
        "<div class=\"banner {}\" role=\"status\"><span class=\"verdict\">{}</span><span>{}</span><span class=\"status\">{}</span></div>",
        if banner.holds { "holds" } else { "fails" },
        esc(&banner.verdict),
        esc(&banner.line),
        esc(banner.status)
    );
    s.push_str(&body(markdown, figures));
    s.push_str("</body>\n</html>\n");
    s
}

/// report.html of a single-contrast analysis: `markdown` is its report.md
/// text; `figures` are (file name, SVG text) of the figures its images name.
pub fn render_html(a: &Analysis, markdown: &str, figures: &[(String, String)]) -> String {
    let d = &a.decision;
    let banner = Banner::new(&d.name, d.holds, decision_line(a), a.exploratory, a.preregistered);
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
}
