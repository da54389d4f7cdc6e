//! The cluster path (`run --slurm`, `job`, `gather`), issue 17.
//!
//! The first tests need no Slurm: they run the generated scripts with `sh`
//! (the array task script once per index, as Slurm would), check that
//! hostile names cannot run a command, and that bad options and
//! directories are refused; a dose x split study runs as one array. The
//! last three submit to a real single-node Slurm started by
//! `scripts/slurm-local.sh` and compare the bytes with a local run; they print a SKIPPED line and return when Slurm is not
//! installed (`.ci/run` installs it).

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use crate::common::root;

/// The simulated study of the trust tests, seconds per run.
const DESIGN: &str = "tests/designs/sim_small.design";

/// A study name built to break a careless script: quotes, `;`, command
/// substitution in both forms and a variable.
const HOSTILE_STUDY: &str = "x'; rm -rf ~; echo '$(touch pwned) `touch pwned2` ${HOME}";

/// A directory name built the same way (a double quote is legal in a path).
const HOSTILE_DIR: &str = "run $(touch pwned) x\"; y'z `touch pwned2`";

pub(crate) fn crossaudit_in(cwd: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = crate::common::bin();
    c.current_dir(cwd).args(args);
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().unwrap()
}

pub(crate) fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

#[track_caller]
fn assert_ok(o: &Output) {
    assert!(o.status.success(), "{}", text(o));
}

#[track_caller]
fn assert_refused(o: &Output, needle: &str) {
    assert_eq!(o.status.code(), Some(1), "expected a refusal containing {needle:?}: {}", text(o));
    assert!(text(o).contains(needle), "expected {needle:?} in: {}", text(o));
    assert!(!text(o).contains("panicked"), "{}", text(o));
}

/// `DESIGN` with `study` as its name and `edit` applied, written into `dir`.
fn design_variant(dir: &Path, study: &str, edit: &dyn Fn(String) -> String) -> PathBuf {
    let source = std::fs::read_to_string(root().join(DESIGN)).unwrap();
    let source = edit(source.replace("study \"sim-small\"", &format!("study \"{study}\"")));
    let path = dir.join("study.design");
    std::fs::write(&path, source).unwrap();
    path
}

/// Every file under `dir` (relative path, bytes), except `slurm/` (the
/// scripts and logs only a cluster run has) and staging files. Two fields
/// record wall time and differ between any two runs, local or not: the
/// `seconds` column of a training curve, dropped here, and hence the
/// curve's hash in its job record, dropped too.
fn tree(dir: &Path) -> Vec<(String, Vec<u8>)> {
    fn walk(base: &Path, dir: &Path, out: &mut Vec<(String, Vec<u8>)>) {
        for e in std::fs::read_dir(dir).unwrap().filter_map(|e| e.ok()) {
            let p = e.path();
            let name = p.strip_prefix(base).unwrap().display().to_string();
            if name == "slurm" || name.ends_with(".tmp") {
                continue;
            }
            if p.is_dir() {
                walk(base, &p, out);
                continue;
            }
            let bytes = std::fs::read(&p).unwrap();
            let under = |folder: &str| name.starts_with(&format!("{folder}/")) || name.contains(&format!("/{folder}/"));
            let bytes = if under("curves") {
                let t = String::from_utf8(bytes).unwrap();
                let lines: Vec<String> = t.lines().map(|l| l.rsplit_once(',').unwrap().0.to_string()).collect();
                assert!(lines[0].ends_with("val_loss"), "{name}: {}", lines[0]);
                lines.join("\n").into_bytes()
            } else if under("jobs") {
                let t = String::from_utf8(bytes).unwrap();
                t.lines().filter(|l| !l.contains("\"curves/")).collect::<Vec<_>>().join("\n").into_bytes()
            } else {
                bytes
            };
            out.push((name, bytes));
        }
    }
    let mut v = Vec::new();
    walk(dir, dir, &mut v);
    v.sort();
    v
}

/// Staging files (`*.tmp`) anywhere under `dir`.
fn staging_files(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().filter_map(|e| e.ok()) {
        let p = e.path();
        if p.is_dir() {
            found.extend(staging_files(&p));
        } else if p.extension().is_some_and(|x| x == "tmp") {
            found.push(p.display().to_string());
        }
    }
    found
}

#[track_caller]
fn assert_same_run(local: &Path, cluster: &Path) {
    let (a, b) = (tree(local), tree(cluster));
    let names = |t: &[(String, Vec<u8>)]| t.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&a), names(&b), "the two runs wrote different files");
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{name} differs between the local run and the cluster run");
    }
    for must in ["cells.csv", "report/report.md", "report/results.json"] {
        assert!(a.iter().any(|(n, _)| n == must), "{must} missing");
    }
    // run.json at the top, or in each split's directory of a multi-split study.
    assert!(a.iter().any(|(n, _)| n == "run.json" || n.ends_with("/run.json")), "run.json missing");
}

