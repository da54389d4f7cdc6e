//! Split manifests and the invariants: every checkable invariant is broken
//! on purpose and must fail with the right message.

use std::path::PathBuf;

use crate::common::{minimal_design, root};
use crate::snapshots;
use crossaudit::data::{Audit, FileRow, Recording, Status};
use crossaudit::design::{ArmKind, Design, DuplicatePolicy};
use crossaudit::split::{self, check_invariants, InvariantStatus, JobManifests, Manifests, Split, SplitError, Window};

/// `n` synthetic recordings of 300 rows; rows 0..10 inactive. Recording k
/// has content hash `h{k}`, except those listed in `dup` which copy the
/// content of recording 0.
fn recordings(n: usize, dup: &[usize]) -> Vec<Recording> {
    (0..n)
        .map(|k| {
            let rows = 300;
            let hash = if dup.contains(&k) { "h0".to_string() } else { format!("h{k}") };
            Recording {
                name: format!("R{k:02}_circle_slow_rep1"),
                path: PathBuf::from(format!("R{k:02}.csv")),
                rows,
                t: (0..rows).map(|i| i as f64 * 0.01).collect(),
                state: vec![vec![0.0; 14]; rows],
                action: vec![vec![0.5; 4]; rows],
                pwm: vec![vec![30000.0; 4]; rows],
                slots: crossaudit::model::Slots::NANOBENCH,
                active: (0..rows).map(|i| i >= 10).collect(),
                content_hash: hash,
                row_hashes: (0..rows as u64).map(|i| i * 1000 + k as u64).collect(),
                tail: None,
                rows_cut: 0,
                quaternion_deviation: None,
                cuts: Vec::new(),
            }
        })
        .collect()
}

fn audit_of(recs: &[Recording], dup: &[usize]) -> Audit {
    let files = recs
        .iter()
        .enumerate()
        .map(|(k, r)| FileRow {
            name: r.name.clone(),
            file: format!("{}.csv", r.name),
            rows: r.rows,
            active_rows: r.active_rows(),
            duration_s: r.duration_s(),
            trajectory: if k % 2 == 0 { "circle".into() } else { "star".into() },
            speed: "slow".into(),
            speed_mps: None,
            tail: None,
            rows_cut: 0,
            quaternion_deviation: None,
            onboard_row_counts: (None, None),
            controller: "pid".into(),
            repetition: Some(1),
            start_utc: None,
            battery_start_v: None,
            battery_end_v: None,
            duplicate_group: (k == 0 && !dup.is_empty() || dup.contains(&k)).then(|| "dup01".to_string()),
            content_hash: r.content_hash.clone(),
            verdicts: Vec::new(),
            status: Status::Included,
            reason: String::new(),
            broken_metadata: None,
        })
        .collect();
    Audit {
        data_dir: "synthetic".into(),
        rules: Vec::new(),
        duplicates: DuplicatePolicy::Group,
        tails: crossaudit::design::TailPolicy::Keep,
        quaternion_tolerance: None,
        files,
        duplicate_groups: Default::default(),
        not_read: Vec::new(),
    }
}

fn setup(policy: DuplicatePolicy, dup: &[usize]) -> (Design, Split) {
    let mut d = minimal_design();
    d.data.duplicates = policy;
    let recs = recordings(10, dup);
    let s = split::build(&d, &audit_of(&recs, dup), &recs).unwrap();
    (d, s)
}

fn cells(d: &Design, s: &Split) -> Vec<JobManifests> {
    JobManifests::for_plan(&crossaudit::compile(d), &Manifests::new(d, None, s))
}

fn status(d: &Design, s: &Split, c: &[JobManifests], id: u8) -> (InvariantStatus, String) {
    let r = check_invariants(d, s, c);
    let i = r.invariants.iter().find(|i| i.id == id).unwrap();
    (i.status, i.detail.clone())
}

