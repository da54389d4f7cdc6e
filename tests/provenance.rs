//! Issue 30, round 3 (trust-b): sequences the bad-input corpus cannot
//! express, each with the real binary. Job provenance: a run directory is
//! written only by its own design, a finished job is reused only when its
//! record is of this run's design and lists exactly the files such a job
//! writes, a lock covers the files a design refers to and the language's
//! defaults, and the gather step recomputes the lock state. Preregistration
//! status: an unlocked design's outputs say NOT PREREGISTERED wherever a
//! locked one's say preregistered. Degenerate data: coverage leaves out
//! unusable replications, the planner refuses a pilot without variance.
//!
//! The runs use a tiny simulated design (one model, two seeds, a few
//! epochs) written by the tests, so none needs data beside the repository.

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::common::{assert_ok, assert_refused, root, stderr, stdout};

/// The tiny simulated study; `{epochs}` is filled in, so that two designs
/// can differ only in their epochs (issue 30's example).
const TINY: &str = r#"study "trust3-tiny"
data simulated {
  recordings 12 seed 5 strength 1.0 duration 15 s
  rate       100 Hz
  include    active(motor_motor_m1 > 1000) >= 200 samples
  exclude    implausible
  duplicates group
}
factor recording { evaluation 4 split_seed 42; starts 10 horizon 100 conditions trajectory, speed }
factor seed = 1..2
validation 300 windows from 2 recordings seed 143
arm disjoint     { fit 2000 windows seed 42 }
arm contaminated { from disjoint replace 25% with evaluation windows exclude starts seed 7 }
model world = mlp(32, 32, 32) inputs world
train { adam lr 1e-3 batch 256 epochs {epochs} cosine patience 15 action_noise 0.02 }
endpoint primary fa_position_rmse at 1.0 s cap 2 m model world
contrast contaminated - disjoint
estimate crossed_mom level 0.95 df seed - 1
decide confirmed when optimism >= 10% and upper < 0
"#;

fn crossaudit(args: &[&str]) -> Output {
    crate::common::bin().current_dir(root()).args(args).env("NO_COLOR", "1").output().unwrap()
}

/// Writes the tiny design with `epochs` into `dir/NAME`.
fn tiny(dir: &Path, name: &str, epochs: u32) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, TINY.replace("{epochs}", &epochs.to_string())).unwrap();
    path
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Every file under `dir`, by relative path.
fn tree(dir: &Path) -> Vec<(String, Vec<u8>)> {
    fn walk(base: &Path, dir: &Path, out: &mut Vec<(String, Vec<u8>)>) {
        for e in std::fs::read_dir(dir).unwrap().filter_map(|e| e.ok()) {
            let p = e.path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                out.push((p.strip_prefix(base).unwrap().display().to_string(), std::fs::read(&p).unwrap()));
            }
        }
    }
    let mut v = Vec::new();
    walk(dir, dir, &mut v);
    v.sort();
    v
}

/// One finished run of the tiny design (3 epochs), shared by the tests
/// that break a copy of it: (its directory, its design, its stdout).
fn reference() -> &'static (PathBuf, PathBuf, String) {
    static REFERENCE: std::sync::OnceLock<(PathBuf, PathBuf, String)> = std::sync::OnceLock::new();
    REFERENCE.get_or_init(|| {
        let base = root().join("target/test-trust3");
        let _ = std::fs::remove_dir_all(&base);
        std::fs::create_dir_all(&base).unwrap();
        let design = tiny(&base, "a.design", 3);
        let out = base.join("reference");
        let o = crossaudit(&["run", s(&design), "--out", s(&out), "--workers", "2"]);
        assert_ok(&o);
        (out, design, stdout(&o))
    })
}

/// A copy of the reference run (every file) in `into`.
fn copy_of_reference(into: &Path) -> PathBuf {
    let out = into.join("copy");
    for (name, bytes) in tree(&reference().0) {
        let p = out.join(&name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, bytes).unwrap();
    }
    out
}

/// A change made to a job record on purpose.
type JsonEdit = fn(&mut serde_json::Value);

fn edit_json(path: &Path, edit: impl Fn(&mut serde_json::Value)) {
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    edit(&mut v);
    std::fs::write(path, serde_json::to_string_pretty(&v).unwrap()).unwrap();
}

/// As [`edit_json`], the record's seal taken off first: the record as a
/// build before seals would have written it, so what is tested is how its
/// fields are read, not that an edit is found.
fn edit_as_older(path: &Path, edit: impl Fn(&mut serde_json::Value)) {
    edit_json(path, |v| {
        v.as_object_mut().unwrap().remove("seal").expect("the record was sealed");
        edit(v)
    });
}

#[test]
fn train_with_another_design_cannot_overwrite_a_finished_run() {
    // Issue 30, class 1: `train b.design` (b differs only in its epochs)
    // into a finished run of a.design exited 0 and overwrote a job, and the
    // next `run a.design` reused it. Now it is refused and nothing changes.
    let (_, design, first) = reference();
    let dir = tempfile::tempdir().unwrap();
    let out = copy_of_reference(dir.path());
    let b = tiny(dir.path(), "b.design", 4);
    let before = tree(&out);
    let o = crossaudit(&["train", s(&b), "--model", "world", "--arm", "disjoint", "--seed", "1", "--out", s(&out)]);
    assert_refused(&o, "holds a run of a different design");
    assert_eq!(tree(&out), before, "a refused train wrote into the run directory");
    let again = crossaudit(&["run", s(design), "--out", s(&out), "--workers", "2"]);
    assert_ok(&again);
    assert!(stderr(&again).contains("0 cells trained, 4 resumed"), "{}", stderr(&again));
    assert_eq!(stdout(&again), *first, "the decision moved");
}

