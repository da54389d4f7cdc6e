//! Issue 57, items 3 and 4: declared policies for missing values and time
//! gaps (refuse, exclude, or cut the recording into segments that no
//! window crosses), the fewest recordings an audit may keep, a conditions
//! table's columns mapped by name, and the folder as a condition. Every
//! log is written here as CSV with its defect at a known row.

use std::path::Path;

use crossaudit::data::{self, Status};

/// A 100 Hz log of a circle at 1 m/s, 6 s, actions varying: `edit` may
/// change each row's fields (t, x, y, z, m1, as text) before it is written.
fn circle(path: &Path, edit: &dyn Fn(usize, &mut Vec<String>)) {
    let mut text = String::from("t,x,y,z,m1\n");
    for k in 0..600 {
        let t = k as f64 * 0.01;
        let m1 = 0.6 + 0.1 * (3.0 * t).sin();
        let mut row: Vec<String> = [t, t.cos(), t.sin(), 1.0, m1].iter().map(|v| format!("{v:?}")).collect();
        edit(k, &mut row);
        text += &(row.join(",") + "\n");
    }
    std::fs::write(path, text).unwrap();
}

/// Six logs: four clean, one with x missing on rows 200 to 202 (an empty
/// field, `NaN`, an empty field), one whose time jumps by 2 s after row 299.
fn six_logs(dir: &Path) {
    for k in 1..=4 {
        circle(&dir.join(format!("clean_{k}.csv")), &|_, r| r[3] = format!("1.{k}"));
    }
    circle(&dir.join("holes_1.csv"), &|k, r| match k {
        200 | 202 => r[1] = String::new(),
        201 => r[1] = "NaN".into(),
        _ => {}
    });
    circle(&dir.join("stall_1.csv"), &|k, r| {
        if k >= 300 {
            r[0] = format!("{:?}", k as f64 * 0.01 + 2.0);
        }
    });
}

/// The four logs' design, with `extra` clauses in the data block.
fn design(dir: &Path, extra: &str) -> String {
    format!(
        r#"study "holes"
data csv {{
  path "{}"
  rate 100 Hz
  time t
  position x, y, z
  action m1 scale 1
  include active(m1 > 0.1) >= 20 samples
{extra}
}}
factor recording {{ evaluation 2 split_seed 3; starts 3 horizon 20 }}
factor seed = 1..2
validation 60 windows from 1 recordings seed 5
arm disjoint {{ fit 1000 windows seed 1 }}
arm contaminated {{ from disjoint replace 25% with evaluation windows exclude starts seed 2 }}
train {{ adam lr 1e-3 batch 64 epochs 2 cosine patience 2 action_noise 0 }}
model world = mlp(32, 32) inputs world
endpoint primary fa_position_rmse at 0.1 s cap 2 m model world
contrast contaminated - disjoint
estimate crossed_mom level 0.95 df seed - 1
decide confirmed when optimism >= 10% and upper < 0
"#,
        dir.display()
    )
}

fn spec(text: &str) -> crossaudit::design::DataSpec {
    crossaudit::design::from_str("holes.design", text).unwrap_or_else(|e| panic!("{}", e.render(false))).data
}