/// A local run of `design` into `out`, from `cwd`.
fn local_run(cwd: &Path, design: &Path, out: &Path) {
    assert_ok(&crossaudit_in(
        cwd,
        &["run", design.to_str().unwrap(), "--out", out.to_str().unwrap(), "--workers", "2"],
        &[],
    ));
}

/// The simulated study over two splits and two doses (24 jobs), seconds per run.
const SPLITS_DESIGN: &str = "tests/designs/sim_splits_small.design";

/// Runs `DIR/slurm/array.sbatch` with `sh` for one index, as a Slurm task would.
pub(crate) fn sh_task(cwd: &Path, dir: &Path, index: usize) -> Output {
    Command::new("sh")
        .current_dir(cwd)
        .arg(dir.join("slurm/array.sbatch"))
        .env("SLURM_ARRAY_TASK_ID", index.to_string())
        .output()
        .unwrap()
}

fn no_pwned(dirs: &[&Path]) {
    for d in dirs {
        for name in ["pwned", "pwned2"] {
            assert!(!d.join(name).exists(), "a name ran a command: {} exists", d.join(name).display());
        }
    }
}

#[test]
fn hostile_names_are_quoted_and_the_scripts_reproduce_a_local_run() {
    let tmp = tempfile::tempdir().unwrap();
    let cwd = tmp.path().join("cwd");
    std::fs::create_dir_all(&cwd).unwrap();
    let design = design_variant(tmp.path(), HOSTILE_STUDY, &|s| s);
    let dir = tmp.path().join(HOSTILE_DIR);

    // sbatch stand-in: records each call's arguments (NUL-separated) and
    // answers with a job ID, as `sbatch --parsable` does. It checks what the
    // shell hands sbatch; the real Slurm tests below check the rest.
    let shim = tmp.path().join("bin");
    std::fs::create_dir_all(&shim).unwrap();
    let calls = tmp.path().join("calls");
    std::fs::create_dir_all(&calls).unwrap();
    let sbatch = shim.join("sbatch");
    std::fs::write(
        &sbatch,
        "#!/bin/sh\nn=$(ls \"$CALLS\" | wc -l)\nprintf '%s\\0' \"$@\" > \"$CALLS/call-$n\"\necho $((n + 100))\n",
    )
    .unwrap();
    Command::new("chmod").arg("+x").arg(&sbatch).status().unwrap();
    let path = format!("{}:{}", shim.display(), std::env::var("PATH").unwrap_or_default());
    let o = crossaudit_in(
        &cwd,
        &[
            "run",
            design.to_str().unwrap(),
            "--out",
            dir.to_str().unwrap(),
            "--slurm",
            "--submit",
            "--throttle",
            "3",
            "--mem",
            "1G",
            "--time",
            "0:10:00",
            "--partition",
            "local",
        ],
        &[("PATH", &path), ("CALLS", calls.to_str().unwrap())],
    );
    assert_ok(&o);
    assert_eq!(String::from_utf8_lossy(&o.stdout).trim(), "100 101", "{}", text(&o));
    no_pwned(&[&cwd, tmp.path(), &dir]);

    let call = |n: usize| -> Vec<String> {
        let bytes = std::fs::read(calls.join(format!("call-{n}"))).unwrap();
        bytes.split(|b| *b == 0).filter(|a| !a.is_empty()).map(|a| String::from_utf8(a.to_vec()).unwrap()).collect()
    };
    let d = dir.canonicalize().unwrap().display().to_string();
    // Letters, digits, `_.-` kept, the rest `_`, cut to 64 characters.
    let name = "crossaudit-x___rm_-rf____echo____touch_pwned___touch_pwned2____H";
    assert_eq!(name.len(), 64);
    let common = ["--cpus-per-task=1".to_string(), "--mem=1G".into(), format!("--chdir={d}"), "--time=0:10:00".into()];
    let mut expected: Vec<String> = vec!["--parsable".into(), format!("--job-name={name}"), "--array=0-7%3".into()];
    expected.extend(common.iter().cloned());
    expected.extend([
        "--partition=local".into(),
        format!("--output={d}/slurm/logs/task-%a.out"),
        "--open-mode=append".into(),
        format!("{d}/slurm/array.sbatch"),
    ]);
    assert_eq!(call(0), expected);
    let mut expected: Vec<String> = vec![
        "--parsable".into(),
        format!("--job-name={name}-gather"),
        "--dependency=afterok:100".into(),
        "--kill-on-invalid-dep=yes".into(),
    ];
    expected.extend(common.iter().cloned());
    expected.extend([
        "--partition=local".into(),
        format!("--output={d}/slurm/logs/gather.out"),
        "--open-mode=append".into(),
        format!("{d}/slurm/gather.sbatch"),
    ]);
    assert_eq!(call(1), expected);

    // The task and gather scripts, run as Slurm would run them. The gather
    // step refuses while a job is missing, naming it and its log.
    assert_ok(&sh_task(&cwd, &dir, 0));
    assert_ok(&sh_task(&cwd, &dir, 0)); // a finished job is verified and skipped
    let gather = || Command::new("sh").current_dir(&cwd).arg(dir.join("slurm/gather.sbatch")).output().unwrap();
    let o = gather();
    assert_refused(&o, "7 of 8 jobs");
    assert!(
        text(&o).contains(&format!("task 1 (world/disjoint/2): no Slurm log at {d}/slurm/logs/task-1.out")),
        "{}",
        text(&o)
    );
    assert!(!dir.join("cells.csv").exists());
    for i in 1..8 {
        assert_ok(&sh_task(&cwd, &dir, i));
    }
    assert_ok(&gather());
    no_pwned(&[&cwd, tmp.path(), &dir]);

    let local = tmp.path().join("local");
    local_run(&cwd, &design, &local);
    assert_same_run(&local, &dir);
}

