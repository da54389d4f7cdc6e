//! Logs declared in the design (`data csv`): NanoBench's preset and the
//! same columns written out give the same bytes; columns are found by
//! header in any order, a quaternion in either order or Euler angles; every
//! broken log is refused with its file, line and column.

use std::path::{Path, PathBuf};

use crate::common::bin;
use crate::common::{assert_ok, root, run_json_fields, stderr};
use crossaudit::data::{self, load_recording, Layout, LogError, Recording, Status};
use crossaudit::design::{self, DataSpec};

fn fixture(name: &str) -> PathBuf {
    root().join("tests/fixtures/nanobench").join(name)
}

pub(crate) fn spec(design: &str) -> DataSpec {
    design::from_str("columns.design", design).unwrap_or_else(|e| panic!("{e}")).data
}

/// Every file under `dir`, relative, sorted.
pub(crate) fn files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    out.sort();
    out
}

#[test]
fn the_nanobench_preset_and_its_columns_written_out_give_the_same_audit_split_and_cells() {
    let tmp = tempfile::tempdir().unwrap();
    let run = |design: &str, out: &str| {
        let o = bin()
            .arg("run")
            .arg(root().join("tests/designs").join(design))
            .args(["--exploratory", "--workers", "2", "--out"])
            .arg(tmp.path().join(out))
            .output()
            .unwrap();
        assert_ok(&o);
        tmp.path().join(out)
    };
    let (preset, generic) = (run("logs_preset.design", "preset"), run("logs_generic.design", "generic"));
    let listed = files(&preset);
    assert_eq!(listed, files(&generic), "the two runs wrote different files");
    let mut compared = 0;
    for f in &listed {
        let name = f.to_string_lossy();
        let (a, b) = (std::fs::read(preset.join(f)).unwrap(), std::fs::read(generic.join(f)).unwrap());
        if name.starts_with("audit/")
            || name.starts_with("cells")
            || name.ends_with(".safetensors")
            || (name.starts_with("manifests/") && name.ends_with(".csv"))
            || name == "report/estimates.csv"
        {
            assert!(a == b, "{name} differs between the preset and the generic block");
            compared += 1;
        } else if name.starts_with("curves/") {
            // Every column but the last (each epoch's wall-clock seconds).
            let strip = |t: &[u8]| -> Vec<String> {
                String::from_utf8_lossy(t)
                    .lines()
                    .map(|l| l.rsplit_once(',').map_or(l, |(a, _)| a).to_string())
                    .collect()
            };
            assert_eq!(strip(&a), strip(&b), "{name} differs");
            compared += 1;
        }
    }
    // audit (4), cells.csv + 4 per-cell files, 4 models, 4 manifests, 4 curves, estimates.
    assert!(compared >= 20, "only {compared} files compared");
    let recordings = std::fs::read_to_string(preset.join("audit/recordings.csv")).unwrap();
    assert!(recordings.lines().count() > 4, "the audit lists the fixture recordings:\n{recordings}");
}

/// A design text over `dir` with the columns of [`rewrite`]'s files.
pub(crate) fn reordered_design(dir: &Path, attitude: &str) -> String {
    format!(
        r#"study "columns"
data csv {{
  path "{}"
  rate 100 Hz
  time "time [s]"
  position x, y, z
  velocity vx, vy, vz
  attitude {attitude}
  reference xr, yr, zr
  extra vbat fill zeros
  action m1, m2, m3, m4 scale 65535
  include active(m1 > 1000) >= 20 samples
}}
factor recording {{ evaluation 2 split_seed 3; starts 3 horizon 20 conditions trajectory }}
factor seed = 1..2
validation 60 windows from 1 recordings seed 5
arm disjoint {{ fit 200 windows seed 1 }}
arm contaminated {{ from disjoint replace 25% with evaluation windows exclude starts seed 2 }}
model world = mlp(32, 32, 32) inputs world
train {{ adam lr 1e-3 batch 32 epochs 3 cosine patience 2 action_noise 0.0 }}
endpoint primary fa_position_rmse at 0.2 s cap 2 m model world
contrast contaminated - disjoint
estimate crossed_mom level 0.95 df seed - 1
decide confirmed when optimism >= 10% and upper < 0
"#,
        dir.display()
    )
}

/// The fixture log `name` rewritten in another lab's layout: other column
/// names, another order, a text column nobody declares, the quaternion
/// scalar last, and Euler angles (Z-Y-X, degrees) computed from it.
pub(crate) fn rewrite(name: &str, out: &Path) -> PathBuf {
    let text = std::fs::read_to_string(fixture(name)).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let pick = [
        ("motor_motor_m3", "m3"),
        ("pwr_pm_vbat", "vbat"),
        ("px", "x"),
        ("py", "y"),
        ("pz", "z"),
        ("att_stateEstimate_qx", "qx"),
        ("att_stateEstimate_qy", "qy"),
        ("att_stateEstimate_qz", "qz"),
        ("att_stateEstimate_qw", "qw"),
        ("t", "time [s]"),
        ("est_stateEstimate_vx", "vx"),
        ("est_stateEstimate_vy", "vy"),
        ("est_stateEstimate_vz", "vz"),
        ("sp_ctrltarget_x", "xr"),
        ("sp_ctrltarget_y", "yr"),
        ("sp_ctrltarget_z", "zr"),
        ("motor_motor_m1", "m1"),
        ("motor_motor_m2", "m2"),
        ("motor_motor_m4", "m4"),
    ];
    let mut csv = pick.iter().map(|(_, n)| *n).collect::<Vec<_>>().join(",");
    csv.push_str(",mode,roll_deg,pitch_deg,yaw_deg\n");
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let v = |n: &str| f[col(n)].parse::<f64>().unwrap();
        let row: Vec<&str> = pick.iter().map(|(from, _)| f[col(from)]).collect();
        let (w, x, y, z) = (
            v("att_stateEstimate_qw"),
            v("att_stateEstimate_qx"),
            v("att_stateEstimate_qy"),
            v("att_stateEstimate_qz"),
        );
        // Z-Y-X Euler angles of a unit quaternion (the inverse of data::euler_zyx).
        let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
        let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
        let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
        let deg = |r: f64| format!("{:.17e}", r.to_degrees());
        csv.push_str(&format!("{},flying,{},{},{}\n", row.join(","), deg(roll), deg(pitch), deg(yaw)));
    }
    let path = out.join(fixture(name).file_name().unwrap());
    std::fs::write(&path, csv).unwrap();
    path
}

