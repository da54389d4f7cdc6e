//! Published splits: each input form, each finding kind on the committed
//! fixtures (tests/fixtures/splits, written by make_nanobench_fixtures.py),
//! the real CLI with `--fail-on leak`, and the audit of NanoBench's own
//! task-2 split against an independent Python reference.

use std::path::{Path, PathBuf};

use crate::common::{root, shared_logs};
use crate::snapshots;
use crossaudit::design::DataSpec;
use crossaudit::published::{self, Format, Place};
use crossaudit::split_audit::{self, Effect, Presence, SplitAudit};

fn fixture(name: &str) -> PathBuf {
    root().join("tests/fixtures/splits").join(name)
}

fn audit_fixture(name: &str) -> SplitAudit {
    let split = published::read(&fixture(name)).unwrap();
    split_audit::audit(&split, &DataSpec::upstream_task2(), "upstream", &fixture("data"), Default::default()).unwrap()
}

fn roles(s: &published::PublishedSplit) -> Vec<(String, Vec<String>)> {
    s.roles.iter().map(|r| (r.name.clone(), r.entries.iter().map(|e| e.name.clone()).collect())).collect()
}

#[test]
fn reads_each_form_by_stem_with_places() {
    let nb = published::read(&fixture("nanobench_small.json")).unwrap();
    assert_eq!(nb.format, Format::NanobenchJson);
    assert_eq!(nb.notes.get("seed").map(String::as_str), Some("7"));
    let r = roles(&nb);
    assert_eq!(
        r.iter().map(|(n, e)| (n.as_str(), e.len())).collect::<Vec<_>>(),
        [("train", 5), ("val", 1), ("test", 3)]
    );
    assert_eq!(r[0].1[0], "S1_circle_slow_rep1");
    // json.dumps(indent=2): "seed" on line 2, "train_files" on line 3, its first path on line 4.
    let first = &nb.roles[0].entries[0];
    assert_eq!(first.at, Place { line: 4, column: 5 });
    assert!(first.listed.starts_with("/home/someone/"));

    let csv = published::read(&fixture("roles.csv")).unwrap();
    assert_eq!(csv.format, Format::RoleCsv);
    let r = roles(&csv);
    assert_eq!(r[0].0, "fit");
    assert_eq!(r[1].0, "hold-out");
    // `.csv.gz` and `.csv` suffixes are file names of the same stem.
    assert_eq!(r[1].1[0], "S1_circle_slow_rep2");
    assert_eq!(csv.roles[1].entries[0].at, Place { line: 5, column: 1 });

    let fj = published::read(&fixture("folds.json")).unwrap();
    assert_eq!(fj.format, Format::FoldJson);
    assert_eq!(roles(&fj).iter().map(|(n, _)| n.clone()).collect::<Vec<_>>(), ["fold0", "fold1", "fold2"]);
    let fc = published::read(&fixture("folds.csv")).unwrap();
    assert_eq!(fc.format, Format::FoldCsv);
    assert_eq!(roles(&fc)[3], ("fold3".to_string(), vec!["S3_oval_medium_rep2".to_string()]));
}

#[test]
fn stems_are_file_names_without_folders_csv_or_gz() {
    assert_eq!(published::stem("/a/b/B9_trefoil_slow_rep3.csv"), "B9_trefoil_slow_rep3");
    assert_eq!(published::stem("C:\\data\\B9_trefoil_slow_rep3.csv.gz"), "B9_trefoil_slow_rep3");
    assert_eq!(published::stem("B9_trefoil_slow_rep3"), "B9_trefoil_slow_rep3");
    // Nothing else is guessed: a different case is a different name.
    assert_eq!(published::stem("b9_TREFOIL_slow_rep3.CSV"), "b9_TREFOIL_slow_rep3.CSV");
}

