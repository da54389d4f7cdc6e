//! The fused f32 trainer: the design's MLP (inputs -> W -> W -> W -> state,
//! ReLU; 18 -> W -> W -> W -> 14 for NanoBench)
//! trained with MSE and Adam on preallocated buffers, with no per-step
//! allocation and no autodiff tape.
//!
//! It is bit-identical to the dfdx reference trainer in [`super::net`]
//! because it performs the same floating-point operations in the same
//! order: every matrix product goes to `gemm` with the arguments dfdx 0.13
//! passes (see `super::kernel`); the bias add, ReLU and its derivative,
//! the loss and its gradient, the bias gradient (a sum over rows in row
//! order) and Adam are written as dfdx's CPU kernels compute them,
//! including dfdx's accumulation of each gradient into a zeroed buffer
//! (`0.0 + g`, which turns a negative zero into a positive one). The
//! initial weights come from dfdx ([`super::net`] builds the module and
//! hands its tensors over).

use super::features::Slots;
use super::kernel::{gemm, Strided};

/// One dense layer: `out x inp` weights, row-major as dfdx stores them.
#[derive(Debug, Clone, PartialEq)]
pub struct Dense {
    /// Input width.
    pub inp: usize,
    /// Output width.
    pub out: usize,
    /// `out x inp`, row-major.
    pub weight: Vec<f32>,
    /// `out`.
    pub bias: Vec<f32>,
}

/// The MLP's parameters: hidden ReLU layers and a linear output.
#[derive(Debug, Clone, PartialEq)]
pub struct FusedMlp {
    /// Input to output.
    pub layers: Vec<Dense>,
}

/// Activations of one batch, preallocated for `capacity` rows.
#[derive(Debug, Clone)]
pub struct Activations {
    capacity: usize,
    /// ReLU output of every hidden layer (n x width).
    h: Vec<Vec<f32>>,
    /// Output of the last layer (n x outputs).
    out: Vec<f32>,
}

impl Activations {
    /// Buffers for batches of up to `capacity` rows of `net`.
    pub fn new(net: &FusedMlp, capacity: usize) -> Self {
        let (last, hidden) = net.layers.split_last().expect("the network has layers");
        let h = hidden.iter().map(|l| vec![0.0; capacity * l.out]).collect();
        Activations { capacity, h, out: vec![0.0; capacity * last.out] }
    }
}

/// Runs `f` with the widest vector instructions this CPU has enabled for
/// the code inlined into it (AVX-512 where present): the elementwise passes
/// vectorize without changing a result, since every element still gets the
/// same operations in the same order and Rust never contracts `a * b + c`
/// into a fused multiply-add.
#[inline(always)]
fn vectorized<R>(f: impl FnOnce() -> R) -> R {
    pulp::Arch::new().dispatch(f)
}

impl FusedMlp {
    /// Each layer's (inputs, outputs) of an `inputs -> W1 -> ... -> Wk ->
    /// state` network of `slots` with hidden `widths`.
    pub fn dims(slots: &Slots, widths: &[usize]) -> Vec<(usize, usize)> {
        let sizes: Vec<usize> =
            [slots.input()].into_iter().chain(widths.iter().copied()).chain([slots.state]).collect();
        sizes.windows(2).map(|p| (p[0], p[1])).collect()
    }

    /// The network of `slots` with hidden `widths` from its parameters in
    /// dfdx's order (weight, bias per layer).
    pub fn from_parts(slots: &Slots, widths: &[usize], parts: &[(Vec<f32>, Vec<f32>)]) -> FusedMlp {
        let dims = Self::dims(slots, widths);
        assert_eq!(dims.len(), parts.len(), "one (weight, bias) per layer");
        let layers = dims
            .iter()
            .zip(parts)
            .map(|(&(inp, out), (w, b))| {
                assert_eq!((w.len(), b.len()), (inp * out, out), "layer shape");
                Dense { inp, out, weight: w.clone(), bias: b.clone() }
            })
            .collect();
        FusedMlp { layers }
    }

    /// Input width (18 for NanoBench).
    pub fn inputs(&self) -> usize {
        self.layers[0].inp
    }

    /// Output width (14 for NanoBench).
    pub fn outputs(&self) -> usize {
        self.layers[self.layers.len() - 1].out
    }

