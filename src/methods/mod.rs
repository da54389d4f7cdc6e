//! The methodologists' tools, which stand beside the study pipeline: the
//! coverage study of interval estimators and the power planner.

pub mod coverage;
pub mod coverage_svg;
pub mod coverage_tidy;
pub mod coverage_zip;
pub mod decision_coverage;
pub mod draw_coverage;
pub mod draw_power;
pub mod formula_file;
pub mod power;
pub mod simsum;
pub mod simsum_report;
pub mod split_power;

pub use coverage::{run_coverage, CoverageError, CoverageSpec};
pub use draw_power::{draw_power_plan, DrawComponents, DrawPowerPlan, DrawPowerRow};
pub use power::{
    declared_power_plan, dose_power_plan, parse_components, power_plan, Declared, PowerError, PowerPlan, PowerRow,
};
pub use split_power::{pooled_se, split_power_plan, SplitPowerPlan, SplitPowerRow};
