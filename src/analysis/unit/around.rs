//! The checks and intervals of one unit around its estimate: a unit
//! whose differences do not vary is refused, and the optimism's interval.

use super::{ArmArrays, Ctx, Grid};
use crate::analysis::AnalysisError;
use crate::design::{EstimatorKind, Metric};
use crate::plan::AnalysisUnit;
use crossaudit_stats::{mean_squares_along, mom_from_squares, ratio_interval, ratio_interval_batched};
use crossaudit_stats::{DfRule, RatioInterval, ALONG_LANES};

impl Ctx<'_> {
    /// The optimism's Fieller and delta-method intervals (in %) from the
    /// plan's estimator on the arrays L(rho) = treated - (1 - rho)
    /// reference (`stats::ratio_interval`); `None`, with a warning, when
    /// the estimator cannot give them.
    pub(super) fn optimism_interval(
        &self,
        a: &ArmArrays,
        optimism_pct: f64,
        label: &str,
        warnings: &mut Vec<String>,
    ) -> Option<RatioInterval> {
        let (rows, cols) = (a.treated.rows, a.treated.cols);
        let interval = self.estimate(&a.reference).and_then(|reference| {
            let point = optimism_pct / 100.0;
            let est = &self.plan.estimator;
            if let (Some(t), Some(r), true) =
                (a.treated.values(), a.reference.values(), est.kind == EstimatorKind::CrossedMom)
            {
                // Every cell present, under the method of moments: the
                // arrays L(rho) of a round of both edges' steps summed side
                // by side in one pass over the arms, never built
                // (`stats::mean_squares_along`), each estimated as one
                // array alone is (`estimate_of`: a seed-invariant array's
                // df from the recordings).
                ratio_interval_batched(point, &reference, ALONG_LANES, |rhos: &[f64]| {
                    let tables = mean_squares_along(t, r, rows, cols, rhos);
                    tables
                        .into_iter()
                        .map(|table| {
                            let (table, invariant) = table?;
                            let rule = if invariant { DfRule::RecordingsMinusOne } else { est.df };
                            mom_from_squares(table, rows, cols, est.level, rule)
                        })
                        .collect()
                })
            } else {
                ratio_interval(point, &reference, |rho: f64| {
                    let v = a.treated.v.iter().zip(&a.reference.v);
                    self.estimate(&Grid { rows, cols, v: v.map(|(t, r)| t - (1.0 - rho) * r).collect() })
                })
            }
        });
        match interval {
            Ok(iv) => Some(iv.scaled(100.0)),
            Err(e) => {
                warnings.push(format!("{label}: no interval for the optimism: {e}"));
                None
            }
        }
    }

    /// Refuses a unit whose treated - reference differences do not vary: the
    /// method of moments would give an interval of width zero around them
    /// (and confirm any nonzero shift), REML cannot fit them at all. The
    /// differences count as constant when their range is within 1e-9 of the
    /// largest value in either arm, the size of rounding in the subtraction.
    /// When every start diverged in both arms (every cell at the cap), the
    /// message says so: the endpoint cannot tell the arms apart.
    pub(super) fn degenerate(&self, u: &AnalysisUnit, a: &ArmArrays, label: &str) -> Result<(), AnalysisError> {
        let d: Vec<f64> = a.diff.present().collect();
        let (lo, hi) = d.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| (l.min(*x), h.max(*x)));
        let scale = a.treated.present().chain(a.reference.present()).fold(0.0f64, |m, x| m.max(x.abs()));
        if d.len() < 2 || hi - lo > 1e-9 * scale {
            return Ok(());
        }
        let all_diverged = [&self.plan.contrast.treated, &self.plan.contrast.reference].iter().all(|arm| {
            self.recordings.iter().all(|r| {
                self.plan.seeds.iter().all(|s| {
                    self.data
                        .find(&u.model, arm, s.0, &r.recording, u.horizon_s)
                        .is_none_or(|c| c.n_divergent == c.n_starts)
                })
            })
        });
        let fixed = self.plan.models.iter().find(|m| m.name == u.model && !m.kind.trains());
        let detail = if let Some(m) = fixed {
            // A baseline fits nothing: the same model in every arm.
            let used: Vec<String> = self
                .plan
                .interactions
                .iter()
                .filter(|i| i.left == m.name || i.right == m.name)
                .map(|i| format!("`{} - {}`", i.left, i.right))
                .collect();
            format!(
                "`{}` is parameter-free ({}): it is the same model in every arm, so `{} - {}` is {} by construction and measures nothing about the arms; {}",
                m.name,
                crate::plan::model_text(&m.kind),
                self.plan.contrast.treated,
                self.plan.contrast.reference,
                (lo + hi) / 2.0,
                if used.is_empty() {
                    "it is a reference level for an interaction, not a contrast of its own".to_string()
                } else {
                    format!("it enters the report as the reference level of {}", used.join(", "))
                }
            )
        } else if all_diverged && u.metric != Metric::DivergenceRate {
            format!(
                "every start diverged in both arms (every cell is at the divergence cap of {} m), so the endpoint cannot tell `{}` from `{}`; no optimism or interval is reported for it",
                self.plan.cap.0, self.plan.contrast.treated, self.plan.contrast.reference
            )
        } else {
            format!(
                "every {} - {} difference is {} in all {} recording x seed pairs: with no variance there is no interval to decide on (per-cell data whose arms differ by a constant are not the output of a run)",
                self.plan.contrast.treated,
                self.plan.contrast.reference,
                (lo + hi) / 2.0,
                d.len()
            )
        };
        Err(AnalysisError::Degenerate { unit: label.to_string(), detail })
    }
}
