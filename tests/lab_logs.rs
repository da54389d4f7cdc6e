//! A real lab's logs as they come (issue 57): quaternions off unit length,
//! and the rest of what a lab's folder holds. The logs are the committed
//! NanoBench fixtures rewritten in another lab's layout (`logs::rewrite`).

use std::path::Path;

use crate::logs::{reordered_design, rewrite, spec};
use crossaudit::data::{self, load_recording, Layout, LogError};

const XYZW: &str = "quaternion xyzw qx, qy, qz, qw";

/// The rewritten logs' design with `attitude`, every flying row active
/// (the fixture flies at m1 = 1000).
fn design(dir: &Path, attitude: &str) -> crossaudit::design::DataSpec {
    spec(&reordered_design(dir, attitude).replace("active(m1 > 1000)", "active(m1 >= 1000)"))
}

/// Loads `path`, or gives the error (never a recording's Debug dump).
fn load(path: &Path, spec: &crossaudit::design::DataSpec) -> Result<crossaudit::data::Recording, LogError> {
    load_recording(path, &Layout::new(spec).unwrap())
}

/// The quaternion columns of a rewritten log multiplied by `factor` on
/// every row, as an estimator that does not renormalise logs them.
fn scale_quaternion(path: &Path, factor: f64) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let header: Vec<String> = lines[0].split(',').map(String::from).collect();
    let q: Vec<usize> = ["qx", "qy", "qz", "qw"].iter().map(|n| header.iter().position(|h| h == n).unwrap()).collect();
    for line in lines.iter_mut().skip(1) {
        let mut f: Vec<String> = line.split(',').map(String::from).collect();
        for &c in &q {
            f[c] = format!("{:.17e}", f[c].parse::<f64>().unwrap() * factor);
        }
        *line = f.join(",");
    }
    std::fs::write(path, lines.join("\n") + "\n").unwrap();
}

/// Issue 57, item 2: a logged quaternion 1.4% long is refused with the
/// file's largest deviation and the clause that accepts it; with `norm
/// within 0.02` the file loads, every quaternion has unit length, and the
/// audit reports the largest deviation it renormalised.
#[test]
fn a_quaternion_off_unit_length_is_accepted_only_as_declared_and_renormalised() {
    let tmp = tempfile::tempdir().unwrap();
    let name = "F3_oval_medium_rep1.csv";
    let plain_dir = tmp.path().join("plain");
    let long_dir = tmp.path().join("long");
    std::fs::create_dir_all(&plain_dir).unwrap();
    std::fs::create_dir_all(&long_dir).unwrap();
    let plain = rewrite(name, &plain_dir);
    let long = rewrite(name, &long_dir);
    scale_quaternion(&long, 1.014);

    // As logged: refused at the first active row, with the fix in words.
    let Err(e) = load(&long, &design(&long_dir, XYZW)) else { panic!("1.4% off unit length accepted") };
    let LogError::NotUnit { line, norm, largest, declared: false, .. } = &e else { panic!("{e:?}") };
    assert!(*line > 1 && (norm - 1.0).abs() > 0.01, "{e:?}");
    let text = e.to_string();
    assert!(text.contains("norm within 0.02") && text.contains(&format!("{largest:.4}")), "{text}");

    // A declared tolerance smaller than the deviation names itself.
    let Err(e) = load(&long, &design(&long_dir, &format!("{XYZW} norm within 0.01"))) else {
        panic!("beyond the declared tolerance accepted")
    };
    assert!(e.to_string().contains("the declared `norm within 0.01`"), "{e}");

    // Declared: loaded, renormalised to unit length; the deviation is the
    // file's own, computed here from the file's columns.
    let lenient = design(&long_dir, &format!("{XYZW} norm within 0.02"));
    let rec = load(&long, &lenient).unwrap_or_else(|e| panic!("{e}"));
    let q = rec.slots.quaternion_slots().unwrap();
    for s in &rec.state {
        let n = s[q.clone()].iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!((n - 1.0).abs() < 1e-12, "length {n} after renormalisation");
    }
    let base = load(&plain, &design(&plain_dir, XYZW)).unwrap_or_else(|e| panic!("{e}"));
    assert!(base.active_rows() > 100);
    let checked = base.tail.map_or(base.rows, |t| t.start);
    let expected = (0..checked)
        .filter(|&k| base.active[k])
        .map(|k| (1.014 * base.state[k][q.clone()].iter().map(|v| v * v).sum::<f64>().sqrt() - 1.0).abs())
        .fold(0.0, f64::max);
    let got = rec.quaternion_deviation.unwrap();
    assert!((got - expected).abs() < 1e-9 && got > 0.01, "{got} vs {expected}");
    // Renormalising the long quaternion gives the plain one's direction.
    for (a, b) in rec.state.iter().zip(&base.state) {
        let nb = b[q.clone()].iter().map(|v| v * v).sum::<f64>().sqrt();
        for (x, y) in a[q.clone()].iter().zip(&b[q.clone()]) {
            assert!((x - y / nb).abs() < 1e-12);
        }
    }
    // Only the quaternion changed.
    for (a, b) in rec.state.iter().zip(&base.state) {
        assert!(a[..q.start] == b[..q.start] && a[q.end..] == b[q.end..]);
    }

    // The audit: a column with each file's deviation, and the summary's line.
    let audit = data::audit(&lenient, &long_dir).unwrap();
    let csv = audit.to_csv();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let at = header.iter().position(|h| *h == "quaternion_max_deviation").expect("the column");
    let row: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(row[at].parse::<f64>().unwrap(), got);
    assert!(audit
        .summary()
        .contains(&format!("`norm within 0.02`): largest deviation from 1 among included recordings {got:.4}")));
    // Without the clause, no new column: every other audit is unchanged.
    let before = data::audit(&design(&plain_dir, XYZW), &plain_dir).unwrap().to_csv();
    assert!(!before.contains("quaternion_max_deviation"));
}

/// `norm within` is refused on Euler angles (they have no length) and
/// outside (0, 0.5], at its place.
#[test]
fn a_norm_tolerance_that_cannot_apply_is_refused_by_check() {
    let tmp = tempfile::tempdir().unwrap();
    for (attitude, needle) in [
        ("euler degrees roll_deg, pitch_deg, yaw_deg norm within 0.02", "norm tolerance on Euler angles"),
        (&format!("{XYZW} norm within 0.7") as &str, "bad norm tolerance"),
        (&format!("{XYZW} norm within 0") as &str, "bad norm tolerance"),
    ] {
        let design = reordered_design(tmp.path(), attitude);
        let e = crossaudit::design::from_str("study.design", &design).expect_err(attitude);
        let text = e.to_string();
        assert!(text.contains(needle) && text.contains("norm within"), "{text}");
        assert!(text.contains("study.design:8:"), "located at the attitude line: {text}");
    }
}
