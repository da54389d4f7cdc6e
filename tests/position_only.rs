//! Logs with only a position (issue 41): `velocity` and `attitude` are
//! optional in `data csv`. Without them the layout has no velocity or
//! quaternion slots, the failure-aware metrics (position only) are still
//! computed, the velocity and attitude RMSE are left empty, and what needs
//! the missing state (`constant_velocity`, a velocity or attitude
//! endpoint) is refused in the design with its place.

use std::path::{Path, PathBuf};

use crossaudit::cells::{read_cells, read_cells_from, HEADER};
use crossaudit::data::{load_recording, Layout};
use crossaudit::model::Slots;

use crate::common::crossaudit;
use crate::common::{assert_ok, root, stderr};

const VELOCITY: &str = "  velocity  mocap_xdot, mocap_ydot, mocap_zdot\n";
const ATTITUDE: &str = "  attitude  quaternion xyzw mocap_qx, mocap_qy, mocap_qz, mocap_qw\n";

/// The RotorPy design, small (3 seeds, 5 starts, 2 epochs), with the
/// logs' absolute path and `drop` removed from its text, written to `dir`.
fn rotorpy_without(dir: &Path, name: &str, drop: &[&str]) -> PathBuf {
    let text = std::fs::read_to_string(root().join("designs/logs/rotorpy.design")).unwrap();
    let logs = root().join("tests/fixtures/rotorpy/logs");
    let mut text = text
        .replace("path      \"../../tests/fixtures/rotorpy/logs\"", &format!("path \"{}\"", logs.display()))
        .replace("factor seed = 1..5", "factor seed = 1..3")
        .replace("starts 25", "starts 5")
        .replace("epochs 30", "epochs 2");
    for d in drop {
        assert!(text.contains(d), "{d}");
        text = text.replace(d, "");
    }
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn the_layout_has_no_velocity_or_quaternion_slots_unless_declared() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = |drop: &[&str]| {
        let path = rotorpy_without(tmp.path(), "d.design", drop);
        crossaudit::design::load(&path).unwrap().design.data
    };
    let full = spec(&[]);
    let bare = spec(&[VELOCITY, ATTITUDE]);
    let attitude_only = spec(&[VELOCITY]);
    // Position and reference: 6 slots, the first 3 predicted.
    let s = bare.slots();
    assert_eq!((s.state, s.predicted, s.velocity, s.attitude), (6, 3, false, false));
    assert_eq!((s.velocity_slots(), s.quaternion_slots()), (None, None));
    let s = attitude_only.slots();
    assert_eq!((s.state, s.predicted, s.velocity_slots(), s.quaternion_slots()), (10, 7, None, Some(3..7)));
    assert_eq!(full.slots(), Slots::full(13, 4, 10, true));
    // The same file read under each layout: every slot holds its column.
    let path = root().join("tests/fixtures/rotorpy/logs/R5_lissajous_medium_rep2.csv.gz");
    let load = |spec| load_recording(&path, &Layout::new(spec).unwrap()).unwrap();
    let (f, b, a) = (load(&full), load(&bare), load(&attitude_only));
    assert_eq!((b.slots, a.slots), (bare.slots(), attitude_only.slots()));
    for k in 0..f.rows {
        let x = &f.state[k];
        assert_eq!(b.state[k], [&x[0..3], &x[10..13]].concat(), "row {k}");
        assert_eq!(a.state[k], [&x[0..3], &x[6..10], &x[10..13]].concat(), "row {k}");
        assert_eq!((&b.action[k], &a.action[k]), (&f.action[k], &f.action[k]));
    }
}

/// The cells of a run, and the job record of its first world job.
fn run(design: &Path, out: &Path) -> (Vec<crossaudit::cells::Cell>, serde_json::Value) {
    let o = crossaudit(&["run", design.to_str().unwrap(), "--exploratory", "--out", out.to_str().unwrap()]);
    assert_ok(&o);
    let cells = read_cells(&out.join("cells.csv")).unwrap();
    let record = serde_json::from_slice(&std::fs::read(out.join("jobs/world__disjoint__1.json")).unwrap()).unwrap();
    (cells, record)
}

#[test]
fn position_only_logs_run_end_to_end_with_the_metrics_they_can_have() {
    let tmp = tempfile::tempdir().unwrap();
    let design = rotorpy_without(tmp.path(), "bare.design", &[VELOCITY, ATTITUDE]);
    let (cells, record) = run(&design, &tmp.path().join("bare"));
    assert!(!cells.is_empty());
    for c in &cells {
        assert!(c.fa_position_rmse_m.is_finite() && c.fa_position_rmse_m <= 2.0, "{c:?}");
        assert_eq!((c.velocity_rmse_mps, c.attitude_rmse_deg), (None, None), "{c:?}");
    }
    // Some start survives somewhere, so the conditional RMSE is there.
    assert!(cells.iter().any(|c| c.conditional_position_rmse_m.is_some()));
    let slots = &record["standardizers"]["slots"];
    assert_eq!((slots["state"].as_u64(), slots["velocity"].as_bool()), (Some(6), Some(false)), "{record}");
    let report = std::fs::read_to_string(tmp.path().join("bare/report/report.md")).unwrap();
    assert!(!report.contains("NaN"), "{report}");
    // One job alone prints its yardsticks: persistence only (constant
    // velocity needs a velocity).
    let one = tmp.path().join("one");
    let args = ["--model", "world", "--arm", "disjoint", "--seed", "1", "--exploratory", "--out"];
    let o = crossaudit(&[&["train", design.to_str().unwrap()], &args[..], &[one.to_str().unwrap()]].concat());
    assert_ok(&o);
    let said = crate::common::stdout(&o);
    assert!(said.contains("persistence") && !said.contains("constant_velocity"), "{said}");

    // An attitude without a velocity: the attitude RMSE is there, at most
    // 180 degrees, and the velocity RMSE is empty.
    let design = rotorpy_without(tmp.path(), "attitude.design", &[VELOCITY]);
    let (cells, _) = run(&design, &tmp.path().join("attitude"));
    let survived: Vec<_> = cells.iter().filter(|c| c.n_divergent < c.n_starts).collect();
    assert!(!survived.is_empty());
    for c in survived {
        assert!(c.attitude_rmse_deg.is_some_and(|a| (0.0..=180.0).contains(&a)), "{c:?}");
        assert_eq!(c.velocity_rmse_mps, None, "{c:?}");
    }
}