#[test]
fn a_clean_split_passes_every_checkable_invariant() {
    let (d, s) = setup(DuplicatePolicy::Group, &[]);
    let r = check_invariants(&d, &s, &cells(&d, &s));
    assert!(r.all_pass, "{}", r.to_json());
    for i in &r.invariants {
        let expected = if [6, 8, 9].contains(&i.id) { InvariantStatus::Deferred } else { InvariantStatus::Pass };
        assert_eq!(i.status, expected, "invariant {}: {}", i.id, i.detail);
    }
    assert_eq!(s.evaluation.len(), 4);
    assert_eq!(s.starts.len(), 4 * 5);
    assert_eq!(s.validation.len(), 100);
    assert_eq!(s.fit("disjoint").unwrap().len(), 400);
    assert_eq!(s.fit("contaminated").unwrap().len(), 400);
    assert_eq!(s.contaminating[0].1.len(), 100, "25% of 400");
}

#[test]
fn manifests_are_byte_identical_for_the_same_design_and_data() {
    let (d, a) = setup(DuplicatePolicy::Group, &[]);
    let (_, b) = setup(DuplicatePolicy::Group, &[]);
    let (ma, mb) = (Manifests::new(&d, None, &a), Manifests::new(&d, None, &b));
    assert_eq!(ma.to_json(), mb.to_json());
    for (name, m) in &ma.files {
        assert_eq!(m.text, mb.files[name].text, "{name}");
    }
}

#[test]
fn starts_leave_a_full_horizon_and_are_sorted_and_unique() {
    let (d, s) = setup(DuplicatePolicy::Group, &[]);
    let mut sorted = s.starts.clone();
    sorted.sort();
    sorted.dedup();
    assert_eq!(sorted, s.starts);
    for w in &s.starts {
        assert!(
            w.t >= 10 && w.t + d.recording.horizon < 300,
            "start {w:?} lacks {} active samples after it",
            d.recording.horizon
        );
    }
}

#[test]
fn breaking_invariant_1_shared_starts_fails() {
    let (d, s) = setup(DuplicatePolicy::Group, &[]);
    let mut c = cells(&d, &s);
    c[3].starts_sha256 = "something else".into();
    let (st, detail) = status(&d, &s, &c, 1);
    assert_eq!(st, InvariantStatus::Fail);
    assert!(detail.contains("2 start manifest(s)"), "{detail}");
}

#[test]
fn breaking_invariant_2_duplicate_start_fails() {
    let (d, mut s) = setup(DuplicatePolicy::Group, &[]);
    let first = s.starts[0];
    s.starts.push(first);
    let (st, detail) = status(&d, &s, &cells(&d, &s), 2);
    assert_eq!(st, InvariantStatus::Fail);
    assert!(detail.contains("1 duplicated"), "{detail}");
}

#[test]
fn breaking_invariant_3_validation_from_evaluation_fails() {
    let (d, mut s) = setup(DuplicatePolicy::Group, &[]);
    let e = s.evaluation[0];
    s.validation[0] = Window { recording: e, t: 50 };
    let (st, detail) = status(&d, &s, &cells(&d, &s), 3);
    assert_eq!(st, InvariantStatus::Fail);
    assert!(detail.starts_with("1 validation windows from evaluation recordings"), "{detail}");
    // ... and validation differing between cells fails too.
    let (d, s) = setup(DuplicatePolicy::Group, &[]);
    let mut c = cells(&d, &s);
    c[0].validation_sha256 = "other".into();
    let (st, detail) = status(&d, &s, &c, 3);
    assert_eq!(st, InvariantStatus::Fail);
    assert!(detail.contains("2 validation manifest(s)"), "{detail}");
}

