//! External models: `crossaudit export` and `crossaudit score` with the
//! real binary on real files. The built-in MLP's own rollouts, written as
//! predictions, score to the quickstart's per-cell rows byte for byte;
//! persistence's rollouts score to persistence's rows; non-finite states
//! count as divergence; every refusal names what is wrong.

use std::path::{Path, PathBuf};
use std::process::Output;

use crossaudit::model::{Learned, Net, State, STATE};
use crossaudit::run::external::{npy, ExportIndex};

use crate::common::crossaudit;
use crate::common::{assert_ok, root};

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[track_caller]
fn assert_fails_with(o: &Output, needles: &[&str]) -> String {
    let e = stderr(o);
    assert!(!o.status.success(), "expected a refusal, got success:\n{e}");
    assert!(!e.contains("panicked"), "{e}");
    for n in needles {
        assert!(e.contains(n), "expected {n:?} in:\n{e}");
    }
    e
}

pub(crate) fn index(dir: &Path) -> (ExportIndex, String) {
    let bytes = std::fs::read(dir.join("export/export.json")).unwrap();
    (serde_json::from_slice(&bytes).unwrap(), crossaudit::io::sha256_hex(&bytes))
}

/// Writes `predictions/STEM.npy` (starts x steps x 14, row-major) and its description.
pub(crate) fn write_predictions(dir: &Path, job: &crossaudit::run::external::ExportJob, sha: &str, data: &[f64]) {
    std::fs::create_dir_all(dir.join("predictions")).unwrap();
    std::fs::write(dir.join(&job.predictions), npy::write(&job.shape, data).unwrap()).unwrap();
    let d = serde_json::json!({"export_sha256": sha, "model": job.model, "arm": job.arm, "seed": job.seed});
    std::fs::write(dir.join(&job.description), d.to_string()).unwrap();
}

fn files_under(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).unwrap()))
        .collect();
    v.sort();
    v
}

#[test]
fn the_mlps_own_rollouts_as_predictions_score_to_the_quickstarts_cells_byte_for_byte() {
    let tmp = tempfile::tempdir().unwrap();
    let (a, b) = (tmp.path().join("builtin"), tmp.path().join("external"));
    let o = crossaudit(&["run", "designs/quickstart.design", "--out", a.to_str().unwrap()]);
    assert_ok(&o);
    // Not a terminal: a line per finished job, with its count, on standard error.
    let e = stderr(&o);
    assert!(e.contains("done world/disjoint/1 (") && e.contains("(20/20)"), "{e}");
    let o = crossaudit(&["export", "tests/designs/quickstart_external.design", "--out", b.to_str().unwrap()]);
    assert_ok(&o);
    let (idx, sha) = index(&b);
    assert!(String::from_utf8_lossy(&o.stdout).contains(&sha), "export prints its sha256");
    assert_eq!(idx.jobs.len(), 10, "world x 2 arms x 5 seeds");

    // The built-in run's split and its trained world MLPs, rolled out by
    // the library with every step's states kept.
    let file = crossaudit::design::load(&root().join("designs/quickstart.design")).unwrap();
    let plan = crossaudit::compile(&file.design);
    let prepared = crossaudit::split::rebuild(&file, &plan, &a.join("simulated_data"), &a).unwrap();
    for job in &idx.jobs {
        write_predictions(&b, job, &sha, &mlp_rollouts(&a, job, &prepared, &[64, 64, 64]));
    }
    let o = crossaudit(&["score", b.to_str().unwrap()]);
    assert_ok(&o);
    let e = stderr(&o);
    assert!(e.contains("scored world/disjoint/1") && e.contains("10 external jobs scored now"), "{e}");
    let (x, y) = (files_under(&a.join("cells")), files_under(&b.join("cells")));
    assert_eq!(x.len(), 20, "world and relative x 2 arms x 5 seeds");
    assert_eq!(x.iter().map(|f| &f.0).collect::<Vec<_>>(), y.iter().map(|f| &f.0).collect::<Vec<_>>());
    for ((name, left), (_, right)) in x.iter().zip(&y) {
        assert!(left == right, "cells/{name} differs between run and score");
    }
    assert_eq!(std::fs::read(a.join("cells.csv")).unwrap(), std::fs::read(b.join("cells.csv")).unwrap());
    let report = std::fs::read_to_string(b.join("report/report.md")).unwrap();
    assert!(report.contains("fitted outside crossaudit"), "the report says which models came from predictions");

    // Scoring again verifies and redoes nothing; edited predictions are refused.
    let o = crossaudit(&["score", b.to_str().unwrap()]);
    assert_ok(&o);
    assert!(stderr(&o).contains("0 external jobs scored now, 10 before"), "{}", stderr(&o));
    let p = b.join(&idx.jobs[3].predictions);
    let mut bytes = std::fs::read(&p).unwrap();
    let n = bytes.len();
    bytes[n - 3] ^= 1;
    std::fs::write(&p, bytes).unwrap();
    assert_fails_with(&crossaudit(&["score", b.to_str().unwrap()]), &[&idx.jobs[3].predictions, "sha256"]);
}

