//! Per-window published splits: `audit split` measures, for each window of
//! a role, the distance in time to the nearest window of another role in
//! the same recording (or a byte-identical copy). The committed fixture's
//! distances are worked out by hand; random splits are checked against a
//! brute-force search written here; bad files are refused at their place.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::root;
use crossaudit::design::DataSpec;
use crossaudit::published;
use crossaudit::split_audit::{self, SplitAudit};

fn fixture(name: &str) -> PathBuf {
    root().join("tests/fixtures/splits").join(name)
}

fn audit_file(path: &Path, gap_s: f64) -> SplitAudit {
    let split = published::read(path).unwrap();
    let options = split_audit::AuditOptions { gap_s, ..Default::default() };
    split_audit::audit(&split, &DataSpec::upstream_task2(), "upstream", &fixture("data"), options).unwrap()
}

fn cli(args: &[&str]) -> (Option<i32>, String, String) {
    let out = crate::common::bin().current_dir(root()).args(args).output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// tests/fixtures/splits/windows.csv, by hand (make_nanobench_fixtures.py
/// writes it; every recording there is 260 rows at 100 Hz, 2.59 s, and S1
/// rep2 is a byte-identical copy of S1 rep1):
/// - test S1r1 [0.5, 1.0) touches train [0, 0.5) and [1.0, 1.5): 0 s, no
///   shared time; test S1r1 [2.0, 2.5) is 0.5 s after train [1.0, 1.5);
///   test S1r2 [1.2, 1.4) lies inside train S1r1 [1.0, 1.5): overlap;
///   test S3 [2.5, 3.0) is 1.5 s after train [0, 1) and ends past 2.59 s;
///   test S2 has no train window in its recording.
/// - test distances {0, 0.5, 0, 1.5}: 3 below 1 s; type-7 quantiles of
///   (0, 0, 0.5, 1.5) are 0, 0, 0.25, 0.75, 1.5.
/// - train: S1r1 [0, 0.5) touches test [0.5, 1.0); [1.0, 1.5) holds test's
///   [1.2, 1.4); S3 [0, 1) is 1.5 s before test's [2.5, 3.0); S4 has no
///   test window. Distances {0, 0, 1.5}: quantiles 0, 0, 0, 0.75, 1.5.
#[test]
fn the_fixture_split_window_by_window() {
    let a = audit_file(&fixture("windows.csv"), 1.0);
    assert!(a.windowed);
    let pair = |r: &str, o: &str| a.distances.iter().find(|d| d.role == r && d.other == o).unwrap();
    let test = pair("test", "train");
    assert_eq!((test.windows, test.in_shared_recording, test.overlapping, test.within_gap), (5, 4, 1, 3));
    assert_eq!(test.quantiles_s, Some([0.0, 0.0, 0.25, 0.75, 1.5]));
    let train = pair("train", "test");
    assert_eq!((train.windows, train.in_shared_recording, train.overlapping, train.within_gap), (4, 3, 1, 2));
    assert_eq!(train.quantiles_s, Some([0.0, 0.0, 0.0, 0.75, 1.5]));
    let rows: Vec<(&str, usize, usize, f64, bool)> = a
        .windows
        .iter()
        .filter(|w| w.role == "test")
        .map(|w| (w.recording.as_str(), w.line, w.nearest.2, w.distance_s, w.overlaps))
        .collect();
    assert_eq!(
        rows,
        [
            ("S1_circle_slow_rep1", 6, 2, 0.0, false),
            ("S1_circle_slow_rep1", 7, 3, 0.5, false),
            ("S1_circle_slow_rep2", 8, 3, 0.0, true),
            ("S3_oval_medium_rep1", 10, 4, 1.5, false),
        ]
    );
    let past: Vec<bool> = a.windows.iter().filter(|w| w.role == "test").map(|w| w.past_end).collect();
    assert_eq!(past, [false, false, false, true]);
    assert_eq!(a.roles.iter().map(|r| (r.windows, r.windows_past_end)).collect::<Vec<_>>(), [(4, 0), (5, 1)]);
    // One row per role and recording; S1 rep1 sits in both roles, and
    // only S1 rep2 (another recording, a copy) makes an identity leak.
    let s1 = a.recordings.iter().filter(|r| r.recording == "S1_circle_slow_rep1").count();
    assert_eq!(s1, 2);
    assert_eq!(a.exact.len(), 1);
    let test_s1 = a.recordings.iter().find(|r| r.recording == "S1_circle_slow_rep1" && r.role == "test").unwrap();
    assert_eq!(test_s1.identical_in_other_roles, Vec::<String>::new());
    assert_eq!(test_s1.windows, 2);
    // A narrower gap counts fewer: below 0.4 s only the 0 s windows.
    let narrow = audit_file(&fixture("windows.csv"), 0.4);
    assert_eq!(narrow.distances.iter().map(|d| d.within_gap).collect::<Vec<_>>(), [2, 2]);
}

/// Whole recordings: roles meet only through copies, which overlap
/// entirely (S1 rep2 in test is S1 rep1 in train).
#[test]
fn whole_recording_splits_meet_only_through_copies() {
    let a = audit_file(&fixture("nanobench_small.json"), 1.0);
    assert!(!a.windowed);
    let test = a.distances.iter().find(|d| d.role == "test" && d.other == "train").unwrap();
    assert_eq!((test.windows, test.in_shared_recording, test.overlapping), (3, 1, 1));
    assert_eq!(test.quantiles_s, Some([0.0; 5]));
    let w: Vec<(&str, &str)> = a.windows.iter().map(|w| (w.recording.as_str(), w.nearest.0.as_str())).collect();
    assert_eq!(w, [("S1_circle_slow_rep1", "S1_circle_slow_rep2"), ("S1_circle_slow_rep2", "S1_circle_slow_rep1")]);
    let folds = audit_file(&fixture("folds.csv"), 1.0);
    assert!(folds.distances.iter().all(|d| d.in_shared_recording == 0), "S1's copies share fold 0");
}

/// A small generator so the random splits are the same on every machine.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The sorted-index search against every pair of windows: 20 random
/// splits of three roles over the fixture recordings (two of them copies),
/// windows on a 0.05 s grid so touching and nested windows are common, and
/// starting up to 3.0 s, past the recordings' last timestamp (2.59 s: 260
/// rows at 100 Hz), where two windows that meet share no row.
#[test]
fn nearest_windows_match_a_brute_force_search() {
    let names = ["S1_circle_slow_rep1", "S1_circle_slow_rep2", "S2_star_fast_rep1", "S3_oval_medium_rep1"];
    // S1 rep2 is S1 rep1 byte for byte: the same content.
    fn content(n: &str) -> &str {
        if n == "S1_circle_slow_rep2" {
            "S1_circle_slow_rep1"
        } else {
            n
        }
    }
    let tmp = tempfile::tempdir().unwrap();
    let mut rng = Lcg(59);
    for study in 0..20 {
        let mut text = String::from("recording,role,start_s,end_s\n");
        let mut windows: Vec<(String, &str, f64, f64)> = Vec::new();
        for _ in 0..(5 + study * 3) {
            let n = names[(rng.next() * 4.0) as usize];
            let role = ["a", "b", "c"][(rng.next() * 3.0) as usize];
            let start = (rng.next() * 61.0).floor() * 0.05;
            let end = start + (1.0 + (rng.next() * 12.0).floor()) * 0.05;
            let (start, end) = ((start * 100.0).round() / 100.0, (end * 100.0).round() / 100.0);
            if windows.iter().any(|w| w.0 == n && w.1 == role && w.2 == start && w.3 == end) {
                continue;
            }
            text.push_str(&format!("{n},{role},{start},{end}\n"));
            windows.push((n.to_string(), role, start, end));
        }
        let path = tmp.path().join(format!("w{study}.csv"));
        std::fs::write(&path, text).unwrap();
        let a = audit_file(&path, 0.3);
        let mut want: BTreeMap<(usize, String), (f64, bool)> = BTreeMap::new();
        for (k, (n, role, s, e)) in windows.iter().enumerate() {
            for other in ["a", "b", "c"].iter().filter(|o| *o != role) {
                let mut best: Option<(f64, bool)> = None;
                for (m, orole, os, oe) in &windows {
                    if orole != other || content(m) != content(n) {
                        continue;
                    }
                    let d = (os - e).max(s - oe).max(0.0);
                    // Shared time that begins before the last row (2.59 s)
                    // plus half a sample interval.
                    let overlap = os < e && oe > s && s.max(*os) < 2.595;
                    best = Some(match best {
                        Some((bd, bo)) if bd < d => (bd, bo),
                        Some((bd, bo)) if bd == d => (bd, bo || overlap),
                        _ => (d, overlap),
                    });
                }
                if let Some(b) = best {
                    want.insert((k + 2, other.to_string()), b);
                }
            }
        }
        let got: BTreeMap<(usize, String), (f64, bool)> =
            a.windows.iter().map(|w| ((w.line, w.other.clone()), (w.distance_s, w.overlaps))).collect();
        assert_eq!(got.len(), want.len(), "study {study}: windows with a shared recording");
        for (key, (d, overlap)) in &want {
            let (gd, go) = got[key];
            assert!((gd - d).abs() < 1e-12, "study {study} line {} against {}: {gd} vs {d}", key.0, key.1);
            // At distance 0 the nearest may touch where another overlaps:
            // an overlap anywhere is what counts.
            assert_eq!(go, *overlap, "study {study} line {} against {}", key.0, key.1);
        }
        for d in &a.distances {
            let mine: Vec<&(f64, bool)> =
                want.iter().filter(|((k, o), _)| *o == d.other && windows[k - 2].1 == d.role).map(|(_, v)| v).collect();
            assert_eq!(d.in_shared_recording, mine.len());
            assert_eq!(d.overlapping, mine.iter().filter(|v| v.1).count());
            assert_eq!(d.within_gap, mine.iter().filter(|v| v.0 < 0.3).count());
        }
    }
}

/// Two windows that meet only past the end of their recording (S3 is
/// 2.59 s long) share no row: not an overlap, but both ends past the log
/// are counted; where they meet at the last row (2.59 s) they share it.
#[test]
fn windows_that_meet_past_the_end_share_no_row() {
    let tmp = tempfile::tempdir().unwrap();
    let split = tmp.path().join("past.csv");
    let write = |text: &str| std::fs::write(&split, text).unwrap();
    write("recording,role,start_s,end_s\nS3_oval_medium_rep1,train,0,3.5\nS3_oval_medium_rep1,test,3,4\n");
    let a = audit_file(&split, 1.0);
    let test = a.distances.iter().find(|d| d.role == "test").unwrap();
    assert_eq!((test.in_shared_recording, test.overlapping, test.quantiles_s.map(|q| q[2])), (1, 0, Some(0.0)));
    assert_eq!(a.roles.iter().map(|r| r.windows_past_end).collect::<Vec<_>>(), [1, 1]);
    write("recording,role,start_s,end_s\nS3_oval_medium_rep1,train,0,3.5\nS3_oval_medium_rep1,test,2.59,4\n");
    let a = audit_file(&split, 1.0);
    assert!(a.distances.iter().all(|d| d.overlapping == 1), "the last row, at 2.59 s, is in both");
}

#[test]
fn the_cli_writes_the_windows_and_fails_on_a_gap_when_asked() {
    let tmp = tempfile::tempdir().unwrap();
    let split = tmp.path().join("apart.csv");
    // 0.5 s apart, no copy, no overlap: no leak, but inside a 1 s gap.
    std::fs::write(
        &split,
        "recording,role,start_s,end_s\nS3_oval_medium_rep1,train,0,1\nS3_oval_medium_rep1,test,1.5,2\n",
    )
    .unwrap();
    let out = tmp.path().join("audit");
    let base = [
        "audit",
        "split",
        split.to_str().unwrap(),
        "--data",
        "tests/fixtures/splits/data",
        "--out",
        out.to_str().unwrap(),
    ];
    let (code, stdout, stderr) = cli(&[&base[..], &["--fail-on", "leak"]].concat());
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stdout.contains("1 lie within the 1 s gap; median distance 0.5 s"), "{stdout}");
    let windows = std::fs::read_to_string(out.join("split_windows.csv")).unwrap();
    assert_eq!(windows.lines().count(), 3, "{windows}");
    assert!(windows.lines().nth(2).unwrap().ends_with(",0.5,false,true,false"), "{windows}");
    let (code, _, stderr) = cli(&[&base[..], &["--fail-on", "gap"]].concat());
    assert_eq!(code, Some(3), "{stderr}");
    assert!(stderr.contains("windows within the gap found"), "{stderr}");
    let (code, _, stderr) = cli(&[&base[..], &["--fail-on", "gap", "--gap", "0.4"]].concat());
    assert_eq!(code, Some(0), "0.5 s keeps a 0.4 s gap: {stderr}");
    for bad in ["0", "-1", "nan", "inf", "1s"] {
        let (code, _, stderr) = cli(&[&base[..], &[&format!("--gap={bad}")[..]]].concat());
        assert_eq!(code, Some(2), "--gap {bad}: {stderr}");
        assert!(stderr.contains("is not a number of seconds above 0"), "{stderr}");
    }
    // Overlapping windows are a leak.
    let (code, _, stderr) = cli(&[
        "audit",
        "split",
        "tests/fixtures/splits/windows.csv",
        "--data",
        "tests/fixtures/splits/data",
        "--out",
        out.to_str().unwrap(),
        "--fail-on",
        "leak",
    ]);
    assert_eq!(code, Some(3), "{stderr}");
}

