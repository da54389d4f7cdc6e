//! Any number of state and action dimensions (`data csv`): body rates,
//! further predicted columns, exogenous columns after the reference, and
//! any number of actions reach the models, the rollouts, the export and
//! the scoring of external predictions with the widths the data declare.

use std::io::Read;
use std::path::Path;

use crossaudit::data::{load_recording, Layout};
use crossaudit::design::{ActionScaling, InputMap, TargetKind};
use crossaudit::model::{Engine, FeatureMap, NetError, Slots, State};
use crossaudit::run::external::{npy, ExportIndex, ExportJob};

use crate::common::crossaudit;
use crate::common::{assert_ok, root, stderr};

const WIDE: &str = "designs/logs/rotorpy_wide.design";

/// One RotorPy log's columns by header name, parsed here with the csv
/// crate (not crossaudit's reader).
fn raw_columns(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut text = String::new();
    flate2::read::GzDecoder::new(std::fs::File::open(path).unwrap()).read_to_string(&mut text).unwrap();
    let mut rdr = csv::Reader::from_reader(text.as_bytes());
    let header: Vec<String> = rdr.headers().unwrap().iter().map(String::from).collect();
    let rows = rdr.records().map(|r| r.unwrap().iter().map(|v| v.parse().unwrap()).collect()).collect();
    (header, rows)
}

#[test]
fn the_wide_rotorpy_layout_reads_every_declared_column_into_its_slot() {
    let file = crossaudit::design::load(&root().join(WIDE)).unwrap();
    let spec = &file.design.data;
    // 17 predicted (position, velocity, quaternion, body rates, rotor
    // speeds), then the reference and the wind: exogenous.
    assert_eq!(spec.slots(), Slots::full(23, 4, 17, true));
    let path = root().join("tests/fixtures/rotorpy/logs/R5_lissajous_medium_rep2.csv.gz");
    let rec = load_recording(&path, &Layout::new(spec).unwrap()).unwrap();
    let (header, rows) = raw_columns(&path);
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let slots = [
        "mocap_x",
        "mocap_y",
        "mocap_z",
        "mocap_xdot",
        "mocap_ydot",
        "mocap_zdot",
        "mocap_qw",
        "mocap_qx",
        "mocap_qy",
        "mocap_qz",
        "mocap_wx",
        "mocap_wy",
        "mocap_wz",
        "r1",
        "r2",
        "r3",
        "r4",
        "xdes",
        "ydes",
        "zdes",
        "windx",
        "windy",
        "windz",
    ];
    assert_eq!((rec.rows, rec.slots.predicted), (rows.len(), 17));
    for (k, row) in rows.iter().enumerate() {
        let want: Vec<f64> = slots.iter().map(|c| row[col(c)]).collect();
        assert_eq!(rec.state[k], want, "row {k}");
        let actions: Vec<f64> = ["r1des", "r2des", "r3des", "r4des"].iter().map(|c| row[col(c)] / 2500.0).collect();
        assert_eq!(rec.action[k], actions, "row {k}");
    }
}

/// Windows of a layout with 3 actions, body rates, one predicted extra and
/// two exogenous columns after the reference.
fn odd_windows(slots: &Slots, n: usize) -> Vec<(State, State, State)> {
    (0..n)
        .map(|k| {
            let a = k as f64 * 0.05;
            let mut x: Vec<f64> = (0..slots.state).map(|j| (a * (j + 1) as f64).sin()).collect();
            x[6..10].copy_from_slice(&[1.0, 0.0, 0.0, 0.0]);
            let mut next = x.clone();
            for (j, v) in next.iter_mut().enumerate().take(slots.predicted) {
                *v += 0.01 * (a + j as f64).cos();
            }
            (x, (0..slots.action).map(|j| 0.5 + 0.1 * (a * j as f64).cos()).collect(), next)
        })
        .collect()
}

#[test]
fn the_relative_map_subtracts_position_from_the_reference_wherever_it_sits() {
    let slots = Slots::full(19, 3, 14, true);
    let x: Vec<f64> = (0..19).map(|j| j as f64 * 0.25).collect();
    let u = vec![0.1, 0.2, 0.3];
    let raw = crossaudit::model::features::raw_input(&slots, InputMap::Relative, &x, &u);
    assert_eq!(raw.len(), 22);
    assert_eq!(raw[..3], [0.0; 3], "absolute position is not an input");
    assert_eq!(raw[3..14], x[3..14], "velocity, quaternion, rates and the predicted extra as they are");
    for k in 0..3 {
        assert_eq!(raw[14 + k], x[14 + k] - x[k], "reference - position in slot {}", 14 + k);
    }
    assert_eq!(raw[17..19], x[17..19], "the exogenous extras as they are");
    assert_eq!(raw[19..], u[..], "the actions last");
    // The increment target: exogenous slots zero, predicted slots the increment.
    let next: Vec<f64> = x.iter().map(|v| v + 1.0).collect();
    let d = crossaudit::model::features::raw_target(&slots, &x, &next);
    assert!(d[..14].iter().all(|v| *v == 1.0) && d[14..].iter().all(|v| *v == 0.0), "{d:?}");
    // A layout without a reference: nothing is subtracted.
    let bare = Slots { reference: false, ..slots };
    let raw = crossaudit::model::features::raw_input(&bare, InputMap::Relative, &x, &u);
    assert_eq!(raw[3..19], x[3..19]);
}

