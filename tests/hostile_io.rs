//! Issue 30, what the bad-input corpus cannot hold: standard output that
//! is a closed pipe or a full disk, inputs that are FIFOs, devices or
//! files too large to commit, an output folder another process holds,
//! and line numbers asserted one by one. Every test runs the real binary
//! and ends in seconds; a child still running after 30 s is a hang.

use std::fs::File;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::root;

const MINIMAL: &str = "tests/designs/minimal.design";
const CELLS: &str = "fuzz/seeds_cells/minimal_complete.csv";

/// The binary with `args`, run from the repository root; stderr piped.
fn spawn(args: &[&str], stdout: Stdio) -> Child {
    crate::common::bin()
        .current_dir(root())
        .args(args)
        .env("NO_COLOR", "1")
        .stdin(Stdio::null())
        .stdout(stdout)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Waits for `child` (killing it after 30 s: a hang); its exit code and stderr.
fn finish(child: Child, what: &str) -> (Option<i32>, String) {
    crate::common::finish_within(child, 30, what)
}

/// Runs `args` to the end with stdout discarded.
fn run(args: &[&str]) -> (Option<i32>, String) {
    finish(spawn(args, Stdio::null()), &args.join(" "))
}

#[track_caller]
fn assert_refused(got: &(Option<i32>, String), needles: &[&str]) {
    let (code, err) = got;
    assert!(!err.contains("panicked"), "a panic:\n{err}");
    assert_eq!(*code, Some(1), "expected exit 1:\n{err}");
    for n in needles {
        assert!(err.contains(n), "expected {n:?} in:\n{err}");
    }
}

/// A pipe whose reader is gone before the child starts: every write to
/// it fails with EPIPE, whatever the timing.
fn closed_pipe() -> Stdio {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    Stdio::from(writer)
}

/// Runs `args` with standard output a pipe whose reader is gone.
fn into_closed_pipe(args: &[&str]) -> (Option<i32>, String) {
    finish(spawn(args, closed_pipe()), &args.join(" "))
}

#[test]
fn output_into_a_closed_pipe_ends_quietly_without_a_panic() {
    // Issue 30 class 5: `check X | true` panicked "failed printing to stdout".
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("report");
    let report = report.to_str().unwrap();
    for args in [
        vec!["check", MINIMAL],
        vec!["check", MINIMAL, "--json"],
        vec!["analyze", MINIMAL, "--cells", CELLS, "--out", report],
        vec!["--help"],
    ] {
        let (code, err) = into_closed_pipe(&args);
        assert!(!err.contains("panicked"), "{args:?} panicked:\n{err}");
        assert_eq!(code, Some(141), "{args:?}: a closed pipe ends with status 141 (as SIGPIPE would):\n{err}");
        assert!(err.trim().is_empty() || !err.contains("error"), "{args:?}: a closed pipe is not an error:\n{err}");
    }
}

#[test]
fn a_run_into_a_closed_pipe_finishes_its_files_and_does_not_panic() {
    // Issue 30 class 5: `run ... | true` panicked after the run.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let args = ["run", "tests/designs/sim_small.design", "--out", out.to_str().unwrap(), "--workers", "2"];
    let (code, err) = crate::common::finish_within(spawn(&args, closed_pipe()), 300, "run");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(code, Some(141), "{err}");
    assert!(out.join("report/report.md").exists() && out.join("cells.csv").exists(), "{err}");
}

#[test]
fn output_to_a_full_disk_is_an_error_not_a_panic() {
    // Issue 30 class 5: `check X > /dev/full` panicked.
    if !Path::new("/dev/full").exists() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("report");
    let analyze = vec!["analyze", MINIMAL, "--cells", CELLS, "--out", report.to_str().unwrap()];
    for args in [vec!["check", MINIMAL], analyze, vec!["--help"], vec!["--version"]] {
        let full = File::options().write(true).open("/dev/full").unwrap();
        let got = finish(spawn(&args, Stdio::from(full)), &args.join(" "));
        assert_refused(&got, &["cannot write to standard output", "No space left on device"]);
    }
}

/// A FIFO at `path` (nothing ever writes to it).
fn mkfifo(path: &Path) {
    let status = Command::new("mkfifo").arg(path).status().unwrap();
    assert!(status.success());
}

#[test]
fn fifos_are_refused_before_they_are_opened() {
    // Issue 30 class 4: a FIFO named like a recording blocked for ever.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = |name: &str| d.join(name).to_str().unwrap().to_string();
    mkfifo(&d.join("study.design"));
    assert_refused(&run(&["check", &p("study.design")]), &["study.design", "FIFO", "not a regular file"]);

    mkfifo(&d.join("cells.csv"));
    let got = run(&["analyze", MINIMAL, "--cells", &p("cells.csv"), "--out", &p("report")]);
    assert_refused(&got, &["cells.csv", "FIFO"]);

    mkfifo(&d.join("split.json"));
    let got = run(&["audit", "split", &p("split.json"), "--data", "tests/fixtures/splits/data", "--out", &p("sa")]);
    assert_refused(&got, &["split.json", "FIFO"]);

    // A data folder whose recording is a FIFO, strict and lenient.
    let logs = d.join("logs");
    std::fs::create_dir(&logs).unwrap();
    let good = root().join("tests/fixtures/nanobench_corrupt/C10_good_rep1.csv");
    std::fs::copy(&good, logs.join("A1_circle_slow_rep1.csv")).unwrap();
    mkfifo(&logs.join("A2_circle_fast_rep1.csv"));
    let minimal = std::fs::read_to_string(root().join(MINIMAL)).unwrap();
    let strict = minimal.replace("path \"recordings\" }", "path \"recordings\" strict }");
    std::fs::write(d.join("strict.design"), strict).unwrap();
    let got = run(&["data", "audit", &p("strict.design"), "--data", &p("logs"), "--out", &p("audit")]);
    assert_refused(&got, &["A2_circle_fast_rep1.csv", "FIFO"]);
    let (code, err) = run(&["data", "audit", MINIMAL, "--data", &p("logs"), "--out", &p("audit2")]);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(code, Some(0), "a lenient audit excludes the FIFO with its reason:\n{err}");
    let table = std::fs::read_to_string(d.join("audit2/recordings.csv")).unwrap();
    assert!(table.contains("A2_circle_fast_rep1") && table.contains("FIFO"), "{table}");
}

#[test]
fn symlinks_to_devices_are_refused_not_read_until_memory_runs_out() {
    // Issue 30 class 4: a symlink to /dev/zero was read until memory ran out.
    if !Path::new("/dev/zero").exists() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = |name: &str| d.join(name).to_str().unwrap().to_string();
    let link = |name: &str| std::os::unix::fs::symlink("/dev/zero", d.join(name)).unwrap();
    link("study.design");
    assert_refused(&run(&["check", &p("study.design")]), &["study.design", "character device", "/dev/zero"]);
    link("cells.csv");
    let got = run(&["analyze", MINIMAL, "--cells", &p("cells.csv"), "--out", &p("report")]);
    assert_refused(&got, &["cells.csv", "character device"]);
    link("split.csv");
    let got = run(&["audit", "split", &p("split.csv"), "--data", "tests/fixtures/splits/data", "--out", &p("sa")]);
    assert_refused(&got, &["split.csv", "character device"]);
    link("spec.json");
    assert_refused(&run(&["coverage", &p("spec.json"), "--out", &p("cov")]), &["spec.json", "character device"]);

    let logs = d.join("logs");
    std::fs::create_dir(&logs).unwrap();
    std::os::unix::fs::symlink("/dev/zero", logs.join("A1_circle_slow_rep1.csv")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", logs.join("A1_circle_slow_rep1_metadata.yaml")).unwrap();
    let minimal = std::fs::read_to_string(root().join(MINIMAL)).unwrap();
    std::fs::write(d.join("strict.design"), minimal.replace("\"recordings\" }", "\"recordings\" strict }")).unwrap();
    let got = run(&["data", "audit", &p("strict.design"), "--data", &p("logs"), "--out", &p("audit")]);
    assert_refused(&got, &["A1_circle_slow_rep1", "character device"]);
}

#[test]
fn inputs_larger_than_their_limit_are_refused_before_they_are_read() {
    // Sparse files: the size is what is checked, so nothing is written.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = |name: &str| d.join(name).to_str().unwrap().to_string();
    let sparse = |name: &str, len: u64| File::create(d.join(name)).unwrap().set_len(len).unwrap();
    sparse("study.design", crossaudit::io::MAX_SMALL_TEXT + 1);
    assert_refused(&run(&["check", &p("study.design")]), &["study.design", "bytes read from a design file"]);
    sparse("cells.csv", crossaudit::io::MAX_CELLS_FILE + 1);
    let got = run(&["analyze", MINIMAL, "--cells", &p("cells.csv"), "--out", &p("report")]);
    assert_refused(&got, &["cells.csv", "bytes read from a per-cell CSV"]);
    sparse("split.json", crossaudit::io::MAX_SPLIT_FILE + 1);
    let got = run(&["audit", "split", &p("split.json"), "--data", "tests/fixtures/splits/data", "--out", &p("sa")]);
    assert_refused(&got, &["split.json", "bytes read from a split file"]);
}

#[test]
fn a_role_csv_of_200000_names_is_read_in_linear_time() {
    // Issue 30 class 4: a 200,000-name role CSV took quadratic time.
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("recording,role\r\n");
    for k in 0..200_000 {
        text.push_str(&format!("X{k}_circle_slow_rep1,{}\r\n", if k % 2 == 0 { "train" } else { "test" }));
    }
    // The last row is bad, so the whole file is read and the error located.
    text.push_str("X_last_circle_slow_rep1,\r\n");
    let split = dir.path().join("split.csv");
    std::fs::write(&split, text).unwrap();
    let started = Instant::now();
    let got = run(&[
        "audit",
        "split",
        split.to_str().unwrap(),
        "--data",
        "tests/fixtures/splits/data",
        "--out",
        dir.path().join("sa").to_str().unwrap(),
    ]);
    assert_refused(&got, &["split.csv:200002:25: empty `role`"]);
    assert!(started.elapsed() < Duration::from_secs(20), "took {:?}", started.elapsed());
}

#[test]
fn an_output_folder_another_process_holds_is_refused_by_name() {
    // Issue 30 class 6: a second run on one --out failed with "No such file
    // or directory". The test holds the folder's lock as a running
    // crossaudit would.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("busy");
    std::fs::create_dir(&out).unwrap();
    let held = File::open(&out).unwrap();
    held.try_lock().unwrap();
    let o = out.to_str().unwrap();
    let sim = "tests/designs/sim_small.design";
    for args in [
        vec!["run", sim, "--out", o, "--workers", "1"],
        vec!["train", sim, "--model", "world", "--arm", "disjoint", "--seed", "1", "--out", o],
        vec!["split", sim, "--out", o],
        vec!["simulate", sim, "--out", o],
        vec!["gather", o],
        vec!["analyze", MINIMAL, "--cells", CELLS, "--out", o],
    ] {
        let got = run(&args);
        assert_refused(&got, &[&format!("{o} is in use by another crossaudit process")]);
    }
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 0, "nothing was written into the held folder");
    drop(held);
    let (code, err) = run(&["analyze", MINIMAL, "--cells", CELLS, "--out", o]);
    assert_eq!(code, Some(0), "once released, the folder is usable:\n{err}");
}

#[test]
fn two_runs_on_one_output_folder_one_is_refused_as_in_use() {
    // Issue 30 class 6, as reported: two `run` processes on one --out.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let o = out.to_str().unwrap();
    let args = ["run", "tests/designs/sim_small.design", "--out", o, "--workers", "1"];
    let first = spawn(&args, Stdio::null());
    // The first holds the lock once the folder exists (it takes it there).
    let started = Instant::now();
    while !out.exists() && started.elapsed() < Duration::from_secs(20) {
        std::thread::sleep(Duration::from_millis(5));
    }
    let second = run(&args);
    let first = finish(first, "first run");
    // One of them took the folder first; the other is refused by name
    // (or, had the first ended already, resumed its finished run).
    for got in [&first, &second] {
        assert!(!got.1.contains("No such file"), "{}", got.1);
        if got.0 != Some(0) {
            assert_refused(got, &["is in use by another crossaudit process"]);
        }
    }
    assert!(first.0 == Some(0) || second.0 == Some(0), "{}\n{}", first.1, second.1);
}

/// The exit code and stderr of `args` on a file `name` holding `text` in a
/// fresh folder (`{f}` in `args` is the file's path).
fn on_file(name: &str, text: &str, args: &[&str]) -> (Option<i32>, String) {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join(name);
    std::fs::write(&f, text).unwrap();
    let out = dir.path().join("out");
    let args: Vec<String> =
        args.iter().map(|a| a.replace("{f}", f.to_str().unwrap()).replace("{out}", out.to_str().unwrap())).collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (code, err) = run(&args);
    (code, err.replace(f.to_str().unwrap(), "FILE"))
}

#[test]
fn line_numbers_are_right_for_crlf_and_lone_cr() {
    // Issue 30 class 9: errors were one line too low for CRLF files.
    for eol in ["\n", "\r\n", "\r"] {
        let cells = std::fs::read_to_string(root().join(CELLS)).unwrap();
        let mut lines: Vec<String> = cells.lines().map(str::to_string).collect();
        lines[5] = lines[5].replacen(",0.5,5,0,", ",0.5,5,0,NaN_", 1);
        let got =
            on_file("cells.csv", &(lines.join(eol) + eol), &["analyze", MINIMAL, "--cells", "{f}", "--out", "{out}"]);
        assert_refused(&got, &["FILE: line 6, field"]);
        lines[5] = lines[5].splitn(3, ',').take(2).collect::<Vec<_>>().join(",");
        let got =
            on_file("cells.csv", &(lines.join(eol) + eol), &["analyze", MINIMAL, "--cells", "{f}", "--out", "{out}"]);
        assert_refused(&got, &["FILE: line 6: row has 2 fields"]);

        let split = ["recording,fold", "S1_circle_slow_rep1,0", "S2_star_fast_rep1,1", "S3_oval_medium_rep1,x"];
        let audit = ["audit", "split", "{f}", "--data", "tests/fixtures/splits/data", "--out", "{out}"];
        assert_refused(&on_file("split.csv", &(split.join(eol) + eol), &audit), &["FILE:4:21: fold \"x\""]);
        let json =
            ["{", "  \"train_files\": [\"S1_circle_slow_rep1\"],", "  \"train_files\": [\"S2_star_fast_rep1\"]", "}"];
        assert_refused(
            &on_file("split.json", &(json.join(eol) + eol), &audit),
            &["FILE:3:3: key `train_files` appears twice"],
        );

        let design = std::fs::read_to_string(root().join(MINIMAL)).unwrap().replace("lr 1e-3", "lr -1e-3");
        let line = design.lines().position(|l| l.contains("lr -1e-3")).unwrap() + 1;
        let got = on_file("study.design", &(design.lines().collect::<Vec<_>>().join(eol) + eol), &["check", "{f}"]);
        assert_refused(&got, &[&format!("FILE:{line}:")]);
    }
}

#[test]
fn long_lists_in_a_design_are_refused_at_their_limit_in_linear_time() {
    // Issue 30 class 4: 200,000 seeds as a list passed where the range was
    // refused, and lists were checked for duplicates pairwise (a hang).
    let minimal = std::fs::read_to_string(root().join(MINIMAL)).unwrap();
    let names: Vec<String> = (0..100_001).map(|k| format!("\"R{k}_circle_slow_rep1\"")).collect();
    let listed = minimal
        .replace("evaluation 4 split_seed 1;", &format!("evaluation recordings {} split_seed 1;", names.join(", ")));
    let seeds: Vec<String> = (0..200_000).map(|k| k.to_string()).collect();
    let seeded = minimal.replace("factor seed = 1..3", &format!("factor seed = {}", seeds.join(", ")));
    for (text, needle) in [
        (listed, "the number of listed evaluation recordings must be at most 100000, found 100001"),
        (seeded, "seed number 100001 of a list of 200000"),
    ] {
        let started = Instant::now();
        let got = on_file("study.design", &text, &["check", "{f}"]);
        assert_refused(&got, &[needle]);
        assert_eq!(got.1.matches("error:").count(), 1, "one error, not its consequences:\n{}", got.1);
        assert!(got.1.lines().all(|l| l.len() < 300), "the long line is quoted around the error:\n{}", got.1);
        assert!(started.elapsed() < Duration::from_secs(10), "took {:?}", started.elapsed());
    }
}

#[test]
fn the_largest_min_run_ends_at_once() {
    // Issue 30 class 4: `audit split --min-run 18446744073709551615` looped
    // 2^64 times building its rolling hash.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sa");
    let started = Instant::now();
    let (code, err) = run(&[
        "audit",
        "split",
        "tests/fixtures/splits/nanobench_small.json",
        "--data",
        "tests/fixtures/splits/data",
        "--min-run",
        "18446744073709551615",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{err}");
    assert!(started.elapsed() < Duration::from_secs(10), "took {:?}", started.elapsed());
}

#[test]
fn a_slurm_job_shares_its_run_folder_with_other_jobs_only() {
    // Issue 30 class 6: a job takes a shared lock on its run folder, so a
    // `run` or `gather` holding it (exclusive) keeps every job off.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("slurm");
    let o = out.to_str().unwrap();
    let (code, err) = run(&["run", "tests/designs/sim_small.design", "--out", o, "--slurm"]);
    assert_eq!(code, Some(0), "{err}");
    let held = File::open(&out).unwrap();
    held.try_lock().unwrap();
    assert_refused(&run(&["job", o, "--index", "0"]), &[&format!("{o} is in use by another crossaudit process")]);
    assert!(!out.join("jobs").exists(), "no job ran");
    drop(held);
    let shared = File::open(&out).unwrap();
    shared.try_lock_shared().unwrap();
    let (code, err) = run(&["job", o, "--index", "0"]);
    assert_eq!(code, Some(0), "a job runs beside another job's shared lock:\n{err}");
    assert_refused(&run(&["gather", o]), &["is in use by another crossaudit process"]);
}
