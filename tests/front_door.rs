//! What a newcomer reads first stays true: results/INDEX.md lists every
//! committed result folder, each has the commands that made it, and every
//! link and source path the README and the docs name exists.

use std::path::Path;

use crate::common::root;

fn folders(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn every_result_folder_is_indexed_and_has_its_command() {
    let results = root().join("results");
    let index = std::fs::read_to_string(results.join("INDEX.md")).unwrap();
    let listed: Vec<String> = index
        .lines()
        .filter_map(|l| l.strip_prefix("| `"))
        .filter_map(|l| l.split('`').next())
        .map(String::from)
        .collect();
    let present = folders(&results);
    assert_eq!(listed, present, "results/INDEX.md must list exactly the folders under results/, in order");
    for f in &present {
        let dir = results.join(f);
        if dir.join("COMMAND").is_file() {
            continue;
        }
        // A group: each of its runs has its own COMMAND.
        let subs = folders(&dir);
        assert!(!subs.is_empty(), "results/{f} has no COMMAND");
        for s in subs {
            assert!(dir.join(&s).join("COMMAND").is_file(), "results/{f}/{s} has no COMMAND");
        }
    }
}

/// Relative link targets of `[text](target)` in Markdown, without anchors.
fn links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(k) = rest.find("](") {
        rest = &rest[k + 2..];
        let Some(end) = rest.find(')') else { break };
        let target = rest[..end].split('#').next().unwrap_or("").trim().to_string();
        if !target.is_empty() && !target.contains("://") && !target.starts_with("mailto:") && !target.contains(' ') {
            out.push(target);
        }
    }
    out
}

#[test]
fn every_link_and_source_path_in_the_readme_and_docs_exists() {
    let mut pages = vec![root().join("README.md"), root().join("ARCHITECTURE.md")];
    for e in std::fs::read_dir(root().join("docs")).unwrap().filter_map(|e| e.ok()) {
        if e.path().extension().is_some_and(|x| x == "md") {
            pages.push(e.path());
        }
    }
    let mut checked = 0;
    for page in &pages {
        let text = std::fs::read_to_string(page).unwrap();
        let base = page.parent().unwrap();
        for target in links(&text) {
            assert!(base.join(&target).exists(), "{}: link to {target}, which does not exist", page.display());
            checked += 1;
        }
        // `src/...rs` paths quoted in backticks.
        for quoted in text.split('`').skip(1).step_by(2) {
            if quoted.starts_with("src/") && quoted.ends_with(".rs") && !quoted.contains(' ') {
                assert!(root().join(quoted).exists(), "{} names {quoted}, which does not exist", page.display());
                checked += 1;
            }
        }
    }
    assert!(checked > 20, "{checked} links and paths checked");
}

#[test]
fn the_language_reference_is_the_grammar() {
    // docs/language.md is generated from grammar/design.pest; to accept a
    // grammar change: CROSSAUDIT_BLESS_DOCS=1 cargo test front_door
    let page = root().join("docs/language.md");
    let fresh = crossaudit::design::reference::markdown();
    if std::env::var_os("CROSSAUDIT_BLESS_DOCS").is_some() {
        std::fs::write(&page, &fresh).unwrap();
    }
    let committed = std::fs::read_to_string(&page).unwrap_or_default();
    assert!(
        committed == fresh,
        "docs/language.md differs from the grammar; regenerate it with CROSSAUDIT_BLESS_DOCS=1"
    );
    // Every keyword of the grammar is in the reference, and every rule has a heading.
    let words = crossaudit::design::reference::GRAMMAR
        .split('"')
        .filter(|w| !w.is_empty() && w.chars().all(|c| c.is_ascii_lowercase() || c == '_'));
    let mut keywords = 0;
    for k in words {
        assert!(fresh.contains(&format!("\"{k}\"")), "keyword {k}");
        keywords += 1;
    }
    assert!(keywords > 100, "{keywords} keywords");
    assert!(fresh.matches("\n### `").count() > 100, "one heading per rule");
}

#[test]
fn the_book_lists_every_page_of_the_docs() {
    let summary = std::fs::read_to_string(root().join("docs/SUMMARY.md")).unwrap();
    for e in std::fs::read_dir(root().join("docs")).unwrap().filter_map(|e| e.ok()) {
        let name = e.file_name().to_string_lossy().into_owned();
        if name.ends_with(".md") && name != "SUMMARY.md" {
            assert!(summary.contains(&format!("({name})")), "docs/SUMMARY.md does not list {name}");
        }
    }
}

