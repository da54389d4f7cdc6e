//! The coverage study's measures beyond coverage: a true mean, several
//! levels, power, type S error, relative precision with its paired MCSE,
//! seeds that follow a setting's values, and the tidy replications that R's
//! rsimsum reproduces.

use crate::common::{assert_ok, assert_rel, root};
use crossaudit::methods::CoverageSpec;
use crossaudit::stats::coverage::{draw_array, performance_at, setting_seed, shifted, Distribution, Missing, Setting};
use crossaudit::stats::{compare_intervals, reml_intervals, IntervalMethod};
use rand::SeedableRng;

fn spec(text: &str) -> CoverageSpec {
    serde_json::from_str(text).unwrap()
}

/// rsimsum 0.13.0, run on the committed study's replications.csv by
/// scripts/reference/rsimsum_check.R (output committed beside it), gives
/// every measure of the committed coverage.csv to 1e-12; and the study
/// reruns to those two files byte for byte.
#[test]
fn rsimsum_reproduces_every_measure_of_the_committed_study() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("cov");
    let o = crate::common::bin()
        .current_dir(root())
        .args(["coverage", "specs/coverage_rsimsum.json", "--replications", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert_ok(&o);
    // Field by field: numbers to 1e-9 relative (REML's linear algebra picks
    // its SIMD kernels by CPU, so its last bits may differ on another
    // machine), everything else exactly.
    for f in ["coverage.csv", "replications.csv"] {
        let fresh = std::fs::read_to_string(out.join(f)).unwrap();
        let committed = std::fs::read_to_string(root().join("results/coverage_rsimsum").join(f)).unwrap();
        assert_eq!(fresh.lines().count(), committed.lines().count(), "{f}: line counts");
        for (k, (a, b)) in fresh.lines().zip(committed.lines()).enumerate() {
            for (x, y) in a.split(',').zip(b.split(',')) {
                let same = match (x.parse::<f64>(), y.parse::<f64>()) {
                    (Ok(u), Ok(v)) => {
                        u == v || (u.is_nan() && v.is_nan()) || (u - v).abs() <= 1e-9 * u.abs().max(v.abs())
                    }
                    _ => x == y,
                };
                assert!(same, "{f} line {}: {x} here, {y} in results/coverage_rsimsum", k + 1);
            }
        }
    }
    let report = std::fs::read_to_string(root().join("scripts/reference/rsimsum_check.out")).unwrap();
    let mut measures = 0;
    for line in report.lines().filter(|l| l.contains(" compared ") && !l.starts_with("not ")) {
        let f: Vec<&str> = line.split_whitespace().collect();
        let (n, diff): (usize, f64) = (f[2].parse().unwrap(), f.last().unwrap().parse().unwrap());
        assert!(n > 0 && diff < 1e-12, "{line}");
        measures += 1;
    }
    assert_eq!(measures, 11, "{report}");
    let overall = report.lines().find(|l| l.starts_with("overall")).unwrap();
    let diff: f64 = overall.split_whitespace().nth(5).unwrap().parse().unwrap();
    assert!(diff < 1e-12, "{overall}");
}

/// Every estimator is location-equivariant: on an array shifted by mu, the
/// estimate and both ends move by mu and the SE and df do not. This is why
/// a true mean mu is scored on the arrays drawn around 0, plus mu.
#[test]
fn every_estimator_is_location_equivariant() {
    let s = Setting {
        rows: 7,
        cols: 5,
        shares: [0.5, 0.3, 0.2],
        distribution: Distribution::Skewed,
        missing: Missing::Complete,
    };
    for r in 0..5u64 {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        rng.set_stream(r);
        let m = draw_array(&s, &mut rng).unwrap();
        for mu in [0.5, -2.25, 10.0] {
            let moved =
                crossaudit::stats::CrossedMatrix::new(7, 5, m.values().iter().map(|v| v + mu).collect()).unwrap();
            let every = |m: &crossaudit::stats::CrossedMatrix| {
                let mut v = compare_intervals(m, 0.9, 99, 1, r).unwrap();
                v.extend(crossaudit::stats::further_intervals(m, 0.9, 99, 1, r).unwrap());
                v
            };
            let (a, b) = (every(&m), every(&moved));
            assert_eq!(a.len(), 18);
            for (x, y) in a.iter().zip(&b) {
                let want = shifted((x.estimate, x.se, x.lower, x.upper), mu);
                // REML's variance components come from an optimizer stopped at
                // its tolerance, so its SE and df (and so its ends) agree to
                // that tolerance; every other estimator to rounding.
                let reml = matches!(x.method, IntervalMethod::RemlKenwardRoger | IntervalMethod::RemlSatterthwaite);
                let tol = if reml { 1e-6 * (x.upper - x.lower) } else { 1e-9 * (1.0 + mu.abs()) };
                assert!((y.estimate - want.0).abs() < tol, "{:?} mu {mu}: estimate", x.method);
                let se_tol = if reml { 1e-6 } else { 1e-9 } * x.se.max(1.0);
                assert!((y.se - want.1).abs() < se_tol, "{:?} mu {mu}: SE {} and {}", x.method, x.se, y.se);
                let ends = (y.lower - want.2).abs().max((y.upper - want.3).abs());
                assert!(ends < tol, "{:?} mu {mu}: ends off by {ends:e}", x.method);
                let same_df = (x.df.is_nan() && y.df.is_nan())
                    || x.df == y.df
                    || (x.df - y.df).abs() < 1e-6 * x.df.abs().max(1.0);
                assert!(same_df, "{:?}: df {} and {}", x.method, x.df, y.df);
            }
            // With cells missing: REML on the cells present.
            let cells: Vec<(usize, usize, f64)> =
                (0..35).filter(|k| k % 6 != 1).map(|k| (k / 5, k % 5, m.values()[k])).collect();
            let shifted_cells: Vec<_> = cells.iter().map(|&(i, j, v)| (i, j, v + mu)).collect();
            let (a, b) =
                (reml_intervals(&cells, 7, 5, 0.95).unwrap(), reml_intervals(&shifted_cells, 7, 5, 0.95).unwrap());
            for (x, y) in a.iter().zip(&b) {
                assert!(
                    (y.estimate - x.estimate - mu).abs() < 1e-8 * (1.0 + mu.abs()),
                    "{:?}: REML estimate",
                    x.method
                );
                assert!((y.se - x.se).abs() < 1e-7 * x.se, "{:?}: REML SE", x.method);
            }
        }
    }
}

/// Power (rsimsum's Wald z test), the rejection rate of the intervals and
/// the type S error on hand-built replications, truth 0.5, level 0.95
/// (z = 1.959964).
#[test]
fn power_rejection_and_type_s_by_hand() {
    // (estimate, SE, lower, upper)
    let est = [
        (1.0, 0.4, 0.2, 1.8),     // |1.0| >= 1.96 * 0.4 = 0.784: power; excludes 0 above
        (0.3, 0.2, -0.1, 0.7),    // 0.3 < 0.392: neither
        (-0.9, 0.3, -1.5, -0.3),  // 0.9 >= 0.588: power; excludes 0 below: the wrong sign
        (0.5, 0.25, 0.05, 0.95),  // 0.5 >= 0.49: power; excludes 0 above
        (0.45, 0.2, -0.01, 0.91), // 0.45 >= 0.392: power, but the interval holds 0
    ];
    let p = performance_at("hand", IntervalMethod::MomT, &est, &[4.0, 4.0, 4.0, 4.0, 4.0], 0.5, 0.95);
    assert_rel(p.power, 4.0 / 5.0, 1e-12, "power");
    assert_rel(p.power_mcse, (0.8f64 * 0.2 / 5.0).sqrt(), 1e-12, "power MCSE");
    assert_rel(p.rejection, 3.0 / 5.0, 1e-12, "rejection");
    assert_rel(p.type_s, 1.0 / 3.0, 1e-12, "type S: 1 of the 3 rejections is below 0");
    assert_rel(p.type_s_mcse, (1.0f64 / 3.0 * 2.0 / 3.0 / 3.0).sqrt(), 1e-12, "type S MCSE");
    // Relative bias: mean((est - 0.5) / 0.5) = (1 - 0.4 - 2.8 + 0 - 0.1) / 5.
    assert_rel(p.rel_bias, (1.0 - 0.4 - 2.8 + 0.0 - 0.1) / 5.0, 1e-12, "relative bias");
    assert_eq!(p.df_median, 4.0);
    // At a true mean of 0 there is no type S error and no relative bias.
    let q = performance_at("hand", IntervalMethod::MomT, &est, &[], 0.0, 0.95);
    assert!(q.type_s.is_nan() && q.rel_bias.is_nan() && q.df_median.is_nan());
}

/// A setting's draws depend on its own values only: the same setting in
/// another grid, at another place, gives the same rows.
#[test]
fn a_settings_seed_follows_its_values_not_its_place() {
    let one = spec(
        r#"{"seed": 5, "reps": 30, "bootstrap": 19, "rows": [6], "cols": [4],
            "shares": [[0.5, 0.25, 0.25]], "distributions": ["normal"]}"#,
    );
    let three = spec(
        r#"{"seed": 5, "reps": 30, "bootstrap": 19, "rows": [9, 6], "cols": [5, 4],
            "shares": [[0.2, 0.2, 0.6], [0.5, 0.25, 0.25]], "distributions": ["skewed", "normal"]}"#,
    );
    let target = one.settings()[0].clone();
    assert!(three.settings().iter().position(|s| *s == target).unwrap() > 0, "not first in the larger grid");
    assert_eq!(setting_seed(5, &target), setting_seed(5, &three.settings()[three.settings().len() - 1]));
    let a = crossaudit::methods::run_coverage(&one, &mut |_, _, _| {}).unwrap();
    let b = crossaudit::methods::run_coverage(&three, &mut |_, _, _| {}).unwrap();
    let mine: Vec<_> = b.into_iter().filter(|r| r.setting == target.label()).collect();
    assert_eq!(
        crossaudit::methods::coverage::to_csv(&a).unwrap(),
        crossaudit::methods::coverage::to_csv(&mine).unwrap()
    );
    // Another base seed, other draws.
    assert_ne!(setting_seed(6, &target), setting_seed(5, &target));
}

