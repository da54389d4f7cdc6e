//! `crossaudit run` as a user runs it: the real binary on the shared logs.
//! Killed part-way and restarted, it must give byte-identical per-cell
//! results; 1 and 2 workers must give byte-identical cells.csv.

use std::path::Path;
use std::time::{Duration, Instant};

use crate::common::{root, shared_logs};

fn run(design: &str, out: &Path, workers: &str) -> std::process::Output {
    crate::common::bin()
        .current_dir(root())
        .args(["run", design, "--out", out.to_str().unwrap(), "--workers", workers])
        .output()
        .unwrap()
}

/// Jobs whose record marks them finished.
fn finished_jobs(out: &Path) -> usize {
    std::fs::read_dir(out.join("jobs"))
        .map(|d| d.filter_map(|e| e.ok()).filter(|e| e.path().extension().is_some_and(|x| x == "json")).count())
        .unwrap_or(0)
}

fn cell_files(out: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(out.join("cells"))
        .map(|d| {
            // Finished cells only: a killed run may leave a `.csv.tmp` behind.
            d.filter_map(|e| e.ok())
                .filter(|e| e.path().extension().is_some_and(|x| x == "csv"))
                .map(|e| (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).unwrap()))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

#[test]
#[ignore = "needs ../shared/nanobench"]
fn one_and_two_workers_give_byte_identical_cells() {
    let _logs = crate::needs_shared_logs!();
    shared_logs();
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("w1"), dir.path().join("w2"));
    let (ra, rb) = (run("tests/designs/tiny_train.design", &a, "1"), run("tests/designs/tiny_train.design", &b, "2"));
    assert!(ra.status.success(), "{}", String::from_utf8_lossy(&ra.stderr));
    assert!(rb.status.success(), "{}", String::from_utf8_lossy(&rb.stderr));
    assert_eq!(std::fs::read(a.join("cells.csv")).unwrap(), std::fs::read(b.join("cells.csv")).unwrap());
    assert_eq!(
        std::fs::read(a.join("report/results.json")).unwrap(),
        std::fs::read(b.join("report/results.json")).unwrap()
    );
    // cells.parquet beside cells.csv: the same bytes from either worker
    // count, read back as the same cells, each in its place (line L of
    // the CSV, row L - 1 of the Parquet file).
    assert_eq!(std::fs::read(a.join("cells.parquet")).unwrap(), std::fs::read(b.join("cells.parquet")).unwrap());
    let from_parquet = crossaudit::cells::read_cells(&a.join("cells.parquet")).unwrap();
    let mut from_csv = crossaudit::cells::read_cells(&a.join("cells.csv")).unwrap();
    from_csv.iter_mut().for_each(|c| c.origin = c.origin.in_parquet());
    assert_eq!(from_parquet, from_csv);
    assert_eq!(from_parquet[0].origin.to_string(), "row 1");
    assert!(a.join("report/estimates.parquet").is_file());
    let cells = std::fs::read_to_string(a.join("cells.csv")).unwrap();
    // 2 models x 2 arms x 2 seeds; world at 0.5 and 1 s, relative at 0.5 s; 4 recordings.
    assert_eq!(cells.lines().count(), 1 + (2 * 2 * 4 + 2 * 2 * 4) + 2 * 2 * 4);
    let md = std::fs::read_to_string(a.join("report/report.md")).unwrap();
    assert!(md.lines().next().unwrap().contains("CONFIRMED"), "the report states the decision first");
    for f in [
        "optimism.svg",
        "interaction.svg",
        "per_seed_optimism.svg",
        "trajectory_differences.svg",
        "training_curves.svg",
    ] {
        let svg = std::fs::read_to_string(a.join("report").join(f)).unwrap();
        assert!(svg.starts_with("<svg") && md.contains(f), "{f}");
    }
}

#[test]
#[ignore = "needs ../shared/nanobench"]
fn a_killed_run_resumes_to_byte_identical_results() {
    let _logs = crate::needs_shared_logs!();
    shared_logs();
    let dir = tempfile::tempdir().unwrap();
    let design = "tests/designs/kill_restart.design";
    let reference = dir.path().join("reference");
    let r = run(design, &reference, "2");
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let total = cell_files(&reference).len();
    assert_eq!(total, 8);

    let killed = dir.path().join("killed");
    let mut child = crate::common::bin()
        .current_dir(root())
        .args(["run", design, "--out", killed.to_str().unwrap(), "--workers", "2"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while cell_files(&killed).is_empty() && t0.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap(); // SIGKILL on Unix
    child.wait().unwrap();
    let done_at_kill = cell_files(&killed).len();
    assert!(done_at_kill >= 1 && done_at_kill < total, "killed after {done_at_kill} of {total} cells");
    assert!(!killed.join("cells.csv").exists(), "the run was killed before it finished");
    // A job is finished once its record (jobs/STEM.json) is written, after
    // its cell file: a kill between the two leaves a cell file that the
    // resume retrains.
    let present = finished_jobs(&killed);
    assert!(present <= done_at_kill);
    let again = run(design, &killed, "2");
    assert!(again.status.success(), "{}", String::from_utf8_lossy(&again.stderr));
    let log = String::from_utf8_lossy(&again.stderr);
    assert!(log.contains(&format!("{} cells trained, {present} resumed", total - present)), "{log}");
    assert_eq!(cell_files(&killed), cell_files(&reference), "per-cell results differ after a kill and restart");
    assert_eq!(std::fs::read(killed.join("cells.csv")).unwrap(), std::fs::read(reference.join("cells.csv")).unwrap());
}

#[test]
#[ignore = "needs ../shared/nanobench"]
fn a_changed_locked_design_is_refused_unless_exploratory() {
    let _logs = crate::needs_shared_logs!();
    shared_logs();
    let dir = tempfile::tempdir().unwrap();
    let design = dir.path().join("tiny.design");
    let text = std::fs::read_to_string(root().join("tests/designs/tiny_train.design")).unwrap();
    std::fs::write(&design, text.replace("../shared", &format!("{}/../shared", root().display()))).unwrap();
    let lock = crate::common::bin().args(["lock", design.to_str().unwrap()]).output().unwrap();
    assert!(lock.status.success());
    std::fs::write(&design, std::fs::read_to_string(&design).unwrap() + "# amended after locking\n").unwrap();
    let out = dir.path().join("out");
    let refused = run(design.to_str().unwrap(), &out, "2");
    assert_eq!(refused.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&refused.stderr).contains("changed after it was locked"),
        "{}",
        String::from_utf8_lossy(&refused.stderr)
    );
    let explored = crate::common::bin()
        .current_dir(root())
        .args(["run", design.to_str().unwrap(), "--out", out.to_str().unwrap(), "--exploratory"])
        .output()
        .unwrap();
    assert!(explored.status.success(), "{}", String::from_utf8_lossy(&explored.stderr));
    let md = std::fs::read_to_string(out.join("report/report.md")).unwrap();
    assert!(
        md.lines().next().unwrap().contains("(EXPLORATORY: the design changed after it was locked)"),
        "{}",
        md.lines().next().unwrap()
    );
    let tex = std::fs::read_to_string(out.join("report/results.tex")).unwrap();
    assert!(tex.contains("EXPLORATORY"));
}