#[test]
fn a_wide_layout_trains_with_the_fused_trainer_and_the_reference_trainer_refuses_it() {
    let slots = Slots::full(19, 3, 14, true);
    let w = odd_windows(&slots, 300);
    let features = FeatureMap::fit(slots, InputMap::World, ActionScaling::Raw, TargetKind::Standardized, &w, "m");
    assert_eq!((features.input.dim(), features.target.dim()), (22, 19));
    let t = crossaudit::design::load(&root().join("tests/designs/tiny_train.design")).unwrap().design.training.unwrap();
    let mut t = t;
    t.epochs = 2;
    let (net, logs) = crossaudit::model::train(&[32, 32, 32], &features, &w, &w[..50], &t, 4, &mut |_| {}).unwrap();
    assert_eq!(logs.len(), 2);
    let f = net.fused();
    assert_eq!((f.inputs(), f.outputs()), (22, 19));
    // One step: the exogenous slots come back as they went in (the rollout
    // then writes the measured values over them).
    use crossaudit::model::Dynamics;
    let mut model = crossaudit::model::Learned::new(&net, &features);
    let next = model.step(&[w[0].0.clone()], &[w[0].1.clone()]);
    assert_eq!(next[0].len(), 19);
    assert_eq!(next[0][14..], w[0].0[14..]);
    let refused =
        crossaudit::model::train_with(Engine::Reference, &[32, 32, 32], &features, &w, &w[..50], &t, 4, &mut |_| {});
    assert!(matches!(refused, Err(NetError::ReferenceLayout { state: 19, action: 3 })));
}