#[test]
fn the_readmes_worked_example_prints_what_the_readme_quotes() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    assert!(readme.contains("--cells examples/cells/nanobench_synthetic.csv --out out/example"));
    // The decision line and the guard lines indented under it.
    let start = readme.lines().position(|l| l.starts_with("decision: ")).expect("the README quotes a decision line");
    let quoted: Vec<&str> = readme
        .lines()
        .skip(start)
        .enumerate()
        .take_while(|(k, l)| *k == 0 || l.starts_with("  "))
        .map(|(_, l)| l)
        .collect();
    assert!(quoted.len() >= 2, "the README quotes the guards under the decision: {quoted:?}");
    let tmp = tempfile::tempdir().unwrap();
    let out = crate::common::bin()
        .current_dir(root())
        .args(["analyze", "designs/nanobench_confirmatory.design", "--cells", "examples/cells/nanobench_synthetic.csv"])
        .arg("--out")
        .arg(tmp.path().join("example"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let printed = String::from_utf8_lossy(&out.stdout);
    assert_eq!(printed.lines().collect::<Vec<_>>(), quoted, "README quote vs the command's output");
    assert!(tmp.path().join("example/report.html").is_file() && tmp.path().join("example/estimates.csv").is_file());
}

/// Every file under `dir`, relative, sorted.
fn files_in(dir: &Path) -> Vec<String> {
    fn walk(base: &Path, d: &Path, out: &mut Vec<String>) {
        for e in std::fs::read_dir(d).unwrap().filter_map(|e| e.ok()) {
            let p = e.path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                out.push(p.strip_prefix(base).unwrap().display().to_string());
            }
        }
    }
    let mut v = Vec::new();
    walk(dir, dir, &mut v);
    v.sort();
    v
}