    /// Forward pass of `n` rows of `x` (n x inputs) into `act`; returns the
    /// output (n x outputs).
    ///
    /// dfdx computes `z = x * W^T` into a fresh tensor, `z + b`, then
    /// `max(z, 0)` in separate passes; here the product goes straight into
    /// the layer's output buffer and bias and ReLU are one pass over it,
    /// with the same two operations per element.
    pub fn forward<'a>(&self, x: &[f32], n: usize, act: &'a mut Activations) -> &'a [f32] {
        assert!(n <= act.capacity, "batch of {n} rows for buffers of {}", act.capacity);
        let last = self.layers.len() - 1;
        for (l, layer) in self.layers.iter().enumerate() {
            let (inp, out) = (layer.inp, layer.out);
            let (below, rest) = act.h.split_at_mut(l.min(last));
            let a: &[f32] = if l == 0 { &x[..n * inp] } else { &below[l - 1][..n * inp] };
            let z = if l == last { &mut act.out[..n * out] } else { &mut rest[0][..n * out] };
            // dfdx: x.matmul(weight.permute()), into a fresh zeroed tensor.
            gemm(
                (n, out, inp),
                z,
                (out, 1),
                false,
                Strided { data: a, rs: inp, cs: 1 },
                Strided { data: &layer.weight, rs: 1, cs: inp },
                0.0,
                1.0,
            );
            let relu = l < last;
            vectorized(|| {
                for row in z.chunks_exact_mut(out) {
                    for (v, b) in row.iter_mut().zip(&layer.bias) {
                        let zb = *v + *b;
                        *v = if relu { zb.max(0.0) } else { zb };
                    }
                }
            });
        }
        &act.out[..n * self.outputs()]
    }

    /// Predictions for `x` (n x inputs), all rows in one pass (as dfdx's
    /// forward on the whole batch).
    pub fn predict(&self, x: &[f32]) -> Vec<f32> {
        let n = x.len() / self.inputs();
        let mut act = Activations::new(self, n.max(1));
        self.forward(x, n, &mut act).to_vec()
    }
}

/// Adam's state for one parameter tensor.
#[derive(Debug, Clone)]
struct Moments {
    m: Vec<f32>,
    v: Vec<f32>,
}

/// Gradients and Adam moments of one layer.
#[derive(Debug, Clone)]
struct LayerState {
    grad_w: Vec<f32>,
    grad_b: Vec<f32>,
    adam_w: Moments,
    adam_b: Moments,
}

/// Trains a [`FusedMlp`] one minibatch at a time.
#[derive(Debug, Clone)]
pub struct Trainer {
    /// The parameters being trained.
    pub net: FusedMlp,
    state: Vec<LayerState>,
    act: Activations,
    /// Gradient of the loss with respect to each layer's pre-activation.
    grad_z: Vec<Vec<f32>>,
    /// Adam's step counter (dfdx's `t`, starting at 1 on the first update).
    t: i32,
}

impl Trainer {
    /// A trainer for minibatches of at most `batch` rows.
    pub fn new(net: FusedMlp, batch: usize) -> Trainer {
        let zeros = |n: usize| vec![0.0f32; n];
        let state = net
            .layers
            .iter()
            .map(|l| LayerState {
                grad_w: zeros(l.weight.len()),
                grad_b: zeros(l.out),
                adam_w: Moments { m: zeros(l.weight.len()), v: zeros(l.weight.len()) },
                adam_b: Moments { m: zeros(l.out), v: zeros(l.out) },
            })
            .collect();
        let act = Activations::new(&net, batch.max(1));
        let grad_z = net.layers.iter().map(|l| zeros(batch.max(1) * l.out)).collect();
        Trainer { net, state, act, grad_z, t: 0 }
    }

    /// One Adam step on `n` rows (x: n x inputs, y: n x outputs) at learning rate
    /// `lr`; returns the batch's mean squared error before the step.
    pub fn step(&mut self, x: &[f32], y: &[f32], n: usize, lr: f64) -> f32 {
        assert!(n > 0 && n <= self.act.capacity, "batch of {n} rows for a trainer of {}", self.act.capacity);
        let len = self.net.forward(x, n, &mut self.act).len();
        let loss = self.loss_and_gradient(len, y, n);
        self.backward(x, n);
        self.adam(lr);
        loss
    }

