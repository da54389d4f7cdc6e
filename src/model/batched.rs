//! The batched trainer's work on a device, whatever the device: K jobs
//! that share a shape (layer widths, minibatch size, fit and validation
//! window counts, learning rate and schedule) keep their parameters,
//! gradients, Adam moments and best parameters side by side, and every
//! minibatch step of all K is one strided-batched product per layer and
//! direction ([`Product`]) plus the elementwise kernels of
//! `cuda_kernels.cu`. What executes them is an [`Ops`]: the GPU
//! (`super::cuda`), or plain loops on the CPU (`super::emulated`), which
//! runs this same code where no GPU is, so that it is tested everywhere.
//! The host keeps each job's shuffle, action noise and early stopping
//! ([`super::lockstep`]), so a job sees the same minibatches as on the CPU.
//! A job that stops while others go on leaves the batch (its best
//! parameters to the host, the jobs after it moved down), so the work of
//! each step is that of the jobs still training.

use std::collections::BTreeMap;
use std::ops::Range;

use rayon::prelude::*;

use super::fused::FusedMlp;
use super::lockstep::{lockstep, validation_set, Backend, BackendError, BatchJob, Step};
use super::net::{EpochLog, Net};

/// A strided-batched product C = op(A) op(B) of `batch` pairs, in
/// cuBLAS's column-major terms (alpha 1, beta 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Product {
    pub transa: bool,
    pub transb: bool,
    pub m: usize,
    pub n: usize,
    pub k: usize,
    pub lda: usize,
    pub ldb: usize,
    pub ldc: usize,
    pub stride_a: usize,
    pub stride_b: usize,
    pub stride_c: usize,
    pub batch: usize,
}

/// Adam's scalars for one step.
#[derive(Debug, Clone, Copy)]
pub(super) struct AdamStep {
    pub lr: f32,
    pub b1: f32,
    pub b2: f32,
    pub eps: f32,
    /// 1 / (1 - b1^t), 1 / (1 - b2^t).
    pub c1: f32,
    pub c2: f32,
}

/// What executes the batch: buffers, copies, products and the kernels of
/// `cuda_kernels.cu` (each method that kernel, with its arguments).
pub(super) trait Ops {
    /// A buffer of f32.
    type Buf;
    /// A buffer of f64.
    type Buf64;
    fn zeros(&self, n: usize) -> Result<Self::Buf, BackendError>;
    fn zeros64(&self, n: usize) -> Result<Self::Buf64, BackendError>;
    fn upload(&self, host: &[f32]) -> Result<Self::Buf, BackendError>;
    /// `host` into the start of `dst`.
    fn write(&self, host: &[f32], dst: &mut Self::Buf) -> Result<(), BackendError>;
    fn read(&self, src: &Self::Buf) -> Result<Vec<f32>, BackendError>;
    fn read64(&self, src: &Self::Buf64) -> Result<Vec<f64>, BackendError>;
    /// `range.len()` values of `src` from `from` on into `dst[range]`.
    fn copy(&self, src: &Self::Buf, from: usize, dst: &mut Self::Buf, range: Range<usize>) -> Result<(), BackendError>;
    fn product(&self, p: &Product, a: &Self::Buf, b: &Self::Buf, c: &mut Self::Buf) -> Result<(), BackendError>;
    #[allow(clippy::too_many_arguments)]
    fn bias_act(
        &self,
        z: &mut Self::Buf,
        bias: &Self::Buf,
        k: usize,
        n: usize,
        w: usize,
        relu: bool,
    ) -> Result<(), BackendError>;
    fn mse_grad(
        &self,
        pred: &Self::Buf,
        y: &Self::Buf,
        grad: &mut Self::Buf,
        total: usize,
        inv_n: f32,
    ) -> Result<(), BackendError>;
    fn relu_back(&self, g: &mut Self::Buf, h: &Self::Buf, total: usize) -> Result<(), BackendError>;
    fn bias_grad(&self, g: &Self::Buf, gb: &mut Self::Buf, k: usize, n: usize, w: usize) -> Result<(), BackendError>;
    /// Each of `k` jobs' sum of squared errors over its `len` elements.
    #[allow(clippy::too_many_arguments)]
    fn sq_err(
        &self,
        pred: &Self::Buf,
        y: &Self::Buf,
        k: usize,
        len: usize,
        out32: &mut Self::Buf,
        out64: &mut Self::Buf64,
    ) -> Result<(), BackendError>;
    /// Adam on each of `total / per_job` jobs whose mask is 1.
    #[allow(clippy::too_many_arguments)]
    fn adam(
        &self,
        pgmv: (&mut Self::Buf, &Self::Buf, &mut Self::Buf, &mut Self::Buf),
        mask: &Self::Buf,
        per_job: usize,
        total: usize,
        step: AdamStep,
    ) -> Result<(), BackendError>;
    /// Bytes of device memory free for new buffers.
    fn free_memory(&self) -> Result<usize, BackendError>;
}

