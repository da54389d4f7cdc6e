//! One integration-test binary. Snapshots live in the top-level
//! `snapshots/` folder.

mod common;

mod analyze;
mod architecture;
mod bad_inputs;
mod browser;
mod condition_coverage;
mod coverage;
mod coverage_measures;
mod data;
mod design_errors;
mod designs;
mod draws;
mod early_stopping;
mod external;
mod external_levels;
mod family;
mod front_door;
mod fused;
mod golden;
mod logs;
mod mixed_cli;
mod model;
mod multiverse;
mod optimism_interval;
mod position_only;
mod resampling;
mod run;
mod simulate;
mod slurm;
mod slurm_external;
mod split;
mod split_audit;
mod split_numpy;
mod split_paper;
mod stats_mixed;
mod stats_mixed_df;
mod stats_props;
mod stats_reference;
mod stats_stress;
mod trust;
mod trust3_io;
mod trust3_provenance;
mod trust4;
mod wide_state;
