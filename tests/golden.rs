//! Golden tests of the real `crossaudit` binary on real files.

use crate::common::bin;
use crate::common::{confirmatory_design, example_cells, minimal_cells, minimal_design, root, write_temp_cells};
use crate::snapshots;

fn run(args: &[&str]) -> (i32, String, String) {
    let out = bin().args(args).output().expect("run crossaudit");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn check_prints_the_plan_and_exits_zero() {
    let (code, out, _) = run(&["check", "designs/nanobench_confirmatory.design"]);
    assert_eq!(code, 0);
    assert!(out.contains("training cells: 80 = 2 models x 2 arms x 20 seeds"), "{out}");
    assert!(out.contains("lock: "), "{out}");
}

#[test]
fn check_json_is_machine_readable() {
    let (code, out, _) = run(&["check", "--json", "designs/nanobench_confirmatory.design"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["plan"]["training_cells"].as_array().unwrap().len(), 80);
    assert_eq!(v["plan"]["required_rows"], 6240);
}

#[test]
fn check_json_of_a_bad_design_is_json_too() {
    let (code, out, err) = run(&["check", "--json", "tests/designs/errors/unknown_arm_in_contrast.design"]);
    assert_eq!(code, 1);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap_or_else(|e| panic!("{e}: {out}"));
    assert_eq!(v["valid"], false);
    let first = &v["errors"][0];
    assert_eq!(first["file"], "tests/designs/errors/unknown_arm_in_contrast.design");
    // The same line and column as the text the terminal gets.
    let at = format!("{}:{}:{}", first["file"].as_str().unwrap(), first["line"], first["column"]);
    assert!(err.contains(&at), "{at} in {err}");
    assert!(first["title"].as_str().is_some_and(|t| !t.is_empty()) && first["label"].is_string());
    let (_, good, _) = run(&["check", "--json", "designs/quickstart.design"]);
    assert_eq!(serde_json::from_str::<serde_json::Value>(&good).unwrap()["valid"], true);
}

#[test]
fn check_of_a_bad_design_shows_the_caret_and_fails() {
    let (code, out, err) = run(&["check", "tests/designs/errors/unknown_arm_in_contrast.design"]);
    assert_eq!(code, 1);
    assert!(out.is_empty());
    snapshots!({ insta::assert_snapshot!(err) });
}

#[test]
fn a_missing_design_file_is_a_clear_error() {
    let (code, _, err) = run(&["check", "no/such.design"]);
    assert_eq!(code, 1);
    assert!(err.starts_with("error: cannot read design file no/such.design"), "{err}");
}

#[test]
fn lock_then_check_reports_the_lock_state() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.design");
    std::fs::copy(root().join("tests/designs/minimal.design"), &path).unwrap();
    let p = path.to_str().unwrap();
    assert!(run(&["check", p]).1.contains("lock: unlocked"));
    let (code, out, _) = run(&["lock", p]);
    assert_eq!(code, 0, "{out}");
    assert!(dir.path().join("s.design.lock").exists());
    assert!(run(&["check", p]).1.contains("lock: locked/unchanged"));
    std::fs::write(&path, std::fs::read_to_string(&path).unwrap() + "\n# amended\n").unwrap();
    assert!(run(&["check", p]).1.contains("lock: locked/changed"));
    let (code, _, err) = run(&["lock", p]);
    assert_eq!(code, 1);
    assert!(err.contains("already locked"), "{err}");
}

#[test]
fn analyze_writes_reports_and_prints_the_decision() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("report");
    let (code, out, err) = run(&[
        "analyze",
        confirmatory_design().to_str().unwrap(),
        "--cells",
        example_cells().to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.starts_with("decision: "), "{out}");
    let md = std::fs::read_to_string(out_dir.join("report.md")).unwrap();
    assert!(md.lines().next().unwrap().contains("CONFIRMED"), "first line states the decision");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("results.json")).unwrap()).unwrap();
    assert_eq!(json["units"].as_array().unwrap().len(), 6);
    let tex = std::fs::read_to_string(out_dir.join("results.tex")).unwrap();
    assert!(tex.contains("\\newcommand{\\caWorldFaPositionRmseOneSOptimism}"), "{tex}");
    // Every macro name is unique and letters only.
    let names: Vec<&str> =
        tex.lines().filter_map(|l| l.strip_prefix("\\newcommand{\\")).map(|l| l.split('}').next().unwrap()).collect();
    assert!(names.iter().all(|n| n.chars().all(|c| c.is_ascii_alphabetic())));
    let mut sorted = names.clone();
    sorted.sort();
    sorted.dedup();
    assert_eq!(sorted.len(), names.len());
}