/// A dose x split study is one array over every split's jobs. Each split
/// is opened in DIR/split-s as a local run opens it, a task trains in its
/// split's directory, a local run resumes a half-finished array, and the
/// gather step pools the splits: the same bytes as a local run.
#[test]
fn a_dose_by_split_study_runs_as_one_array_and_matches_a_local_run() {
    let tmp = tempfile::tempdir().unwrap();
    let cwd = tmp.path().join("cwd");
    std::fs::create_dir_all(&cwd).unwrap();
    let design = root().join(SPLITS_DESIGN);
    let dir = tmp.path().join("cluster");
    let (ds, d) = (design.to_str().unwrap(), dir.to_str().unwrap());
    let o = crossaudit_in(&cwd, &["run", ds, "--out", d, "--slurm"], &[]);
    assert_ok(&o);
    assert!(text(&o).contains("--array='0-23'") && text(&o).contains("24 of 24 jobs pending"), "{}", text(&o));
    for s in ["split-42", "split-43"] {
        for f in ["run.json", "audit/treatment.json", "manifests/manifests.json"] {
            assert!(dir.join(s).join(f).is_file(), "{s}/{f} was not written by run --slurm");
        }
    }
    let array = std::fs::read_to_string(dir.join("slurm/array.json")).unwrap();
    assert!(
        array.contains("\"split-42/world__disjoint__1\"")
            && array.contains("\"split-43/relative__contaminated_25pct__2\"")
    );

    // The gather step names a missing job with its split.
    let gather = || Command::new("sh").current_dir(&cwd).arg(dir.join("slurm/gather.sbatch")).output().unwrap();
    let o = gather();
    assert_refused(&o, "24 of 24 jobs");
    let canonical = dir.canonicalize().unwrap().display().to_string();
    assert!(
        text(&o).contains(&format!(
            "task 13 (split-43 world/disjoint/2): no Slurm log at {canonical}/slurm/logs/task-13.out"
        )),
        "{}",
        text(&o)
    );
    // Half the tasks through the array script (task 13 is split 43's), one twice.
    for i in (0..24).step_by(2).chain([13]) {
        let o = sh_task(&cwd, &dir, i);
        assert_ok(&o);
        assert!(text(&o).contains("finished in") && text(&o).contains("wrote split-4"), "{}", text(&o));
    }
    let o = sh_task(&cwd, &dir, 13);
    assert_ok(&o);
    assert!(text(&o).contains("job split-43 world/disjoint/2 had finished: files verified"), "{}", text(&o));
    let o = crossaudit_in(&cwd, &["job", d, "--index", "24"], &[]);
    assert_refused(&o, "array index 24 is out of range: the study has 24 jobs");
    // A local run resumes the rest, and the gather step then agrees with it.
    let o = crossaudit_in(&cwd, &["run", ds, "--out", d, "--workers", "2"], &[]);
    assert_ok(&o);
    assert!(text(&o).contains("11 cells trained, 13 resumed"), "{}", text(&o));
    assert_ok(&gather());
    let local = tmp.path().join("local");
    local_run(&cwd, &design, &local);
    assert_same_run(&local, &dir);
    for s in ["split-42", "split-43"] {
        assert!(tree(&dir).iter().any(|(n, _)| n == &format!("{s}/report/report.md")), "{s} has no report");
    }

    // A directory holding a single-split run is not prepared for a multi-split one.
    let single = tmp.path().join("single");
    let o =
        crossaudit_in(&cwd, &["run", root().join(DESIGN).to_str().unwrap(), "--out", single.to_str().unwrap()], &[]);
    assert_ok(&o);
    let o = crossaudit_in(&cwd, &["run", ds, "--out", single.to_str().unwrap(), "--slurm"], &[]);
    assert_refused(&o, "holds a run of a different design");
    assert!(!single.join("split-42").exists() && !single.join("slurm").exists());
}