#[test]
fn breaking_invariant_4_fit_sizes_fails() {
    let (d, mut s) = setup(DuplicatePolicy::Group, &[]);
    s.fits[0].1.pop();
    let (st, detail) = status(&d, &s, &cells(&d, &s), 4);
    assert_eq!(st, InvariantStatus::Fail);
    assert!(detail.contains("disjoint: 399 windows (declared 400)"), "{detail}");
    // One evaluation window too many in the contaminated arm.
    let (d, mut s) = setup(DuplicatePolicy::Group, &[]);
    let e = s.evaluation[1];
    let k = s.fits[1].1.iter().position(|w| !s.evaluation_side.contains(&w.recording)).unwrap();
    s.fits[1].1[k] = Window { recording: e, t: 12 };
    let (st, detail) = status(&d, &s, &cells(&d, &s), 4);
    assert_eq!(st, InvariantStatus::Fail);
    assert!(detail.contains("101 from evaluation (declared 100)"), "{detail}");
    // A registered start used as a contaminating window.
    let (d, mut s) = setup(DuplicatePolicy::Group, &[]);
    let start = s.starts[0];
    let k = s.fits[1].1.iter().position(|w| s.evaluation_side.contains(&w.recording)).unwrap();
    s.fits[1].1[k] = start;
    let r = check_invariants(&d, &s, &cells(&d, &s));
    assert!(!r.all_pass);
    assert_eq!(r.invariants[3].numbers["contaminated"]["registered_starts_used"], true);
}

#[test]
fn breaking_invariant_5_evaluation_in_disjoint_fit_fails() {
    let (d, mut s) = setup(DuplicatePolicy::Group, &[]);
    let e = s.evaluation[0];
    s.fits[0].1[0] = Window { recording: e, t: 40 };
    let (st, detail) = status(&d, &s, &cells(&d, &s), 5);
    assert_eq!(st, InvariantStatus::Fail);
    assert!(detail.starts_with("1 disjoint-fit windows from evaluation recordings"), "{detail}");
}

#[test]
fn duplicates_of_evaluation_content_fail_unless_the_design_keeps_them() {
    // Make a disjoint-fit recording a byte-identical copy of an evaluation
    // recording: a failure under `duplicates group`, a warning under
    // `duplicates keep` (the design chose to treat copies as independent).
    for (policy, expected) in
        [(DuplicatePolicy::Group, InvariantStatus::Fail), (DuplicatePolicy::Keep, InvariantStatus::Warn)]
    {
        let (mut d, mut s) = setup(DuplicatePolicy::Group, &[]);
        d.data.duplicates = policy;
        let e = s.evaluation[0];
        let f = s.fits[0].1[0].recording;
        s.recordings[f].content_hash = s.recordings[e].content_hash.clone();
        let (st, detail) = status(&d, &s, &cells(&d, &s), 5);
        assert_eq!(st, expected, "{policy:?}: {detail}");
        if policy == DuplicatePolicy::Keep {
            assert!(
                detail
                    .contains("allowed only because duplicates are kept (`duplicates keep`, declared or the default)"),
                "{detail}"
            );
        }
    }
    // Under `group`, a duplicate group is one unit and goes wholly to one side.
    let (d, s) = setup(DuplicatePolicy::Group, &[1, 2]);
    assert!(s.units.iter().any(|u| u.members == vec![0, 1, 2]), "{:?}", s.units);
    assert_eq!(status(&d, &s, &cells(&d, &s), 5).0, InvariantStatus::Pass);
    assert_eq!(status(&d, &s, &cells(&d, &s), 3).0, InvariantStatus::Pass);
}

#[test]
fn breaking_invariant_7_missing_seed_fails() {
    let (d, s) = setup(DuplicatePolicy::Group, &[]);
    let mut c = cells(&d, &s);
    let gone = c.remove(4);
    let (st, detail) = status(&d, &s, &c, 7);
    assert_eq!(st, InvariantStatus::Fail);
    assert!(detail.contains(&format!("{}/{}/{}", gone.model, gone.arm, gone.seed.0)), "{detail}");
}