/// The rollouts of the built-in MLP that `run` trained into `run_dir` for
/// `job`, every step's states kept: what an external model's predictions
/// hold (starts x steps x 14, row-major).
fn mlp_rollouts(
    run_dir: &Path,
    job: &crossaudit::run::external::ExportJob,
    prepared: &crossaudit::split::Prepared,
    widths: &[usize],
) -> Vec<f64> {
    let stem = job.stem();
    let net = Net::load(widths, &run_dir.join(format!("models/{stem}.safetensors"))).unwrap();
    let meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run_dir.join(format!("models/{stem}.json"))).unwrap()).unwrap();
    let features: crossaudit::model::FeatureMap = serde_json::from_value(meta["features"].clone()).unwrap();
    assert_eq!(features, job.standardizers, "{stem}: the export's standardizers are the MLP's");
    let [s, k, _] = job.shape;
    let mut data = vec![0.0; s * k * STATE];
    let mut keep = |step: usize, states: &[State]| {
        for (i, x) in states.iter().enumerate() {
            let off = (i * k + step - 1) * STATE;
            data[off..off + STATE].copy_from_slice(x);
        }
    };
    let mut model = Learned::new(&net, &features);
    crossaudit::rollout::trajectories(&mut model, &prepared.recordings, &prepared.split.starts, k, &mut keep, &[]);
    data
}