/// Several means and levels are scored on the same replications: the
/// rows at mu are the rows at 0 with the estimates moved by mu, and a
/// wider level never covers less.
#[test]
fn means_and_levels_share_their_replications() {
    let s = spec(
        r#"{"seed": 9, "reps": 60, "bootstrap": 39, "levels": [0.8, 0.95], "means": [0, 1.5],
            "rows": [6], "cols": [4], "shares": [[0.5, 0.25, 0.25]], "distributions": ["normal"]}"#,
    );
    let rows = crossaudit::methods::run_coverage(&s, &mut |_, _, _| {}).unwrap();
    let methods = 18;
    assert_eq!(rows.len(), 2 * 2 * methods);
    for (a, b) in rows[..2 * methods].iter().zip(&rows[2 * methods..]) {
        assert_eq!((a.true_mean, b.true_mean, a.level), (0.0, 1.5, b.level));
        assert_rel(b.bias, a.bias, 1e-9, "bias is the same at every mean");
        assert_eq!(a.coverage, b.coverage, "{:?}: coverage at mu is coverage at 0", a.method);
        assert!(b.rejection >= a.rejection, "{:?}: a true effect is rejected at least as often", a.method);
    }
    for (narrow, wide) in rows[..methods].iter().zip(&rows[methods..2 * methods]) {
        assert!(wide.coverage >= narrow.coverage, "{:?}", narrow.method);
    }
    for bad in [r#""level": 0.9, "levels": [0.9]"#, r#""levels": [0.9, 0.9]"#, r#""levels": [1.5]"#, r#""means": []"#] {
        let text = format!(
            r#"{{"seed": 1, "reps": 10, {bad}, "rows": [4], "cols": [3], "shares": [[0.5, 0.25, 0.25]], "distributions": ["normal"]}}"#
        );
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("spec.json");
        std::fs::write(&p, text).unwrap();
        let e = CoverageSpec::load(&p).unwrap_err().to_string();
        assert!(e.contains("spec.json"), "{bad}: {e}");
    }
}