/// The crossaudit build (version and commit) changes with every commit.
fn without_build(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes)
        .lines()
        .map(|l| if l.contains("(commit ") { "<build>" } else { l })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn the_fast_committed_results_regenerate_byte_for_byte() {
    // Each folder's COMMAND, run afresh into a temporary folder; every
    // committed file (the build line aside) must come out the same.
    // `summary.txt` is the command's standard output. The quickstart is
    // checked by tests/run_integrity.rs, the slower ones by scripts/regenerate.sh.
    let shared = crate::common::shared_logs_or_skip().is_some();
    let cases: &[(&str, &[&str], bool)] = &[
        (
            "example",
            &[
                "analyze",
                "designs/nanobench_confirmatory.design",
                "--cells",
                "examples/cells/nanobench_synthetic.csv",
                "--compare-intervals",
                "--out",
            ],
            false,
        ),
        ("coverage_decision", &["coverage", "specs/coverage_decision.json", "--out"], false),
        (
            "nanobench_divergence",
            &[
                "analyze",
                "designs/nanobench_divergence.design",
                "--cells",
                "results/nanobench_confirmatory/cells.csv",
                "--out",
            ],
            false,
        ),
        (
            "plan_audited",
            &[
                "plan",
                "designs/nanobench_paper_audited.design",
                "--cells",
                "results/nanobench_paper_audited/cells.csv",
                "--recordings",
                "8,13,26,52",
                "--seeds",
                "3,5,10,20,40",
                "--out",
            ],
            false,
        ),
        (
            "plan_dose_response",
            &[
                "plan",
                "designs/nanobench_dose_response.design",
                "--cells",
                "results/dose_response/cells.csv",
                "--recordings",
                "8,13,24,26,52",
                "--seeds",
                "3,5,10,20,40",
                "--out",
            ],
            false,
        ),
        (
            "plan_multi_split",
            &[
                "plan",
                "designs/nanobench_multi_split.design",
                "--cells",
                "results/multi_split/cells.csv",
                "--splits",
                "3,5,10,20",
                "--recordings",
                "13,26",
                "--seeds",
                "5,10,20",
                "--out",
            ],
            false,
        ),
        (
            "plan_draws",
            &[
                "plan",
                "designs/multiverse/paper_draws.design",
                "--cells",
                "results/multiverse/draws",
                "--recordings",
                "13,24,52",
                "--seeds",
                "5,10,20,40",
                "--draws",
                "3,5,10",
                "--out",
            ],
            false,
        ),
        (
            "plan_paper_declared",
            &[
                "plan",
                "designs/nanobench_paper.design",
                "--components",
                "recording=0.00791883,seed=6.98702e-05,residual=0.00495443",
                "--effect=-0.0362",
                "--reference-mean",
                "0.299",
                "--recordings",
                "26,52,104,208",
                "--seeds",
                "5,10,20,40",
                "--out",
            ],
            false,
        ),
        (
            "plan_per_seed",
            &[
                "plan",
                "designs/multiverse/paper_per_seed.design",
                "--cells",
                "results/multiverse/per_seed/cells.csv",
                "--recordings",
                "24,48",
                "--seeds",
                "20,40,60,120",
                "--out",
            ],
            false,
        ),
        ("nanobench_audit", &["data", "audit", "designs/nanobench_confirmatory.design", "--out"], true),
        ("nanobench_audit_hygiene", &["data", "audit", "designs/nanobench_audited.design", "--out"], true),
        ("nanobench_split", &["split", "designs/nanobench_confirmatory.design", "--out"], true),
        ("nanobench_split_audited", &["split", "designs/nanobench_audited.design", "--out"], true),
        (
            "simsum_rsimsum",
            &[
                "simsum",
                "results/coverage_rsimsum/replications.csv",
                "--by",
                "setting,true_mean",
                "--true",
                "true_mean",
                "--level",
                "level",
                "--ci",
                "ci_lower,ci_upper",
                "--rep",
                "rep",
                "--target-mcse",
                "cover=0.005,bias=0.02",
                "--out",
            ],
            false,
        ),
        (
            "upstream_split_audit",
            &[
                "audit",
                "split",
                "../shared/nanobench/upstream_task2_split_metadata.json",
                "--data",
                "../shared/nanobench/recordings",
                "--out",
            ],
            true,
        ),
    ];
    let tmp = tempfile::tempdir().unwrap();
    let mut compared = 0;
    for (folder, args, needs_shared) in cases {
        if *needs_shared && !shared {
            continue;
        }
        let out = tmp.path().join(folder);
        let o = crate::common::bin().current_dir(root()).args(*args).arg(&out).output().unwrap();
        assert!(o.status.success(), "{folder}: {}", String::from_utf8_lossy(&o.stderr));
        let committed = root().join("results").join(folder);
        for name in files_in(&committed) {
            if name == "COMMAND" {
                continue;
            }
            let fresh = if name == "summary.txt" {
                o.stdout.clone()
            } else {
                std::fs::read(out.join(&name))
                    .unwrap_or_else(|e| panic!("results/{folder}/{name}: not regenerated ({e})"))
            };
            let old = std::fs::read(committed.join(&name)).unwrap();
            if std::env::var_os("CROSSAUDIT_BLESS_RESULTS").is_some() && without_build(&fresh) != without_build(&old) {
                // Rewrites the committed file from its COMMAND (review the diff).
                std::fs::write(committed.join(&name), &fresh).unwrap();
                continue;
            }
            assert!(
                without_build(&fresh) == without_build(&old),
                "results/{folder}/{name} differs from what its COMMAND gives now"
            );
            compared += 1;
        }
    }
    assert!(compared >= 10, "{compared} files compared");
}

/// The cells of the markdown table whose header row is `header`, one Vec per
/// row, header first.
fn tables(report: &str) -> Vec<Vec<Vec<String>>> {
    let mut out: Vec<Vec<Vec<String>>> = Vec::new();
    let mut current: Vec<Vec<String>> = Vec::new();
    for line in report.lines().chain([""]) {
        if line.starts_with('|') {
            if !line.starts_with("|---") {
                current.push(line.trim_matches('|').split('|').map(|c| c.trim().to_string()).collect());
            }
        } else if !current.is_empty() {
            out.push(std::mem::take(&mut current));
        }
    }
    out
}