/// Each malformed per-window file is refused at its line and column.
#[test]
fn bad_windows_are_refused_where_they_are() {
    let tmp = tempfile::tempdir().unwrap();
    let cases = [
        ("recording,role,start_s\nS1,train,0\n", "1:16", "gives both `start_s` and `end_s`"),
        ("recording,role,start_s,end_s\nS1,train,1,1\n", "2:12", "ends at 1 s, not after its start at 1 s"),
        ("recording,role,start_s,end_s\nS1,train,-1,1\n", "2:10", "`start_s` \"-1\" is not a time"),
        ("recording,role,start_s,end_s\nS1,train,0,\n", "2:12", "empty `end_s`"),
        ("recording,role,start_s,end_s\nS1,train,0,NaN\n", "2:12", "`end_s` \"NaN\" is not a time"),
        (
            "recording,role,start_s,end_s\nS1,train,0,1\nS1,test,0,1\nS1,train,0,1\n",
            "4:1",
            "listed twice in role `train` (first at line 2, column 1)",
        ),
    ];
    for (k, (text, place, message)) in cases.iter().enumerate() {
        let path = tmp.path().join(format!("bad{k}.csv"));
        std::fs::write(&path, text).unwrap();
        let e = published::read(&path).unwrap_err().to_string();
        assert!(e.contains(&format!("bad{k}.csv:{place}: ")), "{k}: {e}");
        assert!(e.contains(message), "{k}: {e}");
    }
    // The same window in two roles is not a file error: the audit reports it.
    let path = tmp.path().join("both.csv");
    std::fs::write(&path, "recording,role,start_s,end_s\nS1,train,0,1\nS1,test,0,1\n").unwrap();
    assert!(published::read(&path).is_ok());
    // Twenty-one roles of windows are refused at the twenty-first.
    let many: String = (0..21).map(|k| format!("S1,r{k},0,1\n")).collect();
    std::fs::write(&path, format!("recording,role,start_s,end_s\n{many}")).unwrap();
    let e = published::read(&path).unwrap_err().to_string();
    assert!(e.contains(":22:") && e.contains("more than the 20"), "{e}");
}