#[test]
fn bad_slurm_options_directories_and_indices_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let design = root().join(DESIGN);
    let d = design.to_str().unwrap();
    let out = tmp.path().join("out");
    let o = out.to_str().unwrap();
    for (flag, value, needle) in [
        ("--mem", "4X", "--mem \"4X\": expected a positive size"),
        ("--mem", "0G", "--mem \"0G\""),
        ("--time", "1;touch pwned", "--time \"1;touch pwned\": expected a Slurm time"),
        ("--partition", "a b", "--partition \"a b\": expected letters"),
        ("--account", "$(id)", "--account \"$(id)\""),
        ("--cpus", "0", "--cpus \"0\": expected at least 1"),
        ("--throttle", "0", "--throttle \"0\""),
    ] {
        let r = crossaudit_in(tmp.path(), &["run", d, "--out", o, "--slurm", flag, value], &[]);
        assert_refused(&r, needle);
        assert!(!out.exists(), "{flag} {value}: refused, yet {o} was written");
    }
    for bad in ["with%percent", "with\nnewline"] {
        let dir = tmp.path().join(bad);
        let r = crossaudit_in(tmp.path(), &["run", d, "--out", dir.to_str().unwrap(), "--slurm"], &[]);
        assert_refused(&r, "cannot be used in a Slurm script");
    }
    // Slurm options without --slurm, and --workers with it.
    let r = crossaudit_in(tmp.path(), &["run", d, "--out", o, "--throttle", "2"], &[]);
    assert_eq!(r.status.code(), Some(2), "{}", text(&r));
    let r = crossaudit_in(tmp.path(), &["run", d, "--out", o, "--slurm", "--workers", "2"], &[]);
    assert_eq!(r.status.code(), Some(2), "{}", text(&r));

    // A directory no `run --slurm` prepared, and an index out of range.
    let r = crossaudit_in(tmp.path(), &["job", o, "--index", "0"], &[]);
    assert_refused(&r, "is not a run prepared for Slurm");
    let r = crossaudit_in(tmp.path(), &["gather", o], &[]);
    assert_refused(&r, "is not a run prepared for Slurm");
    assert_ok(&crossaudit_in(tmp.path(), &["run", d, "--out", o, "--slurm"], &[]));
    let r = crossaudit_in(tmp.path(), &["job", o, "--index", "8"], &[]);
    assert_refused(&r, "array index 8 is out of range: the study has 8 jobs, indices 0 to 7");

    // Two processes on one job: the second is refused while the first holds the lock.
    let lock = std::fs::File::create(out.join("slurm/locks/3.lock")).unwrap();
    lock.try_lock().unwrap();
    let r = crossaudit_in(tmp.path(), &["job", o, "--index", "3"], &[]);
    assert_refused(&r, "job world/contaminated/2 is being run by another process");
    drop(lock);
    assert_ok(&crossaudit_in(tmp.path(), &["job", o, "--index", "3"], &[]));

    // A design copy changed after preparing is refused by every task.
    let copy = out.join("slurm/design.design");
    let mut f = std::fs::OpenOptions::new().append(true).open(&copy).unwrap();
    writeln!(f, "# edited").unwrap();
    let r = crossaudit_in(tmp.path(), &["job", o, "--index", "0"], &[]);
    assert_refused(&r, "slurm/design.design records design sha256");
}

// ---------------------------------------------------------------------------
// A real Slurm.

/// One test at a time drives the cluster.
static SLURM: Mutex<()> = Mutex::new(());

/// The test cluster's state directory and ports (not the defaults, so a
/// trial cluster started by a user keeps running).
const STATE: &str = "/tmp/crossaudit-slurm-test";

/// Why the real-Slurm tests cannot run here, if they cannot.
fn slurm_missing() -> Option<String> {
    let on_path = |tool: &str| {
        ["/usr/sbin", "/usr/bin", "/sbin", "/bin", "/usr/local/sbin", "/usr/local/bin"]
            .iter()
            .any(|d| Path::new(d).join(tool).is_file())
    };
    let missing: Vec<&str> =
        ["munged", "slurmctld", "slurmd", "sbatch", "squeue", "scancel"].into_iter().filter(|t| !on_path(t)).collect();
    if !missing.is_empty() {
        return Some(format!(
            "Slurm is not installed ({} not found); `bash scripts/slurm-local.sh install` installs it",
            missing.join(", ")
        ));
    }
    let uid = Command::new("id").arg("-u").output().ok().map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    if uid.as_deref() != Some("0") {
        return Some("the local Slurm daemons need root".into());
    }
    None
}

/// A running test cluster, stopped when dropped (also when a test fails).
pub(crate) struct Cluster {
    conf: String,
}

