//! Leave-one-out of a unit: every fit with one recording (or seed) left
//! out, the range of its estimates, and the levels whose leaving-out moves
//! the verdict.

use super::{optimism, ArmArrays, Ctx, Grid};
use crate::analysis::decision::rule_holds;
use crate::analysis::types::LeaveOneOut;
use crate::analysis::AnalysisError;
use crate::design::{EstimatorKind, Factor};
use crossaudit_stats::{leave_one_out_mom, Axis, CrossedMatrix, DfRule, StatsError};

/// A grid's sum and count of present cells, in all and per row or column
/// of one factor, for its mean with that row or column left out.
struct LeftOut {
    sum: f64,
    count: usize,
    part: Vec<(f64, usize)>,
}

impl LeftOut {
    fn new(g: &Grid, factor: Factor) -> LeftOut {
        let by_seed = factor == Factor::Seed;
        let mut part = vec![(0.0, 0usize); if by_seed { g.cols } else { g.rows }];
        for (k, x) in g.v.iter().enumerate().filter(|(_, x)| !x.is_nan()) {
            let p = &mut part[if by_seed { k % g.cols } else { k / g.cols }];
            (p.0, p.1) = (p.0 + x, p.1 + 1);
        }
        LeftOut { sum: part.iter().map(|p| p.0).sum(), count: part.iter().map(|p| p.1).sum(), part }
    }

    /// The mean of the cells outside row (column) k; NaN (exactly 0 / 0)
    /// when none are.
    fn mean_without(&self, k: usize) -> f64 {
        let (s, n) = self.part[k];
        (self.sum - s) / (self.count - n) as f64
    }
}

impl Ctx<'_> {
    /// The design's leave-one-out sensitivities, each factor's in turn; one
    /// with fewer than 3 levels is skipped with a warning.
    pub(super) fn leave_one_out_all(
        &self,
        a: &ArmArrays,
        complete: Option<&CrossedMatrix>,
        (label, holds): (&str, bool),
        warnings: &mut Vec<String>,
    ) -> Result<Vec<LeaveOneOut>, AnalysisError> {
        let mut out = Vec::new();
        for &f in &self.plan.sensitivity.leave_one_out {
            let (n, noun) = match f {
                Factor::Seed => (a.diff.cols, "seeds"),
                Factor::Recording => (a.diff.rows, "recordings"),
            };
            if n < 3 {
                // A sensitivity that cannot run does not stop the primary
                // analysis: it is skipped, and the report says why.
                let one = noun.trim_end_matches('s');
                warnings.push(format!(
                    "{label}: leave-one-{one}-out skipped: it needs at least 3 {noun} (each fit leaves one out and a crossed estimate needs 2), found {n}"
                ));
                continue;
            }
            let fit = self.leave_one_out(a, complete, f, holds);
            out.push(fit.map_err(|source| AnalysisError::Stats { unit: label.to_string(), source })?);
        }
        Ok(out)
    }

    /// Every fit with one recording (or seed) left out. The crossed MoM on
    /// a complete array takes the closed form ([`leave_one_out_mom`], O(IJ)
    /// for all of them); REML refits each. `holds`: the rule on every level,
    /// against which the levels that move the verdict are named.
    fn leave_one_out(
        &self,
        a: &ArmArrays,
        complete: Option<&CrossedMatrix>,
        factor: Factor,
        holds: bool,
    ) -> Result<LeaveOneOut, StatsError> {
        let n = match factor {
            Factor::Seed => a.diff.cols,
            Factor::Recording => a.diff.rows,
        };
        let est = &self.plan.estimator;
        // A seed-invariant contrast takes its df from the recordings, in
        // every fit as in the primary one (`estimate_grid`).
        let df = if a.diff.seed_invariant() { DfRule::RecordingsMinusOne } else { est.df };
        let closed = match (est.kind, complete) {
            (EstimatorKind::CrossedMom, Some(m)) => {
                let axis = if factor == Factor::Seed { Axis::Cols } else { Axis::Rows };
                Some(leave_one_out_mom(m, axis, est.level, df)?)
            }
            _ => None,
        };
        let (treated, reference) = (LeftOut::new(&a.treated, factor), LeftOut::new(&a.reference, factor));
        let mut fits = Vec::with_capacity(n);
        for k in 0..n {
            let e = match &closed {
                Some(all) => all[k],
                None => self.estimate(&a.diff.without(factor, k))?,
            };
            let opt = optimism(reference.mean_without(k), treated.mean_without(k));
            fits.push((e.mean, e.upper, opt, rule_holds(&self.plan.decision, opt, &e)));
        }
        let min = |f: fn(&(f64, f64, f64, bool)) -> f64| fits.iter().map(f).fold(f64::INFINITY, f64::min);
        let max = |f: fn(&(f64, f64, f64, bool)) -> f64| fits.iter().map(f).fold(f64::NEG_INFINITY, f64::max);
        Ok(LeaveOneOut {
            factor,
            fits: n,
            mean_min: min(|x| x.0),
            mean_max: max(|x| x.0),
            upper_min: min(|x| x.1),
            upper_max: max(|x| x.1),
            optimism_min: min(|x| x.2),
            optimism_max: max(|x| x.2),
            rule_holds: fits.iter().filter(|x| x.3).count(),
            moves_verdict: (0..n).filter(|&k| fits[k].3 != holds).map(|k| self.level_name(factor, k)).collect(),
        })
    }

    /// The name of row (recording) or column (seed) `k`.
    fn level_name(&self, factor: Factor, k: usize) -> String {
        match factor {
            Factor::Recording => self.recordings.get(k).map(|r| r.recording.clone()).unwrap_or_else(|| k.to_string()),
            Factor::Seed => self.plan.seeds.get(k).map(|s| s.0.to_string()).unwrap_or_else(|| k.to_string()),
        }
    }
}
