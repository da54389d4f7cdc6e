//! Runs a reviewer can trust: what a resume reuses is verified, not assumed;
//! interrupted writes are never mistaken for finished ones; and inputs that
//! would end in a wrong answer are refused with a message saying what
//! differs. Every test drives the real binary on a small simulated study
//! (tests/designs/sim_small.design), so none needs data beside the
//! repository.

use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use std::time::{Duration, Instant};

use crate::common::crossaudit;
use crate::common::{assert_ok, assert_refused, root, stderr};

const DESIGN: &str = "tests/designs/sim_small.design";

/// `crossaudit run` of the design into `out` (two workers unless `extra` says).
fn run(out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["run", DESIGN, "--out", out.to_str().unwrap()];
    if !extra.contains(&"--workers") {
        args.extend(["--workers", "2"]);
    }
    args.extend_from_slice(extra);
    crossaudit(&args)
}

/// Every file under `dir` (relative path, bytes), leaving out staging files
/// and the wall-clock fields that cannot repeat (curves' `seconds`).
fn tree(dir: &Path) -> Vec<(String, Vec<u8>)> {
    fn walk(base: &Path, dir: &Path, out: &mut Vec<(String, Vec<u8>)>) {
        for e in std::fs::read_dir(dir).unwrap().filter_map(|e| e.ok()) {
            let p = e.path();
            if p.is_dir() {
                walk(base, &p, out);
            } else if p.extension().is_none_or(|x| x != "tmp") {
                let name = p.strip_prefix(base).unwrap().display().to_string();
                if !name.starts_with("curves/") {
                    out.push((name, std::fs::read(&p).unwrap()));
                }
            }
        }
    }
    let mut v = Vec::new();
    walk(dir, dir, &mut v);
    v.sort();
    v
}

/// Files that must be byte-identical between an interrupted-and-resumed run
/// and an uninterrupted one: everything but job records (which hash the
/// curves, whose `seconds` differ) and curves.
fn results(dir: &Path) -> Vec<(String, Vec<u8>)> {
    tree(dir).into_iter().filter(|(n, _)| !n.starts_with("jobs/") && n != "run.json").collect()
}

/// One uninterrupted run of the design, shared by the tests of this file
/// (under target/, replaced on every test run).
fn reference() -> &'static Path {
    static REFERENCE: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    REFERENCE.get_or_init(|| {
        let out = root().join("target/test-trust/reference");
        let _ = std::fs::remove_dir_all(&out);
        assert_ok(&run(&out, &[]));
        out
    })
}

/// A finished copy of the reference run to break on purpose.
fn copy_of_reference(into: &Path) -> PathBuf {
    let out = into.join("copy");
    for (name, bytes) in tree(reference()) {
        let p = out.join(&name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, bytes).unwrap();
    }
    let curves = reference().join("curves");
    std::fs::create_dir_all(out.join("curves")).unwrap();
    for e in std::fs::read_dir(curves).unwrap().filter_map(|e| e.ok()) {
        std::fs::copy(e.path(), out.join("curves").join(e.file_name())).unwrap();
    }
    out
}

#[test]
fn a_truncated_simulated_log_is_refused_not_reused() {
    // Issue 12, case 1: truncate one simulated CSV of a finished simulation.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("q");
    let sim = out.join("simulated_data");
    assert_ok(&crossaudit(&["simulate", DESIGN, "--out", sim.to_str().unwrap()]));
    let victim = sim.join("S01_circle_slow_rep1.csv");
    let bytes = std::fs::read(&victim).unwrap();
    std::fs::write(&victim, &bytes[..bytes.len() / 2]).unwrap();
    let o = run(&out, &[]);
    assert_refused(&o, "is not the file the simulator wrote");
    assert!(stderr(&o).contains("S01_circle_slow_rep1.csv"), "{}", stderr(&o));
}

#[test]
fn an_interrupted_simulation_is_generated_again() {
    // No record: the generation never finished, so every file is rewritten
    // and the run matches an uninterrupted one.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("q");
    let sim = out.join("simulated_data");
    assert_ok(&crossaudit(&["simulate", DESIGN, "--out", sim.to_str().unwrap()]));
    std::fs::remove_file(sim.join("simulation.json")).unwrap();
    let victim = sim.join("S01_circle_slow_rep1.csv");
    let bytes = std::fs::read(&victim).unwrap();
    std::fs::write(&victim, &bytes[..1000]).unwrap();
    assert_ok(&run(&out, &[]));
    assert_eq!(results(&out), results(reference()));
}

