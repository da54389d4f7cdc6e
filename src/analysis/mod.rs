//! Stage 4: per-cell data -> [`Analysis`]. Everything in DESIGN.md's
//! Analysis paragraph, for every analysis unit of the [`Plan`], plus the
//! decision on the primary unit.
//!
//! Architecture Invariant: `analysis` reads only the plan and per-cell rows
//! (`plan`, `cells`, `design` types, `stats`); it knows nothing of flight
//! logs, splits, models or files, so any per-cell CSV can be reanalysed.

pub mod budget;
pub mod coverage;
mod decision;
mod diff;
mod error;
pub mod evidence;
pub mod family;
pub mod guards;
mod index;
pub mod multiverse;
pub mod record;
mod standing;
pub mod study;
pub mod training;
mod types;
mod unit;
pub(crate) mod words;

use rayon::prelude::*;

use crate::cells::Cell;
use crate::label::Label;
use crate::plan::Plan;

pub use error::{AnalysisError, FileAnalysisError};
pub use evidence::analyze_study;
pub use standing::{AnalysisHeader, Standing};
pub use study::StudyAnalysis;
pub use types::*;

/// Tolerance of the failure-aware identity, in metres: absolute plus
/// relative, wide enough for per-cell files written with 3 decimals.
const FA_TOLERANCE: (f64, f64) = (1e-3, 1e-3);

/// Refuses values no rollout under the plan can produce (the row reader
/// has already refused negative, non-finite and inconsistent counts): a
/// number of starts other than the design's, a speed label its data block
/// cannot give, a recording the design does not pin (when it pins them),
/// a velocity or attitude error the data's layout cannot have (or lacks),
/// position errors above the divergence cap, attitude errors above 180
/// degrees, and a failure-aware RMSE that is not the one its conditional
/// RMSE, divergence count and cap imply. Every non-divergent start's error
/// is at most the cap, so with n starts, d of them divergent,
/// FA^2 n = COND^2 (n - d) + CAP^2 d exactly (rollout/metrics.rs); a file
/// with one arm in millimetres, or from another cap, breaks it.
fn check_values(plan: &Plan, speeds: &[Label], c: &Cell) -> Result<(), AnalysisError> {
    check_labels(plan, speeds, c)?;
    check_errors(plan, c)
}

/// A cell's labels against the design: its starts, its speed label and,
/// where the design pins them, its recording. `speeds` are the plan's
/// speed labels, as labels (compared by number, not by name).
fn check_labels(plan: &Plan, speeds: &[Label], c: &Cell) -> Result<(), AnalysisError> {
    // Every evaluation recording gets exactly `starts` rollout starts
    // (split/mod.rs, draw_starts), in every arm.
    if u64::from(c.n_starts) != plan.starts as u64 {
        return Err(AnalysisError::NotInDesign {
            at: c.origin,
            field: "n_starts",
            value: c.n_starts.to_string(),
            known: format!("every evaluation recording has `starts {}` in every arm", plan.starts),
        });
    }
    if !speeds.contains(&c.speed) {
        return Err(AnalysisError::NotInDesign {
            at: c.origin,
            field: "speed",
            value: c.speed.to_string(),
            known: format!("the design's data block labels speeds {}", plan.speed_labels.join(", ")),
        });
    }
    if !plan.pinned_recordings.is_empty() && !plan.pinned_recordings.iter().any(|r| *r == c.recording) {
        let n = plan.pinned_recordings.len();
        let shown: Vec<&str> = plan.pinned_recordings.iter().take(5).map(|r| r.as_str()).collect();
        let more = if n > 5 { format!(", ... ({n} in all)") } else { String::new() };
        return Err(AnalysisError::NotInDesign {
            at: c.origin,
            field: "recording",
            value: c.recording.to_string(),
            known: format!("the design pins its evaluation recordings: {}{more}", shown.join(", ")),
        });
    }
    Ok(())
}

