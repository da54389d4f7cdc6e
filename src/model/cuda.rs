//! The CUDA backend of the batched trainer: K jobs that share a shape
//! (layer widths, minibatch size, fit and validation window counts and
//! learning-rate schedule) keep their parameters, gradients, Adam moments
//! and best parameters side by side on the GPU, and every minibatch step
//! of all K is one strided-batched cuBLAS product per layer and direction,
//! plus the elementwise kernels of `cuda_kernels.cu` (NVRTC, no fused
//! multiply-add contraction). The host keeps each job's shuffle, action
//! noise and early stopping ([`super::lockstep`]), so a job sees the same
//! minibatches as on the CPU.
//!
//! Reproducible on one GPU: cuBLAS's single-precision products give the
//! same bits run to run on the same GPU and library, and no reduction uses
//! atomics. Against the CPU trainer the products are summed in another
//! order, so the weights differ in their last bits, and the curves by a
//! stated floating-point tolerance (`scripts/gpu-check.sh`).
//!
//! Rollouts still run on the CPU, from the weights trained here.
#![allow(unsafe_code)]

use std::collections::BTreeMap;
use std::sync::Arc;

use cudarc::cublas::sys::cublasOperation_t::{CUBLAS_OP_N, CUBLAS_OP_T};
use cudarc::cublas::{CudaBlas, Gemm, GemmConfig, StridedBatchedConfig};
use cudarc::driver::{CudaContext, CudaFunction, CudaSlice, CudaStream, LaunchConfig, PushKernelArg};
use cudarc::nvrtc::{compile_ptx_with_opts, CompileOptions, Ptx};
use rayon::prelude::*;

use super::device::Gpu;
use super::fused::FusedMlp;
use super::lockstep::{lockstep, validation_set, Backend, BackendError, BatchJob, Step};
use super::net::{EpochLog, Net, NetError};

/// The elementwise kernels, compiled at run time.
const KERNELS: &str = include_str!("cuda_kernels.cu");

/// The kernels compiled by NVRTC: IEEE division and square root, no
/// flush to zero, and no contraction of `a * b + c` into a fused
/// multiply-add, as on the CPU. Needs the NVRTC library, not a GPU.
pub(super) fn compile_kernels() -> Result<Ptx, BackendError> {
    // SAFETY: the check only tries to open the library by its names.
    if !unsafe { cudarc::nvrtc::sys::is_culib_present() } {
        return Err(BackendError("the NVRTC library (libnvrtc.so) is not installed".into()));
    }
    let opts = CompileOptions {
        fmad: Some(false),
        prec_div: Some(true),
        prec_sqrt: Some(true),
        ftz: Some(false),
        ..Default::default()
    };
    compile_ptx_with_opts(KERNELS, opts).map_err(|e| fail("compiling the kernels with NVRTC")(&e))
}

/// Threads per block of the elementwise kernels.
const THREADS: u32 = 256;

/// Any CUDA failure, in words.
fn fail(what: &str) -> impl Fn(&dyn std::fmt::Debug) -> BackendError + '_ {
    move |e| BackendError(format!("{what}: {e:?}"))
}

/// A GPU opened for training: its stream, cuBLAS handle and kernels.
struct Session {
    ctx: Arc<CudaContext>,
    stream: Arc<CudaStream>,
    blas: CudaBlas,
    bias_act: CudaFunction,
    mse_grad: CudaFunction,
    relu_back: CudaFunction,
    bias_grad: CudaFunction,
    sq_err: CudaFunction,
    adam: CudaFunction,
}