#[test]
fn each_finding_on_the_fixture_split() {
    let a = audit_fixture("nanobench_small.json");
    let row = |name: &str| a.recordings.iter().find(|r| r.recording == name).unwrap();
    // Declared against effective: a metadata-only file, an unknown name, an implausible file.
    assert_eq!(row("S6_figure8_slow_rep1").presence, Presence::MetadataOnly);
    assert_eq!(row("Z9_unknown_rep1").presence, Presence::Unknown);
    let s5 = row("S5_helix_fast_rep1");
    assert_eq!(s5.effect, Effect::Dropped);
    assert!(s5.reason.contains("battery"), "{}", s5.reason);
    let sizes: Vec<(&str, usize, usize, usize, usize, usize)> = a
        .roles
        .iter()
        .map(|r| (r.role.as_str(), r.declared, r.metadata_only, r.unknown, r.dropped, r.effective))
        .collect();
    assert_eq!(sizes, [("train", 5, 1, 1, 0, 3), ("val", 1, 0, 0, 1, 0), ("test", 3, 0, 0, 0, 3)]);
    // Exact leakage: S1 rep2 (test, gzip) is S1 rep1 (train) byte for byte.
    assert_eq!(a.exact.len(), 1);
    let names: Vec<&str> = a.exact[0].members.iter().map(|m| m.1.as_str()).collect();
    assert_eq!(names, ["S1_circle_slow_rep1", "S1_circle_slow_rep2"]);
    assert!(a.exact[0].effective);
    assert_eq!(row("S1_circle_slow_rep2").identical_in_other_roles, ["train:S1_circle_slow_rep1"]);
    assert!(a.has_exact_leak());
    // Near-leakage: S3 rep2 repeats rows 1..150 of S3 rep1 (the fixture script writes them so).
    assert_eq!(a.shared_runs.len(), 1);
    let run = &a.shared_runs[0];
    assert_eq!(
        (run.a.1.as_str(), run.a.2, run.b.1.as_str(), run.b.2, run.rows),
        ("S3_oval_medium_rep1", 1, "S3_oval_medium_rep2", 1, 150)
    );
    assert_eq!(row("S3_oval_medium_rep2").longest_shared_run, Some((150, "train:S3_oval_medium_rep1".to_string())));
    // The same trajectory and speed on both sides: circle/slow and oval/medium, not star/fast.
    let pair = a.pairs.iter().find(|p| p.role == "test" && p.other == "train").unwrap();
    assert_eq!((pair.identical, pair.identical_effective, pair.shared_run, pair.same_condition), (1, 1, 1, 2));
    assert_eq!(row("S2_star_fast_rep1").same_condition_in_other_roles, 0);
    // Composition: train {circle/slow, oval/medium, linear_ramp/unknown}, test {circle/slow,
    // oval/medium, star/fast}, one each: total variation 0.5 * (1/3 + 1/3) = 1/3.
    let tv = a.composition.pairwise.iter().find(|(x, y, _)| x == "train" && y == "test").unwrap().2;
    assert!((tv - 1.0 / 3.0).abs() < 1e-15, "{tv}");
    // A role with nothing kept has no composition to compare.
    assert!(a.composition.pairwise.iter().filter(|(x, y, _)| x == "val" || y == "val").all(|(_, _, d)| d.is_nan()));
}

#[test]
fn folds_are_roles_and_copies_inside_one_fold_do_not_leak() {
    let a = audit_fixture("folds.csv");
    assert!(!a.has_exact_leak(), "S1's copies share fold 0");
    assert_eq!(a.shared_runs.len(), 1, "S3's partial copy crosses folds 2 and 3");
    let f0 = &a.roles[0];
    assert_eq!((f0.effective, f0.effective_distinct), (2, 1));
    let a = audit_fixture("folds.json");
    assert!(a.has_exact_leak(), "S1's copies are in folds 0 and 1");
    assert!(a.shared_runs.is_empty(), "S3's copies share fold 2");
    // A role CSV with any role names; S5 is in the data but in no role.
    let a = audit_fixture("roles.csv");
    assert!(a.has_exact_leak());
    let unlisted: Vec<&str> = a.recordings.iter().filter(|r| r.role.is_empty()).map(|r| r.recording.as_str()).collect();
    assert_eq!(unlisted, ["S5_helix_fast_rep1", "S6_figure8_slow_rep1"]);
}

#[test]
fn a_shorter_minimum_run_finds_nothing_new_and_a_longer_one_drops_the_partial_copy() {
    let split = published::read(&fixture("nanobench_small.json")).unwrap();
    let run = |n| {
        let o = split_audit::AuditOptions { min_run_rows: n, ..Default::default() };
        split_audit::audit(&split, &DataSpec::upstream_task2(), "upstream", &fixture("data"), o).unwrap().shared_runs
    };
    assert_eq!(run(150).len(), 1);
    assert!(run(151).is_empty());
    assert_eq!(run(1)[0].rows, 150);
}

