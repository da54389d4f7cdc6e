//! Round 4 of the hostile-user checks (issue 39), with the real binary on
//! real files: names from input cannot put markup into report.md or a
//! script or an external resource into report.html; a multiverse
//! reanalysis checks every level folder it reads and never writes into
//! another design's run; damaged logs are named, not dropped in silence;
//! every gzip member is read and a gzip bomb stops at the limit; a very
//! long line is refused before it is parsed; alternatives are compared as
//! values; the decision line carries the analysis's status.

use std::io::Write as _;
use std::path::Path;
use std::process::Output;

use crate::common::root;
use crate::common::{crossaudit, said};

#[track_caller]
fn ok(o: &Output) -> String {
    let s = said(o);
    assert!(o.status.success(), "failed:\n{s}");
    s
}

#[track_caller]
fn refused(o: &Output, needles: &[&str]) -> String {
    let s = said(o);
    assert!(!o.status.success(), "expected a refusal:\n{s}");
    assert!(!s.contains("panicked"), "{s}");
    for n in needles {
        assert!(s.contains(n), "expected {n:?} in:\n{s}");
    }
    s
}

// ---- class 1: report.md and report.html carry no markup from input -------

const HOSTILE: &str = "[click](javascript:alert(document.cookie)) ![x](http://host/x.png) <script>alert(1)</script> <img src=x onerror=alert(1)> a|b *em* _u_ `c`";

/// Everything in a page that could run a script or load a resource: no
/// element outside the page's own (text, tables, inline SVG figures), no
/// `javascript:` or external link or source.
fn assert_inert(html: &str) {
    const ALLOWED: &[&str] = &[
        "!doctype",
        "html",
        "head",
        "meta",
        "title",
        "style",
        "body",
        "div",
        "span",
        "h1",
        "h2",
        "h3",
        "h4",
        "p",
        "table",
        "thead",
        "tbody",
        "tr",
        "th",
        "td",
        "ul",
        "ol",
        "li",
        "code",
        "strong",
        "em",
        "a",
        "figure",
        "br",
        "hr",
        "pre",
        "blockquote",
        "nav",
        "svg",
        "g",
        "text",
        "line",
        "rect",
        "circle",
        "path",
        "polyline",
        "polygon",
        "defs",
        "clippath",
        "title",
        "desc",
        "tspan",
    ];
    let lower = html.to_ascii_lowercase();
    let b = lower.as_bytes();
    for (k, _) in lower.match_indices('<') {
        let rest = &lower[k + 1..];
        let name: String =
            rest.trim_start_matches('/').chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '!').collect();
        assert!(ALLOWED.contains(&name.as_str()), "element <{name}> in the page (byte {k}):\n{html}");
        let _ = b;
    }
    for bad in ["href=\"javascript:", "src=\"", "href=\"http://host", "href=\"//", "href=\"data:"] {
        assert!(!lower.contains(bad), "{bad} in the page:\n{html}");
    }
}

/// Every row of every table in `md` has as many cells as its header,
/// counting the `|` that are not escaped.
fn assert_tables_aligned(md: &str) {
    let cells = |line: &str| {
        let b = line.as_bytes();
        (0..b.len()).filter(|&k| b[k] == b'|' && (k == 0 || b[k - 1] != b'\\')).count()
    };
    let mut header: Option<usize> = None;
    for line in md.lines() {
        if line.starts_with('|') {
            let n = cells(line);
            match header {
                None => header = Some(n),
                Some(h) => assert_eq!(n, h, "a row with other columns than its header: {line}"),
            }
        } else {
            header = None;
        }
    }
}

