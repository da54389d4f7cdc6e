//! SVG figures of a run (plotters): apparent optimism with intervals per
//! model and horizon, the interaction, per-seed optimism against the
//! threshold, contaminated - disjoint by trajectory family, training curves.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use crate::analysis::Analysis;
use crate::design::Quantity;
use crate::Error;

type Res = Result<(), String>;

fn err<E: std::fmt::Debug>(e: E) -> String {
    format!("{e:?}")
}

fn span(values: impl Iterator<Item = f64>) -> (f64, f64) {
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

/// Points with vertical interval bars over categories, plus horizontal
/// reference lines.
fn intervals(
    path: &Path,
    title: &str,
    y_desc: &str,
    rows: &[(String, f64, f64, f64)],
    lines: &[(f64, RGBColor)],
) -> Res {
    let root = SVGBackend::new(path, (900, 480)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let (lo, hi) = span(rows.iter().flat_map(|r| [r.1, r.2, r.3]).chain(lines.iter().map(|l| l.0)));
    let n = rows.len().max(1);
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(70)
        .build_cartesian_2d(-0.5f64..(n as f64 - 0.5), lo..hi)
        .map_err(err)?;
    let labels: Vec<String> = rows.iter().map(|r| r.0.clone()).collect();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(n)
        .x_label_formatter(&|x| category_label(*x, &labels))
        .y_desc(y_desc)
        .draw()
        .map_err(err)?;
    for (y, color) in lines {
        chart.draw_series(LineSeries::new(vec![(-0.5, *y), (n as f64 - 0.5, *y)], color)).map_err(err)?;
    }
    chart
        .draw_series(
            rows.iter()
                .enumerate()
                .map(|(k, r)| PathElement::new(vec![(k as f64, r.2), (k as f64, r.3)], BLUE.stroke_width(2))),
        )
        .map_err(err)?;
    chart
        .draw_series(rows.iter().enumerate().map(|(k, r)| Circle::new((k as f64, r.1), 5, BLUE.filled())))
        .map_err(err)?;
    root.present().map_err(err)
}

/// The label of category k at x = k on a categorical axis; empty between
/// categories.
pub(crate) fn category_label(x: f64, labels: &[String]) -> String {
    let k = x.round();
    if (x - k).abs() < 1e-6 && k >= 0.0 && (k as usize) < labels.len() {
        labels[k as usize].clone()
    } else {
        String::new()
    }
}

fn threshold(a: &Analysis) -> Option<f64> {
    a.decision
        .conditions
        .iter()
        .find(|c| c.quantity == Quantity::Optimism)
        .and_then(|c| c.condition.split_whitespace().nth(2).and_then(|v| v.trim_end_matches('%').parse().ok()))
}

/// Writes the figures into `report_dir`; training curves are read from
/// `run_dir/curves/`. Returns the files written.
pub fn write_figures(a: &Analysis, run_dir: &Path, report_dir: &Path) -> Result<Vec<PathBuf>, Error> {
    let mut written = Vec::new();
    let fail = |what: &str, e: String| Error::Cell(format!("cannot draw {what}: {e}"));
    let t = threshold(a);
    let mut lines = vec![(0.0, BLACK)];
    if let Some(t) = t {
        lines.push((t, RED));
    }

    // Optimism = -100 d / mean_reference, so its interval is the d interval
    // rescaled (and flipped).
    let rows: Vec<(String, f64, f64, f64)> = a
        .units
        .iter()
        .map(|u| {
            let k = -100.0 / u.mean_reference;
            (format!("{} {} s", u.model, u.horizon_s), u.optimism_pct, u.estimate.upper * k, u.estimate.lower * k)
        })
        .collect();
    let p = report_dir.join("optimism.svg");
    intervals(&p, "Apparent optimism (contaminated vs disjoint), 95% crossed intervals", "optimism (%)", &rows, &lines)
        .map_err(|e| fail("optimism.svg", e))?;
    written.push(p);

    if !a.interactions.is_empty() {
        let rows: Vec<(String, f64, f64, f64)> = a
            .interactions
            .iter()
            .map(|ix| (format!("{} s", ix.horizon_s), ix.estimate.mean, ix.estimate.lower, ix.estimate.upper))
            .collect();
        let p = report_dir.join("interaction.svg");
        let title = format!("Interaction: d({}) - d({})", a.interactions[0].left, a.interactions[0].right);
        intervals(&p, &title, "difference in d (m)", &rows, &[(0.0, BLACK)]).map_err(|e| fail("interaction.svg", e))?;
        written.push(p);
    }

    if let Some(primary) = a.units.first() {
        let rows: Vec<(String, f64, f64, f64)> = primary
            .per_seed_optimism
            .iter()
            .map(|s| (s.seed.to_string(), s.optimism_pct, s.optimism_pct, s.optimism_pct))
            .collect();
        let p = report_dir.join("per_seed_optimism.svg");
        let title = format!("Per-seed optimism, {} at {} s (red: threshold)", primary.model, primary.horizon_s);
        intervals(&p, &title, "optimism (%)", &rows, &lines).map_err(|e| fail("per_seed_optimism.svg", e))?;
        written.push(p);

        let rows: Vec<(String, f64, f64, f64)> = primary
            .per_trajectory
            .iter()
            .map(|t| {
                (
                    format!("{} ({})", t.trajectory, t.recordings),
                    t.mean_difference,
                    t.mean_difference,
                    t.mean_difference,
                )
            })
            .collect();
        let p = report_dir.join("trajectory_differences.svg");
        let title =
            format!("Contaminated - disjoint by trajectory family, {} at {} s", primary.model, primary.horizon_s);
        intervals(&p, &title, "mean d (m)", &rows, &[(0.0, BLACK)])
            .map_err(|e| fail("trajectory_differences.svg", e))?;
        written.push(p);
    }

    let curves = read_curves(&run_dir.join("curves"));
    if !curves.is_empty() {
        let p = report_dir.join("training_curves.svg");
        draw_curves(&p, &curves).map_err(|e| fail("training_curves.svg", e))?;
        written.push(p);
    }
    Ok(written)
}

/// (cell name, [(epoch, validation loss)]) for every curve file, sorted.
fn read_curves(dir: &Path) -> Vec<(String, Vec<(f64, f64)>)> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    paths.sort();
    paths
        .into_iter()
        .map(|p| {
            let name = p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            let text = std::fs::read_to_string(&p).unwrap_or_default();
            let pts = text
                .lines()
                .skip(1)
                .filter_map(|l| {
                    let f: Vec<&str> = l.split(',').collect();
                    Some((f.first()?.parse().ok()?, f.get(3)?.parse().ok()?))
                })
                .collect();
            (name, pts)
        })
        .collect()
}

fn draw_curves(path: &Path, curves: &[(String, Vec<(f64, f64)>)]) -> Res {
    let root = SVGBackend::new(path, (900, 480)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let max_epoch = curves.iter().flat_map(|c| c.1.iter().map(|p| p.0)).fold(1.0, f64::max);
    let (lo, hi) = span(curves.iter().flat_map(|c| c.1.iter().map(|p| p.1)));
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Validation loss per epoch, every training cell (blue: contaminated, orange: disjoint)",
            ("sans-serif", 18),
        )
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..max_epoch, lo.max(0.0)..hi)
        .map_err(err)?;
    chart.configure_mesh().x_desc("epoch").y_desc("validation loss (standardized MSE)").draw().map_err(err)?;
    for (name, pts) in curves {
        let color = if name.contains("__contaminated__") { BLUE.mix(0.5) } else { RGBColor(230, 120, 20).mix(0.5) };
        chart.draw_series(LineSeries::new(pts.iter().copied(), color)).map_err(err)?;
    }
    root.present().map_err(err)
}