/// A cell's errors against the design and each other: within the cap,
/// present exactly where the design's data declare them, an attitude error
/// of at most 180 degrees, and the failure-aware RMSE implied by the
/// conditional one and the divergent starts.
fn check_errors(plan: &Plan, c: &Cell) -> Result<(), AnalysisError> {
    let cap = plan.cap.0;
    let impossible = |field, value, problem: String| AnalysisError::Impossible { at: c.origin, field, value, problem };
    // A file's values are finite (its reader refuses any other); cells
    // built in memory are checked here, since the analysis's grids mark a
    // missing cell with NaN.
    for (field, value) in [
        ("fa_position_rmse_m", Some(c.fa_position_rmse_m)),
        ("conditional_position_rmse_m", c.conditional_position_rmse_m),
        ("divergence_rate", Some(c.divergence_rate)),
        ("velocity_rmse_mps", c.velocity_rmse_mps),
        ("attitude_rmse_deg", c.attitude_rmse_deg),
    ] {
        if let Some(v) = value.filter(|v| !v.is_finite()) {
            return Err(impossible(field, v, "a metric is a finite number".to_string()));
        }
    }
    if c.fa_position_rmse_m > cap {
        return Err(impossible(
            "fa_position_rmse_m",
            c.fa_position_rmse_m,
            format!("above the design's divergence cap of {cap} m"),
        ));
    }
    if let Some(v) = c.conditional_position_rmse_m.filter(|v| *v > cap) {
        return Err(impossible(
            "conditional_position_rmse_m",
            v,
            format!("above the design's divergence cap of {cap} m, which no non-divergent rollout exceeds"),
        ));
    }
    let all_diverged = c.n_divergent == c.n_starts;
    for (field, value, what, declared) in [
        ("velocity_rmse_mps", c.velocity_rmse_mps, "velocity", plan.slots.velocity),
        ("attitude_rmse_deg", c.attitude_rmse_deg, "attitude", plan.slots.attitude),
    ] {
        let problem = match value {
            Some(v) if !declared => {
                format!("is {v}, but the design's data declare no {what}: the column must be empty")
            }
            None if declared && !all_diverged => {
                format!("is empty, but the design's data declare a {what} and not every start diverged")
            }
            _ => continue,
        };
        return Err(AnalysisError::Layout { at: c.origin, field, problem });
    }
    if let Some(v) = c.attitude_rmse_deg.filter(|v| *v > 180.0) {
        return Err(impossible("attitude_rmse_deg", v, "an attitude error is at most 180 degrees".to_string()));
    }
    let (n, d) = (c.n_starts as f64, c.n_divergent as f64);
    let cond = c.conditional_position_rmse_m.unwrap_or(0.0);
    let implied = ((cond * cond * (n - d) + cap * cap * d) / n).sqrt();
    if (c.fa_position_rmse_m - implied).abs() > FA_TOLERANCE.0 + FA_TOLERANCE.1 * implied {
        return Err(impossible(
            "fa_position_rmse_m",
            c.fa_position_rmse_m,
            format!(
                "with conditional_position_rmse_m {cond}, {} of {} starts divergent and the design's cap of {cap} m it must be {implied:.6} (within {} m + {}%)",
                c.n_divergent, c.n_starts, FA_TOLERANCE.0, FA_TOLERANCE.1 * 100.0
            ),
        ));
    }
    Ok(())
}

