//! The MLP and its training. dfdx 0.13 (CPU) defines the model: its module
//! type, initialisation and safetensors format, and its trainer is kept as
//! the reference ([`Engine::Reference`]). Runs train with the fused f32
//! trainer of [`super::fused`] ([`Engine::Fused`]), which is bit-identical
//! to it and takes about half its time per epoch
//! (`results/benchmarks/torch_reference.txt`); rollouts predict through the same fused
//! forward pass.
//!
//! The architectures are any hidden ReLU layers the language accepts
//! ([`crate::design::mlp_unsupported`]): inputs -> W1 -> ... -> Wk -> state
//! (18 -> 256 -> 256 -> 256 -> 14 for the paper on NanoBench). Layer widths
//! are types in dfdx 0.13, so its reference trainer runs the architectures
//! of [`REFERENCE_WIDTHS`] on NanoBench's layout only; the fused trainer
//! takes any widths and any [`Slots`], starting from dfdx's initialisation
//! ([`Net::init`], checked bit for bit against it).

use std::path::Path;

use rand::SeedableRng;

use super::features::{Action, FeatureMap, Slots, State};
use super::fused::{Activations, FusedMlp, Trainer};
pub use super::lockstep::{learning_rate, EpochLog, Windows};
use super::lockstep::{lockstep, BatchJob, PerJob};
use super::minibatch::{mse_of, Minibatches};
use super::reference::{self, REFERENCE_WIDTHS};
use super::Dynamics;
use crate::design::{mlp_unsupported, Training};

/// A trained network: its parameters, in the fused trainer's layout.
#[derive(Debug, Clone, PartialEq)]
pub struct Net {
    mlp: FusedMlp,
}

/// Why a network could not be trained, saved or loaded.
#[derive(Debug, thiserror::Error)]
pub enum NetError {
    #[error("mlp widths {0:?}: {1}")]
    /// Widths the language does not accept, and why.
    Unsupported(Vec<usize>, String),
    #[error("dfdx's reference trainer has no network type for mlp widths {0:?}; it has {REFERENCE_WIDTHS:?}")]
    /// The reference trainer was asked for widths it has no type for.
    NoReference(Vec<usize>),
    #[error("cannot save or load model weights at {path}: {message}")]
    /// Weights could not be saved or loaded.
    Io {
        /// The weights file.
        path: String,
        /// Why.
        message: String,
    },
    #[error("training on the GPU failed: {0}")]
    /// A GPU call failed.
    Device(#[from] super::lockstep::BackendError),
    #[error("training needs at least one fit and one validation window")]
    /// No fit or no validation windows.
    NoData,
    #[error("dfdx's reference trainer runs NanoBench's layout (14 state, 4 action dimensions) only; this data has {state} state and {action} action dimensions")]
    /// The reference trainer was asked for another layout.
    ReferenceLayout {
        /// State dimensions.
        state: usize,
        /// Action dimensions.
        action: usize,
    },
}

/// Which trainer runs: both give bit-identical weights and curves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Engine {
    /// The fused f32 trainer on AVX-512 `gemm` kernels (what runs use).
    #[default]
    Fused,
    /// dfdx's own tape-based trainer, kept as the reference.
    Reference,
}

/// Trains a network exactly as the design says, with the fused trainer.
/// The seed fixes the initialisation (dfdx's device RNG), the shuffling
/// (ChaCha8 stream 1) and the action noise (stream 2). `on_epoch` sees
/// every epoch.
pub fn train(
    widths: &[usize],
    features: &FeatureMap,
    fit: &Windows,
    validation: &Windows,
    t: &Training,
    seed: u64,
    on_epoch: &mut dyn FnMut(&EpochLog),
) -> Result<(Net, Vec<EpochLog>), NetError> {
    train_with(Engine::Fused, widths, features, fit, validation, t, seed, on_epoch)
}

