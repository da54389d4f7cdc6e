//! The CUDA backend of the batched trainer: the [`Ops`] of
//! [`super::batched`] on an NVIDIA GPU. Each product is a strided-batched
//! cuBLAS SGEMM, each kernel one of `cuda_kernels.cu` (NVRTC, no fused
//! multiply-add contraction). What the batch does with them is
//! `super::batched`'s, which `super::emulated` runs on the CPU in tests.
//!
//! Reproducible on one GPU: cuBLAS's single-precision products give the
//! same bits run to run on the same GPU and library, and no reduction uses
//! atomics. Against the CPU trainer the products are summed in another
//! order, so the weights differ in their last bits, and the curves by a
//! stated floating-point tolerance (`scripts/gpu-check.sh`).
//!
//! Rollouts still run on the CPU, from the weights trained here.
#![allow(unsafe_code)]

use std::ops::Range;
use std::sync::Arc;

use cudarc::cublas::sys::cublasOperation_t::{CUBLAS_OP_N, CUBLAS_OP_T};
use cudarc::cublas::{CudaBlas, Gemm, GemmConfig, StridedBatchedConfig};
use cudarc::driver::{CudaContext, CudaFunction, CudaSlice, CudaStream, LaunchConfig, PushKernelArg};
use cudarc::nvrtc::{compile_ptx_with_opts, CompileOptions, Ptx};

use super::batched::{train_on, AdamStep, Ops, Product};
use super::device::Gpu;
use super::lockstep::{BackendError, BatchJob};
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

    /// A kernel launch: `args` pushed in order, then launched on `cfg`.
    fn launch<'a>(
        &'a self,
        f: &'a CudaFunction,
        name: &str,
        cfg: LaunchConfig,
        args: impl FnOnce(&mut cudarc::driver::LaunchArgs<'a>),
    ) -> Result<(), BackendError> {
        let mut launch = self.stream.launch_builder(f);
        args(&mut launch);
        // SAFETY: every caller pushes the kernel's arguments in the order
        // and with the types of its signature in cuda_kernels.cu, on
        // buffers allocated for the elements the kernel touches.
        unsafe { launch.launch(cfg) }.map(|_| ()).map_err(|e| fail(name)(&e))
    }
}

/// A launch of one thread per element of `total`, in blocks of THREADS.
fn per_element(total: usize) -> LaunchConfig {
    let blocks = total.div_ceil(THREADS as usize).max(1) as u32;
    LaunchConfig { grid_dim: (blocks, 1, 1), block_dim: (THREADS, 1, 1), shared_mem_bytes: 0 }
}

/// A grid-stride launch over `total` elements.
fn elementwise(total: usize) -> LaunchConfig {
    let blocks = total.div_ceil(THREADS as usize).clamp(1, 65_535) as u32;
    LaunchConfig { grid_dim: (blocks, 1, 1), block_dim: (THREADS, 1, 1), shared_mem_bytes: 0 }
}

impl Ops for Session {
    type Buf = CudaSlice<f32>;
    type Buf64 = CudaSlice<f64>;

    fn zeros(&self, n: usize) -> Result<CudaSlice<f32>, BackendError> {
        self.stream.alloc_zeros::<f32>(n.max(1)).map_err(|e| fail("allocating GPU memory")(&e))
    }
    fn zeros64(&self, n: usize) -> Result<CudaSlice<f64>, BackendError> {
        self.stream.alloc_zeros::<f64>(n.max(1)).map_err(|e| fail("allocating GPU memory")(&e))
    }
    fn upload(&self, host: &[f32]) -> Result<CudaSlice<f32>, BackendError> {
        self.stream.clone_htod(host).map_err(|e| fail("copying to the GPU")(&e))
    }
    fn write(&self, host: &[f32], dst: &mut CudaSlice<f32>) -> Result<(), BackendError> {
        self.stream.memcpy_htod(host, dst).map_err(|e| fail("copying to the GPU")(&e))
    }
    fn read(&self, src: &CudaSlice<f32>) -> Result<Vec<f32>, BackendError> {
        self.stream.clone_dtoh(src).map_err(|e| fail("copying from the GPU")(&e))
    }
    fn read64(&self, src: &CudaSlice<f64>) -> Result<Vec<f64>, BackendError> {
        self.stream.clone_dtoh(src).map_err(|e| fail("copying from the GPU")(&e))
    }
    fn copy(
        &self,
        src: &CudaSlice<f32>,
        from: usize,
        dst: &mut CudaSlice<f32>,
        range: Range<usize>,
    ) -> Result<(), BackendError> {
        let from = src.slice(from..from + range.len());
        self.stream.memcpy_dtod(&from, &mut dst.slice_mut(range)).map_err(|e| fail("copying on the GPU")(&e))
    }

