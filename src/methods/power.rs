//! The design planner: from a pilot's variance components, the SE,
//! interval width and probability that the decision rule holds for other
//! numbers of recordings I and seeds J.

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;
use statrs::distribution::{ContinuousCDF, Normal};

use crate::analysis::Analysis;
use crate::io::{create_dir_all, write_atomic, WriteError};
use crate::plan::{DoseAxis, Plan};
use crate::report::charts::{draw_err, DrawError};
use crate::report::MdTable;
use crossaudit_stats::{critical_value, StatsError};

/// The most recordings or seeds the planner considers (a design declares
/// at most 100,000 seeds).
pub const MAX_PLANNED: usize = 100_000;

/// Why a power plan could not be made or written.
#[derive(Debug, thiserror::Error)]
pub enum PowerError {
    /// Fewer than 2 recordings or seeds were asked for.
    #[error("--recordings, --seeds, --splits and --draws need values of at least 2, found {0}")]
    TooFew(usize),
    /// A number listed twice in one option (`--draws 5,5,3`).
    #[error("--recordings, --seeds, --splits and --draws each list a number once, found {0} twice")]
    Twice(usize),
    /// More recordings or seeds than a design may declare.
    #[error("--recordings, --seeds, --splits and --draws take values of at most {MAX_PLANNED}, found {0}")]
    TooMany(usize),
    /// A pilot with `factor draw` has no certified fit over its draws to
    /// plan from.
    #[error("the pilot has no fit pooled over its draws to plan from: {why}")]
    NoPooledFit {
        /// Why.
        why: String,
    },
    /// Declared components, effect or reference mean that cannot be
    /// planned from.
    #[error("{0}")]
    Declared(String),
    /// The pilot analysis has no primary unit.
    #[error("the analysis has no primary endpoint")]
    NoPrimary,
    /// A dose-response plan needs a trend, which needs two or more doses.
    #[error("the pilot has no trend over doses (it needs two or more doses)")]
    NoTrend,
    /// The pilot's variance components are zero (or rounding noise): every
    /// predicted SE would be zero and every P(rule holds) 0 or 1.
    #[error("the pilot's variance components of {unit} are {components} against a mean of {mean}: the pilot has no variance to plan from (its differences are constant up to rounding), so every predicted SE would be 0 and every P(rule holds) 0 or 1; plan from a pilot whose cells vary")]
    Degenerate {
        /// What is planned.
        unit: String,
        /// The components, as printed.
        components: String,
        /// The pilot's reference mean.
        mean: f64,
    },
    /// A quantile could not be computed.
    #[error(transparent)]
    Stats(#[from] StatsError),
    /// An output could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
    /// plan.svg could not be drawn.
    #[error(transparent)]
    Draw(#[from] DrawError),
}

/// One row of the design planner.
#[derive(Debug, Clone, Serialize)]
pub struct PowerRow {
    /// Recordings I.
    pub recordings: usize,
    /// Seeds J.
    pub seeds: usize,
    /// Predicted SE.
    pub se: f64,
    /// Predicted interval width, 2 t SE.
    pub width: f64,
    /// P(the decision rule holds) with the SE and df estimated, as a study
    /// of that size would: the share of [`SIMULATED`] studies drawn from
    /// the estimator's exact sampling distribution
    /// ([`crossaudit_stats::crossed_mom_draws`]) in which the rule holds.
    pub power: f64,
    /// The same with the SE taken as known (the normal approximation
    /// Phi((min(-t SE, -c m_ref / 100) - mean) / SE)), which overstates
    /// or understates it where the SE rests on few seeds.
    pub power_known_se: f64,
}

/// Simulated studies per planned size: the probability's Monte Carlo SE
/// is at most 0.5 / sqrt(20,000) = 0.0035.
pub const SIMULATED: usize = 20_000;

/// The planner's answer for one design and pilot.
#[derive(Debug, Clone, Serialize)]
pub struct PowerPlan {
    /// The primary unit's label.
    pub unit: String,
    /// Recordings in the pilot.
    pub pilot_recordings: usize,
    /// Seeds in the pilot.
    pub pilot_seeds: usize,
    /// What is planned: `d`, or `slope (per dose point)` (plan.md says
    /// which; plan.json's `unit` names it).
    #[serde(skip)]
    pub estimand: String,
    /// The unit of the SE and width (`m`, or `m/pp` for a slope), for
    /// plan.md's headers.
    #[serde(skip)]
    pub value_unit: String,
    /// Pilot mean of the estimand (d, or the slope).
    pub mean_d: f64,
    /// Pilot reference-arm mean.
    pub mean_reference: f64,
    /// Pilot between-recording component.
    pub sigma2_recording: f64,
    /// Pilot between-seed component.
    pub sigma2_seed: f64,
    /// Pilot residual component.
    pub sigma2_residual: f64,
    /// One row per (I, J) asked for.
    pub rows: Vec<PowerRow>,
    /// Whether more recordings or more seeds reduce the SE more.
    pub advice: String,
    /// The pilot gave each seed its own draw (`draws per seed`), so its
    /// seed component includes the draw variance.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub draws_per_seed: bool,
    /// The components, effect and reference mean were declared (`plan
    /// --components`), not estimated from a pilot; `pilot_recordings` and
    /// `pilot_seeds` are then the first I and J asked for, where the
    /// advice compares doubling each.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub declared: bool,
}

/// Variance components, effect and reference mean declared by the user
/// (`plan --components recording=V,seed=V,residual=V --effect D
/// --reference-mean M`), planned from as a pilot's would be.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Declared {
    /// The components: SE^2 = recording/I + seed/J + residual/(IJ).
    pub components: crossaudit_stats::VarianceComponents,
    /// The true effect (d, in the endpoint's unit).
    pub effect: f64,
    /// The reference arm's mean.
    pub reference_mean: f64,
}

/// The smallest nonzero magnitude of a declared effect or reference mean
/// (a variance: its square), as every reader's ([`crate::io::MIN_MAGNITUDE`]).
const MIN_MAGNITUDE: f64 = crate::io::MIN_MAGNITUDE;

/// The largest magnitude of a declared effect or reference mean (a
/// variance: its square): the planner's sums of squares stay finite.
const MAX_DECLARED: f64 = 1e75;

/// Reads `recording=V,seed=V,residual=V`: each name once, each value a
/// finite number at least 0, and 0 or between 1e-120 and 1e150.
pub fn parse_components(text: &str) -> Result<crossaudit_stats::VarianceComponents, PowerError> {
    let bad = |why: String| PowerError::Declared(format!("--components {text:?}: {why}"));
    let mut found: [Option<f64>; 3] = [None; 3];
    const NAMES: [&str; 3] = ["recording", "seed", "residual"];
    for part in text.split(',') {
        let (name, value) = part
            .split_once('=')
            .ok_or_else(|| bad(format!("{part:?} is not NAME=VALUE (NAME one of recording, seed, residual)")))?;
        let k = NAMES
            .iter()
            .position(|n| *n == name.trim())
            .ok_or_else(|| bad(format!("{:?} is not a component: give recording, seed and residual", name.trim())))?;
        let v: f64 = value.trim().parse().map_err(|_| bad(format!("{:?} is not a number", value.trim())))?;
        if !v.is_finite() || v < 0.0 {
            return Err(bad(format!("{} = {v}: a variance is a finite number at least 0", NAMES[k])));
        }
        if v != 0.0 && !(MIN_MAGNITUDE * MIN_MAGNITUDE..=MAX_DECLARED * MAX_DECLARED).contains(&v) {
            return Err(bad(format!(
                "{} = {v:e}: a variance must be 0 or between 1e-120 and 1e150 (an SD between 1e-60 and 1e75), where the planner's sums and squares stay inside double precision; rescale (another unit)",
                NAMES[k]
            )));
        }
        if found[k].replace(v).is_some() {
            return Err(bad(format!("{} is given twice", NAMES[k])));
        }
    }
    match found {
        [Some(recording), Some(seed), Some(residual)] => {
            Ok(crossaudit_stats::VarianceComponents { recording, seed, residual })
        }
        _ => {
            let missing: Vec<&str> = NAMES.iter().zip(found).filter(|(_, v)| v.is_none()).map(|(n, _)| *n).collect();
            Err(bad(format!("{} missing: give all three", missing.join(" and "))))
        }
    }
}

/// Predicts SE, interval width and the probability that the decision rule
/// holds for other numbers of recordings I and seeds J, from the pilot's
/// primary-endpoint variance components:
/// SE^2 = sa/I + sb/J + se/(IJ) (closed form), width = 2 t(J-1) SE, and,
/// with d_hat ~ N(mu, SE^2), the rule "optimism >= c% and upper < 0" holds
/// when d_hat <= min(-t SE, -c m_ref / 100), so
/// P = Phi((min(-t SE, -c m_ref/100) - mu) / SE). The pilot's mean is taken
/// as the true effect.
pub fn power_plan(
    plan: &Plan,
    analysis: &Analysis,
    recordings: &[usize],
    seeds: &[usize],
) -> Result<PowerPlan, PowerError> {
    check_counts(&[recordings, seeds])?;
    let u = analysis.units.first().ok_or(PowerError::NoPrimary)?;
    let unit = format!("{} {} at {} s", u.model, u.metric.name(), u.horizon_s);
    let estimand = ("d", unit_of(u.metric.unit(), None));
    crossed_plan(plan, unit, estimand, &Pilot::of(&u.estimate, u.mean_reference), recordings, seeds)
}

/// [`power_plan`] from declared components, effect and reference mean
/// instead of a pilot's: the same rows a pilot with those values gives
/// (`tests/plan_declared.rs` checks both against the closed form).
pub fn declared_power_plan(
    plan: &Plan,
    declared: &Declared,
    recordings: &[usize],
    seeds: &[usize],
) -> Result<PowerPlan, PowerError> {
    check_counts(&[recordings, seeds])?;
    let scaled = |x: f64| x == 0.0 || (MIN_MAGNITUDE..=MAX_DECLARED).contains(&x.abs());
    if !scaled(declared.effect) || !scaled(declared.reference_mean) {
        return Err(PowerError::Declared(format!(
            "--effect {:e} and --reference-mean {:e} must be finite numbers, each 0 or between 1e-60 and 1e75 in magnitude, the scale of the components' SDs; rescale (another unit)",
            declared.effect, declared.reference_mean
        )));
    }
    if declared.reference_mean <= 0.0 && plan.decision.optimism_threshold().is_some() {
        return Err(PowerError::Declared(format!(
            "--reference-mean {} must be above 0: the rule reads the optimism, 100 (reference - treated) / reference, which is undefined at 0 and changes sign below it (a metric's mean error is positive)",
            declared.reference_mean
        )));
    }
    let p = &plan.primary;
    let unit = format!("{} {} at {} s", p.model, p.metric.name(), p.horizon_s);
    let estimand = ("d", unit_of(p.metric.unit(), None));
    let base = (recordings.first().copied().unwrap_or(2), seeds.first().copied().unwrap_or(2));
    let pilot =
        Pilot { components: declared.components, mean: declared.effect, mean_reference: declared.reference_mean, base };
    let mut out = crossed_plan(plan, unit, estimand, &pilot, recordings, seeds).map_err(|e| match e {
        // The components are the user's declaration, not a pilot's.
        PowerError::Degenerate { unit, components, .. } => PowerError::Declared(format!(
            "the declared variance components of {unit} are {components}: there is no variance to plan from, so every predicted SE would be 0 and every P(rule holds) 0 or 1; declare components above 0 (--components recording=...,seed=...,residual=...)"
        )),
        other => other,
    })?;
    out.declared = true;
    out.advice = out.advice.replacen("From the pilot's", "At the declared components, from", 1);
    Ok(out)
}

/// What a crossed plan is made from: a pilot's estimate, or declared
/// values.
struct Pilot {
    components: crossaudit_stats::VarianceComponents,
    mean: f64,
    mean_reference: f64,
    /// The (I, J) the advice doubles from: the pilot's.
    base: (usize, usize),
}

impl Pilot {
    fn of(estimate: &crossaudit_stats::CrossedEstimate, mean_reference: f64) -> Pilot {
        Pilot {
            components: estimate.components,
            mean: estimate.mean,
            mean_reference,
            base: (estimate.rows, estimate.cols),
        }
    }
}

/// The planner for a single-split dose-response design: [`power_plan`]
/// applied to the trend, the per-cell least-squares slope of d over the
/// doses (its crossed estimate's components and mean from the pilot). A
/// rule `optimism >= c%` on the slope holds when the slope is at most
/// -c m_ref / 100, as for d, since the optimism slope is -100 slope / m_ref.
///
/// A multi-split design goes to [`super::split_power::split_power_plan`], which plans the
/// pooled slope when the rule is on it.
pub fn dose_power_plan(
    plan: &Plan,
    family: &crate::analysis::family::FamilyAnalysis,
    recordings: &[usize],
    seeds: &[usize],
) -> Result<PowerPlan, PowerError> {
    check_counts(&[recordings, seeds])?;
    let split = family.splits.first().ok_or(PowerError::NoPrimary)?;
    let trend = split.trend.as_ref().ok_or(PowerError::NoTrend)?;
    let reference = split.doses.first().ok_or(PowerError::NoPrimary)?.mean_reference;
    let unit = format!("{} of {}", slope_name(family), family.unit);
    let estimand = match family.dose_axis {
        DoseAxis::Percent => ("slope (per dose point)", unit_of(plan.primary.metric.unit(), Some(DoseAxis::Percent))),
        DoseAxis::Distance => {
            ("slope (per second of distance)", unit_of(plan.primary.metric.unit(), Some(DoseAxis::Distance)))
        }
    };
    crossed_plan(plan, unit, estimand, &Pilot::of(&trend.slope, reference), recordings, seeds)
}

/// A metric's unit as plan.md prints it ([`crate::report::unit_label`]),
/// for a slope per percentage point of dose or per second of distance.
pub(super) fn unit_of(unit: &str, slope: Option<DoseAxis>) -> String {
    let unit = crate::report::unit_label(unit);
    match slope {
        None => unit.to_string(),
        Some(DoseAxis::Percent) => format!("{unit}/pp"),
        Some(DoseAxis::Distance) => format!("{unit} per s"),
    }
}

/// `slope over doses`, or `slope over distance` in a distance-dose family.
pub(super) fn slope_name(family: &crate::analysis::family::FamilyAnalysis) -> &'static str {
    match family.dose_axis {
        DoseAxis::Percent => "slope over doses",
        DoseAxis::Distance => "slope over distance",
    }
}