/// As [`train`], with the trainer chosen.
#[allow(clippy::too_many_arguments)]
pub fn train_with(
    engine: Engine,
    widths: &[usize],
    features: &FeatureMap,
    fit: &Windows,
    validation: &Windows,
    t: &Training,
    seed: u64,
    on_epoch: &mut dyn FnMut(&EpochLog),
) -> Result<(Net, Vec<EpochLog>), NetError> {
    if fit.is_empty() || validation.is_empty() {
        return Err(NetError::NoData);
    }
    if let Some(why) = mlp_unsupported(widths) {
        return Err(NetError::Unsupported(widths.to_vec(), why));
    }
    let job = BatchJob { widths, features, fit, validation, training: t, seed };
    if engine == Engine::Fused {
        let mut run = FusedRun::new(Net::init(&features.slots, widths, seed).mlp, t.batch, validation.len());
        let logs = alone(&mut run, &job, on_epoch)?;
        return Ok((Net { mlp: run.best }, logs));
    }
    let slots = features.slots;
    if !slots.is_nanobench() {
        return Err(NetError::ReferenceLayout { state: slots.state, action: slots.action });
    }
    let mut logs = Ok(Vec::new());
    let best = reference::train(widths, t.lr, seed, &mut |run| {
        logs = alone(run, &job, on_epoch);
    })
    .ok_or_else(|| NetError::NoReference(widths.to_vec()))?;
    Ok((Net { mlp: FusedMlp::from_parts(&Slots::NANOBENCH, widths, &best) }, logs?))
}

/// Trains `jobs` in lockstep on the CPU, each with its own fused trainer,
/// through the loop the GPU backend runs (minibatch by minibatch, a job
/// leaving when it stops): each job's network and epoch logs are
/// bit-identical to [`train`]'s. The reference the batched trainer is
/// tested against; `on_epoch` sees (job index, log).
pub fn train_lockstep(
    jobs: &[BatchJob],
    on_epoch: &mut dyn FnMut(usize, &EpochLog),
) -> Result<Vec<(Net, Vec<EpochLog>)>, NetError> {
    for j in jobs {
        if j.fit.is_empty() || j.validation.is_empty() {
            return Err(NetError::NoData);
        }
        if let Some(why) = mlp_unsupported(j.widths) {
            return Err(NetError::Unsupported(j.widths.to_vec(), why));
        }
    }
    let mut runs: Vec<FusedRun> = jobs
        .iter()
        .map(|j| {
            FusedRun::new(Net::init(&j.features.slots, j.widths, j.seed).mlp, j.training.batch, j.validation.len())
        })
        .collect();
    let logs = {
        let trainers: Vec<&mut dyn Minibatches> = runs.iter_mut().map(|r| r as &mut dyn Minibatches).collect();
        lockstep(&mut PerJob::new(trainers, jobs), jobs, on_epoch)?
    };
    Ok(runs.into_iter().map(|r| Net { mlp: r.best }).zip(logs).collect())
}

/// One job through the protocol's loop on its own CPU trainer.
fn alone(
    trainer: &mut dyn Minibatches,
    job: &BatchJob,
    on_epoch: &mut dyn FnMut(&EpochLog),
) -> Result<Vec<EpochLog>, NetError> {
    let mut backend = PerJob::new(vec![trainer], std::slice::from_ref(job));
    let logs = lockstep(&mut backend, std::slice::from_ref(job), &mut |_, log| on_epoch(log))?;
    Ok(logs.into_iter().next().unwrap_or_default())
}

/// The fused trainer with its validation buffers and best parameters.
struct FusedRun {
    trainer: Trainer,
    val_act: Activations,
    best: FusedMlp,
}

impl FusedRun {
    fn new(init: FusedMlp, batch: usize, n_val: usize) -> Self {
        let val_act = Activations::new(&init, n_val);
        FusedRun { best: init.clone(), trainer: Trainer::new(init, batch), val_act }
    }
}

impl Minibatches for FusedRun {
    fn step(&mut self, x: &[f32], y: &[f32], n: usize, lr: f64) -> f32 {
        self.trainer.step(x, y, n, lr)
    }
    fn val_loss(&mut self, x: &[f32], y: &[f32]) -> f64 {
        mse_of(self.trainer.net.forward(x, x.len() / self.trainer.net.inputs(), &mut self.val_act), y)
    }
    fn keep_best(&mut self) {
        self.best.clone_from(&self.trainer.net);
    }
}

/// dfdx's name for each layer's (weight, bias) in a safetensors file of
/// `layers` layers: the MLP's tuple position, then the Linear's inside its
/// (Linear, ReLU); the output layer is a bare Linear.
fn tensor_names(layers: usize) -> Vec<(String, String)> {
    (0..layers)
        .map(|k| {
            let at = if k + 1 == layers { format!("{k}") } else { format!("{k}.0") };
            (format!("{at}.weight"), format!("{at}.bias"))
        })
        .collect()
}

