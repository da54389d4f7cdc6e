//! Stage 4: per-cell data -> [`Analysis`]. Everything in DESIGN.md's
//! Analysis paragraph, for every endpoint unit and model, plus the decision
//! on the primary endpoint.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::cells::Cell;
use crate::design::{Condition, Design, Factor, Grouped, Metric, Quantity, Role};
use crate::pipeline::{self, InteractionUnit, Plan, Unit};
use crate::stats::{
    compare_intervals, crossed_mom, pigeonhole_bootstrap, BootstrapInterval, CrossedEstimate, CrossedMatrix,
    IntervalEstimate, StatsError,
};

#[derive(Debug, Clone, Copy, Default)]
pub struct AnalyzeOptions {
    /// Add every interval estimator side by side for each contrast.
    pub compare_intervals: bool,
}

/// Why per-cell data cannot be analysed under a design.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    #[error("line {line}, field `{field}`: {value:?} is not in the design ({known})")]
    NotInDesign { line: u64, field: &'static str, value: String, known: String },
    #[error("line {line}: duplicate cell (model={model} arm={arm} seed={seed} recording={recording} horizon={horizon} s), first seen on line {first_line}")]
    Duplicate { line: u64, first_line: u64, model: String, arm: String, seed: u64, recording: String, horizon: f64 },
    #[error("line {line}, field `{field}`: recording {recording} is labelled {value:?} here but {first:?} on line {first_line}")]
    InconsistentLabel {
        line: u64,
        field: &'static str,
        recording: String,
        value: String,
        first: String,
        first_line: u64,
    },
    #[error(
        "{count} missing cell(s); the crossed design needs every model x arm x seed x recording x horizon:\n{list}"
    )]
    Missing { count: usize, list: String },
    #[error("the per-cell data has {found} recording(s); the design declares `evaluation {declared}`")]
    RecordingCount { found: usize, declared: usize },
    #[error("line {line}, field `{field}`: empty, but {unit} needs a value here")]
    EmptyMetric { line: u64, field: &'static str, unit: String },
    #[error("{unit}: the {arm} arm's mean is zero, so optimism (a percentage of it) is undefined")]
    ZeroReferenceMean { unit: String, arm: String },
    #[error("{unit}: {source}")]
    Stats { unit: String, source: StatsError },
}

/// The whole analysis, serialized as results.json.
#[derive(Debug, Clone, Serialize)]
pub struct Analysis {
    pub study: String,
    pub design_sha256: Option<String>,
    pub exploratory: bool,
    pub treated: String,
    pub reference: String,
    pub level: f64,
    pub recordings: Vec<RecordingLabels>,
    pub seeds: Vec<u64>,
    pub units: Vec<UnitResult>,
    pub interactions: Vec<InteractionResult>,
    pub decision: Decision,
    pub warnings: Vec<String>,
    /// Figure files (relative to the report), when a run drew them.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub figures: Vec<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct RecordingLabels {
    pub recording: String,
    pub trajectory: String,
    pub speed: String,
}

#[derive(Debug, Clone, Serialize)]
pub struct UnitResult {
    pub role: Role,
    pub model: String,
    pub metric: Metric,
    pub horizon_s: f64,
    pub mean_treated: f64,
    pub mean_reference: f64,
    /// 100 (mean_reference - mean_treated) / mean_reference.
    pub optimism_pct: f64,
    pub estimate: CrossedEstimate,
    pub bootstrap: Option<BootstrapInterval>,
    pub grouped: Option<GroupedResult>,
    pub leave_one_out: Vec<LeaveOneOut>,
    pub per_seed_optimism: Vec<SeedOptimism>,
    pub per_trajectory: Vec<TrajectoryMean>,
    pub conditional: ConditionalSummary,
    /// Whether this unit alone would meet the decision rule.
    pub rule_holds: bool,
    pub intervals: Option<Vec<IntervalEstimate>>,
}

#[derive(Debug, Clone, Serialize)]
pub struct GroupedResult {
    /// Group labels, in row order of the grouped matrix.
    pub groups: Vec<String>,
    pub recordings_per_group: Vec<usize>,
    pub estimate: CrossedEstimate,
}

