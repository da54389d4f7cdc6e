//! `run --reuse`: a locked per-seed study extended with further seeds by an
//! amendment, the first seeds' jobs copied (identical inputs by content
//! key, files checked), only the new seeds trained, and every seed analysed
//! together; a folder that cannot be reused is refused before anything runs.

use std::path::Path;

use crate::common::crossaudit;

fn design(seeds: &str) -> String {
    format!(
        r#"study "reuse-check"
data simulated {{
  recordings 24 seed 7 strength 1.0 duration 15 s
  rate       100 Hz
  include    active(motor_motor_m1 > 1000) >= 200 samples
  duplicates group
}}
factor recording {{ evaluation 6 split_seed 42; starts 8 horizon 100 conditions trajectory }}
factor seed = {seeds}
validation 400 windows from 2 recordings seed 143
arm disjoint      {{ fit 2000 windows seed 42 }}
arm contaminated  {{ from disjoint replace 25% with evaluation windows exclude starts seed 7 }}
model world = mlp(32, 32, 32) inputs world
train {{ adam lr 1e-3 batch 256 epochs 4 cosine patience 4 action_noise 0.02 }}
endpoint primary fa_position_rmse at 1.0 s cap 2 m model world
contrast contaminated - disjoint
estimate crossed_mom level 0.95 df seed - 1
draws per seed
decide confirmed when optimism >= 10% and upper < 0
"#
    )
}

fn said(o: &std::process::Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

/// The per-cell rows of `seeds` in a run's cells.csv, sorted.
fn rows(dir: &Path, seeds: &[&str]) -> Vec<String> {
    let text = std::fs::read_to_string(dir.join("cells.csv")).unwrap();
    let mut v: Vec<String> = text
        .lines()
        .skip(1)
        .filter(|l| seeds.iter().any(|s| l.split(',').nth(2) == Some(s)))
        .map(String::from)
        .collect();
    v.sort();
    v
}

#[test]
fn an_amended_per_seed_study_trains_only_its_new_seeds() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("study.design");
    let p = path.to_str().unwrap();
    std::fs::write(&path, design("1..2")).unwrap();
    assert!(crossaudit(&["lock", p]).status.success());
    let first = dir.path().join("first");
    let o = crossaudit(&["run", p, "--out", first.to_str().unwrap(), "--workers", "2"]);
    assert!(o.status.success(), "{}", said(&o));
    assert!(said(&o).contains("4 cells trained, 0 resumed"), "{}", said(&o));

    // The amendment: two more seeds (two more draws), the first two kept.
    std::fs::write(&path, design("1..4")).unwrap();
    let o = crossaudit(&["lock", p, "--amend", "two more seeds of the same protocol"]);
    assert!(o.status.success(), "{}", said(&o));
    let second = dir.path().join("second");
    let o = crossaudit(&[
        "run",
        p,
        "--out",
        second.to_str().unwrap(),
        "--workers",
        "2",
        "--reuse",
        first.to_str().unwrap(),
    ]);
    let s = said(&o);
    assert!(o.status.success(), "{s}");
    assert!(s.contains("4 cells trained, 4 resumed"), "only the new seeds train: {s}");
    // The first seeds' cells are the first run's, byte for byte; the new
    // seeds' are new; all four seeds are analysed together.
    assert_eq!(rows(&second, &["1", "2"]), rows(&first, &["1", "2"]));
    assert_eq!(rows(&second, &["3", "4"]).len(), 2 * 2 * 6);
    let md = std::fs::read_to_string(second.join("report/report.md")).unwrap();
    assert!(md.contains("over 6 recordings x 4 seeds"), "{md}");
    assert!(md.contains("jobs were copied from the earlier run"), "{md}");
    // Each copied record names the run it came from.
    let rec = std::fs::read_to_string(second.join("draw-1/jobs/world__disjoint__1.json")).unwrap();
    assert!(rec.contains("\"reused_from\"") && rec.contains("\"key\""), "{rec}");
    let fresh = std::fs::read_to_string(second.join("draw-3/jobs/world__disjoint__3.json")).unwrap();
    assert!(!fresh.contains("\"reused_from\"") && fresh.contains("\"key\""), "{fresh}");
}

#[test]
fn a_folder_that_cannot_be_reused_is_refused_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("study.design");
    std::fs::write(&path, design("1..2")).unwrap();
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let out = dir.path().join("out");
    let o = crossaudit(&[
        "run",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--reuse",
        empty.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(said(&o).contains("it holds no finished job"), "{}", said(&o));
    assert!(!out.join("draw-1/cells.csv").exists());
}

/// A run folder written before the content hashes were of the values read
/// (no `content_hashes` in its run.json: its hashes are of the logs'
/// text) is refused by name when resumed and when reused: not taken for
/// other data, and not silently trained again for want of a matching key.
#[test]
fn a_run_that_hashed_the_logs_text_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("study.design");
    let p = path.to_str().unwrap();
    std::fs::write(&path, design("1..2")).unwrap();
    let first = dir.path().join("first");
    let o = crossaudit(&["run", p, "--out", first.to_str().unwrap(), "--workers", "2"]);
    assert!(o.status.success(), "{}", said(&o));
    // As an earlier build wrote it: each level's run.json without the field.
    for level in ["draw-1", "draw-2"] {
        let record = first.join(level).join("run.json");
        let mut json: serde_json::Value = serde_json::from_slice(&std::fs::read(&record).unwrap()).unwrap();
        assert_eq!(json["content_hashes"], "values", "{json}");
        json.as_object_mut().unwrap().remove("content_hashes");
        json.as_object_mut().unwrap().remove("seal");
        std::fs::write(&record, serde_json::to_string_pretty(&json).unwrap()).unwrap();
    }
    let o = crossaudit(&["run", p, "--out", first.to_str().unwrap(), "--workers", "2"]);
    assert!(!o.status.success(), "{}", said(&o));
    assert!(
        said(&o).contains("whose content hashes of the logs (in its audit and manifests) are of their text"),
        "{}",
        said(&o)
    );
    let second = dir.path().join("second");
    let o = crossaudit(&["run", p, "--out", second.to_str().unwrap(), "--reuse", first.to_str().unwrap()]);
    assert!(!o.status.success(), "{}", said(&o));
    assert!(said(&o).contains("whose content hashes of the logs are of their text"), "{}", said(&o));
    assert!(!second.join("draw-1/cells.csv").exists());
}
