use std::path::{Path, PathBuf};

use crossaudit::cells::Cell;
use crossaudit::design::Design;

/// Tolerances, kept in one place (statrs keeps them in `prec.rs`).
pub mod tol {
    /// Same arithmetic in a different order: relative.
    pub const EXACT: f64 = 1e-9;
    /// Numerically inverted quantiles against R / scipy (relative).
    pub const QUANTILE: f64 = 1e-8;
}

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

pub fn rel_close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1e-300)
}

#[track_caller]
pub fn assert_rel(actual: f64, expected: f64, tol: f64, what: &str) {
    assert!(
        rel_close(actual, expected, tol),
        "{what}: got {actual:?}, expected {expected:?} (relative tolerance {tol})"
    );
}

/// Insta settings shared by every snapshot: all files under `snapshots/`.
#[macro_export]
macro_rules! snapshots {
    ($body:block) => {
        insta::with_settings!({ snapshot_path => "../snapshots", prepend_module_to_snapshot => true }, $body)
    };
}

/// The shared NanoBench logs. Tests that need them are marked
/// `#[ignore = "needs ../shared/nanobench"]` (a plain `cargo test` leaves
/// them out; the README's `cargo test -- --include-ignored` runs them) and
/// start with [`needs_shared_logs!`]: on a machine without the folder they
/// pass after writing a visible `SKIPPED` line, unless
/// `CROSSAUDIT_REQUIRE_SHARED` is set (as `.ci/run` sets it), when they fail.
#[track_caller]
pub fn shared_logs() -> PathBuf {
    let dir = root().join("../shared/nanobench/recordings");
    assert!(dir.is_dir(), "{} is absent; this test needs the shared NanoBench recordings", dir.display());
    dir
}

/// Where each skipped test is recorded (`KIND<TAB>LINE`, one a line), for
/// the summary `scripts/test.sh` prints after the run.
pub fn skips_file() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("skipped.txt")
}

/// Says that the running test is skipped and why: a `SKIPPED` line on
/// standard error (written past the test harness's capture, so it shows)
/// and a line in [`skips_file`] under `kind` (what it needs: `nanobench`,
/// `slurm`, `chromium`, `lab data`), which the test command's summary counts.
pub fn skip(kind: &str, line: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "SKIPPED {line}");
    let _ = std::fs::create_dir_all(env!("CARGO_TARGET_TMPDIR"));
    if let Ok(mut f) = std::fs::OpenOptions::new().create(true).append(true).open(skips_file()) {
        let _ = writeln!(f, "{kind}\t{}", line.replace(['\n', '\t'], " "));
    }
}

/// The shared logs, or `None` after a `SKIPPED` line on standard error
/// (written past the test harness's capture, so it shows in the output).
#[track_caller]
pub fn shared_logs_or_skip() -> Option<PathBuf> {
    let dir = root().join("../shared/nanobench/recordings");
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var_os("CROSSAUDIT_REQUIRE_SHARED").is_some() {
        panic!("{} is absent and CROSSAUDIT_REQUIRE_SHARED is set", dir.display());
    }
    let name = std::thread::current().name().unwrap_or("a test").to_string();
    skip(
        "nanobench",
        &format!(
            "{name}: needs the NanoBench recordings in ../shared/nanobench/recordings (see the README, \"Install\")"
        ),
    );
    None
}

/// A committed design, or `None` after a `SKIPPED` line when it cannot
/// load because a file it refers to beside the repository (a published
/// split in ../shared/nanobench) is absent; any other error fails, and so
/// does an absent file when `CROSSAUDIT_REQUIRE_SHARED` is set.
#[track_caller]
pub fn load_shipped_design(path: &Path) -> Option<crossaudit::DesignFile> {
    match crossaudit::design::load(path) {
        Ok(file) => Some(file),
        Err(e) => {
            let source = std::fs::read_to_string(path).unwrap_or_default();
            let shared = root().join("../shared/nanobench");
            let needs_shared =
                source.lines().any(|l| l.starts_with("split published") && l.contains("shared/nanobench"));
            if !needs_shared || shared.is_dir() || std::env::var_os("CROSSAUDIT_REQUIRE_SHARED").is_some() {
                panic!("{}: {e}", path.display());
            }
            skip(
                "nanobench",
                &format!(
                    "{}: its published split lives in ../shared/nanobench, which is absent (see the README, \"Install\")",
                    path.display()
                ),
            );
            None
        }
    }
}

/// The shared logs' folder, or an early return (the test passes, with a
/// SKIPPED line) when they are absent.
#[macro_export]
macro_rules! needs_shared_logs {
    () => {
        match $crate::common::shared_logs_or_skip() {
            Some(dir) => dir,
            None => return,
        }
    };
}

/// The tiny training design and its split on the shared logs.
#[track_caller]
pub fn tiny_split(out: &Path) -> (crossaudit::DesignFile, crossaudit::Plan, crossaudit::split::Prepared) {
    let dir = shared_logs();
    let file = crossaudit::design::load(&root().join("tests/designs/tiny_train.design")).unwrap();
    let plan = crossaudit::compile(&file.design);
    let split = crossaudit::split::prepare(&file, &plan, &dir, out).unwrap();
    (file, plan, split)
}

