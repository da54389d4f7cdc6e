//! The report of a dose-response or multi-split study: report.md (the
//! decision, the estimate per split and dose, the trend, the pooled
//! estimates), results.json, estimates.csv (tidy: one row per split and
//! dose, trend and pooled estimate), report.html (the same as one page,
//! figures inline), and two figures: optimism against dose with
//! intervals, and the per-split estimates beside the pooled one (a forest
//! plot).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use plotters::prelude::{BLACK, RED};

use super::charts::{dose_response, intervals, DoseRow, DrawError, IntervalRow};
use super::figures::Figure;
use super::format::{decision_summary, df, f, level_pct, sci};
use super::{MdTable, ReportError};
use crate::analysis::family::{dose_label, dose_name, dose_value, FamilyAnalysis, Pooled, PooledEstimate};
use crate::design::DoseAxis;
use crate::io::{create_dir_all, pretty_json, write_atomic};

fn split_name(s: Option<u64>) -> String {
    s.map(|s| s.to_string()).unwrap_or_else(|| "-".to_string())
}

/// The decision line as the console prints it.
pub fn family_decision_line(a: &FamilyAnalysis) -> String {
    super::format::labelled(decision_summary(&a.decision), &a.header.standing)
}

/// report.md of a family analysis.
pub fn render_family_markdown(a: &FamilyAnalysis) -> String {
    let mut s = header(a);
    let unit = super::format::unit_label(&a.metric_unit);
    let per_dose = match a.dose_axis {
        DoseAxis::Percent => format!("{unit}/pp"),
        DoseAxis::Distance => format!("{unit} per s"),
    };
    s.push_str(&per_dose_section(a, unit));
    if !a.secondary.is_empty() {
        s.push_str(&secondary_section(a));
    }
    if !a.treatment.is_empty() {
        let _ = writeln!(s, "## Treatment strength\n\n{}\n", super::markdown::TREATMENT_NOTE);
        let _ = writeln!(s, "{}", super::markdown::treatment(&a.treatment).render());
    }
    if a.splits.iter().any(|sp| sp.trend.is_some()) {
        s.push_str(&trend_section(a, &per_dose));
    }
    if let Some(p) = &a.pooled {
        s.push_str(&pooled_section(a, p, (unit, &per_dose)));
    }
    if !a.figures.is_empty() {
        let _ = writeln!(s, "## Figures\n");
        for fig in &a.figures {
            let _ = writeln!(s, "![{fig}]({fig})");
        }
        let _ = writeln!(s);
    }
    if !a.warnings.is_empty() {
        let _ = writeln!(s, "## Warnings\n");
        for w in &a.warnings {
            let _ = writeln!(s, "- {}", crate::io::md_line(w));
        }
        let _ = writeln!(s);
    }
    s
}

/// The title, the decision with its notes, what a distance-dose family's
/// contrast measures, and the provenance lines.
fn header(a: &FamilyAnalysis) -> String {
    let mut s = String::new();
    let _ =
        writeln!(s, "# {}: {}\n", super::md_text(&a.study), super::format::verdict(&a.decision, &a.header.standing));
    let _ = writeln!(s, "**{}**\n", decision_summary(&a.decision));
    for g in &a.guards {
        let _ = writeln!(s, "{}\n", g.text);
    }
    let _ = writeln!(s, "Primary endpoint: {}; contrast {} - {}.", a.unit, a.treated, a.reference);
    if let Some(sha) = &a.header.design_sha256 {
        let _ = writeln!(s, "Design sha256: {sha}.");
    }
    if let Some((path, sha)) = &a.provenance.cells {
        let _ = writeln!(s, "Per-cell data: {path} (sha256 {sha}).");
    }
    if let Some(d) = &a.provenance.data {
        let _ = writeln!(s, "Data: {}.", crate::io::md_line(d));
    }
    let _ = writeln!(
        s,
        "crossaudit {}{}.\n",
        a.provenance.crossaudit,
        a.header.standing.line().map(|l| format!("; {l}")).unwrap_or_default()
    );
    s
}

