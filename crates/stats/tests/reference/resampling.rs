//! The resampling and profile-likelihood intervals of the coverage study
//! (issue 44): the pigeonhole SE-based and bootstrap-t intervals, Owen &
//! Eckles' product weights and the parametric bootstrap-t, each against a
//! closed form or an independent R simulation
//! (scripts/reference/resampling_check.R), and the ML profile-likelihood
//! interval against lme4 (scripts/reference/mean_profile.R).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::assert_rel;
use crate::common::root;
use crossaudit_stats::resampling::{
    chi_squared, parametric_replicates, pigeonhole_t_replicates, product_weight_replicates,
};
use crossaudit_stats::{crossed_mom, pigeonhole_bootstrap, pigeonhole_variance, CrossedMatrix, DfRule};

/// Array `rep` of setting 0 of the small locked study (10 x 4).
fn fixture(rep: usize) -> CrossedMatrix {
    small_study_array(0, rep)
}

/// Array `rep` of setting `setting` of the small locked study (10 x 4,
/// tests/fixtures/coverage_small/arrays.csv).
pub(crate) fn small_study_array(setting: usize, rep: usize) -> CrossedMatrix {
    let text = std::fs::read_to_string(root().join("tests/fixtures/coverage_small/arrays.csv")).unwrap();
    let mut data = vec![0.0; 40];
    for row in text.lines().skip(1) {
        let v: Vec<&str> = row.split(',').collect();
        if v[0].parse::<usize>().unwrap() == setting && v[1].parse::<usize>().unwrap() == rep {
            let (i, j): (usize, usize) = (v[2].parse().unwrap(), v[3].parse().unwrap());
            data[i * 4 + j] = v[4].parse().unwrap();
        }
    }
    CrossedMatrix::new(10, 4, data).unwrap()
}

/// Variance with divisor n - 1, and its Monte Carlo SE from the squared deviations.
fn variance(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let sq: Vec<f64> = x.iter().map(|v| (v - mean).powi(2)).collect();
    let m2 = sq.iter().sum::<f64>() / n;
    let var_sq = sq.iter().map(|s| (s - m2).powi(2)).sum::<f64>() / (n - 1.0);
    (m2 * n / (n - 1.0), (var_sq / n).sqrt())
}

/// Each pigeonhole replicate's (mean, SE) is the crossed MoM's on the
/// resampled array built cell by cell from the same draws (I row indices,
/// then J column indices, per replicate), and the replicates are the
/// percentile interval's: the same SD of the replicate means.
#[test]
fn pigeonhole_t_replicates_are_the_moms_on_the_resampled_arrays() {
    let m = fixture(0);
    let (rows, cols) = (m.rows(), m.cols());
    let reps = pigeonhole_t_replicates(&m, 200, 5, 9);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    rng.set_stream(9);
    for (b, (dev, se)) in reps.iter().enumerate() {
        let r: Vec<usize> = (0..rows).map(|_| rng.gen_range(0..rows)).collect();
        let c: Vec<usize> = (0..cols).map(|_| rng.gen_range(0..cols)).collect();
        let cells = r.iter().flat_map(|&i| c.iter().map(move |&j| (i, j))).map(|(i, j)| m.get(i, j)).collect();
        let e = crossed_mom(&CrossedMatrix::new(rows, cols, cells).unwrap(), 0.95, DfRule::SeedsMinusOne).unwrap();
        assert!((m.mean() + dev - e.mean).abs() < 1e-12 * (1.0 + e.mean.abs()), "replicate {b}: mean");
        assert!((se - e.se).abs() < 1e-9 * e.se.max(1e-12), "replicate {b}: SE {se} and {}", e.se);
    }
    let boot = pigeonhole_bootstrap(&m, 200, 0.95, 5, 9).unwrap();
    let devs: Vec<f64> = reps.iter().map(|r| r.0).collect();
    assert_rel(variance(&devs).0.sqrt(), boot.se, 1e-10, "the percentile interval's SD");
}