#[test]
fn simulated_data_of_another_spec_is_refused() {
    // Issue 12, case 1: the design edited after its data were simulated.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("q");
    let sim = out.join("simulated_data");
    assert_ok(&crossaudit(&["simulate", DESIGN, "--out", sim.to_str().unwrap()]));
    let edited = dir.path().join("edited.design");
    let text = std::fs::read_to_string(root().join(DESIGN)).unwrap();
    std::fs::write(&edited, text.replace("recordings 16 seed 5", "recordings 16 seed 6")).unwrap();
    let o = crossaudit(&["run", edited.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_refused(&o, "holds recordings simulated from another spec");
    assert!(stderr(&o).contains("seed 5") && stderr(&o).contains("seed 6"), "{}", stderr(&o));
}

#[test]
fn data_override_on_a_simulated_design_is_refused() {
    // Issue 12, case 3.
    let dir = tempfile::tempdir().unwrap();
    let o = run(&dir.path().join("q"), &["--data", dir.path().to_str().unwrap()]);
    assert_refused(&o, "the design's data are `simulated`");
}

#[test]
fn a_missing_or_unreadable_run_record_is_refused() {
    // Issue 12, case 6: finished cells beside no run.json are never reused.
    let dir = tempfile::tempdir().unwrap();
    let out = copy_of_reference(dir.path());
    std::fs::remove_file(out.join("run.json")).unwrap();
    assert_refused(&run(&out, &[]), "it is missing, but jobs is there");
    std::fs::write(out.join("run.json"), "{ not json").unwrap();
    assert_refused(&run(&out, &[]), "cannot be read as the record of a run");
}

#[test]
fn a_folder_whose_report_is_no_runs_is_refused_not_written_over() -> Result<(), Box<dyn std::error::Error>> {
    // Before: a run into a folder holding someone's own report/report.md
    // wrote its report over it (only a run's own outputs beside no
    // run.json were refused). A run writes run.json before its report.
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("mine");
    std::fs::create_dir_all(out.join("report"))?;
    std::fs::write(out.join("report/report.md"), "my own notes\n")?;
    assert_refused(&run(&out, &[]), "holds files, which a run would write its report over");
    assert_eq!(std::fs::read_to_string(out.join("report/report.md"))?, "my own notes\n");
    assert!(!out.join("run.json").exists());
    // Nothing else is written there either: the simulated design's data
    // was generated into the folder before the refusal.
    let left: Vec<_> = std::fs::read_dir(&out)?.map(|e| e.map(|e| e.file_name())).collect::<Result<_, _>>()?;
    assert_eq!(left, ["report"], "{left:?}");
    // Nor by `split`, which prepares a run folder as `run` does.
    assert_refused(
        &crossaudit(&["split", DESIGN, "--out", out.to_str().ok_or("path")?]),
        "would write its report over",
    );
    assert_eq!(std::fs::read_dir(&out)?.count(), 1);
    // An empty report/ is no one's: the run goes ahead.
    std::fs::remove_file(out.join("report/report.md"))?;
    assert_ok(&run(&out, &[]));
    Ok(())
}

#[test]
fn a_changed_finished_cell_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = copy_of_reference(dir.path());
    let cells = out.join("cells/world__disjoint__1.csv");
    let text = std::fs::read_to_string(&cells).unwrap();
    std::fs::write(&cells, text.replacen("0.", "1.", 1)).unwrap();
    let o = run(&out, &[]);
    assert_refused(&o, "is not the file its job wrote");
    assert!(stderr(&o).contains("world__disjoint__1.csv"), "{}", stderr(&o));
}

#[test]
fn a_job_without_its_record_is_trained_again() {
    let dir = tempfile::tempdir().unwrap();
    let out = copy_of_reference(dir.path());
    std::fs::remove_file(out.join("jobs/relative__contaminated__2.json")).unwrap();
    std::fs::write(out.join("cells/relative__contaminated__2.csv"), "half a fi").unwrap();
    let o = run(&out, &[]);
    assert_ok(&o);
    assert!(stderr(&o).contains("1 cells trained"), "{}", stderr(&o));
    assert_eq!(results(&out), results(reference()));
}

#[test]
fn a_fresh_run_reproduces_the_reference_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("again");
    assert_ok(&run(&out, &["--workers", "1"]));
    assert_eq!(results(&out), results(reference()));
}

