//! report.md: the decision first, then one section per analysis, each a
//! [`MdTable`].

use std::fmt::Write as _;

use super::format::{df, f, level_pct, sci};
use super::MdTable;
use crate::analysis::{Analysis, UnitResult};
use crate::design::{Factor, Role};
use crossaudit_stats::{BootstrapInterval, CrossedEstimate};

fn ci(e: &CrossedEstimate) -> String {
    format!("[{}, {}]", f(e.lower, 4), f(e.upper, 4))
}

fn boot(b: &Option<BootstrapInterval>) -> String {
    b.map(|b| format!("[{}, {}]", f(b.lower, 4), f(b.upper, 4))).unwrap_or_else(|| "-".into())
}

/// `model | metric | h s`: the first three columns of most tables.
fn unit_name(u: &UnitResult) -> String {
    format!("{} | {} | {} s", u.model, u.metric.name(), u.horizon_s)
}

/// The unit of a metric's values (`fraction` for a rate).
fn unit_of(m: crate::design::Metric) -> &'static str {
    super::format::unit_label(m.unit())
}

/// `model | metric | h s | unit`: [`unit_name`] and the unit of the
/// row's values.
fn unit_name_in(u: &UnitResult, unit: &str) -> String {
    format!("{} | {unit}", unit_name(u))
}

/// The unit of a variance: the metric's unit squared.
fn squared(m: crate::design::Metric) -> String {
    format!("{}^2", unit_of(m))
}

/// A `## title` section: heading, optional note, table, blank line.
fn section(s: &mut String, title: &str, note: &str, table: &MdTable) {
    let _ = writeln!(s, "## {title}\n");
    if !note.is_empty() {
        let _ = writeln!(s, "{note}\n");
    }
    let _ = writeln!(s, "{}", table.render());
}