/// The pigeonhole replicate means' variance is the closed form of
/// `pigeonhole_variance` (Owen 2007; derived in stats/bootstrap.rs), and
/// the SE-based interval is mean +- z SD.
#[test]
fn the_pigeonhole_variance_is_its_closed_form() {
    for rep in 0..3 {
        let m = fixture(rep);
        let devs: Vec<f64> = pigeonhole_t_replicates(&m, 100_000, 11, rep as u64).iter().map(|r| r.0).collect();
        let (v, mcse) = variance(&devs);
        let want = pigeonhole_variance(&m);
        assert!((v - want).abs() < 4.0 * mcse, "array {rep}: {v} vs {want} (MCSE {mcse})");
        let iv = crossaudit_stats::resampling::pigeonhole_further(&m, 0.95, 2000, 11, 3).unwrap();
        let se = iv[0].se;
        assert_rel(iv[0].upper - iv[0].estimate, 1.959963984540054 * se, 1e-12, "z SD");
        assert_rel(iv[0].estimate - iv[0].lower, 1.959963984540054 * se, 1e-12, "z SD");
    }
}

/// One line of scripts/reference/resampling_check.out: the product-weight
/// variance and the parametric t* quantiles, each with its MCSE.
fn r_reference(rep: usize) -> [(f64, f64); 3] {
    let text = std::fs::read_to_string(root().join("scripts/reference/resampling_check.out")).unwrap();
    let line = text.lines().find(|l| l.starts_with(&format!("0 {rep} |"))).unwrap();
    let parts: Vec<Vec<f64>> =
        line.split(" | ").skip(1).map(|p| p.split_whitespace().map(|x| x.parse().unwrap()).collect()).collect();
    [(parts[0][0], parts[0][1]), (parts[1][0], parts[1][1]), (parts[2][0], parts[2][1])]
}

/// Owen & Eckles' product weights: the variance of 200,000 replicates
/// agrees with R's independent simulation (rexp weights) and with the
/// closed form of `product_weight_variance` (flat Dirichlet weights along
/// each factor) within Monte Carlo error.
#[test]
fn the_product_weight_variance_agrees_with_an_independent_simulation() {
    for rep in 0..3 {
        let m = fixture(rep);
        let (v, mcse) = variance(&product_weight_replicates(&m, 200_000, 17, rep as u64));
        let (want, want_mcse) = r_reference(rep)[0];
        let z = (v - want) / (mcse * mcse + want_mcse * want_mcse).sqrt();
        assert!(z.abs() < 4.0, "array {rep}: {v} vs R's {want}: z = {z:.2}");
        let exact = crossaudit_stats::resampling::product_weight_variance(&m);
        assert!((v - exact).abs() < 4.0 * mcse, "array {rep}: {v} vs the closed form {exact} (MCSE {mcse})");
        // Narrower than the pigeonhole's, as the closed forms say.
        assert!(exact < pigeonhole_variance(&m), "array {rep}");
    }
}

/// The parametric bootstrap draws the mean and the sums of squares from
/// their sampling distributions: the mean's variance is the MoM's SE^2,
/// and the t* quantiles agree with R's simulation of whole arrays.
#[test]
fn the_parametric_bootstrap_t_agrees_with_whole_arrays_drawn_in_r() {
    for rep in 0..3 {
        let m = fixture(rep);
        // A fixed seed: at B = 20,000, 2 of 200 seeds gave |z| > 2.5 here
        // (1.2% expected), so the check is calibrated.
        let reps = parametric_replicates(&m, 200_000, 24, rep as u64);
        let se = crossed_mom(&m, 0.95, DfRule::SeedsMinusOne).unwrap().se;
        let (v, mcse) = variance(&reps.iter().map(|r| r.0).collect::<Vec<_>>());
        assert!((v - se * se).abs() < 4.0 * mcse, "array {rep}: Var(mean*) {v} vs SE^2 {}", se * se);
        let mut t: Vec<f64> = reps.iter().map(|(g, s)| g / s).collect();
        t.sort_by(f64::total_cmp);
        let q = |p: f64| crossaudit_stats::quantile_type7(&t, p);
        let reference = r_reference(rep);
        for (p, (want, want_mcse)) in [(0.025, reference[1]), (0.975, reference[2])] {
            // Ours has the same Monte Carlo SE as R's (the same B).
            let z = (q(p) - want) / (want_mcse * std::f64::consts::SQRT_2);
            assert!(z.abs() < 4.0, "array {rep}: t* {p} quantile {} vs R's {want}: z = {z:.2}", q(p));
        }
    }
}

