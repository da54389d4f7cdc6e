//! The language reference (`docs/language.md`), generated from the grammar
//! itself so that it cannot drift from what the parser accepts: every rule
//! in file order, grouped by the grammar's section markers, with its
//! `///` documentation and its definition. `tests/front_door.rs` checks the
//! committed page against this.

use std::fmt::Write as _;

/// The grammar, as compiled into the parser.
pub const GRAMMAR: &str = include_str!("../../grammar/design.pest");

/// `docs/language.md`.
pub fn markdown() -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# The `.design` language: reference\n");
    let _ = writeln!(
        s,
        "Generated from `grammar/design.pest` (the parser's own grammar) by `crossaudit::design::reference`; a test fails when this page and the grammar differ. What each statement means, with a whole example, is in [usage.md](usage.md#the-design-language); the validator then checks names, ranges and counts with located errors.\n"
    );
    let mut doc: Vec<String> = Vec::new();
    let mut lines = GRAMMAR.lines().peekable();
    while let Some(line) = lines.next() {
        let t = line.trim();
        if let Some(text) = t.strip_prefix("//!") {
            let _ = writeln!(s, "{}", text.trim());
            if lines.peek().is_some_and(|n| !n.trim().starts_with("//!")) {
                s.push('\n');
            }
        } else if let Some(text) = t.strip_prefix("///") {
            doc.push(text.trim().to_string());
        } else if let Some(section) = t.strip_prefix("// ----") {
            let name = section.trim_start_matches('-').trim();
            let _ = writeln!(
                s,
                "## {}\n",
                name.chars()
                    .next()
                    .map(|c| c.to_uppercase().collect::<String>() + &name[c.len_utf8()..])
                    .unwrap_or_default()
            );
        } else if let Some((rule, _)) = t.split_once('=').filter(|(r, _)| {
            let r = r.trim();
            !r.is_empty() && r.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        }) {
            let mut def = vec![line.to_string()];
            let mut depth = line.matches('{').count() as i64 - line.matches('}').count() as i64;
            while depth > 0 {
                let Some(next) = lines.next() else { break };
                depth += next.matches('{').count() as i64 - next.matches('}').count() as i64;
                def.push(next.to_string());
            }
            let _ = writeln!(s, "### `{}`\n", rule.trim());
            if !doc.is_empty() {
                let _ = writeln!(s, "{}\n", doc.join("\n"));
            }
            let _ = writeln!(s, "```\n{}\n```\n", def.join("\n"));
            doc.clear();
        } else if t.is_empty() {
            doc.clear();
        }
    }
    s
}