/// The boundary rate against its closed form. Under normal errors
/// MS_seed / MS_e ~ (1 + I sb / se) F(J - 1, (I - 1)(J - 1)), so the MoM
/// truncates the seed component with probability
/// P(F < 1 / (1 + I sb / se)). With the recording component large, its
/// truncation (P(F(I - 1, ...) < 1 / (1 + J sa / se)) = 2e-4 here) is
/// added (the two events rarely meet).
#[test]
fn the_moms_boundary_rate_is_the_f_distributions() {
    use statrs::distribution::{ContinuousCDF, FisherSnedecor};
    let s = spec(
        r#"{"seed": 21, "reps": 2000, "bootstrap": 1, "rows": [10], "cols": [6],
            "shares": [[0.9, 0.02, 0.08]], "distributions": ["normal"]}"#,
    );
    let setting = &s.settings()[0];
    let (sa, sb, se) = setting.components();
    let (i, j) = (10.0, 6.0);
    let seed_side = FisherSnedecor::new(j - 1.0, (i - 1.0) * (j - 1.0)).unwrap().cdf(1.0 / (1.0 + i * sb / se));
    let row_side = FisherSnedecor::new(i - 1.0, (i - 1.0) * (j - 1.0)).unwrap().cdf(1.0 / (1.0 + j * sa / se));
    assert!(row_side < 1e-3, "{row_side}");
    let either = seed_side + row_side;
    let rows = crossaudit::methods::run_coverage(&s, &mut |_, _, _| {}).unwrap();
    for r in &rows {
        match r.method {
            IntervalMethod::MomT | IntervalMethod::MomSatterthwaite | IntervalMethod::MomZ => {
                let z = (r.boundary - either) / r.boundary_mcse;
                assert!(z.abs() < 4.0, "{:?}: {} ({}) against {either}", r.method, r.boundary, r.boundary_mcse);
            }
            IntervalMethod::NaiveIid | IntervalMethod::PigeonholePercentile => assert_eq!(r.boundary, 0.0),
            _ => {}
        }
    }
}