#[test]
fn a_multiverse_with_an_external_model_is_exported_per_level_and_scores_to_the_built_in_cells() {
    let tmp = tempfile::tempdir().unwrap();
    let (a, b) = (tmp.path().join("builtin"), tmp.path().join("external"));
    assert_ok(&crossaudit(&[
        "run",
        "tests/designs/sim_multiverse.design",
        "--exploratory",
        "--out",
        a.to_str().unwrap(),
    ]));
    let o = crossaudit(&[
        "export",
        "tests/designs/sim_multiverse_external.design",
        "--exploratory",
        "--out",
        b.to_str().unwrap(),
    ]);
    assert_ok(&o);
    assert!(stderr(&o).contains("2 levels, each exported to"), "{}", stderr(&o));
    let listed: serde_json::Value =
        serde_json::from_slice(&std::fs::read(b.join("export/levels.json")).unwrap()).unwrap();
    let levels: Vec<String> =
        listed["levels"].as_array().unwrap().iter().map(|l| l["level"].as_str().unwrap().into()).collect();
    assert_eq!(levels.len(), 2, "one export per specification: {listed}");

    // Each level's split, rebuilt by the library, and the MLPs `run` trained there.
    let file = crossaudit::design::load(&root().join("tests/designs/sim_multiverse.design")).unwrap();
    let study = crossaudit::compile_study(&file.design);
    let all = study.levels();
    for id in &levels {
        let level = all.iter().find(|l| l.id == *id).unwrap();
        let level_file = crossaudit::design::DesignFile { design: level.design.clone(), ..file.clone() };
        let level_plan = &level.plan;
        let prepared =
            crossaudit::split::rebuild(&level_file, level_plan, &a.join("simulated_data"), &a.join(id)).unwrap();
        let (idx, sha) = index(&b.join(id));
        assert_eq!(idx.jobs.len(), 4, "world x 2 arms x 2 seeds");
        for job in &idx.jobs {
            write_predictions(&b.join(id), job, &sha, &mlp_rollouts(&a.join(id), job, &prepared, &[32, 32, 32]));
        }
    }
    // One level's predictions missing: named, by level, and nothing runs.
    let held = b.join(&levels[1]).join("predictions");
    std::fs::rename(&held, tmp.path().join("held")).unwrap();
    let e =
        assert_fails_with(&crossaudit(&["score", b.to_str().unwrap()]), &["4 of 8", &format!("{}/world/", levels[1])]);
    assert!(!b.join("multiverse_cells.csv").exists(), "{e}");
    std::fs::rename(tmp.path().join("held"), &held).unwrap();
    let o = crossaudit(&["score", b.to_str().unwrap()]);
    assert_ok(&o);
    assert!(stderr(&o).contains("4 external jobs scored now, 4 before"), "{}", stderr(&o));
    for id in &levels {
        let (x, y) = (files_under(&a.join(id).join("cells")), files_under(&b.join(id).join("cells")));
        assert_eq!(x.len(), 8, "world and relative x 2 arms x 2 seeds");
        assert_eq!(x, y, "{id}: per-cell files differ between run and score");
        let report = std::fs::read_to_string(b.join(id).join("report/report.md")).unwrap();
        assert!(report.contains("fitted outside crossaudit"), "{id}: the level's report says so");
    }
    assert_eq!(
        std::fs::read(a.join("multiverse_cells.csv")).unwrap(),
        std::fs::read(b.join("multiverse_cells.csv")).unwrap(),
        "the combined cells"
    );
    let combined = std::fs::read_to_string(b.join("report/report.md")).unwrap();
    assert!(combined.contains("fitted outside crossaudit"), "{combined}");
    // A level's folder alone is refused: the study is scored whole.
    assert_fails_with(&crossaudit(&["score", b.join(&levels[0]).to_str().unwrap()]), &["score the study's folder"]);
}

/// A fresh export of the small external design into `dir`.
pub(crate) fn export_small(dir: &Path) -> (ExportIndex, String) {
    let o = crossaudit(&["export", "tests/designs/sim_external.design", "--out", dir.to_str().unwrap()]);
    assert_ok(&o);
    // The design is not locked: export says so before any model is fitted.
    assert!(stderr(&o).contains("is not locked, so the scores will be NOT PREREGISTERED"), "{}", stderr(&o));
    index(dir)
}

/// Persistence's own rollouts (the library's baseline, renormalised as
/// every rollout is) as an external model's predictions; on the
/// contaminated arm, positions offset by 1 cm per seed times the start's
/// index modulo 3 (so the arms differ).
pub(crate) fn persistence(dir: &Path, job: &crossaudit::run::external::ExportJob) -> Vec<f64> {
    let file = crossaudit::design::load(&root().join("tests/designs/sim_external.design")).unwrap();
    let plan = crossaudit::compile(&file.design);
    let prepared = crossaudit::split::rebuild(&file, &plan, &dir.join("simulated_data"), dir).unwrap();
    let [s, k, _] = job.shape;
    let mut data = vec![0.0; s * k * STATE];
    let mut keep = |step: usize, states: &[State]| {
        for (i, x) in states.iter().enumerate() {
            let off = (i * k + step - 1) * STATE;
            data[off..off + STATE].copy_from_slice(x);
            if job.arm == "contaminated" {
                data[off] += 0.01 * job.seed as f64 * (i % 3) as f64;
            }
        }
    };
    let mut still = crossaudit::model::baseline::Persistence;
    crossaudit::rollout::trajectories(&mut still, &prepared.recordings, &prepared.split.starts, k, &mut keep, &[]);
    data
}

pub(crate) fn write_all(dir: &Path, idx: &ExportIndex, sha: &str) {
    for job in &idx.jobs {
        write_predictions(dir, job, sha, &persistence(dir, job));
    }
}