#[test]
fn train_with_the_same_design_reuses_a_finished_job() {
    // A finished job is verified and left as it is, not trained again over
    // its files (its record would change: the curve's seconds differ).
    let (_, design, _) = reference();
    let dir = tempfile::tempdir().unwrap();
    let out = copy_of_reference(dir.path());
    let before = tree(&out);
    let o =
        crossaudit(&["train", s(design), "--model", "world", "--arm", "contaminated", "--seed", "2", "--out", s(&out)]);
    assert_ok(&o);
    assert!(stderr(&o).contains("had finished") && stderr(&o).contains("nothing run"), "{}", stderr(&o));
    assert_eq!(tree(&out), before);
}

#[test]
fn split_and_analyze_with_another_design_leave_the_run_alone() {
    let dir = tempfile::tempdir().unwrap();
    let out = copy_of_reference(dir.path());
    let b = tiny(dir.path(), "b.design", 4);
    let before = tree(&out);
    assert_refused(&crossaudit(&["split", s(&b), "--out", s(&out)]), "holds a run of a different design");
    // `analyze` writes report/ beside the cells by default: the run's report.
    let cells = out.join("cells.csv");
    assert_refused(&crossaudit(&["analyze", s(&b), "--cells", s(&cells)]), "holds a run of a different design");
    assert_eq!(tree(&out), before);
}

#[test]
fn a_job_record_of_another_design_is_refused() {
    // Issue 30, class 1: a job record's design hash was never compared with
    // run.json.
    let (_, design, _) = reference();
    let dir = tempfile::tempdir().unwrap();
    let out = copy_of_reference(dir.path());
    edit_json(&out.join("jobs/world__disjoint__1.json"), |v| v["design_sha256"] = "ab".repeat(32).into());
    let o = crossaudit(&["run", s(design), "--out", s(&out)]);
    assert_refused(&o, "records design sha256 abab");
    assert!(stderr(&o).contains("world__disjoint__1.json"), "{}", stderr(&o));
}

#[test]
fn a_job_record_whose_files_were_emptied_or_cut_is_refused() {
    // Issue 30, class 1: a record whose `files` map was emptied verified
    // nothing, so edited cells were accepted.
    let (_, design, _) = reference();
    let cases: [(&str, JsonEdit); 3] = [
        ("its `files` lists nothing", |v| v["files"] = serde_json::json!({})),
        ("but the job writes", |v| {
            v["files"].as_object_mut().unwrap().remove("models/world__contaminated__1.safetensors");
        }),
        ("but the job writes", |v| v["files"]["cells/other.csv"] = "00".repeat(32).into()),
    ];
    for (needle, edit) in cases {
        let dir = tempfile::tempdir().unwrap();
        let out = copy_of_reference(dir.path());
        edit_json(&out.join("jobs/world__contaminated__1.json"), edit);
        let cells = out.join("cells/world__contaminated__1.csv");
        let text = std::fs::read_to_string(&cells).unwrap();
        std::fs::write(&cells, text.replacen(",0.", ",0.0", 1)).unwrap();
        let o = crossaudit(&["run", s(design), "--out", s(&out)]);
        assert_refused(&o, needle);
        assert!(stderr(&o).contains("world__contaminated__1.json"), "{}", stderr(&o));
    }
}

/// The published-split fixture design copied into `dir` beside its split
/// file, its data path made absolute.
fn published_copy(dir: &Path) -> (PathBuf, PathBuf) {
    let text = std::fs::read_to_string(root().join("tests/designs/published_fixture.design")).unwrap();
    let data = root().join("tests/fixtures/splits/data");
    let text = text
        .replace("\"../fixtures/splits/data\"", &format!("\"{}\"", data.display()))
        .replace("\"../fixtures/splits/pin.json\"", "\"pin.json\"");
    let design = dir.join("study.design");
    std::fs::write(&design, text).unwrap();
    let pin = dir.join("pin.json");
    std::fs::copy(root().join("tests/fixtures/splits/pin.json"), &pin).unwrap();
    (design, pin)
}

