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

/// Three jobs that differ in seed, data, epochs and patience: the second
/// trains 2 epochs of its budget, the third stops early (patience 1, at a
/// learning rate high enough to make its validation loss rise), the first
/// trains all 8.
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
    // A protocol written out (not read from a design file) so that the
    // test binary runs from any folder (scripts/gpu-check.sh); a learning
    // rate of 0.1 makes the validation loss rise, so patience 1 stops early.
    let t = Training {
        optimizer: Optimizer::Adam,
        lr: 1e-1,
        batch: 256,
        epochs: 8,
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

/// The GPU backend's own code, run by plain loops on the CPU
/// (`train_emulated`: cuBLAS's products as documented, the kernels element
/// by element), trains each job as the CPU trainer does, within the
/// rounding of products summed in another order. The first and third jobs
/// share a shape and a batch, and the third leaves it after 2 epochs; with
/// memory for one job at a time each trains alone, to the same bits.
#[test]
fn the_gpu_backend_emulated_on_the_cpu_trains_as_the_cpu_does() {
    let (fits, val, features, ts) = three();
    let jobs = jobs(&fits, &val, &features, &ts);
    let cpu = train_lockstep(&jobs, &mut |_, _| {}).unwrap();
    let epochs: Vec<usize> = cpu.iter().map(|(_, l)| l.len()).collect();
    assert_eq!(epochs, [8, 2, 2], "the third job stops early (patience 1), the first goes on");
    let seen = std::sync::Mutex::new(vec![0usize; 3]);
    let emulated =
        crossaudit::model::batch::train_emulated(&jobs, 1 << 40, &|k, _| seen.lock().unwrap()[k] += 1).unwrap();
    assert_eq!(*seen.lock().unwrap(), epochs, "every epoch of every job is reported");
    for (k, ((ne, le), (nc, lc))) in emulated.iter().zip(&cpu).enumerate() {
        assert_eq!(le.len(), lc.len(), "job {k}: epochs");
        for (e, c) in le.iter().zip(lc) {
            for (what, a, b) in [("validation", e.val_loss, c.val_loss), ("training", e.train_loss, c.train_loss)] {
                let rel = (a - b).abs() / b;
                assert!(rel < 1e-4, "job {k} epoch {}: {what} loss {a} emulated, {b} on the CPU ({rel:e})", c.epoch);
            }
        }
        let worst = ne.flat_weights().iter().zip(nc.flat_weights()).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
        assert!(worst < 1e-4, "job {k}: a weight differs by {worst:e}");
        assert_ne!(ne.flat_weights(), nc.flat_weights(), "job {k}: the products are summed in another order");
    }
    // Memory for one job: every batch holds one, and nothing changes.
    let alone = crossaudit::model::batch::train_emulated(&jobs, 1, &|_, _| {}).unwrap();
    same(&alone, &emulated);
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
    // With early stopping the third job leaves its batch after 2 epochs
    // (its best weights copied to the host, the first job stepping on
    // alone): the same epochs as on the CPU, and the same bits on a rerun.
    let (fits, val, features, ts) = three();
    let jobs = self::jobs(&fits, &val, &features, &ts);
    let first = train_batch(&device, &jobs, &|_, _| {}).unwrap();
    let epochs: Vec<usize> = first.iter().map(|(_, l)| l.len()).collect();
    assert_eq!(epochs, [8, 2, 2], "the third job stops early on the GPU too");
    same(&first, &train_batch(&device, &jobs, &|_, _| {}).unwrap());
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

/// The CUDA kernels' source compiled for the CPU by gcc (one thread per
/// launch, `__syncthreads` a no-op, no contraction of multiply-adds) and
/// run on small inputs: each element must be what the fused CPU trainer
/// computes for it (src/model/fused.rs), bit for bit. This checks the
/// kernels' indexing and arithmetic where no GPU is at hand; it cannot
/// check the launches, which scripts/gpu-check.sh does on a GPU.
#[test]
fn the_gpu_kernels_compute_on_a_cpu_what_the_cpu_trainer_computes() {
    let gcc = std::process::Command::new("gcc").arg("--version").output();
    if !gcc.is_ok_and(|o| o.status.success()) {
        return skip("gcc", "the CUDA kernels on the CPU: gcc is not installed");
    }
    let kernels = std::fs::read_to_string(root().join("src/model/cuda_kernels.cu")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let source =
        format!("{KERNEL_SHIM}\n{}\n{KERNEL_HARNESS}", kernels.replace("extern \"C\" __global__ void", "void"));
    std::fs::write(dir.path().join("k.c"), source).unwrap();
    let exe = dir.path().join("k");
    let cc = std::process::Command::new("gcc")
        .args(["-O2", "-ffp-contract=off", "-fno-fast-math", "-o"])
        .arg(&exe)
        .arg(dir.path().join("k.c"))
        .arg("-lm")
        .output()
        .unwrap();
    assert!(cc.status.success(), "gcc: {}", String::from_utf8_lossy(&cc.stderr));
    let run = std::process::Command::new(&exe).output().unwrap();
    assert!(run.status.success());
    // name: hex bit patterns, one line per array.
    let text = String::from_utf8(run.stdout).unwrap();
    let arrays: std::collections::HashMap<&str, Vec<u64>> = text
        .lines()
        .map(|l| {
            let (name, v) = l.split_once(':').unwrap();
            (name, v.split_whitespace().map(|h| u64::from_str_radix(h, 16).unwrap()).collect())
        })
        .collect();
    let f = |name: &str| arrays[name].iter().map(|&b| f32::from_bits(b as u32)).collect::<Vec<f32>>();
    let (k, n, w) = (3usize, 5usize, 4usize);
    let (z0, bias, z) = (f("z0"), f("bias"), f("z"));
    for e in 0..k * n * w {
        // fused.rs, forward: zb = v + b; max(zb, 0) on hidden layers.
        let want = (z0[e] + bias[(e / (n * w)) * w + e % w]).max(0.0);
        assert_eq!(z[e].to_bits(), want.to_bits(), "bias_act at {e}");
    }
    let (y, g) = (f("y"), f("g"));
    let inv_n = (1.0 / (n * w) as f64) as f32;
    for e in 0..k * n * w {
        // fused.rs, loss_and_gradient: 0 + (d + d) * inv_n.
        let d = z[e] - y[e];
        assert_eq!(g[e].to_bits(), (0.0 + (d + d) * inv_n).to_bits(), "mse_grad at {e}");
    }
    let (gr, h) = (f("grelu"), f("h"));
    for e in 0..k * n * w {
        let df = if h[e] > 0.0 { 1.0f32 } else { 0.0 };
        assert_eq!(gr[e].to_bits(), (0.0 + df * g[e]).to_bits(), "relu_back at {e}");
    }
    let gb = f("gb");
    for (job, j) in (0..k).flat_map(|p| (0..w).map(move |j| (p, j))) {
        // Rows summed in order into a zeroed sum, as fused.rs does.
        let want = (0..n).fold(0f32, |s, i| s + g[(job * n + i) * w + j]);
        assert_eq!(gb[job * w + j].to_bits(), want.to_bits(), "bias_grad at ({job}, {j})");
    }
    let sq = arrays["sq64"].iter().map(|&b| f64::from_bits(b)).collect::<Vec<f64>>();
    for job in 0..k {
        let want: f64 = (0..n * w).map(|e| f64::from(z[job * n * w + e] - y[job * n * w + e]).powi(2)).sum();
        assert_eq!(sq[job].to_bits(), want.to_bits(), "sq_err of job {job}");
    }
    // Adam at step 3, job 1 masked out (fused.rs, adam).
    let (p0, m0, v0, p, m, v) = (f("p0"), f("m0"), f("v0"), f("p"), f("m"), f("v"));
    let (b1, b2, eps, lr) = (0.9f64 as f32, 0.999f64 as f32, 1e-8f64 as f32, 1e-3f32);
    // The bias corrections are the host's (the backend computes them as
    // fused.rs does); the harness's are read back.
    let (c1, c2) = (f("c")[0], f("c")[1]);
    for e in 0..k * n * w {
        if e / (n * w) == 1 {
            assert_eq!((p[e], m[e], v[e]), (p0[e], m0[e], v0[e]), "a masked job is left as it was");
            continue;
        }
        let gv = g[e];
        let mm = m0[e] * b1 + gv * (1.0 - b1);
        let vv = v0[e] * b2 + gv.powi(2) * (1.0 - b2);
        let want = p0[e] - lr * (mm * c1) / ((vv * c2).sqrt() + eps);
        assert_eq!(
            (p[e].to_bits(), m[e].to_bits(), v[e].to_bits()),
            (want.to_bits(), mm.to_bits(), vv.to_bits()),
            "adam at {e}"
        );
    }
}

/// What CUDA gives a kernel, for one thread on the CPU.
const KERNEL_SHIM: &str = r#"
#include <math.h>
#include <stdio.h>
#include <string.h>
typedef struct { unsigned x; } dim3_;
static dim3_ blockIdx, threadIdx, blockDim = {1}, gridDim = {1};
#define __shared__ static
#define __syncthreads()
"#;

/// Runs each kernel on the same small inputs and prints every array's bit
/// patterns (K = 3 jobs, n = 5 rows, w = 4 columns).
const KERNEL_HARNESS: &str = r#"
#define K 3
#define N 5
#define W 4
#define E (K * N * W)
static unsigned seed = 12345;
static float next(void) { seed = seed * 1103515245u + 12345u; return (float)((seed >> 9) & 0xFFFF) / 16384.0f - 2.0f; }
static void put32(const char* name, const float* a, int n) {
    printf("%s:", name);
    for (int i = 0; i < n; i++) { unsigned b; memcpy(&b, &a[i], 4); printf(" %08x", b); }
    printf("\n");
}
int main(void) {
    float z0[E], z[E], bias[K * W], y[E], g[E], grelu[E], h[E], gb[K * W], s32[K];
    double s64[K];
    float p0[E], m0[E], v0[E], p[E], m[E], v[E], mask[K] = {1.0f, 0.0f, 1.0f};
    for (int i = 0; i < E; i++) { z0[i] = next(); y[i] = next(); h[i] = next(); p0[i] = next(); m0[i] = next() / 10; v0[i] = fabsf(next()) / 10; }
    for (int i = 0; i < K * W; i++) bias[i] = next();
    memcpy(z, z0, sizeof z);
    bias_act(z, bias, K, N, W, 1);
    mse_grad(z, y, g, E, (float)(1.0 / (N * W)));
    memcpy(grelu, g, sizeof g);
    relu_back(grelu, h, E);
    for (unsigned t = 0; t < K * W; t++) { blockIdx.x = t; bias_grad(g, gb, K, N, W); }
    for (unsigned j = 0; j < K; j++) { blockIdx.x = j; sq_err(z, y, N * W, s32, s64); }
    blockIdx.x = 0;
    memcpy(p, p0, sizeof p); memcpy(m, m0, sizeof m); memcpy(v, v0, sizeof v);
    float b1 = 0.9f, b2 = 0.999f, c1 = 1.0f / (1.0f - b1 * b1 * b1), c2 = 1.0f / (1.0f - b2 * b2 * b2);
    adam(p, g, m, v, mask, N * W, E, 1e-3f, b1, b2, 1e-8f, c1, c2);
    float c[2] = {c1, c2};
    put32("c", c, 2);
    put32("z0", z0, E); put32("bias", bias, K * W); put32("z", z, E); put32("y", y, E); put32("g", g, E);
    put32("grelu", grelu, E); put32("h", h, E); put32("gb", gb, K * W);
    put32("p0", p0, E); put32("m0", m0, E); put32("v0", v0, E); put32("p", p, E); put32("m", m, E); put32("v", v, E);
    printf("sq64:");
    for (int j = 0; j < K; j++) { unsigned long long b; memcpy(&b, &s64[j], 8); printf(" %016llx", b); }
    printf("\n");
    return 0;
}
"#;
