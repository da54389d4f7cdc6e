//! User text made safe wherever it is written: on one line with control
//! characters escaped, and escaped for Markdown.

use std::borrow::Cow;

// ---- Markdown text from input ------------------------------------------
// Names from input (a study's name, recording, trajectory and role labels,
// file names) written into a Markdown file (report.md, split_audit.md) are
// escaped so that they are read back as the same text, never as a link,
// an image, emphasis, raw HTML or a table's column separator.

/// `s` as Markdown text: every character that could start markup is
/// backslash-escaped (`[` and `]`, so no link or image can form and
/// parentheses stay as they are; `_` only where it could open or close
/// emphasis, so `nanobench_paper` is written as it is), and line breaks and other
/// control characters become spaces (a name stays on its line and in its
/// table cell).
///
/// ```
/// use crossaudit::io::md_text;
/// assert_eq!(md_text("nanobench_paper"), "nanobench_paper");
/// assert_eq!(md_text("[x](javascript:alert(1))"), "\\[x\\](javascript:alert(1))");
/// assert_eq!(md_text("a|b"), "a\\|b");
/// assert_eq!(md_text("_x_"), "\\_x\\_");
/// ```
pub fn md_text(s: &str) -> String {
    escape_markup(s, false)
}

/// Markdown text written by [`md_text`] as the terminal shows it: each
/// backslash escape of a punctuation character undone outside code spans
/// (which hold no escapes), so a console line reads `a > b`, not `a \> b`.
///
/// ```
/// use crossaudit::io::{md_plain, md_text};
/// assert_eq!(md_plain(&md_text("active(m1 > 1000) >= 1 [0.5, 9]")), "active(m1 > 1000) >= 1 [0.5, 9]");
/// assert_eq!(md_plain(&md_text("C:\\logs\\_x_")), "C:\\logs\\_x_");
/// assert_eq!(md_plain("`a\\_b` \\_c"), "`a\\_b` _c");
/// ```
pub fn md_plain(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let (mut chars, mut in_code) = (s.chars().peekable(), false);
    while let Some(c) = chars.next() {
        match c {
            '`' => in_code = !in_code,
            '\\' if !in_code && chars.peek().is_some_and(|n| n.is_ascii_punctuation()) => {
                out.extend(chars.next());
                continue;
            }
            _ => {}
        }
        out.push(c);
    }
    out
}

/// [`md_text`]'s escapes; with `code_spans`, a backtick run that a later
/// run of the same length closes is kept with everything between them (a
/// code span: nothing in it is markup), and any other backtick escaped.
fn escape_markup(s: &str, code_spans: bool) -> String {
    let chars: Vec<char> = s.chars().collect();
    let mut out = String::with_capacity(s.len());
    let run_at = |k: usize| chars[k..].iter().take_while(|c| **c == '`').count();
    let mut k = 0;
    while k < chars.len() {
        let c = chars[k];
        if c == '`' && code_spans {
            let n = run_at(k);
            // The closing run: the next run of exactly n backticks.
            let mut j = k + n;
            let mut close = None;
            while j < chars.len() {
                if chars[j] == '`' {
                    let m = run_at(j);
                    if m == n {
                        close = Some(j);
                        break;
                    }
                    j += m;
                } else {
                    j += 1;
                }
            }
            if let Some(j) = close {
                chars[k..j + n].iter().for_each(|c| out.push(if c.is_control() { ' ' } else { *c }));
                k = j + n;
                continue;
            }
        }
        match c {
            '\\' | '`' | '*' | '[' | ']' | '<' | '>' | '|' | '&' | '~' => {
                out.push('\\');
                out.push(c);
            }
            '_' => {
                let word = |j: Option<usize>| j.and_then(|j| chars.get(j)).is_some_and(|c| c.is_alphanumeric());
                if !(word(k.checked_sub(1)) && word(Some(k + 1))) {
                    out.push('\\');
                }
                out.push('_');
            }
            c if c.is_control() => out.push(' '),
            c => out.push(c),
        }
        k += 1;
    }
    out
}

/// `s` on one line, every control character (a line break, a terminal
/// escape, NUL) shown as its Rust escape (`\n`, `\u{1b}`): user text
/// (an amendment's reason, a file name, a label) embedded in a message,
/// a warning or a report line can then neither start a line of its own
/// nor drive the terminal.
///
/// ```
/// use crossaudit::io::one_line;
/// assert_eq!(one_line("a\nb"), "a\\nb");
/// assert_eq!(one_line("\u{1b}[31mred"), "\\u{1b}[31mred");
/// assert_eq!(one_line("plain"), "plain");
/// ```
pub fn one_line(s: &str) -> Cow<'_, str> {
    escape_controls(s, &[])
}

