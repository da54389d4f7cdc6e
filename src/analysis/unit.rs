//! One analysis unit: the two arms' I x J arrays, the crossed estimate of
//! their difference, and every preregistered sensitivity analysis.

use std::collections::BTreeMap;

use super::decision::rule_holds;
use super::index::Indexed;
use super::types::*;
use super::AnalysisError;
use crate::cells::Cell;
use crate::design::{Condition, Factor, Grouped, Metric};
use crate::plan::{AnalysisUnit, InteractionUnit, Plan};
use crate::stats::{compare_intervals, crossed_mom, pigeonhole_bootstrap, CrossedMatrix, StatsError};

/// What every unit's estimation reads: the plan, the indexed cells and the
/// evaluation recordings in row order.
pub(crate) struct Ctx<'a> {
    pub(crate) plan: &'a Plan,
    pub(crate) data: &'a Indexed<'a>,
    pub(crate) recordings: &'a [RecordingLabels],
    pub(crate) options: AnalyzeOptions,
}

/// The two arms' I x J arrays for one unit.
struct ArmArrays {
    treated: CrossedMatrix,
    reference: CrossedMatrix,
    diff: CrossedMatrix,
}

fn metric_value(c: &Cell, metric: Metric) -> Option<f64> {
    match metric {
        Metric::FaPositionRmse => Some(c.fa_position_rmse_m),
        Metric::ConditionalPositionRmse => c.conditional_position_rmse_m,
        Metric::DivergenceRate => Some(c.divergence_rate),
        Metric::VelocityRmse => c.velocity_rmse_mps,
        Metric::AttitudeRmse => c.attitude_rmse_deg,
    }
}

fn optimism(reference: f64, treated: f64) -> f64 {
    100.0 * (reference - treated) / reference
}