fn preset_recording(name: &str) -> Recording {
    let preset = design::load(&root().join("tests/designs/logs_preset.design")).unwrap().design.data;
    load_recording(&fixture(name), &Layout::new(&preset).unwrap()).unwrap()
}

#[test]
fn columns_are_found_by_name_in_any_order_with_the_quaternion_scalar_last() {
    let tmp = tempfile::tempdir().unwrap();
    let path = rewrite("F1_circle_slow_rep1.csv", tmp.path());
    let generic = spec(&reordered_design(tmp.path(), "quaternion xyzw qx, qy, qz, qw"));
    let got = load_recording(&path, &Layout::new(&generic).unwrap()).unwrap();
    let want = preset_recording("F1_circle_slow_rep1.csv");
    assert_eq!(got.rows, want.rows);
    assert_eq!(got.t, want.t);
    assert_eq!(got.state, want.state, "the same 14 state values in the model's order");
    assert_eq!(got.action, want.action);
    assert_eq!(got.active, want.active);
}

#[test]
fn euler_angles_in_degrees_become_the_same_quaternion() {
    let tmp = tempfile::tempdir().unwrap();
    let path = rewrite("F3_oval_medium_rep1.csv", tmp.path());
    let generic = spec(&reordered_design(tmp.path(), "euler degrees roll_deg, pitch_deg, yaw_deg"));
    let got = load_recording(&path, &Layout::new(&generic).unwrap()).unwrap();
    let want = preset_recording("F3_oval_medium_rep1.csv");
    let mut worst: f64 = 0.0;
    for (g, w) in got.state.iter().zip(&want.state) {
        assert_eq!(g[..6], w[..6]);
        assert_eq!(g[10..], w[10..]);
        // q and -q are one rotation; the fixture's quaternions are unit to
        // about 1e-9, the recomputed ones exactly.
        let sign = if g[6] * w[6] + g[7] * w[7] + g[8] * w[8] + g[9] * w[9] < 0.0 { -1.0 } else { 1.0 };
        let norm = (w[6] * w[6] + w[7] * w[7] + w[8] * w[8] + w[9] * w[9]).sqrt();
        for k in 6..10 {
            worst = worst.max((sign * g[k] - w[k] / norm).abs());
        }
    }
    assert!(worst < 1e-12, "Euler round trip off by {worst}");
}

/// Writes a small log in the layout of [`reordered_design`] with `edit`
/// applied to the rows after the header, and loads it.
fn load_edited(edit: impl Fn(usize, &mut Vec<String>), header_edit: impl Fn(&mut Vec<String>)) -> LogError {
    let tmp = tempfile::tempdir().unwrap();
    let path = rewrite("F1_circle_slow_rep1.csv", tmp.path());
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut header: Vec<String> = lines[0].split(',').map(String::from).collect();
    header_edit(&mut header);
    lines[0] = header.join(",");
    for (k, line) in lines.iter_mut().enumerate().skip(1) {
        let mut f: Vec<String> = line.split(',').map(String::from).collect();
        edit(k + 1, &mut f);
        *line = f.join(",");
    }
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    let generic = spec(&reordered_design(tmp.path(), "quaternion xyzw qx, qy, qz, qw"));
    load_recording(&path, &Layout::new(&generic).unwrap()).expect_err("a broken log must be refused")
}

#[test]
fn a_declared_column_the_header_lacks_is_named() {
    let e = load_edited(|_, _| {}, |h| h[3] = "y_m".into());
    assert!(matches!(&e, LogError::MissingColumn { column, .. } if column == "y"), "{e:?}");
    let text = e.to_string();
    assert!(text.contains("F1_circle_slow_rep1.csv: line 1") && text.contains("`y`") && text.contains("y_m"), "{text}");
    let e = load_edited(|_, _| {}, |h| h[1] = "x".into());
    assert!(e.to_string().contains("holds it twice"), "{e}");
}

#[test]
fn a_non_numeric_declared_column_is_located_and_undeclared_text_is_not_read() {
    // Line 40, column `vy` (the 12th field).
    let e = load_edited(
        |line, f| {
            if line == 40 {
                f[11] = "n/a".into()
            }
        },
        |_| {},
    );
    match &e {
        LogError::NonNumeric { line, column, value, .. } => {
            assert_eq!((*line, column.as_str(), value.as_str()), (40, "vy", "n/a"));
        }
        other => panic!("{other:?}"),
    }
    // The undeclared `mode` column holds text on every line and is not read.
    let tmp = tempfile::tempdir().unwrap();
    let path = rewrite("F1_circle_slow_rep1.csv", tmp.path());
    let generic = spec(&reordered_design(tmp.path(), "quaternion xyzw qx, qy, qz, qw"));
    assert!(load_recording(&path, &Layout::new(&generic).unwrap()).is_ok());
}

