//! The batched trainer's products and batches, run by the emulated GPU.

use super::super::emulated::Emulated;
use super::*;

fn fill(n: usize, seed: u32) -> Vec<f32> {
    (0..n).map(|i| (((i as u32).wrapping_mul(2_654_435_761) ^ seed) % 1000) as f32 / 500.0 - 1.0).collect()
}

/// The three products, run by the emulated cuBLAS (column-major, as its
/// documentation defines SGEMM), compute the row-major layer algebra.
#[test]
fn the_three_products_compute_the_row_major_layer_algebra() -> Result<(), Box<dyn std::error::Error>> {
    let (k, rows, inp, out) = (3, 5, 4, 6);
    let (a, w, g) = (fill(k * rows * inp, 1), fill(k * out * inp, 2), fill(k * rows * out, 3));
    let o = Emulated::new(0);
    let close = |x: f32, y: f64| (f64::from(x) - y).abs() < 1e-5;
    let cells =
        |n1: usize, n2: usize| (0..k).flat_map(move |p| (0..n1).flat_map(move |i| (0..n2).map(move |j| (p, i, j))));
    // Forward: Z[k][i][o] = sum_j A[k][i][j] W[k][o][j].
    let mut z = vec![0f32; k * rows * out];
    o.product(&forward_product(k, rows, inp, out), &w, &a, &mut z)?;
    for (p, i, c) in cells(rows, out) {
        let want: f64 =
            (0..inp).map(|j| f64::from(a[(p * rows + i) * inp + j]) * f64::from(w[(p * out + c) * inp + j])).sum();
        assert!(close(z[(p * rows + i) * out + c], want), "forward ({p}, {i}, {c})");
    }
    // Weight gradient: gW[k][o][j] = sum_i G[k][i][o] A[k][i][j].
    let mut gw = vec![0f32; k * out * inp];
    o.product(&weight_gradient_product(k, rows, inp, out), &a, &g, &mut gw)?;
    for (p, c, j) in cells(out, inp) {
        let want: f64 =
            (0..rows).map(|i| f64::from(g[(p * rows + i) * out + c]) * f64::from(a[(p * rows + i) * inp + j])).sum();
        assert!(close(gw[(p * out + c) * inp + j], want), "weight gradient ({p}, {c}, {j})");
    }
    // Input gradient: gA[k][i][j] = sum_o G[k][i][o] W[k][o][j].
    let mut ga = vec![0f32; k * rows * inp];
    o.product(&input_gradient_product(k, rows, inp, out), &w, &g, &mut ga)?;
    for (p, i, j) in cells(rows, inp) {
        let want: f64 =
            (0..out).map(|c| f64::from(g[(p * rows + i) * out + c]) * f64::from(w[(p * out + c) * inp + j])).sum();
        assert!(close(ga[(p * rows + i) * inp + j], want), "input gradient ({p}, {i}, {j})");
    }
    Ok(())
}

/// Windows along a circle, offset by `offset`: enough to fit
/// standardizers and a small network.
fn windows(offset: f64, n: usize) -> Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    (0..n)
        .map(|i| {
            let a = i as f64 * 0.05 + offset;
            let mut x = vec![0.0; 14];
            x[..6].copy_from_slice(&[a.cos(), a.sin(), 1.0 + 0.1 * a.sin(), 0.3, -0.1, 0.05]);
            x[6..10].copy_from_slice(&[0.99, 0.05, -0.08, 0.1]);
            x[10..14].copy_from_slice(&[a.cos() + 0.1, a.sin(), 1.0, 3.9]);
            let mut next = x.clone();
            next[0] += 0.01 * x[3];
            next[1] += 0.01 * x[4];
            (x, vec![0.5 + 0.1 * a.sin(), 0.5, 0.52, 0.49], next)
        })
        .collect()
}

/// Three jobs of one shape in one batch: the first stops early (patience
/// 1 at a learning rate that makes its validation loss rise), so the
/// other two move down a place and every product after its last epoch
/// runs over two jobs, not three. Each job's network and curve are the
/// bits it gets in a batch of its own (memory for one job).
#[test]
fn a_job_that_stops_leaves_the_batch_and_the_others_train_on_unchanged() -> Result<(), Box<dyn std::error::Error>> {
    use crate::design::{ActionScaling, InputMap, Optimizer, Schedule, TargetKind, Training};
    use crate::model::{FeatureMap, Slots};
    let fits: Vec<_> = [1.9, 0.0, 0.7].iter().map(|&o| windows(o, 600)).collect();
    let val = windows(3.1, 120);
    let features: Vec<FeatureMap> = fits
        .iter()
        .map(|w| {
            FeatureMap::fit(Slots::NANOBENCH, InputMap::World, ActionScaling::Raw, TargetKind::StateScaled, w, "m")
        })
        .collect();
    let patient = Training {
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
    let impatient = Training { patience: 1, ..patient.clone() };
    let ts = [impatient, patient.clone(), patient];
    let jobs: Vec<BatchJob> = (0..3)
        .map(|k| BatchJob {
            widths: &[32, 32, 32],
            features: &features[k],
            fit: &fits[k],
            validation: &val,
            training: &ts[k],
            seed: [13, 11, 12][k],
        })
        .collect();
    let together = Emulated::new(1 << 40);
    let trained = train_on(&together, &jobs, &|_, _| {})?;
    let epochs: Vec<usize> = trained.iter().map(|(_, l)| l.len()).collect();
    assert_eq!(epochs, [2, 8, 8], "the first job stops early, the others train every epoch");
    let batches = together.batches.lock().map_err(|_| "poisoned")?.clone();
    assert_eq!(batches.first(), Some(&3));
    assert_eq!(batches.last(), Some(&2));
    let shrank = batches.iter().position(|&b| b == 2).ok_or("the batch never shrank")?;
    assert!(batches[..shrank].iter().all(|&b| b == 3) && batches[shrank..].iter().all(|&b| b == 2));
    let alone = train_on(&Emulated::new(1), &jobs, &|_, _| {})?;
    for (k, ((nt, lt), (na, la))) in trained.iter().zip(&alone).enumerate() {
        assert_eq!(nt.flat_weights(), na.flat_weights(), "job {k}: weights");
        let curve = |l: &[EpochLog]| l.iter().map(|e| (e.epoch, e.train_loss, e.val_loss)).collect::<Vec<_>>();
        assert_eq!(curve(lt), curve(la), "job {k}: curve");
    }
    Ok(())
}

#[test]
fn a_job_takes_at_least_the_memory_of_its_buffers() {
    // The paper's network: 18 -> 256 -> 256 -> 256 -> 14.
    let dims = [(18, 256), (256, 256), (256, 256), (256, 14)];
    let params = 18 * 256 + 256 + 2 * (256 * 256 + 256) + 256 * 14 + 14;
    let bytes = bytes_per_job(&dims, 1024, 2000);
    // The parameters and their six companions (gradients, two moments,
    // best), the minibatch's and the validation's activations.
    assert!(bytes >= 4 * (7 * params + 2 * 1024 * 782 + 2000 * 782), "{bytes}");
    assert!(bytes < 32 << 20, "{bytes} bytes: 320 jobs fit in 10 GB");
}