/// Runs the analysis the plan preregistered on per-cell data.
///
/// ```
/// use std::path::Path;
/// let file = crossaudit::design::load(Path::new("designs/nanobench_confirmatory.design")).unwrap();
/// let plan = crossaudit::plan::compile(&file.design);
/// let cells = crossaudit::cells::read_cells(Path::new("examples/cells/nanobench_synthetic.csv")).unwrap();
/// let a = crossaudit::analysis::analyze(&plan, &cells, Default::default()).unwrap();
/// assert_eq!(a.units.len(), plan.units().count());
/// assert_eq!(a.decision.rule.to_string(), "confirmed when optimism >= 10% and upper < 0");
/// ```
pub fn analyze(plan: &Plan, cells: &[Cell], options: AnalyzeOptions) -> Result<Analysis, AnalysisError> {
    // Checked on every core, in one pass over the cells: the first row a
    // single run refuses (a `split` or `dose` column the design lacks, or a
    // value it refuses). Where there is one, the checks in their order
    // name the first refused row in file order.
    let family_column =
        |c: &Cell| (c.split.is_some() && plan.splits.is_empty()) || (c.dose.is_some() && plan.doses.is_empty());
    let speeds: Vec<Label> = plan.speed_labels.iter().map(Label::from).collect();
    let first_refused =
        cells.par_iter().position_first(|c| family_column(c) || check_values(plan, &speeds, c).is_err());
    check_single_run(plan, if first_refused.is_some() { cells } else { &[] })?;
    if let Some(k) = first_refused {
        check_values(plan, &speeds, &cells[k])?;
    }
    let data = index::index(plan, cells)?;
    let recordings: Vec<RecordingLabels> = data
        .labels
        .iter()
        .map(|(r, (t, s, _))| RecordingLabels { recording: r.clone(), trajectory: t.clone(), speed: s.clone() })
        .collect();
    let fewer_allowed = plan.recordings_may_be_absent && recordings.len() < plan.recordings;
    if recordings.len() != plan.recordings && !fewer_allowed {
        let (found, declared) = (recordings.len(), plan.recordings);
        return Err(AnalysisError::RecordingCount { found, declared, fewest: String::new() });
    }
    let names: Vec<String> = recordings.iter().map(|r| r.recording.clone()).collect();
    let missing_cells = index::check_complete(plan, &data, &names)?;

    let ctx = unit::Ctx { plan, data: &data, recordings: &recordings, options };
    let mut warnings = Vec::new();
    if fewer_allowed {
        warnings.push(format!(
            "{} of the {} declared evaluation recordings are in the cells: the design allows drawn recordings without a CSV (`missing csv allow`); the run's manifests/absent_recordings.csv names the others",
            recordings.len(),
            plan.recordings
        ));
    }
    if !missing_cells.is_empty() {
        warnings.push(format!(
            "{} cell(s) of the crossed matrix are missing (the design allows it: `missing allow`); each is listed under Missing cells",
            missing_cells.len()
        ));
    }
    let units = analyze_units(&ctx, &mut warnings)?;
    let n_units = plan.units().count();
    let interactions = plan
        .interactions
        .par_iter()
        .enumerate()
        .map(|(k, ix)| ctx.interaction(ix, (n_units + k) as u64))
        .collect::<Result<Vec<_>, _>>()?;
    // The plan's primary unit is the first.
    let decision = decision::study_decision(&plan.decision, &units, &plan.contrast)?;
    fragile_warnings(&units[0], decision.holds, &mut warnings);
    let fixed_budget = budget::fixed_budget(plan, &units);
    let mut a = Analysis {
        study: plan.study.clone(),
        header: AnalysisHeader::default(),
        treated: plan.contrast.treated.clone(),
        reference: plan.contrast.reference.clone(),
        level: plan.estimator.level,
        recordings,
        seeds: plan.seeds.iter().map(|s| s.0).collect(),
        units,
        interactions,
        decision,
        warnings,
        missing_cells,
        figures: Vec::new(),
        treatment: Vec::new(),
        coverage: None,
        fixed_budget,
        provenance: Provenance::default(),
        curves: Vec::new(),
        guards: Vec::new(),
    };
    a.guards = guards::guards(&a);
    Ok(a)
}