/// The table of every split's and dose's crossed contrast.
fn per_dose_section(a: &FamilyAnalysis, unit: &str) -> String {
    let mut s = String::new();
    let level = level_pct(a.level);
    let u = |h: &str| format!("{h} ({unit})");
    let _ = writeln!(s, "## Per split and dose\n");
    let _ = writeln!(
        s,
        "Each row is the crossed analysis of one contrast (its treated arm against the shared reference arm) over that split's recording x seed matrix, {level} intervals of the design's estimator. Optimism = 100 (mean reference - mean treated) / mean reference.\n"
    );
    let (mr, mt, d_h, se_h, iv_h) = (u("mean ref"), u("mean treated"), u("d"), u("SE"), u("interval"));
    let mut t = MdTable::new(
        &["split", "dose", "arm", &mr, &mt, &d_h, &se_h, "df", &iv_h, "optimism %", "excludes 0"],
        "llrrrrrrrrl",
    );
    for sp in &a.splits {
        for d in &sp.doses {
            let e = &d.estimate;
            t.row([
                split_name(sp.split),
                dose_name(d),
                d.arm.clone(),
                f(d.mean_reference, 4),
                f(d.mean_treated, 4),
                f(e.mean, 4),
                f(e.se, 4),
                df(e.df),
                format!("[{}, {}]", f(e.lower, 4), f(e.upper, 4)),
                f(d.optimism_pct, 1),
                if e.lower > 0.0 || e.upper < 0.0 { "yes".into() } else { "no".into() },
            ]);
        }
    }
    let _ = writeln!(s, "{}", t.render());
    s
}

/// Each declared secondary endpoint's contrast per split and dose.
fn secondary_section(a: &FamilyAnalysis) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "## Secondary endpoints
"
    );
    let _ = writeln!(
        s,
        "Descriptive: each secondary endpoint the design declares, as the per-dose table (its treated arm against the shared reference arm over that split's recording x seed matrix, {} intervals). No rule reads them; the trend and the pooled fit are the primary endpoint's.\n",
        level_pct(a.level)
    );
    let mut t = MdTable::new(
        &[
            "split",
            "dose",
            "arm",
            "model",
            "metric",
            "horizon",
            "unit",
            "mean ref",
            "mean treated",
            "d",
            "SE",
            "df",
            "interval",
            "optimism %",
        ],
        "llllllrrrrrrrr",
    );
    for r in &a.secondary {
        let e = &r.estimate;
        t.row([
            split_name(r.split),
            dose_label(r.distance_s, r.percent, &r.arm),
            r.arm.clone(),
            r.model.clone(),
            r.metric.name().to_string(),
            format!("{} s", r.horizon_s),
            super::format::unit_label(r.metric.unit()).to_string(),
            f(r.mean_reference, 4),
            f(r.mean_treated, 4),
            f(e.mean, 4),
            f(e.se, 4),
            df(e.df),
            format!("[{}, {}]", f(e.lower, 4), f(e.upper, 4)),
            f(r.optimism_pct, 1),
        ]);
    }
    let _ = writeln!(s, "{}", t.render());
    s
}

/// How the trend was computed, on the family's axis.
fn trend_note(axis: DoseAxis) -> &'static str {
    match axis {
        DoseAxis::Percent => "Per recording x seed cell, the least-squares slope of d over the doses with the reference arm as dose 0 (d = 0); its crossed estimate, per percentage point of dose. The dose-0 point is d = 0 by construction (no noise) and the line's intercept is free: the slope is the ordinary least-squares slope over 0 and the doses, not a fit through the origin. The optimism slope is -100 slope / mean reference (optimism points per dose point), its interval the slope's rescaled. `smallest dose excluding 0` is descriptive (no control of multiplicity over the doses); `step-down dose` is the lowest dose reached by testing from the largest dose down, stopping at the first interval that includes zero, which keeps the family-wise error at most 1 - level.\n",
        DoseAxis::Distance => "Per recording x seed cell, the least-squares slope of d over the distances (the reference arm holds no contaminating window, so it is off this axis and cancels from the slope); its crossed estimate, per second of distance. The optimism slope is -100 slope / mean reference (optimism points per second), its interval the slope's rescaled. `farthest distance with optimism` is the farthest distance whose interval lies below zero (the treated arm better), descriptive (no control of multiplicity over the distances); `step-down distance` is the farthest distance reached by testing from the nearest outwards, stopping at the first interval that does not lie below zero, which keeps the family-wise error at most 1 - level. An interval above zero (the treated arm worse) stops the sequence: it is no optimism surviving.\n",
    }
}