#[test]
fn editing_a_file_the_design_refers_to_makes_its_lock_stale() {
    // Issue 30, class 1: editing a locked design's published split file
    // left the design "locked, unchanged".
    let dir = tempfile::tempdir().unwrap();
    let (design, pin) = published_copy(dir.path());
    assert_ok(&crossaudit(&["lock", s(&design)]));
    let lock: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("study.design.lock")).unwrap()).unwrap();
    assert_eq!(lock["language"], 1);
    assert!(lock["files"]["pin.json"].as_str().is_some_and(|h| h.len() == 64), "{lock}");
    assert!(stdout(&crossaudit(&["check", s(&design)])).contains("lock: locked/unchanged"));
    // The same roles and names, one more line: another file.
    let mut bytes = std::fs::read(&pin).unwrap();
    bytes.push(b'\n');
    std::fs::write(&pin, bytes).unwrap();
    let check = stdout(&crossaudit(&["check", s(&design)]));
    assert!(check.contains("lock: locked/changed"), "{check}");
    let json: serde_json::Value = serde_json::from_slice(&crossaudit(&["check", "--json", s(&design)]).stdout).unwrap();
    assert_eq!(json["lock"]["status"], "locked_stale");
    assert!(json["lock"]["reason"].as_str().unwrap().contains("`pin.json`"), "{json}");
    let out = dir.path().join("out");
    assert_refused(
        &crossaudit(&["run", s(&design), "--out", s(&out)]),
        "`pin.json`, which the design refers to, changed",
    );
    assert_refused(&crossaudit(&["lock", s(&design)]), "delete the lock to re-lock");
}

#[test]
fn a_lock_made_under_other_language_defaults_is_reported() {
    // Issue 30, class 1: a lock recorded only the design's bytes, so an old
    // locked design silently took new language defaults.
    let dir = tempfile::tempdir().unwrap();
    let design = dir.path().join("minimal.design");
    std::fs::copy(root().join("tests/designs/minimal.design"), &design).unwrap();
    assert_ok(&crossaudit(&["lock", s(&design)]));
    edit_json(&dir.path().join("minimal.design.lock"), |v| v["language"] = 0.into());
    assert!(stdout(&crossaudit(&["check", s(&design)])).contains("lock: locked/changed"));
    let cells = root().join("fuzz/seeds_cells/minimal_complete.csv");
    let report = dir.path().join("report");
    let o = crossaudit(&["analyze", s(&design), "--cells", s(&cells), "--out", s(&report)]);
    assert_ok(&o);
    assert!(stdout(&o).starts_with("EXPLORATORY decision:"), "{}", stdout(&o));
    assert!(stderr(&o).contains("design language version 0"), "{}", stderr(&o));
}

#[test]
fn every_committed_lock_still_holds() {
    // The locks under designs/ verify under the new lock format (the
    // upstream-split design's lock was regenerated to record its split
    // file's hash; its time and design hash are unchanged).
    // designs/logs/lab.design's lock covers its generated folder's listing.
    crate::lab_logs::lab_logs();
    let mut checked = 0;
    let mut dirs = vec![root().join("designs")];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap().filter_map(|e| e.ok()) {
            let p = e.path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "design") && crossaudit::design::lock::lock_path(&p).exists() {
                let Some(file) = crate::common::load_shipped_design(&p) else { continue };
                let status = crossaudit::design::lock::status(&file).unwrap();
                assert!(
                    matches!(status, crossaudit::design::LockStatus::LockedUnchanged { .. }),
                    "{}: {status:?}",
                    p.display()
                );
                checked += 1;
            }
        }
    }
    assert!(checked >= 15, "{checked} locks checked");
}

#[test]
fn gather_recomputes_the_lock_state_instead_of_trusting_array_json() {
    // Issue 30, class 1: `gather` took the lock state from array.json.
    let dir = tempfile::tempdir().unwrap();
    let design = tiny(dir.path(), "a.design", 2);
    assert_ok(&crossaudit(&["lock", s(&design)]));
    // Changed after the lock: prepared as exploratory, as it must be.
    std::fs::write(&design, TINY.replace("{epochs}", "3")).unwrap();
    let out = dir.path().join("slurm-run");
    assert_ok(&crossaudit(&["run", s(&design), "--slurm", "--exploratory", "--out", s(&out)]));
    for index in 0..4 {
        assert_ok(&crossaudit(&["job", s(&out), "--index", &index.to_string()]));
    }
    // Someone makes the run look preregistered.
    edit_json(&out.join("slurm/array.json"), |v| {
        v["lock"] = serde_json::json!({"status": "locked_unchanged", "locked_at_utc": "2026-01-01T00:00:00Z"})
    });
    // run.json's label taken off: its seal no longer holds, and the gather
    // refuses the folder; taken off a record without a seal, the array's
    // own record keeps the label.
    let run_json = out.join("run.json");
    let sealed = std::fs::read(&run_json).unwrap();
    edit_json(&run_json, |v| v["exploratory"] = false.into());
    assert_refused(&crossaudit(&["gather", s(&out)]), "run.json was edited after crossaudit wrote it");
    std::fs::write(&run_json, sealed).unwrap();
    edit_as_older(&run_json, |v| v["exploratory"] = false.into());
    let o = crossaudit(&["gather", s(&out)]);
    assert_ok(&o);
    assert!(stdout(&o).starts_with("EXPLORATORY decision:"), "{}", stdout(&o));
    let results: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report/results.json")).unwrap()).unwrap();
    assert_eq!(results["exploratory"], true);
    assert_eq!(results["preregistered"], false);
}

