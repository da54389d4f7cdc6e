//! One analysis unit: the two arms' I x J arrays, the crossed estimate of
//! their difference, and every preregistered sensitivity analysis.
//!
//! Arrays are grids with optional cells. Under the crossed MoM every cell
//! is present (the index refuses incomplete data); under `estimate reml ...
//! missing allow` a cell may be absent, and every summary is taken over the
//! cells where both arms have a value, so the contrast stays paired.

use std::collections::BTreeMap;

mod around;
mod compared;
pub(crate) mod glmm;
mod grid;
mod loo;

use grid::Grid;

use super::decision::rule_holds;
use super::index::Indexed;
use super::types::*;
use super::AnalysisError;
use crate::cells::Cell;
use crate::design::{Condition, Estimator, EstimatorKind, Grouped, Metric};
use crate::plan::{AnalysisUnit, InteractionUnit, Plan};
use crossaudit_stats::{
    crossed_mom, crossed_reml, pigeonhole_bootstrap, BootstrapInterval, CrossedEstimate, CrossedMatrix, DfRule,
    StatsError,
};

/// What every unit's estimation reads: the plan, the indexed cells and the
/// evaluation recordings in row order.
pub(crate) struct Ctx<'a> {
    pub(crate) plan: &'a Plan,
    pub(crate) data: &'a Indexed<'a>,
    pub(crate) recordings: &'a [RecordingLabels],
    pub(crate) options: AnalyzeOptions,
}

/// The two arms' grids for one unit, each masked to the cells where both
/// arms have a value, and their difference.
struct ArmArrays {
    treated: Grid,
    reference: Grid,
    diff: Grid,
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

/// The crossed estimate of the mean of a rows x cols grid (row-major,
/// `None` where a cell is missing) under `est`. The MoM needs every cell;
/// REML takes whatever cells are present.
pub(crate) fn estimate_grid(
    est: &Estimator,
    rows: usize,
    cols: usize,
    v: Vec<Option<f64>>,
) -> Result<CrossedEstimate, StatsError> {
    if let Some((k, x)) = v.iter().enumerate().find_map(|(k, x)| x.filter(|x| !x.is_finite()).map(|x| (k, x))) {
        return Err(StatsError::NonFinite { row: k / cols.max(1), col: k % cols.max(1), value: x });
    }
    estimate_of(est, &Grid::of(rows, cols, v))
}

/// [`estimate_grid`] of a grid held elsewhere: it is read, not copied (at
/// 10M cells a grid is 80 MB), and its values are taken once.
fn estimate_of(est: &Estimator, g: &Grid) -> Result<CrossedEstimate, StatsError> {
    if g.seed_invariant() {
        if let Some(m) = g.complete() {
            // Every recording's value is the same for every seed: the
            // seeds add no variation, and the interval's df come from the
            // recordings.
            return crossed_mom(&m?, est.level, DfRule::RecordingsMinusOne);
        }
    }
    match est.kind {
        EstimatorKind::Reml => crossed_reml(&g.cells(), g.rows, g.cols, est.level, est.df),
        EstimatorKind::CrossedMom => match g.complete() {
            Some(m) => crossed_mom(&m?, est.level, est.df),
            None => Err(StatsError::Invalid(format!(
                "{} of {} cells are missing and the method of moments needs every one",
                g.missing(),
                g.v.len()
            ))),
        },
    }
}

/// The estimator of a contrast whose array `diff` lacks pairs, where the
/// plan's cannot take it: REML with Kenward-Roger df in place of the
/// crossed MoM, which needs every cell ([`Ctx::unit`]'s warning says so).
fn paired_estimator(est: &Estimator, diff: &Grid) -> Option<Estimator> {
    (est.kind == EstimatorKind::CrossedMom && diff.missing() > 0).then_some(Estimator {
        kind: EstimatorKind::Reml,
        df: DfRule::KenwardRoger,
        missing_allowed: true,
        ..*est
    })
}

/// The value of `metric` in a cell, if it has one.
pub(crate) fn value_of(c: &Cell, metric: Metric) -> Option<f64> {
    metric_value(c, metric)
}

impl Ctx<'_> {
    /// The crossed estimate of a grid's mean under the plan's estimator. The
    /// MoM needs every cell; REML takes whatever cells are present.
    fn estimate(&self, g: &Grid) -> Result<CrossedEstimate, StatsError> {
        estimate_of(&self.plan.estimator, g)
    }