impl Session {
    fn open(gpu: &Gpu) -> Result<Session, BackendError> {
        let ctx = CudaContext::new(gpu.ordinal).map_err(|e| fail("opening the CUDA device")(&e))?;
        let stream = ctx.default_stream();
        let blas = CudaBlas::new(stream.clone()).map_err(|e| fail("starting cuBLAS")(&e))?;
        let module = ctx.load_module(compile_kernels()?).map_err(|e| fail("loading the kernels")(&e))?;
        let f = |name: &str| module.load_function(name).map_err(|e| fail(name)(&e));
        Ok(Session {
            bias_act: f("bias_act")?,
            mse_grad: f("mse_grad")?,
            relu_back: f("relu_back")?,
            bias_grad: f("bias_grad")?,
            sq_err: f("sq_err")?,
            adam: f("adam")?,
            ctx,
            stream,
            blas,
        })
    }

    fn zeros(&self, n: usize) -> Result<CudaSlice<f32>, BackendError> {
        self.stream.alloc_zeros::<f32>(n.max(1)).map_err(|e| fail("allocating GPU memory")(&e))
    }

    fn upload(&self, host: &[f32]) -> Result<CudaSlice<f32>, BackendError> {
        self.stream.clone_htod(host).map_err(|e| fail("copying to the GPU")(&e))
    }
}

/// A grid-stride launch over `total` elements.
fn elementwise(total: usize) -> LaunchConfig {
    let blocks = total.div_ceil(THREADS as usize).clamp(1, 65_535) as u32;
    LaunchConfig { grid_dim: (blocks, 1, 1), block_dim: (THREADS, 1, 1), shared_mem_bytes: 0 }
}

/// One layer of K jobs: `[K][out][inp]` weights and their companions.
struct Layer {
    inp: usize,
    out: usize,
    w: CudaSlice<f32>,
    b: CudaSlice<f32>,
    gw: CudaSlice<f32>,
    gb: CudaSlice<f32>,
    mw: CudaSlice<f32>,
    vw: CudaSlice<f32>,
    mb: CudaSlice<f32>,
    vb: CudaSlice<f32>,
    best_w: CudaSlice<f32>,
    best_b: CudaSlice<f32>,
    /// `[K][batch][out]`: the layer's output (after ReLU) of a minibatch.
    h: CudaSlice<f32>,
    /// `[K][batch][out]`: the loss's gradient at the layer's pre-activation.
    gz: CudaSlice<f32>,
    /// `[K][n_val][out]`: the layer's output on the validation windows.
    val_h: CudaSlice<f32>,
}

/// K jobs of one shape on the GPU.
struct Batch<'s> {
    s: &'s Session,
    k: usize,
    n_val: usize,
    layers: Vec<Layer>,
    x: CudaSlice<f32>,
    y: CudaSlice<f32>,
    val_x: CudaSlice<f32>,
    val_y: CudaSlice<f32>,
    mask: CudaSlice<f32>,
    sq32: CudaSlice<f32>,
    sq64: CudaSlice<f64>,
    host_x: Vec<f32>,
    host_y: Vec<f32>,
    /// Adam's step counter, shared: every job in the batch steps together.
    t: i32,
}

/// Bytes of GPU memory one job of this shape takes.
fn bytes_per_job(dims: &[(usize, usize)], batch: usize, n_val: usize) -> usize {
    let params: usize = dims.iter().map(|&(i, o)| i * o + o).sum();
    let widths: usize = dims.iter().map(|&(_, o)| o).sum();
    let (inputs, outputs) = (dims[0].0, dims[dims.len() - 1].1);
    4 * (10 * params + (batch + n_val) * (inputs + outputs) + (2 * batch + n_val) * widths) + 16
}