#[test]
fn data_that_cannot_support_the_design_is_a_clear_error() {
    let d = minimal_design();
    let recs = recordings(6, &[]);
    let e = split::build(&d, &audit_of(&recs, &[]), &recs).unwrap_err();
    assert!(matches!(e, SplitError::TooFewRecordings { available: 6, needed: 7, .. }), "{e}");
    assert!(e.to_string().contains("only 6 usable deployment units remain"));

    let mut d = minimal_design();
    d.recording.horizon = 295;
    let recs = recordings(10, &[]);
    let e = split::build(&d, &audit_of(&recs, &[]), &recs).unwrap_err();
    assert!(matches!(e, SplitError::TooFewStarts { valid: 0, needed: 5, .. }), "{e}");

    let mut d = minimal_design();
    d.validation.windows = 10_000;
    let e = split::build(&d, &audit_of(&recs, &[]), &recs).unwrap_err();
    assert!(e.to_string().starts_with("validation (2 recordings with data): the design needs 10000 windows"), "{e}");

    let mut d = minimal_design();
    d.arms[0].kind = ArmKind::Fit { windows: 100_000, seed: 0, hold_out: Vec::new() };
    let e = split::build(&d, &audit_of(&recs, &[]), &recs).unwrap_err();
    assert!(matches!(e, SplitError::TooFewWindows { needed: 100_000, .. }), "{e}");

    let mut d = minimal_design();
    if let ArmKind::Derived { percent, .. } = &mut d.arms[1].kind {
        *percent = 0.1;
    }
    let e = split::build(&d, &audit_of(&recs, &[]), &recs).unwrap_err();
    assert!(matches!(e, SplitError::NothingToReplace { replaced: 0, .. }), "{e}");
}

#[test]
fn treatment_audit_counts_windows_inside_evaluated_segments() {
    let (_, mut s) = setup(DuplicatePolicy::Group, &[]);
    let r = s.evaluation[0];
    s.starts = vec![Window { recording: r, t: 20 }, Window { recording: r, t: 150 }];
    s.horizon = 100;
    // Inside [20, 120] or [150, 250]: 20, 120, 200; outside: 130, 290.
    let ts = [20, 120, 130, 200, 290];
    s.contaminating = vec![("contaminated".into(), ts.iter().map(|&t| Window { recording: r, t }).collect())];
    let a = split::treatment_audit(&s, true);
    let arm = &a.arms[0];
    assert_eq!((arm.contaminating_windows, arm.inside_evaluated_segment), (5, 3));
    // Distances to the nearest start: 0, 30, 20, 50, 140 -> median 30.
    assert_eq!(arm.median_distance_samples, 30.0);
    assert_eq!(arm.median_distance_s, 0.3);
    assert_eq!(a.composition.total, 4);
}

#[test]
#[ignore = "needs ../shared/nanobench"]
fn the_papers_split_on_the_shared_logs_is_locked() {
    let _logs = crate::needs_shared_logs!();
    let dir = crate::common::shared_logs();
    let file = crossaudit::design::load(&root().join("designs/nanobench_confirmatory.design")).unwrap();
    let out = tempfile::tempdir().unwrap();
    let plan = crossaudit::compile(&file.design);
    let o = crossaudit::split::prepare(&file, &plan, &dir, out.path()).unwrap();
    assert_eq!(o.split.evaluation.len(), 26);
    assert_eq!(o.split.fit("disjoint").unwrap().len(), 16_000);
    assert_eq!(o.split.contaminating[0].1.len(), 4_000);
    // Hashes and counts, so that any change to sampling shows in review.
    let mut json: serde_json::Value = serde_json::from_str(&o.manifests.to_json()).unwrap();
    json["design_sha256"] = serde_json::Value::String("[design hash]".into());
    snapshots!({ insta::assert_json_snapshot!(json) });
    let again = tempfile::tempdir().unwrap();
    let o2 = crossaudit::split::prepare(&file, &plan, &dir, again.path()).unwrap();
    for name in o.manifests.files.keys() {
        let a = std::fs::read(out.path().join("manifests").join(name)).unwrap();
        let b = std::fs::read(again.path().join("manifests").join(name)).unwrap();
        assert_eq!(a, b, "{name} differs between runs");
    }
    assert_eq!(o2.manifests.to_json(), o.manifests.to_json());
}