    /// One arm's grid of `metric`. A cell is missing where the per-cell
    /// file has none (which the index allows only under `missing allow`)
    /// and where the metric is empty: the conditional position, velocity
    /// and attitude errors are over finite rollouts, so a cell whose every
    /// start diverged has none (the cells reader checks exactly that).
    fn grid(&self, model: &str, arm: &str, metric: Metric, h: f64) -> Grid {
        use rayon::prelude::*;
        let (rows, cols) = (self.recordings.len(), self.plan.seeds.len());
        // A row of the grid per task: its cells lie apart in memory (the
        // file's order is rarely the grid's), and their reads wait on every
        // core at once. Each value lands in its place: the same grid at any
        // thread count.
        let mut v = vec![f64::NAN; rows * cols];
        v.par_chunks_mut(cols.max(1)).zip(self.recordings).for_each(|(out, r)| {
            let row = self.data.row(model, arm, &r.recording, h);
            for (j, x) in out.iter_mut().enumerate() {
                *x = row.and_then(|row| row.get(j)).and_then(|c| metric_value(c, metric)).unwrap_or(f64::NAN);
            }
        });
        Grid { rows, cols, v }
    }

    fn arrays(&self, model: &str, metric: Metric, h: f64) -> ArmArrays {
        let (treated, reference) = rayon::join(
            || self.grid(model, &self.plan.contrast.treated, metric, h),
            || self.grid(model, &self.plan.contrast.reference, metric, h),
        );
        let diff = treated.minus(&reference);
        ArmArrays { treated: treated.masked(&diff), reference: reference.masked(&diff), diff }
    }

    /// The context in which a contrast whose array `diff` has is estimated:
    /// this one, unless pairs are missing (a cell whose every start
    /// diverged has no finite-rollout error) under the crossed MoM, which
    /// needs every cell. Then the contrast stays paired, over the pairs
    /// where both arms have a value, and every estimate of it is REML with
    /// Kenward-Roger df, as the conditional RMSE's is; the warning says so.
    fn paired(&self, diff: &Grid, label: &str, warnings: &mut Vec<String>) -> Option<Plan> {
        let dropped = diff.missing();
        if dropped == 0 {
            return None;
        }
        let mom = self.plan.estimator.kind == EstimatorKind::CrossedMom;
        warnings.push(format!(
            "{label}: {dropped} of {} recording x seed pairs lack a value in one arm or both (every start of a cell diverged, so its finite-rollout error is empty, or the cell is missing); every estimate of this unit uses the other {}{}",
            diff.v.len(),
            diff.v.len() - dropped,
            if mom { ", by REML with Kenward-Roger df: the crossed method of moments needs every cell" } else { "" }
        ));
        paired_estimator(&self.plan.estimator, diff).map(|estimator| Plan { estimator, ..self.plan.clone() })
    }

    pub(crate) fn unit(
        &self,
        u: &AnalysisUnit,
        stream: u64,
        warnings: &mut Vec<String>,
    ) -> Result<UnitResult, AnalysisError> {
        let label = u.label();
        let a = self.arrays(&u.model, u.metric, u.horizon_s);
        match self.paired(&a.diff, &label, warnings) {
            Some(plan) => Ctx { plan: &plan, ..*self }.unit_of(u, a, &label, stream, warnings),
            None => self.unit_of(u, a, &label, stream, warnings),
        }
    }