// The three products of a layer of `inp` inputs and `out` outputs over
// `rows` rows, for K jobs. The host's matrices are row-major, so cuBLAS
// (column-major) sees each as its transpose: a row-major n x w buffer is a
// column-major w x n matrix with leading dimension w.

/// Z = A W^T (rows x out), from A (rows x inp) and W (out x inp): as
/// cuBLAS sees it, Z^T = op_T(W^T) A^T. Operands (W, A).
pub(super) fn forward_product(k: usize, rows: usize, inp: usize, out: usize) -> Product {
    product(k, (out, rows, inp), (true, inp, out * inp), (false, inp, rows * inp), out)
}

/// gW = G^T A (out x inp), from A (rows x inp) and G (rows x out): as
/// cuBLAS sees it, gW^T = A^T op_T(G^T). Operands (A, G).
pub(super) fn weight_gradient_product(k: usize, rows: usize, inp: usize, out: usize) -> Product {
    product(k, (inp, out, rows), (false, inp, rows * inp), (true, out, rows * out), inp)
}

/// gA = G W (rows x inp), from G (rows x out) and W (out x inp): as cuBLAS
/// sees it, gA^T = W^T G^T. Operands (W, G).
pub(super) fn input_gradient_product(k: usize, rows: usize, inp: usize, out: usize) -> Product {
    product(k, (inp, rows, out), (false, inp, out * inp), (false, out, rows * out), inp)
}

/// (m, n, inner), each operand's (transposed, leading dimension, stride),
/// and C's leading dimension (its stride is ldc * n).
fn product(
    batch: usize,
    (m, n, k): (usize, usize, usize),
    (transa, lda, stride_a): (bool, usize, usize),
    (transb, ldb, stride_b): (bool, usize, usize),
    ldc: usize,
) -> Product {
    Product { transa, transb, m, n, k, lda, ldb, ldc, stride_a, stride_b, stride_c: ldc * n, batch }
}

/// One layer of K jobs: `[K][out][inp]` weights and their companions.
struct Layer<B> {
    inp: usize,
    out: usize,
    w: B,
    b: B,
    gw: B,
    gb: B,
    mw: B,
    vw: B,
    mb: B,
    vb: B,
    best_w: B,
    best_b: B,
    /// `[K][batch][out]`: the layer's output (after ReLU) of a minibatch.
    h: B,
    /// `[K][batch][out]`: the loss's gradient at the layer's pre-activation.
    gz: B,
    /// `[K][n_val][out]`: the layer's output on the validation windows.
    val_h: B,
}

/// Parameters on the host: each layer's weights and biases (of one job,
/// or of every job of a batch side by side).
type Parts = Vec<(Vec<f32>, Vec<f32>)>;

/// K jobs of one shape on a device. A job that stops while others go on
/// leaves it: its best parameters are copied to the host, and the jobs
/// after it move down, so that every product and kernel runs over the
/// jobs still training only.
struct Batch<'s, O: Ops> {
    o: &'s O,
    /// The jobs in the batch now.
    k: usize,
    /// Each job's place in the batch (`None` once it has left).
    slot_of: Vec<Option<usize>>,
    /// The best parameters (weights, biases of each layer) of each job
    /// that has left.
    left: Vec<Option<Parts>>,
    n_val: usize,
    layers: Vec<Layer<O::Buf>>,
    x: O::Buf,
    y: O::Buf,
    val_x: O::Buf,
    val_y: O::Buf,
    mask: O::Buf,
    sq32: O::Buf,
    sq64: O::Buf64,
    host_x: Vec<f32>,
    host_y: Vec<f32>,
    /// Adam's step counter, shared: every job in the batch steps together.
    t: i32,
}

/// Bytes of device memory one job of this shape takes.
pub(super) fn bytes_per_job(dims: &[(usize, usize)], batch: usize, n_val: usize) -> usize {
    let params: usize = dims.iter().map(|&(i, o)| i * o + o).sum();
    let widths: usize = dims.iter().map(|&(_, o)| o).sum();
    let (inputs, outputs) = (dims[0].0, dims[dims.len() - 1].1);
    4 * (10 * params + (batch + n_val) * (inputs + outputs) + (2 * batch + n_val) * widths) + 16
}

