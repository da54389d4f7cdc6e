//! The batched GPU trainer's work done by plain loops on the CPU: cuBLAS's
//! strided-batched product as its documentation defines it (column-major,
//! each element summed in order of the inner index) and each kernel of
//! `cuda_kernels.cu` element by element. It runs the GPU backend's own
//! code ([`super::batched`]) where no GPU is, so that code is tested on
//! every machine; it is a reference, not a trainer anyone should use (it
//! is far slower than the fused CPU trainer).

// Each loop is written as its kernel is, by the element's index.
#![allow(clippy::needless_range_loop)]

use std::ops::Range;

use super::batched::{AdamStep, Ops, Product};
use super::lockstep::BackendError;

/// The CPU standing in for a GPU with `free` bytes of memory.
pub(super) struct Emulated {
    pub free: usize,
    /// The number of jobs of every product run, in order (what a test
    /// reads to see the batch shrink as jobs leave it).
    pub batches: std::sync::Mutex<Vec<usize>>,
}

impl Emulated {
    /// A GPU with `free` bytes of memory, stood in for.
    pub(super) fn new(free: usize) -> Emulated {
        Emulated { free, batches: std::sync::Mutex::default() }
    }
}

impl Ops for Emulated {
    type Buf = Vec<f32>;
    type Buf64 = Vec<f64>;

    fn zeros(&self, n: usize) -> Result<Vec<f32>, BackendError> {
        Ok(vec![0.0; n.max(1)])
    }
    fn zeros64(&self, n: usize) -> Result<Vec<f64>, BackendError> {
        Ok(vec![0.0; n.max(1)])
    }
    fn upload(&self, host: &[f32]) -> Result<Vec<f32>, BackendError> {
        Ok(host.to_vec())
    }
    fn write(&self, host: &[f32], dst: &mut Vec<f32>) -> Result<(), BackendError> {
        dst[..host.len()].copy_from_slice(host);
        Ok(())
    }
    fn read(&self, src: &Vec<f32>) -> Result<Vec<f32>, BackendError> {
        Ok(src.clone())
    }
    fn read64(&self, src: &Vec<f64>) -> Result<Vec<f64>, BackendError> {
        Ok(src.clone())
    }
    fn copy(&self, src: &Vec<f32>, from: usize, dst: &mut Vec<f32>, range: Range<usize>) -> Result<(), BackendError> {
        dst[range.clone()].copy_from_slice(&src[from..from + range.len()]);
        Ok(())
    }

    fn product(&self, p: &Product, a: &Vec<f32>, b: &Vec<f32>, c: &mut Vec<f32>) -> Result<(), BackendError> {
        // Element (r, col) of a column-major operand, or of its transpose.
        let at =
            |x: &[f32], t: bool, ld: usize, r: usize, col: usize| if t { x[col + r * ld] } else { x[r + col * ld] };
        self.batches.lock().map_err(|_| BackendError("a test's record was poisoned".into()))?.push(p.batch);
        for q in 0..p.batch {
            let (a, b) = (&a[q * p.stride_a..], &b[q * p.stride_b..]);
            let c = &mut c[q * p.stride_c..];
            for j in 0..p.n {
                for i in 0..p.m {
                    let mut s = 0f32;
                    for l in 0..p.k {
                        s += at(a, p.transa, p.lda, i, l) * at(b, p.transb, p.ldb, l, j);
                    }
                    c[i + j * p.ldc] = s;
                }
            }
        }
        Ok(())
    }

    fn bias_act(
        &self,
        z: &mut Vec<f32>,
        bias: &Vec<f32>,
        k: usize,
        n: usize,
        w: usize,
        relu: bool,
    ) -> Result<(), BackendError> {
        for (e, v) in z[..k * n * w].iter_mut().enumerate() {
            let zb = *v + bias[(e / (n * w)) * w + e % w];
            *v = if relu { zb.max(0.0) } else { zb };
        }
        Ok(())
    }

    fn mse_grad(
        &self,
        pred: &Vec<f32>,
        y: &Vec<f32>,
        grad: &mut Vec<f32>,
        total: usize,
        inv_n: f32,
    ) -> Result<(), BackendError> {
        for e in 0..total {
            let d = pred[e] - y[e];
            grad[e] = 0.0 + (d + d) * inv_n;
        }
        Ok(())
    }

    fn relu_back(&self, g: &mut Vec<f32>, h: &Vec<f32>, total: usize) -> Result<(), BackendError> {
        for e in 0..total {
            let df = if h[e] > 0.0 { 1.0f32 } else { 0.0 };
            g[e] = 0.0 + df * g[e];
        }
        Ok(())
    }

    fn bias_grad(&self, g: &Vec<f32>, gb: &mut Vec<f32>, k: usize, n: usize, w: usize) -> Result<(), BackendError> {
        for t in 0..k * w {
            let (job, j) = (t / w, t % w);
            gb[t] = (0..n).fold(0f32, |s, i| s + g[job * n * w + i * w + j]);
        }
        Ok(())
    }

    fn sq_err(
        &self,
        pred: &Vec<f32>,
        y: &Vec<f32>,
        k: usize,
        len: usize,
        out32: &mut Vec<f32>,
        out64: &mut Vec<f64>,
    ) -> Result<(), BackendError> {
        for job in 0..k {
            let s: f64 = (job * len..(job + 1) * len).map(|e| f64::from(pred[e] - y[e]).powi(2)).sum();
            out32[job] = s as f32;
            out64[job] = s;
        }
        Ok(())
    }

    fn adam(
        &self,
        (p, g, m, v): (&mut Vec<f32>, &Vec<f32>, &mut Vec<f32>, &mut Vec<f32>),
        mask: &Vec<f32>,
        per_job: usize,
        total: usize,
        s: AdamStep,
    ) -> Result<(), BackendError> {
        for e in (0..total).filter(|e| mask[e / per_job] != 0.0) {
            let gv = g[e];
            m[e] = m[e] * s.b1 + gv * (1.0 - s.b1);
            v[e] = v[e] * s.b2 + (gv * gv) * (1.0 - s.b2);
            let (m_hat, v_hat) = (m[e] * s.c1, v[e] * s.c2);
            p[e] -= s.lr * m_hat / (v_hat.sqrt() + s.eps);
        }
        Ok(())
    }

    fn free_memory(&self) -> Result<usize, BackendError> {
        Ok(self.free)
    }
}