/// A design's `split published` assigns recordings: a per-window file is
/// refused at its first window, naming `audit split`.
#[test]
fn a_design_refuses_a_per_window_split() {
    let path = root().join("tests/designs/published_fixture.design");
    let text = std::fs::read_to_string(&path).unwrap().replace("pin.json", "windows.csv");
    let e = crossaudit::design::from_str_in("published_fixture.design", &text, &root().join("tests/designs"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("windows.csv:2:1: this split assigns windows"), "{e}");
    assert!(e.contains("crossaudit audit split"), "{e}");
}

/// results/nanobench_window_split: scripts/window_splits.py writes the
/// three committed split files, the binary writes the committed audits,
/// and their distance rows agree with scripts/reference/window_split_reference.py
/// (brute force, standard library; its output committed beside it).
#[test]
#[ignore = "needs ../shared/nanobench"]
fn committed_window_split_audits_are_current_and_match_the_python_reference() {
    let _logs = crate::needs_shared_logs!();
    let _ = crate::common::shared_logs();
    let logs = "../shared/nanobench/recordings";
    let tmp = tempfile::tempdir().unwrap();
    let committed = root().join("results/nanobench_window_split");
    let status = Command::new("python3")
        .current_dir(root())
        .arg("scripts/window_splits.py")
        .arg(logs)
        .arg(tmp.path().join("splits"))
        .output()
        .unwrap();
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    let reference: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("scripts/reference/window_split_reference.out")).unwrap(),
    )
    .unwrap();
    for name in ["random", "chronological", "embargo"] {
        let file = format!("{name}.csv");
        let fresh_split = std::fs::read_to_string(tmp.path().join("splits").join(&file)).unwrap();
        assert_eq!(fresh_split, std::fs::read_to_string(committed.join("splits").join(&file)).unwrap(), "{file}");
        let out = tmp.path().join(name);
        let split = format!("results/nanobench_window_split/splits/{file}");
        let (code, _, stderr) = cli(&["audit", "split", &split, "--data", logs, "--out", out.to_str().unwrap()]);
        assert_eq!(code, Some(0), "{stderr}");
        for f in ["split_audit.md", "split_audit.json", "split_recordings.csv", "split_windows.csv"] {
            let want = std::fs::read_to_string(committed.join(name).join(f)).unwrap();
            let got = std::fs::read_to_string(out.join(f)).unwrap();
            assert_eq!(got, want, "{name}/{f} differs from a fresh run (regenerate with its COMMAND)");
        }
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("split_audit.json")).unwrap()).unwrap();
        for d in json["distances"].as_array().unwrap() {
            let key = format!("{}/{}", d["role"].as_str().unwrap(), d["other"].as_str().unwrap());
            let want = &reference[name][&key];
            for field in ["windows", "in_shared_recording", "overlapping", "within_gap"] {
                assert_eq!(d[field], want[field], "{name} {key} {field}");
            }
            let q = |v: &serde_json::Value| -> Vec<f64> {
                v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
            };
            let (got, want) = (q(&d["quantiles_s"]), q(&want["quantiles_s"]));
            assert!(got.iter().zip(&want).all(|(a, b)| (a - b).abs() < 1e-12), "{name} {key}: {got:?} vs {want:?}");
        }
    }
}
