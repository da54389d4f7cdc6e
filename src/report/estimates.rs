//! estimates.csv: every estimate of the report as one tidy table for R and
//! pandas: one row per analysis unit (or interaction) and estimator. The
//! preregistered estimator's row of each unit carries the arm means and
//! the optimism (%), and the primary endpoint's (the one the decision rule
//! is evaluated on) whether the rule holds there: on every other row
//! `rule_holds` is empty, since no rule decides on it; the
//! bootstrap, the optimism's intervals (kind `optimism`, unit `%`:
//! Fieller's, `fieller`, and the delta method's, `delta_method`), the
//! grouped sensitivity and any compared intervals follow as rows of their
//! own. Where the reference arm leaves an evaluated condition uncovered,
//! the coverage guard's rows (kind `coverage`) follow the units: the share
//! of d the uncovered recordings carry and the contrast over the covered
//! recordings alone. Numbers are written in full (shortest round-trip
//! form), `Inf` and `NaN` as R and pandas read them; empty means not
//! applicable.

use crate::analysis::family::{PooledEstimate, RuleReads};
use crate::analysis::{Analysis, UnitResult};
use crate::design::DoseAxis;
use crossaudit_stats::CrossedEstimate;

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
    /// The interval; `None` for a number that has none (a share).
    bounds: Option<(f64, f64)>,
    optimism: Option<f64>,
    holds: Option<bool>,
}

/// The name of the design's estimator that made `e`.
fn estimator(e: &CrossedEstimate) -> &'static str {
    if e.reml.is_some() {
        "reml"
    } else {
        "crossed_mom"
    }
}

fn crossed<'a>(name: &'a str, e: &CrossedEstimate) -> Row<'a> {
    interval(name, e.mean, Some(e.se), Some(e.df), (e.lower, e.upper))
}

/// A row of an interval alone: no arm means, optimism or rule.
fn interval(estimator: &str, estimate: f64, se: Option<f64>, df: Option<f64>, (lower, upper): (f64, f64)) -> Row<'_> {
    Row { estimator, means: None, estimate, se, df, bounds: Some((lower, upper)), optimism: None, holds: None }
}

/// The pigeonhole bootstrap's row about the point estimate `mean`.
fn bootstrap(mean: f64, b: &crossaudit_stats::BootstrapInterval) -> Row<'static> {
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
    let (estimate, se, df) = (num(r.estimate), opt(r.se), opt(r.df));
    let (lower, upper) = r.bounds.map(|(lo, hi)| (num(lo), num(hi))).unwrap_or_default();
    format!("{key},{},{level},{t},{rf},{estimate},{se},{df},{lower},{upper},{},{holds}\n", r.estimator, opt(r.optimism))
}

/// The coverage guard's rows (kind `coverage`), where the reference arm
/// leaves an evaluated condition uncovered: the share of the primary
/// endpoint's summed d the uncovered recordings carry (estimator
/// `uncovered_share_of_d`, in %), and the primary contrast over the
/// covered recordings alone (estimator `covered_only`: the design's
/// estimator, with the arm means and optimism; `rule_holds` empty, since
/// no rule decides on it), then its optimism's Fieller interval.
fn coverage_rows(a: &Analysis, contrast: &str, put: &mut impl FnMut(&str, Row)) {
    let (Some(c), Some(u)) = (a.coverage.as_ref().filter(|c| c.mixes_novelty()), a.units.first()) else { return };
    let at =
        |unit: &str| format!("coverage,primary,{},{contrast},{},{unit},{}", u.model, u.metric.name(), num(u.horizon_s));
    // A share has no interval: its bounds are empty.
    let share = interval("uncovered_share_of_d", 100.0 * c.share_of_d, None, None, (0.0, 0.0));
    put(&at("%"), Row { bounds: None, ..share });
    if let Some(k) = &c.covered_only {
        put(&at(u.metric.unit()), Row { optimism: Some(k.optimism_pct), ..crossed("covered_only", &k.estimate) });
        if let Some((lo, hi)) = k.optimism_interval.and_then(|iv| iv.fieller.bounds()) {
            put(&at("%"), interval("covered_only_fieller", k.optimism_pct, None, None, (lo, hi)));
        }
    }
}

/// The text of estimates.csv for `a`.
pub fn render_estimates(a: &Analysis) -> String {
    let mut s = String::from(COLUMNS);
    s.push('\n');
    let contrast = format!("{} - {}", a.treated, a.reference);
    let level = num(a.level);
    let mut put = |key: &str, r: Row| s.push_str(&line(key, &level, &r));
    let on_divergence = a.decision.rule.on == crate::design::DecisionTarget::Divergence;
    let preregistered = a.units.first().map_or("crossed_mom", |u| estimator(&u.estimate));
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
                holds: (u.role == crate::design::Role::Primary && !on_divergence && a.decision.member_of.is_none())
                    .then_some(u.rule_holds),
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
        if let Some((key, row)) =
            glmm_row(u, &role, &contrast, (on_divergence && a.decision.member_of.is_none()).then_some(a.decision.holds))
        {
            put(&key, row);
        }
    }
    coverage_rows(a, &contrast, &mut put);
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

