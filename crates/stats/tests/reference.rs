//! The statistics crate's own checks that need no other part of
//! crossaudit: properties of the crossed estimators (proptest), the mixed
//! models' df against lme4 on dominant-component data, stress fits, and
//! the resampling intervals against R. One test binary for all four.

// The reference helpers are shared with the other test binaries; this one
// uses only some of them.
#[allow(dead_code)]
#[path = "common/mod.rs"]
mod common;

#[path = "reference/mixed_df.rs"]
mod mixed_df;
#[path = "reference/props.rs"]
mod props;
#[path = "reference/resampling.rs"]
mod resampling;
#[path = "reference/stress.rs"]
mod stress;

/// Whether `a` is within `tol` of `b`, relative to `b`.
pub fn rel_close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1e-300)
}

/// Fails unless `actual` is within `tol` of `expected`, relative to it.
#[track_caller]
pub fn assert_rel(actual: f64, expected: f64, tol: f64, what: &str) {
    assert!(
        rel_close(actual, expected, tol),
        "{what}: got {actual:?}, expected {expected:?} (relative tolerance {tol})"
    );
}