#[test]
fn names_from_input_reach_the_report_as_text_only() {
    let tmp = tempfile::tempdir().unwrap();
    let design = std::fs::read_to_string(root().join("tests/designs/minimal.design")).unwrap();
    let design = design.replacen("study \"minimal\"", &format!("study \"{HOSTILE}\""), 1);
    assert!(design.contains(HOSTILE));
    let path = tmp.path().join("hostile.design");
    std::fs::write(&path, &design).unwrap();
    // A trajectory label with a link, a pipe and markup.
    let cells = std::fs::read_to_string(root().join("fuzz/seeds_cells/minimal_complete.csv")).unwrap();
    let label = "\"circle](javascript:alert(1))|x<b>\"";
    let cells: String = cells
        .lines()
        .enumerate()
        .map(|(k, l)| {
            let mut f: Vec<&str> = l.split(',').collect();
            if k > 0 && f[4] == "circle" {
                f[4] = label;
            }
            f.join(",") + "\n"
        })
        .collect();
    assert!(cells.contains(label));
    let cells_path = tmp.path().join("cells.csv");
    std::fs::write(&cells_path, cells).unwrap();
    let out = tmp.path().join("report");
    ok(&crossaudit(&[
        "analyze",
        path.to_str().unwrap(),
        "--cells",
        cells_path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert_inert(&html);
    assert_tables_aligned(&md);
    // The name is shown, as text, on line 1 and in the page's title.
    assert!(md.lines().next().unwrap().contains("\\[click\\](javascript:alert(document.cookie))"), "{md}");
    assert!(html.contains("[click](javascript:alert(document.cookie))"), "the name is shown as text:\n{html}");
    assert!(html.contains("&lt;script&gt;alert(1)&lt;/script&gt;"), "{html}");
    // The label stays in its cell.
    assert!(md.contains("circle\\](javascript:alert(1))\\|x\\<b\\>"), "{md}");
    assert!(html.contains("<td>circle](javascript:alert(1))|x&lt;b&gt;</td>"), "{html}");
}

#[test]
fn the_page_renders_markdown_with_no_live_markup_from_the_text() {
    use crossaudit::report::html::{render_page, Banner};
    let banner = Banner::new(
        "confirmed",
        true,
        "decision".into(),
        &crossaudit::analysis::Standing::Preregistered { amended: false },
    );
    let md = "# t\n\n[a](javascript:alert(1)) [b](JAVASCRIPT:x) [c](data:text/html,x) [d](//host/x) [e](vbscript:x) \
              [ok](audit/recordings.csv) [web](https://example.org/x)\n\n<script>alert(1)</script>\n\n\
              <a href=\"javascript:x\">raw</a> ![ext](http://host/x.png) ![local](other.svg)\n\n\
              | a | b |\n|---|---:|\n| x \\| y | 1 |\n";
    let html = render_page("<s>", &banner, md, &[]);
    assert_inert(&html);
    for dead in ["javascript:alert(1)", "JAVASCRIPT:x", "data:text/html", "//host/x", "vbscript:x"] {
        assert!(!html.contains(&format!("href=\"{dead}")), "{dead} is live:\n{html}");
    }
    assert!(html.contains("<a href=\"audit/recordings.csv\">ok</a>"), "{html}");
    assert!(html.contains("<a href=\"https://example.org/x\">web</a>"), "{html}");
    assert!(html.contains("&lt;script&gt;alert(1)&lt;/script&gt;"), "{html}");
    // Images that are not a figure given to the page: their alt text only.
    assert!(html.contains("raw&lt;/a&gt; ext local</p>"), "{html}");
    let alone = render_page("t", &banner, "![ext](http://host/x.png)\n", &[]);
    assert_inert(&alone);
    assert!(alone.contains("<p>[figure not included: ext]</p>"), "{alone}");
    assert!(html.contains("<td>x | y</td><td class=\"num\">1</td>"), "{html}");
    assert!(html.contains("<title>&lt;s&gt;: CONFIRMED</title>"), "{html}");
}

// ---- class 3, 4, 5: damaged logs, gzip, long lines -----------------------

fn good_log() -> Vec<u8> {
    std::fs::read(root().join("tests/fixtures/nanobench_corrupt/C10_good_rep1.csv")).unwrap()
}

fn gz(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

fn lenient_design(dir: &Path) -> std::path::PathBuf {
    let text = std::fs::read_to_string(root().join("tests/designs/minimal.design")).unwrap();
    let p = dir.join("study.design");
    std::fs::write(&p, text).unwrap();
    p
}

fn audit(design: &Path, logs: &Path, out: &Path) -> Output {
    crossaudit(&[
        "data",
        "audit",
        design.to_str().unwrap(),
        "--data",
        logs.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ])
}

/// The rows `audit/recordings.csv` gives `name`, and its status and reason.
fn audit_row(out: &Path, name: &str) -> (String, String) {
    let text = std::fs::read_to_string(out.join("recordings.csv")).unwrap();
    let mut r = csv::Reader::from_reader(text.as_bytes());
    let headers = r.headers().unwrap().clone();
    let col = |h: &str| headers.iter().position(|x| x == h).unwrap();
    for row in r.records() {
        let row = row.unwrap();
        if &row[col("name")] == name {
            return (row[col("status")].to_string(), row[col("reason")].to_string());
        }
    }
    panic!("{name} not in recordings.csv:\n{text}");
}

#[test]
fn damaged_logs_are_named_on_the_console_and_refused_under_strict() {
    let tmp = tempfile::tempdir().unwrap();
    let logs = tmp.path().join("logs");
    std::fs::create_dir_all(&logs).unwrap();
    let good = good_log();
    let z = gz(&good);
    std::fs::write(logs.join("A1_circle_slow_rep1.csv"), &good).unwrap();
    let mut damaged: Vec<(&str, Vec<u8>)> = vec![
        ("B1_circle_slow_rep1.csv.gz", z[..z.len() / 2].to_vec()),
        ("B2_circle_slow_rep1.csv.gz", good.clone()),
        ("B4_circle_slow_rep1.csv.gz", Vec::new()),
        ("B5_circle_slow_rep1.csv.gz", [z.clone(), b"trailing garbage".to_vec()].concat()),
    ];
    let mut bad_crc = z.clone();
    let n = bad_crc.len();
    bad_crc[n - 8] ^= 0xff;
    damaged.push(("B3_circle_slow_rep1.csv.gz", bad_crc));
    let mut forged = z.clone();
    forged[n - 1] ^= 0x01;
    damaged.push(("B6_circle_slow_rep1.csv.gz", forged));
    for (name, bytes) in &damaged {
        std::fs::write(logs.join(name), bytes).unwrap();
    }
    #[cfg(unix)]
    std::os::unix::fs::symlink("/dev/zero", logs.join("B7_circle_slow_rep1.csv")).unwrap();
    let design = lenient_design(tmp.path());
    // Seven of eight unreadable: more than half, so the audit stops after
    // writing itself; the design accepts it by saying how few it needs.
    let s = refused(&audit(&design, &logs, &tmp.path().join("audit0")), &["the audit kept 1 of 8 log file(s)"]);
    assert!(s.contains("declare `require at least 1 recordings`"), "{s}");
    assert!(tmp.path().join("audit0/recordings.csv").exists());
    let text = std::fs::read_to_string(&design).unwrap().replace(
        "data nanobench { path \"recordings\" }",
        "data nanobench { path \"recordings\" require at least 1 recordings }",
    );
    std::fs::write(&design, text).unwrap();
    let out = tmp.path().join("audit");
    let s = ok(&audit(&design, &logs, &out));
    assert!(s.contains("7 file(s) in the data folder could not be read and were excluded"), "{s}");
    for k in 1..=7 {
        let name = format!("B{k}_circle_slow_rep1");
        assert!(s.contains(&name), "{name} is not named:\n{s}");
        let (status, reason) = audit_row(&out, &name);
        assert_eq!(status, "excluded", "{name}: {reason}");
        assert!(!reason.is_empty());
    }
    // Under `strict` the same folder is an error naming them.
    let strict = std::fs::read_to_string(&design)
        .unwrap()
        .replace("require at least 1 recordings }", "require at least 1 recordings strict }");
    assert!(strict.contains("strict"));
    std::fs::write(&design, strict).unwrap();
    let s = refused(&audit(&design, &logs, &tmp.path().join("audit2")), &["strict data rules: 7 file(s)"]);
    assert!(s.contains("B3_circle_slow_rep1") && s.contains("B7_circle_slow_rep1"), "{s}");
}

#[test]
fn every_gzip_member_is_read_and_a_bomb_stops_at_the_limit() {
    let tmp = tempfile::tempdir().unwrap();
    let logs = tmp.path().join("logs");
    std::fs::create_dir_all(&logs).unwrap();
    let good = good_log();
    let text = String::from_utf8(good.clone()).unwrap();
    let (header, body) = text.split_once('\n').unwrap();
    // Two members: the header and half the rows, then the other half.
    let rows: Vec<&str> = body.lines().collect();
    let half = rows.len() / 2;
    let first = format!("{header}\n{}\n", rows[..half].join("\n"));
    let second = format!("{}\n", rows[half..].join("\n"));
    std::fs::write(logs.join("A1_circle_slow_rep1.csv.gz"), [gz(first.as_bytes()), gz(second.as_bytes())].concat())
        .unwrap();
    // 600 MB of zeros in well under a megabyte.
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    let block = vec![b'0'; 1 << 20];
    for _ in 0..600 {
        e.write_all(&block).unwrap();
    }
    std::fs::write(logs.join("A2_circle_slow_rep1.csv.gz"), e.finish().unwrap()).unwrap();
    let design = lenient_design(tmp.path());
    let out = tmp.path().join("audit");
    let s = ok(&audit(&design, &logs, &out));
    let recordings = std::fs::read_to_string(out.join("recordings.csv")).unwrap();
    let mut r = csv::Reader::from_reader(recordings.as_bytes());
    let h = r.headers().unwrap().clone();
    let (name, rows_col) = (h.iter().position(|x| x == "name").unwrap(), h.iter().position(|x| x == "rows").unwrap());
    let loaded = r.records().map(|r| r.unwrap()).find(|r| &r[name] == "A1_circle_slow_rep1").unwrap();
    assert_eq!(loaded[rows_col].parse::<usize>().unwrap(), rows.len(), "both members are read");
    let (status, reason) = audit_row(&out, "A2_circle_slow_rep1");
    assert_eq!(status, "excluded");
    assert!(reason.contains("decompresses to more than"), "{reason}");
    assert!(s.contains("A2_circle_slow_rep1"), "{s}");
}

#[test]
fn a_very_long_line_is_refused_before_it_is_parsed_and_quoted_in_part() {
    let tmp = tempfile::tempdir().unwrap();
    let logs = tmp.path().join("logs");
    std::fs::create_dir_all(&logs).unwrap();
    let good = String::from_utf8(good_log()).unwrap();
    let mut lines: Vec<String> = good.lines().map(str::to_string).collect();
    // 80 MB on one line: digits with no comma, then the rest of the row.
    lines[5] = "1".repeat(80 << 20) + &lines[5];
    std::fs::write(logs.join("A1_circle_slow_rep1.csv"), lines.join("\n") + "\n").unwrap();
    // A field that is long but within the line limit is quoted in part.
    let mut lines: Vec<String> = good.lines().map(str::to_string).collect();
    let mut f: Vec<String> = lines[7].split(',').map(str::to_string).collect();
    f[1] = "x".repeat(30_000);
    lines[7] = f.join(",");
    std::fs::write(logs.join("A2_circle_slow_rep1.csv"), lines.join("\n") + "\n").unwrap();
    let design = lenient_design(tmp.path());
    let out = tmp.path().join("audit");
    // Both excluded: the audit is written, then refused (it keeps nothing).
    refused(&audit(&design, &logs, &out), &["none of its 2 log file(s) was included", "recordings.csv"]);
    let (status, reason) = audit_row(&out, "A1_circle_slow_rep1");
    assert_eq!(status, "excluded");
    assert!(reason.contains("line 6 is longer than 65536 bytes"), "{reason}");
    let (status, reason) = audit_row(&out, "A2_circle_slow_rep1");
    assert_eq!(status, "excluded");
    assert!(reason.contains("(30000 bytes in all)") && reason.len() < 400, "{reason}");
    assert!(std::fs::metadata(out.join("recordings.csv")).unwrap().len() < 10_000);
}

// ---- class 6: alternatives compared as values -----------------------------

fn small(extra: &str) -> String {
    let base = std::fs::read_to_string(root().join("tests/designs/sim_small.design")).unwrap();
    base.replace("epochs 15 cosine patience 15", "epochs 2 cosine patience 2") + extra
}

/// [`small`] with its learning rate left to a choice.
fn small_lr(extra: &str) -> String {
    small(extra).replace("adam lr 1e-3 ", "")
}

fn design_error(text: &str) -> String {
    match crossaudit::design::from_str("m.design", text) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.render(false),
    }
}

#[test]
fn alternatives_are_compared_as_values() {
    let e = design_error(&small_lr("choices { lr 1e-3 | 0.001 }\nprimary specification lr 1e-3\n"));
    assert!(e.contains("duplicate alternative") && e.contains("`0.001` is the same value as `1e-3`"), "{e}");
    let e =
        design_error(&small("choices { cap 2 | 2.0 | 2e0 }\nprimary specification cap 2\n").replace(" cap 2 m", ""));
    assert!(e.contains("`2.0` is the same value as `2`") && e.contains("`2e0` is the same value as `2`"), "{e}");
    // The primary may name an alternative by another spelling of its value.
    let d = crossaudit::design::from_str(
        "m.design",
        &small_lr("choices { lr 1e-3 | 2e-3 }\nprimary specification lr 0.002\n"),
    )
    .unwrap();
    assert_eq!(d.multiverse.unwrap().primary, 1);
}

// ---- class 10: a level whose quantile is infinite --------------------------

#[test]
fn a_level_too_close_to_one_is_refused() {
    let text = small("").replace("level 0.95", "level 0.9999999999999999");
    assert!(text.contains("0.9999999999999999"));
    let e = design_error(&text);
    assert!(e.contains("level out of range") && e.contains("at most 0.999999999"), "{e}");
}

// ---- class 2: a multiverse reanalysis checks what it reads ------------------

/// A two-specification multiverse (two learning rates, two epochs) run
/// into `tmp/run`; returns the design's path.
fn multiverse_run(tmp: &Path) -> std::path::PathBuf {
    let path = tmp.join("m.design");
    std::fs::write(&path, small_lr("choices { lr 1e-3 | 2e-3 }\nprimary specification lr 1e-3\n")).unwrap();
    ok(&crossaudit(&["run", path.to_str().unwrap(), "--out", tmp.join("run").to_str().unwrap(), "--workers", "2"]));
    path
}

#[test]
fn a_multiverse_reanalysis_checks_every_level_and_writes_into_no_run() {
    let tmp = tempfile::tempdir().unwrap();
    let design = multiverse_run(tmp.path());
    let d = design.to_str().unwrap();
    let run = tmp.path().join("run");
    let record = std::fs::read_to_string(run.join("spec-s1/run.json")).unwrap();
    assert!(record.contains("\"level\": \"spec-s1\"") && record.contains("\"cells_sha256\""), "{record}");
    // The untouched run reanalyses.
    let fresh = tmp.path().join("fresh");
    ok(&crossaudit(&["analyze", d, "--cells", run.to_str().unwrap(), "--out", fresh.to_str().unwrap()]));
    let report = std::fs::read(run.join("report/report.md")).unwrap();
    // Without --out: into the run's `reanalysis/`, never into the folder
    // above the run (where a second study's reanalysis replaced the first's).
    ok(&crossaudit(&["analyze", d, "--cells", run.to_str().unwrap()]));
    assert!(run.join("reanalysis/multiverse.json").is_file());
    assert!(!tmp.path().join("report").exists(), "nothing written beside the run");
    assert_eq!(
        std::fs::read(fresh.join("multiverse.json")).unwrap(),
        std::fs::read(run.join("reanalysis/multiverse.json")).unwrap()
    );

    // An edited design (alternatives reordered): refused, and the run's
    // own combined report is not replaced.
    let edited = tmp.path().join("edited.design");
    std::fs::write(&edited, std::fs::read_to_string(&design).unwrap().replace("lr 1e-3 | 2e-3", "lr 2e-3 | 1e-3"))
        .unwrap();
    let e = edited.to_str().unwrap();
    refused(
        &crossaudit(&["analyze", e, "--cells", run.to_str().unwrap(), "--out", run.join("report").to_str().unwrap()]),
        &["holds a run of a different design"],
    );
    refused(
        &crossaudit(&[
            "analyze",
            e,
            "--cells",
            run.to_str().unwrap(),
            "--out",
            run.join("x/../report/.").to_str().unwrap(),
        ]),
        &["holds a run of a different design"],
    );
    refused(
        &crossaudit(&["analyze", e, "--cells", run.to_str().unwrap(), "--out", tmp.path().join("e").to_str().unwrap()]),
        &["was run from design sha256"],
    );
    assert_eq!(std::fs::read(run.join("report/report.md")).unwrap(), report, "the run's report is unchanged");

    // A level's cells.csv edited after the run: refused, with and without its job records.
    let edits = tmp.path().join("edits");
    crate::common::copy_dir(&run, &edits);
    let cells = edits.join("spec-s2/cells.csv");
    let text = std::fs::read_to_string(&cells).unwrap();
    let line = text.lines().nth(1).unwrap().to_string();
    let mut f: Vec<String> = line.split(',').map(str::to_string).collect();
    f[9] = "0.123".into();
    std::fs::write(&cells, text.replacen(&line, &f.join(","), 1)).unwrap();
    let out = tmp.path().join("o").to_str().unwrap().to_string();
    refused(&crossaudit(&["analyze", d, "--cells", edits.to_str().unwrap(), "--out", &out]), &["edited after the run"]);
    std::fs::remove_dir_all(edits.join("spec-s2/jobs")).unwrap();
    refused(
        &crossaudit(&["analyze", d, "--cells", edits.to_str().unwrap(), "--out", &out]),
        &["but the run recorded", "edited after the run"],
    );

    // Two level folders swapped.
    let swapped = tmp.path().join("swapped");
    crate::common::copy_dir(&run, &swapped);
    std::fs::rename(swapped.join("spec-s1"), swapped.join("tmp")).unwrap();
    std::fs::rename(swapped.join("spec-s2"), swapped.join("spec-s1")).unwrap();
    std::fs::rename(swapped.join("tmp"), swapped.join("spec-s2")).unwrap();
    refused(
        &crossaudit(&["analyze", d, "--cells", swapped.to_str().unwrap(), "--out", &out]),
        &["holds the run of level spec-s2, not of spec-s1"],
    );
}

#[test]
fn a_reanalysed_multiverse_of_an_edited_design_says_exploratory_on_its_decision_line() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("m.design");
    let text = small("choices { level 0.95 | 0.99 }\nprimary specification level 0.95\n")
        .replace("estimate crossed_mom level 0.95 df seed - 1\n", "estimate crossed_mom df seed - 1\n");
    std::fs::write(&path, &text).unwrap();
    let p = path.to_str().unwrap();
    ok(&crossaudit(&["lock", p]));
    // Edited after its lock, run as an exploratory analysis, then reanalysed.
    std::fs::write(&path, text + "# an edit after the lock\n").unwrap();
    let run = tmp.path().join("run");
    let r = run.to_str().unwrap();
    let s = ok(&crossaudit(&["run", p, "--out", r, "--workers", "2", "--exploratory"]));
    let last = |s: &str| s.lines().rfind(|l| l.contains("specifications (primary")).unwrap_or_default().to_string();
    assert!(last(&s).starts_with("EXPLORATORY "), "{s}");
    let o = crossaudit(&["analyze", p, "--cells", r, "--out", tmp.path().join("again").to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "{}", said(&o));
    assert!(stdout.trim_end().starts_with("EXPLORATORY ") || last(&stdout).starts_with("EXPLORATORY "), "{stdout}");
}
