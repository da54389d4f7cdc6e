//! Stage: dynamics models. Standardizers and the world / relative input
//! maps, the dfdx MLP and its training, and parameter-free baselines.

pub mod baseline;
pub mod features;
pub mod net;
mod standardize;

pub use features::FeatureMap;
pub use net::{train, EpochLog, Learned, Net, NetError, SUPPORTED_WIDTHS};
pub use standardize::Standardizer;