fn count_in(dir: &Path) -> usize {
    std::fs::read_dir(dir).map(|d| d.count()).unwrap_or(0)
}

/// A point in a run to kill it at: (phase, condition on the output directory).
type KillPoint = (&'static str, Box<dyn Fn(&Path) -> bool>);

/// Kill points across every phase of a run: simulating the data, the audit
/// and split, training (after k job records), and the report.
fn kill_points() -> Vec<KillPoint> {
    let mut points: Vec<KillPoint> = Vec::new();
    for n in [1, 5, 9, 14, 19, 24] {
        points.push(("simulation", Box::new(move |o: &Path| count_in(&o.join("simulated_data")) >= n)));
    }
    for marker in [
        "simulated_data/simulation.json",
        "audit",
        "audit/recordings.csv",
        "manifests",
        "manifests/manifests.json",
        "run.json",
    ] {
        points.push(("split", Box::new(move |o: &Path| o.join(marker).exists())));
    }
    for k in [0, 1, 2, 4, 6, 7] {
        points
            .push(("training", Box::new(move |o: &Path| o.join("models").exists() && count_in(&o.join("jobs")) >= k)));
    }
    for marker in [
        "audit/invariants_trained.json",
        "cells.csv",
        "report",
        "report/optimism.svg",
        "report/report.md",
        "report/results.json",
    ] {
        points.push(("report", Box::new(move |o: &Path| o.join(marker).exists())));
    }
    points
}

/// SIGKILLs `run` at 24 points spread over every phase (simulation, split,
/// training, report), resumes each, and checks that the resumed outputs
/// are byte-identical to an uninterrupted run's.
#[test]
fn runs_killed_at_every_phase_resume_to_identical_results() {
    let _ = reference();
    let dir = tempfile::tempdir().unwrap();
    let mut killed: std::collections::BTreeMap<&str, usize> = Default::default();
    for (k, (phase, reached)) in kill_points().into_iter().enumerate() {
        let out = dir.path().join(format!("kill{k}"));
        let mut child = crate::common::bin()
            .current_dir(root())
            .args(["run", DESIGN, "--out", out.to_str().unwrap(), "--workers", "2"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let t0 = Instant::now();
        let mut finished = false;
        while !reached(&out) {
            if child.try_wait().unwrap().is_some() {
                finished = true;
                break;
            }
            assert!(t0.elapsed() < Duration::from_secs(120), "kill {k}: the run hangs");
            std::thread::sleep(Duration::from_micros(200));
        }
        child.kill().ok(); // SIGKILL on Unix
        child.wait().unwrap();
        if !finished {
            *killed.entry(phase).or_default() += 1;
        }
        let again = run(&out, &[]);
        assert_ok(&again);
        assert_eq!(results(&out), results(reference()), "kill {k} ({phase})");
    }
    let total: usize = killed.values().sum();
    assert!(total >= 20, "only {total} of 24 runs were killed before they finished: {killed:?}");
    for phase in ["simulation", "split", "training", "report"] {
        assert!(killed.get(phase).copied().unwrap_or(0) >= 3, "too few kills in the {phase} phase: {killed:?}");
    }
}

/// The reference run's cells.csv with `edit` applied to every row of one
/// arm, analysed under the design.
fn analyze_edited(dir: &Path, edit: impl Fn(&mut Vec<String>)) -> Output {
    let text = std::fs::read_to_string(reference().join("cells.csv")).unwrap();
    let mut lines = text.lines();
    let mut out = vec![lines.next().unwrap().to_string()];
    for line in lines {
        let mut f: Vec<String> = line.split(',').map(String::from).collect();
        if f[1] == "contaminated" {
            edit(&mut f);
        }
        out.push(f.join(","));
    }
    let cells = dir.join("cells.csv");
    std::fs::write(&cells, out.join("\n") + "\n").unwrap();
    crossaudit(&["analyze", DESIGN, "--cells", cells.to_str().unwrap(), "--out", dir.join("report").to_str().unwrap()])
}

#[test]
fn impossible_per_cell_values_are_refused() {
    // Issue 12, case 2. Columns: 9 fa_position_rmse_m, 10 conditional,
    // 11 divergence_rate, 13 attitude_rmse_deg.
    let dir = tempfile::tempdir().unwrap();
    let scale = |k: usize, by: f64| {
        move |f: &mut Vec<String>| {
            if let Ok(v) = f[k].parse::<f64>() {
                f[k] = (v * by).to_string();
            }
        }
    };
    // One arm in millimetres: both RMSEs scaled, so only the cap catches it.
    let mm = |f: &mut Vec<String>| {
        scale(9, 1000.0)(f);
        scale(10, 1000.0)(f);
    };
    assert_refused(&analyze_edited(dir.path(), mm), "above the design's divergence cap of 2 m");
    // The failure-aware RMSE alone changed: inconsistent with its parts.
    assert_refused(&analyze_edited(dir.path(), scale(9, 1.5)), "it must be");
    assert_refused(&analyze_edited(dir.path(), |f| f[9] = "1e308".into()), "above the design's divergence cap");
    assert_refused(&analyze_edited(dir.path(), |f| f[13] = "200".into()), "at most 180 degrees");
    assert_refused(&analyze_edited(dir.path(), |f| f[9] = "-0.1".into()), "is negative");
    assert_refused(&analyze_edited(dir.path(), |f| f[11] = "1.5".into()), "disagrees with n_divergent / n_starts");
    assert_refused(&analyze_edited(dir.path(), |f| f[8] = "99".into()), "exceeds n_starts");
    // The untouched file passes.
    assert_ok(&analyze_edited(dir.path(), |_| {}));
}

#[test]
fn sizes_that_cannot_finish_are_refused_up_front() {
    // Issue 12, case 5.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let o = out.to_str().unwrap();
    assert_refused(&crossaudit(&["run", DESIGN, "--out", o, "--workers", "0"]), "--workers must be at least 1");
    assert_refused(
        &crossaudit(&["coverage", "specs/coverage_paper.json", "--reps", "0", "--out", o]),
        "`reps` must be at least 2",
    );
    let huge = dir.path().join("huge.json");
    let spec = std::fs::read_to_string(root().join("specs/coverage_paper.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&spec).unwrap();
    v["rows"] = serde_json::json!([1_000_000_000u64]);
    std::fs::write(&huge, v.to_string()).unwrap();
    assert_refused(&crossaudit(&["coverage", huge.to_str().unwrap(), "--out", o]), "may be at most");
    let t = Instant::now();
    let cells = root().join("examples/cells/nanobench_synthetic.csv");
    let plan = crossaudit(&[
        "plan",
        "designs/nanobench_confirmatory.design",
        "--cells",
        cells.to_str().unwrap(),
        "--seeds",
        "1000000000",
        "--out",
        o,
    ]);
    assert_refused(&plan, "at most 100000");
    assert!(t.elapsed() < Duration::from_secs(30));
    let big = dir.path().join("big.design");
    let text = std::fs::read_to_string(root().join(DESIGN)).unwrap();
    std::fs::write(&big, text.replace("recordings 16 seed 5", "recordings 1000000000 seed 5")).unwrap();
    assert_refused(&crossaudit(&["check", big.to_str().unwrap()]), "at most 2000 recordings");
    std::fs::write(
        &big,
        text.replace("recordings 16 seed 5", "recordings 1500 seed 5").replace("duration 15 s", "duration 600 s"),
    )
    .unwrap();
    assert_refused(&crossaudit(&["check", big.to_str().unwrap()]), "simulated data too large");
}

#[test]
fn a_byte_order_mark_is_read_past() {
    // Issue 12, case 4.
    let dir = tempfile::tempdir().unwrap();
    let design = dir.path().join("bom.design");
    let mut bytes = vec![0xef, 0xbb, 0xbf];
    bytes.extend(std::fs::read(root().join(DESIGN)).unwrap());
    std::fs::write(&design, bytes).unwrap();
    assert_ok(&crossaudit(&["check", design.to_str().unwrap()]));
}

#[test]
fn two_files_of_one_recording_are_refused() {
    // Issue 12, case 4: X.csv beside X.csv.gz.
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("logs");
    assert_ok(&crossaudit(&["simulate", DESIGN, "--out", data.to_str().unwrap()]));
    let csv = data.join("S01_circle_slow_rep1.csv");
    let gz = std::fs::File::create(data.join("S01_circle_slow_rep1.csv.gz")).unwrap();
    let mut enc = flate2::write::GzEncoder::new(gz, flate2::Compression::fast());
    std::io::Write::write_all(&mut enc, &std::fs::read(&csv).unwrap()).unwrap();
    enc.finish().unwrap();
    let design = dir.path().join("real.design");
    let text = std::fs::read_to_string(root().join(DESIGN)).unwrap();
    let text = text.replace(
        "data simulated {\n  recordings 16 seed 5 strength 1.0 duration 15 s\n",
        &format!("data nanobench {{\n  path \"{}\"\n", data.display()),
    );
    std::fs::write(&design, text).unwrap();
    let o = crossaudit(&["data", "audit", design.to_str().unwrap(), "--out", dir.path().join("a").to_str().unwrap()]);
    assert_refused(&o, "would both load as recording S01_circle_slow_rep1");
}

/// A change made to a job record on purpose.
type RecordEdit = Box<dyn Fn(&mut serde_json::Value)>;

/// Edits one job record of a finished copy of the reference run.
fn edit_record(out: &Path, stem: &str, edit: impl Fn(&mut serde_json::Value)) {
    let path = out.join("jobs").join(format!("{stem}.json"));
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    edit(&mut v);
    std::fs::write(&path, serde_json::to_string_pretty(&v).unwrap()).unwrap();
}

#[test]
fn each_trained_invariant_catches_a_broken_job_record() {
    // Issue 12, case 7: invariants 1, 3, 6 and 7 read what each job
    // recorded; a record broken on purpose is caught on the next run.
    const OTHER: &str = "0000000000000000000000000000000000000000000000000000000000000000";
    let cases: Vec<(&str, RecordEdit)> = vec![
        ("(1) evaluation recordings and starts", Box::new(|v| v["manifests"]["evaluation_sha256"] = OTHER.into())),
        ("(1) evaluation recordings and starts", Box::new(|v| v["manifests"]["starts_sha256"] = OTHER.into())),
        ("(3) validation windows", Box::new(|v| v["manifests"]["validation_sha256"] = OTHER.into())),
        ("(6) standardizers", Box::new(|v| v["manifests"]["fit_sha256"] = OTHER.into())),
        ("(6) standardizers", Box::new(|v| v["standardizers"]["fitted_on"] = OTHER.into())),
        (
            "(6) standardizers",
            Box::new(|v| {
                let m = v["standardizers"]["input"]["mean"][0].as_f64().unwrap();
                v["standardizers"]["input"]["mean"][0] = (m + 1e-9).into();
            }),
        ),
    ];
    for (k, (needle, edit)) in cases.iter().enumerate() {
        let dir = tempfile::tempdir().unwrap();
        let out = copy_of_reference(dir.path());
        edit_record(&out, "world__contaminated__2", edit);
        let o = run(&out, &[]);
        assert_refused(&o, needle);
        assert!(stderr(&o).contains("world/contaminated/2"), "case {k}: {}", stderr(&o));
    }
    // Invariant 7: a record that vanished after the grid. (A missing record
    // before the grid makes the job train again, so this is checked on the
    // library call that runs after the grid.)
    let dir = tempfile::tempdir().unwrap();
    let out = copy_of_reference(dir.path());
    let file = crossaudit::design::load(&root().join(DESIGN)).unwrap();
    let plan = crossaudit::compile(&file.design);
    let prepared = crossaudit::split::prepare(&file, &plan, &out.join("simulated_data"), &out).unwrap();
    assert!(crossaudit::run::check_trained_invariants(&plan, &prepared, &out).is_ok());
    std::fs::remove_file(out.join("jobs/relative__disjoint__1.json")).unwrap();
    let e = crossaudit::run::check_trained_invariants(&plan, &prepared, &out).unwrap_err().to_string();
    assert!(e.contains("(7) all seeds present") && e.contains("relative__disjoint__1"), "{e}");
}

/// Normalizes the crossaudit build (version and commit), which changes
/// with every commit, so committed reports compare with fresh ones.
fn without_build(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes)
        .lines()
        .map(|l| if l.contains("(commit ") { "<build>" } else { l })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn the_readme_main_command_reproduces_the_committed_quickstart() {
    // Issue 12, case 9: the README's main command writes to out/, and a
    // fresh run reproduces the committed reference output byte for byte
    // (the build line aside).
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    assert!(readme.contains("run designs/quickstart.design --out out/quickstart"));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("quickstart");
    assert_ok(&crossaudit(&["run", "designs/quickstart.design", "--out", out.to_str().unwrap()]));
    let committed = root().join("results/quickstart");
    let mut compared = 0;
    for (name, bytes) in tree(&committed) {
        if name == "COMMAND" || name.ends_with("time.txt") || name.ends_with("stdout.txt") {
            continue;
        }
        let fresh = std::fs::read(out.join(&name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        if name == "run.json" {
            let fields = crate::common::run_json_fields;
            assert_eq!(fields(&fresh), fields(&bytes), "run.json differs from the committed one");
            compared += 1;
            continue;
        }
        let (mut a, mut b) = (without_build(&fresh), without_build(&bytes));
        if name.starts_with("curves/") {
            // Every column of a training curve but the last, its wall-clock seconds.
            assert!(b.starts_with("epoch,lr,train_loss,val_loss,seconds\n"), "{name}: {b}");
            let strip =
                |t: &str| t.lines().map(|l| l.rsplit_once(',').map_or(l, |p| p.0)).collect::<Vec<_>>().join("\n");
            (a, b) = (strip(&a), strip(&b));
        }
        if let Some((k, (x, y))) = a.lines().zip(b.lines()).enumerate().find(|(_, (x, y))| x != y) {
            panic!("{name} differs from the committed one at line {}:\n  fresh:     {x}\n  committed: {y}", k + 1);
        }
        assert_eq!(a.lines().count(), b.lines().count(), "{name}: line counts differ");
        compared += 1;
    }
    assert!(compared > 30, "{compared} files compared");
    let md = std::fs::read_to_string(out.join("report/report.md")).unwrap();
    assert!(md.contains("Data: simulated recordings (recordings 40, seed 7"), "the report says which data");
}

#[test]
fn reports_say_what_decides_and_keep_infinite_and_undefined_df_apart() {
    // Issue 12, case 8.
    let dir = tempfile::tempdir().unwrap();
    let cells = reference().join("cells.csv");
    let report = dir.path().join("r");
    let o = crossaudit(&[
        "analyze",
        DESIGN,
        "--cells",
        cells.to_str().unwrap(),
        "--out",
        report.to_str().unwrap(),
        "--compare-intervals",
    ]);
    assert_ok(&o);
    let json = std::fs::read_to_string(report.join("results.json")).unwrap();
    assert!(json.contains("\"df\": \"infinite\""), "the normal interval's df");
    assert!(json.contains("\"df\": \"undefined\""), "the bootstrap interval's df");
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    assert!(md.contains("The decision uses the 95% crossed-estimator interval"));
    assert!(md.contains("| descriptive |"), "secondary endpoints are labelled descriptive");
    // A locked design changed afterwards: the console line says EXPLORATORY.
    let design = dir.path().join("locked.design");
    std::fs::copy(root().join(DESIGN), &design).unwrap();
    assert_ok(&crossaudit(&["lock", design.to_str().unwrap()]));
    std::fs::write(&design, std::fs::read_to_string(&design).unwrap() + "# amended\n").unwrap();
    let o = crossaudit(&[
        "analyze",
        design.to_str().unwrap(),
        "--cells",
        cells.to_str().unwrap(),
        "--out",
        report.to_str().unwrap(),
    ]);
    assert_ok(&o);
    assert!(
        String::from_utf8_lossy(&o.stdout).starts_with("EXPLORATORY decision:"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
}

#[test]
fn a_relative_data_path_resolves_from_the_design_files_directory() {
    // Issue 12, case 4: run from the repository root, a design elsewhere
    // with `path "logs"` reads the logs beside it.
    let dir = tempfile::tempdir().unwrap();
    assert_ok(&crossaudit(&["simulate", DESIGN, "--out", dir.path().join("logs").to_str().unwrap()]));
    let text = std::fs::read_to_string(root().join(DESIGN)).unwrap();
    let real = text.replace(
        "data simulated {\n  recordings 16 seed 5 strength 1.0 duration 15 s\n",
        "data nanobench {\n  path \"logs\"\n",
    );
    let design = dir.path().join("study.design");
    std::fs::write(&design, &real).unwrap();
    let o = crossaudit(&["data", "audit", design.to_str().unwrap(), "--out", dir.path().join("a").to_str().unwrap()]);
    assert_ok(&o);
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("16 log files, 16 included"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    // A relative path naming one directory from the design's folder and
    // another from the current directory is ambiguous.
    std::fs::create_dir_all(dir.path().join("tests/fixtures/nanobench")).unwrap();
    std::fs::write(&design, real.replace("path \"logs\"", "path \"tests/fixtures/nanobench\"")).unwrap();
    let o = crossaudit(&["data", "audit", design.to_str().unwrap(), "--out", dir.path().join("b").to_str().unwrap()]);
    assert_refused(&o, "names two different directories");
}
