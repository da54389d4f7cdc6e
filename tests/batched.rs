//! The batched trainer: jobs trained in lockstep give each job exactly what
//! it gets trained alone on the CPU, and on a GPU (where one is found) the
//! same within a stated tolerance, bit-identical run to run.

use crate::common::{crossaudit, root, said, skip};
use crate::model::windows;
use crossaudit::design::{ActionScaling, InputMap, Optimizer, Schedule, TargetKind, Training};
use crossaudit::model::{
    device, train, train_batch, train_lockstep, BatchJob, Device, EpochLog, FeatureMap, Net, Slots, State,
};

type Triple = (State, Vec<f64>, State);

/// Three jobs of one shape that differ in seed, data, epochs and patience:
/// the second leaves the batch after 2 epochs, the third may stop early.
fn three() -> (Vec<Vec<Triple>>, Vec<Triple>, Vec<FeatureMap>, Vec<Training>) {
    let fits: Vec<Vec<Triple>> = [0.0, 0.7, 1.9].iter().map(|&o| windows(o, 600)).collect();
    let val = windows(3.1, 120);
    let features = fits
        .iter()
        .map(|w| {
            let map = (Slots::NANOBENCH, InputMap::World, ActionScaling::Raw, TargetKind::StateScaled);
            FeatureMap::fit(map.0, map.1, map.2, map.3, w, "manifest")
        })
        .collect();
    // tests/designs/tiny_train.design's protocol, written out so that the
    // test binary runs from any folder (scripts/gpu-check.sh).
    let t = Training {
        optimizer: Optimizer::Adam,
        lr: 1e-3,
        batch: 256,
        epochs: 6,
        schedule: Schedule::Cosine,
        patience: 6,
        action_noise: 0.02,
        target: TargetKind::StateScaled,
        restore_final: false,
    };
    let mut short = t.clone();
    short.epochs = 2;
    let mut impatient = t.clone();
    impatient.patience = 1;
    (fits, val, features, vec![t, short, impatient])
}

fn jobs<'a>(
    fits: &'a [Vec<Triple>],
    val: &'a [Triple],
    features: &'a [FeatureMap],
    ts: &'a [Training],
) -> Vec<BatchJob<'a>> {
    (0..3)
        .map(|k| BatchJob {
            widths: &[32, 32, 32],
            features: &features[k],
            fit: &fits[k],
            validation: val,
            training: &ts[k],
            seed: 11 + k as u64,
        })
        .collect()
}

fn alone(j: &BatchJob) -> (Net, Vec<EpochLog>) {
    train(j.widths, j.features, j.fit, j.validation, j.training, j.seed, &mut |_| {}).unwrap()
}

fn same(a: &[(Net, Vec<EpochLog>)], b: &[(Net, Vec<EpochLog>)]) {
    assert_eq!(a.len(), b.len());
    for (k, ((na, la), (nb, lb))) in a.iter().zip(b).enumerate() {
        assert_eq!(na.flat_weights(), nb.flat_weights(), "job {k}: weights differ");
        let curve = |l: &[EpochLog]| l.iter().map(|e| (e.epoch, e.lr, e.train_loss, e.val_loss)).collect::<Vec<_>>();
        assert_eq!(curve(la), curve(lb), "job {k}: curves differ");
    }
}

#[test]
fn jobs_in_lockstep_train_bit_for_bit_as_each_alone() {
    let (fits, val, features, ts) = three();
    let jobs = jobs(&fits, &val, &features, &ts);
    let alone: Vec<_> = jobs.iter().map(alone).collect();
    assert_eq!(alone[1].1.len(), 2, "the short job trains 2 epochs");
    assert!(alone[0].1.len() > 2, "the first job goes on after the short one leaves");
    let mut seen = vec![0usize; 3];
    let together = train_lockstep(&jobs, &mut |k, _| seen[k] += 1).unwrap();
    same(&together, &alone);
    assert_eq!(seen, alone.iter().map(|(_, l)| l.len()).collect::<Vec<_>>(), "every epoch of every job is reported");
    // The batched trainer's CPU backend: the same again.
    let batched = train_batch(&Device::Cpu, &jobs, &|_, _| {}).unwrap();
    same(&batched, &alone);
}

