//! `crossaudit plan --components`: the crossed planner from declared
//! variance components, effect and reference mean instead of a pilot. A
//! pilot's own components, declared, give its plan's rows bit for bit; the
//! rows are the closed form SE^2 = s_rec/I + s_seed/J + s_res/(IJ), width
//! 2 t(J - 1) SE and, with the SE taken as known, P = Phi((min(-t SE,
//! -c m_ref / 100) - d) / SE); the probability with the SE estimated agrees
//! with studies simulated in full and analysed by the crossed estimator;
//! bad declarations are refused by name.

use std::path::Path;

use statrs::distribution::{ContinuousCDF, Normal, StudentsT};

use crate::common::{assert_ok, assert_refused, confirmatory_design, example_cells, root, stderr};

fn plan(args: &[&str], out: &Path) -> std::process::Output {
    crate::common::bin().current_dir(root()).arg("plan").args(args).arg("--out").arg(out).output().unwrap()
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn a_pilot_s_components_declared_give_its_rows_and_the_closed_form() {
    let tmp = tempfile::tempdir().unwrap();
    let design = confirmatory_design();
    let design = design.to_str().unwrap();
    let cells = example_cells();
    let grid = ["--recordings", "13,26", "--seeds", "7,20"];
    let pilot_out = tmp.path().join("pilot");
    let o = plan(&[&[design, "--cells", cells.to_str().unwrap()], &grid[..]].concat(), &pilot_out);
    assert_ok(&o);
    let pilot = json(&pilot_out.join("plan.json"));
    // serde_json writes each f64 as the shortest text that parses back to
    // it, so the declared values are the pilot's to the bit.
    let v = |k: &str| pilot[k].as_f64().unwrap();
    let components = format!(
        "recording={},seed={},residual={}",
        pilot["sigma2_recording"], pilot["sigma2_seed"], pilot["sigma2_residual"]
    );
    let (effect, reference) = (format!("--effect={}", pilot["mean_d"]), pilot["mean_reference"].to_string());
    let declared_out = tmp.path().join("declared");
    let args = [&[design, "--components", &components, &effect, "--reference-mean", &reference], &grid[..]].concat();
    let o = plan(&args, &declared_out);
    assert_ok(&o);
    let declared = json(&declared_out.join("plan.json"));
    assert_eq!(declared["rows"], pilot["rows"], "declared components give the pilot's rows");
    assert_eq!(declared["declared"], serde_json::Value::Bool(true));
    assert!(pilot.get("declared").is_none(), "a pilot's plan.json is as before");
    let md = std::fs::read_to_string(declared_out.join("plan.md")).unwrap();
    assert!(md.contains("Declared (`--components`") && md.contains("The declared variance components"), "{md}");
    assert!(!md.contains("Pilot:"), "{md}");

    // The closed form, by hand, at every row: the design says `df seed - 1`
    // and `decide confirmed when optimism >= 10% and upper < 0`.
    let (sa, sb, se2, d, m) =
        (v("sigma2_recording"), v("sigma2_seed"), v("sigma2_residual"), v("mean_d"), v("mean_reference"));
    let rows = declared["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 4);
    for row in rows {
        let (i, j) = (row["recordings"].as_f64().unwrap(), row["seeds"].as_f64().unwrap());
        let se = (sa / i + sb / j + se2 / (i * j)).sqrt();
        let t = StudentsT::new(0.0, 1.0, j - 1.0).unwrap().inverse_cdf(0.975);
        let bound = (-t * se).min(-0.10 * m);
        let p = Normal::new(0.0, 1.0).unwrap().cdf((bound - d) / se);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
        assert!(close(row["se"].as_f64().unwrap(), se), "{row}: SE {se}");
        assert!(close(row["width"].as_f64().unwrap(), 2.0 * t * se), "{row}: width");
        assert!((row["power_known_se"].as_f64().unwrap() - p).abs() < 1e-9, "{row}: P {p}");
    }
}

/// Issue 72: the planner's probability that the rule holds accounts for
/// the SE the study estimates. The reference: 20,000 studies simulated in
/// full (every recording, seed and cell effect drawn, d = mu + a_i + b_j +
/// e_ij) and analysed by the design's own crossed estimator
/// (`crossed_mom`, df J - 1), the rule `optimism >= 10% and upper < 0`
/// applied with the reference mean held at the declared one. At 13 x 3
/// (df 2) and 30 x 6 the planner must agree within Monte Carlo error, and
/// the known-SE approximation is shown to miss at 13 x 3.
#[test]
fn the_probability_with_the_se_estimated_matches_simulated_studies() {
    use crossaudit::stats::{crossed_mom, standard_normal, CrossedMatrix, DfRule, VarianceComponents};
    use rand::SeedableRng;
    let design = crossaudit::design::load(&confirmatory_design()).unwrap().design;
    let plan = crossaudit::compile(&design);
    // The paper's recording and residual components with a per-seed seed
    // component (about 26 times the single draw's), its effect and reference mean.
    let truth = VarianceComponents { recording: 0.00791883, seed: 0.0018, residual: 0.00495443 };
    let (mu, m_ref) = (-0.0362, 0.299);
    let declared = crossaudit::methods::Declared { components: truth, effect: mu, reference_mean: m_ref };
    let p = crossaudit::methods::declared_power_plan(&plan, &declared, &[13, 30], &[3, 6]).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2026);
    let reps = 20_000;
    for (i, j) in [(13usize, 3usize), (30, 6)] {
        let row = p.rows.iter().find(|r| r.recordings == i && r.seeds == j).unwrap();
        let mut holds = 0;
        for _ in 0..reps {
            let a: Vec<f64> = (0..i).map(|_| truth.recording.sqrt() * standard_normal(&mut rng)).collect();
            let b: Vec<f64> = (0..j).map(|_| truth.seed.sqrt() * standard_normal(&mut rng)).collect();
            let mut v = Vec::with_capacity(i * j);
            for ai in &a {
                for bj in &b {
                    v.push(mu + ai + bj + truth.residual.sqrt() * standard_normal(&mut rng));
                }
            }
            let e = crossed_mom(&CrossedMatrix::new(i, j, v).unwrap(), 0.95, DfRule::SeedsMinusOne).unwrap();
            let optimism = -100.0 * e.mean / m_ref;
            if optimism >= 10.0 && e.upper < 0.0 {
                holds += 1;
            }
        }
        let simulated = holds as f64 / reps as f64;
        // Both are Monte Carlo estimates of the same probability: their
        // difference's SE, from the simulated share.
        let mc = (2.0 * simulated.max(0.001) * (1.0 - simulated) / reps as f64).sqrt();
        assert!(
            (row.power - simulated).abs() < 4.0 * mc,
            "{i} x {j}: planner {} against {simulated} simulated (MC SE {mc})",
            row.power
        );
        if (i, j) == (13, 3) {
            assert!(
                (row.power_known_se - simulated).abs() > 8.0 * mc,
                "the known-SE approximation {} should miss {simulated} at df 2",
                row.power_known_se
            );
        }
    }
}

#[test]
fn bad_declarations_are_refused_by_name() {
    let tmp = tempfile::tempdir().unwrap();
    let design = confirmatory_design();
    let design = design.to_str().unwrap();
    let out = tmp.path().join("out");
    let with = |components: &str| {
        plan(&[design, "--components", components, "--effect=-0.03", "--reference-mean", "0.3"], &out)
    };
    assert_refused(&with("recording=1e-3,seed=1e-4"), "residual missing: give all three");
    assert_refused(
        &with("recording=1e-3,seed=-1e-4,residual=1e-3"),
        "seed = -0.0001: a variance is a finite number at least 0",
    );
    assert_refused(&with("recording=1e-3,seed=1e-4,seed=1e-4,residual=1"), "seed is given twice");
    assert_refused(&with("recording=1e-3,draw=1e-4,residual=1"), "\"draw\" is not a component");
    assert_refused(&with("recording=1e-3,seed=lots,residual=1"), "\"lots\" is not a number");
    assert_refused(&with("recording=inf,seed=0,residual=1"), "a variance is a finite number");
    assert_refused(&with("recording=0,seed=0,residual=0"), "no variance to plan from");
    // Issue 77, class 4: a reference mean at which the optimism is undefined.
    for m in ["0", "-0.3"] {
        let o = plan(
            &[
                design,
                "--components",
                "recording=1e-3,seed=1e-4,residual=1e-3",
                "--effect=-0.03",
                &format!("--reference-mean={m}"),
            ],
            &out,
        );
        assert_refused(&o, "must be above 0: the rule reads the optimism");
    }
    // Without --effect and --reference-mean, or with --cells too: usage errors.
    let o = plan(&[design, "--components", "recording=1,seed=1,residual=1"], &out);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--effect"), "{}", stderr(&o));
    let cells = example_cells();
    let o = plan(
        &[
            design,
            "--cells",
            cells.to_str().unwrap(),
            "--components",
            "recording=1,seed=1,residual=1",
            "--effect",
            "0",
            "--reference-mean",
            "1",
        ],
        &out,
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // A design whose estimand is not one crossed contrast.
    let draws = root().join("designs/multiverse/paper_draws.design");
    let o = plan(
        &[
            draws.to_str().unwrap(),
            "--components",
            "recording=1,seed=1,residual=1",
            "--effect",
            "0",
            "--reference-mean",
            "1",
        ],
        &out,
    );
    assert_refused(&o, "the design has `factor draw`; --components plans a single crossed contrast");
    assert!(!out.join("plan.json").exists());
}

/// Declared components that are all zero are refused as the declaration's,
/// not as "the pilot's variance components" (there is no pilot).
#[test]
fn zero_declared_components_are_named_as_declared() {
    let out = tempfile::tempdir().unwrap();
    let o = crate::common::crossaudit(&[
        "plan",
        "designs/nanobench_paper.design",
        "--components",
        "recording=0,seed=0,residual=0",
        "--effect=-0.0362",
        "--reference-mean",
        "0.299",
        "--out",
        out.path().to_str().unwrap(),
    ]);
    crate::common::assert_refused(&o, "the declared variance components of world fa_position_rmse at 1 s are 0.000e0");
    assert!(!crate::common::stderr(&o).contains("pilot"), "{}", crate::common::stderr(&o));
}