/// An independent simulation of the further estimators' coverage, with R's
/// own random numbers (scripts/reference/further_coverage.R, committed
/// output), agrees with the committed study within Monte Carlo error in
/// all six settings, and it compared the study as committed now.
#[test]
fn the_further_estimators_coverage_agrees_with_an_independent_simulation() {
    assert_eq!(independent_simulation_agrees("scripts/reference/further_coverage.out"), 18);
}

/// Reads an independent simulation's committed output (lines `setting |
/// method | R coverage (MCSE) | crossaudit coverage (MCSE) | z`), checks
/// every |z| < 3.5 and that the crossaudit coverage it compared is the one
/// results/coverage/coverage.csv has now; returns how many it compared.
pub(crate) fn independent_simulation_agrees(out: &str) -> usize {
    let root = root();
    let out = std::fs::read_to_string(root.join(out)).unwrap();
    let mut rdr = csv::Reader::from_path(root.join("results/coverage/coverage.csv")).unwrap();
    let header: Vec<String> = rdr.headers().unwrap().iter().map(String::from).collect();
    let ours: Vec<std::collections::HashMap<String, String>> =
        rdr.records().map(|r| header.iter().cloned().zip(r.unwrap().iter().map(String::from)).collect()).collect();
    let mut compared = 0;
    for line in out.lines().filter(|l| !l.starts_with('#') && l.contains(" | ")) {
        let f: Vec<&str> = line.split(" | ").map(str::trim).collect();
        let z: f64 = f[4].parse().unwrap();
        assert!(z.abs() < 3.5, "{line}");
        let committed: f64 = f[3].split_whitespace().next().unwrap().parse().unwrap();
        let row = ours.iter().find(|r| r["setting"] == f[0] && r["method"] == f[1]).unwrap_or_else(|| panic!("{line}"));
        let now: f64 = row["coverage"].parse().unwrap();
        assert!((now - committed).abs() < 5e-5, "{line}: results/coverage now has {now}");
        compared += 1;
    }
    compared
}

/// Issue 56, class 3: a coverage study at a true mean of 1e20 or 1e300
/// scores the same intervals as at 0. Shifted by 1e20 first, an interval
/// of width about 1 rounds to a point, and every coverage came out 1.000
/// with width 0 (0.925 at mean 0). Coverage, misses, width, bias and the
/// SEs do not move with the location, so they must be equal bit for bit.
#[test]
fn coverage_at_a_huge_true_mean_is_coverage_at_zero() {
    let s = Setting {
        rows: 6,
        cols: 4,
        shares: [0.4, 0.3, 0.3],
        distribution: Distribution::Normal,
        missing: Missing::Complete,
    };
    let sim = crossaudit::stats::coverage::simulate_reps(&s, 200, &[0.95], 19, 11).unwrap();
    let all = crossaudit::stats::coverage::measures(&sim, &[0.0, 1e20, -1e300]);
    let per = all.len() / 3;
    let (zero, rest) = all.split_at(per);
    for p in rest {
        let z = zero.iter().find(|z| z.method == p.method).unwrap();
        assert!(z.mean_width > 0.0 && z.coverage < 1.0, "{:?}: the study at 0 is not degenerate", z.method);
        for (what, a, b) in [
            ("coverage", p.coverage, z.coverage),
            ("width", p.mean_width, z.mean_width),
            ("below", p.miss_below, z.miss_below),
            ("above", p.miss_above, z.miss_above),
            ("bias", p.bias, z.bias),
            ("empirical SE", p.emp_se, z.emp_se),
            ("model SE", p.mod_se, z.mod_se),
            ("relative precision", p.rel_precision, z.rel_precision),
        ] {
            assert!(
                a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                "{:?} at {}: {what} {a} != {b}",
                p.method,
                p.true_mean
            );
        }
        // Relative bias is bias / mu, without cancellation.
        assert_eq!(p.rel_bias, z.bias / p.true_mean);
    }
}

/// An independent simulation of the resampling intervals' coverage, with
/// R's own bootstrap code and random numbers
/// (scripts/reference/resampling_coverage.R, committed output), agrees with
/// the committed study within Monte Carlo error in all six settings, and
/// it compared the study as committed now.
#[test]
fn the_resampling_intervals_coverage_agrees_with_an_independent_simulation() {
    let compared = independent_simulation_agrees("scripts/reference/resampling_coverage.out");
    assert_eq!(compared, 30);
}