    /// [`Ctx::unit`] on its arrays `a`, under this context's estimator.
    fn unit_of(
        &self,
        u: &AnalysisUnit,
        a: ArmArrays,
        label: &str,
        stream: u64,
        warnings: &mut Vec<String>,
    ) -> Result<UnitResult, AnalysisError> {
        let label = label.to_string();
        let stats = |source| AnalysisError::Stats { unit: label.clone(), source };
        let (mean_t, mean_r) = (a.treated.mean(), a.reference.mean());
        if mean_r == 0.0 {
            return Err(AnalysisError::ZeroReferenceMean {
                unit: label.clone(),
                arm: self.plan.contrast.reference.clone(),
            });
        }
        self.degenerate(u, &a, &label)?;
        let estimate = self.estimate(&a.diff).map_err(stats)?;
        let optimism_pct = optimism(mean_r, mean_t);
        let complete = a.diff.complete().transpose().map_err(stats)?;
        let rule_holds = rule_holds(&self.plan.decision, optimism_pct, &estimate);
        // The sensitivities are independent of each other: they run at
        // once, each with its own warnings, taken (as errors are) in the
        // order the report gives them, whatever the thread count.
        let mut w: [Vec<String>; 4] = Default::default();
        let [w_ratio, w_boot, w_grouped, w_loo] = &mut w;
        let ((optimism_interval, bootstrap), ((grouped, leave_one_out), (conditional, intervals))) = rayon::join(
            || {
                rayon::join(
                    || self.optimism_interval(&a, optimism_pct, &label, w_ratio),
                    || self.bootstrap(complete.as_ref(), stream, &label, w_boot),
                )
            },
            || {
                rayon::join(
                    || {
                        rayon::join(
                            || self.grouped(&a.diff, &label, w_grouped),
                            || self.leave_one_out_all(&a, complete.as_ref(), (&label, rule_holds), w_loo),
                        )
                    },
                    || {
                        rayon::join(
                            || self.conditional(u, &label),
                            || self.compared(&a.diff, complete.as_ref(), stream),
                        )
                    },
                )
            },
        );
        let (bootstrap, grouped, leave_one_out) = (bootstrap.map_err(stats)?, grouped?, leave_one_out?);
        let (conditional, intervals) = (conditional?, intervals.map_err(stats)?);
        warnings.extend(w.into_iter().flatten());
        let per_seed_optimism = self.per_seed_optimism(&a);
        let per_trajectory = self.per_trajectory(&a.diff);
        Ok(UnitResult {
            role: u.role,
            model: u.model.clone(),
            metric: u.metric,
            horizon_s: u.horizon_s,
            mean_treated: mean_t,
            mean_reference: mean_r,
            optimism_pct,
            optimism_interval,
            seed_invariant: a.treated.seed_invariant() && a.reference.seed_invariant(),
            estimate,
            bootstrap,
            grouped,
            leave_one_out,
            per_seed_optimism,
            per_trajectory,
            conditional,
            rule_holds,
            intervals,
            glmm: u.glmm.then(|| self.glmm(u)),
        })
    }

    /// The preregistered pigeonhole bootstrap of a unit's complete array
    /// of differences; skipped, with a warning, when pairs are missing.
    fn bootstrap(
        &self,
        complete: Option<&CrossedMatrix>,
        stream: u64,
        label: &str,
        warnings: &mut Vec<String>,
    ) -> Result<Option<BootstrapInterval>, StatsError> {
        match (self.plan.sensitivity.bootstrap, complete) {
            (Some(b), Some(m)) => {
                pigeonhole_bootstrap(m, b.replicates, self.plan.estimator.level, b.seed, stream).map(Some)
            }
            (Some(_), None) => {
                warnings.push(format!("{label}: pigeonhole bootstrap skipped: it resamples a complete array"));
                Ok(None)
            }
            (None, _) => Ok(None),
        }
    }