impl Net {
    /// dfdx's initialisation for `seed`, for any layout: each layer's
    /// weight, then its bias, drawn in storage order from Uniform(-b, b),
    /// b = 1 / sqrt(inputs) in f32, with the device's RNG (rand's `StdRng`
    /// seeded with `seed`), as dfdx's `Cpu::seed_from_u64(seed)` and
    /// `build_module` do (tests/fused.rs checks it bit for bit).
    pub fn init(slots: &Slots, widths: &[usize], seed: u64) -> Net {
        use rand::distributions::{Distribution, Uniform};
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let parts: Vec<(Vec<f32>, Vec<f32>)> = FusedMlp::dims(slots, widths)
            .iter()
            .map(|&(inp, out)| {
                let b = 1.0f32 / (inp as f32).sqrt();
                let u = Uniform::new(-b, b);
                let w = (0..inp * out).map(|_| u.sample(&mut rng)).collect();
                let bias = (0..out).map(|_| u.sample(&mut rng)).collect();
                (w, bias)
            })
            .collect();
        Net { mlp: FusedMlp::from_parts(slots, widths, &parts) }
    }

    /// dfdx's own initialisation of NanoBench's layout (the reference
    /// [`Net::init`] is checked against), for the widths of
    /// [`REFERENCE_WIDTHS`].
    pub fn init_dfdx(widths: &[usize], seed: u64) -> Option<Net> {
        let parts = reference::init(widths, seed)?;
        Some(Net { mlp: FusedMlp::from_parts(&Slots::NANOBENCH, widths, &parts) })
    }

    /// The network of these parameters.
    pub(super) fn from_mlp(mlp: FusedMlp) -> Net {
        Net { mlp }
    }

    /// The parameters for the fused forward pass and trainer.
    pub fn fused(&self) -> FusedMlp {
        self.mlp.clone()
    }

    /// Hidden widths.
    pub fn widths(&self) -> Vec<usize> {
        self.mlp.layers[..self.mlp.layers.len() - 1].iter().map(|l| l.out).collect()
    }

    /// Standardized predictions for standardized inputs (n x inputs -> n x
    /// state) through dfdx's forward pass (the reference; rollouts use
    /// [`Learned`], which runs the fused one). A layout dfdx has no type
    /// for goes through the fused pass.
    pub fn predict(&self, x: &[f32]) -> Vec<f32> {
        reference::predict(&self.widths(), &self.mlp, x).unwrap_or_else(|| self.mlp.predict(x))
    }

    /// All weights, flattened in a fixed order (for bit-identity checks).
    pub fn flat_weights(&self) -> Vec<f32> {
        self.mlp.layers.iter().flat_map(|l| l.weight.iter().chain(&l.bias).copied()).collect()
    }

