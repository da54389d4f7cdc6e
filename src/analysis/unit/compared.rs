//! `--compare-intervals` for one unit: every interval estimator on its
//! array, the coverage study's further ones on a complete array.

use super::{Ctx, Grid};
use crossaudit_stats::{compare_intervals, incomplete_intervals, CrossedMatrix, IntervalEstimate, StatsError};

impl Ctx<'_> {
    /// `--compare-intervals`: every interval estimator on the unit's
    /// array, the coverage study's further ones on a complete array; on an
    /// incomplete one, those it allows (REML, naive, one-way clustered) and
    /// a row of NaN for each other, which the report names with its
    /// reason; None without the option.
    pub(super) fn compared(
        &self,
        diff: &Grid,
        complete: Option<&CrossedMatrix>,
        stream: u64,
    ) -> Result<Option<Vec<IntervalEstimate>>, StatsError> {
        if !self.options.compare_intervals {
            return Ok(None);
        }
        let level = self.plan.estimator.level;
        let b = self.plan.sensitivity.bootstrap.map(|b| (b.replicates, b.seed)).unwrap_or((9999, 0));
        Ok(Some(match complete {
            Some(m) => {
                let mut all = compare_intervals(m, level, b.0, b.1, stream)?;
                all.extend(further(m, level, b, stream));
                all
            }
            None => incomplete_intervals(&diff.cells(), diff.rows, diff.cols, level)?,
        }))
    }
}

/// The coverage study's further intervals on a unit's complete array
/// (`stats::further_intervals`); where the array does not allow them, each
/// is a row of NaN, which the report names as undefined.
fn further(
    m: &crossaudit_stats::CrossedMatrix,
    level: f64,
    (b, seed): (usize, u64),
    stream: u64,
) -> Vec<crossaudit_stats::IntervalEstimate> {
    use crossaudit_stats::IntervalMethod as M;
    crossaudit_stats::further_intervals(m, level, b, seed, stream).unwrap_or_else(|_| {
        [
            M::TwoWayCluster,
            M::SumOfMargins,
            M::MomUntruncated,
            M::PigeonholeSe,
            M::PigeonholeT,
            M::ProductWeightsSe,
            M::ProductWeightsPercentile,
            M::ParametricT,
            M::ProfileMl,
        ]
        .map(crossaudit_stats::IntervalEstimate::undefined)
        .to_vec()
    })
}