impl Cluster {
    fn start() -> Cluster {
        let o = Self::script("start");
        assert!(o.status.success(), "scripts/slurm-local.sh start failed: {}", text(&o));
        Cluster { conf: format!("{STATE}/slurm.conf") }
    }

    fn script(what: &str) -> Output {
        Command::new("bash")
            .current_dir(root())
            .args(["scripts/slurm-local.sh", what])
            .env("CROSSAUDIT_SLURM_DIR", STATE)
            .env("CROSSAUDIT_SLURMCTLD_PORT", "6917")
            .env("CROSSAUDIT_SLURMD_PORT", "6918")
            .env("PATH", format!("/usr/sbin:/sbin:{}", std::env::var("PATH").unwrap_or_default()))
            .output()
            .unwrap()
    }

    pub(crate) fn env(&self) -> Vec<(&str, &str)> {
        vec![("SLURM_CONF", self.conf.as_str())]
    }

    fn cmd(&self, tool: &str, args: &[&str]) -> Output {
        Command::new(tool).args(args).env("SLURM_CONF", &self.conf).output().unwrap()
    }

    /// Jobs of `ids` still queued or running.
    fn queued(&self, ids: &[&str]) -> Vec<String> {
        let o = self.cmd("squeue", &["-h", "-o", "%i %T", "-j", &ids.join(",")]);
        String::from_utf8_lossy(&o.stdout).lines().map(str::to_string).collect()
    }

    /// Waits until none of `ids` is queued, at most `limit`.
    pub(crate) fn wait(&self, ids: &[&str], limit: Duration, dir: &Path) {
        let t0 = Instant::now();
        while !self.queued(ids).is_empty() {
            if t0.elapsed() > limit {
                panic!("Slurm jobs {ids:?} still queued after {limit:?}: {:?}\nlogs: {}", self.queued(ids), logs(dir));
            }
            std::thread::sleep(Duration::from_millis(200));
        }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Self::script("stop");
    }
}

pub(crate) fn logs(dir: &Path) -> String {
    let mut s = String::new();
    if let Ok(rd) = std::fs::read_dir(dir.join("slurm/logs")) {
        for e in rd.filter_map(|e| e.ok()) {
            s.push_str(&format!(
                "--- {}\n{}",
                e.path().display(),
                std::fs::read_to_string(e.path()).unwrap_or_default()
            ));
        }
    }
    s
}

/// Takes the cluster, or says why the test is skipped.
pub(crate) fn cluster(test: &str) -> Option<(std::sync::MutexGuard<'static, ()>, Cluster)> {
    if let Some(why) = slurm_missing() {
        // Straight to the process's stderr: libtest captures eprintln! of a passing test.
        crate::common::skip("slurm", &format!("{test}: {why}"));
        return None;
    }
    let guard = SLURM.lock().unwrap_or_else(|e| e.into_inner());
    Some((guard, Cluster::start()))
}

/// The IDs `run --slurm --submit` printed: the array's (if any) and the gather job's.
pub(crate) fn submitted(o: &Output) -> Vec<String> {
    assert_ok(o);
    String::from_utf8_lossy(&o.stdout).split_whitespace().map(str::to_string).collect()
}

#[test]
fn a_study_through_real_slurm_matches_a_local_run_byte_for_byte() {
    let Some((_guard, cluster)) = cluster("a_study_through_real_slurm_matches_a_local_run_byte_for_byte") else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let cwd = tmp.path().join("cwd");
    std::fs::create_dir_all(&cwd).unwrap();
    let design = design_variant(tmp.path(), HOSTILE_STUDY, &|s| s);
    let dir = tmp.path().join(HOSTILE_DIR);
    let d = dir.to_str().unwrap();
    let o = crossaudit_in(
        &cwd,
        &["run", design.to_str().unwrap(), "--out", d, "--slurm", "--submit", "--mem", "1G", "--throttle", "4"],
        &cluster.env(),
    );
    let ids = submitted(&o);
    assert_eq!(ids.len(), 2, "{}", text(&o));
    let ids: Vec<&str> = ids.iter().map(String::as_str).collect();
    cluster.wait(&ids, Duration::from_secs(600), &dir);
    let gather_log = std::fs::read_to_string(dir.join("slurm/logs/gather.out")).unwrap_or_default();
    assert!(gather_log.contains("gathered 8 jobs"), "the gather job did not finish: {}", logs(&dir));
    for i in 0..8 {
        let log = std::fs::read_to_string(dir.join(format!("slurm/logs/task-{i}.out"))).unwrap();
        assert!(log.contains(&format!("task {i} of ")) && log.contains("finished in"), "task {i}: {log}");
        assert!(log.contains(&format!("array job {}", ids[0])), "task {i} ran outside the array: {log}");
    }
    no_pwned(&[&cwd, tmp.path(), &dir]);
    let local = tmp.path().join("local");
    local_run(&cwd, &design, &local);
    assert_same_run(&local, &dir);
}