    /// Writes the weights as safetensors, with dfdx's tensor names and
    /// shapes (dfdx's `load_safetensors` reads them).
    pub fn save(&self, path: &Path) -> Result<(), NetError> {
        use ::safetensors::tensor::{Dtype, TensorView};
        let err = |e: String| NetError::Io { path: path.display().to_string(), message: e };
        let bytes = |v: &[f32]| v.iter().flat_map(|f| f.to_le_bytes()).collect::<Vec<u8>>();
        let data: Vec<(String, Vec<usize>, Vec<u8>)> = self
            .mlp
            .layers
            .iter()
            .zip(tensor_names(self.mlp.layers.len()))
            .flat_map(|(l, (w, b))| [(w, vec![l.out, l.inp], bytes(&l.weight)), (b, vec![l.out], bytes(&l.bias))])
            .collect();
        let views = data
            .iter()
            .map(|(name, shape, d)| {
                TensorView::new(Dtype::F32, shape.clone(), d)
                    .map(|v| (name.clone(), v))
                    .map_err(|e| err(format!("{e:?}")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        // Staged and renamed, so that an interrupted save never leaves half a file.
        let tmp = crate::io::staged(path).map_err(|e| err(e.to_string()))?;
        ::safetensors::tensor::serialize_to_file(views, &None, &tmp).map_err(|e| err(format!("{e:?}")))?;
        std::fs::rename(&tmp, path).map_err(|e| err(e.to_string()))
    }

    /// Reads weights written by [`Net::save`] (or dfdx) for an
    /// architecture of `widths`; the layout is read from the shapes.
    pub fn load(widths: &[usize], path: &Path) -> Result<Net, NetError> {
        if let Some(why) = mlp_unsupported(widths) {
            return Err(NetError::Unsupported(widths.to_vec(), why));
        }
        let err = |e: String| NetError::Io { path: path.display().to_string(), message: e };
        let raw = std::fs::read(path).map_err(|e| err(e.to_string()))?;
        let file = ::safetensors::tensor::SafeTensors::deserialize(&raw).map_err(|e| err(format!("{e:?}")))?;
        let tensor = |name: &str, shape: &[Option<usize>]| -> Result<(Vec<usize>, Vec<f32>), NetError> {
            let t = file.tensor(name).map_err(|e| err(format!("{name}: {e:?}")))?;
            let fits =
                t.shape().len() == shape.len() && t.shape().iter().zip(shape).all(|(a, b)| b.is_none_or(|b| *a == b));
            if t.dtype() != ::safetensors::tensor::Dtype::F32 || !fits {
                return Err(err(format!("{name}: {:?} of shape {:?}, not the architecture's", t.dtype(), t.shape())));
            }
            let v = t.data().chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
            Ok((t.shape().to_vec(), v))
        };
        let names = tensor_names(widths.len() + 1);
        if let Ok(extra) = file.tensor(&names[widths.len()].0.replace(".weight", ".0.weight")) {
            return Err(err(format!("a hidden layer beyond mlp widths {widths:?} ({:?})", extra.shape())));
        }
        // Each layer's (out, in): the first layer's inputs and the last's
        // outputs are read from the file.
        let mut parts = Vec::with_capacity(names.len());
        let (mut inputs, mut state) = (0, 0);
        for (k, (w, b)) in names.iter().enumerate() {
            let out = widths.get(k).copied();
            let inp = if k == 0 { None } else { Some(widths[k - 1]) };
            let (shape, weight) = tensor(w, &[out, inp])?;
            if k == 0 {
                inputs = shape[1];
            }
            if k == widths.len() {
                state = shape[0];
            }
            parts.push((weight, tensor(b, &[Some(shape[0])])?.1));
        }
        if inputs <= state {
            return Err(err(format!("{inputs} inputs for {state} outputs: not a dynamics network")));
        }
        let slots = Slots::full(state, inputs - state, state, false);
        Ok(Net { mlp: FusedMlp::from_parts(&slots, widths, &parts) })
    }
}

/// A trained network and its standardizers as a rollout [`Dynamics`],
/// predicting through the fused forward pass.
pub struct Learned<'a> {
    forward: Forward<'a>,
    features: &'a FeatureMap,
}

/// Which forward pass a [`Learned`] runs.
enum Forward<'a> {
    Fused(FusedMlp),
    Reference(&'a Net),
}

impl<'a> Learned<'a> {
    /// The rollout model of `net` under `features` (fused forward pass).
    pub fn new(net: &'a Net, features: &'a FeatureMap) -> Self {
        Self::with(Engine::Fused, net, features)
    }

    /// As [`Learned::new`], with the forward pass of `engine`.
    pub fn with(engine: Engine, net: &'a Net, features: &'a FeatureMap) -> Self {
        let forward = match engine {
            Engine::Fused => Forward::Fused(net.mlp.clone()),
            Engine::Reference => Forward::Reference(net),
        };
        Learned { forward, features }
    }
}

impl Dynamics for Learned<'_> {
    fn step(&mut self, states: &[State], actions: &[Action]) -> Vec<State> {
        let inputs = self.features.slots.input();
        let mut x = vec![0f32; states.len() * inputs];
        for ((row, s), u) in x.chunks_exact_mut(inputs).zip(states).zip(actions) {
            self.features.input(s, u, row);
        }
        let z = match &self.forward {
            Forward::Fused(f) => f.predict(&x),
            Forward::Reference(net) => net.predict(&x),
        };
        states
            .iter()
            .zip(z.chunks_exact(self.features.slots.state))
            .map(|(s, z)| self.features.next_state(s, z))
            .collect()
    }
}