pub(super) fn check_counts(counts: &[&[usize]]) -> Result<(), PowerError> {
    let all = || counts.iter().flat_map(|c| c.iter());
    if let Some(n) = all().find(|n| **n < 2) {
        return Err(PowerError::TooFew(*n));
    }
    if let Some(n) = all().find(|n| **n > MAX_PLANNED) {
        return Err(PowerError::TooMany(*n));
    }
    // A value listed twice would plan the same row twice.
    for c in counts {
        if let Some(n) = c.iter().enumerate().find_map(|(k, n)| c[..k].contains(n).then_some(*n)) {
            return Err(PowerError::Twice(n));
        }
    }
    Ok(())
}

/// Refuses components whose sum is not above 1e-18 times the square of the
/// larger of the pilot's means: a relative SD under 1e-9 is rounding in the
/// differences, not variation between recordings or seeds.
pub(super) fn refuse_degenerate(
    unit: &str,
    components: &[f64],
    mean: f64,
    mean_reference: f64,
) -> Result<(), PowerError> {
    let total: f64 = components.iter().sum();
    let scale = mean.abs().max(mean_reference.abs());
    if total > 1e-18 * scale * scale && total.is_finite() {
        return Ok(());
    }
    Err(PowerError::Degenerate {
        unit: unit.to_string(),
        components: components.iter().map(|v| format!("{v:.3e}")).collect::<Vec<_>>().join(", "),
        mean: mean_reference,
    })
}

