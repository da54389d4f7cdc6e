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
    // Beyond 1e300 either way a chart shows nothing more, and the padding
    // of a wider span overflows to an infinite axis, whose ticks the
    // plotting library counts out forever.
    let (lo, hi) = (lo.max(-1e300), hi.min(1e300));
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

/// The fonts of every chart: the caption, the tick labels and the axis
/// descriptions, sized to be read at the page's width.
pub const CAPTION_FONT: (&str, u32) = ("sans-serif", 22);
/// Tick labels.
pub const TICK_FONT: (&str, u32) = ("sans-serif", 16);
/// Axis descriptions.
pub const AXIS_FONT: (&str, u32) = ("sans-serif", 17);

/// A chart builder on `root` with the shared caption font, margins (the
/// right one wide enough for the last tick label) and label areas.
pub fn chart<'a, 'b, 'c>(root: &'a Root<'c>, title: &str) -> ChartBuilder<'a, 'b, SVGBackend<'c>> {
    let mut b = ChartBuilder::on(root);
    b.caption(title, CAPTION_FONT).margin(15).margin_right(40).x_label_area_size(55).y_label_area_size(85);
    b
}

/// The "nice" tick step for a raw one: the smallest of 1, 2, 5 or 10 times
/// the power of ten at or below `raw` that is at least `raw`.
pub fn nice_step(raw: f64) -> f64 {
    let magnitude = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * magnitude).find(|s| *s >= raw * (1.0 - 1e-9)).unwrap_or(raw)
}

/// The decimals a tick step needs (0.02: 2; 5: 0), at most 8.
pub fn step_decimals(step: f64) -> usize {
    (-(step.log10() + 1e-9).floor()).clamp(0.0, 8.0) as usize
}

/// Tick labels for an axis of whole numbers (epochs, seeds): the
/// integers, and nothing between them.
pub fn whole(x: &f64) -> String {
    if (x - x.round()).abs() < 1e-9 {
        format!("{x:.0}")
    } else {
        String::new()
    }
}

/// How many labels a mesh asks plotters for on each axis (its default).
pub const LABELS: usize = 11;

/// Tick labels for an axis whose range is `lo..hi` (the range the chart
/// is built on): the values plotters labels there (its own key points for
/// [`LABELS`] labels), each with the fewest decimals, the same on every
/// tick, that keep neighbouring labels apart; never "-0".
pub fn ticks(lo: f64, hi: f64) -> impl Fn(&f64) -> String {
    use plotters::coord::ranged1d::Ranged;
    let points = plotters::coord::types::RangedCoordf64::from(lo..hi).key_points(LABELS);
    let decimals =
        (0..=12).find(|&d| points.windows(2).all(|w| tick_label(w[0], d) != tick_label(w[1], d))).unwrap_or(12);
    move |v| tick_label(*v, decimals)
}

/// `v` with `decimals` decimals, a negative zero without its sign.
fn tick_label(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    match s.strip_prefix('-') {
        Some(rest) if rest.chars().all(|c| c == '0' || c == '.') => rest.to_string(),
        _ => s,
    }
}

/// The drawing area of an SVG drawn into memory.
pub type Root<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

/// Draws an SVG of `size` pixels in memory with `draw`, writes it to
/// `path` atomically (temporary file + rename: an interrupted run never
/// leaves half a figure) and returns its text, so that a page can inline
/// the figure without reading the file back.
pub fn svg_figure(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Root) -> Result<(), DrawError>,
) -> Result<String, DrawError> {
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err(path))?;
        draw(&root)?;
        root.present().map_err(draw_err(path))?;
    }
    crate::io::write_atomic(path, text.as_bytes())
        .map_err(|e| DrawError { path: path.display().to_string(), message: e.to_string() })?;
    Ok(text)
}

/// Ten colours that stay apart from each other (Tableau 10), for charts
/// with one series per estimator or arm.
pub const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// One category of an interval chart: label, point, lower and upper ends.
pub type IntervalRow = (String, f64, f64, f64);

/// Points with vertical interval bars over categories, plus horizontal
/// reference lines. Returns the SVG text.
pub fn intervals(
    path: &Path,
    title: &str,
    y_desc: &str,
    rows: &[IntervalRow],
    lines: &[(f64, RGBColor)],
) -> Result<String, DrawError> {
    let err = draw_err(path);
    svg_figure(path, (900, 480), |root| {
        let (lo, hi) = span(rows.iter().flat_map(|r| [r.1, r.2, r.3]).chain(lines.iter().map(|l| l.0)));
        let n = rows.len().max(1);
        let mut chart = chart(root, title).build_cartesian_2d(-0.5f64..(n as f64 - 0.5), lo..hi).map_err(&err)?;
        let labels: Vec<String> = rows.iter().map(|r| r.0.clone()).collect();
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n)
            .x_label_formatter(&|x| category_label(*x, &labels))
            .y_label_formatter(&ticks(lo, hi))
            .label_style(TICK_FONT)
            .axis_desc_style(AXIS_FONT)
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
        Ok(())
    })
}

/// One dose of a dose-response chart: dose (%), point, lower and upper ends.
pub type DoseRow = (f64, f64, f64, f64);

