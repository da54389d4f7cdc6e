//! Contamination at a declared distance from the evaluated segments
//! (`at least G s from segments`, `G1 s to G2 s from segments`, issue 59):
//! every contaminating window the split draws lies at that distance, each
//! distance recomputed here from the manifests the real CLI writes (the
//! windows and the registered starts, by recording name and row); a
//! distance the recordings cannot supply is refused at its clause.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use crate::common::{assert_ok, assert_refused, root};

/// The small simulated design (100 Hz, rollouts of 100 samples from 10
/// starts in each of 4 evaluation recordings, 750 windows replaced), its
/// contaminated arm given `clause`.
fn design_with(dir: &Path, name: &str, clause: &str) -> std::path::PathBuf {
    let text = std::fs::read_to_string(root().join("tests/designs/sim_small.design")).unwrap();
    let from = "exclude starts seed 7";
    assert!(text.contains(from));
    let path = dir.join(name);
    std::fs::write(&path, text.replace(from, &format!("exclude starts {clause} seed 7"))).unwrap();
    path
}

fn split(design: &Path, out: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_crossaudit"))
        .args(["split", &design.display().to_string(), "--out", &out.display().to_string()])
        .env("NO_COLOR", "1")
        .output()
        .unwrap()
}

/// A manifest's (recording, row) pairs.
fn rows(path: &Path) -> Vec<(String, usize)> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("recording,sample_index"), "{}", path.display());
    lines
        .map(|l| {
            let (r, t) = l.rsplit_once(',').unwrap();
            (r.to_string(), t.parse().unwrap())
        })
        .collect()
}

/// Each contaminating window's distance in samples to the nearest evaluated
/// segment of its recording (rows s to s + 100 from each start s; a window
/// is its rows t and t + 1), from the manifests alone.
// The three cases written out (before, after, sharing a row), not as the
// library's saturating subtraction: an independent count.
#[allow(clippy::implicit_saturating_sub)]
fn distances(out: &Path) -> Vec<usize> {
    const HORIZON: usize = 100;
    let mut starts: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (r, s) in rows(&out.join("manifests/evaluation_starts.csv")) {
        starts.entry(r).or_default().push(s);
    }
    rows(&out.join("manifests/contaminating_contaminated.csv"))
        .into_iter()
        .map(|(r, t)| {
            let of = starts.get(&r).unwrap_or_else(|| panic!("{r}: a contaminating window outside the evaluation set"));
            of.iter()
                .map(|&s| {
                    if t + 1 < s {
                        s - (t + 1)
                    } else if t > s + HORIZON {
                        t - (s + HORIZON)
                    } else {
                        0
                    }
                })
                .min()
                .unwrap()
        })
        .collect()
}

#[test]
fn contaminating_windows_lie_at_the_declared_distance_from_every_evaluated_segment() {
    let dir = tempfile::tempdir().unwrap();
    // Without the clause, the draw reaches into the segments (the
    // treatment audit's "inside an evaluated segment").
    let plain = dir.path().join("plain");
    assert_ok(&split(&root().join("tests/designs/sim_small.design"), &plain));
    let near = distances(&plain);
    assert_eq!(near.len(), 750);
    assert!(near.iter().filter(|&&d| d == 0).count() > 100, "the plain draw has windows inside segments");
    assert!(near.iter().any(|&d| d > 0 && d < 200), "and windows within 2 s of one");

    // `at least 2 s`: 200 samples at 100 Hz, every window.
    let gap = design_with(dir.path(), "gap.design", "at least 2 s from segments");
    let out = dir.path().join("gap");
    let o = split(&gap, &out);
    assert_ok(&o);
    let d = distances(&out);
    assert_eq!(d.len(), 750, "the arm still replaces 25% of 3000 windows");
    assert!(d.iter().all(|&d| d >= 200), "closest: {:?}", d.iter().min());
    // The treatment audit's quartiles of that distance are these windows'
    // (R's quantile type 7 of the recomputed distances, in seconds).
    let audit: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("audit/treatment.json")).unwrap()).unwrap();
    let q = &audit["arms"][0]["segment_distance_quartiles_s"];
    let mut s: Vec<f64> = d.iter().map(|&d| d as f64 / 100.0).collect();
    s.sort_by(f64::total_cmp);
    for (k, p) in [0.25, 0.5, 0.75].into_iter().enumerate() {
        let h = (s.len() - 1) as f64 * p;
        let want = s[h.floor() as usize] + (h - h.floor()) * (s[h.ceil() as usize] - s[h.floor() as usize]);
        crate::common::assert_rel(q[k].as_f64().unwrap(), want, 1e-12, "a quartile of the distance to a segment");
    }
    assert!(q[0].as_f64().unwrap() >= 2.0);

    // A band: at least 0.5 s, less than 2 s (50 to 199 samples).
    let band = design_with(dir.path(), "band.design", "0.5 s to 2 s from segments");
    let out = dir.path().join("band");
    assert_ok(&split(&band, &out));
    let d = distances(&out);
    assert_eq!(d.len(), 750);
    assert!(d.iter().all(|&d| (50..200).contains(&d)), "range: {:?} to {:?}", d.iter().min(), d.iter().max());

    // `check` prints the clause with the arm.
    let o =
        Command::new(env!("CARGO_BIN_EXE_crossaudit")).args(["check", &gap.display().to_string()]).output().unwrap();
    assert_ok(&o);
    assert!(
        crate::common::stdout(&o).contains("registered starts excluded, at least 2 s from segments (seed 7)"),
        "{}",
        crate::common::stdout(&o)
    );
}

#[test]
fn a_distance_the_recordings_cannot_supply_is_refused_at_its_clause() {
    let dir = tempfile::tempdir().unwrap();
    // 15 s recordings: no window lies 12 s from every segment.
    let clause = "at least 12 s from segments";
    let path = design_with(dir.path(), "far.design", clause);
    let text = std::fs::read_to_string(&path).unwrap();
    let at = text.find(clause).unwrap();
    let line = text[..at].matches('\n').count() + 1;
    let column = at - text[..at].rfind('\n').map_or(0, |k| k + 1) + 1;
    let out = dir.path().join("out");
    let o = split(&path, &out);
    assert_refused(&o, &format!("far.design:{line}:{column}: arm contaminated: 750 contaminating windows {clause}"));
    assert!(crate::common::stderr(&o).contains("hold 0 such windows"), "{}", crate::common::stderr(&o));

    // A band that ends where it starts, or a negative distance, is a
    // design error at `check`.
    for (clause, needle) in [("2 s to 1 s from segments", "not beyond its start"), ("at least -1 s from segments", "")]
    {
        let path = design_with(dir.path(), "bad.design", clause);
        let o = Command::new(env!("CARGO_BIN_EXE_crossaudit"))
            .args(["check", &path.display().to_string()])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(1), "{clause}: {}", crate::common::stderr(&o));
        assert!(crate::common::stderr(&o).contains(needle), "{clause}: {}", crate::common::stderr(&o));
    }
}