#[test]
fn a_quaternion_off_unit_length_is_located() {
    // Line 100 (an active row): qw doubled.
    let e = load_edited(
        |line, f| {
            if line == 100 {
                let w: f64 = f[8].parse().unwrap();
                f[8] = format!("{}", 2.0 * w + 0.5);
            }
        },
        |_| {},
    );
    match &e {
        LogError::NotUnit { line, columns, norm, .. } => {
            assert_eq!(*line, 100);
            assert_eq!(columns, "`qw`, `qx`, `qy`, `qz`");
            assert!(*norm > 1.01, "{norm}");
        }
        other => panic!("{other:?}"),
    }
    // Declared scalar first, the same file's quaternion is off unit length
    // nowhere (a permutation keeps the length): the order is the user's
    // to state, not checked. Declared as x, y, z, w it loads.
}

#[test]
fn a_rate_that_disagrees_with_the_time_column_is_located() {
    // Every time doubled: a 50 Hz log declared as 100 Hz.
    let e = load_edited(
        |_, f| {
            let t: f64 = f[9].parse().unwrap();
            f[9] = format!("{}", 2.0 * t);
        },
        |_| {},
    );
    match &e {
        LogError::Rate { line, median_s, expected_s, column, .. } => {
            assert_eq!((*line, column.as_str()), (3, "time [s]"));
            assert!((median_s - 0.02).abs() < 1e-6 && (expected_s - 0.01).abs() < 1e-15, "{e}");
        }
        other => panic!("{other:?}"),
    }
    assert!(e.to_string().contains("rate 100 Hz"), "{e}");
}

#[test]
fn the_audit_lists_a_broken_log_with_its_reason_and_strict_data_stops() {
    let tmp = tempfile::tempdir().unwrap();
    for name in ["F1_circle_slow_rep1.csv", "F2_star_fast_mell_rep1.csv", "F4_linear_ramp_rep1.csv"] {
        rewrite(name, tmp.path());
    }
    let broken = tmp.path().join("F4_linear_ramp_rep1.csv");
    let text = std::fs::read_to_string(&broken).unwrap().replacen("time [s]", "t", 1);
    std::fs::write(&broken, text).unwrap();
    let generic = spec(&reordered_design(tmp.path(), "quaternion xyzw qx, qy, qz, qw"));
    let audit = data::audit(&generic, tmp.path()).unwrap();
    let row = audit.files.iter().find(|f| f.name == "F4_linear_ramp_rep1").unwrap();
    assert_eq!(row.status, Status::Excluded);
    assert!(row.reason.contains("`time [s]`"), "{}", row.reason);
    // No metadata files: `data csv` needs none, and says nothing of them.
    assert!(audit.files.iter().all(|f| !f.reason.contains("metadata")), "{:#?}", audit.files);
    let included: Vec<&str> = audit.included().map(|f| f.name.as_str()).collect();
    assert_eq!(included.len(), 2, "{:#?}", audit.files);
    let strict = DataSpec { strictness: design::Strictness::Strict, ..generic };
    let e = data::audit(&strict, tmp.path()).expect_err("strict data stops on an unreadable log");
    assert!(e.to_string().contains("F4_linear_ramp_rep1.csv"), "{e}");
}

#[test]
fn a_csv_block_without_what_the_reader_needs_is_refused_with_its_place() {
    let tmp = tempfile::tempdir().unwrap();
    let design = reordered_design(tmp.path(), "quaternion xyzw qx, qy, qz, qw")
        .replace(" scale 65535", "")
        .replace("  velocity vx, vy, vz\n", "")
        .replace("position x, y, z", "position x, y");
    let path = tmp.path().join("bad.design");
    std::fs::write(&path, design).unwrap();
    let o = bin().arg("check").arg(&path).output().unwrap();
    assert!(!o.status.success());
    let err = stderr(&o);
    // Velocity is optional (tests/position_only.rs): its absence is no error.
    assert!(!err.contains("needs `velocity`"), "{err}");
    for needle in ["`data csv` needs `action ... scale`", "the position has 3 columns, 2 given", "bad.design:"] {
        assert!(err.contains(needle), "missing {needle:?} in:\n{err}");
    }
    // NanoBench's preset refuses the csv clauses.
    let preset = std::fs::read_to_string(root().join("tests/designs/logs_preset.design"))
        .unwrap()
        .replace("rate 100 Hz", "rate 100 Hz\n  position px, py, pz");
    std::fs::write(&path, preset).unwrap();
    let o = bin().arg("check").arg(&path).output().unwrap();
    assert!(!o.status.success());
    assert!(stderr(&o).contains("column declaration outside `data csv`"), "{}", stderr(&o));
}

/// Runs `design` and compares every file of its committed run `results`
/// byte for byte (the build line and the training curves' wall-clock
/// seconds aside); returns how many files were compared.
pub(crate) fn reproduces_committed_run(design: &str, results: &str) -> usize {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("run");
    let o = bin().current_dir(root()).args(["run", design, "--out"]).arg(&out).output().unwrap();
    assert_ok(&o);
    let committed = root().join(results);
    let normalize = |name: &str, bytes: &[u8]| -> Vec<String> {
        String::from_utf8_lossy(bytes)
            .lines()
            .map(|l| if l.contains("(commit ") { "<build>" } else { l })
            .map(|l| if name.starts_with("curves/") { l.rsplit_once(',').map_or(l, |p| p.0) } else { l })
            .map(String::from)
            .collect()
    };
    let mut compared = 0;
    for f in files(&committed) {
        let name = f.to_string_lossy().to_string();
        if ["COMMAND", "time.txt", "stdout.txt"].contains(&name.as_str()) {
            continue;
        }
        let fresh = std::fs::read(out.join(&f)).unwrap_or_else(|e| panic!("{name}: {e}"));
        if name.ends_with("run.json") {
            let (a, b) = (run_json_fields(&fresh), run_json_fields(&std::fs::read(committed.join(&f)).unwrap()));
            assert_eq!(a, b, "{results}/{name} differs from the committed one");
            compared += 1;
            continue;
        }
        let (a, b) = (normalize(&name, &fresh), normalize(&name, &std::fs::read(committed.join(&f)).unwrap()));
        if let Some((k, (x, y))) = a.iter().zip(&b).enumerate().find(|(_, (x, y))| x != y) {
            panic!(
                "{results}/{name} differs from the committed one at line {}:\n  fresh:     {x}\n  committed: {y}",
                k + 1
            );
        }
        assert_eq!(a.len(), b.len(), "{name}: line counts differ");
        compared += 1;
    }
    compared
}

