//! dfdx's own networks and trainer, kept as the reference that the fused
//! trainer is checked against. Layer widths are types in dfdx 0.13, so the
//! reference exists for a fixed list of architectures on NanoBench's layout
//! (18 inputs, 14 outputs), [`REFERENCE_WIDTHS`]; the fused trainer takes
//! any widths and any layout.

use dfdx::optim::{Adam, AdamConfig};
use dfdx::prelude::*;

use super::features::{INPUT, STATE};
use super::fused::FusedMlp;
use super::minibatch::{mse_of, Minibatches};

/// Each layer's (weight, bias), weight row-major (out x in) as dfdx stores it.
pub(super) type Parts = Vec<(Vec<f32>, Vec<f32>)>;

/// The hidden widths dfdx has a network type for here.
pub const REFERENCE_WIDTHS: [&[usize]; 5] =
    [&[32, 32, 32], &[64, 64, 64], &[256, 256, 256], &[64, 64], &[256, 128, 64]];

type Two<const A: usize, const B: usize> = ((Linear<INPUT, A>, ReLU), (Linear<A, B>, ReLU), Linear<B, STATE>);
type Three<const A: usize, const B: usize, const C: usize> =
    ((Linear<INPUT, A>, ReLU), (Linear<A, B>, ReLU), (Linear<B, C>, ReLU), Linear<C, STATE>);

/// A network type dfdx builds, with its parameters in and out.
pub(super) trait Arch: BuildOnDevice<Cpu, f32> {
    /// The module's parameters in dfdx's order.
    fn parts(m: &Self::Built) -> Parts;
    /// Copies the fused network's parameters into the module.
    fn set(m: &mut Self::Built, f: &FusedMlp);
}

macro_rules! two {
    ($a:literal, $b:literal) => {
        impl Arch for Two<$a, $b> {
            fn parts(m: &Self::Built) -> Parts {
                let ((a, _), (b, _), c) = m;
                vec![
                    (a.weight.as_vec(), a.bias.as_vec()),
                    (b.weight.as_vec(), b.bias.as_vec()),
                    (c.weight.as_vec(), c.bias.as_vec()),
                ]
            }
            fn set(m: &mut Self::Built, f: &FusedMlp) {
                let ((a, _), (b, _), c) = m;
                a.weight.copy_from(&f.layers[0].weight);
                a.bias.copy_from(&f.layers[0].bias);
                b.weight.copy_from(&f.layers[1].weight);
                b.bias.copy_from(&f.layers[1].bias);
                c.weight.copy_from(&f.layers[2].weight);
                c.bias.copy_from(&f.layers[2].bias);
            }
        }
    };
}

macro_rules! three {
    ($a:literal, $b:literal, $c:literal) => {
        impl Arch for Three<$a, $b, $c> {
            fn parts(m: &Self::Built) -> Parts {
                let ((a, _), (b, _), (c, _), d) = m;
                vec![
                    (a.weight.as_vec(), a.bias.as_vec()),
                    (b.weight.as_vec(), b.bias.as_vec()),
                    (c.weight.as_vec(), c.bias.as_vec()),
                    (d.weight.as_vec(), d.bias.as_vec()),
                ]
            }
            fn set(m: &mut Self::Built, f: &FusedMlp) {
                let ((a, _), (b, _), (c, _), d) = m;
                a.weight.copy_from(&f.layers[0].weight);
                a.bias.copy_from(&f.layers[0].bias);
                b.weight.copy_from(&f.layers[1].weight);
                b.bias.copy_from(&f.layers[1].bias);
                c.weight.copy_from(&f.layers[2].weight);
                c.bias.copy_from(&f.layers[2].bias);
                d.weight.copy_from(&f.layers[3].weight);
                d.bias.copy_from(&f.layers[3].bias);
            }
        }
    };
}

two!(64, 64);
three!(32, 32, 32);
three!(64, 64, 64);
three!(256, 256, 256);
three!(256, 128, 64);

/// `$f::<M>(args)` for the dfdx type `M` of hidden widths `$widths`, or
/// `None` where none is listed in [`REFERENCE_WIDTHS`].
macro_rules! with_arch {
    ($widths:expr, $f:ident($($arg:expr),*)) => {
        match $widths {
            [64, 64] => Some($f::<Two<64, 64>>($($arg),*)),
            [32, 32, 32] => Some($f::<Three<32, 32, 32>>($($arg),*)),
            [64, 64, 64] => Some($f::<Three<64, 64, 64>>($($arg),*)),
            [256, 256, 256] => Some($f::<Three<256, 256, 256>>($($arg),*)),
            [256, 128, 64] => Some($f::<Three<256, 128, 64>>($($arg),*)),
            _ => None,
        }
    };
}