/// Without a policy a missing value or a gap makes the file unreadable (at
/// its line and column); `refuse` stops the audit there; `exclude` leaves
/// the recording out by the declared rule, listed in the audit.
#[test]
fn missing_values_and_gaps_are_refused_or_excluded_as_declared() {
    let tmp = tempfile::tempdir().unwrap();
    six_logs(tmp.path());
    let reason = |audit: &data::Audit, name: &str| {
        let f = audit.files.iter().find(|f| f.name == name).unwrap();
        (f.status, f.reason.clone())
    };
    let audit = data::audit(&spec(&design(tmp.path(), "")), tmp.path()).unwrap();
    let (status, why) = reason(&audit, "holes_1");
    assert_eq!(status, Status::Excluded);
    // Row 200 is line 202 (the header is line 1).
    assert!(why.ends_with("holes_1.csv: line 202, column `x`: the field is empty (a missing value: in a column the design reads, `missing values segment` or `missing values exclude` in the data block decides what it does)"), "{why}");
    let (status, why) = reason(&audit, "stall_1");
    assert_eq!(status, Status::Excluded);
    assert!(why.contains("line 302, column `t`: the time jumps by 2.01"), "{why}");
    assert!(why.contains("declare `gaps over T s segment`"), "{why}");
    assert_eq!(audit.unread().count(), 2);

    let refuse = spec(&design(tmp.path(), "  missing values refuse"));
    let e = data::audit(&refuse, tmp.path()).unwrap_err().to_string();
    assert!(e.starts_with("`missing values refuse`: "), "{e}");
    assert!(e.contains("holes_1.csv: line 202, column `x`: the field is empty"), "{e}");
    let refuse = spec(&design(tmp.path(), "  gaps over 0.5 s refuse\n  missing values segment"));
    let e = data::audit(&refuse, tmp.path()).unwrap_err().to_string();
    assert!(e.starts_with("`gaps over 0.5 s refuse`: "), "{e}");
    assert!(e.contains("stall_1.csv: line 302, column `t`: the time jumps by 2.010 s"), "{e}");
    assert!(e.contains("longer than the declared `gaps over 0.5 s`"), "{e}");

    let exclude = spec(&design(tmp.path(), "  missing values exclude\n  gaps over 0.5 s exclude"));
    let audit = data::audit(&exclude, tmp.path()).unwrap();
    assert_eq!(audit.unread().count(), 0, "excluded by a declared rule, not unreadable");
    assert_eq!(
        reason(&audit, "holes_1"),
        (
            Status::Excluded,
            "`missing values exclude`: 3 row(s) with a missing value (first line 202, column `x`: missing value)"
                .into()
        )
    );
    assert_eq!(
        reason(&audit, "stall_1"),
        (Status::Excluded, "`gaps over 0.5 s exclude`: 1 gap(s) (first line 302: the time jumps by 2.010 s)".into())
    );
    assert_eq!(reason(&audit, "clean_1").0, Status::Included);
    // Each policy is a rule column of recordings.csv, with its verdict.
    let csv = audit.to_csv();
    let header = csv.lines().next().unwrap();
    assert!(header.contains("rule2: `missing values exclude`,rule3: `gaps over 0.5 s exclude`"), "{header}");
    let clean = csv.lines().find(|l| l.starts_with("clean_1,")).unwrap();
    assert!(clean.contains("pass: none,pass: none,included"), "{clean}");
    // `strict` refuses unreadable files, not these declared exclusions.
    let strict = spec(&design(tmp.path(), "  missing values exclude\n  gaps over 0.5 s exclude\n  strict"));
    assert!(data::audit(&strict, tmp.path()).is_ok());
}

/// `segment` keeps both recordings: exactly the rows with a missing value
/// and the first row after the gap become unusable, no value is NaN, and
/// no training window, validation window or rollout of the split reaches
/// across a cut.
#[test]
fn segments_keep_the_recording_and_no_window_crosses_a_cut() {
    let tmp = tempfile::tempdir().unwrap();
    six_logs(tmp.path());
    let text = design(tmp.path(), "  missing values segment\n  gaps over 0.5 s segment");
    let file = crossaudit::design::from_str("holes.design", &text).unwrap();
    let (audit, recordings) = data::audit_and_load(&file.data, tmp.path()).unwrap();
    assert_eq!(audit.included().count(), 6);
    let rec = |name: &str| recordings.iter().find(|r| r.name == name).unwrap();
    let inactive = |name: &str| -> Vec<usize> { (0..600).filter(|&k| !rec(name).active[k]).collect() };
    assert_eq!(inactive("clean_1"), Vec::<usize>::new());
    assert_eq!(inactive("holes_1"), vec![200, 201, 202]);
    assert_eq!(inactive("stall_1"), vec![300]);
    assert!(rec("holes_1").state.iter().flatten().all(|v| v.is_finite()));
    // The missing x is held at row 199's reading (used by no window).
    assert_eq!(rec("holes_1").state[201][0], 1.99f64.cos());
    let holes = audit.files.iter().find(|f| f.name == "holes_1").unwrap();
    assert_eq!(
        holes.verdicts[1].detail,
        "3 row(s) with a missing value, cut there (first line 202, column `x`: missing value)"
    );
    let split = crossaudit::split::build(&file, &audit, &recordings).unwrap_or_else(|e| panic!("{e}"));
    let cut = |w: &crossaudit::split::Window, len: usize| {
        let name = &split.recordings[w.recording].name;
        let r = rec(name);
        (w.t..=w.t + len).any(|k| !r.active[k])
    };
    let mut windows: Vec<&crossaudit::split::Window> = split.validation.iter().collect();
    for (_, fit) in &split.fits {
        windows.extend(fit);
    }
    // 1000 fit windows of about 1800: both cut recordings are drawn from.
    let names: std::collections::BTreeSet<&str> =
        windows.iter().map(|w| split.recordings[w.recording].name.as_str()).collect();
    assert!(names.contains("holes_1") || names.contains("stall_1"), "{names:?}");
    assert!(windows.iter().all(|w| !cut(w, 1)), "a window crosses a cut");
    assert!(split.starts.iter().all(|w| !cut(w, split.horizon)), "a rollout crosses a cut");
}

