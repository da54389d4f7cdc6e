//! The trend over doses (or distances): the per-cell least-squares slope,
//! its crossed estimate, and which doses reject zero, descriptively and by
//! step-down testing.

use super::{AnalysisError, DoseResult, Trend, Values};
use crate::analysis::unit::estimate_grid;
use crate::design::DoseAxis;
use crate::plan::{dose_axis, DoseArm, Plan};

/// Least-squares weights of the slope over (0, doses...): the slope of
/// (0, d_1, ..., d_K) is sum_k w_k d_k. Over distances the reference is
/// off the axis: the slope of (d_1, ..., d_K) over the distances alone.
fn slope_weights(doses: &[DoseArm]) -> Vec<f64> {
    let reference = match dose_axis(doses) {
        DoseAxis::Percent => Some(0.0),
        DoseAxis::Distance => None,
    };
    let x: Vec<f64> = reference.into_iter().chain(doses.iter().map(DoseArm::dose)).collect();
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let sxx: f64 = x.iter().map(|v| (v - mean) * (v - mean)).sum();
    doses.iter().map(|d| (d.dose() - mean) / sxx).collect()
}

/// Per-cell slopes of one split (None where a dose's cell is missing).
pub(super) fn slopes(v: &Values, doses: &[DoseArm]) -> Vec<Option<f64>> {
    let w = slope_weights(doses);
    (0..v.recordings.len() * v.seeds.len())
        .map(|k| {
            let mut total = 0.0;
            for (dk, wk) in v.d.iter().zip(&w) {
                total += wk * dk[k]?;
            }
            Some(total)
        })
        .collect()
}

/// -100 x / mean_reference.
pub(super) fn as_optimism(x: f64, mean_reference: f64) -> f64 {
    -100.0 * x / mean_reference
}

/// The smallest dose whose interval excludes zero. Over distances, the
/// farthest distance whose interval lies below zero: where optimism (the
/// treated arm better) survives; an arm made worse by its far windows is
/// no leak surviving (the report says so beside the verdict).
pub(super) fn smallest_excluding_zero<'a>(
    axis: DoseAxis,
    items: impl Iterator<Item = (f64, f64, f64)> + 'a,
) -> Option<f64> {
    let excluding = items.filter(|&(_, lo, hi)| rejects(axis, lo, hi)).map(|(p, _, _)| p);
    match axis {
        DoseAxis::Percent => excluding.reduce(f64::min),
        DoseAxis::Distance => excluding.reduce(f64::max),
    }
}

/// Step-down (fixed-sequence) testing of (dose, lower, upper) from the
/// largest dose: the lowest dose before the first interval that includes
/// zero. Testing hypotheses in a fixed order, each at the full level, and
/// stopping at the first not rejected is a closed testing procedure
/// (Maurer, Hothorn and Lehmacher 1995), so it controls the family-wise
/// error rate without adjusting the intervals.
/// Over distances the sequence runs from the nearest distance (the
/// strongest treatment) outwards, and an interval counts only below zero.
pub(super) fn step_down(axis: DoseAxis, items: impl Iterator<Item = (f64, f64, f64)>) -> Option<f64> {
    let mut v: Vec<(f64, f64, f64)> = items.collect();
    match axis {
        DoseAxis::Percent => v.sort_by(|a, b| b.0.total_cmp(&a.0)),
        DoseAxis::Distance => v.sort_by(|a, b| a.0.total_cmp(&b.0)),
    }
    v.into_iter().take_while(|&(_, lo, hi)| rejects(axis, lo, hi)).map(|(p, _, _)| p).last()
}

/// Whether an interval [lo, hi] rejects zero on the axis: on either side
/// for a share, only below zero (optimism) for a distance.
fn rejects(axis: DoseAxis, lo: f64, hi: f64) -> bool {
    match axis {
        DoseAxis::Percent => lo > 0.0 || hi < 0.0,
        DoseAxis::Distance => hi < 0.0,
    }
}