#[test]
fn persistences_rollouts_score_as_persistence_and_non_finite_states_diverge() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let (idx, sha) = export_small(&dir);
    write_all(&dir, &idx, &sha);
    // One start of contaminated seed 1 turns NaN at step 30 (before the
    // 0.5 s horizon) and is finite again afterwards: divergent from there on.
    let job = idx.jobs.iter().find(|j| j.arm == "contaminated" && j.seed == 1).unwrap();
    let mut data = persistence(&dir, job);
    data[(7 * job.shape[1] + 29) * STATE + 2] = f64::NAN;
    write_predictions(&dir, job, &sha, &data);
    let o = crossaudit(&["score", dir.to_str().unwrap()]);
    assert_ok(&o);
    assert!(stderr(&o).contains("1 of 40 predicted trajectories have a non-finite state"), "{}", stderr(&o));
    let report = std::fs::read_to_string(dir.join("report/report.md")).unwrap();
    assert!(report.contains("ext/contaminated/1: 1 of 40 predicted trajectories have a non-finite state"), "{report}");

    let cells = crossaudit::cells::read_cells(&dir.join("cells.csv")).unwrap();
    let rows = |model: &str, arm: &str, seed: u64| -> Vec<_> {
        cells.iter().filter(|c| c.model == model && c.arm == arm && c.seed == seed && c.horizon_s == 0.5).collect()
    };
    // Disjoint: persistence's predictions give persistence's numbers bit for bit.
    for seed in [1, 2] {
        let (ext, still) = (rows("ext", "disjoint", seed), rows("still", "disjoint", seed));
        assert_eq!(ext.len(), 4);
        for (e, s) in ext.iter().zip(&still) {
            assert_eq!(e.recording, s.recording);
            assert_eq!(e.fa_position_rmse_m.to_bits(), s.fa_position_rmse_m.to_bits(), "{}", e.recording);
            assert_eq!(e.n_divergent, s.n_divergent);
            assert_eq!(e.velocity_rmse_mps.map(f64::to_bits), s.velocity_rmse_mps.map(f64::to_bits));
            assert_eq!(e.attitude_rmse_deg.map(f64::to_bits), s.attitude_rmse_deg.map(f64::to_bits));
        }
    }
    // The NaN start: one more divergent start than seed 2's twin on its recording.
    let starts = std::fs::read_to_string(dir.join("export/starts.csv")).unwrap();
    let recording = starts.lines().nth(8).unwrap().split(',').nth(1).unwrap().to_string();
    let nan_row = rows("ext", "contaminated", 1).into_iter().find(|c| c.recording == recording).unwrap().clone();
    let still_row = rows("still", "contaminated", 1).into_iter().find(|c| c.recording == recording).unwrap().clone();
    assert_eq!(nan_row.n_divergent, still_row.n_divergent + 1, "the NaN start is divergent at 0.5 s");
    let total: u32 = rows("ext", "contaminated", 1).iter().map(|c| c.n_divergent).sum();
    let twin: u32 = rows("still", "contaminated", 1).iter().map(|c| c.n_divergent).sum();
    assert_eq!(total, twin + 1, "exactly one start more");
}