fn cli(args: &[&str]) -> (Option<i32>, String, String) {
    let out = crate::common::bin().current_dir(root()).args(args).output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn cli_writes_three_files_and_fails_on_leak_only_when_asked() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("audit");
    let o = out.to_str().unwrap();
    let base = [
        "audit",
        "split",
        "tests/fixtures/splits/nanobench_small.json",
        "--data",
        "tests/fixtures/splits/data",
        "--out",
        o,
    ];
    let (code, stdout, stderr) = cli(&base);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stdout.contains("exact leakage: 1 identity group"), "{stdout}");
    for f in ["split_audit.md", "split_audit.json", "split_recordings.csv"] {
        assert!(out.join(f).exists(), "{f}");
    }
    let md = std::fs::read_to_string(out.join("split_audit.md")).unwrap();
    snapshots!({
        insta::assert_snapshot!("split_audit_fixture_md", md);
        insta::assert_snapshot!(
            "split_audit_fixture_csv",
            std::fs::read_to_string(out.join("split_recordings.csv")).unwrap()
        );
    });
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("split_audit.json")).unwrap()).unwrap();
    assert_eq!(json["exact"].as_array().unwrap().len(), 1);

    let (code, _, stderr) = cli(&[&base[..], &["--fail-on", "leak"]].concat());
    assert_eq!(code, Some(3), "{stderr}");
    assert!(stderr.contains("exact leakage found"), "{stderr}");
    assert!(out.join("split_audit.md").exists(), "outputs are written before the failing exit");
    let folds = [
        "audit",
        "split",
        "tests/fixtures/splits/folds.csv",
        "--data",
        "tests/fixtures/splits/data",
        "--out",
        o,
        "--fail-on",
        "leak",
    ];
    let (code, _, stderr) = cli(&folds);
    assert_eq!(code, Some(0), "no identical copies across folds: {stderr}");
}

#[test]
fn a_design_supplies_its_own_rules() {
    // minimal.design declares no inclusion rule: S5, implausible under upstream's rules, is kept.
    let split = published::read(&fixture("nanobench_small.json")).unwrap();
    let file = crossaudit::design::load(&root().join("tests/designs/minimal.design")).unwrap();
    let a = split_audit::audit(&split, &file.design.data, "design", &fixture("data"), Default::default()).unwrap();
    let s5 = a.recordings.iter().find(|r| r.recording == "S5_helix_fast_rep1").unwrap();
    assert_eq!(s5.effect, Effect::Kept, "{}", s5.reason);
}

fn reference() -> serde_json::Value {
    let text = std::fs::read_to_string(root().join("scripts/reference/split_audit_reference.out")).unwrap();
    serde_json::from_str(&text).unwrap()
}