#[test]
fn a_design_locked_after_its_slurm_run_was_prepared_is_not_preregistered_at_gather() {
    // Issue 30, class 1: a lock made while the array runs must not make the
    // run preregistered (the gather reads the lock beside the design).
    let dir = tempfile::tempdir().unwrap();
    let design = tiny(dir.path(), "a.design", 2);
    let out = dir.path().join("slurm-run");
    assert_ok(&crossaudit(&["run", s(&design), "--slurm", "--out", s(&out)]));
    for index in 0..4 {
        assert_ok(&crossaudit(&["job", s(&out), "--index", &index.to_string()]));
    }
    assert_ok(&crossaudit(&["lock", s(&design)]));
    let o = crossaudit(&["gather", s(&out)]);
    assert_ok(&o);
    assert!(stdout(&o).starts_with("NOT PREREGISTERED decision:"), "{}", stdout(&o));
    let results: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report/results.json")).unwrap()).unwrap();
    assert_eq!(results["preregistered"], false);
}

#[test]
fn an_unlocked_design_says_not_preregistered_wherever_a_locked_one_is() {
    // Issue 30, class 8: a never-locked design ran and was analysed with
    // nothing on the decision line, and results.json said
    // `exploratory: false` with no warning.
    let dir = tempfile::tempdir().unwrap();
    let design = dir.path().join("minimal.design");
    std::fs::copy(root().join("tests/designs/minimal.design"), &design).unwrap();
    let cells = root().join("fuzz/seeds_cells/minimal_complete.csv");
    let analyze = |report: &Path| crossaudit(&["analyze", s(&design), "--cells", s(&cells), "--out", s(report)]);
    let unlocked = dir.path().join("unlocked");
    let o = analyze(&unlocked);
    assert_ok(&o);
    assert!(stdout(&o).starts_with("NOT PREREGISTERED decision:"), "{}", stdout(&o));
    assert!(stderr(&o).contains("NOT PREREGISTERED: the design was never locked"), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(unlocked.join("results.json")).unwrap()).unwrap();
    assert_eq!((json["preregistered"].clone(), json["exploratory"].clone()), (false.into(), false.into()));
    let md = std::fs::read_to_string(unlocked.join("report.md")).unwrap();
    assert!(md.lines().next().unwrap().contains("NOT PREREGISTERED"), "{md}");
    let tex = std::fs::read_to_string(unlocked.join("results.tex")).unwrap();
    assert!(tex.contains("% NOT PREREGISTERED") && tex.contains("caPreregistered}{no}"), "{tex}");

    assert_ok(&crossaudit(&["lock", s(&design)]));
    let locked = dir.path().join("locked");
    let o = analyze(&locked);
    assert_ok(&o);
    assert!(stdout(&o).starts_with("decision:"), "{}", stdout(&o));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(locked.join("results.json")).unwrap()).unwrap();
    assert_eq!(json["preregistered"], true);
    assert!(!std::fs::read_to_string(locked.join("report.md")).unwrap().contains("PREREGISTERED"));
    assert!(std::fs::read_to_string(locked.join("results.tex")).unwrap().contains("caPreregistered}{yes}"));

    // A run of an unlocked design says so on its decision line too.
    let (_, _, first) = reference();
    assert!(first.starts_with("NOT PREREGISTERED decision:"), "{first}");
}

/// A run records in run.json the lock state it began under (`lock`), kept
/// over resumes, and its analyses stand under the lower of that and the
/// state now: a design locked after its run began is not preregistered
/// for it, a post hoc mark taken off the lock since or a lock rewritten
/// does not raise the label, and a resume keeps an EXPLORATORY label.
#[test]
fn a_run_stands_under_the_lock_state_it_began_in() {
    let dir = tempfile::tempdir().unwrap();
    let out = copy_of_reference(dir.path());
    let design = dir.path().join("a.design");
    std::fs::copy(&reference().1, &design).unwrap();
    let run_json = out.join("run.json");
    // The console's decision line.
    let decision = |o: &Output| stdout(o).lines().find(|l| l.contains("decision:")).unwrap_or_default().to_string();
    let began = |out: &Path| -> serde_json::Value {
        serde_json::from_slice::<serde_json::Value>(&std::fs::read(out.join("run.json")).unwrap()).unwrap()["lock"]
            .clone()
    };
    assert_eq!(began(&out), serde_json::json!({"status": "unlocked"}), "the reference ran unlocked");

    // Locked after the run, then resumed (nothing to train): not preregistered.
    assert_ok(&crossaudit(&["lock", s(&design)]));
    let o = crossaudit(&["run", s(&design), "--out", s(&out)]);
    assert_ok(&o);
    assert!(decision(&o).starts_with("NOT PREREGISTERED decision:"), "{}", stdout(&o));
    let md = std::fs::read_to_string(out.join("report/report.md")).unwrap();
    assert!(
        md.lines().next().unwrap().ends_with("(NOT PREREGISTERED: the design was not locked when this run began)"),
        "{md}"
    );
    assert_eq!(began(&out), serde_json::json!({"status": "unlocked"}), "a resume keeps the state the run began in");
    let analyze = |name: &str| {
        let report = dir.path().join(name);
        let o = crossaudit(&["analyze", s(&design), "--cells", s(&out), "--out", s(&report)]);
        assert_ok(&o);
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(report.join("results.json")).unwrap()).unwrap();
        (decision(&o), json)
    };
    let (line, json) = analyze("later");
    assert!(line.starts_with("NOT PREREGISTERED decision:"), "{line}");
    assert_eq!(json["preregistered"], false);

    // Begun under this very lock (as run.json records it): preregistered;
    // the lock rewritten since (another time of locking): EXPLORATORY.
    let lock: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("a.design.lock")).unwrap()).unwrap();
    let at = lock["locked_at_utc"].clone();
    edit_as_older(&run_json, |v| v["lock"] = serde_json::json!({"status": "locked_unchanged", "locked_at_utc": at}));
    let (line, json) = analyze("locked");
    assert!(line.starts_with("decision:"), "{line}");
    assert_eq!(json["preregistered"], true);
    edit_json(&dir.path().join("a.design.lock"), |v| v["locked_at_utc"] = "2020-01-01T00:00:00Z".into());
    let (line, json) = analyze("relocked");
    assert!(line.starts_with("EXPLORATORY decision:"), "{line}");
    assert!(json["standing"].as_str().unwrap().contains("the design's lock changed after this run began"), "{json}");

    // Begun under a post hoc lock whose mark was taken off since: POST HOC.
    edit_json(&dir.path().join("a.design.lock"), |v| v["locked_at_utc"] = at.clone());
    let why = "written after the pilot";
    edit_json(&run_json, |v| v["lock"]["posthoc"] = why.into());
    let (line, json) = analyze("posthoc");
    assert!(line.starts_with("POST HOC decision:"), "{line}");
    assert!(json["standing"].as_str().unwrap().contains(why), "{json}");

    // Labelled EXPLORATORY, resumed without the flag: still EXPLORATORY.
    edit_json(&run_json, |v| v["exploratory"] = true.into());
    let o = crossaudit(&["run", s(&design), "--out", s(&out)]);
    assert_ok(&o);
    assert!(decision(&o).starts_with("EXPLORATORY decision:"), "{}", stdout(&o));
    assert_eq!(
        serde_json::from_slice::<serde_json::Value>(&std::fs::read(&run_json).unwrap()).unwrap()["exploratory"],
        true
    );
}

