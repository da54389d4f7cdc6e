//! estimates.csv: every estimate of the report as one tidy table for R and
//! pandas: one row per analysis unit (or interaction) and estimator. The
//! preregistered estimator's row of each unit carries the arm means and
//! the optimism (%), and the primary endpoint's (the one the decision rule
//! is evaluated on) whether the rule holds there: on every other row
//! `rule_holds` is empty, since no rule decides on it; the
//! bootstrap, the optimism's intervals (kind `optimism`, unit `%`:
//! Fieller's, `fieller`, and the delta method's, `delta_method`), the
//! grouped sensitivity and any compared intervals follow as rows of their
//! own. Numbers are written in full (shortest round-trip
//! form), `Inf` and `NaN` as R and pandas read them; empty means not
//! applicable.

use std::fmt::Write as _;

use crate::analysis::{Analysis, UnitResult};
use crate::design::DoseAxis;
use crate::stats::CrossedEstimate;

/// The header of estimates.csv.
pub const COLUMNS: &str = "kind,role,model,contrast,metric,unit,horizon_s,estimator,level,treated_mean,reference_mean,estimate,se,df,lower,upper,optimism_pct,rule_holds";

fn num(x: f64) -> String {
    if x.is_nan() {
        "NaN".into()
    } else if x.is_infinite() {
        if x > 0.0 { "Inf" } else { "-Inf" }.into()
    } else {
        format!("{x}")
    }
}

fn opt(x: Option<f64>) -> String {
    x.map(num).unwrap_or_default()
}

/// One row's values after the unit's key columns.
struct Row<'a> {
    estimator: &'a str,
    means: Option<(f64, f64)>,
    estimate: f64,
    se: Option<f64>,
    df: Option<f64>,
    lower: f64,
    upper: f64,
    optimism: Option<f64>,
    holds: Option<bool>,
}

fn crossed<'a>(name: &'a str, e: &CrossedEstimate) -> Row<'a> {
    interval(name, e.mean, Some(e.se), Some(e.df), (e.lower, e.upper))
}

/// A row of an interval alone: no arm means, optimism or rule.
fn interval(estimator: &str, estimate: f64, se: Option<f64>, df: Option<f64>, (lower, upper): (f64, f64)) -> Row<'_> {
    Row { estimator, means: None, estimate, se, df, lower, upper, optimism: None, holds: None }
}

/// The pigeonhole bootstrap's row about the point estimate `mean`.
fn bootstrap(mean: f64, b: &crate::stats::BootstrapInterval) -> Row<'static> {
    interval("pigeonhole_bootstrap", mean, Some(b.se), None, (b.lower, b.upper))
}

/// The row of a unit's divergence GLMM, when it has an estimate: the log
/// odds ratio of a diverged rollout and its Wald interval; `holds` where
/// the rule decides on it.
fn glmm_row(u: &UnitResult, role: &str, contrast: &str, holds: Option<bool>) -> Option<(String, Row<'static>)> {
    let e = u.glmm.as_ref()?.estimate.as_ref()?;
    let key = format!("glmm,{role},{},{contrast},{},log OR,{}", u.model, u.metric.name(), num(u.horizon_s));
    let row = interval("binomial_glmm", e.log_odds_ratio, Some(e.se), None, (e.lower, e.upper));
    Some((key, Row { holds, ..row }))
}

/// One line of estimates.csv: the row's key columns, the level, then its
/// values.
fn line(key: &str, level: &str, r: &Row) -> String {
    let (t, rf) = r.means.map(|(t, rf)| (num(t), num(rf))).unwrap_or_default();
    let holds = r.holds.map(|h| h.to_string()).unwrap_or_default();
    let (estimate, se, df, lower, upper) = (num(r.estimate), opt(r.se), opt(r.df), num(r.lower), num(r.upper));
    format!("{key},{},{level},{t},{rf},{estimate},{se},{df},{lower},{upper},{},{holds}\n", r.estimator, opt(r.optimism))
}

/// The text of estimates.csv for `a`.
pub fn render_estimates(a: &Analysis) -> String {
    let mut s = String::from(COLUMNS);
    s.push('\n');
    let contrast = format!("{} - {}", a.treated, a.reference);
    let level = num(a.level);
    let mut put = |key: &str, r: Row| s.push_str(&line(key, &level, &r));
    let on_divergence = a.decision.rule.on == crate::design::DecisionTarget::Divergence;
    let preregistered = if a.units.first().is_some_and(|u| u.estimate.reml.is_some()) { "reml" } else { "crossed_mom" };
    for u in &a.units {
        let role = format!("{:?}", u.role).to_lowercase();
        let key = format!(
            "endpoint,{role},{},{contrast},{},{},{}",
            u.model,
            u.metric.name(),
            u.metric.unit(),
            num(u.horizon_s)
        );
        put(
            &key,
            Row {
                means: Some((u.mean_treated, u.mean_reference)),
                optimism: Some(u.optimism_pct),
                // The rule decides on the primary endpoint alone (or on the
                // divergence GLMM's row below).
                holds: (u.role == crate::design::Role::Primary && !on_divergence).then_some(u.rule_holds),
                ..crossed(preregistered, &u.estimate)
            },
        );
        if let Some(b) = &u.bootstrap {
            put(&key, bootstrap(u.estimate.mean, b));
        }
        if let Some(iv) = &u.optimism_interval {
            // The optimism's intervals, in %: Fieller's (no SE or df of
            // its own; empty bounds when unbounded) and the delta method's.
            let key = format!("optimism,{role},{},{contrast},{},%,{}", u.model, u.metric.name(), num(u.horizon_s));
            let bounds = iv.fieller.bounds().unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
            put(&key, interval("fieller", iv.estimate, None, Some(iv.delta_df), bounds));
            let delta = (iv.delta_lower, iv.delta_upper);
            put(&key, interval("delta_method", iv.estimate, Some(iv.delta_se), Some(iv.delta_df), delta));
        }
        if let Some(g) = &u.grouped {
            put(&key, crossed("grouped_conditions", &g.estimate));
        }
        for iv in u.intervals.iter().flatten() {
            let name =
                serde_json::to_value(iv.method).ok().and_then(|v| v.as_str().map(String::from)).unwrap_or_default();
            put(&key, interval(&name, iv.estimate, Some(iv.se), Some(iv.df), (iv.lower, iv.upper)));
        }
        if let Some((key, row)) = glmm_row(u, &role, &contrast, on_divergence.then_some(a.decision.holds)) {
            put(&key, row);
        }
    }
    for ix in &a.interactions {
        let key = format!(
            "interaction,,{} - {},{contrast},{},{},{}",
            ix.left,
            ix.right,
            ix.metric.name(),
            ix.metric.unit(),
            num(ix.horizon_s)
        );
        put(&key, crossed(preregistered, &ix.estimate));
        if let Some(b) = &ix.bootstrap {
            put(&key, bootstrap(ix.estimate.mean, b));
        }
    }
    s
}