/// The chi-square sampler's mean and variance are k and 2k, for shapes
/// below and above 1.
#[test]
fn chi_square_draws_have_their_moments() {
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let n = 200_000;
    for k in [1.0, 3.0, 9.0, 475.0] {
        let x: Vec<f64> = (0..n).map(|_| chi_squared(&mut rng, k)).collect();
        let mean = x.iter().sum::<f64>() / n as f64;
        let (var, _) = variance(&x);
        let mean_se = (2.0 * k / n as f64).sqrt();
        assert!((mean - k).abs() < 4.0 * mean_se, "k = {k}: mean {mean}");
        // Var of the sample variance of a chi-square: (mu4 - sigma^4) / n,
        // mu4 = 12 k (k + 4).
        let var_se = ((12.0 * k * (k + 4.0) - 4.0 * k * k) / n as f64).sqrt();
        assert!((var - 2.0 * k).abs() < 4.0 * var_se, "k = {k}: variance {var}");
        assert!(x.iter().all(|v| *v > 0.0 && v.is_finite()));
    }
}

/// The ML profile-likelihood interval equals lme4's exact profile
/// (scripts/reference/mean_profile.R: the deviance of
/// lmer(y ~ 0 + (1|row) + (1|col), offset = mu, REML = FALSE) and uniroot)
/// on 50 arrays of the small study, to 1e-7 of the interval's width.
/// (lme4's own confint, which interpolates its profile by a spline, is
/// printed beside them: it is off the exact limits by up to 6.7% of the
/// width on these arrays, most where a fit is near singular.)
#[test]
fn the_profile_likelihood_interval_is_lme4s() {
    let text = std::fs::read_to_string(root().join("scripts/reference/mean_profile.out")).unwrap();
    let mut compared = 0;
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let f: Vec<f64> = line.split_whitespace().map(|x| x.parse().unwrap()).collect();
        let (k, r) = (f[0] as usize, f[1] as usize);
        let m = small_study_array(k, r);
        let iv = crossaudit_stats::profile_interval(&m, 0.95).unwrap();
        let width = f[3] - f[2];
        for (what, got, want, tol) in [("lower", iv.lower, f[2], 1e-7), ("upper", iv.upper, f[3], 1e-7)] {
            assert!((got - want).abs() < tol * width, "setting {k} rep {r}: {what} {got} vs {want}");
        }
        compared += 1;
    }
    assert_eq!(compared, 50);
}

/// The further estimators' variances on the 200 arrays of the small locked
/// study equal those computed by other code (scripts/reference/
/// further_intervals.R: sandwich's vcovCL for the two-way cluster-robust
/// variance, R's var() for the sum of margins and an explicit delete-one
/// row and column jackknife, anova()'s mean squares for the untruncated
/// MoM) to 1e-12; the jackknife and the sum of margins are the same
/// number.
#[test]
fn the_further_estimators_are_sandwichs_var_s_and_anova_s() {
    let root = root();
    let reference = std::fs::read_to_string(root.join("scripts/reference/further_intervals.out")).unwrap();
    let mut compared = 0;
    for line in reference.lines().filter(|l| !l.starts_with('#')) {
        let f: Vec<f64> = line.split_whitespace().map(|x| x.parse().unwrap()).collect();
        let (k, r) = (f[0] as usize, f[1] as usize);
        let m = small_study_array(k, r);
        let ours = crossaudit_stats::further_intervals(&m, 0.95, 99, 1, 1).unwrap();
        let var_of = |method: crossaudit_stats::IntervalMethod| {
            let e = ours.iter().find(|e| e.method == method).unwrap();
            if e.se.is_nan() {
                f64::NAN
            } else {
                e.se * e.se
            }
        };
        let (cgm, margins, jackknife, untruncated) = (f[2], f[3], f[4], f[5]);
        for (what, got, want) in [
            ("two-way cluster-robust", var_of(crossaudit_stats::IntervalMethod::TwoWayCluster), cgm),
            ("sum of margins", var_of(crossaudit_stats::IntervalMethod::SumOfMargins), margins),
            ("row + column jackknife", var_of(crossaudit_stats::IntervalMethod::SumOfMargins), jackknife),
            ("untruncated MoM", var_of(crossaudit_stats::IntervalMethod::MomUntruncated), untruncated),
        ] {
            if want > 0.0 {
                assert_rel(got, want, 1e-12, &format!("setting {k} rep {r}: {what}"));
            } else {
                assert!(got.is_nan(), "setting {k} rep {r}: {what} is {want} in R, so undefined here");
            }
        }
        compared += 1;
    }
    assert_eq!(compared, 200);
}