/// A run's own cells.csv edited after the run is refused whether it is
/// named as the folder or as the file (given as the file, it was analysed
/// as a per-cell file of its own, with the run's standing, into the run's
/// folder); with run.json's hash taken out, the job records say what it
/// must be.
#[test]
fn a_runs_cells_edited_after_the_run_are_refused_however_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = copy_of_reference(dir.path());
    let design = &reference().1;
    let cells = out.join("cells.csv");
    let text = std::fs::read_to_string(&cells).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    // A value of the second row's failure-aware RMSE (field 10) scaled.
    let mut f: Vec<String> = lines[1].split(',').map(String::from).collect();
    f[9] = format!("{}", f[9].parse::<f64>().unwrap() * 0.8);
    lines[1] = f.join(",");
    std::fs::write(&cells, lines.join("\n") + "\n").unwrap();
    let o = crossaudit(&["analyze", s(design), "--cells", s(&cells)]);
    assert_refused(&o, "it was edited after the run (to analyse the edited file as a per-cell file of its own, copy it out of the run's folder)");
    assert!(!out.join("reanalysis").exists(), "nothing written into the run's folder");
    edit_as_older(&out.join("run.json"), |v| {
        v.as_object_mut().unwrap().remove("cells_sha256");
    });
    let o = crossaudit(&["analyze", s(design), "--cells", s(&out), "--out", s(&dir.path().join("r"))]);
    assert_refused(&o, "cells.csv is not the per-cell files its jobs wrote");
    // Restored, the folder without its hash is read through its job records.
    std::fs::write(&cells, text).unwrap();
    assert_ok(&crossaudit(&["analyze", s(design), "--cells", s(&out), "--out", s(&dir.path().join("r"))]));
}

