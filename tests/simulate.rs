//! The built-in Crazyflie simulator: determinism, realism against the real
//! logs, and compatibility with the loader's audit.

use crate::common::root;
use crossaudit::data::Status;
use crossaudit::sim::{simulate, SimSpec};

fn spec(strength: f64) -> SimSpec {
    SimSpec { recordings: 6, seed: 3, strength, duration_s: 8.0 }
}

#[test]
fn same_seed_gives_byte_identical_csv() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    let csvs = |dir: &std::path::Path, r: crossaudit::sim::SimRecord| -> Vec<std::path::PathBuf> {
        r.files.keys().filter(|n| n.ends_with(".csv")).map(|n| dir.join(n)).collect()
    };
    let fa = csvs(&a, simulate(&spec(1.0), &a).unwrap());
    let fb = csvs(&b, simulate(&spec(1.0), &b).unwrap());
    assert_eq!(fa.len(), 6);
    for (x, y) in fa.iter().zip(&fb) {
        assert_eq!(std::fs::read(x).unwrap(), std::fs::read(y).unwrap(), "{}", x.display());
    }
    let other = dir.path().join("c");
    let fc = csvs(&other, simulate(&SimSpec { seed: 4, ..spec(1.0) }, &other).unwrap());
    assert_ne!(std::fs::read(&fa[0]).unwrap(), std::fs::read(&fc[0]).unwrap(), "another seed, another flight");
}

#[test]
fn simulated_logs_pass_the_loaders_audit_and_hover_like_the_real_crazyflie() {
    let dir = tempfile::tempdir().unwrap();
    simulate(&spec(1.0), dir.path()).unwrap();
    let design = crossaudit::design::load(&root().join("designs/quickstart.design")).unwrap().design;
    let (audit, recs) = crossaudit::data::audit_and_load(&design.data, dir.path()).unwrap();
    assert!(audit.files.iter().all(|f| f.status == Status::Included), "{}", audit.summary());
    assert_eq!(recs.len(), 6);
    assert_eq!(audit.files[0].trajectory, "circle");
    assert_eq!(audit.files[0].speed, "slow");
    // Hover: the median motor command over active rows lies inside the real
    // logs' range. Real NanoBench flights (README table, results/simulator/)
    // hover at median PWM 56,000-60,000 of 65,535.
    for r in &recs {
        let mut pwm: Vec<f64> =
            (0..r.rows).filter(|&k| r.active[k]).map(|k| r.pwm[k].iter().sum::<f64>() / 4.0).collect();
        pwm.sort_by(f64::total_cmp);
        let median = pwm[pwm.len() / 2];
        assert!((50_000.0..=62_000.0).contains(&median), "{}: median PWM {median}", r.name);
    }
}

#[test]
fn strength_zero_makes_same_trajectory_recordings_alike_and_strength_makes_them_differ() {
    // Two repetitions of the same slot (recordings k and k + 24 share a
    // trajectory and speed). Their mean battery-normalised motor command
    // differs more with strength than without.
    let spread = |strength: f64| {
        let dir = tempfile::tempdir().unwrap();
        simulate(&SimSpec { recordings: 26, seed: 9, strength, duration_s: 6.0 }, dir.path()).unwrap();
        let design = crossaudit::design::load(&root().join("designs/quickstart.design")).unwrap().design;
        let (_, recs) = crossaudit::data::audit_and_load(&design.data, dir.path()).unwrap();
        let mean_pwm = |name: &str| {
            let r = recs.iter().find(|r| r.name == name).unwrap();
            let v: Vec<f64> =
                (0..r.rows).filter(|&k| r.active[k]).map(|k| r.pwm[k].iter().sum::<f64>() / 4.0).collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        (mean_pwm("S01_circle_slow_rep1") - mean_pwm("S01_circle_slow_rep2")).abs()
            + (mean_pwm("S02_circle_medium_rep1") - mean_pwm("S02_circle_medium_rep2")).abs()
    };
    assert!(spread(0.0) * 3.0 < spread(2.0), "strength 0: {}, strength 2: {}", spread(0.0), spread(2.0));
}

#[test]
fn a_simulated_design_must_say_what_to_simulate() {
    let e = crossaudit::design::from_str(
        "sim.design",
        &std::fs::read_to_string(root().join("designs/quickstart.design")).unwrap().replace("strength 1.0 ", ""),
    )
    .unwrap_err();
    assert!(e.render(false).contains("incomplete simulated data"), "{}", e.render(false));
}