/// P(the decision rule holds) for an estimate ~ N(mean, se^2) whose
/// interval half-width is t se: the rule "optimism >= c% and upper < 0"
/// holds when the estimate is at most min(-t se, -c m_ref / 100).
pub(super) fn rule_power(plan: &Plan, mean: f64, se: f64, t: f64, mean_reference: f64) -> Result<f64, PowerError> {
    let normal = Normal::new(0.0, 1.0).map_err(|e| StatsError::Invalid(e.to_string()))?;
    let mut bound = -t * se;
    if let Some(thr) = plan.decision.optimism_threshold() {
        bound = bound.min(-thr * mean_reference / 100.0);
    }
    Ok(if se > 0.0 { normal.cdf((bound - mean) / se) } else { f64::from(u8::from(mean <= bound)) })
}

/// P(the decision rule holds) at `i` recordings x `j` seeds with the SE
/// and df estimated: the share of [`SIMULATED`] crossed MoM estimates,
/// drawn from their exact sampling distribution at the pilot's mean and
/// components (seeded by the size, so a plan is reproducible), whose
/// estimate is at most min(-t SE, -c m_ref / 100) with that estimate's own
/// SE and t. The reference mean is held at the pilot's.
fn simulated_rule_power(plan: &Plan, pilot: &Pilot, (i, j): (usize, usize)) -> Result<f64, PowerError> {
    let est = &plan.estimator;
    // A REML estimator's df rule applied to the MoM's draws (on a complete
    // array with positive components the two estimates agree).
    let df_rule = match est.df {
        crossaudit_stats::DfRule::KenwardRoger => crossaudit_stats::DfRule::Satterthwaite,
        other => other,
    };
    let seed = ((i as u64) << 32) ^ j as u64;
    let draws = crossaudit_stats::crossed_mom_draws(
        pilot.mean,
        pilot.components,
        (i, j),
        (est.level, df_rule),
        SIMULATED,
        seed,
    )?;
    let threshold = plan.decision.optimism_threshold().map(|c| -c * pilot.mean_reference / 100.0);
    let holds =
        draws.iter().filter(|e| e.mean <= threshold.map_or(-e.critical * e.se, |b| b.min(-e.critical * e.se))).count();
    Ok(holds as f64 / SIMULATED as f64)
}