/// NanoBench's published task-2 split against scripts/reference/split_audit_reference.py
/// (Python standard library, written from the data README: its own percentile,
/// SHA-256 of the data rows, 100-line windows).
#[test]
#[ignore = "needs ../shared/nanobench"]
fn upstream_task2_split_matches_the_python_reference() {
    let _logs = crate::needs_shared_logs!();
    let dir = shared_logs();
    let path = root().join("../shared/nanobench/upstream_task2_split_metadata.json");
    let split = published::read(&path).unwrap();
    let a = split_audit::audit(&split, &DataSpec::upstream_task2(), "upstream", &dir, Default::default()).unwrap();
    let r = reference();
    for role in &a.roles {
        let want = &r["roles"][&role.role];
        assert_eq!(role.declared as u64, want["declared"].as_u64().unwrap(), "{}", role.role);
        assert_eq!(role.with_csv as u64, want["with_csv"].as_u64().unwrap(), "{}", role.role);
        assert_eq!(role.effective as u64, want["effective"].as_u64().unwrap(), "{}", role.role);
        let mut dropped: Vec<&str> = a
            .recordings
            .iter()
            .filter(|x| x.role == role.role && x.effect == Effect::Dropped)
            .map(|x| x.recording.as_str())
            .collect();
        dropped.sort();
        let want_dropped: Vec<&str> = want["dropped"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
        assert_eq!(dropped, want_dropped, "{}", role.role);
        assert_eq!(role.metadata_only, want["metadata_only"].as_array().unwrap().len(), "{}", role.role);
    }
    let mut pairs: Vec<Vec<(String, String)>> = a
        .exact
        .iter()
        .map(|l| {
            let mut m: Vec<(String, String)> = l.members.iter().map(|(r, n, _)| (r.clone(), n.clone())).collect();
            m.sort();
            m
        })
        .collect();
    pairs.sort();
    let mut want: Vec<Vec<(String, String)>> = r["identical_pairs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            p.as_array()
                .unwrap()
                .iter()
                .map(|m| (m[0].as_str().unwrap().to_string(), m[1].as_str().unwrap().to_string()))
                .collect()
        })
        .collect();
    want.sort();
    assert_eq!(pairs, want);
    assert_eq!(a.shared_runs.len(), r["shared_run_pairs"].as_array().unwrap().len());
    for (x, y, d) in &a.composition.pairwise {
        let (p, q) = if x < y { (x, y) } else { (y, x) };
        let want = r["tv_distance"][format!("{p}/{q}")].as_f64().unwrap();
        assert!((d - want).abs() < 1e-12, "{x}/{y}: {d} vs {want}");
    }
}

/// The committed audit under results/ is what the binary writes today.
#[test]
#[ignore = "needs ../shared/nanobench"]
fn committed_upstream_audit_is_current() {
    let _logs = crate::needs_shared_logs!();
    let _ = shared_logs();
    let tmp = tempfile::tempdir().unwrap();
    let o = tmp.path().to_str().unwrap();
    let (code, _, stderr) = cli(&[
        "audit",
        "split",
        "../shared/nanobench/upstream_task2_split_metadata.json",
        "--data",
        "../shared/nanobench/recordings",
        "--out",
        o,
    ]);
    assert_eq!(code, Some(0), "{stderr}");
    for f in ["split_audit.md", "split_audit.json", "split_recordings.csv", "split_windows.csv"] {
        let committed = std::fs::read_to_string(root().join("results/upstream_split_audit").join(f)).unwrap();
        let fresh = std::fs::read_to_string(Path::new(o).join(f)).unwrap();
        assert_eq!(
            committed, fresh,
            "{f} differs from a fresh run (regenerate with results/upstream_split_audit/COMMAND)"
        );
    }
}

fn pinned_design(edit: &dyn Fn(&str) -> String) -> Result<crossaudit::Design, crossaudit::design::DesignError> {
    let path = root().join("tests/designs/published_fixture.design");
    let text = edit(&std::fs::read_to_string(&path).unwrap());
    crossaudit::design::from_str_in("published_fixture.design", &text, &root().join("tests/designs"))
}

fn build_pinned(design: &crossaudit::Design) -> Result<crossaudit::split::Split, crossaudit::split::SplitError> {
    let (audit, recordings) = crossaudit::data::audit_and_load(&design.data, &fixture("data")).unwrap();
    crossaudit::split::build(design, &audit, &recordings)
}

#[test]
fn a_design_pins_the_published_roles_and_drops_leaked_fit_copies() {
    let file = crossaudit::design::load(&root().join("tests/designs/published_fixture.design")).unwrap();
    let pin = file.design.published.as_ref().unwrap();
    assert_eq!((pin.evaluation_roles.clone(), pin.fit.len()), (vec!["test".to_string()], 3));
    let plan = crossaudit::compile(&file.design);
    let tmp = tempfile::tempdir().unwrap();
    let p = crossaudit::split::prepare(&file, &plan, &fixture("data"), tmp.path()).unwrap();
    let names = |rs: &[usize]| rs.iter().map(|&r| p.split.recordings[r].name.clone()).collect::<Vec<_>>();
    assert_eq!(names(&p.split.evaluation), ["S1_circle_slow_rep2", "S3_oval_medium_rep2"]);
    assert_eq!(names(&p.split.validation_recordings), ["S2_star_fast_rep1"]);
    assert_eq!(p.split.fit_leaked, [("S1_circle_slow_rep1".to_string(), "S1_circle_slow_rep2".to_string())]);
    let disjoint = p.split.fit("disjoint").unwrap();
    let fit_names: std::collections::BTreeSet<String> =
        disjoint.iter().map(|w| p.split.recordings[w.recording].name.clone()).collect();
    assert_eq!(fit_names.into_iter().collect::<Vec<_>>(), ["S3_oval_medium_rep1", "S4_linear_ramp_rep1"]);
    assert!(p.invariants.all_pass);
    let dropped = std::fs::read_to_string(tmp.path().join("manifests/fit_leaked_dropped.csv")).unwrap();
    assert_eq!(dropped, "recording,identical_to\nS1_circle_slow_rep1,S1_circle_slow_rep2\n");
}

