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

/// Two architectures that are not three equal layers, `mlp(64, 64)` and
/// `mlp(256, 128, 64)`: the fused trainer gives dfdx's weights, curves and
/// per-cell rows bit for bit.
#[test]
#[ignore = "needs ../shared/nanobench"]
fn the_fused_trainer_is_bit_identical_to_dfdx_for_other_shapes() {
    let _logs = crate::needs_shared_logs!();
    let out = tempfile::tempdir().unwrap();
    let epochs = both_engines_agree("tests/designs/shapes_train.design", out.path());
    assert_eq!(epochs, vec![2; 8], "2 models x 2 arms x 2 seeds, 2 epochs each");
}

/// The fused trainer starts any layout from dfdx's initialisation
/// ([`Net::init`]): on NanoBench's layout it must draw dfdx's own initial
/// weights bit for bit, for every architecture dfdx has a type for here
/// (two and three layers, equal and unequal widths).
#[test]
fn the_initialisation_is_dfdxs_bit_for_bit() {
    use crossaudit::model::{Net, Slots, REFERENCE_WIDTHS};
    for widths in REFERENCE_WIDTHS {
        for seed in [0u64, 1, 7, 123_456_789] {
            let ours = Net::init(&Slots::NANOBENCH, widths, seed);
            let dfdx = Net::init_dfdx(widths, seed).unwrap();
            assert_eq!(ours.widths(), widths);
            assert!(ours.flat_weights() == dfdx.flat_weights(), "widths {widths:?}, seed {seed}");
        }
    }
    assert!(Net::init_dfdx(&[48, 16], 0).is_none(), "no dfdx type for these widths here");
    // Another layout: the shapes follow the slots, and the first layer's
    // bound is 1 / sqrt(inputs).
    let slots = Slots::full(20, 6, 16, true);
    let net = Net::init(&slots, &[32, 32, 32], 3).fused();
    assert_eq!((net.inputs(), net.outputs()), (26, 20));
    let b = 1.0 / 26f32.sqrt();
    assert!(
        net.layers[0].weight.iter().all(|w| w.abs() <= b) && net.layers[0].weight.iter().any(|w| w.abs() > 0.9 * b)
    );
}

/// Weights are written in dfdx's safetensors layout: dfdx reads what
/// crossaudit writes, and crossaudit reads what dfdx writes, bit for bit;
/// another layout's file is read back with its own shapes.
#[test]
fn weights_files_are_dfdxs_safetensors() {
    use crossaudit::model::{Net, Slots};
    use dfdx::nn::{LoadFromSafetensors, SaveToSafetensors};
    use dfdx::prelude::*;
    type Mlp = ((Linear<18, 32>, ReLU), (Linear<32, 32>, ReLU), (Linear<32, 32>, ReLU), Linear<32, 14>);
    let dir = tempfile::tempdir().unwrap();
    let ours = Net::init(&Slots::NANOBENCH, &[32, 32, 32], 5);
    let path = dir.path().join("ours.safetensors");
    ours.save(&path).unwrap();
    let dev = Cpu::default();
    let mut m = dev.build_module::<Mlp, f32>();
    m.load_safetensors(&path).unwrap();
    let ((a, _), (b, _), (c, _), d) = &m;
    let theirs: Vec<f32> = [(&a.weight.as_vec(), &a.bias.as_vec()), (&b.weight.as_vec(), &b.bias.as_vec())]
        .into_iter()
        .chain([(&c.weight.as_vec(), &c.bias.as_vec()), (&d.weight.as_vec(), &d.bias.as_vec())])
        .flat_map(|(w, b)| w.iter().chain(b.iter()).copied().collect::<Vec<_>>())
        .collect();
    assert!(theirs == ours.flat_weights(), "dfdx reads crossaudit's file");
    let dfdx_path = dir.path().join("dfdx.safetensors");
    let m = Cpu::seed_from_u64(9).build_module::<Mlp, f32>();
    m.save_safetensors(&dfdx_path).unwrap();
    let back = Net::load(&[32, 32, 32], &dfdx_path).unwrap();
    assert!(
        back.flat_weights() == Net::init_dfdx(&[32, 32, 32], 9).unwrap().flat_weights(),
        "crossaudit reads dfdx's file"
    );
    let slots = Slots::full(17, 8, 13, false);
    let other = Net::init(&slots, &[64, 64, 64], 2);
    let p = dir.path().join("other.safetensors");
    other.save(&p).unwrap();
    assert_eq!(Net::load(&[64, 64, 64], &p).unwrap(), other);
    assert!(Net::load(&[32, 32, 32], &p).is_err(), "a file of another width is refused");
}

/// Any depth and widths, in dfdx's file layout: dfdx reads a two-layer
/// network crossaudit writes; a file is read back only as its own
/// architecture (not as a deeper, shallower or narrower one).
#[test]
fn weights_files_of_any_shape_round_trip() {
    use crossaudit::model::{Net, Slots};
    use dfdx::nn::LoadFromSafetensors;
    use dfdx::prelude::*;
    type Two = ((Linear<18, 64>, ReLU), (Linear<64, 64>, ReLU), Linear<64, 14>);
    let dir = tempfile::tempdir().unwrap();
    let ours = Net::init(&Slots::NANOBENCH, &[64, 64], 4);
    let path = dir.path().join("two.safetensors");
    ours.save(&path).unwrap();
    let mut m = Cpu::default().build_module::<Two, f32>();
    m.load_safetensors(&path).unwrap();
    let ((a, _), (b, _), c) = &m;
    let theirs: Vec<f32> = [a.weight.as_vec(), a.bias.as_vec(), b.weight.as_vec(), b.bias.as_vec()]
        .into_iter()
        .chain([c.weight.as_vec(), c.bias.as_vec()])
        .flatten()
        .collect();
    assert!(theirs == ours.flat_weights(), "dfdx reads a two-layer file");
    assert_eq!(Net::load(&[64, 64], &path).unwrap(), ours);
    assert!(Net::load(&[64], &path).is_err(), "read as one layer");
    assert!(Net::load(&[64, 64, 64], &path).is_err(), "read as three layers");
    assert!(Net::load(&[64, 32], &path).is_err(), "read as narrower");
    let slots = Slots::full(17, 8, 13, false);
    for widths in [&[7][..], &[256, 128, 64], &[5, 9, 3, 11, 2]] {
        let net = Net::init(&slots, widths, 11);
        let p = dir.path().join(format!("{}.safetensors", widths.len()));
        net.save(&p).unwrap();
        let back = Net::load(widths, &p).unwrap();
        assert_eq!(back, net, "{widths:?}");
        assert_eq!(back.widths(), widths);
    }
}
