//! SVG figures of a run (plotters): apparent optimism with intervals per
//! model and horizon, the interaction, per-seed optimism against the
//! threshold, treated - reference by trajectory family, training curves.
//! Everything drawn comes from the [`Analysis`] and the curves passed in;
//! nothing here reads a file.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use super::charts::{chart, draw_err, intervals, span, ticks, whole, DrawError, IntervalRow, AXIS_FONT, TICK_FONT};
use super::format::level_pct;
use crate::analysis::Analysis;

/// One fitted job's validation loss per epoch (the run folder's record holds them).
pub use crate::analysis::record::Curve;

/// A figure written: its file and its SVG text.
pub type Figure = (PathBuf, String);

/// The figures as (file name, SVG text), as a page inlines them.
pub fn by_name(figures: Vec<Figure>) -> Vec<(String, String)> {
    figures.into_iter().filter_map(|(p, svg)| p.file_name().map(|f| (f.to_string_lossy().into_owned(), svg))).collect()
}

/// Writes the figures into `report_dir` and returns the files written
/// with their SVG text.
pub fn write_figures(a: &Analysis, curves: &[Curve], report_dir: &Path) -> Result<Vec<Figure>, DrawError> {
    let mut written = Vec::new();
    let mut lines = vec![(0.0, BLACK)];
    if let Some(t) = a.decision.rule.optimism_threshold() {
        lines.push((t, RED));
    }
    let contrast = format!("{} vs {}", a.treated, a.reference);

    // Optimism = -100 d / mean_reference, so its interval is the d interval
    // rescaled (and flipped).
    let rows: Vec<IntervalRow> = a
        .units
        .iter()
        .map(|u| {
            let k = -100.0 / u.mean_reference;
            // The endpoint the decision rule is evaluated on is named so.
            let primary = if u.role == crate::design::Role::Primary { " (primary)" } else { "" };
            let name = format!("{} {} s{primary}", u.model, u.horizon_s);
            (name, u.optimism_pct, u.estimate.upper * k, u.estimate.lower * k)
        })
        .collect();
    let p = report_dir.join("optimism.svg");
    let title = format!("Apparent optimism ({contrast}), {} crossed intervals", level_pct(a.level));
    let svg = intervals(&p, &label(a, &title), "optimism (%)", &rows, &lines)?;
    written.push((p, svg));

    if let Some(first) = a.interactions.first() {
        let rows: Vec<IntervalRow> = a
            .interactions
            .iter()
            .map(|ix| (format!("{} s", ix.horizon_s), ix.estimate.mean, ix.estimate.lower, ix.estimate.upper))
            .collect();
        let p = report_dir.join("interaction.svg");
        let title = format!("Interaction: d({}) - d({})", first.left, first.right);
        let axis = format!("difference in d ({})", super::format::unit_label(first.metric.unit()));
        let svg = intervals(&p, &label(a, &title), &axis, &rows, &[(0.0, BLACK)])?;
        written.push((p, svg));
    }

    if let Some(primary) = a.units.first() {
        let rows: Vec<IntervalRow> = primary
            .per_seed_optimism
            .iter()
            .map(|s| (s.seed.to_string(), s.optimism_pct, s.optimism_pct, s.optimism_pct))
            .collect();
        let p = report_dir.join("per_seed_optimism.svg");
        let title = format!("Per-seed optimism, {} at {} s (red: threshold)", primary.model, primary.horizon_s);
        let svg = intervals(&p, &label(a, &title), "optimism (%)", &rows, &lines)?;
        written.push((p, svg));

        let rows: Vec<IntervalRow> = primary
            .per_trajectory
            .iter()
            .map(|t| {
                let d = t.mean_difference;
                (format!("{} ({})", t.trajectory, t.recordings), d, d, d)
            })
            .collect();
        let p = report_dir.join("trajectory_differences.svg");
        let title = format!(
            "{} - {} by trajectory family, {} at {} s",
            capitalize(&a.treated),
            a.reference,
            primary.model,
            primary.horizon_s
        );
        let axis = format!("mean d ({})", super::format::unit_label(primary.metric.unit()));
        let svg = intervals(&p, &label(a, &title), &axis, &rows, &[(0.0, BLACK)])?;
        written.push((p, svg));
    }

    if !curves.is_empty() {
        let p = report_dir.join("training_curves.svg");
        let svg = draw_curves(&p, a, curves)?;
        written.push((p, svg));
    }
    Ok(written)
}

/// The figures of a single study drawn only where its analysis has what
/// they show (an interaction, training curves).
pub(super) const OPTIONAL: [&str; 2] = ["interaction.svg", "training_curves.svg"];

/// A figure title, prefixed `EXPLORATORY:` when the analysis is not the
/// preregistered one.
fn label(a: &Analysis, title: &str) -> String {
    if a.header.standing.exploratory() {
        format!("EXPLORATORY: {title}")
    } else {
        title.to_string()
    }
}

fn capitalize(s: &str) -> String {
    let mut c = s.chars();
    c.next().map(|f| f.to_uppercase().chain(c).collect()).unwrap_or_default()
}

/// Every curve, the treated arm's in blue and the others in orange.
fn draw_curves(path: &Path, a: &Analysis, curves: &[Curve]) -> Result<String, DrawError> {
    let err = draw_err(path);
    super::charts::svg_figure(path, (900, 480), |root| {
        let epochs = curves.iter().flat_map(|c| c.points.iter().map(|p| p.0));
        let max_epoch = epochs.filter(|e| e.is_finite()).fold(1.0, f64::max);
        let (lo, hi) = span(curves.iter().flat_map(|c| c.points.iter().map(|p| p.1)));
        let title =
            format!("Validation loss per epoch, every training cell (blue: {}, orange: {})", a.treated, a.reference);
        let mut chart =
            chart(root, &label(a, &title)).build_cartesian_2d(0.0..max_epoch, lo.max(0.0)..hi).map_err(&err)?;
        chart
            .configure_mesh()
            .x_label_formatter(&whole)
            .y_label_formatter(&ticks(lo.max(0.0), hi))
            .label_style(TICK_FONT)
            .axis_desc_style(AXIS_FONT)
            .x_desc("epoch")
            .y_desc("validation loss (standardized MSE)")
            .draw()
            .map_err(&err)?;
        for c in curves {
            let color = if c.arm == a.treated { BLUE.mix(0.5) } else { RGBColor(230, 120, 20).mix(0.5) };
            chart.draw_series(LineSeries::new(c.points.iter().copied(), color)).map_err(&err)?;
        }
        Ok(())
    })
}