    /// Optimism within each seed (its column of both arms), for the seeds
    /// with a value.
    fn per_seed_optimism(&self, a: &ArmArrays) -> Vec<SeedOptimism> {
        let seeds = self.plan.seeds.iter().enumerate();
        seeds
            .map(|(j, s)| (s, a.treated.col_mean(j), a.reference.col_mean(j)))
            .filter(|(_, t, _)| !t.is_nan())
            .map(|(s, t, r)| SeedOptimism { seed: s.0, optimism_pct: optimism(r, t) })
            .collect()
    }

    /// Average d within condition groups (e.g. trajectory x speed), then the
    /// same crossed estimator on the groups x seeds array, where the design
    /// asks for it.
    fn grouped(
        &self,
        diff: &Grid,
        label: &str,
        warnings: &mut Vec<String>,
    ) -> Result<Option<GroupedResult>, AnalysisError> {
        if self.plan.sensitivity.grouped != Grouped::ByConditions {
            return Ok(None);
        }
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
        // Each recording's group by binary search, and the counts in one
        // pass: O(I log G), where a search per group was O(I G).
        let index: Vec<usize> =
            self.recordings.iter().map(|r| groups.binary_search(&name(r)).unwrap_or_default()).collect();
        let mut per_group = vec![0usize; groups.len()];
        index.iter().for_each(|&g| per_group[g] += 1);
        let stats = |source| AnalysisError::Stats { unit: label.to_string(), source };
        let estimate = match diff.complete() {
            // Complete: the group means of the balanced array (bit for bit
            // the first wave's computation).
            Some(m) => {
                let g = m.map_err(stats)?.group_rows(&index, groups.len()).map_err(stats)?;
                let grid = Grid { rows: g.rows(), cols: g.cols(), v: g.into_values() };
                self.estimate(&grid).map_err(stats)?
            }
            // Incomplete: each group x seed mean over the cells present.
            // One pass over the cells, recordings in order, so each sum
            // adds its values in the order the per-group filter did.
            None => {
                let (mut sum, mut n) = (vec![0.0; groups.len() * diff.cols], vec![0usize; groups.len() * diff.cols]);
                for (i, &g) in index.iter().enumerate() {
                    for j in 0..diff.cols {
                        if let Some(x) = diff.get(i, j) {
                            sum[g * diff.cols + j] += x;
                            n[g * diff.cols + j] += 1;
                        }
                    }
                }
                let v = sum.iter().zip(&n).map(|(s, &n)| (n > 0).then(|| s / n as f64));
                self.estimate(&Grid::of(groups.len(), diff.cols, v)).map_err(stats)?
            }
        };
        Ok(Some(GroupedResult { groups, recordings_per_group: per_group, estimate }))
    }

    fn per_trajectory(&self, diff: &Grid) -> Vec<TrajectoryMean> {
        let mut acc: BTreeMap<&str, (usize, f64)> = BTreeMap::new();
        for (i, r) in self.recordings.iter().enumerate() {
            let m = diff.row_mean(i);
            if m.is_nan() {
                continue;
            }
            let e = acc.entry(r.trajectory.as_str()).or_insert((0, 0.0));
            e.0 += 1;
            e.1 += m;
        }
        acc.into_iter()
            .map(|(t, (n, s))| TrajectoryMean {
                trajectory: t.to_string(),
                recordings: n,
                mean_difference: s / n as f64,
            })
            .collect()
    }