/// Every committed report that the fast results regenerate: each table
/// column holding a value in the metric's unit either sits beside a `unit`
/// column or names its unit in its header, and the report's first line is
/// the study and its verdict.
#[test]
fn every_table_of_the_regenerated_reports_names_its_units() {
    let reports = [
        "results/quickstart/report/report.md",
        "results/example/report.md",
        "results/simulated_family/dose_high/report/report.md",
        "results/simulated_family/splits_0/report/report.md",
    ];
    // Columns whose values carry the metric's unit.
    let valued =
        ["d mean", "SE", "delta mean", "mean d", "estimate", "d", "mu", "mean ref", "slope", "MS rec", "s2 rec"];
    for path in reports {
        let text = std::fs::read_to_string(root().join(path)).unwrap();
        let first = text.lines().next().unwrap();
        assert!(
            first.starts_with("# ")
                && [": CONFIRMED", ": NOT CONFIRMED", ": GROWS", ": NOT GROWS"].iter().any(|v| first.contains(v)),
            "{path}: line 1 is not the verdict: {first}"
        );
        for table in tables(&text) {
            let header = &table[0];
            let has_unit = header.iter().any(|h| h == "unit");
            for h in header.iter().filter(|h| valued.contains(&h.as_str())) {
                assert!(has_unit, "{path}: column `{h}` has no unit (header {header:?})");
            }
        }
        // The decision line states its units.
        let line = text.lines().find(|l| l.contains("decision: ")).unwrap();
        assert!(line.contains("%: ") || line.contains("%/pp: ") || !line.contains("optimism ="), "{path}: {line}");
        assert!(line.contains(" m: ") || line.contains(" m/pp: "), "{path}: {line}");
    }
}

/// The treatment-strength table of the committed quickstart and dose
/// reports says what `audit/treatment.json` says.
#[test]
fn the_treatment_strength_table_is_the_treatment_audit() {
    for run in ["results/quickstart", "results/simulated_family/dose_high"] {
        let dir = root().join(run);
        let audit: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("audit/treatment.json")).unwrap()).unwrap();
        let text = std::fs::read_to_string(dir.join("report/report.md")).unwrap();
        let table = tables(&text)
            .into_iter()
            .find(|t| t[0].first().map(String::as_str) == Some("arm") && t[0].len() == 7)
            .unwrap_or_else(|| panic!("{run}: no treatment-strength table"));
        let arms = audit["arms"].as_array().unwrap();
        assert_eq!(table.len() - 1, arms.len(), "{run}");
        for (row, arm) in table[1..].iter().zip(arms) {
            assert_eq!(row[0], arm["arm"].as_str().unwrap());
            assert_eq!(row[1], arm["contaminating_windows"].to_string());
            assert_eq!(row[2], arm["inside_evaluated_segment"].to_string());
            assert_eq!(row[3], format!("{:.1}", 100.0 * arm["share_inside"].as_f64().unwrap()));
            assert_eq!(row[5], format!("{:.2}", arm["median_distance_s"].as_f64().unwrap()));
            let q: Vec<String> = arm["segment_distance_quartiles_s"]
                .as_array()
                .unwrap()
                .iter()
                .map(|q| format!("{:.2}", q.as_f64().unwrap()))
                .collect();
            assert_eq!(row[6], q.join(" / "));
        }
    }
}

/// A dose-response report: report.html with the verdict and its figures
/// inline, and the dose figure on a numeric axis with the fitted slope the
/// report's trend table gives.
#[test]
fn a_dose_report_has_its_page_and_a_numeric_dose_axis_with_the_slope() {
    let dir = root().join("results/simulated_family/dose_high/report");
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    let verdict = if md.lines().next().unwrap().ends_with("NOT GROWS") { "NOT GROWS" } else { "GROWS" };
    assert!(html.contains(&format!(": {verdict}</h1>")) && html.contains("<h1 class=\"verdict\">"), "{html}");
    assert!(html.contains("<figure data-figure=\"optimism_by_dose.svg\"") && !html.contains("<img"), "{html}");
    let svg = std::fs::read_to_string(dir.join("optimism_by_dose.svg")).unwrap();
    assert!(svg.contains("dose (% of the fit windows from the evaluation recordings)"), "no numeric dose axis");
    // The slope the figure's key quotes is the trend table's optimism slope.
    let trend = tables(&md).into_iter().find(|t| t[0].iter().any(|h| h == "optimism slope (%/pp)")).unwrap();
    let k = trend[0].iter().position(|h| h == "optimism slope (%/pp)").unwrap();
    assert!(svg.contains(&format!("fitted slope {} %/pp", trend[1][k])), "slope {} not in the figure", trend[1][k]);
}