impl<'s> Batch<'s> {
    fn new(s: &'s Session, jobs: &[BatchJob], inits: &[FusedMlp]) -> Result<Batch<'s>, BackendError> {
        let k = jobs.len();
        let (batch, n_val) = (jobs[0].training.batch, jobs[0].validation.len());
        let mut layers = Vec::new();
        for (l, first) in inits[0].layers.iter().enumerate() {
            let (inp, out) = (first.inp, first.out);
            let w: Vec<f32> = inits.iter().flat_map(|m| m.layers[l].weight.iter().copied()).collect();
            let b: Vec<f32> = inits.iter().flat_map(|m| m.layers[l].bias.iter().copied()).collect();
            layers.push(Layer {
                inp,
                out,
                w: s.upload(&w)?,
                b: s.upload(&b)?,
                best_w: s.upload(&w)?,
                best_b: s.upload(&b)?,
                gw: s.zeros(w.len())?,
                gb: s.zeros(b.len())?,
                mw: s.zeros(w.len())?,
                vw: s.zeros(w.len())?,
                mb: s.zeros(b.len())?,
                vb: s.zeros(b.len())?,
                h: s.zeros(k * batch * out)?,
                gz: s.zeros(k * batch * out)?,
                val_h: s.zeros(k * n_val * out)?,
            });
        }
        let sets: Vec<(Vec<f32>, Vec<f32>)> = jobs.iter().map(validation_set).collect();
        let val_x: Vec<f32> = sets.iter().flat_map(|(x, _)| x.iter().copied()).collect();
        let val_y: Vec<f32> = sets.iter().flat_map(|(_, y)| y.iter().copied()).collect();
        let (inputs, outputs) = (layers[0].inp, layers[layers.len() - 1].out);
        Ok(Batch {
            s,
            k,
            n_val,
            x: s.zeros(k * batch * inputs)?,
            y: s.zeros(k * batch * outputs)?,
            val_x: s.upload(&val_x)?,
            val_y: s.upload(&val_y)?,
            mask: s.zeros(k)?,
            sq32: s.zeros(k)?,
            sq64: s.stream.alloc_zeros::<f64>(k).map_err(|e| fail("allocating GPU memory")(&e))?,
            host_x: vec![0.0; k * batch * inputs],
            host_y: vec![0.0; k * batch * outputs],
            layers,
            t: 0,
        })
    }

    /// The forward pass of `rows` rows of every job: from `x` (or the
    /// validation inputs) through each layer's `h` (or `val_h`).
    fn forward(&mut self, rows: usize, validation: bool) -> Result<(), BackendError> {
        let (s, k) = (self.s, self.k);
        let last = self.layers.len() - 1;
        for l in 0..self.layers.len() {
            let (below, here) = self.layers.split_at_mut(l);
            let layer = &mut here[0];
            let (inp, out) = (layer.inp, layer.out);
            let input = match (l, validation) {
                (0, false) => &self.x,
                (0, true) => &self.val_x,
                (_, false) => &below[l - 1].h,
                (_, true) => &below[l - 1].val_h,
            };
            let z = if validation { &mut layer.val_h } else { &mut layer.h };
            let cfg = forward_product(k, rows, inp, out);
            // SAFETY: every buffer holds K matrices of the shapes and strides
            // given (allocated for at least `rows` rows each).
            unsafe { s.blas.gemm_strided_batched(cfg, &layer.w, input, z) }.map_err(|e| fail("cuBLAS forward")(&e))?;
            let (kk, n, w, relu) = (k as i64, rows as i64, out as i64, i32::from(l < last));
            let mut launch = s.stream.launch_builder(&s.bias_act);
            launch.arg(z).arg(&layer.b).arg(&kk).arg(&n).arg(&w).arg(&relu);
            // SAFETY: the kernel's arguments match its signature in cuda_kernels.cu.
            unsafe { launch.launch(elementwise(k * rows * out)) }.map_err(|e| fail("bias_act")(&e))?;
        }
        Ok(())
    }

    /// Each job's sum of squared errors of `pred` against `y` over `len`
    /// elements per job, in f32 and f64.
    fn sq_err(&mut self, validation: bool, len: usize) -> Result<(Vec<f32>, Vec<f64>), BackendError> {
        let s = self.s;
        let last = self.layers.len() - 1;
        let (pred, y) =
            if validation { (&self.layers[last].val_h, &self.val_y) } else { (&self.layers[last].h, &self.y) };
        let len = len as i64;
        let mut launch = s.stream.launch_builder(&s.sq_err);
        launch.arg(pred).arg(y).arg(&len).arg(&mut self.sq32).arg(&mut self.sq64);
        let cfg = LaunchConfig { grid_dim: (self.k as u32, 1, 1), block_dim: (THREADS, 1, 1), shared_mem_bytes: 0 };
        // SAFETY: the kernel's arguments match its signature; one block per job.
        unsafe { launch.launch(cfg) }.map_err(|e| fail("sq_err")(&e))?;
        let f32s = s.stream.clone_dtoh(&self.sq32).map_err(|e| fail("copying from the GPU")(&e))?;
        let f64s = s.stream.clone_dtoh(&self.sq64).map_err(|e| fail("copying from the GPU")(&e))?;
        Ok((f32s, f64s))
    }

    /// Backpropagation of the loss's gradient at the output (in the last
    /// layer's `gz`) through every layer, and each layer's bias gradient.
    fn backward(&mut self, rows: usize) -> Result<(), BackendError> {
        let (s, k) = (self.s, self.k);
        for l in (0..self.layers.len()).rev() {
            let (below, here) = self.layers.split_at_mut(l);
            let layer = &mut here[0];
            let (inp, out) = (layer.inp, layer.out);
            bias_grad(s, k, rows, out, &layer.gz, &mut layer.gb)?;
            let input = if l == 0 { &self.x } else { &below[l - 1].h };
            let cfg = weight_gradient_product(k, rows, inp, out);
            // SAFETY: shapes and strides as allocated.
            unsafe { s.blas.gemm_strided_batched(cfg, input, &layer.gz, &mut layer.gw) }
                .map_err(|e| fail("cuBLAS weight gradient")(&e))?;
            if l == 0 {
                break;
            }
            let prev = &mut below[l - 1];
            let cfg = input_gradient_product(k, rows, inp, out);
            // SAFETY: shapes and strides as allocated.
            unsafe { s.blas.gemm_strided_batched(cfg, &layer.w, &layer.gz, &mut prev.gz) }
                .map_err(|e| fail("cuBLAS input gradient")(&e))?;
            let total = (k * rows * inp) as i64;
            let mut launch = s.stream.launch_builder(&s.relu_back);
            launch.arg(&mut prev.gz).arg(&prev.h).arg(&total);
            // SAFETY: the kernel's arguments match its signature.
            unsafe { launch.launch(elementwise(k * rows * inp)) }.map_err(|e| fail("relu_back")(&e))?;
        }
        Ok(())
    }

    /// dfdx's Adam step on every job of the mask.
    fn adam(&mut self, lr: f64) -> Result<(), BackendError> {
        self.t = self.t.checked_add(1).ok_or_else(|| BackendError("more than 2^31 Adam steps".into()))?;
        let (b1, b2) = (0.9f64 as f32, 0.999f64 as f32);
        let (eps, lr) = (1e-8f64 as f32, lr as f32);
        let (c1, c2) = ((1.0 - b1.powi(self.t)).recip(), (1.0 - b2.powi(self.t)).recip());
        let (s, k, mask) = (self.s, self.k, &self.mask);
        for layer in &mut self.layers {
            let tensors = [
                (&mut layer.w, &layer.gw, &mut layer.mw, &mut layer.vw, layer.inp * layer.out),
                (&mut layer.b, &layer.gb, &mut layer.mb, &mut layer.vb, layer.out),
            ];
            for (p, g, m, v, per_job) in tensors {
                let (per, total) = (per_job as i64, (k * per_job) as i64);
                let mut launch = s.stream.launch_builder(&s.adam);
                launch.arg(p).arg(g).arg(m).arg(v).arg(mask).arg(&per).arg(&total);
                launch.arg(&lr).arg(&b1).arg(&b2).arg(&eps).arg(&c1).arg(&c2);
                // SAFETY: the kernel's arguments match its signature.
                unsafe { launch.launch(elementwise(k * per_job)) }.map_err(|e| fail("adam")(&e))?;
            }
        }
        Ok(())
    }

    /// Each job's best parameters, as networks of `jobs`' shape.
    fn best(&self, jobs: &[BatchJob]) -> Result<Vec<Net>, BackendError> {
        let down = |d: &CudaSlice<f32>| self.s.stream.clone_dtoh(d).map_err(|e| fail("copying from the GPU")(&e));
        let layers: Vec<(Vec<f32>, Vec<f32>)> =
            self.layers.iter().map(|l| Ok((down(&l.best_w)?, down(&l.best_b)?))).collect::<Result<_, _>>()?;
        Ok(jobs
            .iter()
            .enumerate()
            .map(|(j, job)| {
                let parts: Vec<(Vec<f32>, Vec<f32>)> = self
                    .layers
                    .iter()
                    .zip(&layers)
                    .map(|(l, (w, b))| {
                        let (nw, nb) = (l.inp * l.out, l.out);
                        (w[j * nw..(j + 1) * nw].to_vec(), b[j * nb..(j + 1) * nb].to_vec())
                    })
                    .collect();
                Net::from_mlp(FusedMlp::from_parts(&job.features.slots, job.widths, &parts))
            })
            .collect())
    }
}

/// `bias_grad`: each job's column sums of `g` (rows x out), in row order.
fn bias_grad(
    s: &Session,
    k: usize,
    rows: usize,
    out: usize,
    g: &CudaSlice<f32>,
    gb: &mut CudaSlice<f32>,
) -> Result<(), BackendError> {
    let (kk, n, w) = (k as i64, rows as i64, out as i64);
    let mut launch = s.stream.launch_builder(&s.bias_grad);
    launch.arg(g).arg(gb).arg(&kk).arg(&n).arg(&w);
    let blocks = (k * out).div_ceil(THREADS as usize) as u32;
    let cfg = LaunchConfig { grid_dim: (blocks.max(1), 1, 1), block_dim: (THREADS, 1, 1), shared_mem_bytes: 0 };
    // SAFETY: the kernel's arguments match its signature; it bounds its index.
    unsafe { launch.launch(cfg) }.map_err(|e| fail("bias_grad")(&e))?;
    Ok(())
}

// The three products of a layer of `inp` inputs and `out` outputs over
// `rows` rows, for K jobs. The host's matrices are row-major, so cuBLAS
// (column-major) sees each as its transpose: a row-major n x w buffer is a
// column-major w x n matrix with leading dimension w.

/// Z = A W^T (rows x out), from A (rows x inp) and W (out x inp): as
/// cuBLAS sees it, Z^T = op_T(W^T) A^T. Operands (W, A).
fn forward_product(k: usize, rows: usize, inp: usize, out: usize) -> StridedBatchedConfig<f32> {
    batched(k, (out, rows, inp), (CUBLAS_OP_T, inp, out * inp), (CUBLAS_OP_N, inp, rows * inp), out)
}

/// gW = G^T A (out x inp), from A (rows x inp) and G (rows x out): as
/// cuBLAS sees it, gW^T = A^T op_T(G^T). Operands (A, G).
fn weight_gradient_product(k: usize, rows: usize, inp: usize, out: usize) -> StridedBatchedConfig<f32> {
    batched(k, (inp, out, rows), (CUBLAS_OP_N, inp, rows * inp), (CUBLAS_OP_T, out, rows * out), inp)
}

/// gA = G W (rows x inp), from G (rows x out) and W (out x inp): as cuBLAS
/// sees it, gA^T = W^T G^T. Operands (W, G).
fn input_gradient_product(k: usize, rows: usize, inp: usize, out: usize) -> StridedBatchedConfig<f32> {
    batched(k, (inp, rows, out), (CUBLAS_OP_N, inp, out * inp), (CUBLAS_OP_N, out, rows * out), inp)
}

/// A strided-batched product C = op(A) op(B) of `k` pairs, column-major:
/// (m, n, inner), each operand's (op, leading dimension, stride), and C's
/// leading dimension (its stride is ldc * n).
fn batched(
    k: usize,
    (m, n, inner): (usize, usize, usize),
    (op_a, lda, stride_a): (cudarc::cublas::sys::cublasOperation_t, usize, usize),
    (op_b, ldb, stride_b): (cudarc::cublas::sys::cublasOperation_t, usize, usize),
    ldc: usize,
) -> StridedBatchedConfig<f32> {
    StridedBatchedConfig {
        gemm: GemmConfig {
            transa: op_a,
            transb: op_b,
            m: m as i32,
            n: n as i32,
            k: inner as i32,
            alpha: 1.0,
            lda: lda as i32,
            ldb: ldb as i32,
            beta: 0.0,
            ldc: ldc as i32,
        },
        batch_size: k as i32,
        stride_a: stride_a as i64,
        stride_b: stride_b as i64,
        stride_c: (ldc * n) as i64,
    }
}

impl Backend for Batch<'_> {
    fn steps(&mut self, steps: &[Step<'_>]) -> Result<Vec<f32>, BackendError> {
        let rows = steps[0].n;
        if steps.iter().any(|s| s.n != rows || s.lr != steps[0].lr) {
            return Err(BackendError("the jobs of one GPU batch took minibatches of different sizes or rates".into()));
        }
        let (inputs, outputs) = (self.layers[0].inp, self.layers[self.layers.len() - 1].out);
        // Each job's minibatch into its place, in parallel (tens of MB a
        // step for hundreds of jobs); a job without a step is masked out.
        let mut of_job: Vec<Option<&Step>> = vec![None; self.k];
        for st in steps {
            of_job[st.job] = Some(st);
        }
        let mask: Vec<f32> = of_job.iter().map(|st| if st.is_some() { 1.0 } else { 0.0 }).collect();
        let (xs, ys) = (&mut self.host_x[..self.k * rows * inputs], &mut self.host_y[..self.k * rows * outputs]);
        xs.par_chunks_mut(rows * inputs).zip(ys.par_chunks_mut(rows * outputs)).zip(&of_job).for_each(
            |((x, y), st)| {
                if let Some(st) = st {
                    x.copy_from_slice(st.x);
                    y.copy_from_slice(st.y);
                }
            },
        );
        let s = self.s;
        let up = |e: &dyn std::fmt::Debug| fail("copying to the GPU")(e);
        s.stream.memcpy_htod(&self.host_x[..self.k * rows * inputs], &mut self.x).map_err(|e| up(&e))?;
        s.stream.memcpy_htod(&self.host_y[..self.k * rows * outputs], &mut self.y).map_err(|e| up(&e))?;
        s.stream.memcpy_htod(&mask, &mut self.mask).map_err(|e| up(&e))?;
        self.forward(rows, false)?;
        let last = self.layers.len() - 1;
        let total = (self.k * rows * outputs) as i64;
        let inv_n = (1.0 / (rows * outputs) as f64) as f32;
        let (sums, _) = self.sq_err(false, rows * outputs)?;
        {
            let layer = &mut self.layers[last];
            let mut launch = s.stream.launch_builder(&s.mse_grad);
            launch.arg(&layer.h).arg(&self.y).arg(&mut layer.gz).arg(&total).arg(&inv_n);
            // SAFETY: the kernel's arguments match its signature.
            unsafe { launch.launch(elementwise(self.k * rows * outputs)) }.map_err(|e| fail("mse_grad")(&e))?;
        }
        self.backward(rows)?;
        self.adam(steps[0].lr)?;
        Ok(steps.iter().map(|st| (sums[st.job] * 1.0) * inv_n).collect())
    }

    fn val_losses(&mut self, jobs: &[usize]) -> Result<Vec<f64>, BackendError> {
        self.forward(self.n_val, true)?;
        let len = self.n_val * self.layers[self.layers.len() - 1].out;
        let (_, sums) = self.sq_err(true, len)?;
        Ok(jobs.iter().map(|&j| sums[j] / len as f64).collect())
    }

    fn keep_best(&mut self, job: usize) -> Result<(), BackendError> {
        let stream = &self.s.stream;
        for l in &mut self.layers {
            let (nw, nb) = (l.inp * l.out, l.out);
            let (rw, rb) = (job * nw..(job + 1) * nw, job * nb..(job + 1) * nb);
            let copy = |e: &dyn std::fmt::Debug| fail("copying on the GPU")(e);
            stream.memcpy_dtod(&l.w.slice(rw.clone()), &mut l.best_w.slice_mut(rw)).map_err(|e| copy(&e))?;
            stream.memcpy_dtod(&l.b.slice(rb.clone()), &mut l.best_b.slice_mut(rb)).map_err(|e| copy(&e))?;
        }
        Ok(())
    }
}

/// What jobs must share to step together.
fn shape(job: &BatchJob) -> (Vec<usize>, [usize; 5], [u64; 2], bool) {
    let t = job.training;
    let slots = job.features.slots;
    let sizes = [slots.input(), slots.state, t.batch, job.fit.len(), job.validation.len()];
    (job.widths.to_vec(), sizes, [t.lr.to_bits(), t.epochs as u64], t.schedule == crate::design::Schedule::Cosine)
}

/// Trains `jobs` on `gpu`: jobs of one shape in batches sized from the
/// GPU's free memory, each batch in lockstep.
pub(super) fn train_batch(
    gpu: &Gpu,
    jobs: &[BatchJob],
    on_epoch: &(dyn Fn(usize, &EpochLog) + Sync),
) -> Result<Vec<(Net, Vec<EpochLog>)>, NetError> {
    let s = Session::open(gpu)?;
    let mut groups: BTreeMap<_, Vec<usize>> = BTreeMap::new();
    for (i, job) in jobs.iter().enumerate() {
        groups.entry(shape(job)).or_default().push(i);
    }
    let mut out: Vec<Option<(Net, Vec<EpochLog>)>> = jobs.iter().map(|_| None).collect();
    for members in groups.values() {
        let first = &jobs[members[0]];
        let dims = FusedMlp::dims(&first.features.slots, first.widths);
        let free = s.ctx.mem_get_info().map_err(|e| fail("asking the GPU's free memory")(&e))?.0;
        let per = bytes_per_job(&dims, first.training.batch, first.validation.len());
        let fits = (free / 10 * 8 / per).max(1);
        for chunk in members.chunks(fits) {
            let batch: Vec<BatchJob> = chunk.iter().map(|&i| jobs[i]).collect();
            let inits: Vec<FusedMlp> =
                batch.iter().map(|j| Net::init(&j.features.slots, j.widths, j.seed).fused()).collect();
            let mut b = Batch::new(&s, &batch, &inits)?;
            let logs = lockstep(&mut b, &batch, &mut |k, log| on_epoch(chunk[k], log))?;
            for ((&i, net), logs) in chunk.iter().zip(b.best(&batch)?).zip(logs) {
                out[i] = Some((net, logs));
            }
        }
    }
    out.into_iter().map(|r| r.ok_or_else(|| NetError::Device(BackendError("a job was not trained".into())))).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// cuBLAS's strided-batched SGEMM as its documentation defines it
    /// (column-major; element (r, c) of a matrix at r + c * ld; op T reads
    /// the transpose), with alpha = 1 and beta = 0.
    fn cublas(cfg: &StridedBatchedConfig<f32>, a: &[f32], b: &[f32], c: &mut [f32]) {
        let g = &cfg.gemm;
        let (m, n, kk) = (g.m as usize, g.n as usize, g.k as usize);
        let at = |x: &[f32], op, ld: usize, r: usize, col: usize| {
            if op == CUBLAS_OP_N {
                x[r + col * ld]
            } else {
                x[col + r * ld]
            }
        };
        for p in 0..cfg.batch_size as usize {
            let (a, b) = (&a[p * cfg.stride_a as usize..], &b[p * cfg.stride_b as usize..]);
            let c = &mut c[p * cfg.stride_c as usize..];
            for i in 0..m {
                for j in 0..n {
                    let s: f64 = (0..kk)
                        .map(|l| {
                            f64::from(at(a, g.transa, g.lda as usize, i, l))
                                * f64::from(at(b, g.transb, g.ldb as usize, l, j))
                        })
                        .sum();
                    c[i + j * g.ldc as usize] = s as f32;
                }
            }
        }
    }

    fn fill(n: usize, seed: u32) -> Vec<f32> {
        (0..n).map(|i| (((i as u32).wrapping_mul(2_654_435_761) ^ seed) % 1000) as f32 / 500.0 - 1.0).collect()
    }

    #[test]
    fn the_three_products_compute_the_row_major_layer_algebra() {
        let (k, rows, inp, out) = (3, 5, 4, 6);
        let (a, w, g) = (fill(k * rows * inp, 1), fill(k * out * inp, 2), fill(k * rows * out, 3));
        let close = |x: f32, y: f64| (f64::from(x) - y).abs() < 1e-5;
        // Forward: Z[k][i][o] = sum_j A[k][i][j] W[k][o][j].
        let mut z = vec![0f32; k * rows * out];
        cublas(&forward_product(k, rows, inp, out), &w, &a, &mut z);
        for (p, i, o) in (0..k).flat_map(|p| (0..rows).flat_map(move |i| (0..out).map(move |o| (p, i, o)))) {
            let want: f64 =
                (0..inp).map(|j| f64::from(a[(p * rows + i) * inp + j]) * f64::from(w[(p * out + o) * inp + j])).sum();
            assert!(close(z[(p * rows + i) * out + o], want), "forward ({p}, {i}, {o})");
        }
        // Weight gradient: gW[k][o][j] = sum_i G[k][i][o] A[k][i][j].
        let mut gw = vec![0f32; k * out * inp];
        cublas(&weight_gradient_product(k, rows, inp, out), &a, &g, &mut gw);
        for (p, o, j) in (0..k).flat_map(|p| (0..out).flat_map(move |o| (0..inp).map(move |j| (p, o, j)))) {
            let want: f64 = (0..rows)
                .map(|i| f64::from(g[(p * rows + i) * out + o]) * f64::from(a[(p * rows + i) * inp + j]))
                .sum();
            assert!(close(gw[(p * out + o) * inp + j], want), "weight gradient ({p}, {o}, {j})");
        }
        // Input gradient: gA[k][i][j] = sum_o G[k][i][o] W[k][o][j].
        let mut ga = vec![0f32; k * rows * inp];
        cublas(&input_gradient_product(k, rows, inp, out), &w, &g, &mut ga);
        for (p, i, j) in (0..k).flat_map(|p| (0..rows).flat_map(move |i| (0..inp).map(move |j| (p, i, j)))) {
            let want: f64 =
                (0..out).map(|o| f64::from(g[(p * rows + i) * out + o]) * f64::from(w[(p * out + o) * inp + j])).sum();
            assert!(close(ga[(p * rows + i) * inp + j], want), "input gradient ({p}, {i}, {j})");
        }
    }

    #[test]
    fn a_job_takes_the_memory_of_its_buffers() {
        // The paper's network: 18 -> 256 -> 256 -> 256 -> 14.
        let dims = [(18, 256), (256, 256), (256, 256), (256, 14)];
        let params = 18 * 256 + 256 + 2 * (256 * 256 + 256) + 256 * 14 + 14;
        let bytes = bytes_per_job(&dims, 1024, 2000);
        // At least the parameters and their six companions (gradients, two
        // moments, best), the minibatch's and validation's activations.
        assert!(bytes >= 4 * (7 * params + 2 * 1024 * 782 + 2000 * 782), "{bytes}");
        assert!(bytes < 32 << 20, "{bytes} bytes: 320 jobs fit in 10 GB");
    }
}
