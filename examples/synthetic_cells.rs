//! Writes a SYNTHETIC per-cell CSV for a design: the right shape (every
//! model x arm x seed x recording x horizon the analysis needs), filled by a
//! seeded crossed random-effects generator. It is an example input for
//! `crossaudit analyze`, the snapshot tests and the benchmark; it is not the
//! result of training any model.
//!
//!     cargo run --release --example synthetic_cells -- DESIGN OUT.csv [SEED]
//!
//! Model (log scale, per model m and horizon h):
//!   log e = log(base_h) + a_i + b_j + c_arm + e_ij,
//!   a_i ~ N(0, 0.25^2) recording, b_j ~ N(0, 0.03^2) seed,
//!   e_ij ~ N(0, 0.05^2), c_contaminated = log(1 - effect_m g_i h_j) with
//!   recording and seed gains g_i ~ N(1, 0.6^2), h_j ~ N(1, 0.3^2).
//! Divergent starts are Binomial(n_starts, p_i) with p_i from the recording
//! effect; the failure-aware RMSE counts them at the 2 m cap.

use std::path::Path;

use crossaudit::cells::{write_cells, Cell};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const RECORDINGS: [(&str, &str, &str); 26] = [
    ("B2_circle_fast_rep1", "circle", "fast"),
    ("B2_circle_medium_rep2", "circle", "medium"),
    ("B2_circle_slow_rep3", "circle", "slow"),
    ("B3_figure8_fast_rep2", "figure8", "fast"),
    ("B3_figure8_medium_rep1", "figure8", "medium"),
    ("B3_figure8_slow_rep1", "figure8", "slow"),
    ("B4_oval_fast_rep1", "oval", "fast"),
    ("B4_oval_medium_rep3", "oval", "medium"),
    ("B4_oval_slow_rep2", "oval", "slow"),
    ("B5_helix_fast_rep1", "helix", "fast"),
    ("B5_helix_medium_rep2", "helix", "medium"),
    ("B5_helix_slow_mell_rep1", "helix", "slow"),
    ("B6_linear_ramp_rep1", "linear_ramp", "unknown"),
    ("B6_linear_ramp_rep2", "linear_ramp", "unknown"),
    ("B7_star_fast_rep1", "star", "fast"),
    ("B7_star_medium_rep1", "star", "medium"),
    ("B7_star_slow_rep2", "star", "slow"),
    ("B8_square_fast_rep1", "square", "fast"),
    ("B8_square_slow_rep1", "square", "slow"),
    ("B9_trefoil_fast_rep2", "trefoil", "fast"),
    ("B9_trefoil_medium_rep1", "trefoil", "medium"),
    ("B9_trefoil_slow_rep3", "trefoil", "slow"),
    ("B10_lissajous_fast_rep1", "lissajous", "fast"),
    ("B10_lissajous_slow_rep1", "lissajous", "slow"),
    ("B2_circle_fast_rep2", "circle", "fast"),
    ("B3_figure8_fast_rep3", "figure8", "fast"),
];

/// Box-Muller from two uniforms; enough for example data.
fn normal(rng: &mut ChaCha8Rng, sd: f64) -> f64 {
    let u1: f64 = rng.gen_range(f64::EPSILON..1.0);
    let u2: f64 = rng.gen();
    sd * (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        return Err("usage: synthetic_cells DESIGN OUT.csv [SEED]".into());
    }
    let file = crossaudit::design::load(Path::new(&args[1]))?;
    let seed: u64 = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(2026);
    let d = &file.design;
    let plan = crossaudit::compile(d);
    let n_rec = d.recording.evaluation;
    if n_rec > RECORDINGS.len() {
        return Err(format!("this example knows {} recordings, the design wants {n_rec}", RECORDINGS.len()).into());
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let rec_effect: Vec<f64> = (0..n_rec).map(|_| normal(&mut rng, 0.25)).collect();
    let seed_effect: Vec<f64> = d.seeds.iter().map(|_| normal(&mut rng, 0.03)).collect();
    // The contamination benefit varies by recording and by seed, so d has
    // recording and seed components of its own.
    let rec_gain: Vec<f64> = (0..n_rec).map(|_| 1.0 + normal(&mut rng, 0.6)).collect();
    let seed_gain: Vec<f64> = d.seeds.iter().map(|_| 1.0 + normal(&mut rng, 0.3)).collect();
    let starts = d.recording.starts as u32;
    let cap = d.endpoints[0].cap.0;
    let mut keys: Vec<(String, f64)> = plan.units().map(|u| (u.model.clone(), u.horizon_s)).collect();
    keys.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    keys.dedup();
    let mut cells = Vec::new();
    for (model, h) in &keys {
        // The first declared model gains more from contamination than the others.
        let effect = if *model == d.models[0].name { 0.18 } else { 0.04 };
        let base = 0.3 * h.powf(1.3);
        for arm in [&d.contrast.treated, &d.contrast.reference] {
            let treated = arm == &d.contrast.treated;
            for (j, s) in d.seeds.iter().enumerate() {
                for (i, (name, traj, speed)) in RECORDINGS.iter().take(n_rec).enumerate() {
                    let gain = (effect * rec_gain[i] * seed_gain[j]).clamp(-0.5, 0.9);
                    let c = if treated { (1.0 - gain).ln() } else { 0.0 };
                    let e = (base.ln() + rec_effect[i] + seed_effect[j] + c + normal(&mut rng, 0.05)).exp();
                    let p_div = (0.02 * h * (rec_effect[i] * 4.0).exp()).min(0.9);
                    let n_div = (0..starts).filter(|_| rng.gen::<f64>() < p_div).count() as u32;
                    let finite = starts - n_div;
                    let cond = e.min(cap * 0.9);
                    let fa = ((finite as f64 * cond * cond + n_div as f64 * cap * cap) / starts as f64).sqrt();
                    let some = |v: f64| (finite > 0).then_some(v);
                    cells.push(Cell {
                        split: None,
                        dose: None,
                        model: model.as_str().into(),
                        arm: arm.as_str().into(),
                        seed: s.0,
                        recording: (*name).into(),
                        trajectory: (*traj).into(),
                        speed: (*speed).into(),
                        horizon_s: *h,
                        n_starts: starts,
                        n_divergent: n_div,
                        fa_position_rmse_m: round6(fa),
                        conditional_position_rmse_m: some(round6(cond)),
                        divergence_rate: n_div as f64 / starts as f64,
                        velocity_rmse_mps: some(round6(cond * 1.7 / h.max(0.5))),
                        attitude_rmse_deg: some(round6(3.0 + 2.0 * cond)),
                        origin: Default::default(),
                    });
                }
            }
        }
    }
    write_cells(Path::new(&args[2]), &cells)?;
    eprintln!("wrote {} synthetic cells to {}", cells.len(), args[2]);
    Ok(())
}

fn round6(v: f64) -> f64 {
    (v * 1e6).round() / 1e6
}
