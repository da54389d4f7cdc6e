//! Stage: dynamics models. Standardizers and the world / relative input
//! maps, the dfdx MLP and its training, a ridge regression fitted in
//! closed form (`linear`), and parameter-free baselines, all
//! behind one [`Dynamics`] trait that the rollout stage drives.
//!
//! Architecture Invariant: `model` imports only `design`, `stats` and `io`;
//! it knows nothing of recordings, splits or rollouts.

pub mod baseline;
pub mod batch;
mod batched;
#[cfg(feature = "cuda")]
mod cuda;
pub mod device;
mod emulated;
pub mod features;
pub mod fused;
mod kernel;
pub mod linear;
mod lockstep;
mod minibatch;
pub mod net;
mod reference;
mod standardize;

pub use batch::train_batch;
pub use device::{Device, DeviceChoice, DeviceError, Gpu};
pub use features::{Action, FeatureMap, Slots, State, ACTION, EXOGENOUS, INPUT, STATE};
pub use linear::{Linear, LinearError};
pub use lockstep::{BackendError, BatchJob};
pub use net::{train, train_lockstep, train_with, Engine, EpochLog, Learned, Net, NetError};
pub use reference::REFERENCE_WIDTHS;
pub use standardize::Standardizer;

/// One step of a dynamics model for a batch of states: the next states
/// (exogenous components are overwritten by the rollout afterwards).
pub trait Dynamics {
    /// Predicts x_{t+1} for every (x_t, u_t) of the batch.
    fn step(&mut self, states: &[State], actions: &[Action]) -> Vec<State>;
}
