//! The zip plot of a coverage study (Morris, White & Crowther 2019,
//! Fig. 3): per estimator, every interval of one setting drawn as a
//! horizontal line, ranked by how far its estimate is from the truth in
//! its own SE units (|estimate - mu| / SE, the fractional centile on the
//! vertical axis). Intervals that miss the truth are red and gather at the
//! top; where the red begins is the coverage, beside the nominal level.

use std::path::Path;

use crate::report::charts::{draw_err, DrawError};
use crossaudit_stats::coverage::{usable, Simulated};

/// At most this many intervals per panel, taken evenly by rank (the shape
/// of the zip does not change; the figure stays small).
const MAX_LINES: usize = 400;

/// Draws `zip.svg` for the first true mean and level of one setting.
pub fn draw_zip(path: &Path, sim: &Simulated, mu: f64) -> Result<(), DrawError> {
    use plotters::prelude::*;
    let e = draw_err(path);
    let level = sim.levels.first().copied().unwrap_or(0.95);
    let panels = sim.methods.len().max(1);
    let cols = 3usize;
    let rows = panels.div_ceil(cols);
    let (width, height) = (1200u32, 60 + 330 * rows as u32);
    // One horizontal scale for every panel: mu -+ the widest typical interval.
    let half = sim.replications[0]
        .iter()
        .flat_map(|reps| reps.iter().filter(|(e, _, _)| usable(e)).map(|(e, _, _)| (e.3 - e.2).abs()))
        .filter(|w| w.is_finite())
        .fold(0.0f64, f64::max)
        .clamp(1.0, 20.0);
    crate::report::charts::svg_figure(path, (width, height), |root| {
        let (title, body) = root.split_vertically(50);
        // Drawn around 0, where the intervals were computed: shifted by a
        // true mean of 1e20, an interval would round to a point.
        let frame = if mu == 0.0 { "" } else { " (drawn minus mu)" };
        let text = format!(
            "Zip plot: {}, true mean {mu}, nominal {level}: intervals ranked by |estimate - mu| / SE{frame}",
            sim.label
        );
        title.draw(&Text::new(text, (20, 15), ("sans-serif", 18))).map_err(&e)?;
        let areas = body.split_evenly((rows, cols));
        for (k, method) in sim.methods.iter().enumerate() {
            let area = &areas[k];
            let mut ranked: Vec<(f64, f64, f64)> = sim.replications[0][k]
                .iter()
                .filter(|(e, _, _)| usable(e))
                .map(|(e, _, _)| (e.0.abs() / e.1, e.2, e.3))
                .collect();
            ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
            let n = ranked.len();
            let covered = ranked.iter().filter(|r| r.1 <= 0.0 && 0.0 <= r.2).count();
            let coverage = covered as f64 / n.max(1) as f64;
            let mut chart = ChartBuilder::on(area)
                .caption(format!("{} ({:.3})", method.label(), coverage), ("sans-serif", 14))
                .margin(8)
                .x_label_area_size(25)
                .y_label_area_size(40)
                .build_cartesian_2d(-half..half, 0.0..100.0)
                .map_err(&e)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_labels(5)
                .y_labels(5)
                .label_style(("sans-serif", 11))
                .draw()
                .map_err(&e)?;
            let step = n.div_ceil(MAX_LINES).max(1);
            let miss = RGBColor(214, 39, 40);
            let hit = RGBColor(120, 150, 190);
            chart
                .draw_series(ranked.iter().enumerate().step_by(step).map(|(i, &(_, lo, hi))| {
                    let y = 100.0 * (i as f64 + 0.5) / n as f64;
                    let color = if lo <= 0.0 && 0.0 <= hi { hit } else { miss };
                    PathElement::new(vec![(lo.max(-half), y), (hi.min(half), y)], color.stroke_width(1))
                }))
                .map_err(&e)?;
            // The truth, the nominal level (black) and the coverage (orange).
            chart.draw_series(LineSeries::new(vec![(0.0, 0.0), (0.0, 100.0)], BLACK)).map_err(&e)?;
            for (y, color) in [(100.0 * level, BLACK), (100.0 * coverage, RGBColor(255, 127, 14))] {
                chart.draw_series(LineSeries::new(vec![(-half, y), (half, y)], color)).map_err(&e)?;
            }
        }
        Ok(())
    })?;
    Ok(())
}