/// GPU against CPU: the products are summed in another order, so each
/// validation loss may differ by this relative amount, and each weight by
/// this absolute amount, after the few epochs of these jobs.
const GPU_LOSS_RTOL: f64 = 1e-4;
const GPU_WEIGHT_ATOL: f32 = 1e-3;

#[test]
fn on_a_gpu_the_batch_is_reproducible_and_within_tolerance_of_the_cpu() {
    let gpu = match device::probe() {
        Ok(g) => g,
        Err(e) => return skip("gpu", &format!("batched GPU trainer parity: {e}")),
    };
    let (fits, val, features, mut ts) = three();
    // The full budget for each job, so that both devices train the same
    // epochs whatever the last digits of their validation losses.
    for t in &mut ts {
        t.restore_final = true;
    }
    let jobs = jobs(&fits, &val, &features, &ts);
    let cpu = train_lockstep(&jobs, &mut |_, _| {}).unwrap();
    let device = Device::Cuda(gpu);
    let first = train_batch(&device, &jobs, &|_, _| {}).unwrap();
    let again = train_batch(&device, &jobs, &|_, _| {}).unwrap();
    same(&first, &again);
    for (k, ((ng, lg), (nc, lc))) in first.iter().zip(&cpu).enumerate() {
        assert_eq!(lg.len(), lc.len(), "job {k}: epochs");
        for (g, c) in lg.iter().zip(lc) {
            let rel = (g.val_loss - c.val_loss).abs() / c.val_loss.abs().max(1e-12);
            assert!(rel < GPU_LOSS_RTOL, "job {k} epoch {}: GPU {} CPU {} ({rel:e})", c.epoch, g.val_loss, c.val_loss);
        }
        let worst = ng.flat_weights().iter().zip(nc.flat_weights()).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
        assert!(worst < GPU_WEIGHT_ATOL, "job {k}: a weight differs by {worst:e}");
    }
}

#[test]
fn without_a_gpu_cuda_is_refused_and_auto_trains_on_the_cpu_as_before() {
    if device::probe().is_ok() {
        // A GPU machine: scripts/gpu-check.sh runs the GPU side of this.
        return skip("no gpu", "the refusal of --device cuda needs a machine without a GPU");
    }
    let out = tempfile::tempdir().unwrap();
    let dir = |name: &str| out.path().join(name).display().to_string();
    let o = crossaudit(&["run", "designs/quickstart.design", "--out", &dir("cuda"), "--device", "cuda"]);
    assert_eq!(o.status.code(), Some(1), "{}", said(&o));
    let text = said(&o);
    assert!(text.contains("--device cuda: no usable NVIDIA GPU") && text.contains("libcuda.so.1"), "{text}");
    assert!(!text.contains("panicked"), "{text}");
    assert!(!out.path().join("cuda").exists(), "nothing is written before the device is found");
    // auto: the CPU, said so, and the committed quickstart's cells byte for byte.
    let o = crossaudit(&["run", "designs/quickstart.design", "--out", &dir("auto"), "--device", "auto"]);
    assert!(o.status.success(), "{}", said(&o));
    assert!(said(&o).contains("--device auto: training on the CPU (no usable NVIDIA GPU"), "{}", said(&o));
    let cells = std::fs::read(out.path().join("auto/cells.csv")).unwrap();
    assert!(
        cells == std::fs::read(root().join("results/quickstart/cells.csv")).unwrap(),
        "cells differ from the committed run"
    );
    // The CPU is recorded by omission, in run.json and in every job record.
    let run = std::fs::read_to_string(out.path().join("auto/run.json")).unwrap();
    assert!(!run.contains("\"device\""), "{run}");
    let job = std::fs::read_to_string(out.path().join("auto/jobs/world__disjoint__1.json")).unwrap();
    assert!(!job.contains("\"device\""), "{job}");
    // An unknown device is a usage error.
    let o = crossaudit(&["run", "designs/quickstart.design", "--out", &dir("gpu"), "--device", "gpu"]);
    assert_eq!(o.status.code(), Some(2), "{}", said(&o));
    assert!(said(&o).contains("[possible values: cpu, cuda, auto]"), "{}", said(&o));
}