/// The dose x split study through a real Slurm: one array over both
/// splits, then the gather job pools them; the same bytes as a local run.
#[test]
fn a_dose_by_split_study_through_real_slurm_matches_a_local_run() {
    let Some((_guard, cluster)) = cluster("a_dose_by_split_study_through_real_slurm_matches_a_local_run") else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let design = root().join(SPLITS_DESIGN);
    let dir = tmp.path().join("cluster");
    let o = crossaudit_in(
        tmp.path(),
        &["run", design.to_str().unwrap(), "--out", dir.to_str().unwrap(), "--slurm", "--submit"],
        &cluster.env(),
    );
    let ids = submitted(&o);
    assert_eq!(ids.len(), 2, "{}", text(&o));
    let ids: Vec<&str> = ids.iter().map(String::as_str).collect();
    cluster.wait(&ids, Duration::from_secs(600), &dir);
    let gather_log = std::fs::read_to_string(dir.join("slurm/logs/gather.out")).unwrap_or_default();
    assert!(gather_log.contains("gathered 24 jobs"), "the gather job did not finish: {}", logs(&dir));
    assert!(gather_log.contains("on slope over doses, pooled over 2 splits"), "{gather_log}");
    for i in 0..24 {
        let log = std::fs::read_to_string(dir.join(format!("slurm/logs/task-{i}.out"))).unwrap();
        let split = if i < 12 { "split-42" } else { "split-43" };
        assert!(log.contains(&format!("job {split} ")) && log.contains("finished in"), "task {i}: {log}");
        assert!(log.contains(&format!("array job {}", ids[0])), "task {i} ran outside the array: {log}");
    }
    let local = tmp.path().join("local");
    local_run(tmp.path(), &design, &local);
    assert_same_run(&local, &dir);
}

#[test]
fn a_task_cancelled_mid_job_is_named_and_a_resubmission_gives_the_same_bytes() {
    let Some((_guard, cluster)) = cluster("a_task_cancelled_mid_job_is_named_and_a_resubmission_gives_the_same_bytes")
    else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let cwd = tmp.path().join("cwd");
    std::fs::create_dir_all(&cwd).unwrap();
    // Long enough jobs (2000 epochs) to be caught mid-training: one model,
    // two arms, two seeds.
    let design = design_variant(tmp.path(), "slurm-cancel", &|s| {
        s.replace("epochs 15 cosine patience 15", "epochs 2000 cosine patience 2000")
            .replace("model relative = mlp(32, 32, 32) inputs relative\n", "")
            .replace("models world, relative", "model world")
            .replace("interaction world - relative\n", "")
    });
    let dir = tmp.path().join("study");
    let d = dir.to_str().unwrap();
    let o = crossaudit_in(
        &cwd,
        &["run", design.to_str().unwrap(), "--out", d, "--slurm", "--submit", "--mem", "1G", "--throttle", "1"],
        &cluster.env(),
    );
    let ids = submitted(&o);
    let (array, gather) = (ids[0].clone(), ids[1].clone());

    // Cancel task 1 once it has started its job (its log's first line),
    // before the job's record exists.
    let log1 = dir.join("slurm/logs/task-1.out");
    let t0 = Instant::now();
    while !std::fs::read_to_string(&log1).unwrap_or_default().contains("task 1 of ") {
        assert!(t0.elapsed() < Duration::from_secs(300), "task 1 never started: {}", logs(&dir));
        std::thread::sleep(Duration::from_millis(50));
    }
    let o = cluster.cmd("scancel", &[&format!("{array}_1")]);
    assert_ok(&o);
    cluster.wait(&[&array, &gather], Duration::from_secs(600), &dir);
    assert!(
        !dir.join("jobs/world__disjoint__2.json").exists(),
        "task 1 finished before it was cancelled: make the job longer"
    );
    assert!(std::fs::read_to_string(&log1).unwrap().contains("CANCELLED"), "{}", logs(&dir));
    assert!(!dir.join("cells.csv").exists(), "the gather step ran despite a cancelled task");
    // Nothing half-written: the job's files are absent or complete (each is
    // written atomically; its record, written last, is absent).
    assert_eq!(staging_files(&dir), Vec::<String>::new(), "staging files left behind");

    // The gather step names the cancelled job and its Slurm log.
    let o = crossaudit_in(&cwd, &["gather", d], &[]);
    assert_refused(&o, "1 of 4 jobs");
    let canonical = dir.canonicalize().unwrap();
    assert!(
        text(&o).contains(&format!(
            "task 1 (world/disjoint/2): Slurm log {}/slurm/logs/task-1.out (last line: ",
            canonical.display()
        )),
        "{}",
        text(&o)
    );

    // Resubmitting the same script reruns only what is missing.
    let o = Command::new("sh")
        .current_dir(&cwd)
        .arg(dir.join("slurm/submit.sh"))
        .env("SLURM_CONF", &cluster.conf)
        .output()
        .unwrap();
    let ids = submitted(&o);
    let ids: Vec<&str> = ids.iter().map(String::as_str).collect();
    cluster.wait(&ids, Duration::from_secs(600), &dir);
    assert!(
        std::fs::read_to_string(dir.join("slurm/logs/gather.out")).unwrap().contains("gathered 4 jobs"),
        "{}",
        logs(&dir)
    );
    let log0 = std::fs::read_to_string(dir.join("slurm/logs/task-0.out")).unwrap();
    assert!(log0.contains("job world/disjoint/1 had finished: files verified, nothing run"), "{log0}");

    let local = tmp.path().join("local");
    local_run(&cwd, &design, &local);
    assert_same_run(&local, &dir);
}

