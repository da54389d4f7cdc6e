//! The fused trainer against the dfdx reference: full early-stopped jobs on
//! the shared NanoBench logs must give bit-identical weights, training
//! curves and per-cell rows.

use std::path::Path;

use crate::common::{root, shared_logs};
use crossaudit::model::Engine;

/// Runs every job of `design` with both engines; compares the files each
/// job writes (weights, per-cell rows) and the epoch curves (all but the
/// wall-clock seconds). Returns the number of epochs trained per job.
fn both_engines_agree(design: &str, out: &Path) -> Vec<usize> {
    let dir = shared_logs();
    let file = crossaudit::design::load(&root().join(design)).unwrap();
    let plan = crossaudit::compile(&file.design);
    let split = crossaudit::split::prepare(&file, &plan, &dir, out).unwrap();
    let mut epochs = Vec::new();
    for job in plan.jobs.iter().filter(|j| j.trains()) {
        let mut runs = Vec::new();
        for engine in [Engine::Fused, Engine::Reference] {
            let o = out.join(format!("{engine:?}"));
            let done =
                crossaudit::run::run_job_with(engine, &file.sha256, &plan, job, &split, &o, &mut |_| {}).unwrap();
            let stem = job.stem();
            let weights = std::fs::read(o.join(format!("models/{stem}.safetensors"))).unwrap();
            let cells = std::fs::read(o.join(format!("cells/{stem}.csv"))).unwrap();
            let curve: Vec<(usize, u64, u64, u64)> = done
                .epochs
                .iter()
                .map(|e| (e.epoch, e.lr.to_bits(), e.train_loss.to_bits(), e.val_loss.to_bits()))
                .collect();
            runs.push((weights, cells, curve));
        }
        let stem = job.stem();
        assert!(runs[0].0 == runs[1].0, "{stem}: best weights differ between the fused and the dfdx trainer");
        assert_eq!(runs[0].2, runs[1].2, "{stem}: training curves differ");
        assert!(runs[0].1 == runs[1].1, "{stem}: per-cell rows differ");
        epochs.push(runs[0].2.len());
    }
    epochs
}

/// The paper's width (256): world and relative inputs, both arms, two
/// seeds, each trained until validation stops improving.
#[test]
#[ignore = "needs ../shared/nanobench"]
fn the_fused_trainer_is_bit_identical_to_dfdx_at_the_papers_width() {
    let _logs = crate::needs_shared_logs!();
    let out = tempfile::tempdir().unwrap();
    let epochs = both_engines_agree("tests/designs/fused_check.design", out.path());
    assert_eq!(epochs.len(), 8, "2 models x 2 arms x 2 seeds");
    assert!(epochs.iter().any(|&e| e < 30), "at least one job must stop early: {epochs:?}");
}

/// A small width (32), three epochs.
#[test]
#[ignore = "needs ../shared/nanobench"]
fn the_fused_trainer_is_bit_identical_to_dfdx_at_a_small_width() {
    let _logs = crate::needs_shared_logs!();
    let out = tempfile::tempdir().unwrap();
    let epochs = both_engines_agree("tests/designs/tiny_train.design", out.path());
    assert_eq!(epochs.len(), 8);
}
