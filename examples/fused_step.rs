//! Times one training step of the fused trainer (batch 1024, the paper's
//! 256-wide MLP) and, beside it, the step's matrix products alone, issued
//! as the trainer issues them: what is left between the two is the
//! elementwise work (bias, ReLU, loss, bias gradients, Adam).
//!
//!     cargo run --release --example fused_step
#![allow(unsafe_code)]

use std::time::Instant;

use crossaudit::model::fused::{Activations, FusedMlp, Trainer};

const WIDTH: usize = 256;
const BATCH: usize = 1024;
const REPS: usize = 200;

/// `dst = alpha * dst + lhs * rhs`, strides as (column, row) like `gemm::gemm`.
#[allow(clippy::too_many_arguments)]
fn product(
    (m, n, k): (usize, usize, usize),
    dst: &mut [f32],
    (dcs, drs): (isize, isize),
    read_dst: bool,
    (lhs, lcs, lrs): (&[f32], isize, isize),
    (rhs, rcs, rrs): (&[f32], isize, isize),
    alpha: f32,
) {
    // SAFETY: every operand below is allocated at the full shape it is
    // addressed with (the strides are those of dense row/column-major data).
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            dst.as_mut_ptr(),
            dcs,
            drs,
            read_dst,
            lhs.as_ptr(),
            lcs,
            lrs,
            rhs.as_ptr(),
            rcs,
            rrs,
            alpha,
            1.0,
            false,
            false,
            false,
            gemm::Parallelism::None,
        )
    }
}

/// Mean seconds of `REPS` calls of `f`.
fn time(mut f: impl FnMut()) -> f64 {
    let t = Instant::now();
    for _ in 0..REPS {
        f();
    }
    t.elapsed().as_secs_f64() / REPS as f64
}

fn main() {
    let mut state = 1u64;
    let mut uniform = |n: usize| -> Vec<f32> {
        (0..n)
            .map(|_| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (state >> 40) as f32 / (1u64 << 24) as f32 - 0.5
            })
            .collect()
    };
    let dims = [(18, WIDTH), (WIDTH, WIDTH), (WIDTH, WIDTH), (WIDTH, 14)];
    let parts: Vec<_> = dims.iter().map(|&(i, o)| (uniform(i * o), uniform(o))).collect();
    let net = FusedMlp::from_parts(&crossaudit::model::Slots::NANOBENCH, &[WIDTH; 3], &parts);
    let (x, y) = (uniform(BATCH * 18), uniform(BATCH * 14));
    let mut trainer = Trainer::new(net, BATCH);
    for _ in 0..20 {
        trainer.step(&x, &y, BATCH, 1e-4);
    }
    let step = time(|| {
        trainer.step(&x, &y, BATCH, 1e-4);
    });
    let mut act = Activations::new(&trainer.net, BATCH);
    let forward = time(|| {
        std::hint::black_box(trainer.net.forward(&x, BATCH, &mut act));
    });
    let mut products = 0.0;
    for (l, &(inp, out)) in dims.iter().enumerate() {
        let (a, w, g) = (uniform(BATCH * inp), uniform(out * inp), uniform(BATCH * out));
        let (mut z, mut gw, mut gh) = (vec![0f32; BATCH * out], vec![0f32; out * inp], vec![0f32; BATCH * inp]);
        let (o, i) = (out as isize, inp as isize);
        let fwd = time(|| product((BATCH, out, inp), &mut z, (1, o), false, (&a, 1, i), (&w, i, 1), 0.0));
        let wgrad = time(|| {
            gw.fill(0.0);
            product((inp, out, BATCH), &mut gw, (i, 1), true, (&a, i, 1), (&g, 1, o), 1.0)
        });
        let igrad = if l == 0 {
            0.0 // the input needs no gradient
        } else {
            time(|| product((BATCH, inp, out), &mut gh, (1, i), false, (&g, 1, o), (&w, 1, i), 1.0))
        };
        let gflops = |s: f64| 2.0 * (BATCH * inp * out) as f64 / s / 1e9;
        println!(
            "{inp:>3} x {out:<3}  forward {:.3} ms ({:.0} GFLOP/s)  weight grad {:.3} ms ({:.0})  input grad {:.3} ms",
            fwd * 1e3,
            gflops(fwd),
            wgrad * 1e3,
            gflops(wgrad),
            igrad * 1e3,
        );
        products += fwd + wgrad + igrad;
    }
    let macs = dims.iter().map(|(i, o)| i * o).sum::<usize>() as f64 * BATCH as f64;
    println!(
        "step {:.3} ms ({:.1} GFLOP/s), forward {:.3} ms, products alone {:.3} ms, elementwise {:.3} ms",
        step * 1e3,
        6.0 * macs / step / 1e9,
        forward * 1e3,
        products * 1e3,
        (step - products) * 1e3
    );
}