/// The header of a dose-response or multi-split study's estimates.csv.
pub const FAMILY_COLUMNS: &str =
    "kind,split,dose_pct,arm,estimand,unit,level,treated_mean,reference_mean,estimate,se,df,lower,upper,optimism,optimism_lower,optimism_upper,optimism_unit";

/// The text of a family's estimates.csv: one row per split and dose (the
/// contrast's crossed estimate), per split's trend (the slope over doses),
/// then the pooled estimates per dose and of the slope. Units: d in the
/// metric's, a slope per percentage point of dose; optimism in %, or
/// optimism points per dose point for a slope. A distance-dose family's
/// dose column is `distance_s` (each arm's least distance from the
/// evaluated segments) and its slope is per second.
pub fn render_family_estimates(a: &crate::analysis::family::FamilyAnalysis) -> String {
    // As the single-contrast estimates.csv: the metric's own unit (empty for a rate).
    let unit = a.metric_unit.clone();
    let (per_dose, per_optimism, header) = match a.dose_axis {
        DoseAxis::Percent => (format!("{unit}/pp"), "%/pp", FAMILY_COLUMNS.to_string()),
        DoseAxis::Distance => {
            (format!("{unit} per s"), "% per s", FAMILY_COLUMNS.replacen("dose_pct", "distance_s", 1))
        }
    };
    let dose = |percent: f64, distance: Option<f64>| dose(distance.unwrap_or(percent));
    let split = |s: Option<u64>| s.map(|s| s.to_string()).unwrap_or_default();
    let mut s = header;
    s.push('\n');
    // Arm names are design identifiers: no field needs quoting.
    let mut row = |cols: [String; 18]| {
        let _ = writeln!(s, "{}", cols.join(","));
    };
    for sp in &a.splits {
        for d in &sp.doses {
            let e = &d.estimate;
            let k = -100.0 / d.mean_reference;
            row([
                "contrast".into(),
                split(sp.split),
                dose(d.percent, d.distance_s),
                d.arm.clone(),
                "d".into(),
                unit.clone(),
                num(e.level),
                num(d.mean_treated),
                num(d.mean_reference),
                num(e.mean),
                num(e.se),
                num(e.df),
                num(e.lower),
                num(e.upper),
                num(d.optimism_pct),
                num(e.upper * k),
                num(e.lower * k),
                "%".into(),
            ]);
        }
        if let Some(t) = &sp.trend {
            let e = &t.slope;
            row([
                "trend".into(),
                split(sp.split),
                String::new(),
                String::new(),
                "slope".into(),
                per_dose.clone(),
                num(e.level),
                String::new(),
                String::new(),
                num(e.mean),
                num(e.se),
                num(e.df),
                num(e.lower),
                num(e.upper),
                num(t.optimism_slope),
                num(t.optimism_slope_lower),
                num(t.optimism_slope_upper),
                per_optimism.into(),
            ]);
        }
    }
    if let Some(p) = &a.pooled {
        for (e, d) in p.doses.iter().zip(&a.doses) {
            row(pooled(e, dose(d.percent, d.distance_s), d.arm.clone(), "d", (&unit, "%"), a.level));
        }
        if let Some(e) = &p.slope {
            row(pooled(e, String::new(), String::new(), "slope", (&per_dose, per_optimism), a.level));
        }
    }
    s
}

/// A dose in %; empty for a study of splits without doses.
fn dose(p: f64) -> String {
    if p.is_nan() {
        String::new()
    } else {
        num(p)
    }
}

/// A pooled estimate's row.
fn pooled(
    e: &crate::analysis::family::PooledEstimate,
    dose: String,
    arm: String,
    estimand: &str,
    (unit, optimism_unit): (&str, &str),
    level: f64,
) -> [String; 18] {
    [
        "pooled".into(),
        String::new(),
        dose,
        arm,
        estimand.into(),
        unit.into(),
        num(level),
        String::new(),
        String::new(),
        num(e.mean),
        num(e.se),
        num(e.df),
        num(e.lower),
        num(e.upper),
        num(e.optimism_pct),
        num(e.optimism_lower),
        num(e.optimism_upper),
        optimism_unit.into(),
    ]
}