pub(super) fn trend(
    plan: &Plan,
    v: &Values,
    doses: &[DoseArm],
    results: &[DoseResult],
) -> Result<Trend, AnalysisError> {
    let slope = estimate_grid(&plan.estimator, v.recordings.len(), v.seeds.len(), slopes(v, doses))
        .map_err(|e| AnalysisError::Stats { unit: "slope over doses".to_string(), source: e })?;
    let (a, b) = (as_optimism(slope.upper, v.mean_reference), as_optimism(slope.lower, v.mean_reference));
    let axis = dose_axis(doses);
    let intervals = || results.iter().map(|r| (r.distance_s.unwrap_or(r.percent), r.estimate.lower, r.estimate.upper));
    Ok(Trend {
        optimism_slope: as_optimism(slope.mean, v.mean_reference),
        optimism_slope_lower: a.min(b),
        optimism_slope_upper: a.max(b),
        slope,
        smallest_dose_excluding_zero: smallest_excluding_zero(axis, intervals()),
        step_down_dose: step_down(axis, intervals()),
    })
}

#[cfg(test)]
mod tests {
    use super::{smallest_excluding_zero, step_down, DoseAxis};

    /// Doses 1%, 5%, 10% with intervals that exclude zero at 1% and 10%
    /// but not at 5%: the descriptive rule picks 1%, while step-down
    /// testing from 10% stops at 5% and keeps 10% (a 1% finding reached
    /// past a non-rejection is exactly what it does not allow).
    #[test]
    fn step_down_stops_at_the_first_interval_that_includes_zero() {
        let intervals = [(1.0, -0.3, -0.01), (5.0, -0.2, 0.05), (10.0, -0.5, -0.2)];
        assert_eq!(smallest_excluding_zero(DoseAxis::Percent, intervals.iter().copied()), Some(1.0));
        assert_eq!(step_down(DoseAxis::Percent, intervals.iter().copied()), Some(10.0));
        // Every interval excludes zero: both pick the smallest dose.
        let all = [(1.0, -0.3, -0.01), (5.0, -0.2, -0.05), (10.0, -0.5, -0.2)];
        assert_eq!(step_down(DoseAxis::Percent, all.iter().copied()), Some(1.0));
        // The largest dose includes zero: nothing is claimed.
        let none = [(1.0, -0.3, -0.01), (10.0, -0.5, 0.2)];
        assert_eq!(step_down(DoseAxis::Percent, none.iter().copied()), None);
    }

    /// Over distances the sequence runs outwards from the nearest, and only
    /// an interval below zero (the treated arm better) counts: at 0 s and
    /// 1 s the optimism survives, at 5 s the treated arm is worse: both
    /// rules name 1 s. With 1 s including zero, step-down stops at 0 s
    /// while the descriptive rule finds the farthest below zero, 5 s.
    #[test]
    fn over_distances_only_optimism_counts_and_the_sequence_runs_outwards() {
        let worse_far = [(0.0, -0.3, -0.1), (1.0, -0.2, -0.01), (5.0, 0.1, 0.3)];
        assert_eq!(step_down(DoseAxis::Distance, worse_far.iter().copied()), Some(1.0));
        assert_eq!(smallest_excluding_zero(DoseAxis::Distance, worse_far.iter().copied()), Some(1.0));
        // As shares, 5% would count: its interval excludes zero.
        assert_eq!(smallest_excluding_zero(DoseAxis::Percent, worse_far.iter().copied()), Some(0.0));
        let gap = [(0.0, -0.3, -0.1), (1.0, -0.2, 0.05), (5.0, -0.2, -0.01)];
        assert_eq!(step_down(DoseAxis::Distance, gap.iter().copied()), Some(0.0));
        assert_eq!(smallest_excluding_zero(DoseAxis::Distance, gap.iter().copied()), Some(5.0));
    }
}