#[test]
fn what_needs_an_undeclared_state_is_refused_in_the_design() {
    let tmp = tempfile::tempdir().unwrap();
    let design = rotorpy_without(tmp.path(), "bare.design", &[VELOCITY, ATTITUDE]);
    let text = std::fs::read_to_string(&design).unwrap();
    let check = |name: &str, text: String, needles: &[&str]| {
        let path = tmp.path().join(name);
        std::fs::write(&path, &text).unwrap();
        let o = crossaudit(&["check", path.to_str().unwrap()]);
        assert!(!o.status.success(), "{name} accepted");
        let e = stderr(&o);
        for n in needles {
            assert!(e.contains(n), "{name}: no {n:?} in\n{e}");
        }
    };
    let cv = text.replace("model relative = mlp(64, 64, 64) inputs relative", "model relative = constant_velocity");
    let line = cv.lines().position(|l| l.contains("constant_velocity")).unwrap() + 1;
    check(
        "cv.design",
        cv,
        &["constant velocity without a velocity", &format!("cv.design:{line}:"), "use `persistence`"],
    );
    let velocity = text.replace(
        "endpoint secondary fa_position_rmse at 0.5 s          model world",
        "endpoint secondary velocity_rmse at 0.5 s model world",
    );
    let line = velocity.lines().position(|l| l.contains("velocity_rmse")).unwrap() + 1;
    check("v.design", velocity, &["`velocity_rmse` needs a velocity", &format!("v.design:{line}:")]);
    let attitude = text.replace(
        "endpoint secondary fa_position_rmse at 0.5 s          model world",
        "endpoint secondary attitude_rmse at 0.5 s model world",
    );
    check("a.design", attitude, &["`attitude_rmse` needs an attitude"]);
    // Position stays required.
    let no_position = text.replace("  position  mocap_x, mocap_y, mocap_z\n", "");
    check("p.design", no_position, &["`data csv` needs `position`"]);
}

#[test]
fn a_cells_file_with_velocity_in_some_rows_and_gaps_in_others_is_refused() {
    let header = HEADER.join(",");
    let good = "world,disjoint,1,R1,circle,fast,1,5,0,0.3,0.3,0,0.1,2";
    let gap = "world,disjoint,2,R1,circle,fast,1,5,0,0.3,0.3,0,,2";
    let e = read_cells_from("cells.csv", format!("{header}\n{good}\n{gap}").as_bytes()).unwrap_err().to_string();
    assert!(e.starts_with("cells.csv: line 3, field `velocity_rmse_mps`") && e.contains("line 2 has a value"), "{e}");
    // Empty in every row (a layout without a velocity) reads.
    let bare = "world,disjoint,1,R1,circle,fast,1,5,0,0.3,0.3,0,,";
    let cells = read_cells_from("cells.csv", format!("{header}\n{bare}").as_bytes()).unwrap();
    assert_eq!((cells[0].velocity_rmse_mps, cells[0].attitude_rmse_deg), (None, None));
}

#[test]
fn an_analysis_refuses_velocity_values_the_designs_layout_cannot_have_and_gaps_it_cannot_leave() {
    let tmp = tempfile::tempdir().unwrap();
    let design = rotorpy_without(tmp.path(), "bare.design", &[VELOCITY, ATTITUDE]);
    let out = tmp.path().join("bare");
    let (cells, _) = run(&design, &out);
    let text = std::fs::read_to_string(out.join("cells.csv")).unwrap();
    // The same rows with a velocity RMSE written in: refused with the line.
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    for l in lines.iter_mut().skip(1) {
        let mut f: Vec<&str> = l.split(',').collect();
        let n = f.len();
        f[n - 2] = "0.5";
        *l = f.join(",");
    }
    let forged = tmp.path().join("forged.csv");
    std::fs::write(&forged, lines.join("\n") + "\n").unwrap();
    let analyze = |design: &Path, cells: &Path| {
        let to = tmp.path().join("analysis");
        let [d, c, t] = [design, cells, &to].map(|p| p.to_str().unwrap().to_string());
        crossaudit(&["analyze", &d, "--cells", &c, "--out", &t])
    };
    let o = analyze(&design, &forged);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("line 2, field `velocity_rmse_mps`") && e.contains("declare no velocity"), "{e}");
    // Under the full design (velocity declared), the run's empty column is refused.
    let full = rotorpy_without(tmp.path(), "full.design", &[]);
    let o = analyze(&full, &out.join("cells.csv"));
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("field `velocity_rmse_mps`: is empty, but the design's data declare a velocity"), "{e}");
    // Its own design analyses it.
    let o = analyze(&design, &out.join("cells.csv"));
    assert_ok(&o);
    assert!(!cells.is_empty());
}