#[test]
fn leaked_refuse_is_an_error_naming_the_copy() {
    let d = pinned_design(&|t| t.replace("leaked drop", "leaked refuse")).unwrap();
    let e = build_pinned(&d).unwrap_err().to_string();
    assert!(e.contains("S1_circle_slow_rep1 (fit) is identical to S1_circle_slow_rep2"), "{e}");
    // Refuse is the default.
    let d = pinned_design(&|t| t.replace("; leaked drop", "")).unwrap();
    assert!(build_pinned(&d).is_err());
}

#[test]
fn a_name_the_data_do_not_know_is_located_in_the_split_file() {
    // nanobench_small.json lists Z9_unknown_rep1 in train (line 8) and an implausible val file.
    let d = pinned_design(&|t| {
        t.replace("pin.json", "nanobench_small.json")
            .replace("duplicates keep", "duplicates keep\n  missing csv allow")
            .replace("validation val; fit train", "validation train; fit val")
    })
    .unwrap();
    let e = build_pinned(&d).unwrap_err().to_string();
    assert!(e.contains("nanobench_small.json:8:5: validation recording \"Z9_unknown_rep1\""), "{e}");
    // As a fit recording (a split file written here, named by its absolute path).
    let tmp = tempfile::tempdir().unwrap();
    let split = tmp.path().join("split.json");
    std::fs::write(
        &split,
        "{\"train_files\": [\"S3_oval_medium_rep1\",\n  \"Z9_unknown_rep1\"],\n \"val_files\": [\"S2_star_fast_rep1\"],\n \"test_files\": [\"S1_circle_slow_rep2\", \"S3_oval_medium_rep2\"]}\n",
    )
    .unwrap();
    let d = pinned_design(&|t| t.replace("../fixtures/splits/pin.json", split.to_str().unwrap())).unwrap();
    let e = build_pinned(&d).unwrap_err().to_string();
    assert!(
        e.contains("split.json:2:3: fit recording \"Z9_unknown_rep1\" has neither a CSV nor a metadata file"),
        "{e}"
    );
}

#[test]
fn published_split_design_errors_are_located() {
    let err = |edit: &dyn Fn(&str) -> String| pinned_design(edit).unwrap_err().to_string();
    let e = err(&|t| t.replace("fit train;", ""));
    assert!(e.contains("missing: fit") && e.contains("role `train`"), "{e}");
    let e = err(&|t| t.replace("fit train", "fit training"));
    assert!(e.contains("has no role `training`") && e.contains("`train`, `val`, `test`"), "{e}");
    let e = err(&|t| t.replace("validation val", "validation test"));
    assert!(e.contains("role `test` is already mapped to evaluation"), "{e}");
    let e = err(&|t| t.replace("split_seed 1;", "evaluation 4 split_seed 1;"));
    assert!(e.contains("evaluation recordings given twice"), "{e}");
    let e = err(&|t| t.replace("from split", "from 2 recordings"));
    assert!(e.contains("validation recordings given twice"), "{e}");
    let e = err(&|t| t.lines().filter(|l| !l.starts_with("split published")).collect::<Vec<_>>().join("\n"));
    assert!(e.contains("`from split` needs a `split published` statement"), "{e}");
    let e = err(&|t| t.replace("pin.json", "nowhere.json"));
    assert!(e.contains("cannot read split file") && e.contains("nowhere.json"), "{e}");
    let e = err(&|t| t.replace("{ evaluation test;", "{ ignore val; evaluation test;"));
    assert!(e.contains("role mapped twice") || e.contains("already mapped"), "{e}");
}