#[test]
fn histories_are_the_samples_before_each_window_and_start() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let (idx, _) = export_small(&dir);
    assert_eq!(idx.history, 3);
    let read = |name: &str, shape: &[usize]| {
        npy::read(&std::fs::read(dir.join("export").join(name)).unwrap(), shape).unwrap().data
    };
    let n = idx.starts;
    let states = read("starts_states.npy", &[n, STATE]);
    let history = read("starts_history.npy", &[n, 3, 18]);
    let actions = read("starts_actions.npy", &[n, idx.steps, 4]);
    let data = dir.join("simulated_data");
    let file = crossaudit::design::load(&root().join("tests/designs/sim_external.design")).unwrap();
    let plan = crossaudit::compile(&file.design);
    let prepared = crossaudit::split::rebuild(&file, &plan, &data, &dir).unwrap();
    for (i, w) in prepared.split.starts.iter().enumerate() {
        let r = &prepared.recordings[w.recording];
        assert_eq!(&states[i * STATE..(i + 1) * STATE], &r.state[w.t][..]);
        for back in 0..3 {
            let t = w.t.saturating_sub(3 - back);
            let row = &history[(i * 3 + back) * 18..(i * 3 + back + 1) * 18];
            assert_eq!(&row[..STATE], &r.state[t][..], "start {i}, history sample {back}");
            assert_eq!(&row[STATE..], &r.action[t][..]);
        }
        assert_eq!(&actions[i * idx.steps * 4..i * idx.steps * 4 + 4], &r.action[w.t][..], "first action is u_t");
    }
    // Fit windows and inputs: the split's, in the declared map (relative:
    // absolute position is not an input), through the recorded standardizers.
    let job = &idx.jobs[0];
    let inputs = read(&job.files["fit_inputs"], &[3000, 18]);
    let fit_states = read(&idx.fit["disjoint"]["states"], &[3000, STATE]);
    let fit_actions = read(&idx.fit["disjoint"]["actions"], &[3000, 4]);
    let windows = prepared.split.fit("disjoint").unwrap();
    for (i, w) in windows.iter().enumerate().step_by(97) {
        let r = &prepared.recordings[w.recording];
        assert_eq!(&fit_states[i * STATE..(i + 1) * STATE], &r.state[w.t][..]);
        assert_eq!(&fit_actions[i * 4..(i + 1) * 4], &r.action[w.t][..]);
        let mut x = [0f32; 18];
        job.standardizers.input(&r.state[w.t], &r.action[w.t], &mut x);
        let exported: Vec<f64> = inputs[i * 18..(i + 1) * 18].to_vec();
        assert_eq!(exported, x.iter().map(|v| f64::from(*v)).collect::<Vec<_>>(), "window {i}");
        assert!(exported[0..3].iter().all(|v| *v == 0.0), "relative inputs carry no position: {exported:?}");
    }
}