type In<T> = Tensor<(usize, Const<INPUT>), f32, Cpu, T>;
type Out<T> = Tensor<(usize, Const<STATE>), f32, Cpu, T>;

/// dfdx's initialisation of hidden `widths` for `seed` (`Cpu::seed_from_u64`
/// and `build_module`), or `None` where dfdx has no type for them here.
pub(super) fn init(widths: &[usize], seed: u64) -> Option<Parts> {
    fn built<M: Arch>(seed: u64) -> Parts {
        M::parts(&Cpu::seed_from_u64(seed).build_module::<M, f32>())
    }
    with_arch!(widths, built(seed))
}

/// dfdx's forward pass of `net` on `x` (n x 18), or `None` where dfdx has no
/// type for its widths or layout.
pub(super) fn predict(widths: &[usize], net: &FusedMlp, x: &[f32]) -> Option<Vec<f32>> {
    fn run<M: Arch>(net: &FusedMlp, x: &[f32]) -> Vec<f32>
    where
        M::Built: Module<In<NoneTape>, Output = Out<NoneTape>>,
    {
        let dev = Cpu::default();
        let mut m = dev.build_module::<M, f32>();
        M::set(&mut m, net);
        forward::<M>(&m, &dev, x)
    }
    if (net.inputs(), net.outputs()) != (INPUT, STATE) {
        return None;
    }
    with_arch!(widths, run(net, x))
}

fn forward<M: Arch>(m: &M::Built, dev: &Cpu, x: &[f32]) -> Vec<f32>
where
    M::Built: Module<In<NoneTape>, Output = Out<NoneTape>>,
{
    let n = x.len() / INPUT;
    m.forward(dev.tensor_from_vec(x.to_vec(), (n, Const::<INPUT>))).as_vec()
}

/// dfdx's own tape-based training of a module of type `M`.
struct ReferenceRun<M: Arch> {
    dev: Cpu,
    model: M::Built,
    grads: Option<Gradients<f32, Cpu>>,
    opt: Adam<M::Built, f32, Cpu>,
    best: M::Built,
}

impl<M: Arch> Minibatches for ReferenceRun<M>
where
    M::Built: ModuleMut<In<OwnedTape<f32, Cpu>>, Output = Out<OwnedTape<f32, Cpu>>>
        + Module<In<NoneTape>, Output = Out<NoneTape>>
        + TensorCollection<f32, Cpu>
        + Clone,
{
    fn step(&mut self, x: &[f32], y: &[f32], n: usize, lr: f64) -> f32 {
        self.opt.cfg.lr = lr;
        let x = self.dev.tensor_from_vec(x.to_vec(), (n, Const::<INPUT>));
        let y = self.dev.tensor_from_vec(y.to_vec(), (n, Const::<STATE>));
        let grads = self.grads.take().unwrap_or_else(|| self.model.alloc_grads());
        let loss = mse_loss(self.model.forward_mut(x.traced(grads)), y);
        let value = loss.array();
        let mut grads = loss.backward();
        self.opt.update(&mut self.model, &grads).expect("every parameter of the model receives a gradient");
        self.model.zero_grads(&mut grads);
        self.grads = Some(grads);
        value
    }
    fn val_loss(&mut self, x: &[f32], y: &[f32]) -> f64 {
        mse_of(&forward::<M>(&self.model, &self.dev, x), y)
    }
    fn keep_best(&mut self) {
        self.best = self.model.clone();
    }
}

/// Trains with dfdx's own trainer for hidden `widths` (the loop is
/// `drive`'s), and gives the best module's parameters; `None` where dfdx
/// has no type for the widths here.
pub(super) fn train(
    widths: &[usize],
    lr: f64,
    seed: u64,
    drive: &mut dyn FnMut(&mut dyn Minibatches),
) -> Option<Parts> {
    fn run<M: Arch>(lr: f64, seed: u64, drive: &mut dyn FnMut(&mut dyn Minibatches)) -> Parts
    where
        M::Built: ModuleMut<In<OwnedTape<f32, Cpu>>, Output = Out<OwnedTape<f32, Cpu>>>
            + Module<In<NoneTape>, Output = Out<NoneTape>>
            + TensorCollection<f32, Cpu>
            + Clone,
    {
        let dev = Cpu::seed_from_u64(seed);
        let model = dev.build_module::<M, f32>();
        let grads = Some(model.alloc_grads());
        let opt = Adam::new(&model, AdamConfig { lr, ..Default::default() });
        let best = model.clone();
        let mut run = ReferenceRun::<M> { dev, model, grads, opt, best };
        drive(&mut run);
        M::parts(&run.best)
    }
    with_arch!(widths, run(lr, seed, drive))
}