/// The trend over doses (or distances), per split.
fn trend_section(a: &FamilyAnalysis, per_dose: &str) -> String {
    let mut s = String::new();
    let axis = a.dose_axis;
    let (title, smallest, step, opt) = match axis {
        DoseAxis::Percent => ("## Trend over dose\n", "smallest dose excluding 0", "step-down dose", "%/pp"),
        DoseAxis::Distance => {
            ("## Trend over distance\n", "farthest distance with optimism", "step-down distance", "% per s")
        }
    };
    let _ = writeln!(s, "{title}\n{}", trend_note(axis));
    let upp = |h: &str| format!("{h} ({per_dose})");
    let (sl, se_h, iv_h) = (upp("slope"), upp("SE"), upp("interval"));
    let (os, oi) = (format!("optimism slope ({opt})"), format!("optimism interval ({opt})"));
    let mut t = MdTable::new(&["split", &sl, &se_h, "df", &iv_h, &os, &oi, smallest, step], "lrrrrrrrr");
    for sp in &a.splits {
        if let Some(tr) = &sp.trend {
            let e = &tr.slope;
            t.row([
                split_name(sp.split),
                sci(e.mean),
                sci(e.se),
                df(e.df),
                format!("[{}, {}]", sci(e.lower), sci(e.upper)),
                f(tr.optimism_slope, 3),
                format!("[{}, {}]", f(tr.optimism_slope_lower, 3), f(tr.optimism_slope_upper, 3)),
                dose_value(axis, tr.smallest_dose_excluding_zero),
                dose_value(axis, tr.step_down_dose),
            ]);
        }
    }
    let _ = writeln!(s, "{}", t.render());
    s
}

/// The estimates pooled over splits.
fn pooled_section(a: &FamilyAnalysis, p: &Pooled, (unit, per_dose): (&str, &str)) -> String {
    let mut s = String::new();
    let level = level_pct(a.level);
    let _ = writeln!(s, "## Pooled over splits\n");
    let _ = writeln!(
        s,
        "REML fit of value = mu + split + recording + seed + residual, all three random intercepts and crossed (recordings recur across splits, seeds are shared): lme4's `lmer(d ~ 1 + (1|split) + (1|recording) + (1|seed))`. Interval mu +- t(df) SE, {level}; the df are Satterthwaite's unless the design's estimator asks for Kenward-Roger (column `df`). Split share = var(split) / total variance; SE^2 shares are phi_k dVar(mu)/dphi_k (split, recording, seed, residual). mu, SE and the interval are in the row's unit; the variances in its square; optimism in % (per dose point for the slope).\n"
    );
    let n = a.splits.len();
    if n < 10 {
        let _ = writeln!(
            s,
            "The split variance is estimated from {n} splits, so it has at most {} degrees of freedom: its estimate (and the split share) is very imprecise, and a zero estimate (singular) is common even when splits differ. The interval accounts for this through its df; the split variance itself is descriptive.\n",
            n - 1
        );
    }
    let mut t = MdTable::new(
        &[
            "estimate",
            "unit",
            "n",
            "mu",
            "SE",
            "df",
            "interval",
            "optimism %",
            "optimism interval",
            "var split",
            "var recording",
            "var seed",
            "var residual",
            "split share",
            "SE^2 shares",
        ],
        "llrrrrrrrrrrrrl",
    );
    for e in p.doses.iter().chain(&p.slope) {
        pooled_row(&mut t, e, if e.label == "slope" { per_dose } else { unit });
    }
    let _ = writeln!(s, "{}", t.render());
    let singular: Vec<&str> =
        p.doses.iter().chain(p.slope.as_ref()).filter(|e| e.singular).map(|e| e.label.as_str()).collect();
    if !singular.is_empty() {
        let _ = writeln!(
            s,
            "Singular pooled fit (a variance component estimated at zero) for {}. There Satterthwaite's df hold the zero component fixed while Kenward-Roger's keep it through a generalized inverse, so the two df differ.\n",
            singular.join(", ")
        );
    }
    if p.slope.is_some() {
        let axis = a.dose_axis;
        let (smallest, step) = (dose_value(axis, p.smallest_dose_excluding_zero), dose_value(axis, p.step_down_dose));
        let _ = match axis {
            DoseAxis::Percent => writeln!(
                s,
                "Smallest dose whose pooled interval excludes zero: {smallest} (descriptive, no multiplicity control). Lowest dose reached by step-down testing from the largest dose (family-wise error at most 1 - level): {step}.\n"
            ),
            DoseAxis::Distance => writeln!(
                s,
                "Farthest distance whose pooled interval lies below zero (optimism): {smallest} (descriptive, no multiplicity control). Farthest distance reached by step-down testing from the nearest (family-wise error at most 1 - level): {step}.\n"
            ),
        };
    }
    s
}

