//! Every network of a study trained at once: the batched trainer. On the
//! CPU each job trains with today's fused trainer, in parallel, and its
//! weights and curves are bit-identical to [`super::train`]'s; on a GPU
//! (`super::cuda`, feature `cuda`) the jobs that share a shape step
//! together as batched matrix products, within a stated floating-point
//! tolerance of the CPU's.

use rayon::prelude::*;

use super::device::Device;
use super::lockstep::BatchJob;
use super::net::{train, EpochLog, Net, NetError};

/// Trains every job of `jobs` on `device`; `on_epoch` sees each job's every
/// epoch (the job's index in `jobs`, its log), from any thread. Each job's
/// network and epoch logs, in the order of `jobs`.
pub fn train_batch(
    device: &Device,
    jobs: &[BatchJob],
    on_epoch: &(dyn Fn(usize, &EpochLog) + Sync),
) -> Result<Vec<(Net, Vec<EpochLog>)>, NetError> {
    match device {
        Device::Cpu => jobs
            .par_iter()
            .enumerate()
            .map(|(k, j)| train(j.widths, j.features, j.fit, j.validation, j.training, j.seed, &mut |l| on_epoch(k, l)))
            .collect(),
        #[cfg(feature = "cuda")]
        Device::Cuda(gpu) => super::cuda::train_batch(gpu, jobs, on_epoch),
        #[cfg(not(feature = "cuda"))]
        Device::Cuda(_) => {
            Err(NetError::Device(super::lockstep::BackendError(super::device::DeviceError::NotBuilt.to_string())))
        }
    }
}

/// The CUDA trainer's kernels compiled by NVRTC, as PTX text: a check that
/// needs the NVRTC library but no GPU. An error where NVRTC is absent.
#[cfg(feature = "cuda")]
pub fn compile_gpu_kernels() -> Result<String, super::lockstep::BackendError> {
    super::cuda::compile_kernels().map(|p| p.to_src())
}

/// The GPU backend's own code (`super::batched`: buffers, products and
/// kernels, batches sized from free memory, jobs stepped in lockstep) run
/// by plain loops on the CPU, as if on a GPU with `free_bytes` of memory:
/// cuBLAS's products as its documentation defines them and each kernel of
/// `cuda_kernels.cu` element by element. A reference for the CUDA backend
/// where no GPU is (tests), far slower than [`train_batch`] on the CPU.
pub fn train_emulated(
    jobs: &[BatchJob],
    free_bytes: usize,
    on_epoch: &(dyn Fn(usize, &EpochLog) + Sync),
) -> Result<Vec<(Net, Vec<EpochLog>)>, NetError> {
    Ok(super::batched::train_on(&super::emulated::Emulated::new(free_bytes), jobs, on_epoch)?)
}