    /// Divergence counts over every cell present, and the conditional-RMSE
    /// contrast over the recording x seed pairs where both arms have a
    /// finite value (a cell in which every start diverged has none). The
    /// contrast uses the plan's estimator when no pair is dropped; otherwise
    /// REML with the plan's df when the plan's estimator is REML, and REML
    /// with Kenward-Roger df when it is the method of moments (which needs
    /// a complete array).
    fn conditional(&self, u: &AnalysisUnit, label: &str) -> Result<ConditionalSummary, AnalysisError> {
        let mut counts = [(0u64, 0u64); 2];
        let mut without = 0;
        let arms = [&self.plan.contrast.treated, &self.plan.contrast.reference];
        let (rows, cols) = (self.recordings.len(), self.plan.seeds.len());
        let mut grids = [Vec::with_capacity(rows * cols), Vec::with_capacity(rows * cols)];
        for (k, arm) in arms.iter().enumerate() {
            for r in self.recordings {
                let row = self.data.row(&u.model, arm, &r.recording, u.horizon_s);
                for j in 0..cols {
                    let c = row.and_then(|row| row.get(j));
                    if let Some(c) = c {
                        counts[k].0 += u64::from(c.n_divergent);
                        counts[k].1 += u64::from(c.n_starts);
                        if c.conditional_position_rmse_m.is_none() {
                            without += 1;
                        }
                    }
                    grids[k].push(c.and_then(|c| c.conditional_position_rmse_m).unwrap_or(f64::NAN));
                }
            }
        }
        let [t, r] = grids.map(|v| Grid { rows, cols, v });
        let diff = t.minus(&r);
        let (t, r) = (t.masked(&diff), r.masked(&diff));
        let stats = |source| AnalysisError::Stats { unit: format!("{label} (conditional RMSE)"), source };
        let pairs = diff.v.len() - diff.missing();
        let mut difference_error = None;
        let difference = if pairs == 0 {
            None
        } else if diff.missing() == 0 {
            Some(self.estimate(&diff).map_err(stats)?)
        } else {
            // An incomplete array: the preregistered estimator when it is
            // REML (which takes whatever cells are present), REML with
            // Kenward-Roger df when it is the method of moments (which
            // needs every cell); the report says which. Too few pairs left
            // for a crossed model: no interval, and the reason is kept.
            let est = &self.plan.estimator;
            let rule = match est.kind {
                EstimatorKind::Reml => est.df,
                EstimatorKind::CrossedMom => DfRule::KenwardRoger,
            };
            match crossed_reml(&diff.cells(), rows, cols, est.level, rule) {
                Ok(e) => Some(e),
                Err(e) => {
                    difference_error = Some(e.to_string());
                    None
                }
            }
        };
        let mean = |g: &Grid| (pairs > 0).then(|| g.mean());
        Ok(ConditionalSummary {
            mean_conditional_treated: mean(&t),
            mean_conditional_reference: mean(&r),
            divergent_treated: counts[0].0,
            starts_treated: counts[0].1,
            divergent_reference: counts[1].0,
            starts_reference: counts[1].1,
            difference,
            cells_without_finite_rollout: without,
            pairs_dropped: diff.missing(),
            difference_error,
        })
    }

    pub(crate) fn interaction(&self, ix: &InteractionUnit, stream: u64) -> Result<InteractionResult, AnalysisError> {
        let label = format!("interaction {} - {} at {} s", ix.left, ix.right, ix.horizon_s);
        let stats = |source| AnalysisError::Stats { unit: label.clone(), source };
        let l = self.arrays(&ix.left, ix.metric, ix.horizon_s);
        let r = self.arrays(&ix.right, ix.metric, ix.horizon_s);
        let delta = l.diff.minus(&r.diff);
        // Pairs without a finite-rollout error: paired, as each model's unit.
        let paired = paired_estimator(&self.plan.estimator, &delta);
        let est = paired.as_ref().unwrap_or(&self.plan.estimator);
        let estimate = estimate_of(est, &delta).map_err(stats)?;
        let bootstrap = match (self.plan.sensitivity.bootstrap, delta.complete()) {
            (Some(b), Some(m)) => {
                Some(pigeonhole_bootstrap(&m.map_err(stats)?, b.replicates, est.level, b.seed, stream).map_err(stats)?)
            }
            _ => None,
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