/// The shipped design pinning NanoBench's own split builds on the shared logs.
#[test]
#[ignore = "needs ../shared/nanobench"]
fn the_upstream_split_design_builds_on_the_shared_logs() {
    let _logs = crate::needs_shared_logs!();
    let dir = shared_logs();
    let file = crossaudit::design::load(&root().join("designs/nanobench_upstream_split.design")).unwrap();
    let (audit, recordings) = crossaudit::data::audit_and_load(&file.design.data, &dir).unwrap();
    let s = crossaudit::split::build(&file.design, &audit, &recordings).unwrap();
    // results/upstream_split_audit: 12 test and 13 val recordings kept; 4 train copies of kept held-out ones.
    assert_eq!((s.evaluation.len(), s.validation_recordings.len(), s.fit_leaked.len()), (12, 13, 4));
    assert_eq!(s.evaluation_absent.len() + s.validation_absent.len() + s.fit_absent.len(), 4 + 3 + 12);
}

/// Issue 57, item 6: a lab's split of train and test alone pins, with the
/// validation recordings drawn from the train role by the design's seed
/// (never from test), and taken out of the fit pool.
#[test]
fn a_published_train_test_split_draws_validation_from_its_fit_roles() {
    let tmp = tempfile::tempdir().unwrap();
    let split = tmp.path().join("train_test.csv");
    std::fs::write(
        &split,
        "recording,role\nS1_circle_slow_rep1,train\nS2_star_fast_rep1,train\nS3_oval_medium_rep1,train\n\
         S4_linear_ramp_rep1,train\nS1_circle_slow_rep2,test\nS3_oval_medium_rep2,test\n",
    )
    .unwrap();
    let with = |validation: &str| {
        pinned_design(&|t| {
            t.replace("\"../fixtures/splits/pin.json\"", &format!("{:?}", split.display().to_string()))
                .replace("evaluation test; validation val; fit train", "evaluation test; fit train")
                .replace("validation 100 windows from split seed 2", validation)
        })
    };
    let mut drawn = std::collections::BTreeSet::new();
    for seed in [2, 5, 11, 19] {
        let d =
            with(&format!("validation 100 windows from 1 recordings seed {seed}")).unwrap_or_else(|e| panic!("{e}"));
        assert!(d.published.as_ref().unwrap().validation_roles.is_empty());
        let s = build_pinned(&d).unwrap_or_else(|e| panic!("{e}"));
        let names = |rs: &[usize]| rs.iter().map(|&r| s.recordings[r].name.clone()).collect::<Vec<_>>();
        assert_eq!(names(&s.evaluation), ["S1_circle_slow_rep2", "S3_oval_medium_rep2"]);
        let v = names(&s.validation_recordings);
        assert_eq!(v.len(), 1);
        assert!(["S2_star_fast_rep1", "S3_oval_medium_rep1", "S4_linear_ramp_rep1", "S1_circle_slow_rep1"]
            .contains(&v[0].as_str()));
        let fit: std::collections::BTreeSet<String> =
            s.fit("disjoint").unwrap().iter().map(|w| s.recordings[w.recording].name.clone()).collect();
        assert!(!fit.contains(&v[0]), "seed {seed}: the validation recording {} is also fitted on", v[0]);
        // The train role less validation, less the fit copy of a test recording.
        let mut expected: std::collections::BTreeSet<String> =
            ["S2_star_fast_rep1", "S3_oval_medium_rep1", "S4_linear_ramp_rep1"].map(String::from).into();
        expected.remove(&v[0]);
        assert_eq!(fit, expected, "seed {seed}");
        // The same seed draws the same validation recording.
        assert_eq!(names(&build_pinned(&d).unwrap().validation_recordings), v);
        drawn.insert(v[0].clone());
    }
    assert!(drawn.len() > 1, "the validation seed chooses among the train recordings: {drawn:?}");
    // `from split` needs a validation role; fit and evaluation roles stay required.
    let e = with("validation 100 windows from split seed 2").unwrap_err().to_string();
    assert!(e.contains("no validation role") && e.contains("from K recordings"), "{e}");
    let e = pinned_design(&|t| t.replace("validation val; fit train", "validation val; ignore train")).unwrap_err();
    assert!(e.to_string().contains("missing: fit"), "{e}");
}

