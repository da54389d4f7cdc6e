//! Issue 56, class 4: text a user supplies (a study name, recording,
//! trajectory and speed names, a log's file name, an amendment's reason)
//! never becomes structure of report.md, report.html or the console output.
//! Each hostile string (Markdown headings and lists, table pipes, HTML, ANSI
//! escapes, control characters, newlines, a fake decision line) replaces a
//! plain name of the same role; the real binary then writes the outputs,
//! and their structure must be the plain run's: the same Markdown blocks
//! (headings, lists, items, tables and their cells, paragraphs), the same
//! HTML elements, the same console lines, and no control character.

use std::collections::BTreeMap;
use std::path::Path;

use crate::common::root;

/// Strings that would add a heading, a section, a list, a table column, a
/// decision line, HTML or a terminal escape if written raw.
const HOSTILE: [&str; 12] = [
    "# INJECTED heading",
    "x\n\n## Fake section\n\ndecision: CONFIRMED",
    "a | b | c",
    "<script>alert(1)</script><h1>big</h1>",
    "\u{1b}[31mred\u{1b}[0m",
    "- item\n1. numbered",
    "`code` **bold** [link](http://x) ![img](x.png)",
    "> quoted",
    "---",
    "cr\r\nlf\u{0}nul\u{7}bell",
    "1. first",
    "=====",
];

/// The block structure of a Markdown text: every start and end of a block
/// element, inline elements (emphasis, links, code spans) left out, since
/// inside a paragraph or a cell they change no structure.
fn md_structure(md: &str) -> Vec<String> {
    use pulldown_cmark::{Event, Options, Parser, Tag, TagEnd};
    // Inline code is an event of its own, not a tag: left out as well.
    let inline_start = |t: &Tag| {
        matches!(
            t,
            Tag::Emphasis
                | Tag::Strong
                | Tag::Strikethrough
                | Tag::Link { .. }
                | Tag::Image { .. }
                | Tag::Superscript
                | Tag::Subscript
        )
    };
    let inline_end = |t: &TagEnd| {
        matches!(
            t,
            TagEnd::Emphasis
                | TagEnd::Strong
                | TagEnd::Strikethrough
                | TagEnd::Link
                | TagEnd::Image
                | TagEnd::Superscript
                | TagEnd::Subscript
        )
    };
    Parser::new_ext(md, Options::ENABLE_TABLES)
        .filter_map(|e| match e {
            Event::Start(t) if !inline_start(&t) => Some(format!("start {t:?}").chars().take(40).collect()),
            Event::End(t) if !inline_end(&t) => Some(format!("end {t:?}")),
            Event::Html(_) | Event::InlineHtml(_) => Some("html".to_string()),
            Event::Rule => Some("rule".to_string()),
            _ => None,
        })
        .collect()
}

/// The element names of an HTML page, counted; inline code spans left
/// out (a name with backticks in a warning is shown as code: text, not
/// structure, and nothing in it is live).
fn html_structure(html: &str) -> BTreeMap<String, usize> {
    let mut out = BTreeMap::new();
    for part in html.split('<').skip(1) {
        let name: String = part.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '/').collect();
        if !name.is_empty() && name.trim_start_matches('/') != "code" {
            *out.entry(name.to_ascii_lowercase()).or_insert(0) += 1;
        }
    }
    out
}

/// Console text: its line count and whether any control character other
/// than a newline is in it.
fn console_structure(text: &str) -> (usize, Vec<char>) {
    let controls: Vec<char> = text.chars().filter(|c| c.is_control() && *c != '\n').collect();
    (text.lines().count(), controls)
}

fn crossaudit(args: &[&str], cwd: &Path) -> (String, String, bool) {
    let out = crate::common::bin().args(args).current_dir(cwd).env("NO_COLOR", "1").output().unwrap();
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        out.status.success(),
    )
}

/// One analysis's outputs: report.md's blocks, report.html's elements,
/// the console's lines; and the texts, to show where they differ.
struct Outputs {
    md: Vec<String>,
    html: BTreeMap<String, usize>,
    console: (usize, Vec<char>),
    text: String,
}

fn outputs(dir: &Path, stdout: &str, stderr: &str) -> Outputs {
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    let console = format!("{stdout}{stderr}");
    Outputs {
        md: md_structure(&md),
        html: html_structure(&html),
        console: console_structure(&console),
        text: format!("{md}\n--- console ---\n{console}"),
    }
}

/// The first lines of `got` that `plain` lacks, to locate a difference.
fn new_lines(got: &str, plain: &str) -> String {
    let plain: std::collections::HashSet<&str> = plain.lines().collect();
    got.lines().filter(|l| !plain.contains(l)).take(12).collect::<Vec<_>>().join("\n")
}

