//! External models on Slurm: `run --slurm` on the folder that holds an
//! export and its predictions scores them, queues only the built-in
//! models' jobs, and the gather job writes what a local `score` writes.

use std::path::Path;
use std::time::Duration;

use crate::common::{assert_ok, root};
use crate::external::{export_small, write_all};
use crate::slurm::{cluster, crossaudit_in, logs, sh_task, submitted, text};

/// The small external design exported into `dir` with persistence's
/// rollouts (contaminated arm moved) as its predictions.
fn exported_with_predictions(dir: &Path) {
    let (idx, sha) = export_small(dir);
    write_all(dir, &idx, &sha);
}

fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).unwrap()))
        .collect();
    v.sort();
    v
}

/// The same per-cell files and cells.csv in both folders.
fn assert_same_cells(local: &Path, cluster: &Path) {
    assert_eq!(files(&local.join("cells")), files(&cluster.join("cells")), "cells/ differs");
    assert_eq!(std::fs::read(local.join("cells.csv")).unwrap(), std::fs::read(cluster.join("cells.csv")).unwrap());
    let report = std::fs::read_to_string(cluster.join("report/report.md")).unwrap();
    assert!(report.contains("fitted outside crossaudit"), "{report}");
}

#[test]
fn run_slurm_scores_the_predictions_and_queues_only_the_built_in_jobs() {
    let tmp = tempfile::tempdir().unwrap();
    let (local, slurm) = (tmp.path().join("local"), tmp.path().join("slurm"));
    exported_with_predictions(&local);
    exported_with_predictions(&slurm);
    let design = root().join("tests/designs/sim_external.design");
    let run = |dir: &Path| {
        crossaudit_in(&root(), &["run", design.to_str().unwrap(), "--out", dir.to_str().unwrap(), "--slurm"], &[])
    };
    // Without predictions for every job: refused, each missing job named.
    std::fs::remove_file(slurm.join("predictions/ext__disjoint__2.npy")).unwrap();
    let o = run(&slurm);
    assert!(!o.status.success() && text(&o).contains("ext/disjoint/2"), "{}", text(&o));
    assert!(!slurm.join("slurm/array.json").exists(), "nothing is prepared");
    exported_with_predictions(&slurm);
    let o = run(&slurm);
    assert_ok(&o);
    // 4 external jobs scored here; persistence's 4 are the array's.
    assert!(text(&o).contains("(4 of 8 jobs pending)"), "{}", text(&o));
    let array: serde_json::Value =
        serde_json::from_slice(&std::fs::read(slurm.join("slurm/array.json")).unwrap()).unwrap();
    let jobs: Vec<&str> = array["jobs"].as_array().unwrap().iter().map(|j| j.as_str().unwrap()).collect();
    let pending: Vec<usize> = (0..jobs.len()).filter(|k| jobs[*k].starts_with("still__")).collect();
    assert_eq!(pending.len(), 4, "{jobs:?}");
    // The array's tasks and the gather job, run as Slurm would run them.
    for k in pending {
        let o = sh_task(&root(), &slurm, k);
        assert_ok(&o);
    }
    assert_ok(&crossaudit_in(&root(), &["gather", slurm.to_str().unwrap()], &[]));
    assert_ok(&crossaudit_in(&root(), &["score", local.to_str().unwrap()], &[]));
    assert_same_cells(&local, &slurm);
}

#[test]
fn an_external_model_through_real_slurm_matches_a_local_score() {
    let test = "an_external_model_through_real_slurm_matches_a_local_score";
    let Some((_guard, cluster)) = cluster(test) else { return };
    let tmp = tempfile::tempdir().unwrap();
    let (local, dir) = (tmp.path().join("local"), tmp.path().join("cluster"));
    exported_with_predictions(&local);
    exported_with_predictions(&dir);
    let design = root().join("tests/designs/sim_external.design");
    let o = crossaudit_in(
        &root(),
        &["run", design.to_str().unwrap(), "--out", dir.to_str().unwrap(), "--slurm", "--submit", "--mem", "1G"],
        &cluster.env(),
    );
    let ids = submitted(&o);
    assert_eq!(ids.len(), 2, "{}", text(&o));
    let ids: Vec<&str> = ids.iter().map(String::as_str).collect();
    cluster.wait(&ids, Duration::from_secs(600), &dir);
    let gather_log = std::fs::read_to_string(dir.join("slurm/logs/gather.out")).unwrap_or_default();
    assert!(gather_log.contains("gathered 8 jobs"), "the gather job did not finish: {}", logs(&dir));
    assert_ok(&crossaudit_in(&root(), &["score", local.to_str().unwrap()], &[]));
    assert_same_cells(&local, &dir);
}