/// The small simulated study with per-seed draws: three seeds, each its
/// own level (`draw-1` to `draw-3`), 12 jobs.
fn per_seed_design(dir: &Path) -> PathBuf {
    let base = std::fs::read_to_string(root().join(DESIGN)).unwrap();
    let text = base.replace("factor seed = 1..2", "factor seed = 4..6") + "draws per seed\n";
    let path = dir.join("per_seed.design");
    std::fs::write(&path, text).unwrap();
    path
}

/// A working folder, the per-seed design and the run folder to prepare,
/// under `tmp`.
fn per_seed_folders(tmp: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let cwd = tmp.join("cwd");
    std::fs::create_dir_all(&cwd).unwrap();
    (cwd, per_seed_design(tmp), tmp.join("cluster"))
}

/// Per-seed draws (the design every report recommends) run as one array
/// over every level's jobs; the gather step analyses the seeds together,
/// as a local run does, and both write the same bytes.
#[test]
fn a_per_seed_draw_study_runs_as_one_array_and_matches_a_local_run() {
    let tmp = tempfile::tempdir().unwrap();
    let (cwd, design, dir) = per_seed_folders(tmp.path());
    let (ds, d) = (design.to_str().unwrap(), dir.to_str().unwrap());
    let o = crossaudit_in(&cwd, &["run", ds, "--out", d, "--slurm"], &[]);
    assert_ok(&o);
    assert!(text(&o).contains("--array='0-11'") && text(&o).contains("12 of 12 jobs pending"), "{}", text(&o));
    let array = std::fs::read_to_string(dir.join("slurm/array.json")).unwrap();
    assert!(array.contains("\"draw-1/world__disjoint__4\"") && array.contains("\"draw-3/relative__contaminated__6\""));
    for i in 0..12 {
        let o = sh_task(&cwd, &dir, i);
        assert_ok(&o);
        assert!(text(&o).contains("finished in") && text(&o).contains("wrote draw-"), "{}", text(&o));
    }
    let o = Command::new("sh").current_dir(&cwd).arg(dir.join("slurm/gather.sbatch")).output().unwrap();
    assert_ok(&o);
    let report = std::fs::read_to_string(dir.join("report/report.md")).unwrap();
    assert!(report.contains("draws per seed: each seed trained and was evaluated on its own draw"), "{report}");
    let local = tmp.path().join("local");
    local_run(&cwd, &design, &local);
    assert_same_run(&local, &dir);
}