#[test]
fn score_refuses_what_it_cannot_trust_and_names_it() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let (idx, sha) = export_small(&dir);
    let d = dir.to_str().unwrap();
    let job = &idx.jobs[0];
    let good = persistence(&dir, job);
    let p = job.predictions.as_str();

    // Nothing there: every job named.
    let e = assert_fails_with(&crossaudit(&["score", d]), &["4 of 4 external jobs have no predictions", p]);
    assert!(e.contains("ext/contaminated/2"), "{e}");

    // Wrong shape.
    let [s, k, _] = job.shape;
    std::fs::create_dir_all(dir.join("predictions")).unwrap();
    std::fs::write(dir.join(p), npy::write(&[s, k - 1, STATE], &good[..s * (k - 1) * STATE]).unwrap()).unwrap();
    write_predictions_description(&dir, job, &sha);
    assert_fails_with(
        &crossaudit(&["score", d]),
        &[p, &format!("shape [{s}, {}, 14], expected [{s}, {k}, 14]", k - 1)],
    );
    // Wrong dtype: float32.
    std::fs::write(dir.join(p), npy_with(&job.shape, "<f4", false)).unwrap();
    assert_fails_with(&crossaudit(&["score", d]), &[p, "dtype <f4, expected <f8"]);
    // Fortran order.
    std::fs::write(dir.join(p), npy_with(&job.shape, "<f8", true)).unwrap();
    assert_fails_with(&crossaudit(&["score", d]), &[p, "Fortran order"]);
    // Not a .npy at all.
    std::fs::write(dir.join(p), b"x,y,z\n1,2,3\n").unwrap();
    assert_fails_with(&crossaudit(&["score", d]), &[p, "not a NumPy .npy file"]);
    // Predictions from another export.
    write_predictions(&dir, job, &"0".repeat(64), &good);
    assert_fails_with(&crossaudit(&["score", d]), &[&job.description, "predictions from another export"]);
    // A description of another job.
    write_predictions(&dir, job, &sha, &good);
    let other = &idx.jobs[1];
    let desc = serde_json::json!({"export_sha256": sha, "model": other.model, "arm": other.arm, "seed": other.seed});
    std::fs::write(dir.join(&job.description), desc.to_string()).unwrap();
    assert_fails_with(&crossaudit(&["score", d]), &[&job.description, "describes job ext/disjoint/2"]);
    write_predictions(&dir, job, &sha, &good);
    // A duplicated job: the same job under another spelling of its seed.
    let dup = dir.join(format!("predictions/{}__{}__0{}.npy", job.model, job.arm, job.seed));
    std::fs::copy(dir.join(p), &dup).unwrap();
    assert_fails_with(&crossaudit(&["score", d]), &["names job ext/disjoint/1 again", "one file per job"]);
    std::fs::remove_file(&dup).unwrap();
    // A file named after no job.
    let stray = dir.join("predictions/gru__disjoint__1.npy");
    std::fs::copy(dir.join(p), &stray).unwrap();
    assert_fails_with(&crossaudit(&["score", d]), &["gru__disjoint__1.npy", "names no external job"]);
    std::fs::remove_file(&stray).unwrap();

    // An edited export array, then an edited index: named, nothing scored.
    let fit = dir.join("export").join(&idx.fit["disjoint"]["states"]);
    let original = std::fs::read(&fit).unwrap();
    let mut edited = original.clone();
    let n = edited.len();
    edited[n - 1] ^= 0x10;
    std::fs::write(&fit, &edited).unwrap();
    assert_fails_with(
        &crossaudit(&["score", d]),
        &["fit_disjoint_states.npy", "is not what `crossaudit export` wrote"],
    );
    std::fs::write(&fit, &original).unwrap();
    let index_path = dir.join("export/export.json");
    let original = std::fs::read_to_string(&index_path).unwrap();
    std::fs::write(&index_path, original.replacen("\"history\": 3", "\"history\": 2", 1)).unwrap();
    assert_fails_with(&crossaudit(&["score", d]), &["export.json", "is not what `crossaudit export` wrote"]);
    std::fs::write(&index_path, &original).unwrap();
    assert!(!dir.join("jobs").exists(), "nothing was scored while the export or a prediction was refused");

    // One job present: scored and kept; the missing ones named.
    let e = assert_fails_with(
        &crossaudit(&["score", d]),
        &["3 of 4 external jobs have no predictions", "the 1 present are scored and kept"],
    );
    assert!(!e.contains(p), "{e}");
    assert!(dir.join(format!("jobs/{}.json", job.stem())).is_file());
    assert!(!dir.join("cells.csv").exists(), "no cells.csv until every job is there");
    // Two refused and one missing: every problem named in one run.
    let (j1, j2) = (&idx.jobs[1], &idx.jobs[2]);
    std::fs::write(dir.join(&j1.predictions), npy_with(&j1.shape, "<f4", false)).unwrap();
    write_predictions_description(&dir, j1, &sha);
    std::fs::write(dir.join(&j2.predictions), b"x,y\n").unwrap();
    write_predictions_description(&dir, j2, &sha);
    assert_fails_with(
        &crossaudit(&["score", d]),
        &[
            "2 of 4 external jobs' predictions are refused, and 1 have none",
            &j1.predictions,
            "dtype <f4, expected <f8",
            &j2.predictions,
            "not a NumPy .npy file",
            &idx.jobs[3].predictions,
        ],
    );
    write_all(&dir, &idx, &sha);
    assert_ok(&crossaudit(&["score", d]));
}

/// The description of `job`'s predictions (the file itself written apart).
fn write_predictions_description(dir: &Path, job: &crossaudit::run::external::ExportJob, sha: &str) {
    let d = serde_json::json!({"export_sha256": sha, "model": job.model, "arm": job.arm, "seed": job.seed});
    std::fs::write(dir.join(&job.description), d.to_string()).unwrap();
}