#[test]
fn analyze_of_bad_cells_names_the_line_and_fails() {
    let dir = tempfile::tempdir().unwrap();
    let d = minimal_design();
    let mut cells = minimal_cells(&d);
    // The primary endpoint (world at 1 s) needs this cell.
    let k = cells.iter().rposition(|c| c.model == "world" && c.horizon_s == 1.0).unwrap();
    cells.remove(k);
    let p = write_temp_cells(dir.path(), &cells);
    let (code, out, err) = run(&["analyze", "tests/designs/minimal.design", "--cells", p.to_str().unwrap()]);
    assert_eq!(code, 1);
    assert!(out.is_empty());
    assert!(
        err.contains("1 missing cell(s)")
            && err.contains("model=world arm=disjoint seed=3 recording=R4_star_slow_rep1 horizon=1 s"),
        "{err}"
    );
    assert!(!dir.path().join("report").exists(), "no report from bad data");
}

#[test]
fn analyze_output_does_not_depend_on_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let mut outputs = Vec::new();
    for threads in ["1", "2"] {
        let out_dir = dir.path().join(threads);
        let status = bin()
            .env("RAYON_NUM_THREADS", threads)
            .args(["analyze", confirmatory_design().to_str().unwrap(), "--cells", example_cells().to_str().unwrap()])
            .args(["--out", out_dir.to_str().unwrap(), "--compare-intervals"])
            .output()
            .unwrap();
        assert!(status.status.success());
        outputs.push(std::fs::read(out_dir.join("results.json")).unwrap());
    }
    assert_eq!(outputs[0], outputs[1]);
}

#[test]
fn every_argument_of_every_subcommand_is_described_in_its_help() {
    let subcommands: [&[&str]; 16] = [
        &["check"],
        &["lock"],
        &["audit", "split"],
        &["data", "audit"],
        &["split"],
        &["train"],
        &["run"],
        &["export"],
        &["score"],
        &["job"],
        &["gather"],
        &["coverage"],
        &["plan"],
        &["mixed"],
        &["simulate"],
        &["analyze"],
    ];
    // clap lists each argument as "  NAME  description" under "Arguments:"
    // and "Options:", a long description continuing on lines of its own.
    let is_entry = |t: &str| {
        t.starts_with('-')
            || t.starts_with('<')
            || (t.starts_with('[') && t[1..].starts_with(|c: char| c.is_ascii_uppercase()))
    };
    let mut entries = 0;
    for sub in subcommands {
        let mut args = sub.to_vec();
        args.push("--help");
        let (code, out, err) = run(&args);
        assert_eq!(code, 0, "{sub:?}: {err}");
        let lines: Vec<&str> = out.lines().collect();
        for (k, line) in lines.iter().enumerate() {
            let t = line.trim();
            if !line.starts_with("  ") || !is_entry(t) {
                continue;
            }
            entries += 1;
            let described = t.contains("  ")
                || lines
                    .get(k + 1)
                    .is_some_and(|n| n.starts_with("   ") && !is_entry(n.trim()) && !n.trim().is_empty());
            assert!(described, "crossaudit {} --help: `{t}` has no description", sub.join(" "));
        }
    }
    assert!(entries > 60, "{entries} arguments seen");
}
