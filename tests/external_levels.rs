//! External models in every design with outer levels: replicate draws,
//! per-seed draws and whole splits (a multiverse: tests/external.rs).
//! Persistence's own rollouts, exported per level and written as the
//! external model's predictions, must score to the built-in persistence
//! model's rows in every level, bit for bit.

use std::path::Path;

use crossaudit::model::{State, STATE};
use crossaudit::run::external::{npy, ExportIndex, ExportJob};

use crate::common::crossaudit;
use crate::common::{assert_ok, root};

/// tests/designs/sim_external.design with its `ext` model's history
/// removed and `outer` added: draws, per-seed draws or splits.
fn design(dir: &Path, outer: &str) -> String {
    let text = std::fs::read_to_string(root().join("tests/designs/sim_external.design")).unwrap();
    let mut text = text
        .replace(" actions standardized history 3", "")
        .replace("factor seed = 1..2", &format!("factor seed = 1..2\n{outer}"));
    if outer.contains("split") {
        text = text.replace("decide confirmed when", "decide confirmed on pooled when");
    }
    let path = dir.join("outer.design");
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

/// Persistence's rollouts from `job`'s starts, every step kept.
fn persistence(prepared: &crossaudit::split::Prepared, job: &ExportJob) -> Vec<f64> {
    let [s, k, _] = job.shape;
    let mut data = vec![0.0; s * k * STATE];
    let mut keep = |step: usize, states: &[State]| {
        for (i, x) in states.iter().enumerate() {
            let off = (i * k + step - 1) * STATE;
            data[off..off + STATE].copy_from_slice(x);
            // The contaminated arm moved a little, so that d has variance.
            if job.arm == "contaminated" {
                data[off] += 0.01 * job.seed as f64 * (i % 3) as f64;
            }
        }
    };
    let mut still = crossaudit::model::baseline::Persistence;
    crossaudit::rollout::trajectories(&mut still, &prepared.recordings, &prepared.split.starts, k, &mut keep, &[]);
    data
}

fn export_predict_score(outer: &str, want_levels: usize) {
    let tmp = tempfile::tempdir().unwrap();
    let path = design(tmp.path(), outer);
    let out = tmp.path().join("run");
    let o = crossaudit(&["export", &path, "--exploratory", "--out", out.to_str().unwrap()]);
    assert_ok(&o);
    let listed: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("export/levels.json")).unwrap()).unwrap();
    let levels: Vec<String> =
        listed["levels"].as_array().unwrap().iter().map(|l| l["level"].as_str().unwrap().into()).collect();
    assert_eq!(levels.len(), want_levels, "{outer}: {listed}");
    let file = crossaudit::design::load(Path::new(&path)).unwrap();
    let study = crossaudit::compile_study(&file.design);
    let all = study.levels();
    let mut jobs = 0;
    for id in &levels {
        let level = all.iter().find(|l| l.id == *id).unwrap();
        let level_file = crossaudit::design::DesignFile { design: level.design.clone(), ..file.clone() };
        let level_plan = &level.plan;
        let dir = out.join(id);
        let prepared = crossaudit::split::rebuild(&level_file, level_plan, &out.join("simulated_data"), &dir).unwrap();
        let bytes = std::fs::read(dir.join("export/export.json")).unwrap();
        let (idx, sha): (ExportIndex, String) =
            (serde_json::from_slice(&bytes).unwrap(), crossaudit::io::sha256_hex(&bytes));
        for job in &idx.jobs {
            std::fs::create_dir_all(dir.join("predictions")).unwrap();
            std::fs::write(dir.join(&job.predictions), npy::write(&job.shape, &persistence(&prepared, job)).unwrap())
                .unwrap();
            let d = serde_json::json!({"export_sha256": sha, "model": job.model, "arm": job.arm, "seed": job.seed});
            std::fs::write(dir.join(&job.description), d.to_string()).unwrap();
            jobs += 1;
        }
    }
    let o = crossaudit(&["score", out.to_str().unwrap()]);
    assert_ok(&o);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains(&format!("{jobs} external jobs scored now, 0 before")), "{outer}: {e}");
    // In every level, the external model's rows are persistence's.
    for id in &levels {
        let gathered = out.join(id).join("cells.csv");
        let cells = crossaudit::cells::read_cells(&gathered).unwrap_or_else(|e| panic!("{outer}: {id}: {e}"));
        let of = |model: &str| -> Vec<String> {
            let mut rows: Vec<String> = cells
                .iter()
                .filter(|c| &*c.model == model && &*c.arm == "disjoint" && c.horizon_s == 0.5)
                .map(|c| {
                    format!(
                        "{} {} {} {} {} {:?}",
                        c.arm,
                        c.seed,
                        c.recording,
                        c.horizon_s,
                        c.n_divergent,
                        c.fa_position_rmse_m.to_bits()
                    )
                })
                .collect();
            rows.sort();
            rows
        };
        assert!(!of("ext").is_empty(), "{outer}: {id}");
        assert_eq!(of("ext"), of("still"), "{outer}: {id}: the external rows are persistence's");
        assert!(cells.iter().any(|c| &*c.model == "ext" && &*c.arm == "contaminated"), "{outer}: {id}");
    }
    // The levels combined as `run` combines them, with the study's report.
    let report = std::fs::read_to_string(out.join("report/report.md")).unwrap_or_else(|e| panic!("{outer}: {e}"));
    assert!(report.contains("decision") || report.contains("CONFIRMED"), "{outer}: {report}");
}

#[test]
fn replicate_draws_with_an_external_model_export_and_score_per_draw() {
    export_predict_score("factor draw = 1..2", 2);
}

#[test]
fn per_seed_draws_with_an_external_model_export_and_score_per_seed() {
    export_predict_score("draws per seed", 2);
}

#[test]
fn whole_splits_with_an_external_model_export_and_score_per_split() {
    export_predict_score("factor split = 42..43", 2);
}