/// run.json records what every report of the run quotes beside its
/// verdict (the data it trained on, its label, the lock it began under,
/// its notes). Edited after the run (here: simulated recordings relabelled
/// as the real lab's logs), it was reported as the run's; now its seal
/// (the SHA-256 of its content, recomputed here through serde_json's
/// sorted-key writing, not the crate's) no longer holds, and a reanalysis
/// (of the folder or of its cells.csv) and a resume refuse it, naming it,
/// and change nothing. The same content reformatted is no edit.
#[test]
fn a_runs_record_edited_after_the_run_is_refused_by_every_reader() {
    let dir = tempfile::tempdir().unwrap();
    let out = copy_of_reference(dir.path());
    let design = &reference().1;
    let run_json = out.join("run.json");
    let text = std::fs::read_to_string(&run_json).unwrap();
    let mut content: serde_json::Value = serde_json::from_str(&text).unwrap();
    let seal = content.as_object_mut().unwrap().remove("seal").expect("run.json is sealed");
    let canonical = serde_json::to_string(&content).unwrap();
    assert!(canonical.starts_with(r#"{"audit_sha256":"#), "keys sorted: {canonical}");
    assert_eq!(seal.as_str().unwrap(), crossaudit::io::sha256_hex(canonical.as_bytes()));
    assert_eq!(content["data"]["kind"], "simulated", "{text}");

    edit_json(&run_json, |v| {
        v["data"] = serde_json::json!({"kind": "directory", "path": "../shared/nanobench/recordings"})
    });
    let before = tree(&out);
    let report = dir.path().join("r");
    for o in [
        crossaudit(&["analyze", s(design), "--cells", s(&out), "--out", s(&report)]),
        crossaudit(&["analyze", s(design), "--cells", s(&out.join("cells.csv")), "--out", s(&report)]),
        crossaudit(&["run", s(design), "--out", s(&out)]),
    ] {
        assert_refused(&o, &format!("{} was edited after crossaudit wrote it", run_json.display()));
        assert!(stderr(&o).contains("restore it"), "{}", stderr(&o));
    }
    assert_eq!(tree(&out), before, "nothing in the run's folder changed");
    assert!(!report.exists(), "no report written");

    // The same content, compact: read as the run's.
    std::fs::write(
        &run_json,
        serde_json::to_string(&serde_json::from_str::<serde_json::Value>(&text).unwrap()).unwrap(),
    )
    .unwrap();
    let o = crossaudit(&["analyze", s(design), "--cells", s(&out), "--out", s(&report)]);
    assert_ok(&o);
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    assert!(md.contains("simulated recordings") && !md.contains("nanobench/recordings"), "{md}");
}

/// A run is never written into another run's folder (`run`, `split`
/// wrote their audit, manifests and run.json into a finished run's
/// `jobs/` or `report/`, and a later `--reuse` of the outer run failed on
/// the planted run.json), nor into a file; per-cell data is never read
/// from standard input (the report quotes the file's path and SHA-256).
#[test]
fn a_run_is_never_written_inside_another_run_and_cells_come_from_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = copy_of_reference(dir.path());
    let other = tiny(dir.path(), "other.design", 2);
    let before = tree(&out);
    for (command, inside) in [("run", "jobs"), ("split", "report"), ("run", "cells/sub"), ("train", "curves")] {
        let target = out.join(inside);
        let mut args = vec![command, s(&other), "--out", s(&target)];
        if command == "train" {
            args.extend(["--model", "world", "--arm", "disjoint", "--seed", "1"]);
        }
        let o = crossaudit(&args);
        assert_refused(&o, &format!("{} lies inside the run in {}", target.display(), out.display()));
    }
    assert_eq!(tree(&out), before, "nothing written into the run");
    let o = crossaudit(&["run", s(&other), "--out", s(&other)]);
    assert_refused(&o, "it is a file, not a folder");
    let cells = std::fs::File::open(out.join("cells.csv")).unwrap();
    let o = crate::common::bin()
        .current_dir(root())
        .args(["analyze", s(&reference().1), "--cells", "-", "--out", s(&dir.path().join("r"))])
        .stdin(cells)
        .output()
        .unwrap();
    assert_refused(&o, "standard input is not read");
    assert!(!dir.path().join("r").exists());
}

/// A link planted at an output's temporary name (`OUT/results.json.tmp`
/// pointing at a run's cells.csv) is replaced, not written through; and a
/// thread count that would take minutes to start is refused at once.
#[test]
fn staged_writes_follow_no_planted_link_and_threads_are_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let out = copy_of_reference(dir.path());
    let before = std::fs::read(out.join("cells.csv")).unwrap();
    let report = dir.path().join("report");
    std::fs::create_dir_all(&report).unwrap();
    std::os::unix::fs::symlink(out.join("cells.csv"), report.join("results.json.tmp")).unwrap();
    let design = &reference().1;
    assert_ok(&crossaudit(&["analyze", s(design), "--cells", s(&out), "--out", s(&report)]));
    assert_eq!(std::fs::read(out.join("cells.csv")).unwrap(), before, "the run's cells.csv is untouched");
    assert!(!std::fs::symlink_metadata(report.join("results.json")).unwrap().file_type().is_symlink());
    let o = crossaudit(&["--threads", "2000", "check", s(design)]);
    assert!(!o.status.success() && stderr(&o).contains("2000"), "{}", stderr(&o));
    let o = crate::common::bin()
        .current_dir(root())
        .env("RAYON_NUM_THREADS", "100000")
        .args(["check", s(design)])
        .output()
        .unwrap();
    assert_refused(&o, "RAYON_NUM_THREADS=100000: at most 1024 threads");
}