#[test]
fn the_gpu_kernels_compile_with_nvrtc() {
    match crossaudit::model::batch::compile_gpu_kernels() {
        Ok(ptx) => {
            for kernel in ["bias_act", "mse_grad", "relu_back", "bias_grad", "sq_err", "adam"] {
                assert!(ptx.contains(&format!(".entry {kernel}(")), "{kernel} is not in the PTX");
            }
            // fmad=false: no fused multiply-add in the elementwise arithmetic.
            assert!(!ptx.contains("fma.rn.f32"), "a multiply-add was contracted");
        }
        // CI installs NVRTC (scripts/nvrtc.sh) and sets CROSSAUDIT_REQUIRE_NVRTC.
        Err(e) if e.0.contains("not installed") && std::env::var_os("CROSSAUDIT_REQUIRE_NVRTC").is_none() => {
            skip("nvrtc", &format!("the CUDA kernels' compile (bash scripts/nvrtc.sh installs NVRTC): {e}"))
        }
        Err(e) => panic!("{e}"),
    }
}

#[test]
#[ignore = "needs ../shared/nanobench"]
fn a_network_trained_by_the_batch_is_saved_and_scored_as_one_trained_by_its_job() {
    use crossaudit::run::job::{mlp_setup, run_job, run_job_given, Trained};
    let _ = crate::needs_shared_logs!();
    let (alone_dir, given_dir) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let (file, plan, split) = crate::common::tiny_split(alone_dir.path());
    let (_, _, split_b) = crate::common::tiny_split(given_dir.path());
    let jobs: Vec<_> = plan.jobs.iter().filter(|j| j.seed.0 == 1 && j.model == "world").collect();
    assert_eq!(jobs.len(), 2, "both arms");
    let setups: Vec<_> = jobs.iter().map(|j| mlp_setup(&plan, j, &split_b).unwrap().unwrap()).collect();
    let batch: Vec<BatchJob> = setups
        .iter()
        .zip(&jobs)
        .map(|(s, j)| BatchJob {
            widths: &s.widths,
            features: &s.features,
            fit: &s.fit,
            validation: &s.validation,
            training: &s.training,
            seed: j.seed.0,
        })
        .collect();
    let trained = train_lockstep(&batch, &mut |_, _| {}).unwrap();
    for (job, (net, epochs)) in jobs.iter().zip(trained) {
        let a = run_job(&file.sha256, &plan, job, &split, alone_dir.path(), &mut |_| {}).unwrap();
        let given = Trained { net, epochs, seconds: 0.0, device: "cuda: a test's stand-in".into() };
        let b = run_job_given(
            crossaudit::model::Engine::Fused,
            &file.sha256,
            &plan,
            job,
            &split_b,
            given_dir.path(),
            Some(given),
            &mut |_| {},
        )
        .unwrap();
        assert_eq!(a.files, b.files);
        // Every file byte for byte, but the curves' wall seconds.
        let text = |d: &tempfile::TempDir, f: &str| {
            let t = std::fs::read(d.path().join(f)).unwrap();
            if !f.starts_with("curves/") {
                return t;
            }
            let drop_seconds = |l: &str| l.rsplit_once(',').map_or(l.to_string(), |(a, _)| a.to_string());
            String::from_utf8(t).unwrap().lines().map(drop_seconds).collect::<Vec<_>>().join("\n").into_bytes()
        };
        for f in &a.files {
            assert!(text(&alone_dir, f) == text(&given_dir, f), "{f} differs");
        }
        let stem = format!("jobs/{}.json", job.stem());
        let record = std::fs::read_to_string(given_dir.path().join(&stem)).unwrap();
        assert!(record.contains("\"device\": \"cuda: a test's stand-in\""), "{record}");
        assert!(!std::fs::read_to_string(alone_dir.path().join(&stem)).unwrap().contains("\"device\""));
    }
}