impl<'s, O: Ops> Batch<'s, O> {
    fn new(o: &'s O, jobs: &[BatchJob], inits: &[FusedMlp]) -> Result<Batch<'s, O>, BackendError> {
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
                w: o.upload(&w)?,
                b: o.upload(&b)?,
                best_w: o.upload(&w)?,
                best_b: o.upload(&b)?,
                gw: o.zeros(w.len())?,
                gb: o.zeros(b.len())?,
                mw: o.zeros(w.len())?,
                vw: o.zeros(w.len())?,
                mb: o.zeros(b.len())?,
                vb: o.zeros(b.len())?,
                h: o.zeros(k * batch * out)?,
                gz: o.zeros(k * batch * out)?,
                val_h: o.zeros(k * n_val * out)?,
            });
        }
        let sets: Vec<(Vec<f32>, Vec<f32>)> = jobs.iter().map(validation_set).collect();
        let val_x: Vec<f32> = sets.iter().flat_map(|(x, _)| x.iter().copied()).collect();
        let val_y: Vec<f32> = sets.iter().flat_map(|(_, y)| y.iter().copied()).collect();
        let (inputs, outputs) = (layers[0].inp, layers[layers.len() - 1].out);
        Ok(Batch {
            o,
            k,
            slot_of: (0..k).map(Some).collect(),
            left: vec![None; k],
            n_val,
            x: o.zeros(k * batch * inputs)?,
            y: o.zeros(k * batch * outputs)?,
            val_x: o.upload(&val_x)?,
            val_y: o.upload(&val_y)?,
            mask: o.zeros(k)?,
            sq32: o.zeros(k)?,
            sq64: o.zeros64(k)?,
            host_x: vec![0.0; k * batch * inputs],
            host_y: vec![0.0; k * batch * outputs],
            layers,
            t: 0,
        })
    }

    /// The forward pass of `rows` rows of every job: from `x` (or the
    /// validation inputs) through each layer's `h` (or `val_h`).
    fn forward(&mut self, rows: usize, validation: bool) -> Result<(), BackendError> {
        let (o, k) = (self.o, self.k);
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
            o.product(&forward_product(k, rows, inp, out), &layer.w, input, z)?;
            o.bias_act(z, &layer.b, k, rows, out, l < last)?;
        }
        Ok(())
    }

    /// Each job's sum of squared errors of the output against its targets
    /// over `len` elements per job, in f32 and f64.
    fn sq_err(&mut self, validation: bool, len: usize) -> Result<(Vec<f32>, Vec<f64>), BackendError> {
        let last = self.layers.len() - 1;
        let (pred, y) =
            if validation { (&self.layers[last].val_h, &self.val_y) } else { (&self.layers[last].h, &self.y) };
        self.o.sq_err(pred, y, self.k, len, &mut self.sq32, &mut self.sq64)?;
        Ok((self.o.read(&self.sq32)?, self.o.read64(&self.sq64)?))
    }

    /// Backpropagation of the loss's gradient at the output (in the last
    /// layer's `gz`) through every layer, and each layer's bias gradient.
    fn backward(&mut self, rows: usize) -> Result<(), BackendError> {
        let (o, k) = (self.o, self.k);
        for l in (0..self.layers.len()).rev() {
            let (below, here) = self.layers.split_at_mut(l);
            let layer = &mut here[0];
            let (inp, out) = (layer.inp, layer.out);
            o.bias_grad(&layer.gz, &mut layer.gb, k, rows, out)?;
            let input = if l == 0 { &self.x } else { &below[l - 1].h };
            o.product(&weight_gradient_product(k, rows, inp, out), input, &layer.gz, &mut layer.gw)?;
            if l == 0 {
                break;
            }
            let prev = &mut below[l - 1];
            o.product(&input_gradient_product(k, rows, inp, out), &layer.w, &layer.gz, &mut prev.gz)?;
            o.relu_back(&mut prev.gz, &prev.h, k * rows * inp)?;
        }
        Ok(())
    }

    /// dfdx's Adam step on every job of the mask.
    fn adam(&mut self, lr: f64) -> Result<(), BackendError> {
        self.t = self.t.checked_add(1).ok_or_else(|| BackendError("more than 2^31 Adam steps".into()))?;
        let (b1, b2) = (0.9f64 as f32, 0.999f64 as f32);
        let (eps, lr) = (1e-8f64 as f32, lr as f32);
        // As the fused trainer computes them.
        let (c1, c2) = ((1.0 - b1.powi(self.t)).recip(), (1.0 - b2.powi(self.t)).recip());
        let step = AdamStep { lr, b1, b2, eps, c1, c2 };
        let (o, k, mask) = (self.o, self.k, &self.mask);
        for layer in &mut self.layers {
            let per = layer.inp * layer.out;
            o.adam((&mut layer.w, &layer.gw, &mut layer.mw, &mut layer.vw), mask, per, k * per, step)?;
            let per = layer.out;
            o.adam((&mut layer.b, &layer.gb, &mut layer.mb, &mut layer.vb), mask, per, k * per, step)?;
        }
        Ok(())
    }

    /// Job `job`'s place in the batch.
    fn slot(&self, job: usize) -> Result<usize, BackendError> {
        self.slot_of.get(job).copied().flatten().ok_or_else(|| BackendError(format!("job {job} is not in the batch")))
    }

    /// Every layer's best weights and biases of every job in the batch.
    fn read_best(&self) -> Result<Parts, BackendError> {
        self.layers.iter().map(|l| Ok((self.o.read(&l.best_w)?, self.o.read(&l.best_b)?))).collect()
    }

    /// The part of `best` ([`Batch::read_best`]) of the job in slot `s`.
    fn parts_of(&self, best: &[(Vec<f32>, Vec<f32>)], s: usize) -> Parts {
        self.layers
            .iter()
            .zip(best)
            .map(|(l, (w, b))| {
                let (nw, nb) = (l.inp * l.out, l.out);
                (w[s * nw..(s + 1) * nw].to_vec(), b[s * nb..(s + 1) * nb].to_vec())
            })
            .collect()
    }

    /// Each job's best parameters, as networks of `jobs`' shape.
    fn best(&self, jobs: &[BatchJob]) -> Result<Vec<Net>, BackendError> {
        let best = self.read_best()?;
        jobs.iter()
            .enumerate()
            .map(|(j, job)| {
                let parts = match &self.left[j] {
                    Some(parts) => parts.clone(),
                    None => self.parts_of(&best, self.slot(j)?),
                };
                Ok(Net::from_mlp(FusedMlp::from_parts(&job.features.slots, job.widths, &parts)))
            })
            .collect()
    }
}