    fn product(
        &self,
        p: &Product,
        a: &CudaSlice<f32>,
        b: &CudaSlice<f32>,
        c: &mut CudaSlice<f32>,
    ) -> Result<(), BackendError> {
        let op = |t: bool| if t { CUBLAS_OP_T } else { CUBLAS_OP_N };
        let cfg = StridedBatchedConfig {
            gemm: GemmConfig {
                transa: op(p.transa),
                transb: op(p.transb),
                m: p.m as i32,
                n: p.n as i32,
                k: p.k as i32,
                alpha: 1.0,
                lda: p.lda as i32,
                ldb: p.ldb as i32,
                beta: 0.0,
                ldc: p.ldc as i32,
            },
            batch_size: p.batch as i32,
            stride_a: p.stride_a as i64,
            stride_b: p.stride_b as i64,
            stride_c: p.stride_c as i64,
        };
        // SAFETY: every buffer holds `batch` matrices of the shapes, leading
        // dimensions and strides given (super::batched allocates them so).
        unsafe { self.blas.gemm_strided_batched(cfg, a, b, c) }.map_err(|e| fail("cuBLAS SGEMM")(&e))
    }

    fn bias_act(
        &self,
        z: &mut CudaSlice<f32>,
        bias: &CudaSlice<f32>,
        k: usize,
        n: usize,
        w: usize,
        relu: bool,
    ) -> Result<(), BackendError> {
        let (kk, nn, ww, r) = (k as i64, n as i64, w as i64, i32::from(relu));
        self.launch(&self.bias_act, "bias_act", elementwise(k * n * w), |l| {
            l.arg(z).arg(bias).arg(&kk).arg(&nn).arg(&ww).arg(&r);
        })
    }

    fn mse_grad(
        &self,
        pred: &CudaSlice<f32>,
        y: &CudaSlice<f32>,
        grad: &mut CudaSlice<f32>,
        total: usize,
        inv_n: f32,
    ) -> Result<(), BackendError> {
        let t = total as i64;
        self.launch(&self.mse_grad, "mse_grad", elementwise(total), |l| {
            l.arg(pred).arg(y).arg(grad).arg(&t).arg(&inv_n);
        })
    }

    fn relu_back(&self, g: &mut CudaSlice<f32>, h: &CudaSlice<f32>, total: usize) -> Result<(), BackendError> {
        let t = total as i64;
        self.launch(&self.relu_back, "relu_back", elementwise(total), |l| {
            l.arg(g).arg(h).arg(&t);
        })
    }

    fn bias_grad(
        &self,
        g: &CudaSlice<f32>,
        gb: &mut CudaSlice<f32>,
        k: usize,
        n: usize,
        w: usize,
    ) -> Result<(), BackendError> {
        let (kk, nn, ww) = (k as i64, n as i64, w as i64);
        self.launch(&self.bias_grad, "bias_grad", per_element(k * w), |l| {
            l.arg(g).arg(gb).arg(&kk).arg(&nn).arg(&ww);
        })
    }

    fn sq_err(
        &self,
        pred: &CudaSlice<f32>,
        y: &CudaSlice<f32>,
        k: usize,
        len: usize,
        out32: &mut CudaSlice<f32>,
        out64: &mut CudaSlice<f64>,
    ) -> Result<(), BackendError> {
        let n = len as i64;
        // One block of THREADS (the kernel's shared array's size) per job.
        let cfg = LaunchConfig { grid_dim: (k as u32, 1, 1), block_dim: (THREADS, 1, 1), shared_mem_bytes: 0 };
        self.launch(&self.sq_err, "sq_err", cfg, |l| {
            l.arg(pred).arg(y).arg(&n).arg(out32).arg(out64);
        })
    }

    fn adam(
        &self,
        (p, g, m, v): (&mut CudaSlice<f32>, &CudaSlice<f32>, &mut CudaSlice<f32>, &mut CudaSlice<f32>),
        mask: &CudaSlice<f32>,
        per_job: usize,
        total: usize,
        s: AdamStep,
    ) -> Result<(), BackendError> {
        let (per, t) = (per_job as i64, total as i64);
        self.launch(&self.adam, "adam", elementwise(total), |l| {
            l.arg(p).arg(g).arg(m).arg(v).arg(mask).arg(&per).arg(&t);
            l.arg(&s.lr).arg(&s.b1).arg(&s.b2).arg(&s.eps).arg(&s.c1).arg(&s.c2);
        })
    }

    fn free_memory(&self) -> Result<usize, BackendError> {
        self.ctx.mem_get_info().map(|(free, _)| free).map_err(|e| fail("asking the GPU's free memory")(&e))
    }
}

/// Trains `jobs` on `gpu`: jobs of one shape in batches sized from the
/// GPU's free memory, each batch in lockstep ([`super::batched`]).
pub(super) fn train_batch(
    gpu: &Gpu,
    jobs: &[BatchJob],
    on_epoch: &(dyn Fn(usize, &EpochLog) + Sync),
) -> Result<Vec<(Net, Vec<EpochLog>)>, NetError> {
    let s = Session::open(gpu)?;
    Ok(train_on(&s, jobs, on_epoch)?)
}
