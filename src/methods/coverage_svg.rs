//! coverage.svg (and simsum.svg): coverage per setting and estimator with
//! 2-MCSE bars and each row's nominal level.

use std::path::Path;

use crate::report::charts::{category_label, draw_err, DrawError};
use crossaudit_stats::coverage::Performance;

/// What the figure needs of a coverage spec: each row's setting group,
/// the nominal levels and the replications per setting.
pub struct PanelLayout<'a> {
    /// The setting group a row is plotted in.
    pub group: &'a dyn Fn(&Performance) -> String,
    /// The nominal levels.
    pub levels: Vec<f64>,
    /// Replications per setting.
    pub reps: usize,
}

/// One point of the figure.
#[derive(Debug, Clone)]
pub struct Point {
    /// The setting (group) it is plotted in.
    pub group: String,
    /// The estimator (method), one colour and marker each.
    pub method: String,
    /// The coverage.
    pub coverage: f64,
    /// Its MCSE (no bar when not finite).
    pub mcse: f64,
    /// The group's nominal level.
    pub level: f64,
}

/// Coverage per setting and estimator of a coverage grid
/// ([`draw_points`]).
pub fn draw(path: &Path, spec: &PanelLayout<'_>, rows: &[Performance]) -> Result<(), DrawError> {
    let points: Vec<Point> = rows
        .iter()
        .map(|r| Point {
            group: (spec.group)(r),
            method: r.method.label().to_string(),
            coverage: r.coverage,
            mcse: r.coverage_mcse,
            level: r.level,
        })
        .collect();
    let levels = spec.levels.iter().map(|l| l.to_string()).collect::<Vec<_>>().join(", ");
    let title = format!("Coverage (nominal {levels}), 2-MCSE bars, {} reps", spec.reps);
    draw_points(path, &title, &spec.levels, &points)
}

// `$body` with `$mk`, estimator k's marker at a point: a circle, a
// triangle or a square by turn, so that estimators stay apart without
// colour too.
macro_rules! with_marker {
    ($k:expr, $style:expr, $mk:ident => $body:expr) => {
        match $k % 3 {
            0 => {
                let $mk = |p| EmptyElement::at(p) + Circle::new((0, 0), 4, $style);
                $body
            }
            1 => {
                let $mk = |p| EmptyElement::at(p) + TriangleMarker::new((0, 0), 5, $style);
                $body
            }
            _ => {
                let $mk = |p| EmptyElement::at(p) + Rectangle::new([(-4, -4), (4, 4)], $style);
                $body
            }
        }
    };
}

/// Coverage per group and method with 2-MCSE bars and the nominal line.
/// Each method has its own colour and marker, the key of the methods sits
/// beside the plot (it hides no point) and the key of the numbered groups
/// below it.
pub fn draw_points(path: &Path, title: &str, levels: &[f64], rows: &[Point]) -> Result<(), DrawError> {
    use plotters::prelude::*;
    let e = draw_err(path);
    let settings = first_seen(rows.iter().map(|r| r.group.as_str()));
    let nominal: Vec<f64> =
        settings.iter().map(|g| rows.iter().find(|r| r.group == *g).map_or(f64::NAN, |r| r.level)).collect();
    let methods = first_seen(rows.iter().map(|r| r.method.as_str()));
    let labels: Vec<String> = (1..=settings.len()).map(|k| k.to_string()).collect();
    // The settings' key: three columns of "k. label" lines under the plot.
    let key_rows = settings.len().div_ceil(3);
    let (width, plot_height) = (1100u32, 520u32);
    let height = plot_height + 30 + 18 * key_rows as u32;
    crate::report::charts::svg_figure(path, (width, height), |root| {
        let (top, key) = root.split_vertically(plot_height);
        let (plot, side) = top.split_horizontally(width - 250);
        let lo = lowest_shown(rows, levels);
        let n = settings.len();
        let mut chart = crate::report::charts::chart(&plot, title)
            .build_cartesian_2d(-0.5f64..(n as f64 - 0.5), (lo - 0.02)..1.0)
            .map_err(&e)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n)
            .x_label_formatter(&|x| category_label(*x, &labels))
            .y_label_formatter(&crate::report::charts::ticks(lo - 0.02, 1.0))
            .label_style(crate::report::charts::TICK_FONT)
            .axis_desc_style(crate::report::charts::AXIS_FONT)
            .x_desc("setting (numbered below)")
            .y_desc("coverage")
            .draw()
            .map_err(&e)?;
        // The nominal level: one line, or each group's own.
        if nominal.iter().all(|l| *l == nominal[0]) {
            chart
                .draw_series(LineSeries::new(vec![(-0.5, nominal[0]), (n as f64 - 0.5, nominal[0])], BLACK))
                .map_err(&e)?;
        } else {
            chart
                .draw_series(
                    nominal
                        .iter()
                        .enumerate()
                        .map(|(k, l)| PathElement::new(vec![(k as f64 - 0.45, *l), (k as f64 + 0.45, *l)], BLACK)),
                )
                .map_err(&e)?;
        }
        let palette = crate::report::charts::PALETTE;
        for (k, m) in methods.iter().enumerate() {
            let color = palette[k % palette.len()];
            let dx = (k as f64 - (methods.len() as f64 - 1.0) / 2.0) * 0.07;
            let pts = method_points(rows, &settings, m, dx);
            chart
                .draw_series(
                    pts.iter().map(|(x, c, m)| PathElement::new(vec![(*x, c - 2.0 * m), (*x, c + 2.0 * m)], color)),
                )
                .map_err(&e)?;
            with_marker!(k, color.filled(), mk => {
                chart.draw_series(pts.iter().map(|(x, c, _)| mk((*x, *c)))).map(|_| ())
            })
            .map_err(&e)?;
        }
        draw_keys(&side, &key, &methods, &settings, key_rows).map_err(&e)
    })?;
    Ok(())
}