#[test]
fn every_view_gives_the_one_true_label_of_each_state() {
    // Issue 72: a never-locked design run with --exploratory said "the
    // design changed after it was locked"; post hoc designs carried the
    // "Preregistered" banner.
    let dir = tempfile::tempdir().unwrap();
    let design = dir.path().join("minimal.design");
    std::fs::copy(root().join("tests/designs/minimal.design"), &design).unwrap();
    let cells = root().join("fuzz/seeds_cells/minimal_complete.csv");
    let analyze = |name: &str| {
        let report = dir.path().join(name);
        let o = crossaudit(&["analyze", s(&design), "--cells", s(&cells), "--out", s(&report)]);
        assert_ok(&o);
        let read = |f: &str| std::fs::read_to_string(report.join(f)).unwrap();
        let json: serde_json::Value = serde_json::from_str(&read("results.json")).unwrap();
        (stdout(&o), read("report.md"), read("report.html"), json)
    };

    // Marked post hoc (locking it): every view says POST HOC, none says preregistered.
    let why = "written after the pilot's results were known";
    assert_ok(&crossaudit(&["lock", s(&design), "--posthoc", why]));
    let (line, md, html, json) = analyze("posthoc");
    assert!(line.starts_with("POST HOC decision:"), "{line}");
    assert!(md.lines().next().unwrap().contains("(POST HOC: the design was written after results were known)"), "{md}");
    assert!(
        html.contains("POST HOC: the design was written after results were known (written after the pilot"),
        "{html}"
    );
    assert!(!html.contains("Preregistered:") && !md.contains("Preregistered:"), "{html}");
    assert_eq!((json["preregistered"].clone(), json["exploratory"].clone()), (false.into(), false.into()));
    assert!(json["standing"].as_str().unwrap().contains(why), "{}", json["standing"]);
    // The same reason again is a no-op; another is refused; an amendment keeps the mark.
    assert_ok(&crossaudit(&["lock", s(&design), "--posthoc", why]));
    let o = crossaudit(&["lock", s(&design), "--posthoc", "another reason"]);
    assert!(
        !o.status.success() && stderr(&o).contains("differs from the lock's own post hoc reason"),
        "{}",
        stderr(&o)
    );
    let mut text = std::fs::read_to_string(&design).unwrap();
    text.push_str("\n# amended\n");
    std::fs::write(&design, text).unwrap();
    assert_ok(&crossaudit(&["lock", s(&design), "--amend", "a comment"]));
    let (line, ..) = analyze("amended");
    assert!(line.starts_with("POST HOC decision:"), "{line}");
    // A post hoc mark on a lock that no longer holds is refused.
    std::fs::write(&design, std::fs::read_to_string(&design).unwrap() + "# again\n").unwrap();
    let o = crossaudit(&["lock", s(&design), "--posthoc", why]);
    assert!(!o.status.success() && stderr(&o).contains("no longer holds"), "{}", stderr(&o));

    // A never-locked design run with --exploratory: NOT PREREGISTERED, and never "changed after it was locked".
    let copy = copy_of_reference(dir.path());
    let (_, tiny_design, _) = reference();
    let o = crossaudit(&["run", s(tiny_design), "--out", s(&copy), "--exploratory", "--workers", "1"]);
    assert_ok(&o);
    let md = std::fs::read_to_string(copy.join("report/report.md")).unwrap();
    let html = std::fs::read_to_string(copy.join("report/report.html")).unwrap();
    assert!(stdout(&o).starts_with("NOT PREREGISTERED decision:"), "{}", stdout(&o));
    assert!(md.lines().next().unwrap().contains("(NOT PREREGISTERED: the design was never locked)"), "{md}");
    assert!(html.contains("the design was never locked, and the run was labelled exploratory"), "{html}");
    for text in [&md, &html, &stdout(&o), &stderr(&o)] {
        assert!(!text.contains("changed after it was locked"), "{text}");
    }
}

#[test]
fn coverage_leaves_out_intervals_with_nan_ends_and_gives_no_mcse_from_one() {
    // Issue 30, class 3: a Kenward-Roger interval with NaN ends was counted
    // as a miss, and one usable replication printed "1.000 (0.000)".
    use crossaudit::stats::coverage::performance;
    use crossaudit::stats::IntervalMethod;
    let nan = f64::NAN;
    // One replication whose df were undefined, one covering the truth 0.
    let est = [(0.2, 1.0, nan, nan), (0.1, 1.0, -1.9, 2.1)];
    let p = performance("s", IntervalMethod::RemlKenwardRoger, &est, 0.0);
    // By hand: one usable replication, which covers, so coverage 1/1; an
    // MCSE needs two (Morris, White & Crowther 2019, Table 6: sqrt(c(1-c)/n)
    // is 0 at n = 1, which is no standard error).
    assert_eq!(p.reps, 1);
    assert_eq!(p.coverage, 1.0);
    assert!(p.coverage_mcse.is_nan());
    // Two usable, one covering: coverage 1/2, MCSE sqrt(0.5 * 0.5 / 2).
    let est = [(0.2, 1.0, nan, nan), (0.1, 1.0, -1.9, 2.1), (3.0, 1.0, 1.0, 5.0)];
    let p = performance("s", IntervalMethod::RemlKenwardRoger, &est, 0.0);
    assert_eq!((p.reps, p.coverage), (2, 0.5));
    assert!((p.coverage_mcse - (0.125f64).sqrt()).abs() < 1e-15);
}

#[test]
fn the_planner_refuses_a_pilot_without_variance() {
    // Issue 30, class 3: the planner planned on components of about 1e-34
    // and predicted P(rule holds) = 1.000 at every size.
    let file = crossaudit::design::load(&root().join("tests/designs/minimal.design")).unwrap();
    let plan = crossaudit::compile(&file.design);
    let cells = crossaudit::cells::read_cells(&root().join("fuzz/seeds_cells/minimal_complete.csv")).unwrap();
    let mut a = crossaudit::analysis::analyze(&plan, &cells, Default::default()).unwrap();
    assert!(crossaudit::methods::power_plan(&plan, &a, &[4, 8], &[3, 6]).is_ok());
    let c = &mut a.units[0].estimate.components;
    (c.recording, c.seed, c.residual) = (1e-34, 2e-34, 0.0);
    let e = crossaudit::methods::power_plan(&plan, &a, &[4, 8], &[3, 6]).unwrap_err().to_string();
    assert!(e.contains("no variance to plan from"), "{e}");
}