/// An audit that loses more than half of its logs to unreadable files
/// stops (it used to exit 0 having kept 4 of 21), naming the first reason
/// and the clause that accepts it; `require at least N recordings` sets
/// the fewest it may keep, either way.
#[test]
fn an_audit_keeping_too_few_recordings_stops_after_writing_itself() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("logs");
    std::fs::create_dir(&data).unwrap();
    six_logs(&data);
    // Four of six unreadable: two more defects.
    std::fs::write(data.join("clean_2.csv"), "t,x,y\n0,1,2\n").unwrap();
    std::fs::write(data.join("clean_3.csv"), "t,x,y\n0,1,2\n").unwrap();
    let audit_cli = |extra: &str| {
        let path = tmp.path().join("d.design");
        std::fs::write(&path, design(&data, extra)).unwrap();
        let out = tmp.path().join(format!("out{}", extra.len()));
        let o = crate::common::bin().args(["data", "audit"]).arg(&path).arg("--out").arg(&out).output().unwrap();
        (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned(), out.join("recordings.csv").exists())
    };
    let (code, err, written) = audit_cli("");
    assert_eq!(code, Some(1), "{err}");
    assert!(written, "the audit is written before it stops");
    assert!(err.contains("the audit kept 2 of 6 log file(s): 4 of them could not be read, more than half"), "{err}");
    assert!(err.contains("declare `require at least 2 recordings` to accept this audit"), "{err}");
    let (code, err, _) = audit_cli("  require at least 2 recordings");
    assert_eq!(code, Some(0), "{err}");
    let (code, err, _) = audit_cli("  require at least 3 recordings");
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("the design requires at least 3 (`require at least 3 recordings`); 4 unreadable"), "{err}");
}

/// A conditions table whose columns have the lab's names is read through
/// `columns ROLE = NAME`; a mapped column the table lacks is refused with
/// the mapping and the table's columns.
#[test]
fn a_conditions_table_maps_its_columns_by_name() {
    let tmp = tempfile::tempdir().unwrap();
    circle(&tmp.path().join("run_a.csv"), &|_, _| {});
    circle(&tmp.path().join("run_b.csv"), &|_, r| r[3] = "1.1".into());
    std::fs::write(tmp.path().join("runs.csv"), "run_id,traj,velocity\nrun_a,circle,slow\nrun_b,figure8,fast\n")
        .unwrap();
    let mapped = "  conditions table \"runs.csv\" columns recording = run_id, trajectory = traj, speed = velocity";
    let audit = data::audit(&spec(&design(tmp.path(), mapped)), tmp.path()).unwrap_or_else(|e| panic!("{e}"));
    let got: Vec<(&str, &str, &str)> =
        audit.files.iter().map(|f| (f.name.as_str(), f.trajectory.as_str(), f.speed.as_str())).collect();
    assert_eq!(got, [("run_a", "circle", "slow"), ("run_b", "figure8", "fast")]);
    // Unmapped, the table has no `recording` column: refused, with the way out.
    let unmapped = "  conditions table \"runs.csv\"";
    let e = data::audit(&spec(&design(tmp.path(), unmapped)), tmp.path()).unwrap_err().to_string();
    assert!(e.contains("runs.csv: line 1: the conditions table needs a `recording` column (it has: run_id, traj, velocity); map another with `columns recording = NAME`"), "{e}");
    let wrong = "  conditions table \"runs.csv\" columns recording = run_id, speed = speed_mps";
    let e = data::audit(&spec(&design(tmp.path(), wrong)), tmp.path()).unwrap_err().to_string();
    assert!(e.contains("the conditions table has no column `speed_mps`, which the design maps to speed (`columns speed = speed_mps`); it has: run_id, traj, velocity"), "{e}");
    // A role mapped twice is refused by check, at its place.
    let twice = "  conditions table \"runs.csv\" columns speed = velocity, speed = traj";
    let e = crossaudit::design::from_str("holes.design", &design(tmp.path(), twice)).unwrap_err();
    assert!(e.render(false).contains("table column mapped twice"), "{}", e.render(false));
    assert!(e.render(false).contains("holes.design:9:57"), "{}", e.render(false));
}