/// The header of a dose-response or multi-split study's estimates.csv: the
/// single study's columns, with the split and the dose (`distance_s` in a
/// distance-dose family) after the kind.
pub const FAMILY_COLUMNS: &str = "kind,split,dose_pct,role,model,contrast,metric,unit,horizon_s,estimator,level,treated_mean,reference_mean,estimate,se,df,lower,upper,optimism_pct,rule_holds";

/// The text of a family's estimates.csv, with the single study's names:
/// per split, each dose's crossed estimate of the primary endpoint (kind
/// `endpoint`, the design's estimator) and its optimism (kind `optimism`,
/// in %), then the trend's slope over the doses (kind `trend`, per
/// percentage point of dose, or per second of distance) and the slope in
/// optimism (kind `trend_optimism`); over several splits, the same
/// estimates pooled by REML (estimator `pooled_reml`, split empty). An
/// optimism row's bounds are the interval of d (or of the slope) times
/// -100 / the reference mean, the reference mean held fixed (estimator
/// `fixed_reference`, or `pooled_fixed_reference`). `rule_holds` is
/// filled on the one row the rule decides on and empty elsewhere. Each
/// declared secondary endpoint's rows (role `secondary`, kinds `endpoint`
/// and `optimism`) follow the primary endpoint's, per split and dose.
pub fn render_family_estimates(a: &crate::analysis::family::FamilyAnalysis) -> String {
    let mut out = match a.dose_axis {
        DoseAxis::Percent => FAMILY_COLUMNS.to_string(),
        DoseAxis::Distance => FAMILY_COLUMNS.replacen("dose_pct", "distance_s", 1),
    };
    out.push('\n');
    let family = Family::new(a);
    let reads = a.rule_reads();
    for (k, sp) in a.splits.iter().enumerate() {
        let split = sp.split.map(|s| s.to_string()).unwrap_or_default();
        for (j, d) in sp.doses.iter().enumerate() {
            let holds = (reads == RuleReads::Dose && (k, j) == (0, 0)).then_some(a.decision.holds);
            let at = (split.as_str(), dose(d.distance_s.unwrap_or(d.percent)), d.arm.as_str());
            out.push_str(&family.dose_rows(at, d, holds));
        }
        if let Some(t) = &sp.trend {
            let holds = (reads == RuleReads::Trend && k == 0).then_some(a.decision.holds);
            let optimism = (t.optimism_slope, t.optimism_slope_lower, t.optimism_slope_upper);
            out.push_str(&family.trend_rows(&split, &t.slope, optimism, holds));
        }
    }
    for r in &a.secondary {
        out.push_str(&family.secondary_rows(r));
    }
    if let Some(p) = &a.pooled {
        for (j, (e, d)) in p.doses.iter().zip(&a.doses).enumerate() {
            let holds = (reads == RuleReads::PooledDose && j == 0).then_some(a.decision.holds);
            out.push_str(&family.pooled_dose_rows(dose(d.distance_s.unwrap_or(d.percent)), &d.arm, e, holds));
        }
        if let Some(e) = &p.slope {
            let holds = (reads == RuleReads::PooledTrend).then_some(a.decision.holds);
            out.push_str(&family.pooled_trend_rows(e, holds));
        }
    }
    out
}

/// What every row of a family's table shares: the primary endpoint's key
/// columns and the units of d, the slope and its optimism.
struct Family<'a> {
    a: &'a crate::analysis::family::FamilyAnalysis,
    role: String,
    model: String,
    metric: String,
    horizon: String,
    per_dose: String,
    optimism_per_dose: &'static str,
    level: String,
}

impl<'a> Family<'a> {
    fn new(a: &'a crate::analysis::family::FamilyAnalysis) -> Self {
        let primary = a.splits.iter().flat_map(|s| s.detail.first()).flat_map(|d| d.units.first()).next();
        let (role, model, metric, horizon) = primary
            .map(|u| {
                (format!("{:?}", u.role).to_lowercase(), u.model.clone(), u.metric.name().to_string(), num(u.horizon_s))
            })
            .unwrap_or_default();
        let unit = &a.metric_unit;
        let (per_dose, optimism_per_dose) = match a.dose_axis {
            DoseAxis::Percent => (format!("{unit}/pp"), "%/pp"),
            DoseAxis::Distance => (format!("{unit} per s"), "% per s"),
        };
        Family { a, role, model, metric, horizon, per_dose, optimism_per_dose, level: num(a.level) }
    }