#[derive(Debug, Clone, Serialize)]
pub struct LeaveOneOut {
    pub factor: Factor,
    /// How many fits (one per level left out).
    pub fits: usize,
    pub mean_min: f64,
    pub mean_max: f64,
    pub upper_min: f64,
    pub upper_max: f64,
    pub optimism_min: f64,
    pub optimism_max: f64,
    /// Fits in which the decision rule still holds.
    pub rule_holds: usize,
}

#[derive(Debug, Clone, Serialize)]
pub struct SeedOptimism {
    pub seed: u64,
    pub optimism_pct: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct TrajectoryMean {
    pub trajectory: String,
    pub recordings: usize,
    pub mean_difference: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct ConditionalSummary {
    /// Mean conditional-on-finite position RMSE over cells that have one.
    pub mean_conditional_treated: Option<f64>,
    pub mean_conditional_reference: Option<f64>,
    pub divergent_treated: u64,
    pub starts_treated: u64,
    pub divergent_reference: u64,
    pub starts_reference: u64,
    /// Crossed interval of the conditional RMSE difference; absent when a
    /// cell has no finite rollout.
    pub difference: Option<CrossedEstimate>,
    pub cells_without_finite_rollout: usize,
}

#[derive(Debug, Clone, Serialize)]
pub struct InteractionResult {
    pub metric: Metric,
    pub horizon_s: f64,
    pub left: String,
    pub right: String,
    pub estimate: CrossedEstimate,
    pub bootstrap: Option<BootstrapInterval>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Decision {
    pub name: String,
    pub rule: String,
    pub unit: String,
    pub holds: bool,
    pub conditions: Vec<ConditionOutcome>,
}

#[derive(Debug, Clone, Serialize)]
pub struct ConditionOutcome {
    pub condition: String,
    pub quantity: Quantity,
    pub value: f64,
    pub holds: bool,
}

impl Decision {
    /// One line: the decision and, when it fails, which part failed.
    pub fn summary(&self) -> String {
        let parts: Vec<String> = self
            .conditions
            .iter()
            .map(|c| {
                format!(
                    "{} ({} = {}: {})",
                    c.condition,
                    c.quantity.name(),
                    fmt_num(c.value),
                    if c.holds { "met" } else { "NOT met" }
                )
            })
            .collect();
        let verdict = if self.holds { self.name.to_uppercase() } else { format!("NOT {}", self.name.to_uppercase()) };
        format!("decision: {verdict} on {}: {}", self.unit, parts.join("; "))
    }
}

pub fn fmt_num(v: f64) -> String {
    if v.is_nan() {
        "NA".into()
    } else {
        format!("{v:.4}")
    }
}

/// Cells indexed by (model, arm, seed, recording, horizon).
type Key = (String, String, u64, String, u64);

fn key(c: &Cell) -> Key {
    (c.model.clone(), c.arm.clone(), c.seed, c.recording.clone(), c.horizon_s.to_bits())
}

/// Horizons in CSVs are written by people and tools alike; match them to the
/// design's to a nanosecond.
fn same_horizon(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

/// Runs the analysis the design preregistered on per-cell data.
pub fn analyze(design: &Design, cells: &[Cell], options: AnalyzeOptions) -> Result<Analysis, AnalysisError> {
    let plan = pipeline::compile(design);
    let mut warnings = Vec::new();
    let data = index(design, &plan, cells)?;
    let recordings: Vec<RecordingLabels> = data
        .labels
        .iter()
        .map(|(r, (t, s, _))| RecordingLabels { recording: r.clone(), trajectory: t.clone(), speed: s.clone() })
        .collect();
    if recordings.len() != design.recording.evaluation {
        return Err(AnalysisError::RecordingCount { found: recordings.len(), declared: design.recording.evaluation });
    }
    check_complete(design, &plan, &data, &recordings)?;

    let ctx = Ctx { design, data: &data, recordings: &recordings, options };
    // Units are independent (each has its own bootstrap stream), so they
    // run in parallel; results and warnings are collected in plan order, so
    // the output does not depend on the thread count.
    use rayon::prelude::*;
    let per_unit: Vec<Result<(UnitResult, Vec<String>), AnalysisError>> = plan
        .units
        .par_iter()
        .enumerate()
        .map(|(k, unit)| {
            let mut w = Vec::new();
            ctx.unit(unit, k as u64, &mut w).map(|u| (u, w))
        })
        .collect();
    let mut units = Vec::new();
    for r in per_unit {
        let (u, w) = r?;
        units.push(u);
        warnings.extend(w);
    }
    let interactions = plan
        .interactions
        .par_iter()
        .enumerate()
        .map(|(k, ix)| ctx.interaction(ix, (plan.units.len() + k) as u64))
        .collect::<Result<Vec<_>, _>>()?;
    let primary = units.iter().find(|u| u.role == Role::Primary).expect("a validated design has one primary endpoint");
    let decision = decide(design, primary);
    Ok(Analysis {
        study: design.study.clone(),
        design_sha256: None,
        exploratory: false,
        treated: design.contrast.treated.clone(),
        reference: design.contrast.reference.clone(),
        level: design.estimator.level,
        recordings,
        seeds: design.seeds.iter().map(|s| s.0).collect(),
        units,
        interactions,
        decision,
        warnings,
        figures: Vec::new(),
    })
}

struct Indexed<'a> {
    cells: BTreeMap<Key, &'a Cell>,
    /// recording -> (trajectory, speed, first line)
    labels: BTreeMap<String, (String, String, u64)>,
}

fn index<'a>(design: &Design, plan: &Plan, cells: &'a [Cell]) -> Result<Indexed<'a>, AnalysisError> {
    let models: Vec<&str> = design.models.iter().map(|m| m.name.as_str()).collect();
    let arms: Vec<&str> = design.arms.iter().map(|a| a.name.as_str()).collect();
    let mut horizons: Vec<f64> = plan.units.iter().map(|u| u.horizon_s).collect();
    horizons.sort_by(f64::total_cmp);
    horizons.dedup();
    let mut out = Indexed { cells: BTreeMap::new(), labels: BTreeMap::new() };
    for c in cells {
        let not_in = |field: &'static str, value: String, known: String| AnalysisError::NotInDesign {
            line: c.line,
            field,
            value,
            known,
        };
        if !models.contains(&c.model.as_str()) {
            return Err(not_in("model", c.model.clone(), format!("models: {}", models.join(", "))));
        }
        if !arms.contains(&c.arm.as_str()) {
            return Err(not_in("arm", c.arm.clone(), format!("arms: {}", arms.join(", "))));
        }
        if !design.seeds.iter().any(|s| s.0 == c.seed) {
            let (a, b) = (design.seeds[0].0, design.seeds[design.seeds.len() - 1].0);
            return Err(not_in("seed", c.seed.to_string(), format!("{} seeds, {a}..{b}", design.seeds.len())));
        }
        let Some(&h) = horizons.iter().find(|&&h| same_horizon(h, c.horizon_s)) else {
            let known = horizons.iter().map(|h| format!("{h} s")).collect::<Vec<_>>().join(", ");
            return Err(not_in("horizon_s", c.horizon_s.to_string(), format!("endpoint horizons: {known}")));
        };
        let mut k = key(c);
        k.4 = h.to_bits();
        if let Some(first) = out.cells.get(&k) {
            return Err(AnalysisError::Duplicate {
                line: c.line,
                first_line: first.line,
                model: c.model.clone(),
                arm: c.arm.clone(),
                seed: c.seed,
                recording: c.recording.clone(),
                horizon: h,
            });
        }
        out.cells.insert(k, c);
        match out.labels.get(&c.recording) {
            None => {
                out.labels.insert(c.recording.clone(), (c.trajectory.clone(), c.speed.clone(), c.line));
            }
            Some((t, s, first_line)) => {
                for (field, value, first) in [("trajectory", &c.trajectory, t), ("speed", &c.speed, s)] {
                    if value != first {
                        return Err(AnalysisError::InconsistentLabel {
                            line: c.line,
                            field,
                            recording: c.recording.clone(),
                            value: value.clone(),
                            first: first.clone(),
                            first_line: *first_line,
                        });
                    }
                }
            }
        }
    }
    Ok(out)
}