/// One pooled estimate's row, in `unit`.
fn pooled_row(t: &mut MdTable, e: &PooledEstimate, unit: &str) {
    let slope = e.label == "slope";
    let num = |v: f64| if slope { sci(v) } else { f(v, 4) };
    let digits = if slope { 3 } else { 1 };
    t.row([
        e.label.clone(),
        unit.to_string(),
        e.n.to_string(),
        num(e.mean),
        num(e.se),
        format!("{} ({})", df(e.df), e.df_rule),
        format!("[{}, {}]", num(e.lower), num(e.upper)),
        f(e.optimism_pct, digits),
        format!("[{}, {}]", f(e.optimism_lower, digits), f(e.optimism_upper, digits)),
        sci(e.variances[0]),
        sci(e.variances[1]),
        sci(e.variances[2]),
        sci(e.variances[3]),
        f(e.split_share, 3),
        e.se2_shares.iter().map(|x| f(*x, 3)).collect::<Vec<_>>().join(" / ")
            + if e.singular { " (singular)" } else { "" },
    ]);
}

/// Draws the figures: optimism against dose (two or more doses), and the
/// per-split estimates with the pooled one (two or more splits).
pub fn write_family_figures(a: &FamilyAnalysis, dir: &Path) -> Result<Vec<Figure>, DrawError> {
    let mut written = Vec::new();
    let mut lines = vec![(0.0, BLACK)];
    if let Some(t) = a.decision.rule.optimism_threshold() {
        if a.decision.rule.on != crate::design::DecisionTarget::Slope {
            lines.push((t, RED));
        }
    }
    let tag = if a.header.standing.exploratory() { "EXPLORATORY: " } else { "" };
    let level = level_pct(a.level);
    if a.doses.len() >= 2 {
        written.push(dose_figure(a, dir, tag)?);
    }
    if let Some(p) = &a.pooled {
        for (k, d) in a.doses.iter().enumerate() {
            let mut rows: Vec<IntervalRow> = a
                .splits
                .iter()
                .map(|sp| {
                    let r = &sp.doses[k];
                    let kk = -100.0 / r.mean_reference;
                    (split_name(sp.split), r.optimism_pct, r.estimate.upper * kk, r.estimate.lower * kk)
                })
                .collect();
            let e = &p.doses[k];
            rows.push(("pooled".to_string(), e.optimism_pct, e.optimism_lower, e.optimism_upper));
            let name = if a.doses.len() == 1 {
                "forest.svg".to_string()
            } else {
                match d.distance_s {
                    Some(g) => format!("forest_{}s.svg", g.to_string().replace('.', "p")),
                    None => format!("forest_{}.svg", d.percent.to_string().replace('.', "p")),
                }
            };
            let path = dir.join(&name);
            let title = format!(
                "{tag}Optimism per split and pooled, {} ({}), {level} intervals",
                a.unit,
                dose_name(&a.splits[0].doses[k])
            );
            let svg = intervals(&path, &title, "optimism (%)", &rows, &lines)?;
            written.push((path, svg));
        }
    }
    Ok(written)
}