/// A split published as folders (`train/`, `test/`) is read by `audit
/// split` given the folder; where none of the recordings it lists has a
/// log where the audit looks (its logs lie in subfolders, and no design
/// says `folders nested`), the audit could classify nothing: it exits
/// non-zero with the hint, not 0 with every recording "unknown". With a
/// design that reads the subfolders it classifies every one.
#[test]
fn a_folder_split_is_read_and_an_audit_that_found_nothing_fails_with_the_hint() {
    let tmp = tempfile::tempdir().unwrap();
    let lab = tmp.path().join("lab");
    let mut n = 0;
    for e in std::fs::read_dir(crate::common::root().join("tests/fixtures/nanobench")).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if !name.ends_with(".csv") {
            continue;
        }
        let role = if n % 3 == 0 { "test" } else { "train" };
        std::fs::create_dir_all(lab.join(role)).unwrap();
        std::fs::copy(&p, lab.join(role).join(&name)).unwrap();
        n += 1;
    }
    assert!(n >= 4);
    let (l, out) = (lab.to_str().unwrap(), tmp.path().join("out"));
    let (code, _, err) = cli(&["audit", "split", l, "--data", l, "--out", out.to_str().unwrap()]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains(&format!("none of the {n} recording(s) the split lists has a log here")), "{err}");
    assert!(err.contains("its subfolders hold"), "{err}");
    // A design whose data block reads the subfolders classifies them all.
    let design = tmp.path().join("nested.design");
    let text = std::fs::read_to_string(crate::common::root().join("tests/designs/logs_generic.design")).unwrap();
    std::fs::write(&design, text.replace("  rate 100 Hz\n", "  rate 100 Hz\n  folders nested\n")).unwrap();
    let out2 = tmp.path().join("out2");
    let (code, stdout, err) =
        cli(&["audit", "split", l, "--data", l, "--design", design.to_str().unwrap(), "--out", out2.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{err}");
    let unknown = stdout.matches(" unknown").count();
    assert!(unknown >= 2 && stdout.matches(" 0 unknown").count() == unknown, "{stdout}");
}

/// A role folder that is a symbolic link is named as one (not followed,
/// since a link cycle would never end), not refused as an unknown role.
#[test]
fn a_linked_role_folder_is_named_as_a_link() {
    let tmp = tempfile::tempdir().unwrap();
    let (lab, real) = (tmp.path().join("lab"), tmp.path().join("elsewhere"));
    std::fs::create_dir_all(lab.join("train")).unwrap();
    std::fs::create_dir_all(&real).unwrap();
    let fixtures = crate::common::root().join("tests/fixtures/nanobench");
    std::fs::copy(fixtures.join("F1_circle_slow_rep1.csv"), lab.join("train/F1_circle_slow_rep1.csv")).unwrap();
    std::fs::copy(fixtures.join("F4_linear_ramp_rep1.csv"), real.join("F4_linear_ramp_rep1.csv")).unwrap();
    std::os::unix::fs::symlink(&real, lab.join("test")).unwrap();
    let e = published::from_folders(&lab).unwrap_err().to_string();
    assert!(e.contains("test is a symbolic link to a folder, which crossaudit does not follow"), "{e}");
}

/// Issue 77, class 8: a fit file of the published split that the design
/// excludes by name (`exclude recordings`, a crashed flight) is dropped from
/// the fit roles as the design says, without `missing csv allow` (it has a
/// log; the design left it out), and named: the split's absent fit
/// recordings (manifests/absent_recordings.csv) list it.
#[test]
fn a_published_fit_file_excluded_by_name_is_dropped_and_named() {
    let d = pinned_design(&|t| {
        t.replace("  duplicates keep\n", "  duplicates keep\n  exclude recordings \"S4_linear_ramp_rep1\"\n")
            .replace("fit 400 windows", "fit 200 windows")
    })
    .unwrap();
    let split = build_pinned(&d).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(split.fit_absent, ["S4_linear_ramp_rep1"]);
    let fit: std::collections::BTreeSet<String> =
        split.fit("disjoint").unwrap().iter().map(|w| split.recordings[w.recording].name.clone()).collect();
    assert_eq!(fit.into_iter().collect::<Vec<_>>(), ["S3_oval_medium_rep1"]);
}