/// The rows and advice of a crossed (recording x seed) plan for `estimate`.
fn crossed_plan(
    plan: &Plan,
    unit: String,
    (estimand, value_unit): (&str, String),
    pilot: &Pilot,
    recordings: &[usize],
    seeds: &[usize],
) -> Result<PowerPlan, PowerError> {
    let c = &pilot.components;
    let mean_reference = pilot.mean_reference;
    refuse_degenerate(&unit, &[c.recording, c.seed, c.residual], pilot.mean, mean_reference)?;
    let mut rows = Vec::new();
    for &i in recordings {
        for &j in seeds {
            let se = c.se_at(i as f64, j as f64);
            // Satterthwaite's df need data; the planner uses the normal there.
            let df = plan.df(i, j).unwrap_or(f64::INFINITY);
            let t = critical_value(plan.estimator.level, df)?;
            let power_known_se = rule_power(plan, pilot.mean, se, t, mean_reference)?;
            let power = simulated_rule_power(plan, pilot, (i, j))?;
            rows.push(PowerRow { recordings: i, seeds: j, se, width: 2.0 * t * se, power, power_known_se });
        }
    }
    let (i0, j0) = (pilot.base.0 as f64, pilot.base.1 as f64);
    let (base, more_rec, more_seed) = (c.se_at(i0, j0), c.se_at(2.0 * i0, j0), c.se_at(i0, 2.0 * j0));
    let digits = if base.abs() < 1e-3 { 3 } else { 4 };
    let advice = format!(
        "From the pilot's {i0} recordings x {j0} seeds (SE {}): doubling the recordings gives SE {}, doubling the seeds gives SE {}; {} reduce the SE more.",
        fmt_se(base, digits),
        fmt_se(more_rec, digits),
        fmt_se(more_seed, digits),
        if more_rec < more_seed { "more recordings" } else { "more seeds" }
    );
    Ok(PowerPlan {
        unit,
        estimand: estimand.to_string(),
        value_unit,
        pilot_recordings: pilot.base.0,
        pilot_seeds: pilot.base.1,
        mean_d: pilot.mean,
        mean_reference,
        sigma2_recording: c.recording,
        sigma2_seed: c.seed,
        sigma2_residual: c.residual,
        rows,
        advice,
        draws_per_seed: false,
        declared: false,
    })
}

