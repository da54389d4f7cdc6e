//! Properties of the crossed estimator and the pigeonhole bootstrap.

use proptest::prelude::*;

use crate::{assert_rel, rel_close};
use crossaudit_stats::{crossed_mom, pigeonhole_bootstrap, pigeonhole_variance, CrossedMatrix, DfRule};

fn matrix() -> impl Strategy<Value = CrossedMatrix> {
    (2usize..7, 2usize..7).prop_flat_map(|(i, j)| {
        prop::collection::vec(-10.0f64..10.0, i * j).prop_map(move |v| CrossedMatrix::new(i, j, v).unwrap())
    })
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * (1.0 + b.abs())
}

proptest! {
    #[test]
    fn permuting_recordings_or_seeds_changes_nothing(m in matrix(), rs in any::<u64>(), cs in any::<u64>()) {
        use rand::seq::SliceRandom;
        use rand::SeedableRng;
        let mut rows: Vec<usize> = (0..m.rows()).collect();
        let mut cols: Vec<usize> = (0..m.cols()).collect();
        rows.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(rs));
        cols.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(cs));
        let p = m.permuted(&rows, &cols).unwrap();
        for rule in [DfRule::SeedsMinusOne, DfRule::Satterthwaite] {
            let (a, b) = (crossed_mom(&m, 0.95, rule).unwrap(), crossed_mom(&p, 0.95, rule).unwrap());
            prop_assert!(close(a.mean, b.mean));
            prop_assert!(close(a.se, b.se));
            prop_assert!(close(a.components.recording, b.components.recording));
            prop_assert!(close(a.components.seed, b.components.seed));
            prop_assert!(close(a.components.residual, b.components.residual));
            prop_assert!(a.df.is_infinite() && b.df.is_infinite() || close(a.df, b.df));
        }
        prop_assert!(close(pigeonhole_variance(&m), pigeonhole_variance(&p)));
    }

    #[test]
    fn scaling_d_scales_mean_and_se(m in matrix(), c in prop_oneof![-5.0f64..-0.1, 0.1f64..5.0]) {
        let a = crossed_mom(&m, 0.95, DfRule::SeedsMinusOne).unwrap();
        let b = crossed_mom(&m.scaled(c).unwrap(), 0.95, DfRule::SeedsMinusOne).unwrap();
        prop_assert!(close(b.mean, c * a.mean));
        prop_assert!(close(b.se, c.abs() * a.se));
        prop_assert!(close(b.share_recording, a.share_recording));
    }

    #[test]
    fn shares_sum_to_one(m in matrix()) {
        let e = crossed_mom(&m, 0.95, DfRule::SeedsMinusOne).unwrap();
        prop_assume!(e.se > 0.0);
        prop_assert!(close(e.share_recording + e.share_seed + e.share_residual, 1.0));
    }
}

/// Every equally likely pigeonhole resample of a small array, enumerated:
/// the exact bootstrap variance, with no Monte Carlo error.
fn enumerated_variance(m: &CrossedMatrix) -> f64 {
    fn draws(n: usize) -> Vec<Vec<usize>> {
        let mut out = vec![vec![]];
        for _ in 0..n {
            out = out.into_iter().flat_map(|d| (0..n).map(move |k| [d.clone(), vec![k]].concat())).collect();
        }
        out
    }
    let (rd, cd) = (draws(m.rows()), draws(m.cols()));
    let mut means = Vec::new();
    for r in &rd {
        for c in &cd {
            let s: f64 = r.iter().flat_map(|&i| c.iter().map(move |&j| (i, j))).map(|(i, j)| m.get(i, j)).sum();
            means.push(s / (m.rows() * m.cols()) as f64);
        }
    }
    let mu = means.iter().sum::<f64>() / means.len() as f64;
    means.iter().map(|x| (x - mu).powi(2)).sum::<f64>() / means.len() as f64
}

#[test]
fn pigeonhole_closed_form_equals_full_enumeration() {
    // The derivation in stats::pigeonhole_variance, checked exactly on
    // arrays small enough to enumerate every resample (3^3 x 3^3 and
    // 4^4 x 2^2 resamples).
    for (rows, cols, vals) in [
        (3, 3, vec![1.0, 4.0, -2.0, 0.5, 3.0, 7.0, -1.0, 2.0, 2.5]),
        (4, 2, vec![0.1, 0.9, -0.3, 0.4, 1.7, 1.1, 0.0, -0.8]),
    ] {
        let m = CrossedMatrix::new(rows, cols, vals).unwrap();
        assert_rel(pigeonhole_variance(&m), enumerated_variance(&m), 1e-12, "closed form vs enumeration");
    }
}

#[test]
fn large_b_pigeonhole_variance_converges_to_its_closed_form() {
    // A 6 x 5 array; B = 200,000 replicates. The sample variance of B draws
    // has relative SD about sqrt(2/B) (0.32%) for near-normal replicates;
    // allow 5 of those.
    let vals: Vec<f64> = (0..30).map(|k| ((k * 37 % 11) as f64 - 5.0) * 0.3 + (k / 5) as f64 * 0.7).collect();
    let m = CrossedMatrix::new(6, 5, vals).unwrap();
    let b = 200_000;
    let boot = pigeonhole_bootstrap(&m, b, 0.95, 11, 0).unwrap();
    let exact = pigeonhole_variance(&m);
    let tol = 5.0 * (2.0 / b as f64).sqrt();
    assert!(rel_close(boot.se * boot.se, exact, tol), "bootstrap var {} vs closed form {exact}", boot.se * boot.se);
}

