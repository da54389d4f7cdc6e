//! Single-core f32 FMA peak of this CPU: the denominator of the training
//! GFLOP/s share in `benches/reference/protocol.sh`.
//!
//! Runs `ACC` independent 512-bit (or 256-bit without AVX-512) fused
//! multiply-add chains, enough to cover the FMA latency on every port, for
//! a fixed number of iterations, several times, and reports the best.
//!
//!     cargo run --release --example fma_peak
#![allow(unsafe_code)]

use std::time::Instant;

/// Independent chains: enough to hide FMA latency on two ports, few enough
/// to stay in registers (32 zmm, 16 ymm with the two constants).
const ACC512: usize = 24;
const ACC256: usize = 12;
const ITERS: u64 = 50_000_000;

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn fma512(iters: u64) -> f32 {
    use std::arch::x86_64::*;
    let a = _mm512_set1_ps(0.999_999);
    let b = _mm512_set1_ps(1e-7);
    let mut acc = [_mm512_set1_ps(1.0); ACC512];
    for _ in 0..iters {
        for r in acc.iter_mut() {
            *r = _mm512_fmadd_ps(*r, a, b);
        }
    }
    let mut s = _mm512_setzero_ps();
    for r in acc {
        s = _mm512_add_ps(s, r);
    }
    _mm512_reduce_add_ps(s)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn fma256(iters: u64) -> f32 {
    use std::arch::x86_64::*;
    let a = _mm256_set1_ps(0.999_999);
    let b = _mm256_set1_ps(1e-7);
    let mut acc = [_mm256_set1_ps(1.0); ACC256];
    for _ in 0..iters {
        for r in acc.iter_mut() {
            *r = _mm256_fmadd_ps(*r, a, b);
        }
    }
    let mut out = [0f32; 8];
    let mut s = _mm256_setzero_ps();
    for r in acc {
        s = _mm256_add_ps(s, r);
    }
    _mm256_storeu_ps(out.as_mut_ptr(), s);
    out.iter().sum()
}

/// Best GFLOP/s over `tries` runs of `f`, which does `lanes`-wide FMAs.
fn best(tries: usize, lanes: usize, chains: usize, f: impl Fn(u64) -> f32) -> f64 {
    (0..tries)
        .map(|_| {
            let t = Instant::now();
            let sink = f(ITERS);
            let s = t.elapsed().as_secs_f64();
            std::hint::black_box(sink);
            (ITERS * chains as u64 * lanes as u64 * 2) as f64 / s / 1e9
        })
        .fold(0.0, f64::max)
}

fn main() {
    #[cfg(target_arch = "x86_64")]
    {
        if is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU reports AVX-512F.
            let g = best(5, 16, ACC512, |n| unsafe { fma512(n) });
            println!("avx512 f32 fma peak, one core: {g:.1} GFLOP/s");
        }
        if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
            // SAFETY: the CPU reports AVX2 and FMA.
            let g = best(5, 8, ACC256, |n| unsafe { fma256(n) });
            println!("avx2 f32 fma peak, one core: {g:.1} GFLOP/s");
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    println!("fma_peak measures x86-64 only");
}