/// An SE as the plan prints it: 4 decimals, or 3 significant digits
/// (`digits` 3) for the small numbers a slope per dose point gives.
fn fmt_se(v: f64, digits: usize) -> String {
    if digits == 4 {
        format!("{v:.4}")
    } else {
        format!("{v:.3e}")
    }
}

impl PowerPlan {
    /// plan.md.
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# Design planner: {}\n", self.unit);
        let source = if self.declared {
            "Declared (`--components`, `--effect`, `--reference-mean`; no pilot)".to_string()
        } else {
            format!("Pilot: {} recordings x {} seeds", self.pilot_recordings, self.pilot_seeds)
        };
        let _ = writeln!(
            s,
            "{source}; mean {} {}, reference mean {:.5}; sigma^2 recording {:.3e}, seed {:.3e}, residual {:.3e}.\n",
            self.estimand,
            if self.mean_d.abs() < 1e-3 { format!("{:.4e}", self.mean_d) } else { format!("{:.5}", self.mean_d) },
            self.mean_reference,
            self.sigma2_recording,
            self.sigma2_seed,
            self.sigma2_residual
        );
        let _ = writeln!(s, "{}\n", self.advice);
        if self.declared && self.draws_per_seed {
            let _ = writeln!(
                s,
                "**The seed variance assumed**: sigma^2 seed = {:.3e}, as declared. This design gives each seed its own draw (`draws per seed`), so its seed component must carry the variance between draws: one measured by a per-seed run. A seed component from a study of one draw (a single-draw pilot, a paper's table) leaves that variance out and makes every SE too small and every probability too high (on NanoBench the per-seed runs measure one 26 times the single draw's).\n",
                self.sigma2_seed
            );
        }
        let (se_h, width_h) =
            (format!("predicted SE ({})", self.value_unit), format!("interval width ({})", self.value_unit));
        let cols = ["recordings I", "seeds J", &se_h, &width_h, "P(decision rule holds)", "P with the SE known"];
        let mut table = MdTable::new(&cols, "rrrrrr");
        // A slope per dose point is small: three significant digits.
        let small = self.rows.iter().all(|r| r.width < 1e-2);
        let num = |v: f64| if small { format!("{v:.3e}") } else { format!("{v:.5}") };
        for r in &self.rows {
            table.row([
                r.recordings.to_string(),
                r.seeds.to_string(),
                num(r.se),
                num(r.width),
                format!("{:.3}", r.power),
                format!("{:.3}", r.power_known_se),
            ]);
        }
        s.push_str(&table.render());
        let _ = write!(
            s,
            "\n## Assumptions\n\n\
- The pilot's variance components (recording, seed, residual) are the true ones, and recordings and seeds added or removed are like the pilot's: SE^2 = s2_rec/I + s2_seed/J + s2_res/(IJ) on a complete I x J array (no missing cells).\n\
- The pilot's mean {estimand} is the true effect, and the reference mean stays at the pilot's. A pilot chosen because its effect looked large makes every probability optimistic.\n\
- The rule (`optimism >= c%` and `upper < 0`, or whichever of them it has) holds when the estimate is at most min(-t SE, -c m_ref / 100), with the SE and t the study itself estimates. P(decision rule holds) is the share of 20,000 simulated studies in which it holds (Monte Carlo SE at most 0.0035): each draws the crossed estimate's mean and its three mean squares from their exact distributions under the normal crossed model (the grand mean normal, each mean square a scaled chi-square), and computes the SE, the variance components (truncated at zero) and the df as the design's estimator does (Satterthwaite's for a REML estimator). With few seeds the SE is itself uncertain, and that changes the probability: \"P with the SE known\" is the normal approximation Phi((min(-t SE, -c m_ref / 100) - mean) / SE) with the true SE, for comparison.\n\
- Nothing else varies: the model, training, split and data inclusion are the pilot's.\n",
            estimand = self.estimand
        );
        if self.declared {
            s = s
                .replace("- The pilot's variance components (recording, seed, residual) are the true ones, and recordings and seeds added or removed are like the pilot's:", "- The declared variance components (recording, seed, residual) are the true ones for the recordings and seeds planned:")
                .replace("- The pilot's mean", "- The declared mean")
                .replace("the reference mean stays at the pilot's. A pilot chosen because its effect looked large makes every probability optimistic.", "the reference mean is the declared one. An effect declared from a study chosen because its effect looked large makes every probability optimistic.")
                .replace("inclusion are the pilot's.", "inclusion are those the components describe.");
            s.push_str("- The draws: as the declared components describe them (a seed component measured with `draws per seed` includes the variance between draws; one measured on one draw leaves it out).\n");
        } else if self.draws_per_seed {
            s.push_str("- The pilot gave each seed its own draw (`draws per seed`): its seed component includes the variance between draws, so every row's J seeds are J draws, and the interval is for the mean over draws.\n");
        } else {
            s.push_str("- One draw of the validation recordings, windows and rollout starts: the interval is conditional on it and leaves the variance between draws out (`draws per seed` or `factor draw` put it in; plan a design with `factor draw` to see both).\n");
        }
        s
    }

    /// Writes plan.md, plan.json and plan.svg into `out`.
    pub fn write(&self, out: &Path) -> Result<(), PowerError> {
        create_dir_all(out)?;
        write_atomic(&out.join("plan.md"), self.to_markdown().as_bytes())?;
        // No final newline: the form plan.json has always had.
        let json = serde_json::to_string_pretty(self).unwrap_or_default();
        write_atomic(&out.join("plan.json"), json.as_bytes())?;
        self.draw(&out.join("plan.svg"))?;
        Ok(())
    }

    /// Power against seeds, one line per number of recordings.
    pub fn draw(&self, path: &Path) -> Result<(), DrawError> {
        use plotters::prelude::*;
        let e = draw_err(path);
        crate::report::charts::svg_figure(path, (900, 480), |root| {
            let max_j = self.rows.iter().map(|r| r.seeds).max().unwrap_or(2) as f64;
            use crate::report::charts::{chart, ticks, whole, AXIS_FONT, TICK_FONT};
            let mut chart = chart(root, &format!("P(decision rule holds) for {}", self.unit))
                .build_cartesian_2d(0.0..max_j, 0.0..1.0)
                .map_err(&e)?;
            chart
                .configure_mesh()
                .x_label_formatter(&whole)
                .y_label_formatter(&ticks(0.0, 1.0))
                .label_style(TICK_FONT)
                .axis_desc_style(AXIS_FONT)
                .x_desc("seeds J")
                .y_desc("probability")
                .draw()
                .map_err(&e)?;
            let mut recs: Vec<usize> = self.rows.iter().map(|r| r.recordings).collect();
            recs.dedup();
            let palette = [BLUE, RED, GREEN, MAGENTA, CYAN, BLACK];
            for (k, i) in recs.iter().enumerate() {
                let color = palette[k % palette.len()];
                let pts: Vec<(f64, f64)> =
                    self.rows.iter().filter(|r| r.recordings == *i).map(|r| (r.seeds as f64, r.power)).collect();
                chart
                    .draw_series(LineSeries::new(pts, color))
                    .map_err(&e)?
                    .label(format!("I = {i}"))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], color));
            }
            chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw().map_err(&e)?;
            Ok(())
        })?;
        Ok(())
    }
}