#[test]
fn bootstrap_is_deterministic_per_seed_and_stream() {
    let m = CrossedMatrix::new(3, 3, vec![1.0, 4.0, -2.0, 0.5, 3.0, 7.0, -1.0, 2.0, 2.5]).unwrap();
    let a = pigeonhole_bootstrap(&m, 999, 0.95, 7, 3).unwrap();
    assert_eq!(a, pigeonhole_bootstrap(&m, 999, 0.95, 7, 3).unwrap());
    assert_ne!(a, pigeonhole_bootstrap(&m, 999, 0.95, 7, 4).unwrap());
}

#[test]
fn constructors_reject_bad_input_without_panicking() {
    use crossaudit_stats::StatsError;
    assert!(matches!(CrossedMatrix::new(1, 5, vec![0.0; 5]), Err(StatsError::TooFew { .. })));
    assert!(matches!(CrossedMatrix::new(2, 1, vec![0.0; 2]), Err(StatsError::TooFew { .. })));
    assert!(matches!(CrossedMatrix::new(2, 2, vec![0.0; 3]), Err(StatsError::Shape { .. })));
    assert!(matches!(
        CrossedMatrix::new(2, 2, vec![0.0, f64::NAN, 0.0, 0.0]),
        Err(StatsError::NonFinite { row: 0, col: 1, .. })
    ));
    let m = CrossedMatrix::new(2, 2, vec![0.0; 4]).unwrap();
    assert!(matches!(crossed_mom(&m, 1.5, DfRule::SeedsMinusOne), Err(StatsError::Level(_))));
    assert!(matches!(pigeonhole_bootstrap(&m, 0, 0.95, 1, 0), Err(StatsError::NoReplicates)));
    assert!(m.permuted(&[0, 0], &[0, 1]).is_err(), "a repeated index is not a permutation");
    assert!(m.permuted(&[0, 5], &[0, 1]).is_err(), "an out-of-range index is not a permutation");
}

#[test]
fn naive_iid_interval_collapses_where_the_recording_component_dominates() {
    // d_ij = a_i exactly (pure recording effect): the crossed SE is
    // sd(a)/sqrt(I); naive iid divides by sqrt(IJ) and is too narrow by
    // about sqrt(J).
    let a = [0.5, -1.0, 2.0, 0.0, -0.7];
    let vals: Vec<f64> = a.iter().flat_map(|x| std::iter::repeat_n(*x, 10)).collect();
    let m = CrossedMatrix::new(5, 10, vals).unwrap();
    let iv = crossaudit_stats::compare_intervals(&m, 0.95, 199, 1, 0).unwrap();
    let se = |method| iv.iter().find(|e| e.method == method).unwrap().se;
    use crossaudit_stats::IntervalMethod::*;
    assert_rel(se(MomT), se(ClusterRecording), 1e-12, "MoM SE equals the recording-cluster SE");
    assert!(se(NaiveIid) < se(MomT) / 2.5, "naive iid SE {} vs MoM {}", se(NaiveIid), se(MomT));
}

proptest! {
    /// On a complete array, the intervals `incomplete_intervals` computes
    /// for arrays with missing cells (naive iid, and the intercept-only CR1
    /// one-way cluster-robust ones) are those `compare_intervals` gives: CR1
    /// with equal cluster sizes J is G / (G - 1) sum_g (J (mean_g -
    /// mean))^2 / (G J)^2, the one-sample variance of the cluster means.
    #[test]
    fn the_incomplete_arrays_intervals_are_the_complete_ones_on_a_complete_array(m in matrix()) {
        use crossaudit_stats::{compare_intervals, incomplete_intervals, IntervalMethod as M};
        let cells: Vec<(usize, usize, f64)> =
            (0..m.rows()).flat_map(|i| (0..m.cols()).map(move |j| (i, j))).map(|(i, j)| (i, j, m.get(i, j))).collect();
        let full = compare_intervals(&m, 0.95, 99, 1, 0).unwrap();
        let part = incomplete_intervals(&cells, m.rows(), m.cols(), 0.95).unwrap();
        prop_assert_eq!(part.len(), 18);
        for method in [M::NaiveIid, M::ClusterRecording, M::ClusterSeed] {
            let a = full.iter().find(|e| e.method == method).unwrap();
            let b = part.iter().find(|e| e.method == method).unwrap();
            if a.se > 0.0 {
                prop_assert!(close(a.estimate, b.estimate) && close(a.se, b.se) && close(a.df, b.df), "{method:?}: {a:?} {b:?}");
                prop_assert!(close(a.lower, b.lower) && close(a.upper, b.upper), "{method:?}: {a:?} {b:?}");
            }
        }
    }
}
