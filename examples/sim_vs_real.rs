//! Simulated against real NanoBench recordings of the same trajectory and
//! speed: hover PWM, speed and acceleration ranges, battery sag, and an
//! x-y overlay of a real and a simulated trefoil.
//!
//!     cargo run --release --example sim_vs_real -- OUT_DIR
//!
//! Reads ../shared/nanobench/recordings; simulates 24 recordings (one per
//! trajectory x speed slot) with seed 7, strength 1, 20 s each.

use std::path::Path;

use crossaudit::data::{load_recording, Layout, Recording};
use crossaudit::sim::{simulate, SimSpec};
use plotters::prelude::*;

fn quantile(mut v: Vec<f64>, p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    crossaudit::stats::quantile_type7(&v, p)
}

/// (median PWM, speed p5, speed p95, |acceleration| p95, battery sag V/min)
fn summary(r: &Recording) -> [f64; 5] {
    let act: Vec<usize> = (0..r.rows).filter(|&k| r.active[k]).collect();
    let pwm: Vec<f64> = act.iter().map(|&k| r.pwm[k].iter().sum::<f64>() / 4.0).collect();
    let speed: Vec<f64> =
        act.iter().map(|&k| (r.state[k][3].powi(2) + r.state[k][4].powi(2) + r.state[k][5].powi(2)).sqrt()).collect();
    let acc: Vec<f64> = act
        .windows(2)
        .filter(|w| w[1] == w[0] + 1)
        .map(|w| {
            let dt = (r.t[w[1]] - r.t[w[0]]).max(1e-3);
            ((0..3).map(|i| (r.state[w[1]][3 + i] - r.state[w[0]][3 + i]).powi(2)).sum::<f64>()).sqrt() / dt
        })
        .collect();
    let (a, b) = (act[0], act[act.len() - 1]);
    let minutes = (r.t[b] - r.t[a]) / 60.0;
    let sag = (r.state[a][13] - r.state[b][13]) / minutes;
    [quantile(pwm, 0.5), quantile(speed.clone(), 0.05), quantile(speed, 0.95), quantile(acc, 0.95), sag]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).ok_or("usage: sim_vs_real OUT_DIR")?;
    let out = Path::new(&out);
    std::fs::create_dir_all(out)?;
    let real_dir = Path::new("../shared/nanobench/recordings");
    let design = crossaudit::design::load(Path::new("designs/nanobench_confirmatory.design"))?.design;
    let layout = Layout::new(&design.data)?;
    let sim_dir = out.join("simulated_data");
    simulate(&SimSpec { recordings: 24, seed: 7, strength: 1.0, duration_s: 20.0 }, &sim_dir)?;
    let pairs = [
        ("circle", "slow", "B2_circle_slow_rep1", "S01_circle_slow_rep1"),
        ("circle", "fast", "B2_circle_fast_rep1", "S03_circle_fast_rep1"),
        ("figure_eight", "medium", "B3_figure8_medium_rep1", "S05_figure_eight_medium_rep1"),
        ("helix", "fast", "B5_helix_fast_rep1", "S09_helix_fast_rep1"),
        ("oval", "medium", "B7_oval_medium_rep1", "S11_oval_medium_rep1"),
        ("star", "slow", "B8_star_slow_rep1", "S13_star_slow_rep1"),
        ("trefoil", "medium", "B9_trefoil_medium_rep1", "S17_trefoil_medium_rep1"),
        ("lissajous", "fast", "B10_lissajous_fast_rep1", "S21_lissajous_fast_rep1"),
    ];
    let mut md = String::from("| trajectory | speed | source | hover PWM (median) | speed p5-p95 (m/s) | acceleration p95 (m/s^2) | battery sag (V/min) |\n|---|---|---|---:|---|---:|---:|\n");
    let mut trefoil = Vec::new();
    for (traj, speed, real, sim) in pairs {
        let r = load_recording(&real_dir.join(format!("{real}.csv.gz")), &layout)?;
        let s = load_recording(&sim_dir.join(format!("{sim}.csv")), &layout)?;
        for (label, rec) in [("real", &r), ("simulated", &s)] {
            let v = summary(rec);
            md.push_str(&format!(
                "| {traj} | {speed} | {label} ({}) | {:.0} | {:.2}-{:.2} | {:.1} | {:.2} |\n",
                rec.name, v[0], v[1], v[2], v[3], v[4]
            ));
        }
        if traj == "trefoil" {
            trefoil = vec![r, s];
        }
    }
    std::fs::write(out.join("sim_vs_real.md"), &md)?;
    print!("{md}");
    let path = out.join("trefoil_overlay.svg");
    let root = SVGBackend::new(&path, (700, 640)).into_drawing_area();
    root.fill(&WHITE)?;
    let xy = |r: &Recording| -> Vec<(f64, f64)> {
        (0..r.rows).filter(|&k| r.active[k]).map(|k| (r.state[k][0] - r.state[0][0] * 0.0, r.state[k][1])).collect()
    };
    let (a, b) = (xy(&trefoil[0]), xy(&trefoil[1]));
    // Centre each on its own mean so the shapes overlay.
    let centre = |v: Vec<(f64, f64)>| {
        let (mx, my) =
            (v.iter().map(|p| p.0).sum::<f64>() / v.len() as f64, v.iter().map(|p| p.1).sum::<f64>() / v.len() as f64);
        v.into_iter().map(|(x, y)| (x - mx, y - my)).collect::<Vec<_>>()
    };
    let (a, b) = (centre(a), centre(b));
    let lim = a.iter().chain(&b).map(|p| p.0.abs().max(p.1.abs())).fold(0.1, f64::max) * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .caption("Trefoil, medium speed: real (blue) vs simulated (orange), x-y, centred", ("sans-serif", 18))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(-lim..lim, -lim..lim)?;
    chart.configure_mesh().x_desc("x (m)").y_desc("y (m)").draw()?;
    chart
        .draw_series(LineSeries::new(a, BLUE.mix(0.7)))?
        .label(trefoil[0].name.clone())
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], BLUE));
    let orange = RGBColor(230, 120, 20);
    chart
        .draw_series(LineSeries::new(b, orange.mix(0.8)))?
        .label(trefoil[1].name.clone())
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], orange));
    chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
    root.present()?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