/// The distinct values in the order first seen.
fn first_seen<'a>(values: impl Iterator<Item = &'a str>) -> Vec<&'a str> {
    let mut out: Vec<&str> = Vec::new();
    for v in values {
        if !out.contains(&v) {
            out.push(v);
        }
    }
    out
}

/// The methods' key beside the plot (each one's colour and marker) and
/// the numbered settings' key below it, in `key_rows` rows of three
/// columns.
fn draw_keys(
    side: &crate::report::charts::Root,
    key: &crate::report::charts::Root,
    methods: &[&str],
    settings: &[&str],
    key_rows: usize,
) -> Result<(), plotters::drawing::DrawingAreaErrorKind<std::io::Error>> {
    use plotters::prelude::*;
    let palette = crate::report::charts::PALETTE;
    side.draw(&Text::new("estimator", (10, 40), ("sans-serif", 15).into_font().style(FontStyle::Bold)))?;
    for (k, m) in methods.iter().enumerate() {
        let color = palette[k % palette.len()];
        let y = 64 + 22 * k as i32;
        side.draw(&PathElement::new(vec![(14, y - 8), (14, y + 8)], color))?;
        with_marker!(k, color.filled(), mk => side.draw(&mk((14, y))))?;
        side.draw(&Text::new(m.to_string(), (30, y - 7), ("sans-serif", 14)))?;
    }
    key.draw(&Text::new("settings", (20, 6), ("sans-serif", 14).into_font().style(FontStyle::Bold)))?;
    for (k, s) in settings.iter().enumerate() {
        let (col, row) = (k / key_rows, k % key_rows);
        let at = (20 + 360 * col as i32, 26 + 18 * row as i32);
        key.draw(&Text::new(format!("{}. {s}", k + 1), at, ("sans-serif", 12)))?;
    }
    Ok(())
}

/// The lowest coverage the plot shows: the lowest nominal level or 2 MCSEs
/// below the lowest coverage, whichever is lower, and not below 0.
fn lowest_shown(rows: &[Point], levels: &[f64]) -> f64 {
    let lowest = levels.iter().copied().fold(1.0, f64::min);
    rows.iter()
        .map(|r| r.coverage - 2.0 * if r.mcse.is_finite() { r.mcse } else { 0.0 })
        .filter(|x| x.is_finite())
        .fold(lowest, f64::min)
        .max(0.0)
}

/// The method `m`'s points as (x, coverage, MCSE): at its setting's place
/// shifted by `dx`, an MCSE of 0 (no bar) where it has none (fewer than 2
/// usable replications).
fn method_points(rows: &[Point], settings: &[&str], m: &str, dx: f64) -> Vec<(f64, f64, f64)> {
    rows.iter()
        .filter(|r| r.method == m && r.coverage.is_finite())
        .map(|r| {
            let x = settings.iter().position(|s| *s == r.group).unwrap_or(0) as f64 + dx;
            (x, r.coverage, if r.mcse.is_finite() { r.mcse } else { 0.0 })
        })
        .collect()
}