/// The wide design with an external model beside persistence, small.
fn wide_external(dir: &Path) -> String {
    let text = std::fs::read_to_string(root().join(WIDE)).unwrap();
    let path_line = "path      \"../../tests/fixtures/rotorpy/logs\"";
    let logs = root().join("tests/fixtures/rotorpy/logs");
    let mut text = text
        .replace(path_line, &format!("path \"{}\"", logs.display()))
        .replace("factor seed = 1..5", "factor seed = 1..3")
        .replace("starts 25", "starts 6");
    let models = text.find("model world").unwrap();
    let end = text.find("endpoint primary").unwrap();
    text.replace_range(models..end, "model ext   = external inputs relative\nmodel still = persistence\n");
    let first_endpoint = text.find("endpoint primary").unwrap();
    let analysis = text.find("contrast ").unwrap();
    text.replace_range(
        first_endpoint..analysis,
        "endpoint primary   fa_position_rmse at 1.0 s cap 2 m model ext\nendpoint secondary fa_position_rmse at 0.5 s models ext, still\n",
    );
    text = text.replace("interaction world - relative\n", "");
    let path = dir.join("wide_external.design");
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

#[test]
fn an_external_model_on_a_wide_layout_is_exported_with_its_widths_and_scored_bit_for_bit() {
    let tmp = tempfile::tempdir().unwrap();
    let design = wide_external(tmp.path());
    let out = tmp.path().join("run");
    let o = crossaudit(&["export", &design, "--exploratory", "--out", out.to_str().unwrap()]);
    assert_ok(&o);
    let bytes = std::fs::read(out.join("export/export.json")).unwrap();
    let (index, sha): (ExportIndex, String) =
        (serde_json::from_slice(&bytes).unwrap(), crossaudit::io::sha256_hex(&bytes));
    assert_eq!(index.state_columns.len(), 23);
    assert_eq!(index.state_columns[6..10], ["mocap_qw", "mocap_qx", "mocap_qy", "mocap_qz"], "scalar first");
    assert_eq!(index.state_columns[20..], ["windx", "windy", "windz"]);
    assert_eq!(index.action_columns, ["r1des", "r2des", "r3des", "r4des"]);
    assert_eq!(index.exogenous_columns, (17..23).collect::<Vec<_>>());
    let starts = npy::read(&std::fs::read(out.join("export").join(&index.start_files["states"])).unwrap(), &[54, 23]);
    assert!(starts.is_ok(), "{:?}", starts.err());
    let exo = &index.start_files["exogenous"];
    assert!(npy::read(&std::fs::read(out.join("export").join(exo)).unwrap(), &[54, 100, 6]).is_ok());
    // Persistence's rollouts, written as the external model's predictions.
    let file = crossaudit::design::load(Path::new(&design)).unwrap();
    let plan = crossaudit::compile(&file.design);
    let data = root().join("tests/fixtures/rotorpy/logs");
    let prepared = crossaudit::split::rebuild(&file, &plan, &data, &out).unwrap();
    let write = |job: &ExportJob| {
        let [s, k, width] = job.shape;
        assert_eq!(width, 23);
        let mut data = vec![0.0; s * k * width];
        let mut keep = |step: usize, states: &[State]| {
            for (i, x) in states.iter().enumerate() {
                let off = (i * k + step - 1) * width;
                data[off..off + width].copy_from_slice(x);
                if job.arm == "contaminated" {
                    data[off] += 0.01 * job.seed as f64 * (i % 3) as f64;
                }
            }
        };
        let mut still = crossaudit::model::baseline::Persistence;
        crossaudit::rollout::trajectories(&mut still, &prepared.recordings, &prepared.split.starts, k, &mut keep, &[]);
        std::fs::create_dir_all(out.join("predictions")).unwrap();
        std::fs::write(out.join(&job.predictions), npy::write(&job.shape, &data).unwrap()).unwrap();
        let d = serde_json::json!({"export_sha256": sha, "model": job.model, "arm": job.arm, "seed": job.seed});
        std::fs::write(out.join(&job.description), d.to_string()).unwrap();
    };
    index.jobs.iter().for_each(write);
    // A prediction of the NanoBench width is refused with the shape it needs.
    let wrong = &index.jobs[0];
    let saved = std::fs::read(out.join(&wrong.predictions)).unwrap();
    let [s, k, _] = wrong.shape;
    std::fs::write(out.join(&wrong.predictions), npy::write(&[s, k, 14], &vec![0.0; s * k * 14]).unwrap()).unwrap();
    let o = crossaudit(&["score", out.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains(&format!("[{s}, {k}, 23]")), "{}", stderr(&o));
    std::fs::write(out.join(&wrong.predictions), saved).unwrap();
    let o = crossaudit(&["score", out.to_str().unwrap()]);
    assert_ok(&o);
    let cells = crossaudit::cells::read_cells(&out.join("cells.csv")).unwrap();
    let of = |model: &str| -> Vec<String> {
        let mut rows: Vec<String> = cells
            .iter()
            .filter(|c| &*c.model == model && &*c.arm == "disjoint")
            .map(|c| format!("{} {} {} {:?}", c.seed, c.recording, c.horizon_s, c.fa_position_rmse_m.to_bits()))
            .collect();
        rows.sort();
        rows
    };
    assert!(!of("ext").is_empty());
    let still_half: Vec<String> = of("still");
    let ext_half: Vec<String> = of("ext").into_iter().filter(|r| r.contains(" 0.5 ")).collect();
    assert_eq!(ext_half, still_half, "the external rows are persistence's, bit for bit");
}

#[test]
fn two_actions_and_no_reference_run_end_to_end() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("designs/logs/rotorpy.design")).unwrap();
    let logs = root().join("tests/fixtures/rotorpy/logs");
    let text = text
        .replace("path      \"../../tests/fixtures/rotorpy/logs\"", &format!("path \"{}\"", logs.display()))
        .replace("  reference xdes, ydes, zdes\n", "")
        .replace("action    r1des, r2des, r3des, r4des scale 2500", "action r1des, r3des scale 2500")
        .replace("factor seed = 1..5", "factor seed = 1..3")
        .replace("starts 25", "starts 5")
        .replace("epochs 30", "epochs 2")
        .replace("model relative = mlp(64, 64, 64) inputs relative", "model relative = linear inputs relative ridge 1");
    let design = tmp.path().join("two_actions.design");
    std::fs::write(&design, text).unwrap();
    let out = tmp.path().join("run");
    let o = crossaudit(&["run", design.to_str().unwrap(), "--exploratory", "--out", out.to_str().unwrap()]);
    assert_ok(&o);
    let record: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("jobs/world__disjoint__1.json")).unwrap()).unwrap();
    let slots = &record["standardizers"]["slots"];
    assert_eq!((slots["state"].as_u64(), slots["action"].as_u64()), (Some(10), Some(2)), "{record}");
    assert_eq!(slots["reference"], false);
    let cells = crossaudit::cells::read_cells(&out.join("cells.csv")).unwrap();
    assert!(cells.iter().any(|c| &*c.model == "relative") && cells.iter().all(|c| c.fa_position_rmse_m.is_finite()));
}

#[test]
fn body_rates_need_three_columns_and_the_new_clauses_are_csv_only() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join(WIDE)).unwrap();
    let bad = tmp.path().join("rates.design");
    std::fs::write(&bad, text.replace("rates     mocap_wx, mocap_wy, mocap_wz", "rates mocap_wx, mocap_wy")).unwrap();
    let o = crossaudit(&["check", bad.to_str().unwrap()]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("the body rates has 3 columns, 2 given") && e.contains("rates.design:"), "{e}");
    let nb = tmp.path().join("nanobench.design");
    let preset = std::fs::read_to_string(root().join("tests/designs/logs_preset.design")).unwrap();
    std::fs::write(&nb, preset.replacen("{", "{\n  predicted r1", 1)).unwrap();
    let o = crossaudit(&["check", nb.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("column declaration outside `data csv`"), "{}", stderr(&o));
}

#[test]
fn the_wide_rotorpy_design_reproduces_its_committed_run() {
    let compared = crate::logs::reproduces_committed_run("designs/logs/rotorpy_wide.design", "results/rotorpy_wide");
    assert!(compared > 40, "{compared} files compared");
}