/// Runs the plan's job (model, arm, seed) on a prepared split into `out`.
pub fn run_job(
    file: &crossaudit::DesignFile,
    plan: &crossaudit::Plan,
    split: &crossaudit::split::Prepared,
    (model, arm, seed): (&str, &str, u64),
    out: &Path,
) -> crossaudit::run::JobOutcome {
    let job = plan.jobs.iter().find(|j| j.model == model && j.arm == arm && j.seed.0 == seed).expect("job in plan");
    crossaudit::run::run_job(&file.sha256, plan, job, split, out, &mut |_| {}).unwrap()
}

pub fn minimal_design_path() -> PathBuf {
    root().join("tests/designs/minimal.design")
}

pub fn minimal_design() -> Design {
    crossaudit::design::load(&minimal_design_path()).expect("minimal design is valid").design
}

pub fn example_cells() -> PathBuf {
    root().join("examples/cells/nanobench_synthetic.csv")
}

pub fn confirmatory_design() -> PathBuf {
    root().join("designs/nanobench_confirmatory.design")
}

/// A complete, deterministic set of cells for the minimal design: every
/// model x arm x seed x recording x horizon, with d_ij = -0.02 + a_i + b_j +
/// e_ij built from fixed small integers, so values are exact decimals.
pub fn minimal_cells(design: &Design) -> Vec<Cell> {
    let recs = [
        ("R1_circle_fast_rep1", "circle", "fast"),
        ("R2_circle_slow_rep1", "circle", "slow"),
        ("R3_star_fast_rep1", "star", "fast"),
        ("R4_star_slow_rep1", "star", "slow"),
    ];
    let mut out = Vec::new();
    for model in ["world", "relative"] {
        for h in [0.5, 1.0] {
            for arm in ["contaminated", "disjoint"] {
                for (j, s) in design.seeds.iter().enumerate() {
                    for (i, (r, t, sp)) in recs.iter().enumerate() {
                        let base = 0.3 + 0.05 * i as f64 + 0.01 * j as f64;
                        let d = if arm == "contaminated" { -0.06 + 0.005 * ((i * 3 + j * 7) % 5) as f64 } else { 0.0 };
                        let v = base * h + d;
                        out.push(Cell {
                            split: None,
                            dose: None,
                            model: model.into(),
                            arm: arm.into(),
                            seed: s.0,
                            recording: (*r).into(),
                            trajectory: (*t).into(),
                            speed: (*sp).into(),
                            horizon_s: h,
                            n_starts: 5,
                            n_divergent: 0,
                            fa_position_rmse_m: v,
                            conditional_position_rmse_m: Some(v),
                            divergence_rate: 0.0,
                            velocity_rmse_mps: Some(0.1),
                            attitude_rmse_deg: Some(2.0),
                            origin: Default::default(),
                        });
                    }
                }
            }
        }
    }
    out
}

pub fn write_temp_cells(dir: &Path, cells: &[Cell]) -> PathBuf {
    let p = dir.join("cells.csv");
    crossaudit::cells::write_cells(&p, cells).expect("write cells");
    p
}

/// A finished command's standard error, as text.
pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A finished command's standard output, as text.
pub fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The command succeeded (else its standard error is shown).
#[track_caller]
pub fn assert_ok(o: &std::process::Output) {
    assert!(o.status.success(), "{}", stderr(o));
}

/// The command was refused (exit 1, no panic) with `needle` in its message.
#[track_caller]
pub fn assert_refused(o: &std::process::Output, needle: &str) {
    assert_eq!(o.status.code(), Some(1), "expected a refusal containing {needle:?}; stderr: {}", stderr(o));
    assert!(stderr(o).contains(needle), "expected {needle:?} in: {}", stderr(o));
    assert!(!stderr(o).contains("panicked"), "{}", stderr(o));
}

/// The real `crossaudit` binary, run in the repository root with `args`
/// (colours off), its output collected: the one runner every CLI test uses.
pub fn crossaudit(args: &[&str]) -> std::process::Output {
    bin().env("NO_COLOR", "1").args(args).output().unwrap()
}

/// The real `crossaudit` binary as a command to configure further, run in
/// the repository root.
pub fn bin() -> std::process::Command {
    let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_crossaudit"));
    c.current_dir(root());
    c
}

/// Waits for `child` (spawned with its standard error piped), killing it
/// and failing the test once it runs past `seconds`: a hang; its exit code
/// and standard error. The one wait with a deadline of the CLI tests.
pub fn finish_within(mut child: std::process::Child, seconds: u64, what: &str) -> (Option<i32>, String) {
    use std::io::Read;
    let started = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > std::time::Duration::from_secs(seconds) {
            child.kill().unwrap();
            panic!("{what}: still running after {seconds} s (a hang)");
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    (child.wait().unwrap().code(), err)
}

/// The real binary with `args` (standard output discarded), failed as a
/// hang past `seconds` ([`finish_within`]): its exit code and standard error.
pub fn crossaudit_within(seconds: u64, args: &[&str]) -> (Option<i32>, String) {
    let child = bin()
        .env("NO_COLOR", "1")
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    finish_within(child, seconds, &args.join(" "))
}

/// Everything a command printed: standard output, then standard error.
pub fn said(o: &std::process::Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

/// Copies the files of `from` and its folders into `to` (links are copied
/// as the files they name).
pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), &target).unwrap();
        }
    }
}

/// A run.json's fields but the build and the seal (a hash over the build
/// too): what a fresh run of a committed result must reproduce.
pub fn run_json_fields(bytes: &[u8]) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_slice(bytes).unwrap();
    let fields = v.as_object_mut().unwrap();
    for field in ["crossaudit", "seal"] {
        fields.remove(field);
    }
    v
}