/// The plan and the cells are of one run: no `split` or `dose` column the
/// design does not declare, and no split or dose factor (those are
/// analysed by `analysis::family::analyze_family`).
fn check_single_run(plan: &Plan, cells: &[Cell]) -> Result<(), AnalysisError> {
    if let Some(c) = cells.iter().find(|c| c.split.is_some() && plan.splits.is_empty()) {
        return Err(AnalysisError::Family {
            message: format!("{}: the file has a `split` column, but the design has no split factor", c.origin),
        });
    }
    if let Some(c) = cells.iter().find(|c| c.dose.is_some() && plan.doses.is_empty()) {
        return Err(AnalysisError::Family {
            message: format!(
                "{}: the file has a `dose` column, but the design has no dose-response contrast",
                c.origin
            ),
        });
    }
    if plan.is_family() {
        return Err(AnalysisError::Family {
            message: "the design has several splits or doses: analyse it with analysis::family::analyze_family"
                .to_string(),
        });
    }
    Ok(())
}

/// Every unit of the plan analysed, in plan order, their warnings added
/// to `warnings`. Units are independent (each has its own bootstrap
/// stream), so they run in parallel; results and warnings are collected in
/// plan order, so the output does not depend on the thread count.
fn analyze_units(ctx: &unit::Ctx, warnings: &mut Vec<String>) -> Result<Vec<UnitResult>, AnalysisError> {
    let all: Vec<_> = ctx.plan.units().collect();
    let per_unit: Vec<Result<(UnitResult, Vec<String>), AnalysisError>> = all
        .par_iter()
        .enumerate()
        .map(|(k, unit)| {
            let mut w = Vec::new();
            ctx.unit(unit, k as u64, &mut w).map(|u| (u, w))
        })
        .collect();
    let mut units = Vec::new();
    for (unit, r) in all.iter().zip(per_unit) {
        // A secondary endpoint the data cannot estimate (arms that cannot
        // differ: every rollout diverged in both, or a baseline that fits
        // nothing; a reference arm whose mean is 0, so optimism is
        // undefined; an array the estimator refuses) is not estimable: it is left out
        // with its reason, and the primary endpoint is still decided. The
        // primary endpoint not estimable decides nothing: that is an error.
        let secondary = unit.role != crate::design::Role::Primary;
        let (u, w) = match r {
            Err(AnalysisError::Degenerate { unit: label, detail }) if secondary => {
                warnings.push(format!("{label}: {detail}; this secondary endpoint is left out of the report"));
                continue;
            }
            Err(e @ (AnalysisError::ZeroReferenceMean { .. } | AnalysisError::Stats { .. })) if secondary => {
                let label = unit.label();
                let text = e.to_string();
                let why = text.strip_prefix(&format!("{label}: ")).unwrap_or(&text);
                warnings
                    .push(format!("{label}: not estimable ({why}); this secondary endpoint is left out of the report"));
                continue;
            }
            r => r?,
        };
        units.push(u);
        warnings.extend(w);
    }
    Ok(units)
}

/// A decision that leaving out one seed or one recording overturns is
/// fragile, whatever its interval says: say so beside it.
fn fragile_warnings(primary: &UnitResult, holds: bool, warnings: &mut Vec<String>) {
    for l in primary.leave_one_out.iter().filter(|l| !l.moves_verdict.is_empty()) {
        let one = match l.factor {
            crate::design::Factor::Seed => "seed",
            crate::design::Factor::Recording => "recording",
        };
        let names = match l.moves_verdict.len() {
            1 => format!("{one} {} is left out", l.moves_verdict[0]),
            _ => format!("each of the {one}s {} is left out", l.moves_verdict.join(", ")),
        };
        warnings.push(if holds {
            format!(
                "fragile decision: the rule holds in only {} of the {} fits that leave out one {one} (Leave-one-out table); it fails when {names}",
                l.rule_holds, l.fits
            )
        } else {
            format!(
                "fragile decision: the rule fails, but holds in {} of the {} fits that leave out one {one} (Leave-one-out table): when {names}",
                l.rule_holds, l.fits
            )
        });
    }
}