/// A locked design edited afterwards is refused by every command that would
/// train or export it, before anything (its simulated data included) is
/// written into the output folder.
#[test]
fn a_design_changed_after_its_lock_is_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let design = tiny(dir.path(), "changed.design", 2);
    assert_ok(&crossaudit(&["lock", s(&design)]));
    let text = std::fs::read_to_string(&design).unwrap().replace("epochs 2 ", "epochs 3 ");
    std::fs::write(&design, text).unwrap();
    let out = dir.path().join("out");
    for args in [
        vec!["run", s(&design), "--out", s(&out)],
        vec!["run", s(&design), "--out", s(&out), "--slurm"],
        vec!["train", s(&design), "--model", "world", "--arm", "disjoint", "--seed", "1", "--out", s(&out)],
    ] {
        assert_refused(&crossaudit(&args), "changed after it was locked");
        assert!(!out.exists(), "{args:?} wrote into {} before refusing", out.display());
    }
    // The external-model path: the same design with its model declared external.
    let ext = dir.path().join("ext.design");
    let text =
        std::fs::read_to_string(&design).unwrap().replace("mlp(32, 32, 32) inputs world", "external inputs world");
    std::fs::write(&ext, &text).unwrap();
    assert_ok(&crossaudit(&["lock", s(&ext)]));
    std::fs::write(&ext, text.replace("seed 143", "seed 144")).unwrap();
    assert_refused(&crossaudit(&["export", s(&ext), "--out", s(&out)]), "changed after it was locked");
    assert!(!out.exists(), "export wrote into {} before refusing", out.display());
}

#[test]
fn commands_that_write_no_run_leave_a_runs_own_folders_alone() {
    // A trust review (round 6): `data audit`, `simsum`, `coverage`, `audit
    // split` and `combine` wrote into a run's simulated_data/ (or audit/,
    // report/), and the run could no longer resume ("holds a run on other
    // data"). Each is refused before it writes, and the run resumes.
    let (_, design, first) = reference();
    let dir = tempfile::tempdir().unwrap();
    let out = copy_of_reference(dir.path());
    let before = tree(&out);
    let data = out.join("simulated_data");
    assert_refused(&crossaudit(&["data", "audit", s(design), "--out", s(&data)]), "only the run itself writes");
    let truth = "tests/fixtures/simsum_truth_column.csv";
    let audit = out.join("audit");
    assert_refused(
        &crossaudit(&["simsum", truth, "--true", "true_value", "--out", s(&audit)]),
        "only the run itself writes",
    );
    assert_eq!(tree(&out), before, "a refused command wrote into the run");
    let again = crossaudit(&["run", s(design), "--out", s(&out), "--workers", "2"]);
    assert_ok(&again);
    assert!(stderr(&again).contains("0 cells trained, 4 resumed"), "{}", stderr(&again));
    assert_eq!(stdout(&again), *first);
}

#[test]
fn an_analysis_whose_outputs_hold_an_input_writes_nothing() {
    // A trust review (round 6): the per-cell file given as DIR/estimates.csv
    // was protected, but report.md, results.json and the figures were
    // written before the refusal, a folder that looked like a whole report.
    let (out, design, _) = reference();
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("self");
    std::fs::create_dir_all(&folder).unwrap();
    let cells = folder.join("estimates.csv");
    std::fs::copy(out.join("cells.csv"), &cells).unwrap();
    let o = crossaudit(&["analyze", s(design), "--cells", s(&cells), "--out", s(&folder)]);
    assert_refused(&o, "it is an input of this command");
    let left: Vec<String> = tree(&folder).into_iter().map(|(n, _)| n).collect();
    assert_eq!(left, ["estimates.csv"], "nothing but the input is there");
}

#[test]
fn an_analysis_does_not_replace_someones_own_report() {
    // A trust review (round 7): `analyze --out DIR` replaced a user's own
    // DIR/report.md and results.json. A folder whose report.md has no
    // results.json naming a study beside it is refused before writing; a
    // crossaudit report's folder is rewritten as before.
    let (out, design, _) = reference();
    let dir = tempfile::tempdir().unwrap();
    let mine = dir.path().join("mine");
    std::fs::create_dir_all(&mine).unwrap();
    std::fs::write(mine.join("report.md"), "my notes\n").unwrap();
    let cells = out.join("cells.csv");
    let o = crossaudit(&["analyze", s(design), "--cells", s(&cells), "--out", s(&mine)]);
    assert_refused(&o, "it is no crossaudit report's");
    let left: Vec<String> = tree(&mine).into_iter().map(|(n, _)| n).collect();
    assert_eq!(left, ["report.md"]);
    assert_eq!(std::fs::read_to_string(mine.join("report.md")).unwrap(), "my notes\n");
    // A report's own folder is written again.
    let again = dir.path().join("again");
    assert_ok(&crossaudit(&["analyze", s(design), "--cells", s(&cells), "--out", s(&again)]));
    assert_ok(&crossaudit(&["analyze", s(design), "--cells", s(&cells), "--out", s(&again)]));
}