impl Ctx<'_> {
    fn cell(&self, model: &str, arm: &str, seed: u64, recording: &str, h: f64) -> &Cell {
        self.data.get(model, arm, seed, recording, h)
    }

    fn arrays(&self, model: &str, metric: Metric, h: f64, label: &str) -> Result<ArmArrays, AnalysisError> {
        let stats = |source| AnalysisError::Stats { unit: label.to_string(), source };
        let arr = |arm: &str| -> Result<CrossedMatrix, AnalysisError> {
            let mut values = Vec::with_capacity(self.recordings.len() * self.plan.seeds.len());
            for r in self.recordings {
                for s in &self.plan.seeds {
                    let c = self.cell(model, arm, s.0, &r.recording, h);
                    values.push(metric_value(c, metric).ok_or_else(|| AnalysisError::EmptyMetric {
                        line: c.line,
                        field: metric.column(),
                        unit: label.to_string(),
                    })?);
                }
            }
            CrossedMatrix::new(self.recordings.len(), self.plan.seeds.len(), values).map_err(stats)
        };
        let treated = arr(&self.plan.contrast.treated)?;
        let reference = arr(&self.plan.contrast.reference)?;
        let diff = treated.minus(&reference).map_err(stats)?;
        Ok(ArmArrays { treated, reference, diff })
    }

    pub(crate) fn unit(
        &self,
        u: &AnalysisUnit,
        stream: u64,
        warnings: &mut Vec<String>,
    ) -> Result<UnitResult, AnalysisError> {
        let label = u.label();
        let stats = |source| AnalysisError::Stats { unit: label.clone(), source };
        let a = self.arrays(&u.model, u.metric, u.horizon_s, &label)?;
        let (mean_t, mean_r) = (a.treated.mean(), a.reference.mean());
        if mean_r == 0.0 {
            return Err(AnalysisError::ZeroReferenceMean {
                unit: label.clone(),
                arm: self.plan.contrast.reference.clone(),
            });
        }
        let est = &self.plan.estimator;
        let estimate = crossed_mom(&a.diff, est.level, est.df).map_err(stats)?;
        let optimism_pct = optimism(mean_r, mean_t);
        let bootstrap = match self.plan.sensitivity.bootstrap {
            Some(b) => Some(pigeonhole_bootstrap(&a.diff, b.replicates, est.level, b.seed, stream).map_err(stats)?),
            None => None,
        };
        let grouped = if self.plan.sensitivity.grouped == Grouped::ByConditions {
            self.grouped(&a.diff, &label, warnings)?
        } else {
            None
        };
        let mut leave_one_out = Vec::new();
        for &f in &self.plan.sensitivity.leave_one_out {
            leave_one_out.push(self.leave_one_out(&a, f).map_err(stats)?);
        }
        let per_seed_optimism = self
            .plan
            .seeds
            .iter()
            .zip(a.treated.col_means().iter().zip(a.reference.col_means()))
            .map(|(s, (t, r))| SeedOptimism { seed: s.0, optimism_pct: optimism(r, *t) })
            .collect();
        let per_trajectory = self.per_trajectory(&a.diff);
        let conditional = self.conditional(u, &label)?;
        let rule_holds = rule_holds(&self.plan.decision, optimism_pct, &estimate);
        let intervals = if self.options.compare_intervals {
            let b = self.plan.sensitivity.bootstrap.map(|b| (b.replicates, b.seed)).unwrap_or((9999, 0));
            Some(compare_intervals(&a.diff, est.level, b.0, b.1, stream).map_err(stats)?)
        } else {
            None
        };
        Ok(UnitResult {
            role: u.role,
            model: u.model.clone(),
            metric: u.metric,
            horizon_s: u.horizon_s,
            mean_treated: mean_t,
            mean_reference: mean_r,
            optimism_pct,
            estimate,
            bootstrap,
            grouped,
            leave_one_out,
            per_seed_optimism,
            per_trajectory,
            conditional,
            rule_holds,
            intervals,
        })
    }

    /// Average d within condition groups (e.g. trajectory x speed), then the
    /// same crossed estimator on the groups x seeds array.
    fn grouped(
        &self,
        diff: &CrossedMatrix,
        label: &str,
        warnings: &mut Vec<String>,
    ) -> Result<Option<GroupedResult>, AnalysisError> {
        let name = |r: &RecordingLabels| -> String {
            self.plan
                .conditions
                .iter()
                .map(|c| match c {
                    Condition::Trajectory => r.trajectory.as_str(),
                    Condition::Speed => r.speed.as_str(),
                })
                .collect::<Vec<_>>()
                .join(" / ")
        };
        let mut groups: Vec<String> = self.recordings.iter().map(name).collect();
        groups.sort();
        groups.dedup();
        if groups.len() < 2 {
            warnings.push(format!(
                "{label}: grouped sensitivity skipped: the recordings form {} condition group(s), it needs at least 2",
                groups.len()
            ));
            return Ok(None);
        }
        let index: Vec<usize> = self
            .recordings
            .iter()
            .map(|r| groups.iter().position(|g| *g == name(r)).expect("group was collected"))
            .collect();
        let per_group = (0..groups.len()).map(|g| index.iter().filter(|&&x| x == g).count()).collect();
        let stats = |source| AnalysisError::Stats { unit: label.to_string(), source };
        let m = diff.group_rows(&index, groups.len()).map_err(stats)?;
        let estimate = crossed_mom(&m, self.plan.estimator.level, self.plan.estimator.df).map_err(stats)?;
        Ok(Some(GroupedResult { groups, recordings_per_group: per_group, estimate }))
    }

    fn leave_one_out(&self, a: &ArmArrays, factor: Factor) -> Result<LeaveOneOut, StatsError> {
        let n = match factor {
            Factor::Seed => a.diff.cols(),
            Factor::Recording => a.diff.rows(),
        };
        let est = &self.plan.estimator;
        let mut fits = Vec::with_capacity(n);
        for k in 0..n {
            let drop = |m: &CrossedMatrix| match factor {
                Factor::Seed => m.without_col(k),
                Factor::Recording => m.without_row(k),
            };
            let e = crossed_mom(&drop(&a.diff)?, est.level, est.df)?;
            let opt = optimism(drop(&a.reference)?.mean(), drop(&a.treated)?.mean());
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
        })
    }

    fn per_trajectory(&self, diff: &CrossedMatrix) -> Vec<TrajectoryMean> {
        let mut acc: BTreeMap<&str, (usize, f64)> = BTreeMap::new();
        for (i, r) in self.recordings.iter().enumerate() {
            let e = acc.entry(r.trajectory.as_str()).or_insert((0, 0.0));
            e.0 += 1;
            e.1 += diff.row(i).iter().sum::<f64>() / diff.cols() as f64;
        }
        acc.into_iter()
            .map(|(t, (n, s))| TrajectoryMean {
                trajectory: t.to_string(),
                recordings: n,
                mean_difference: s / n as f64,
            })
            .collect()
    }

    fn conditional(&self, u: &AnalysisUnit, label: &str) -> Result<ConditionalSummary, AnalysisError> {
        let mut sums = [(0.0, 0usize, 0u64, 0u64); 2];
        let mut values = [Vec::new(), Vec::new()];
        let mut without = 0;
        let arms = [&self.plan.contrast.treated, &self.plan.contrast.reference];
        for (k, arm) in arms.iter().enumerate() {
            for r in self.recordings {
                for s in &self.plan.seeds {
                    let c = self.cell(&u.model, arm, s.0, &r.recording, u.horizon_s);
                    sums[k].2 += c.n_divergent;
                    sums[k].3 += c.n_starts;
                    match c.conditional_position_rmse_m {
                        Some(v) => {
                            sums[k].0 += v;
                            sums[k].1 += 1;
                            values[k].push(v);
                        }
                        None => without += 1,
                    }
                }
            }
        }
        let mean = |(s, n, _, _): (f64, usize, u64, u64)| (n > 0).then(|| s / n as f64);
        let difference = if without == 0 {
            let (i, j) = (self.recordings.len(), self.plan.seeds.len());
            let diff: Vec<f64> = values[0].iter().zip(&values[1]).map(|(t, r)| t - r).collect();
            let stats = |source| AnalysisError::Stats { unit: format!("{label} (conditional RMSE)"), source };
            let m = CrossedMatrix::new(i, j, diff).map_err(stats)?;
            Some(crossed_mom(&m, self.plan.estimator.level, self.plan.estimator.df).map_err(stats)?)
        } else {
            None
        };
        Ok(ConditionalSummary {
            mean_conditional_treated: mean(sums[0]),
            mean_conditional_reference: mean(sums[1]),
            divergent_treated: sums[0].2,
            starts_treated: sums[0].3,
            divergent_reference: sums[1].2,
            starts_reference: sums[1].3,
            difference,
            cells_without_finite_rollout: without,
        })
    }

    pub(crate) fn interaction(&self, ix: &InteractionUnit, stream: u64) -> Result<InteractionResult, AnalysisError> {
        let label = format!("interaction {} - {} at {} s", ix.left, ix.right, ix.horizon_s);
        let stats = |source| AnalysisError::Stats { unit: label.clone(), source };
        let l = self.arrays(&ix.left, ix.metric, ix.horizon_s, &label)?;
        let r = self.arrays(&ix.right, ix.metric, ix.horizon_s, &label)?;
        let delta = l.diff.minus(&r.diff).map_err(stats)?;
        let est = &self.plan.estimator;
        let estimate = crossed_mom(&delta, est.level, est.df).map_err(stats)?;
        let bootstrap = match self.plan.sensitivity.bootstrap {
            Some(b) => Some(pigeonhole_bootstrap(&delta, b.replicates, est.level, b.seed, stream).map_err(stats)?),
            None => None,
        };
        Ok(InteractionResult {
            metric: ix.metric,
            horizon_s: ix.horizon_s,
            left: ix.left.clone(),
            right: ix.right.clone(),
            estimate,
            bootstrap,
        })
    }
}