#[test]
fn the_rotorpy_design_reproduces_its_committed_run() {
    // A second simulator's logs, in its own column layout, end to end: the
    // committed run (results/rotorpy) comes out byte for byte.
    let compared = reproduces_committed_run("designs/logs/rotorpy.design", "results/rotorpy");
    assert!(compared > 40, "{compared} files compared");
    let committed = root().join("results/rotorpy");
    // RotorPy's columns were read: every flight included, none without a reason.
    let audit = std::fs::read_to_string(committed.join("audit/recordings.csv")).unwrap();
    assert_eq!(audit.lines().filter(|l| l.contains(",included,")).count(), 27, "{audit}");
    let md = std::fs::read_to_string(committed.join("report/report.md")).unwrap();
    assert!(md.contains("over 9 recordings x 5 seeds"), "{md}");
    // Issue 72: its evaluation draw leaves conditions uncovered, and every
    // view says so: the HTML banner, estimates.csv's coverage rows, the
    // console line of a reanalysis of the folder.
    let html = std::fs::read_to_string(committed.join("report/report.html")).unwrap();
    let banner = html.split("<nav").next().unwrap();
    assert!(banner.contains("class=\"guards\"") && banner.contains("mixes condition novelty"), "{banner}");
    let estimates = std::fs::read_to_string(committed.join("report/estimates.csv")).unwrap();
    for row in [",uncovered_share_of_d,", ",covered_only,", ",covered_only_fieller,"] {
        assert!(estimates.lines().any(|l| l.starts_with("coverage,primary,") && l.contains(row)), "{row}: {estimates}");
    }
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("again");
    let o = crate::common::crossaudit(&[
        "analyze",
        "designs/logs/rotorpy.design",
        "--cells",
        "results/rotorpy",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_ok(&o);
    let console = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(console.lines().any(|l| l.starts_with("  The contrast mixes condition novelty")), "{console}");
}

#[test]
fn a_conditions_table_gives_trajectory_and_speed_and_every_recording_needs_a_row() {
    let tmp = tempfile::tempdir().unwrap();
    for name in ["F1_circle_slow_rep1.csv", "F2_star_fast_mell_rep1.csv", "F4_linear_ramp_rep1.csv"] {
        rewrite(name, tmp.path());
    }
    let design = reordered_design(tmp.path(), "quaternion xyzw qx, qy, qz, qw")
        .replace("  rate 100 Hz\n", "  rate 100 Hz\n  conditions table \"conditions.csv\"\n");
    let table = "recording,trajectory,speed\nF1_circle_slow_rep1,lemniscate,fast\nF2_star_fast_mell_rep1,hover,slow\nF4_linear_ramp_rep1,ramp,medium\n";
    std::fs::write(tmp.path().join("conditions.csv"), table).unwrap();
    let generic = spec(&design);
    let audit = data::audit(&generic, tmp.path()).unwrap();
    assert_eq!(audit.files.len(), 3, "the table itself is not a recording: {:#?}", audit.files);
    let f1 = audit.files.iter().find(|f| f.name == "F1_circle_slow_rep1").unwrap();
    assert_eq!((f1.trajectory.as_str(), f1.speed.as_str()), ("lemniscate", "fast"));
    // A table that lists the files (`.csv`, `.csv.gz`, `.parquet`) names the
    // same recordings: the same audit.
    let files = table
        .replace("F1_circle_slow_rep1,", "F1_circle_slow_rep1.csv.gz,")
        .replace("F2_star_fast_mell_rep1,", "F2_star_fast_mell_rep1.csv,")
        .replace("F4_linear_ramp_rep1,", "F4_linear_ramp_rep1.parquet,");
    std::fs::write(tmp.path().join("conditions.csv"), files).unwrap();
    let by_file = data::audit(&generic, tmp.path()).unwrap();
    let rows = |a: &data::Audit| {
        a.files.iter().map(|f| (f.name.clone(), f.trajectory.clone(), f.speed.clone())).collect::<Vec<_>>()
    };
    assert_eq!(rows(&by_file), rows(&audit));
    // A recording without a row: the audit stops and names it.
    std::fs::write(tmp.path().join("conditions.csv"), table.replace("F4_linear_ramp_rep1,ramp,medium\n", "")).unwrap();
    let e = data::audit(&generic, tmp.path()).unwrap_err().to_string();
    assert!(e.contains("conditions.csv") && e.contains("F4_linear_ramp_rep1.csv"), "{e}");
    // A recording listed twice, and an empty field: located.
    std::fs::write(tmp.path().join("conditions.csv"), format!("{table}F1_circle_slow_rep1,circle,slow\n")).unwrap();
    let e = data::audit(&generic, tmp.path()).unwrap_err().to_string();
    assert!(e.contains("line 5: recording `F1_circle_slow_rep1` is listed again (first on line 2)"), "{e}");
    std::fs::write(tmp.path().join("conditions.csv"), table.replace("hover", "")).unwrap();
    let e = data::audit(&generic, tmp.path()).unwrap_err().to_string();
    assert!(e.contains("line 3, column `trajectory`: empty"), "{e}");
}

/// Issue 72: a conditions table may live outside the data folder (a path
/// from it, or an absolute one), so that the folder holds logs alone and a
/// design that reads it by a name pattern is not disturbed by the table;
/// the lock hashes it there.
#[test]
fn a_conditions_table_outside_the_data_folder_is_read_and_locked() {
    let tmp = tempfile::tempdir().unwrap();
    let logs = tmp.path().join("logs");
    std::fs::create_dir_all(&logs).unwrap();
    for name in ["F1_circle_slow_rep1.csv", "F2_star_fast_mell_rep1.csv"] {
        rewrite(name, &logs);
    }
    let table = "recording,trajectory,speed\nF1_circle_slow_rep1,lemniscate,fast\nF2_star_fast_mell_rep1,hover,slow\n";
    std::fs::create_dir_all(tmp.path().join("tables")).unwrap();
    std::fs::write(tmp.path().join("tables/conditions.csv"), table).unwrap();
    let absolute = tmp.path().join("tables/conditions.csv");
    for written in ["../tables/conditions.csv".to_string(), absolute.display().to_string()] {
        let text = reordered_design(&logs, "quaternion xyzw qx, qy, qz, qw")
            .replace("  rate 100 Hz\n", &format!("  rate 100 Hz\n  conditions table \"{written}\"\n"));
        let audit = data::audit(&spec(&text), &logs).unwrap();
        let f1 = audit.files.iter().find(|f| f.name == "F1_circle_slow_rep1").unwrap();
        assert_eq!((f1.trajectory.as_str(), f1.speed.as_str()), ("lemniscate", "fast"), "{written}");
        assert_eq!(audit.files.len(), 2);
        let path = tmp.path().join("outside.design");
        std::fs::write(&path, &text).unwrap();
        let _ = std::fs::remove_file(tmp.path().join("outside.design.lock"));
        let file = crossaudit::design::load(&path).unwrap();
        let lock = crossaudit::design::lock::write_lock(&file, std::time::SystemTime::now()).unwrap();
        assert!(lock.files.as_ref().is_some_and(|f| f.keys().any(|k| k.ends_with("conditions.csv"))), "{lock:?}");
        assert!(!lock.files.unwrap().values().any(|sha| sha.starts_with("unreadable")), "{written}");
    }
}

/// Issue 77, class 4: `stratify speed` where every recording's speed is
/// unknown (a conditions table with no speed column) would draw an
/// unstratified set without a word; it is refused at the clause's line.
#[test]
fn stratifying_by_a_condition_no_recording_has_is_refused_at_its_line() {
    let tmp = tempfile::tempdir().unwrap();
    let logs = tmp.path().join("logs");
    std::fs::create_dir_all(&logs).unwrap();
    let names = ["F1_circle_slow_rep1", "F2_star_fast_mell_rep1", "F3_oval_medium_rep1", "F4_linear_ramp_rep1"];
    let mut table = String::from("recording,trajectory,speed\n");
    for name in names {
        rewrite(&format!("{name}.csv"), &logs);
        table.push_str(&format!("{name},{},unknown\n", name.split('_').nth(1).unwrap()));
    }
    std::fs::write(logs.join("conditions.csv"), table).unwrap();
    let text = reordered_design(&logs, "quaternion xyzw qx, qy, qz, qw")
        .replace("  rate 100 Hz\n", "  rate 100 Hz\n  conditions table \"conditions.csv\"\n")
        .replace("evaluation 2 split_seed 3;", "evaluation 2 split_seed 3; stratify speed keep 1;");
    let path = tmp.path().join("stratified.design");
    std::fs::write(&path, &text).unwrap();
    let line = text.lines().position(|l| l.contains("stratify speed")).unwrap() + 1;
    // `check` reads the data and says it first, before anyone locks
    // (issue 73: it used to say "valid").
    let o = crate::common::crossaudit(&["check", path.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("run refuses this design on the data in"), "{err}");
    assert!(err.contains(&format!("stratified.design:{line}:")), "{err}");
    assert!(err.contains("every recording's speed is unknown"), "{err}");
    let o = crate::common::crossaudit(&[
        "split",
        path.to_str().unwrap(),
        "--out",
        tmp.path().join("split").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains(&format!("stratified.design:{line}:")), "{err}");
    assert!(err.contains("every recording's speed is unknown"), "{err}");
}

/// Issue 72: the lock covers the conditions table a design names, which
/// decides every recording's condition (and so coverage, groups and the
/// stratified draw): editing it after locking makes the lock no longer
/// hold, naming the table, so the next run is refused unless labelled
/// EXPLORATORY; restoring it restores the lock.
#[test]
fn editing_a_locked_designs_conditions_table_makes_the_run_exploratory() {
    use crossaudit::design::lock::{status, write_lock};
    use crossaudit::design::LockStatus;
    let tmp = tempfile::tempdir().unwrap();
    for name in ["F1_circle_slow_rep1.csv", "F2_star_fast_mell_rep1.csv"] {
        rewrite(name, tmp.path());
    }
    let text = reordered_design(tmp.path(), "quaternion xyzw qx, qy, qz, qw")
        .replace("  rate 100 Hz\n", "  rate 100 Hz\n  conditions table \"conditions.csv\"\n");
    let table = "recording,trajectory,speed\nF1_circle_slow_rep1,circle,slow\nF2_star_fast_mell_rep1,star,fast\n";
    std::fs::write(tmp.path().join("conditions.csv"), table).unwrap();
    let path = tmp.path().join("locked.design");
    std::fs::write(&path, &text).unwrap();
    let load = || crossaudit::design::load(&path).unwrap();
    let lock = write_lock(&load(), std::time::SystemTime::now()).unwrap();
    let table_path = tmp.path().join("conditions.csv").display().to_string();
    assert!(lock.files.as_ref().is_some_and(|f| f.contains_key(&table_path)), "{lock:?}");
    assert!(matches!(status(&load()).unwrap(), LockStatus::LockedUnchanged { .. }));
    // The same design bytes, another table: the lock no longer holds.
    std::fs::write(tmp.path().join("conditions.csv"), table.replace("star,fast", "circle,fast")).unwrap();
    match status(&load()).unwrap() {
        LockStatus::LockedStale { reason, .. } => {
            assert!(reason.contains("conditions.csv") && reason.contains("changed after the lock"), "{reason}")
        }
        other => panic!("{other:?}"),
    }
    let o =
        crate::common::crossaudit(&["run", path.to_str().unwrap(), "--out", tmp.path().join("run").to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("conditions.csv"), "{err}");
    std::fs::write(tmp.path().join("conditions.csv"), table).unwrap();
    assert!(matches!(status(&load()).unwrap(), LockStatus::LockedUnchanged { .. }));
}

#[test]
fn actions_beyond_the_declared_scale_are_noted_in_the_audit_and_rows_default_to_k_over_rate() {
    let tmp = tempfile::tempdir().unwrap();
    for name in ["F1_circle_slow_rep1.csv", "F2_star_fast_mell_rep1.csv"] {
        rewrite(name, tmp.path());
    }
    // A scale below the fixture's PWM commands: every such value is clipped, and said so.
    let design = reordered_design(tmp.path(), "quaternion xyzw qx, qy, qz, qw").replace("scale 65535", "scale 1000");
    let audit = data::audit(&spec(&design), tmp.path()).unwrap();
    let f1 = audit.files.iter().find(|f| f.name == "F1_circle_slow_rep1").unwrap();
    assert!(
        f1.reason.contains("clipped to [0, 1]") && f1.reason.contains("is the action `scale` right?"),
        "{}",
        f1.reason
    );
    // Where to look: the value farthest outside, its data row and time (a
    // trust review found "largest 65535" said of a command of -1e9).
    let layout = Layout::new(&spec(&design)).unwrap();
    let pwm = &load_recording(&tmp.path().join("F1_circle_slow_rep1.csv"), &layout).unwrap().pwm;
    let (row, far) = pwm
        .iter()
        .enumerate()
        .flat_map(|(k, r)| r.iter().map(move |v| (k, *v)))
        .fold((0, f64::NEG_INFINITY), |(k0, m), (k, v)| if v > m { (k, v) } else { (k0, m) });
    assert!(f1.reason.contains(&format!("(the farthest {far}, at data row {}, t = ", row + 1)), "{}", f1.reason);
    // At the right scale, nothing is noted.
    let audit =
        data::audit(&spec(&reordered_design(tmp.path(), "quaternion xyzw qx, qy, qz, qw")), tmp.path()).unwrap();
    assert!(audit.files.iter().all(|f| !f.reason.contains("clipped")), "{:#?}", audit.files);
    // Without a time column, row k is at k / rate.
    let design = reordered_design(tmp.path(), "quaternion xyzw qx, qy, qz, qw").replace("  time \"time [s]\"\n", "");
    let generic = spec(&design);
    let rec = load_recording(&tmp.path().join("F1_circle_slow_rep1.csv"), &Layout::new(&generic).unwrap()).unwrap();
    assert_eq!(rec.t[..3], [0.0, 0.01, 0.02]);
    assert_eq!(rec.t[rec.rows - 1], (rec.rows - 1) as f64 / 100.0);
}

#[test]
fn a_file_name_pattern_gives_trajectory_speed_and_repetition_and_names_what_it_does_not_match() {
    let tmp = tempfile::tempdir().unwrap();
    let logs = root().join("tests/fixtures/rotorpy/logs");
    for (from, to) in [
        ("R1_circle_slow_rep1", "2026-05-01_circle-slow_take1"),
        ("R5_lissajous_medium_rep2", "2026-05-02_lissajous-medium_take12"),
        ("R9_minsnap_fast_rep3", "2026-05-03_min_snap-fast_take3"),
    ] {
        std::fs::copy(logs.join(format!("{from}.csv.gz")), tmp.path().join(format!("{to}.csv.gz"))).unwrap();
    }
    let rotorpy = std::fs::read_to_string(root().join("designs/logs/rotorpy.design")).unwrap();
    let design = rotorpy
        .replace("path      \"../../tests/fixtures/rotorpy/logs\"", &format!("path \"{}\"", tmp.path().display()))
        .replace("  controller se3\n", "  controller se3\n  conditions name \"{*}_{trajectory}-{speed}_take{rep}\"\n");
    let generic = spec(&design);
    let audit = data::audit(&generic, tmp.path()).unwrap();
    let got: Vec<(&str, &str, Option<u32>)> =
        audit.files.iter().map(|f| (f.trajectory.as_str(), f.speed.as_str(), f.repetition)).collect();
    assert_eq!(got, [("circle", "slow", Some(1)), ("lissajous", "medium", Some(12)), ("min_snap", "fast", Some(3))]);
    // A name the pattern does not match stops the audit and is named.
    std::fs::copy(logs.join("R2_circle_medium_rep1.csv.gz"), tmp.path().join("R2_circle_medium_rep1.csv.gz")).unwrap();
    let e = data::audit(&generic, tmp.path()).unwrap_err().to_string();
    assert!(e.contains("does not match 1 recording file name(s): R2_circle_medium_rep1.csv.gz"), "{e}");
    std::fs::remove_file(tmp.path().join("R2_circle_medium_rep1.csv.gz")).unwrap();
    // A speed the design's speed rule cannot give would be refused by the
    // analysis after the whole run: the audit refuses it first.
    std::fs::rename(
        tmp.path().join("2026-05-01_circle-slow_take1.csv.gz"),
        tmp.path().join("2026-05-01_circle-1.8mps_take1.csv.gz"),
    )
    .unwrap();
    let e = data::audit(&generic, tmp.path()).unwrap_err().to_string();
    assert!(e.contains("the speed `1.8mps`") && e.contains("known: slow, medium, fast, unknown"), "{e}");
    // Patterns that cannot work are design errors at their place.
    for (pattern, want) in [
        ("{*}_{shape}", "`{shape}` is not a placeholder"),
        ("{trajectory}{speed}", "two placeholders in a row"),
        ("{*}_take{rep}", "needs `{trajectory}` or `{speed}`"),
    ] {
        let bad = design.replace("{*}_{trajectory}-{speed}_take{rep}", pattern);
        let e = design::from_str("pattern.design", &bad).unwrap_err().to_string();
        assert!(e.contains(want) && e.contains("pattern.design:"), "{pattern}: {e}");
    }
    let both = design.replace("  strict\n", "  strict\n  conditions table \"conditions.csv\"\n");
    let e = design::from_str("both.design", &both).unwrap_err().to_string();
    assert!(e.contains("conditions declared twice"), "{e}");
}

/// Issue 56, class 7: a 5 s hole inside a 100 Hz log (the median step is
/// right, so the rate check passed) is refused at the line after it; the
/// real NanoBench logs drop at most 4 samples in a row.
#[test]
fn a_time_gap_inside_a_log_is_located() {
    let e = load_edited(
        |line, f| {
            if line >= 40 {
                let t: f64 = f[9].parse().unwrap();
                f[9] = format!("{}", t + 5.0);
            }
        },
        |_| {},
    );
    match &e {
        LogError::Gap { line, gap_s, column, .. } => {
            assert_eq!((*line, column.as_str()), (40, "time [s]"));
            assert!((gap_s - 5.01).abs() < 1e-6, "{e}");
        }
        other => panic!("{other:?}"),
    }
    assert!(e.to_string().contains("501 samples at 100 Hz"), "{e}");
}

/// Issue 56, class 7: Euler angles in degrees declared as radians gave
/// a plausible quaternion of the wrong rotation; an angle beyond 2 pi is
/// refused, at its line and column.
#[test]
fn euler_angles_in_degrees_declared_as_radians_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let path = rewrite("F3_oval_medium_rep1.csv", tmp.path());
    // The fixture hovers level: a yaw of 45 degrees from line 30 on.
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let yaw = lines[0].split(',').position(|h| h == "yaw_deg").unwrap();
    for line in lines.iter_mut().skip(29) {
        let mut f: Vec<&str> = line.split(',').collect();
        f[yaw] = "45";
        *line = f.join(",");
    }
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    let radians = spec(&reordered_design(tmp.path(), "euler radians roll_deg, pitch_deg, yaw_deg"));
    let e = load_recording(&path, &Layout::new(&radians).unwrap()).expect_err("degrees read as radians");
    assert!(matches!(&e, LogError::EulerRange { line: 30, value, .. } if *value == 45.0), "{e:?}");
    let text = e.to_string();
    assert!(text.contains("_deg`") && text.contains("euler degrees"), "{text}");
}

/// Issue 56, class 7: one column declared as two quantities is refused by
/// `check` at the second declaration.
#[test]
fn a_column_declared_as_two_quantities_is_refused_at_its_place() {
    let tmp = tempfile::tempdir().unwrap();
    for (from, to, first) in [
        ("reference xr, yr, zr", "reference x, yr, zr", "a position"),
        ("extra vbat fill zeros", "extra m2 fill zeros", "an action"),
    ] {
        let design = reordered_design(tmp.path(), "quaternion xyzw qx, qy, qz, qw").replace(from, to);
        let e = crossaudit::design::from_str("study.design", &design).expect_err("a column declared twice");
        let text = e.to_string();
        assert!(text.contains("column declared twice") && text.contains(first), "{text}");
    }
}

/// Issue 56, class 8: a spreadsheet's log (a UTF-8 byte-order mark before
/// the header, a quoted text column holding commas) reads as the plain
/// log does, where the mark made the first column "missing" for an
/// invisible reason and each quoted comma a field-count error.
#[test]
fn a_byte_order_mark_and_quoted_commas_are_read_as_a_spreadsheet_writes_them() {
    let tmp = tempfile::tempdir().unwrap();
    let plain = rewrite("F1_circle_slow_rep1.csv", tmp.path());
    let text = std::fs::read_to_string(&plain).unwrap();
    let generic = spec(&reordered_design(tmp.path(), "quaternion xyzw qx, qy, qz, qw"));
    let want = load_recording(&plain, &Layout::new(&generic).unwrap()).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    lines[0] = format!("\u{feff}{},note", lines[0]);
    for l in lines.iter_mut().skip(1) {
        l.push_str(",\"take 1, \"\"windy\"\"\"");
    }
    let sheet = tmp.path().join("sheet").join("F1_circle_slow_rep1.csv");
    std::fs::create_dir_all(sheet.parent().unwrap()).unwrap();
    std::fs::write(&sheet, lines.join("\r\n") + "\r\n").unwrap();
    let got = load_recording(&sheet, &Layout::new(&generic).unwrap()).unwrap();
    assert_eq!((got.t.clone(), got.state.clone(), got.action.clone()), (want.t, want.state, want.action));
    // A quote left open is located, not read past the line.
    lines[5] = lines[5].replace("\"take 1, \"\"windy\"\"\"", "\"take 1, windy");
    std::fs::write(&sheet, lines.join("\n") + "\n").unwrap();
    let e = load_recording(&sheet, &Layout::new(&generic).unwrap()).expect_err("an open quote");
    assert!(e.to_string().contains("line 6, column `note`"), "{e}");
}

/// Issue 56, class 8: a `data csv` block without `include active(...)`
/// fell back to NanoBench's motor column and ended in "0 usable
/// deployment units remain"; `check` now asks for the clause.
#[test]
fn a_csv_block_without_include_is_refused_by_check() {
    let tmp = tempfile::tempdir().unwrap();
    let design = reordered_design(tmp.path(), "quaternion xyzw qx, qy, qz, qw")
        .replace("  include active(m1 > 1000) >= 20 samples\n", "");
    let e = crossaudit::design::from_str("study.design", &design).expect_err("no include");
    assert!(e.to_string().contains("`data csv` needs `include active(...)`"), "{e}");
}

/// Issue 56, classes 7 and 8: a conditions table is read as CSV. A quoted
/// name with a comma is one field (it was a field-count error), a
/// byte-order mark is dropped, a column named twice (a second `trajectory`
/// was ignored) and a control character in a name are refused at their
/// line.
#[test]
fn a_conditions_table_is_csv_and_refuses_what_it_cannot_mean() {
    let tmp = tempfile::tempdir().unwrap();
    for name in ["F1_circle_slow_rep1.csv", "F2_star_fast_mell_rep1.csv", "F4_linear_ramp_rep1.csv"] {
        rewrite(name, tmp.path());
    }
    let design = reordered_design(tmp.path(), "quaternion xyzw qx, qy, qz, qw")
        .replace("  rate 100 Hz\n", "  rate 100 Hz\n  conditions table \"conditions.csv\"\n");
    let generic = spec(&design);
    let table = "recording,trajectory,speed\nF1_circle_slow_rep1,\"lemniscate, wide\",fast\nF2_star_fast_mell_rep1,hover,slow\nF4_linear_ramp_rep1,ramp,medium\n";
    let write = |t: &str| std::fs::write(tmp.path().join("conditions.csv"), t).unwrap();
    write(&format!("\u{feff}{table}"));
    let audit = data::audit(&generic, tmp.path()).unwrap();
    let f1 = audit.files.iter().find(|f| f.name == "F1_circle_slow_rep1").unwrap();
    assert_eq!((f1.trajectory.as_str(), f1.speed.as_str()), ("lemniscate, wide", "fast"));
    write(
        &table
            .replace("recording,trajectory,speed", "recording,trajectory,speed,trajectory")
            .replace(",fast\n", ",fast,x\n")
            .replace(",slow\n", ",slow,x\n")
            .replace(",medium\n", ",medium,x\n"),
    );
    let e = data::audit(&generic, tmp.path()).unwrap_err().to_string();
    assert!(e.contains("line 1: column `trajectory` is named twice (columns 2 and 4)"), "{e}");
    write(&table.replace("hover", "ho\u{1b}[31mver"));
    let e = data::audit(&generic, tmp.path()).unwrap_err().to_string();
    assert!(
        e.contains("line 3, column `trajectory`") && e.contains("control character") && !e.contains('\u{1b}'),
        "{e}"
    );
}

/// Issue 57 (with round 5): a condition the design stratifies and groups by
/// that no recording has (a file-name pattern without `{speed}` under
/// `conditions trajectory, speed`) stops the split, where every speed
/// silently became `unknown` and one group.
#[test]
fn a_condition_unknown_for_every_recording_stops_the_split() {
    let tmp = tempfile::tempdir().unwrap();
    let logs = tmp.path().join("logs");
    std::fs::create_dir_all(&logs).unwrap();
    let fixtures = root().join("tests/fixtures/rotorpy/logs");
    for (from, to) in [
        ("R1_circle_slow_rep1", "2026-05-01_circle_take1"),
        ("R5_lissajous_medium_rep2", "2026-05-02_lissajous_take2"),
        ("R9_minsnap_fast_rep3", "2026-05-03_minsnap_take3"),
    ] {
        std::fs::copy(fixtures.join(format!("{from}.csv.gz")), logs.join(format!("{to}.csv.gz"))).unwrap();
    }
    let rotorpy = std::fs::read_to_string(root().join("designs/logs/rotorpy.design")).unwrap();
    let design = rotorpy
        .replace("path      \"../../tests/fixtures/rotorpy/logs\"", &format!("path \"{}\"", logs.display()))
        .replace("  controller se3\n", "  controller se3\n  conditions name \"{*}_{trajectory}_take{rep}\"\n");
    assert!(design.contains("conditions trajectory, speed"), "the design groups by speed");
    let path = tmp.path().join("d.design");
    std::fs::write(&path, design).unwrap();
    let o = bin().arg("split").arg(&path).arg("--out").arg(tmp.path().join("out")).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("conditions include speed, and it is unknown for every included recording"), "{err}");
}

/// Issue 77, class 2: logs in subfolders with `folders nested` forgotten
/// gave "none of its 0 log file(s) was included" and no hint. The audit
/// now names what lies below and the clause that reads it.
#[test]
fn logs_only_in_subfolders_without_folders_nested_get_the_hint() {
    let tmp = tempfile::tempdir().unwrap();
    let logs = tmp.path().join("logs");
    let sub = logs.join("day1");
    std::fs::create_dir_all(&sub).unwrap();
    for name in ["F1_circle_slow_rep1.csv", "F2_star_fast_mell_rep1.csv"] {
        rewrite(name, &sub);
    }
    let text = reordered_design(&logs, "quaternion xyzw qx, qy, qz, qw");
    let path = tmp.path().join("flat.design");
    std::fs::write(&path, &text).unwrap();
    let out = tmp.path().join("audit");
    let o = crate::common::crossaudit(&["data", "audit", path.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("its subfolders hold 2 (the first: day1/F1_circle_slow_rep1.csv)"), "{err}");
    assert!(err.contains("declare `folders nested`"), "{err}");
    // `run` says the same before any count of recordings.
    let o =
        crate::common::crossaudit(&["run", path.to_str().unwrap(), "--out", tmp.path().join("run").to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("declare `folders nested`"), "{err}");
}