/// `s` with every control character but those in `keep` shown as its Rust
/// escape: [`one_line`] keeps none; the binary's console output keeps the
/// line break and the tab of its own messages.
pub fn escape_controls<'a>(s: &'a str, keep: &[char]) -> Cow<'a, str> {
    let escaped = |c: &char| c.is_control() && !keep.contains(c);
    if !s.chars().any(|c| escaped(&c)) {
        return Cow::Borrowed(s);
    }
    let mut out = String::with_capacity(s.len() + 8);
    for c in s.chars() {
        if escaped(&c) {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

/// A line of a Markdown report built by crossaudit around user text (a
/// warning, a note): on one line ([`one_line`]), every character that
/// could start a link, an image, emphasis or raw HTML escaped as
/// [`md_text`] does, and a leading block marker (`#`, `>`, `-`, `+`, `=`,
/// a fence, `1.`) escaped, so it stays one paragraph or one list item with
/// no markup but code spans: the code spans crossaudit writes into its
/// warnings (`` `world` ``) are kept.
///
/// ```
/// use crossaudit::io::md_line;
/// assert_eq!(md_line("# x"), "\\# x");
/// assert_eq!(md_line("12. x"), "12\\. x");
/// assert_eq!(md_line("a <b> `c|d_` [e](f)"), "a \\<b\\> `c|d_` \\[e\\](f)");
/// assert_eq!(md_line("an open ` [e](f)"), "an open \\` \\[e\\](f)");
/// ```
pub fn md_line(s: &str) -> String {
    let flat = escape_markup(&one_line(s), true);
    let body = flat.trim_start();
    let indent = &flat[..flat.len() - body.len()];
    let digits = body.chars().take_while(char::is_ascii_digit).count();
    if body.starts_with(['#', '-', '+', '=', '`']) {
        format!("{indent}\\{body}")
    } else if digits > 0 && body[digits..].starts_with(['.', ')']) {
        format!("{indent}{}\\{}", &body[..digits], &body[digits..])
    } else {
        flat
    }
}

/// `s` as a Markdown code span, with a fence longer than any run of
/// backticks in it (backslash escapes do not work inside code spans).
///
/// ```
/// use crossaudit::io::md_code;
/// assert_eq!(md_code("a_b"), "`a_b`");
/// assert_eq!(md_code("a`b"), "`` a`b ``");
/// ```
pub fn md_code(s: &str) -> String {
    let clean: String = s.chars().map(|c| if c.is_control() { ' ' } else { c }).collect();
    let mut longest = 0;
    let mut run = 0;
    for c in clean.chars() {
        run = if c == '`' { run + 1 } else { 0 };
        longest = longest.max(run);
    }
    if longest == 0 {
        return format!("`{clean}`");
    }
    let fence = "`".repeat(longest + 1);
    format!("{fence} {clean} {fence}")
}

/// A text cell of a CSV file that people open in a spreadsheet, written so
/// that the spreadsheet shows it as text: control characters are shown as
/// their escapes (as [`one_line`]), and a cell that then begins with `=`,
/// `+`, `-` or `@` and is not a finite number gets a leading `'` (OWASP's
/// advice against CSV injection), so that `=HYPERLINK(...)` is not a
/// formula. Finite numbers (`-0.5`, `+3`) stay as they are; `-inf` and
/// `-NaN`, which a spreadsheet does not read as numbers, do not.
///
/// ```
/// use crossaudit::io::spreadsheet_text;
/// assert_eq!(spreadsheet_text("=HYPERLINK(\"x\")"), "'=HYPERLINK(\"x\")");
/// assert_eq!(spreadsheet_text("@SUM(A1)"), "'@SUM(A1)");
/// assert_eq!(spreadsheet_text("-0.5"), "-0.5");
/// assert_eq!(spreadsheet_text("-inf"), "'-inf");
/// assert_eq!(spreadsheet_text("\u{1b}[31mred"), "\\u{1b}[31mred");
/// assert_eq!(spreadsheet_text("\t=1+1"), "\\t=1+1");
/// assert_eq!(spreadsheet_text("mom_t"), "mom_t");
/// ```
pub fn spreadsheet_text(s: &str) -> Cow<'_, str> {
    if formula_like(s) {
        return Cow::Owned(format!("'{}", one_line(s)));
    }
    one_line(s)
}

/// Whether a spreadsheet would read `s` as a formula: it begins (once its
/// control characters are escaped) with `=`, `+`, `-` or `@` and is not a
/// finite number. Names that the tool writes into CSV files it also reads
/// back (recordings, trajectory and speed labels) are refused where they
/// come from when this holds; text it only writes is given a leading `'`
/// ([`spreadsheet_text`]).
///
/// ```
/// use crossaudit::io::formula_like;
/// assert!(formula_like("=1+1") && formula_like("-cmd") && formula_like("@SUM(A1)"));
/// assert!(!formula_like("-0.5") && !formula_like("B9_trefoil_fast_rep2"));
/// ```
pub fn formula_like(s: &str) -> bool {
    let shown = one_line(s);
    shown.starts_with(['=', '+', '-', '@']) && !shown.trim().parse::<f64>().is_ok_and(f64::is_finite)
}
