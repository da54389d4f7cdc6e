//! The methodologists' tools, which stand beside the study pipeline: the
//! coverage study of interval estimators and the power planner.

pub mod coverage;
pub mod power;

pub use coverage::{run_coverage, CoverageError, CoverageSpec};
pub use power::{power_plan, PowerError, PowerPlan, PowerRow};