/// A `.npy` of zeros of `shape` with dtype `descr`, in Fortran order if asked.
fn npy_with(shape: &[usize; 3], descr: &str, fortran: bool) -> Vec<u8> {
    use npyz::WriterBuilder;
    let n: usize = shape.iter().product();
    let shape: Vec<u64> = shape.iter().map(|&d| d as u64).collect();
    let mut buf = Vec::new();
    let order = if fortran { npyz::Order::Fortran } else { npyz::Order::C };
    if descr == "<f4" {
        let mut w = npyz::WriteOptions::<f32>::new()
            .default_dtype()
            .shape(&shape)
            .order(order)
            .writer(&mut buf)
            .begin_nd()
            .unwrap();
        w.extend(std::iter::repeat_n(0f32, n)).unwrap();
        w.finish().unwrap();
    } else {
        let mut w = npyz::WriteOptions::<f64>::new()
            .default_dtype()
            .shape(&shape)
            .order(order)
            .writer(&mut buf)
            .begin_nd()
            .unwrap();
        w.extend(std::iter::repeat_n(0f64, n)).unwrap();
        w.finish().unwrap();
    }
    buf
}

#[test]
fn run_train_and_slurm_refuse_an_external_design_before_writing_anything() {
    let tmp = tempfile::tempdir().unwrap();
    for args in [
        vec!["run", "tests/designs/sim_external.design", "--out"],
        vec![
            "train",
            "tests/designs/sim_external.design",
            "--model",
            "ext",
            "--arm",
            "disjoint",
            "--seed",
            "1",
            "--out",
        ],
        vec!["run", "tests/designs/sim_external.design", "--slurm", "--out"],
    ] {
        let out: PathBuf = tmp.path().join(args[0]);
        let mut a = args.clone();
        a.push(out.to_str().unwrap());
        assert_fails_with(&crossaudit(&a), &["external models (ext)", "crossaudit export"]);
        assert!(!out.exists(), "{args:?} wrote {}", out.display());
    }
    // A design without external models has nothing to export.
    let out = tmp.path().join("none");
    assert_fails_with(
        &crossaudit(&["export", "tests/designs/sim_small.design", "--out", out.to_str().unwrap()]),
        &["no external model"],
    );
    assert!(!out.exists());
    // Absurd worker counts are refused at once (the progress display has a line per worker).
    assert_fails_with(
        &crossaudit(&["score", tmp.path().to_str().unwrap(), "--workers", "1000000000000"]),
        &["workers"],
    );
    // Score of a folder that was never exported.
    assert_fails_with(&crossaudit(&["score", tmp.path().to_str().unwrap()]), &["crossaudit export DESIGN --out DIR"]);
}

/// Predicted quaternions that cannot be an attitude (all zeros, which
/// renormalising leaves at zero and scores as 180 degrees; components of
/// 1e308, whose squares overflow and which scored as 0 degrees) are
/// refused, naming the start and the step; a quaternion off unit length by
/// less than the tolerance is renormalised and scored.
#[test]
fn predicted_quaternions_off_unit_length_are_refused_by_start_and_step() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let (idx, sha) = export_small(&dir);
    write_all(&dir, &idx, &sha);
    let d = dir.to_str().unwrap();
    let job = &idx.jobs[0];
    let k = job.shape[1];
    let good = persistence(&dir, job);
    let at = |start: usize, step: usize| (start * k + step - 1) * STATE;
    let mut data = good.clone();
    data[at(3, 5) + 6..at(3, 5) + 10].copy_from_slice(&[0.0; 4]);
    data[at(7, 1) + 6..at(7, 1) + 10].copy_from_slice(&[1e308, 1e308, 0.0, 0.0]);
    write_predictions(&dir, job, &sha, &data);
    let e = assert_fails_with(
        &crossaudit(&["score", d]),
        &[&job.predictions, "2 predicted state(s) have a quaternion", "start 3, step 5: length 0e0", "start 7, step 1"],
    );
    assert!(e.contains("more than 0.1"), "{e}");
    // 5% long: renormalised, scored as the unit quaternion is.
    let mut data = good.clone();
    for v in &mut data[at(3, 5) + 6..at(3, 5) + 10] {
        *v *= 1.05;
    }
    write_predictions(&dir, job, &sha, &data);
    assert_ok(&crossaudit(&["score", d]));
}