/// `buf`, which holds `per` values of each job, holding only those of the
/// jobs in slots `from` (in order), moved down to slots 0, 1, ...: one
/// copy for each run of consecutive slots.
fn compact<O: Ops>(o: &O, buf: &mut O::Buf, per: usize, from: &[usize]) -> Result<(), BackendError> {
    let mut moved = o.zeros(from.len() * per)?;
    let mut i = 0;
    while i < from.len() {
        let run = (i + 1..from.len()).find(|&e| from[e] != from[i] + (e - i)).unwrap_or(from.len()) - i;
        o.copy(buf, from[i] * per, &mut moved, i * per..(i + run) * per)?;
        i += run;
    }
    *buf = moved;
    Ok(())
}

impl<O: Ops> Backend for Batch<'_, O> {
    fn steps(&mut self, steps: &[Step<'_>]) -> Result<Vec<f32>, BackendError> {
        let rows = steps[0].n;
        if steps.iter().any(|s| s.n != rows || s.lr != steps[0].lr) {
            return Err(BackendError("the jobs of one GPU batch took minibatches of different sizes or rates".into()));
        }
        let (inputs, outputs) = (self.layers[0].inp, self.layers[self.layers.len() - 1].out);
        // Each job's minibatch into its place, in parallel (tens of MB a
        // step for hundreds of jobs); a job without a step is masked out
        // (every job in the batch steps: one that stopped has left it).
        let slots: Vec<usize> = steps.iter().map(|st| self.slot(st.job)).collect::<Result<_, _>>()?;
        let mut of_job: Vec<Option<&Step>> = vec![None; self.k];
        for (st, &s) in steps.iter().zip(&slots) {
            of_job[s] = Some(st);
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
        let o = self.o;
        o.write(&self.host_x[..self.k * rows * inputs], &mut self.x)?;
        o.write(&self.host_y[..self.k * rows * outputs], &mut self.y)?;
        o.write(&mask, &mut self.mask)?;
        self.forward(rows, false)?;
        let last = self.layers.len() - 1;
        let inv_n = (1.0 / (rows * outputs) as f64) as f32;
        let (sums, _) = self.sq_err(false, rows * outputs)?;
        let layer = &mut self.layers[last];
        o.mse_grad(&layer.h, &self.y, &mut layer.gz, self.k * rows * outputs, inv_n)?;
        self.backward(rows)?;
        self.adam(steps[0].lr)?;
        Ok(slots.iter().map(|&s| (sums[s] * 1.0) * inv_n).collect())
    }

    fn val_losses(&mut self, jobs: &[usize]) -> Result<Vec<f64>, BackendError> {
        self.forward(self.n_val, true)?;
        let len = self.n_val * self.layers[self.layers.len() - 1].out;
        let (_, sums) = self.sq_err(true, len)?;
        jobs.iter().map(|&j| Ok(sums[self.slot(j)?] / len as f64)).collect()
    }

    fn keep_best(&mut self, job: usize) -> Result<(), BackendError> {
        let s = self.slot(job)?;
        for l in &mut self.layers {
            let (nw, nb) = (l.inp * l.out, l.out);
            self.o.copy(&l.w, s * nw, &mut l.best_w, s * nw..(s + 1) * nw)?;
            self.o.copy(&l.b, s * nb, &mut l.best_b, s * nb..(s + 1) * nb)?;
        }
        Ok(())
    }

    fn leave(&mut self, jobs: &[usize]) -> Result<(), BackendError> {
        let best = self.read_best()?;
        for &j in jobs {
            self.left[j] = Some(self.parts_of(&best, self.slot(j)?));
            self.slot_of[j] = None;
        }
        // The jobs that go on, in the order of their slots, moved down.
        let mut kept: Vec<(usize, usize)> =
            self.slot_of.iter().enumerate().filter_map(|(j, s)| s.map(|s| (s, j))).collect();
        kept.sort_unstable();
        let from: Vec<usize> = kept.iter().map(|&(s, _)| s).collect();
        for (now, &(_, j)) in kept.iter().enumerate() {
            self.slot_of[j] = Some(now);
        }
        // What a job carries from step to step: its parameters, Adam's
        // moments, its best parameters and its validation set (the rest is
        // written afresh by each step, over the first jobs of each buffer).
        let o = self.o;
        for l in &mut self.layers {
            let (nw, nb) = (l.inp * l.out, l.out);
            for buf in [&mut l.w, &mut l.mw, &mut l.vw, &mut l.best_w] {
                compact(o, buf, nw, &from)?;
            }
            for buf in [&mut l.b, &mut l.mb, &mut l.vb, &mut l.best_b] {
                compact(o, buf, nb, &from)?;
            }
        }
        let (inputs, outputs) = (self.layers[0].inp, self.layers[self.layers.len() - 1].out);
        compact(o, &mut self.val_x, self.n_val * inputs, &from)?;
        compact(o, &mut self.val_y, self.n_val * outputs, &from)?;
        self.k = from.len();
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

/// Trains `jobs` on `o`: jobs of one shape in batches sized from its free
/// memory, each batch in lockstep. Each job's network and epoch logs.
pub(super) fn train_on<O: Ops>(
    o: &O,
    jobs: &[BatchJob],
    on_epoch: &(dyn Fn(usize, &EpochLog) + Sync),
) -> Result<Vec<(Net, Vec<EpochLog>)>, BackendError> {
    let mut groups: BTreeMap<_, Vec<usize>> = BTreeMap::new();
    for (i, job) in jobs.iter().enumerate() {
        groups.entry(shape(job)).or_default().push(i);
    }
    let mut out: Vec<Option<(Net, Vec<EpochLog>)>> = jobs.iter().map(|_| None).collect();
    for members in groups.values() {
        let first = &jobs[members[0]];
        let dims = FusedMlp::dims(&first.features.slots, first.widths);
        let per = bytes_per_job(&dims, first.training.batch, first.validation.len());
        let fits = (o.free_memory()? / 10 * 8 / per).max(1);
        for chunk in members.chunks(fits) {
            let batch: Vec<BatchJob> = chunk.iter().map(|&i| jobs[i]).collect();
            let inits: Vec<FusedMlp> =
                batch.iter().map(|j| Net::init(&j.features.slots, j.widths, j.seed).fused()).collect();
            let mut b = Batch::new(o, &batch, &inits)?;
            let logs = lockstep(&mut b, &batch, &mut |k, log| on_epoch(chunk[k], log))?;
            for ((&i, net), logs) in chunk.iter().zip(b.best(&batch)?).zip(logs) {
                out[i] = Some((net, logs));
            }
        }
    }
    out.into_iter().map(|r| r.ok_or_else(|| BackendError("a job was not trained".into()))).collect()
}

#[cfg(test)]
mod tests;