/// `conditions folder speed` takes each recording's speed from the folder
/// it sits in; `check` refuses it without `folders nested` or beside a
/// pattern that gives the speed too, and the audit refuses a log outside
/// any folder.
#[test]
fn the_folder_a_recording_sits_in_is_a_condition() {
    let tmp = tempfile::tempdir().unwrap();
    for (folder, name) in [("slow", "a_1"), ("slow", "b_1"), ("fast", "a_2"), ("fast", "b_2")] {
        std::fs::create_dir_all(tmp.path().join(folder)).unwrap();
        circle(&tmp.path().join(folder).join(format!("{name}.csv")), &|_, r| r[3] = format!("1.{}", name.len()));
    }
    let clauses = "  folders nested\n  conditions folder speed\n  conditions name \"{trajectory}_{rep}\"";
    let audit = data::audit(&spec(&design(tmp.path(), clauses)), tmp.path()).unwrap_or_else(|e| panic!("{e}"));
    let got: Vec<(&str, &str, &str)> =
        audit.files.iter().map(|f| (f.file.as_str(), f.trajectory.as_str(), f.speed.as_str())).collect();
    assert_eq!(
        got,
        [
            ("slow/a_1.csv", "a", "slow"),
            ("fast/a_2.csv", "a", "fast"),
            ("slow/b_1.csv", "b", "slow"),
            ("fast/b_2.csv", "b", "fast")
        ]
    );
    // A log beside the folders has no folder to give its speed.
    circle(&tmp.path().join("c_1.csv"), &|_, _| {});
    let e = data::audit(&spec(&design(tmp.path(), clauses)), tmp.path()).unwrap_err().to_string();
    assert!(e.contains("c_1.csv sits in no folder, and `conditions folder speed` takes each recording's speed from the folder it sits in"), "{e}");
    // A folder that is not a speed label the design's rule can give.
    std::fs::remove_file(tmp.path().join("c_1.csv")).unwrap();
    std::fs::rename(tmp.path().join("fast"), tmp.path().join("quick")).unwrap();
    let e = data::audit(&spec(&design(tmp.path(), clauses)), tmp.path()).unwrap_err().to_string();
    assert!(e.contains("`conditions folder speed` gives quick/a_2.csv the speed `quick`"), "{e}");
    for (clauses, title) in [
        ("  conditions folder speed", "conditions folder without folders"),
        (
            "  folders nested\n  conditions folder speed\n  conditions name \"{trajectory}_{speed}\"",
            "condition given twice",
        ),
        ("  gaps over 0.01 s segment", "gap shorter than a step"),
    ] {
        let e = crossaudit::design::from_str("holes.design", &design(tmp.path(), clauses)).unwrap_err();
        assert_eq!(e.diagnostics[0].title, title, "{}", e.render(false));
    }
}

/// A `gaps` policy in a block with no time column could never find a gap
/// (row k is at k / rate): refused at its line, with the fix.
#[test]
fn a_gaps_policy_without_a_time_column_is_refused_at_its_line() {
    let tmp = tempfile::tempdir().unwrap();
    let text = design(tmp.path(), "  gaps over 0.5 s segment").replace("  time t\n", "");
    let e = crossaudit::design::from_str("holes.design", &text).unwrap_err().render(false);
    assert!(e.contains("error: gaps without a time column"), "{e}");
    assert!(e.contains("holes.design:8:3") && e.contains("declare the time column (`time COLUMN`)"), "{e}");
    // With the time column it stands.
    assert!(crossaudit::design::from_str("holes.design", &design(tmp.path(), "  gaps over 0.5 s segment")).is_ok());
}