/// Five jobs per array task (`--jobs-per-task 5`): the per-seed study's 12
/// jobs in 3 tasks, a task running jobs of two levels; a second
/// preparation after task 0 leaves tasks 1 and 2 in the array; the tasks'
/// jobs write what a local run writes. A task past the last is refused,
/// and so is `--jobs-per-task 0`; `--device cuda` asks Slurm for a GPU per
/// task, and a task that finds none says so and exits non-zero.
#[test]
fn tasks_of_several_jobs_run_them_all_and_match_a_local_run() {
    let tmp = tempfile::tempdir().unwrap();
    let (cwd, design, dir) = per_seed_folders(tmp.path());
    let (ds, d) = (design.to_str().unwrap(), dir.to_str().unwrap());
    let o = crossaudit_in(&cwd, &["run", ds, "--out", d, "--slurm", "--jobs-per-task", "0"], &[]);
    assert_refused(&o, "--jobs-per-task");
    let o = crossaudit_in(&cwd, &["run", ds, "--out", d, "--slurm", "--jobs-per-task", "5"], &[]);
    assert_ok(&o);
    let said = text(&o);
    assert!(said.contains("--array='0-2'") && said.contains("3 task(s) of up to 5 training jobs each"), "{said}");
    assert!(!said.contains("--gres"), "{said}");
    let array = std::fs::read_to_string(dir.join("slurm/array.json")).unwrap();
    assert!(array.contains("\"per_task\": 5") && array.contains("\"device\": \"cpu\""), "{array}");
    let o = sh_task(&cwd, &dir, 3);
    assert_refused(&o, "array index 3 is out of range: the study has 12 jobs in 3 tasks of up to 5, indices 0 to 2");
    // Task 0: draw-1's four jobs and draw-2's first.
    let o = sh_task(&cwd, &dir, 0);
    assert_ok(&o);
    let said = text(&o);
    assert_eq!(said.matches("finished: wrote draw-1/").count(), 4, "{said}");
    assert_eq!(said.matches("finished: wrote draw-2/").count(), 1, "{said}");
    assert!(said.contains("task 0: 5 of its 5 job(s) ran, finished in"), "{said}");
    // Prepared again, the array holds the two tasks with pending jobs.
    let o = crossaudit_in(&cwd, &["run", ds, "--out", d, "--slurm", "--jobs-per-task", "5"], &[]);
    assert_ok(&o);
    assert!(text(&o).contains("--array='1-2'") && text(&o).contains("7 of 12 jobs pending"), "{}", text(&o));
    for i in [2, 1] {
        let o = sh_task(&cwd, &dir, i);
        assert_ok(&o);
        let ran = if i == 1 { 5 } else { 2 };
        assert!(text(&o).contains(&format!("task {i}: {ran} of its {ran} job(s) ran")), "{}", text(&o));
    }
    // Run again, task 0 verifies its five jobs and runs none.
    let o = sh_task(&cwd, &dir, 0);
    assert_ok(&o);
    assert_eq!(text(&o).matches("had finished: files verified, nothing run").count(), 5, "{}", text(&o));
    let o = Command::new("sh").current_dir(&cwd).arg(dir.join("slurm/gather.sbatch")).output().unwrap();
    assert_ok(&o);
    let local = tmp.path().join("local");
    local_run(&cwd, &design, &local);
    assert_same_run(&local, &dir);

    // A GPU per task where the networks are to train on one.
    let gpu = tmp.path().join("gpu");
    let g = gpu.to_str().unwrap();
    let o = crossaudit_in(&cwd, &["run", ds, "--out", g, "--slurm", "--jobs-per-task", "4", "--device", "cuda"], &[]);
    assert_ok(&o);
    assert!(text(&o).contains("--gres=gpu:1 --output=") && text(&o).contains("--array='0-2'"), "{}", text(&o));
    let submit = std::fs::read_to_string(gpu.join("slurm/submit.sh")).unwrap();
    assert_eq!(submit.matches("--gres=gpu:1").count(), 1, "the gather step asks for no GPU: {submit}");
    if crossaudit::model::device::resolve(crossaudit::model::DeviceChoice::Cuda).is_err() {
        let o = sh_task(&cwd, &gpu, 0);
        assert_refused(&o, "--device cuda");
        assert!(!text(&o).contains("panicked"), "{}", text(&o));
    }
}

/// The per-seed study through a real Slurm with four jobs per array task
/// (a level each): three tasks, and the same bytes as a local run.
#[test]
fn a_per_seed_draw_study_through_real_slurm_matches_a_local_run() {
    let Some((_guard, cluster)) = cluster("a_per_seed_draw_study_through_real_slurm_matches_a_local_run") else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let design = per_seed_design(tmp.path());
    let dir = tmp.path().join("cluster");
    let o = crossaudit_in(
        tmp.path(),
        &[
            "run",
            design.to_str().unwrap(),
            "--out",
            dir.to_str().unwrap(),
            "--slurm",
            "--submit",
            "--jobs-per-task",
            "4",
        ],
        &cluster.env(),
    );
    let ids = submitted(&o);
    assert_eq!(ids.len(), 2, "{}", text(&o));
    let ids: Vec<&str> = ids.iter().map(String::as_str).collect();
    cluster.wait(&ids, Duration::from_secs(600), &dir);
    let gather_log = std::fs::read_to_string(dir.join("slurm/logs/gather.out")).unwrap_or_default();
    assert!(gather_log.contains("gathered 12 jobs"), "the gather job did not finish: {}", logs(&dir));
    // Four jobs per task: task i runs level draw-(i + 1)'s four jobs.
    for i in 0..3 {
        let log = std::fs::read_to_string(dir.join(format!("slurm/logs/task-{i}.out"))).unwrap();
        let level = format!("finished: wrote draw-{}/", i + 1);
        assert_eq!(log.matches(&level).count(), 4, "task {i}: {log}");
        assert!(log.contains(&format!("task {i}: 4 of its 4 job(s) ran, finished in")), "task {i}: {log}");
        assert!(log.contains(&format!("array job {}", ids[0])), "task {i} ran outside the array: {log}");
    }
    let local = tmp.path().join("local");
    local_run(tmp.path(), &design, &local);
    assert_same_run(&local, &dir);
}