    /// dfdx's `(pred - targ).square().mean()`: the forward sum runs over
    /// the elements in order; the gradient of each prediction is
    /// `0 + (d + d) * (1 / N)`. The output layer's bias gradient (the sum
    /// of that gradient over rows, in row order) is taken in the same pass.
    fn loss_and_gradient(&mut self, len: usize, y: &[f32], n: usize) -> f32 {
        let last = self.net.layers.len() - 1;
        let pred = &self.act.out[..len];
        let width = self.net.outputs();
        let inv_n = (1.0 / (n * width) as f64) as f32;
        let grad = &mut self.grad_z[last][..len];
        let grad_b = &mut self.state[last].grad_b;
        grad_b.fill(0.0);
        let mut sum = 0.0f32;
        for ((g, p), t) in grad.chunks_exact_mut(width).zip(pred.chunks_exact(width)).zip(y[..len].chunks_exact(width))
        {
            for (((g, p), t), gb) in g.iter_mut().zip(p).zip(t).zip(grad_b.iter_mut()) {
                let d = p - t;
                sum += d.powi(2);
                *g = 0.0 + (d + d) * inv_n;
                *gb += *g;
            }
        }
        (sum * 1.0) * inv_n
    }

    /// Backpropagation through the layers, last to first. Each layer's
    /// bias gradient is ready when its turn comes: the output layer's from
    /// the loss, the hidden layers' from the ReLU pass that produced their
    /// pre-activation gradient.
    fn backward(&mut self, x: &[f32], n: usize) {
        for l in (0..self.net.layers.len()).rev() {
            let layer = &self.net.layers[l];
            let (inp, out) = (layer.inp, layer.out);
            let (below, here) = self.grad_z.split_at_mut(l);
            let g = &here[0][..n * out];
            // Weights: lhs^T * grad_out into the zeroed (out x inp) gradient,
            // addressed through the permuted view as dfdx does.
            let a: &[f32] = if l == 0 { &x[..n * inp] } else { &self.act.h[l - 1][..n * inp] };
            let grad_w = &mut self.state[l].grad_w;
            grad_w.fill(0.0);
            gemm(
                (inp, out, n),
                grad_w,
                (1, inp),
                true,
                Strided { data: a, rs: 1, cs: inp },
                Strided { data: g, rs: out, cs: 1 },
                1.0,
                1.0,
            );
            if l == 0 {
                break; // the input needs no gradient
            }
            // Input of this layer: grad_out * weight. dfdx accumulates it into
            // a zeroed tensor (0 + p); here it is written directly (p). The
            // two differ only in the sign of a zero, which the ReLU pass
            // below erases (0 + df * p is +0 for either sign).
            let gz = &mut below[l - 1][..n * inp];
            gemm(
                (n, inp, out),
                gz,
                (inp, 1),
                false,
                Strided { data: g, rs: out, cs: 1 },
                Strided { data: &layer.weight, rs: inp, cs: 1 },
                1.0,
                1.0,
            );
            // Through the ReLU below (df = 1 where its input z > 0, i.e. where
            // its output max(z, 0) > 0), and that layer's bias gradient, the
            // rows summed in order.
            let h = &self.act.h[l - 1][..n * inp];
            let grad_b = &mut self.state[l - 1].grad_b;
            grad_b.fill(0.0);
            vectorized(|| {
                for (gz, h) in gz.chunks_exact_mut(inp).zip(h.chunks_exact(inp)) {
                    for ((gz, hv), gb) in gz.iter_mut().zip(h).zip(grad_b.iter_mut()) {
                        let df = if *hv > 0.0 { 1.0f32 } else { 0.0 };
                        *gz = 0.0 + df * *gz;
                        *gb += *gz;
                    }
                }
            });
        }
    }

    /// dfdx's Adam kernel (f32, default betas and epsilon, no weight decay).
    fn adam(&mut self, lr: f64) {
        self.t = self.t.checked_add(1).expect("fewer than 2^31 Adam steps");
        let t = self.t;
        let (b1, b2) = (0.9f64 as f32, 0.999f64 as f32);
        let (eps, lr) = (1e-8f64 as f32, lr as f32);
        // The same value for every element; dfdx computes it per element.
        let (c1, c2) = ((1.0 - b1.powi(t)).recip(), (1.0 - b2.powi(t)).recip());
        let step = |p: &mut [f32], grad: &[f32], mo: &mut Moments| {
            vectorized(|| {
                for (((p, &g), m), v) in p.iter_mut().zip(grad).zip(mo.m.iter_mut()).zip(mo.v.iter_mut()) {
                    *m = *m * b1 + g * (1.0 - b1);
                    *v = *v * b2 + g.powi(2) * (1.0 - b2);
                    let m_hat = *m * c1;
                    let v_hat = *v * c2;
                    let g = lr * m_hat / (v_hat.sqrt() + eps);
                    *p -= g;
                }
            })
        };
        for (layer, st) in self.net.layers.iter_mut().zip(self.state.iter_mut()) {
            step(&mut layer.weight, &st.grad_w, &mut st.adam_w);
            step(&mut layer.bias, &st.grad_b, &mut st.adam_b);
        }
    }
}