/// Optimism against dose (or distance): each dose's estimate with its
/// interval, pooled over splits when there are several, and the fitted
/// trend.
fn dose_figure(a: &FamilyAnalysis, dir: &Path, tag: &str) -> Result<Figure, DrawError> {
    let level = level_pct(a.level);
    // Pooled over splits when there are several, else the one split's.
    let rows: Vec<DoseRow> = match &a.pooled {
        Some(p) => p
            .doses
            .iter()
            .zip(&a.doses)
            .map(|(e, d)| (d.dose(), e.optimism_pct, e.optimism_lower, e.optimism_upper))
            .collect(),
        None => a.splits[0]
            .doses
            .iter()
            .map(|d| {
                let k = -100.0 / d.mean_reference;
                (d.distance_s.unwrap_or(d.percent), d.optimism_pct, d.estimate.upper * k, d.estimate.lower * k)
            })
            .collect(),
    };
    // The optimism slope (per dose point) and its interval: pooled over
    // splits, or the one split's.
    let slope = match &a.pooled {
        Some(p) => p.slope.as_ref().map(|e| (e.optimism_pct, e.optimism_lower, e.optimism_upper)),
        None => a.splits[0].trend.as_ref().map(|t| (t.optimism_slope, t.optimism_slope_lower, t.optimism_slope_upper)),
    };
    // The least-squares line through the reference (0, 0) and the doses'
    // points has the slope's estimate as its slope; its intercept
    // follows from the means. Over distances the reference is off the
    // axis: the line through the distances' points alone.
    let (reference, per, x_desc, against) = match a.dose_axis {
        DoseAxis::Percent => (1.0, "%/pp", "dose (% of the fit windows from the evaluation recordings)", "dose"),
        DoseAxis::Distance => {
            (0.0, "% per s", "least distance of the contaminating windows from the evaluated segments (s)", "distance")
        }
    };
    let fit = slope.filter(|s| s.0.is_finite()).map(|(b, lo, hi)| {
        let n = rows.len() as f64 + reference;
        let mean_x = rows.iter().map(|r| r.0).sum::<f64>() / n;
        let mean_y = rows.iter().map(|r| r.1).sum::<f64>() / n;
        (mean_y - b * mean_x, b, format!("fitted slope {} {per}, {level} [{}, {}]", f(b, 3), f(lo, 3), f(hi, 3)))
    });
    let what = if a.pooled.is_some() { "pooled over splits" } else { "crossed intervals" };
    let p = dir.join("optimism_by_dose.svg");
    let title = format!("{tag}Optimism against {against} ({} vs {}), {level} {what}", a.treated, a.reference);
    let svg = dose_response(&p, &title, ("optimism (%)", x_desc), &rows, fit)?;
    Ok((p, svg))
}

/// Writes report.md, results.json and the figures into `dir`; the figures'
/// names are recorded in the analysis first.
pub fn write_family(a: &FamilyAnalysis, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    create_dir_all(dir)?;
    let figures = write_family_figures(a, dir)?;
    let mut out: Vec<PathBuf> = figures.iter().map(|(p, _)| p.clone()).collect();
    let svgs = super::figures::by_name(figures);
    let a = &a.with_figures(svgs.iter().map(|(name, _)| name.clone()).collect());
    let markdown = render_family_markdown(a);
    let d = &a.decision;
    let banner = super::html::Banner::new(&d.name, d.holds, family_decision_line(a), &a.header.standing)
        .with_guards(a.guards.iter().map(|g| g.text.clone()).collect());
    let html = super::html::render_page(&a.study, &banner, &markdown, &svgs);
    let estimates = super::estimates::render_family_estimates(a);
    out.push(super::write_parquet_twin(dir, &estimates)?);
    let files = [
        // results.json first: a folder holding a report.md without it is
        // someone's own to the next `analyze`.
        ("results.json", pretty_json(a)),
        ("report.md", markdown),
        ("estimates.csv", estimates),
        ("report.html", html),
    ];
    for (name, text) in files {
        let path = dir.join(name);
        write_atomic(&path, text.as_bytes())?;
        out.push(path);
    }
    // Each contrast's full single-contrast analysis, beside the summary.
    for sp in &a.splits {
        for (d, detail) in sp.doses.iter().zip(&sp.detail) {
            let mut sub = match sp.split {
                // The name of the split's run directory (`plan::split_dir`).
                Some(s) => dir.join(format!("split-{s}")),
                None => dir.to_path_buf(),
            };
            if a.doses.len() >= 2 {
                sub = sub.join(&d.arm);
            }
            if sub != dir {
                out.extend(super::write_all(detail, &sub)?);
            }
        }
    }
    Ok(out)
}