    /// A line: the kind, split and dose, the endpoint's key with `contrast`
    /// and `unit`, then the row's values.
    fn line(&self, (kind, split, dose): (&str, &str, &str), (contrast, unit): (&str, &str), r: &Row) -> String {
        let key = format!(
            "{kind},{split},{dose},{},{},{contrast},{},{unit},{}",
            self.role, self.model, self.metric, self.horizon
        );
        line(&key, &self.level, r)
    }

    /// One dose's crossed estimate and its optimism in one split.
    fn dose_rows(
        &self,
        (split, dose, arm): (&str, String, &str),
        d: &crate::analysis::family::DoseResult,
        holds: Option<bool>,
    ) -> String {
        let e = &d.estimate;
        let contrast = format!("{arm} - {}", self.a.reference);
        let k = -100.0 / d.mean_reference;
        let row = Row {
            means: Some((d.mean_treated, d.mean_reference)),
            optimism: Some(d.optimism_pct),
            holds,
            ..crossed(estimator(e), e)
        };
        let optimism = interval("fixed_reference", d.optimism_pct, None, Some(e.df), (e.upper * k, e.lower * k));
        self.line(("endpoint", split, &dose), (&contrast, &self.a.metric_unit), &row)
            + &self.line(("optimism", split, &dose), (&contrast, "%"), &optimism)
    }

    /// A secondary endpoint's crossed estimate at one dose of one split, and
    /// its optimism (role `secondary`; no rule reads them).
    fn secondary_rows(&self, r: &crate::analysis::family::SecondaryDose) -> String {
        let e = &r.estimate;
        let contrast = format!("{} - {}", r.arm, self.a.reference);
        let split = r.split.map(|s| s.to_string()).unwrap_or_default();
        let dose = dose(r.distance_s.unwrap_or(r.percent));
        let key = |kind: &str, unit: &str| {
            format!(
                "{kind},{split},{dose},secondary,{},{contrast},{},{unit},{}",
                r.model,
                r.metric.name(),
                num(r.horizon_s)
            )
        };
        let row = Row {
            means: Some((r.mean_treated, r.mean_reference)),
            optimism: Some(r.optimism_pct),
            ..crossed(estimator(e), e)
        };
        let k = -100.0 / r.mean_reference;
        let optimism = interval("fixed_reference", r.optimism_pct, None, Some(e.df), (e.upper * k, e.lower * k));
        line(&key("endpoint", r.metric.unit()), &self.level, &row)
            + &line(&key("optimism", "%"), &self.level, &optimism)
    }

    /// One split's slope over the doses and the slope in optimism.
    fn trend_rows(
        &self,
        split: &str,
        e: &CrossedEstimate,
        (o, lo, hi): (f64, f64, f64),
        holds: Option<bool>,
    ) -> String {
        let contrast = format!("{} - {}", self.a.treated, self.a.reference);
        let row = Row { holds, ..crossed(estimator(e), e) };
        let optimism = interval("fixed_reference", o, None, Some(e.df), (lo, hi));
        self.line(("trend", split, ""), (&contrast, &self.per_dose), &row)
            + &self.line(("trend_optimism", split, ""), (&contrast, self.optimism_per_dose), &optimism)
    }

    /// A dose's estimate pooled over the splits, and its optimism.
    fn pooled_dose_rows(&self, dose: String, arm: &str, e: &PooledEstimate, holds: Option<bool>) -> String {
        let contrast = format!("{arm} - {}", self.a.reference);
        let row = Row { optimism: Some(e.optimism_pct), holds, ..pooled(e) };
        let optimism = pooled_optimism(e);
        self.line(("endpoint", "", &dose), (&contrast, &self.a.metric_unit), &row)
            + &self.line(("optimism", "", &dose), (&contrast, "%"), &optimism)
    }

    /// The slope pooled over the splits, and its slope in optimism.
    fn pooled_trend_rows(&self, e: &PooledEstimate, holds: Option<bool>) -> String {
        let contrast = format!("{} - {}", self.a.treated, self.a.reference);
        let row = Row { holds, ..pooled(e) };
        self.line(("trend", "", ""), (&contrast, &self.per_dose), &row)
            + &self.line(("trend_optimism", "", ""), (&contrast, self.optimism_per_dose), &pooled_optimism(e))
    }
}

/// A pooled REML estimate's interval row.
fn pooled(e: &PooledEstimate) -> Row<'static> {
    interval("pooled_reml", e.mean, Some(e.se), Some(e.df), (e.lower, e.upper))
}

/// A pooled estimate's optimism: its interval times -100 / the reference
/// mean.
fn pooled_optimism(e: &PooledEstimate) -> Row<'static> {
    interval("pooled_fixed_reference", e.optimism_pct, None, Some(e.df), (e.optimism_lower, e.optimism_upper))
}

/// A dose in % or s; empty for a study of splits without doses.
fn dose(p: f64) -> String {
    if p.is_nan() {
        String::new()
    } else {
        num(p)
    }
}