/// Points with interval bars on a numeric dose axis from 0, the reference
/// arm as the point (0, 0), and the fitted line `intercept + slope x dose`
/// labelled `fit_label`. Returns the SVG text.
pub fn dose_response(
    path: &Path,
    title: &str,
    (y_desc, x_desc): (&str, &str),
    rows: &[DoseRow],
    fit: Option<(f64, f64, String)>,
) -> Result<String, DrawError> {
    let err = draw_err(path);
    svg_figure(path, (900, 480), |root| {
        let max_dose = rows.iter().map(|r| r.0).filter(|d| d.is_finite()).fold(1.0, f64::max) * 1.08;
        let line_ends = fit.iter().flat_map(|(a, b, _)| [*a, a + b * max_dose]);
        let (lo, hi) = span(rows.iter().flat_map(|r| [r.1, r.2, r.3]).chain([0.0]).chain(line_ends));
        let mut chart = chart(root, title).build_cartesian_2d(-max_dose * 0.03..max_dose, lo..hi).map_err(&err)?;
        chart
            .configure_mesh()
            .x_label_formatter(&ticks(-max_dose * 0.03, max_dose))
            .y_label_formatter(&ticks(lo, hi))
            .label_style(TICK_FONT)
            .axis_desc_style(AXIS_FONT)
            .x_desc(x_desc)
            .y_desc(y_desc)
            .draw()
            .map_err(&err)?;
        chart.draw_series(LineSeries::new(vec![(0.0, 0.0), (max_dose, 0.0)], BLACK)).map_err(&err)?;
        if let Some((a, b, label)) = &fit {
            let red = PALETTE[3];
            chart
                .draw_series(LineSeries::new(vec![(0.0, *a), (max_dose, a + b * max_dose)], red.stroke_width(2)))
                .map_err(&err)?
                .label(label.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], red.stroke_width(2)));
        }
        let blue = PALETTE[0];
        chart
            .draw_series(rows.iter().map(|r| PathElement::new(vec![(r.0, r.2), (r.0, r.3)], blue.stroke_width(2))))
            .map_err(&err)?;
        chart
            .draw_series(rows.iter().map(|r| Circle::new((r.0, r.1), 5, blue.filled())))
            .map_err(&err)?
            .label("estimate per dose, with its interval")
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, blue.filled()));
        chart
            .draw_series(std::iter::once(Circle::new((0.0, 0.0), 5, BLACK.stroke_width(2))))
            .map_err(&err)?
            .label("reference arm (dose 0)")
            .legend(|(x, y)| Circle::new((x + 10, y), 5, BLACK.stroke_width(2)));
        // The key where the line is not: above it when optimism grows with dose.
        let rising = fit.as_ref().is_none_or(|f| f.1 >= 0.0);
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .position(if rising { SeriesLabelPosition::UpperLeft } else { SeriesLabelPosition::LowerLeft })
            .draw()
            .map_err(&err)?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::{ticks, whole};

    #[test]
    fn tick_labels_carry_the_steps_decimals_and_no_negative_zero() {
        // Span 0.135: plotters labels every 0.02 (0.24, 0.26, ...): two decimals.
        let f = ticks(0.225, 0.36);
        assert_eq!([f(&0.3), f(&0.34)], ["0.30", "0.34"]);
        // Span 0.06: every 0.01 (not 0.006's three decimals).
        let f = ticks(-0.056, 0.004);
        assert_eq!([f(&-0.05), f(&-0.0), f(&-1e-17)], ["-0.05", "0.00", "0.00"]);
        // Span 45: every 5, no decimals.
        let f = ticks(-4.0, 41.0);
        assert_eq!([f(&35.0), f(&-0.2)], ["35", "0"]);
        assert_eq!([whole(&2.0), whole(&2.5)], ["2", ""]);
    }

    /// A range plotters labels every 0.005 (the lab study's interaction
    /// axis, -0.034 to 0.021): three decimals, every neighbour distinct,
    /// where a step guessed from a tenth of the span (0.01) gave
    /// `-0.03, -0.03, -0.02, -0.02, ...`.
    #[test]
    fn neighbouring_tick_labels_differ_at_every_precision() {
        use plotters::coord::ranged1d::Ranged;
        for (lo, hi) in
            [(-0.034, 0.021), (-0.0562, -0.0041), (0.0, 1.0), (0.2101, 0.2102), (-4.0, 41.0), (1e5, 1e5 + 3.0)]
        {
            let points = plotters::coord::types::RangedCoordf64::from(lo..hi).key_points(super::LABELS);
            let f = ticks(lo, hi);
            let labels: Vec<String> = points.iter().map(&f).collect();
            assert!(labels.len() >= 3, "{lo}..{hi}: {labels:?}");
            assert!(labels.windows(2).all(|w| w[0] != w[1]), "{lo}..{hi}: {labels:?}");
        }
        let points = plotters::coord::types::RangedCoordf64::from(-0.034..0.021).key_points(super::LABELS);
        assert!(points.windows(2).any(|w| (w[1] - w[0] - 0.005).abs() < 1e-12), "{points:?}");
        assert_eq!(ticks(-0.034, 0.021)(&-0.025), "-0.025");
    }

    /// Values near the double's limit: the span and its padding stay
    /// finite, and plotters counts out the axis's ticks (an infinite end
    /// hung it: a training curve's edited loss of 1.7e308 did).
    #[test]
    fn a_span_of_the_largest_doubles_is_a_finite_axis_with_ticks() {
        use plotters::coord::ranged1d::Ranged;
        for values in [[-1.7e308, 1.7e308], [0.01, 1.79e308], [-f64::MAX, 0.0]] {
            let (lo, hi) = super::span(values.into_iter());
            assert!(lo.is_finite() && hi.is_finite() && lo < hi, "{values:?}: {lo}..{hi}");
            let points = plotters::coord::types::RangedCoordf64::from(lo..hi).key_points(super::LABELS);
            assert!(!points.is_empty(), "{values:?}");
        }
    }
}