/// The whole report.md.
pub fn render_markdown(a: &Analysis) -> String {
    let mut s = super::header::header(a);
    let level = level_pct(a.level);
    section(&mut s, "Endpoints", "", &endpoints(a, &level));
    super::glmm::section(a, &mut s);
    super::coverage::section(a, &mut s);
    if !a.treatment.is_empty() {
        section(&mut s, "Treatment strength", TREATMENT_NOTE, &treatment(&a.treatment));
    }
    let note = if reml(a) {
        "REML estimates (no mean squares). Shares are of Var(d mean) by source, phi_k dVar/dphi_k, which add up to it; on a complete array they are s2_rec/I, s2_seed/J and s2_res/(IJ)."
    } else {
        "Shares are of SE^2 = s2_rec/I + s2_seed/J + s2_res/(IJ)."
    };
    section(&mut s, "Variance components of d", note, &components(a));
    if !a.interactions.is_empty() {
        section(&mut s, "Interaction", "delta_ij = d_left,ij - d_right,ij, same estimator.", &interactions(a, &level));
    }
    if a.units.iter().any(|u| u.grouped.is_some()) {
        let note = "d averaged within condition groups, then the same estimator on groups x seeds.";
        section(&mut s, "Grouped sensitivity", note, &grouped(a, &level));
    }
    if a.units.iter().any(|u| !u.leave_one_out.is_empty()) {
        section(&mut s, "Leave-one-out", "", &leave_one_out(a));
    }
    section(&mut s, "Per-seed optimism", "", &per_seed(a));
    section(&mut s, "Mean difference by trajectory", "", &per_trajectory(a));
    let note = if a.units.iter().any(|u| u.conditional.pairs_dropped > 0) {
        if a.units.first().and_then(|u| u.estimate.reml.as_ref()).is_some() {
            "Conditional RMSE is paired: means and the contrast use the recording x seed pairs where both arms have a finite value. Where pairs were dropped (column `pairs dropped`), the contrast is estimated by the preregistered REML estimator on the pairs left."
        } else {
            "Conditional RMSE is paired: means and the contrast use the recording x seed pairs where both arms have a finite value. Where pairs were dropped (column `pairs dropped`), the preregistered method of moments (which needs every pair) cannot be used: the contrast is estimated by REML with Kenward-Roger df instead."
        }
    } else {
        ""
    };
    section(&mut s, "Conditional RMSE and divergence", note, &conditional(a, &level));
    if a.units.iter().any(|u| u.intervals.is_some()) {
        section(&mut s, "Interval estimators compared", "", &compared(a, &level));
    }
    if !a.missing_cells.is_empty() {
        let _ = writeln!(s, "## Missing cells\n");
        let _ = writeln!(
            s,
            "{} cell(s) of the crossed matrix are absent from the per-cell data; the REML fits use the others.\n",
            a.missing_cells.len()
        );
        for m in &a.missing_cells {
            let _ = writeln!(s, "- {}", crate::io::md_line(m));
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

/// Whether the analysis used REML (its estimates carry the fit's summary).
fn reml(a: &Analysis) -> bool {
    a.units.first().is_some_and(|u| u.estimate.reml.is_some())
}

fn endpoints(a: &Analysis, level: &str) -> MdTable {
    let (t, r) = (format!("{} mean", a.treated), format!("{} mean", a.reference));
    let (ci_h, boot_h) = (format!("{level} CI"), format!("bootstrap {level} CI"));
    let opt_h = format!("optimism {level} CI");
    let cols = [
        "role",
        "model",
        "metric",
        "horizon",
        "unit",
        &t,
        &r,
        "optimism %",
        &opt_h,
        "d mean",
        "SE",
        "df",
        &ci_h,
        &boot_h,
        "rule",
    ];
    let mut table = MdTable::new(&cols, "lllllrrrlrrrlll");
    for u in &a.units {
        let e = &u.estimate;
        table.row([
            if u.role == Role::Primary { "primary" } else { "secondary" }.to_string(),
            unit_name_in(u, unit_of(u.metric)),
            f(u.mean_treated, 4),
            f(u.mean_reference, 4),
            f(u.optimism_pct, 1),
            super::format::fieller_cell(u.optimism_interval),
            f(e.mean, 4),
            f(e.se, 4),
            df(e.df),
            ci(e),
            boot(&u.bootstrap),
            match (u.role, u.rule_holds) {
                _ if a.decision.member_of.is_some() => "descriptive",
                (Role::Primary, true) => "holds",
                (Role::Primary, false) => "fails",
                _ => "descriptive",
            }
            .to_string(),
        ]);
    }
    table
}

/// The note above a treatment-strength table.
pub(super) const TREATMENT_NOTE: &str = "How strong the treatment is: each arm's windows drawn from the evaluation recordings, how many start inside a segment that is evaluated (a rollout start to its horizon, same recording), how far they sit from the nearest rollout start, and the quartiles of their distance to the nearest evaluated segment (0: sharing a row with one; what `at least G s from segments` bounds).";

/// One row per treated arm: its treatment strength.
pub(super) fn treatment(rows: &[crate::analysis::TreatmentStrength]) -> MdTable {
    let cols = [
        "arm",
        "windows from evaluation recordings",
        "inside an evaluated segment",
        "share %",
        "segment (s)",
        "median distance to a start (s)",
        "distance to a segment, quartiles (s)",
    ];
    let mut table = MdTable::new(&cols, "lrrrrrr");
    for t in rows {
        let share = if t.contaminating_windows == 0 {
            f64::NAN
        } else {
            100.0 * t.inside_evaluated_segment as f64 / t.contaminating_windows as f64
        };
        table.row([
            t.arm.clone(),
            t.contaminating_windows.to_string(),
            t.inside_evaluated_segment.to_string(),
            f(share, 1),
            f(t.horizon_s, 2),
            f(t.median_distance_s, 2),
            match t.segment_distance_quartiles_s {
                Some(q) => q.iter().map(|&q| f(q, 2)).collect::<Vec<_>>().join(" / "),
                None => "not recorded".into(),
            },
        ]);
    }
    table
}

fn components(a: &Analysis) -> MdTable {
    let cols = [
        "model",
        "metric",
        "horizon",
        "unit",
        "MS rec",
        "MS seed",
        "MS res",
        "s2 rec",
        "s2 seed",
        "s2 res",
        "share rec %",
        "share seed %",
        "share res %",
    ];
    let mut table = MdTable::new(&cols, "llllrrrrrrrrr");
    for u in &a.units {
        let e = &u.estimate;
        let c = &e.components;
        let ms = |f: fn(&crossaudit_stats::MeanSquares) -> f64| {
            e.mean_squares.as_ref().map_or("–".to_string(), |m| sci(f(m)))
        };
        table.row([
            unit_name_in(u, &squared(u.metric)),
            ms(|m| m.ms_rows),
            ms(|m| m.ms_cols),
            ms(|m| m.ms_error),
            sci(c.recording),
            sci(c.seed),
            sci(c.residual),
            f(100.0 * e.share_recording, 1),
            f(100.0 * e.share_seed, 1),
            f(100.0 * e.share_residual, 1),
        ]);
    }
    table
}

fn interactions(a: &Analysis, level: &str) -> MdTable {
    let (ci_h, boot_h) = (format!("{level} CI"), format!("bootstrap {level} CI"));
    let cols = ["contrast", "metric", "horizon", "unit", "delta mean", "SE", "df", &ci_h, &boot_h];
    let mut table = MdTable::new(&cols, "llllrrrll");
    for ix in &a.interactions {
        let e = &ix.estimate;
        table.row([
            format!("{} - {}", ix.left, ix.right),
            ix.metric.name().to_string(),
            format!("{} s", ix.horizon_s),
            unit_of(ix.metric).to_string(),
            f(e.mean, 4),
            f(e.se, 4),
            df(e.df),
            ci(e),
            boot(&ix.bootstrap),
        ]);
    }
    table
}

fn grouped(a: &Analysis, level: &str) -> MdTable {
    let ci_h = format!("{level} CI");
    let cols = ["model", "metric", "horizon", "unit", "groups", "d mean", "SE", "df", &ci_h];
    let mut table = MdTable::new(&cols, "llllrrrrl");
    for u in &a.units {
        if let Some(g) = &u.grouped {
            let e = &g.estimate;
            table.row([
                unit_name_in(u, unit_of(u.metric)),
                g.groups.len().to_string(),
                f(e.mean, 4),
                f(e.se, 4),
                df(e.df),
                ci(e),
            ]);
        }
    }
    table
}

fn leave_one_out(a: &Analysis) -> MdTable {
    let cols = [
        "model",
        "metric",
        "horizon",
        "unit",
        "left out",
        "fits",
        "d mean range",
        "upper range",
        "optimism % range",
        "rule holds",
    ];
    let mut table = MdTable::new(&cols, "lllllrlllr");
    let range = |lo: f64, hi: f64, d: usize| format!("[{}, {}]", f(lo, d), f(hi, d));
    for u in &a.units {
        for l in &u.leave_one_out {
            let factor = match l.factor {
                Factor::Seed => "seed",
                Factor::Recording => "recording",
            };
            table.row([
                unit_name_in(u, unit_of(u.metric)),
                format!("one {factor}"),
                l.fits.to_string(),
                range(l.mean_min, l.mean_max, 4),
                range(l.upper_min, l.upper_max, 4),
                range(l.optimism_min, l.optimism_max, 1),
                format!("{}/{}", l.rule_holds, l.fits),
            ]);
        }
    }
    table
}

fn per_seed(a: &Analysis) -> MdTable {
    let mut table = MdTable::new(&["model", "metric", "horizon", "min %", "max %", "seeds below 0"], "lllrrr");
    for u in &a.units {
        let v: Vec<f64> = u.per_seed_optimism.iter().map(|p| p.optimism_pct).collect();
        let min = v.iter().cloned().fold(f64::INFINITY, f64::min);
        let max = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        table.row([unit_name(u), f(min, 1), f(max, 1), v.iter().filter(|x| **x < 0.0).count().to_string()]);
    }
    table
}

fn per_trajectory(a: &Analysis) -> MdTable {
    let cols = ["model", "metric", "horizon", "unit", "trajectory", "recordings", "mean d"];
    let mut table = MdTable::new(&cols, "lllllrr");
    for u in &a.units {
        for t in &u.per_trajectory {
            table.row([
                unit_name_in(u, unit_of(u.metric)),
                super::md_text(&t.trajectory),
                t.recordings.to_string(),
                f(t.mean_difference, 4),
            ]);
        }
    }
    table
}

fn conditional(a: &Analysis, level: &str) -> MdTable {
    let (t, r) = (&a.treated, &a.reference);
    let (rt, rr, dt, dr, ci_h) = (
        format!("cond. RMSE {t} (m)"),
        format!("cond. RMSE {r} (m)"),
        format!("divergent {t}"),
        format!("divergent {r}"),
        format!("cond. {level} CI (m)"),
    );
    let dropped = a.units.iter().any(|u| u.conditional.pairs_dropped > 0);
    let mut cols = vec!["model", "metric", "horizon", &rt, &rr, &dt, &dr, "cond. d mean (m)", &ci_h];
    if dropped {
        cols.push("pairs dropped");
    }
    let mut table = MdTable::new(&cols, if dropped { "lllrrrrrlr" } else { "lllrrrrrl" });
    for u in &a.units {
        let c = &u.conditional;
        let opt = |v: Option<f64>| v.map(|x| f(x, 4)).unwrap_or_else(|| "NA".into());
        let (dm, dci) = match &c.difference {
            Some(e) => (f(e.mean, 4), ci(e)),
            None => (
                "NA".into(),
                match &c.difference_error {
                    Some(e) => format!("(not estimable on the {} pairs left: {e})", c.pairs_dropped),
                    None => format!("({} pairs without a finite rollout in both arms)", c.pairs_dropped),
                },
            ),
        };
        let mut row = vec![
            unit_name(u),
            opt(c.mean_conditional_treated),
            opt(c.mean_conditional_reference),
            format!("{}/{}", c.divergent_treated, c.starts_treated),
            format!("{}/{}", c.divergent_reference, c.starts_reference),
            dm,
            dci,
        ];
        if dropped {
            row.push(c.pairs_dropped.to_string());
        }
        table.row(row);
    }
    table
}

/// Why an interval can be undefined on an array (`incomplete`: cells of
/// it are missing, which only REML, the naive and the one- and two-way
/// clustered intervals allow).
fn undefined_because(method: crossaudit_stats::IntervalMethod, incomplete: bool) -> &'static str {
    use crossaudit_stats::IntervalMethod as M;
    let allowed = matches!(
        method,
        M::RemlSatterthwaite
            | M::RemlKenwardRoger
            | M::NaiveIid
            | M::ClusterRecording
            | M::ClusterSeed
            | M::TwoWayCluster
    );
    if incomplete && !allowed {
        return "it needs a complete recording x seed array, and this one has missing cells (listed under Missing cells)";
    }
    match method {
        M::TwoWayCluster => "its variance V_row + V_col - V_cell is not positive on this array",
        M::MomUntruncated => "its variance (MS_row + MS_col - MS_error) / IJ is not positive on this array",
        M::RemlSatterthwaite | M::RemlKenwardRoger => "REML does not fit this array (a residual of exactly zero)",
        _ => "the array does not allow it (too few rows or columns, or no variation)",
    }
}

fn compared(a: &Analysis, level: &str) -> MdTable {
    let ci_h = format!("{level} CI");
    let cols = ["model", "metric", "horizon", "unit", "method", "estimate", "SE", "df", &ci_h, "excludes 0"];
    let mut table = MdTable::new(&cols, "lllllrrrll");
    for u in &a.units {
        // A unit whose array lacks cells: the crossed MoM, given on every
        // complete array, is undefined there.
        let incomplete = !a.missing_cells.is_empty()
            && u.intervals
                .iter()
                .flatten()
                .any(|iv| iv.method == crossaudit_stats::IntervalMethod::MomT && iv.lower.is_nan());
        for iv in u.intervals.iter().flatten() {
            if iv.lower.is_nan() || iv.upper.is_nan() {
                table.row([
                    unit_name_in(u, unit_of(u.metric)),
                    iv.method.label().to_string(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    format!("undefined: {}", undefined_because(iv.method, incomplete)),
                    "-".into(),
                ]);
                continue;
            }
            table.row([
                unit_name_in(u, unit_of(u.metric)),
                iv.method.label().to_string(),
                f(iv.estimate, 4),
                f(iv.se, 4),
                if iv.df.is_nan() { "-".to_string() } else { df(iv.df) },
                format!("[{}, {}]", f(iv.lower, 4), f(iv.upper, 4)),
                if iv.lower > 0.0 || iv.upper < 0.0 { "yes" } else { "no" }.to_string(),
            ]);
        }
    }
    table
}
