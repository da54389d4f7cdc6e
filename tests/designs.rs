//! The designs that ship, and locking.

use crate::common::root;
use crate::snapshots;
use crossaudit::design::{self, lock, LockStatus};

#[test]
fn shipped_designs_validate_and_compile_to_the_locked_plan() {
    snapshots!({
        insta::glob!("../designs", "*.design", |path| {
            let file = design::load(path).expect("shipped designs are valid");
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
