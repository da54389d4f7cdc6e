//! Shared plotters helpers: every SVG chart of the report and the
//! methodologists' tools is drawn through these.

use std::path::Path;

use plotters::prelude::*;

/// A chart that could not be drawn, with its file.
#[derive(Debug, thiserror::Error)]
#[error("cannot draw {path}: {message}")]
pub struct DrawError {
    /// The SVG file.
    pub path: String,
    /// plotters' reason.
    pub message: String,
}

/// Moves a finished SVG from its staging file ([`crate::io::tmp_path`]) to
/// `path`: figures are drawn into the staging file and renamed, so that an
/// interrupted run never leaves half a figure.
pub fn finish_svg(path: &Path) -> Result<(), DrawError> {
    std::fs::rename(crate::io::tmp_path(path), path)
        .map_err(|e| DrawError { path: path.display().to_string(), message: e.to_string() })
}

/// Maps any plotters error to a [`DrawError`] for `path`.
pub fn draw_err<E: std::fmt::Debug>(path: &Path) -> impl Fn(E) -> DrawError + '_ {
    move |e| DrawError { path: path.display().to_string(), message: format!("{e:?}") }
}

/// The padded range of the finite values, or (-1, 1) when there are none.
pub fn span(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let pad = ((hi - lo) * 0.1).max(1e-6);
    (lo - pad, hi + pad)
}

/// The label of category k at x = k on a categorical axis; empty between
/// categories.
pub fn category_label(x: f64, labels: &[String]) -> String {
    let k = x.round();
    if (x - k).abs() < 1e-6 && k >= 0.0 && (k as usize) < labels.len() {
        labels[k as usize].clone()
    } else {
        String::new()
    }
}

/// One category of an interval chart: label, point, lower and upper ends.
pub type IntervalRow = (String, f64, f64, f64);

/// Points with vertical interval bars over categories, plus horizontal
/// reference lines.
pub fn intervals(
    path: &Path,
    title: &str,
    y_desc: &str,
    rows: &[IntervalRow],
    lines: &[(f64, RGBColor)],
) -> Result<(), DrawError> {
    let err = draw_err(path);
    let staged = crate::io::tmp_path(path);
    let root = SVGBackend::new(&staged, (900, 480)).into_drawing_area();
    root.fill(&WHITE).map_err(&err)?;
    let (lo, hi) = span(rows.iter().flat_map(|r| [r.1, r.2, r.3]).chain(lines.iter().map(|l| l.0)));
    let n = rows.len().max(1);
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(70)
        .build_cartesian_2d(-0.5f64..(n as f64 - 0.5), lo..hi)
        .map_err(&err)?;
    let labels: Vec<String> = rows.iter().map(|r| r.0.clone()).collect();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(n)
        .x_label_formatter(&|x| category_label(*x, &labels))
        .y_desc(y_desc)
        .draw()
        .map_err(&err)?;
    for (y, color) in lines {
        chart.draw_series(LineSeries::new(vec![(-0.5, *y), (n as f64 - 0.5, *y)], color)).map_err(&err)?;
    }
    chart
        .draw_series(
            rows.iter()
                .enumerate()
                .map(|(k, r)| PathElement::new(vec![(k as f64, r.2), (k as f64, r.3)], BLUE.stroke_width(2))),
        )
        .map_err(&err)?;
    chart
        .draw_series(rows.iter().enumerate().map(|(k, r)| Circle::new((k as f64, r.1), 5, BLUE.filled())))
        .map_err(&err)?;
    root.present().map_err(&err)?;
    finish_svg(path)
}