/// A dose-response study's estimates.csv holds the numbers its report.md
/// prints (each dose's d and optimism, and the trend's slope) under the
/// single study's column names, with `rule_holds` on the one row the rule
/// decides (`on slope`: the trend) and empty elsewhere.
#[test]
fn a_family_estimates_csv_is_its_report_in_tidy_form() {
    let dir = root().join("results/simulated_family/dose_high/report");
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    let csv = std::fs::read_to_string(dir.join("estimates.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    // The single study's columns (a dose's own report beside it), with the
    // split and the dose after the kind.
    let single = std::fs::read_to_string(dir.join("contaminated_5pct/estimates.csv")).unwrap();
    let single: Vec<&str> = single.lines().next().unwrap().split(',').collect();
    assert_eq!([&header[..1], &header[3..]].concat(), single);
    assert_eq!(header[1..3], ["split", "dose_pct"]);
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let per_dose = tables(&md).into_iter().find(|t| t[0].iter().any(|h| h == "d (m)")).unwrap();
    let (d_col, opt_col) = (
        per_dose[0].iter().position(|h| h == "d (m)").unwrap(),
        per_dose[0].iter().position(|h| h == "optimism %").unwrap(),
    );
    // The primary endpoint's rows (each declared secondary has its own,
    // role `secondary`, as the report's "Secondary endpoints" table).
    let primary = |r: &&Vec<&str>| r[col("role")] == "primary";
    let endpoints: Vec<&Vec<&str>> = rows.iter().filter(|r| r[col("kind")] == "endpoint").filter(primary).collect();
    let optimisms: Vec<&Vec<&str>> = rows.iter().filter(|r| r[col("kind")] == "optimism").filter(primary).collect();
    let secondary = rows.iter().filter(|r| r[col("role")] == "secondary").count();
    assert_eq!(secondary, 2 * (per_dose.len() - 1), "the design's one secondary endpoint, per dose");
    assert!(md.contains("## Secondary endpoints"));
    assert_eq!((endpoints.len(), optimisms.len()), (per_dose.len() - 1, per_dose.len() - 1));
    for ((row, optimism), printed) in endpoints.iter().zip(&optimisms).zip(&per_dose[1..]) {
        let v = |name: &str| row[col(name)].parse::<f64>().unwrap();
        assert_eq!(format!("{:.4}", v("estimate")), printed[d_col]);
        assert_eq!(format!("{:.1}", v("optimism_pct")), printed[opt_col]);
        assert_eq!(optimism[col("estimate")], row[col("optimism_pct")]);
        assert_eq!((row[col("unit")], optimism[col("unit")]), ("m", "%"));
        assert_eq!(format!("{}%", row[col("dose_pct")]), printed[1]);
        assert_eq!(row[col("contrast")], format!("{} - disjoint", printed[2].trim_matches('`')));
    }
    let trend = rows.iter().find(|r| r[col("kind")] == "trend").unwrap();
    assert_eq!(trend[col("unit")], "m/pp");
    let decided: Vec<&str> = rows.iter().filter(|r| !r[col("rule_holds")].is_empty()).map(|r| r[col("kind")]).collect();
    assert_eq!(decided, ["trend"]);
    let slope = rows.iter().find(|r| r[col("kind")] == "trend_optimism").unwrap();
    assert_eq!(slope[col("unit")], "%/pp");
    let slope_table = tables(&md).into_iter().find(|t| t[0].iter().any(|h| h == "optimism slope (%/pp)")).unwrap();
    let k = slope_table[0].iter().position(|h| h == "optimism slope (%/pp)").unwrap();
    assert_eq!(format!("{:.3}", slope[col("estimate")].parse::<f64>().unwrap()), slope_table[1][k]);
}

/// CI runs the README's test command, the one that ends with the summary
/// of passed, failed and SKIPPED tests.
#[test]
fn ci_runs_the_readmes_test_command() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let ci = std::fs::read_to_string(root().join(".ci/run")).unwrap();
    assert!(readme.lines().any(|l| l == "bash scripts/test.sh"), "the README's test command");
    assert!(ci.lines().any(|l| l == "bash scripts/test.sh"), ".ci/run runs it");
    let script = std::fs::read_to_string(root().join("scripts/test.sh")).unwrap();
    assert!(script.contains("cargo test --release -p crossaudit -p crossaudit-stats -- --include-ignored"));
    assert!(script.contains("only printed SKIPPED"));
}
