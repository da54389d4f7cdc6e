//! The designs that ship, and locking.

use crate::common::root;
use crate::snapshots;
use crossaudit::design::{self, lock, LockStatus};

#[test]
fn shipped_designs_validate_and_compile_to_the_locked_plan() {
    snapshots!({
        insta::glob!("../designs", "*.design", |path| {
            let Some(file) = crate::common::load_shipped_design(path) else { return };
            let plan = crossaudit::compile(&file.design);
            insta::assert_snapshot!(plan.render_text());
        });
    });
}

#[test]
fn the_confirmatory_design_is_the_papers_protocol() {
    let d = design::load(&root().join("designs/nanobench_confirmatory.design")).unwrap().design;
    assert_eq!(d.recording.evaluation, 26);
    assert_eq!(d.recording.split_seed, 42);
    assert_eq!(d.recording.starts, 50);
    assert_eq!(d.recording.horizon, 200);
    assert_eq!(d.seeds.first().unwrap().0, 100);
    assert_eq!(d.seeds.len(), 20);
    assert_eq!((d.validation.windows, d.validation.recordings, d.validation.seed), (2000, 8, 143));
    let plan = crossaudit::compile(&d);
    assert_eq!(plan.jobs.len(), 80);
    assert_eq!(plan.required_rows, 26 * 20 * 2 * 2 * 3);
    let t = d.training.unwrap();
    assert_eq!((t.lr, t.batch, t.epochs, t.patience, t.action_noise), (1e-3, 1024, 100, 15, 0.02));
}

#[test]
fn lock_records_hash_and_detects_changes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("study.design");
    std::fs::copy(crate::common::minimal_design_path(), &path).unwrap();
    let file = design::load(&path).unwrap();
    assert_eq!(lock::status(&file).unwrap(), LockStatus::Unlocked);
    let l = lock::write_lock(&file, std::time::UNIX_EPOCH).unwrap();
    assert_eq!(l.locked_at_utc, "1970-01-01T00:00:00Z");
    assert_eq!(l.sha256.len(), 64);
    assert!(matches!(lock::status(&file).unwrap(), LockStatus::LockedUnchanged { .. }));
    std::fs::write(&path, file.source.replace("level 0.95", "level 0.9")).unwrap();
    let changed = design::load(&path).unwrap();
    assert!(matches!(lock::status(&changed).unwrap(), LockStatus::LockedChanged { .. }));
    assert!(lock::write_lock(&changed, std::time::UNIX_EPOCH).is_err(), "a changed design is not silently re-locked");
}

#[test]
fn sha256_matches_the_published_test_vector() {
    // FIPS 180-2, Appendix B.1: SHA-256("abc").
    assert_eq!(crossaudit::io::sha256_hex(b"abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

/// `lock --amend`: a design changed after its lock is re-locked with the
/// replaced lock and the reason kept, it reads as preregistered again, and
/// every report of it states the amendment; amending what needs none is
/// refused.
#[test]
fn an_amended_lock_is_disclosed_in_every_report() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("study.design");
    std::fs::copy(crate::common::minimal_design_path(), &path).unwrap();
    let bin = || crate::common::bin();
    let p = path.to_str().unwrap();
    let o = bin().args(["lock", p, "--amend", "nothing changed"]).output().unwrap();
    crate::common::assert_refused(&o, "nothing to amend: it has no lock");
    crate::common::assert_ok(&bin().args(["lock", p]).output().unwrap());
    let first = lock::read_lock(&path).unwrap().unwrap();
    let o = bin().args(["lock", p, "--amend", "nothing changed"]).output().unwrap();
    crate::common::assert_refused(&o, "nothing to amend: its lock holds");
    let source = std::fs::read_to_string(&path).unwrap();
    std::fs::write(&path, source.replace("level 0.95", "level 0.9")).unwrap();
    let o = bin().args(["lock", p]).output().unwrap();
    crate::common::assert_refused(&o, "--amend");
    let o = bin().args(["lock", p, "--amend", "the level was a typo"]).output().unwrap();
    crate::common::assert_ok(&o);
    let amended = lock::read_lock(&path).unwrap().unwrap();
    assert_eq!(amended.amendments.len(), 1);
    assert_eq!(amended.amendments[0].previous_sha256, first.sha256);
    assert_eq!(amended.amendments[0].reason, "the level was a typo");
    let file = design::load(&path).unwrap();
    assert!(matches!(lock::status(&file).unwrap(), LockStatus::LockedUnchanged { .. }));
    let out = dir.path().join("report");
    let cells = crate::common::write_temp_cells(dir.path(), &crate::common::minimal_cells(&file.design));
    let o = bin()
        .args(["analyze", p, "--cells", cells.to_str().unwrap(), "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    crate::common::assert_ok(&o);
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("the design was amended after it was first locked"), "{report}");
    assert!(report.contains(&first.sha256) && report.contains("the level was a typo"), "{report}");
    assert!(
        crate::common::stderr(&o).contains("the level was a typo")
            || crate::common::stdout(&o).contains("the level was a typo")
    );
}