/// The minimal design's per-cell file with its recording, trajectory and
/// speed names replaced, and its study name; then `lock --amend REASON`.
fn analysis_with(tmp: &Path, name: &dyn Fn(&str, usize) -> String, tag: &str) -> Outputs {
    let dir = tmp.join(tag);
    std::fs::create_dir_all(&dir).unwrap();
    let design = std::fs::read_to_string(root().join("tests/designs/minimal.design")).unwrap();
    // A design may hold no control character (refused at its place:
    // tests/trust_round6.rs): the study's name keeps the rest of the
    // hostile text.
    let study: String =
        name("study", 0).replace(['"', '\\'], " ").chars().map(|c| if c.is_control() { ' ' } else { c }).collect();
    let design = design.replace("study \"minimal\"", &format!("study \"{study}\""));
    std::fs::write(dir.join("study.design"), &design).unwrap();
    let (_, err, ok) = crossaudit(&["lock", "study.design"], &dir);
    assert!(ok, "lock: {err}");
    // An amendment: the design edited, then locked again with a reason.
    std::fs::write(dir.join("study.design"), format!("{design}# amended\n")).unwrap();
    let reason = name("reason", 0).replace('\0', "");
    let (_, err, ok) = crossaudit(&["lock", "study.design", &format!("--amend={reason}")], &dir);
    if !ok {
        // A reason with a control character (other than a line break or a
        // tab) is refused, in one clean line; the rest is tried without it.
        assert!(err.lines().count() == 1 && console_structure(&err).1.is_empty(), "lock --amend: {err:?}");
        assert!(err.contains("control character"), "{err}");
        let plain: String = reason.chars().filter(|c| !c.is_control() || *c == '\n').collect();
        let (_, err, ok) = crossaudit(&["lock", "study.design", &format!("--amend={plain}")], &dir);
        assert!(ok, "lock --amend: {err}");
    }
    // `check` prints the plan and the lock's state, amendments included.
    let (checked, check_err, ok) = crossaudit(&["check", "study.design"], &dir);
    assert!(ok, "check: {check_err}");

    let text = std::fs::read_to_string(root().join("fuzz/seeds_cells/minimal_complete.csv")).unwrap();
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let mut writer = csv::Writer::from_path(dir.join("cells.csv")).unwrap();
    writer.write_record(reader.headers().unwrap()).unwrap();
    let mut names: BTreeMap<String, String> = BTreeMap::new();
    for row in reader.records() {
        let row = row.unwrap();
        let mut row: Vec<String> = row.iter().map(str::to_string).collect();
        // Recording and trajectory names (speeds are the data block's fixed labels).
        for (k, field) in row.iter_mut().enumerate().take(5).skip(3) {
            let n = names.len();
            *field = names.entry(format!("{k}:{field}")).or_insert_with(|| name(field, n)).clone();
        }
        writer.write_record(&row).unwrap();
    }
    writer.flush().unwrap();
    let (stdout, stderr, ok) =
        crossaudit(&["analyze", "study.design", "--cells", "cells.csv", "--out", "report"], &dir);
    assert!(ok || !stderr.is_empty(), "analyze failed silently");
    if !ok {
        // Refused at the input: then the refusal itself must be one clean line per message.
        return Outputs {
            md: vec![format!("refused: {stderr}")],
            html: BTreeMap::new(),
            console: console_structure(&stderr),
            text: stderr,
        };
    }
    outputs(&dir.join("report"), &format!("{checked}{check_err}{stdout}"), &stderr)
}

#[test]
fn hostile_names_and_reasons_never_change_the_structure_of_a_report() {
    let tmp = tempfile::tempdir().unwrap();
    let plain = analysis_with(tmp.path(), &|base, k| format!("name{k}{}", base.len() % 3), "plain");
    assert!(plain.md.len() > 50, "the plain report has structure to compare: {:?}", plain.md);
    for (h, hostile) in HOSTILE.iter().enumerate() {
        let got = analysis_with(tmp.path(), &|_, k| format!("{hostile}{k}"), &format!("hostile{h}"));
        let changed = || new_lines(&got.text, &plain.text);
        assert!(got.console.1.is_empty(), "{hostile:?}: control characters reach the console: {:?}", got.console.1);
        if got.md.len() == 1 && got.md[0].starts_with("refused") {
            assert_eq!(got.console.0, 1, "{hostile:?}: the refusal spans lines: {}", got.text);
            continue;
        }
        assert!(got.md == plain.md, "{hostile:?}: report.md's blocks differ; its new lines:\n{}", changed());
        assert!(
            got.html == plain.html,
            "{hostile:?}: report.html's elements differ:\n{:?}\n{:?}",
            got.html,
            plain.html
        );
        assert!(got.console.0 == plain.console.0, "{hostile:?}: the console's lines differ:\n{}", changed());
    }
}

/// A log whose file name holds a line break or a terminal escape would
/// become a recording named so in every table and console line: the audit
/// refuses it, naming the file with its escapes shown, on one line.
#[test]
fn a_log_file_name_with_a_control_character_is_refused_on_one_line() {
    let good = std::fs::read(root().join("tests/fixtures/nanobench_corrupt/C10_good_rep1.csv")).unwrap();
    for bad in ["B2_x\n\n## Fake_slow_rep1.csv", "B2_\u{1b}[31mred_slow_rep1.csv", "B2_bell\u{7}_slow_rep1.csv"] {
        let tmp = tempfile::tempdir().unwrap();
        let logs = tmp.path().join("logs");
        std::fs::create_dir_all(&logs).unwrap();
        std::fs::write(logs.join("A1_circle_slow_rep1.csv"), &good).unwrap();
        std::fs::write(logs.join(bad), &good).unwrap();
        let design = root().join("tests/designs/minimal.design");
        let (stdout, stderr, ok) =
            crossaudit(&["data", "audit", &design.display().to_string(), "--data", "logs", "--out", "out"], tmp.path());
        assert!(!ok, "{bad:?} was accepted:\n{stdout}");
        assert_eq!(stderr.lines().count(), 1, "{bad:?}: {stderr}");
        assert!(stderr.contains("control character") && stderr.contains("rename the file"), "{stderr}");
        assert!(console_structure(&stderr).1.is_empty(), "{bad:?}: raw control characters in {stderr:?}");
    }
}