fn check_complete(
    design: &Design,
    plan: &Plan,
    data: &Indexed,
    recordings: &[RecordingLabels],
) -> Result<(), AnalysisError> {
    let mut missing = Vec::new();
    let mut seen = Vec::new();
    for u in &plan.units {
        if seen.contains(&(u.model.clone(), u.horizon_s.to_bits())) {
            continue;
        }
        seen.push((u.model.clone(), u.horizon_s.to_bits()));
        for arm in [&design.contrast.treated, &design.contrast.reference] {
            for s in &design.seeds {
                for r in recordings {
                    let k = (u.model.clone(), arm.clone(), s.0, r.recording.clone(), u.horizon_s.to_bits());
                    if !data.cells.contains_key(&k) {
                        missing.push(format!(
                            "  model={} arm={} seed={} recording={} horizon={} s",
                            u.model, arm, s.0, r.recording, u.horizon_s
                        ));
                    }
                }
            }
        }
    }
    if missing.is_empty() {
        return Ok(());
    }
    let count = missing.len();
    let mut list: Vec<String> = missing.into_iter().take(10).collect();
    if count > 10 {
        list.push(format!("  ... and {} more", count - 10));
    }
    Err(AnalysisError::Missing { count, list: list.join("\n") })
}

struct Ctx<'a> {
    design: &'a Design,
    data: &'a Indexed<'a>,
    recordings: &'a [RecordingLabels],
    options: AnalyzeOptions,
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
        let k = (model.to_string(), arm.to_string(), seed, recording.to_string(), h.to_bits());
        self.data.cells[&k]
    }

    fn arrays(&self, model: &str, metric: Metric, h: f64, label: &str) -> Result<ArmArrays, AnalysisError> {
        let stats = |source| AnalysisError::Stats { unit: label.to_string(), source };
        let arr = |arm: &str| -> Result<CrossedMatrix, AnalysisError> {
            let mut values = Vec::with_capacity(self.recordings.len() * self.design.seeds.len());
            for r in self.recordings {
                for s in &self.design.seeds {
                    let c = self.cell(model, arm, s.0, &r.recording, h);
                    values.push(metric_value(c, metric).ok_or_else(|| AnalysisError::EmptyMetric {
                        line: c.line,
                        field: metric.column(),
                        unit: label.to_string(),
                    })?);
                }
            }
            CrossedMatrix::new(self.recordings.len(), self.design.seeds.len(), values).map_err(stats)
        };
        let treated = arr(&self.design.contrast.treated)?;
        let reference = arr(&self.design.contrast.reference)?;
        let diff = treated.minus(&reference).map_err(stats)?;
        Ok(ArmArrays { treated, reference, diff })
    }

    fn unit(&self, u: &Unit, stream: u64, warnings: &mut Vec<String>) -> Result<UnitResult, AnalysisError> {
        let label = u.label();
        let stats = |source| AnalysisError::Stats { unit: label.clone(), source };
        let a = self.arrays(&u.model, u.metric, u.horizon_s, &label)?;
        let (mean_t, mean_r) = (a.treated.mean(), a.reference.mean());
        if mean_r == 0.0 {
            return Err(AnalysisError::ZeroReferenceMean {
                unit: label.clone(),
                arm: self.design.contrast.reference.clone(),
            });
        }
        let est = &self.design.estimator;
        let estimate = crossed_mom(&a.diff, est.level, est.df).map_err(stats)?;
        let optimism_pct = optimism(mean_r, mean_t);
        let bootstrap = match self.design.sensitivity.bootstrap {
            Some(b) => Some(pigeonhole_bootstrap(&a.diff, b.replicates, est.level, b.seed, stream).map_err(stats)?),
            None => None,
        };
        let grouped = if self.design.sensitivity.grouped == Grouped::ByConditions {
            self.grouped(&a.diff, &label, warnings)?
        } else {
            None
        };
        let mut leave_one_out = Vec::new();
        for &f in &self.design.sensitivity.leave_one_out {
            leave_one_out.push(self.leave_one_out(&a, f).map_err(stats)?);
        }
        let per_seed_optimism = self
            .design
            .seeds
            .iter()
            .zip(a.treated.col_means().iter().zip(a.reference.col_means()))
            .map(|(s, (t, r))| SeedOptimism { seed: s.0, optimism_pct: optimism(r, *t) })
            .collect();
        let per_trajectory = self.per_trajectory(&a.diff);
        let conditional = self.conditional(u, &label)?;
        let rule_holds = rule_holds(self.design, optimism_pct, &estimate);
        let intervals = if self.options.compare_intervals {
            let b = self.design.sensitivity.bootstrap.map(|b| (b.replicates, b.seed)).unwrap_or((9999, 0));
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
            self.design
                .recording
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
        let estimate = crossed_mom(&m, self.design.estimator.level, self.design.estimator.df).map_err(stats)?;
        Ok(Some(GroupedResult { groups, recordings_per_group: per_group, estimate }))
    }

    fn leave_one_out(&self, a: &ArmArrays, factor: Factor) -> Result<LeaveOneOut, StatsError> {
        let n = match factor {
            Factor::Seed => a.diff.cols(),
            Factor::Recording => a.diff.rows(),
        };
        let est = &self.design.estimator;
        let mut fits = Vec::with_capacity(n);
        for k in 0..n {
            let drop = |m: &CrossedMatrix| match factor {
                Factor::Seed => m.without_col(k),
                Factor::Recording => m.without_row(k),
            };
            let e = crossed_mom(&drop(&a.diff)?, est.level, est.df)?;
            let opt = optimism(drop(&a.reference)?.mean(), drop(&a.treated)?.mean());
            fits.push((e.mean, e.upper, opt, rule_holds(self.design, opt, &e)));
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

    fn conditional(&self, u: &Unit, label: &str) -> Result<ConditionalSummary, AnalysisError> {
        let mut sums = [(0.0, 0usize, 0u64, 0u64); 2];
        let mut values = [Vec::new(), Vec::new()];
        let mut without = 0;
        let arms = [&self.design.contrast.treated, &self.design.contrast.reference];
        for (k, arm) in arms.iter().enumerate() {
            for r in self.recordings {
                for s in &self.design.seeds {
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
            let (i, j) = (self.recordings.len(), self.design.seeds.len());
            let diff: Vec<f64> = values[0].iter().zip(&values[1]).map(|(t, r)| t - r).collect();
            let stats = |source| AnalysisError::Stats { unit: format!("{label} (conditional RMSE)"), source };
            let m = CrossedMatrix::new(i, j, diff).map_err(stats)?;
            Some(crossed_mom(&m, self.design.estimator.level, self.design.estimator.df).map_err(stats)?)
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

    fn interaction(&self, ix: &InteractionUnit, stream: u64) -> Result<InteractionResult, AnalysisError> {
        let label = format!("interaction {} - {} at {} s", ix.left, ix.right, ix.horizon_s);
        let stats = |source| AnalysisError::Stats { unit: label.clone(), source };
        let l = self.arrays(&ix.left, ix.metric, ix.horizon_s, &label)?;
        let r = self.arrays(&ix.right, ix.metric, ix.horizon_s, &label)?;
        let delta = l.diff.minus(&r.diff).map_err(stats)?;
        let est = &self.design.estimator;
        let estimate = crossed_mom(&delta, est.level, est.df).map_err(stats)?;
        let bootstrap = match self.design.sensitivity.bootstrap {
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

fn quantity(q: Quantity, optimism_pct: f64, e: &CrossedEstimate) -> f64 {
    match q {
        Quantity::Optimism => optimism_pct,
        Quantity::Mean => e.mean,
        Quantity::Lower => e.lower,
        Quantity::Upper => e.upper,
    }
}

fn rule_holds(design: &Design, optimism_pct: f64, e: &CrossedEstimate) -> bool {
    design.decision.conditions.iter().all(|c| c.cmp.holds(quantity(c.quantity, optimism_pct, e), c.value))
}

fn decide(design: &Design, primary: &UnitResult) -> Decision {
    let conditions: Vec<ConditionOutcome> = design
        .decision
        .conditions
        .iter()
        .map(|c| {
            let value = quantity(c.quantity, primary.optimism_pct, &primary.estimate);
            let pct = if c.quantity == Quantity::Optimism { "%" } else { "" };
            ConditionOutcome {
                condition: format!("{} {} {}{}", c.quantity.name(), c.cmp.symbol(), c.value, pct),
                quantity: c.quantity,
                value,
                holds: c.cmp.holds(value, c.value),
            }
        })
        .collect();
    Decision {
        name: design.decision.name.clone(),
        rule: pipeline::decision_text(design),
        unit: format!("{} {} at {} s", primary.model, primary.metric.name(), primary.horizon_s),
        holds: conditions.iter().all(|c| c.holds),
        conditions,
    }
}
