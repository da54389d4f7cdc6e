//! Joint inference over a multiverse's curve: the pigeonhole bootstrap
//! that resamples recordings and seeds once per replicate for every
//! specification (simultaneous bands, the share with d < 0) and the same
//! replicates centred at zero (the curve under the null).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::{common, Diff};
use crossaudit_stats::quantile_type7;

/// The joint pigeonhole bootstrap over every specification.
#[derive(Debug, Clone, Serialize)]
pub struct JointBootstrap {
    /// Replicates.
    pub replicates: usize,
    /// ChaCha8 seed (the design's bootstrap seed, or 11).
    pub seed: u64,
    /// Simultaneous level.
    pub level: f64,
    /// The max-|t| quantile multiplying each specification's bootstrap SE.
    pub critical: f64,
    /// Per specification: (id, bootstrap SE, simultaneous lower, upper), in the primary metric's unit.
    pub bands: Vec<(String, f64, f64, f64)>,
    /// Share of specifications with d < 0: observed, and its bootstrap
    /// percentile interval (descriptive: the bootstrap is centred at the
    /// observed estimates, not at the null).
    pub share_negative: (f64, f64, f64),
    /// Simultaneous bands that exclude zero.
    pub bands_excluding_zero: usize,
    /// The curve under the null ([`NullTest`]).
    pub null: NullTest,
    /// Recordings every specification shares.
    pub recordings: usize,
}

/// The specification curve under the null (Simonsohn, Simmons and Nelson
/// 2020, "Specification curve analysis", Nature Human Behaviour 4, step 3;
/// specr's `boot_null`): each specification's d matrix centred at zero,
/// the same pigeonhole resample for every specification in a replicate,
/// so a replicate's d of specification s is its resampled mean minus its
/// observed mean. One-sided p-values in the rule's direction (d < 0: the
/// treated arm looks better), (1 + replicates at least as extreme) /
/// (1 + replicates).
#[derive(Debug, Clone, Serialize)]
pub struct NullTest {
    /// The median d over specifications (the primary metric's unit) and its p-value (null medians
    /// at or below it).
    pub median: (f64, f64),
    /// Specifications in which the rule holds, evaluated on the shared
    /// matrix (each specification's own interval half-widths and reference
    /// mean, its d replaced), and the p-value (null counts at or above it).
    pub holding: (usize, f64),
    /// Stouffer's combined t: the sum over specifications of d / bootstrap
    /// SE, over the square root of their number, and its p-value (null
    /// values at or below it).
    pub stouffer: (f64, f64),
}

/// One replicate's row and column draw counts, from ChaCha8 stream 7 of `seed`.
pub(super) fn joint_bootstrap(
    ids: &[String],
    diffs: &[Diff],
    (b, seed, level): (usize, u64, f64),
    rule: &dyn Fn(usize, f64) -> bool,
) -> Option<JointBootstrap> {
    let all: Vec<&Diff> = diffs.iter().collect();
    let (recs, seeds, mats) = common(&all);
    let (rows, cols) = (recs.len(), seeds.len());
    if rows < 2 || cols < 2 || b < 2 {
        return None;
    }
    let observed: Vec<f64> = mats.iter().map(|m| m.iter().sum::<f64>() / (rows * cols) as f64).collect();
    let reps = replicate_means(&mats, (rows, cols), b, seed);
    let se: Vec<f64> = reps
        .iter()
        .map(|r| {
            let m = r.iter().sum::<f64>() / b as f64;
            (r.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (b - 1) as f64).sqrt()
        })
        .collect();
    let mut t_max: Vec<f64> = (0..b)
        .map(|k| {
            (0..mats.len())
                .map(|s| if se[s] > 0.0 { (reps[s][k] - observed[s]).abs() / se[s] } else { 0.0 })
                .fold(0.0, f64::max)
        })
        .collect();
    t_max.sort_by(f64::total_cmp);
    let critical = quantile_type7(&t_max, level);
    let mut share: Vec<f64> =
        (0..b).map(|k| (0..mats.len()).filter(|&s| reps[s][k] < 0.0).count() as f64 / mats.len() as f64).collect();
    share.sort_by(f64::total_cmp);
    let alpha = 1.0 - level;
    let observed_share = observed.iter().filter(|d| **d < 0.0).count() as f64 / mats.len() as f64;
    let null = null_test(&observed, &reps, &se, rule);
    let bands: Vec<(String, f64, f64, f64)> = (0..mats.len())
        .map(|s| (ids[s].clone(), se[s], observed[s] - critical * se[s], observed[s] + critical * se[s]))
        .collect();
    let bands_excluding_zero = bands.iter().filter(|b| b.2 > 0.0 || b.3 < 0.0).count();
    Some(JointBootstrap {
        replicates: b,
        seed,
        level,
        critical,
        bands,
        bands_excluding_zero,
        null,
        share_negative: (
            observed_share,
            quantile_type7(&share, alpha / 2.0),
            quantile_type7(&share, 1.0 - alpha / 2.0),
        ),
        recordings: rows,
    })
}

/// Replicates computed together, each with its own arithmetic.
const LANES: usize = 16;

/// Every specification's mean in each of `b` pigeonhole replicates
/// (`reps[s][k]`), the same row and column draws for every specification:
/// replicate k's row counts, then its column counts, from ChaCha8 stream 7
/// of `seed`. Replicates are computed [`LANES`] at a time and
/// specifications in parallel; each mean is summed in the one order a
/// replicate alone would use (a column's count times the cell, over the
/// columns; a row's count times that, over the rows with a draw), so the
/// result does not depend on either.
fn replicate_means(mats: &[Vec<f64>], (rows, cols): (usize, usize), b: usize, seed: u64) -> Vec<Vec<f64>> {
    use rayon::prelude::*;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(7);
    let mut reps: Vec<Vec<f64>> = vec![Vec::with_capacity(b); mats.len()];
    let mut done = 0;
    while done < b {
        let n = LANES.min(b - done);
        let mut rc = vec![[0u32; LANES]; rows];
        let mut cc = vec![[0.0f64; LANES]; cols];
        for l in 0..n {
            for _ in 0..rows {
                rc[rng.gen_range(0..rows)][l] += 1;
            }
            for _ in 0..cols {
                cc[rng.gen_range(0..cols)][l] += 1.0;
            }
        }
        let means: Vec<[f64; LANES]> = mats.par_iter().map(|m| lane_means(m, cols, &rc, &cc)).collect();
        for (r, m) in reps.iter_mut().zip(&means) {
            r.extend_from_slice(&m[..n]);
        }
        done += n;
    }
    reps
}

/// One matrix's mean under each lane's row counts `rc[i]` and column
/// counts `cc[j]`.
fn lane_means(m: &[f64], cols: usize, rc: &[[u32; LANES]], cc: &[[f64; LANES]]) -> [f64; LANES] {
    let mut total = [0.0f64; LANES];
    for (i, counts) in rc.iter().enumerate() {
        // As `Iterator::sum` of f64 starts.
        let mut row = [-0.0f64; LANES];
        for (x, c) in m[i * cols..(i + 1) * cols].iter().zip(cc) {
            for l in 0..LANES {
                row[l] += c[l] * x;
            }
        }
        for l in 0..LANES {
            if counts[l] != 0 {
                total[l] += f64::from(counts[l]) * row[l];
            }
        }
    }
    total.map(|t| t / (rc.len() * cols) as f64)
}

/// The median, the count holding and Stouffer's t of the observed curve
/// and of each replicate centred at zero (`reps[s][k] - observed[s]`).
fn null_test(observed: &[f64], reps: &[Vec<f64>], se: &[f64], rule: &dyn Fn(usize, f64) -> bool) -> NullTest {
    let n = observed.len();
    let b = reps.first().map_or(0, Vec::len);
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        if v.len() % 2 == 1 {
            v[v.len() / 2]
        } else {
            0.5 * (v[v.len() / 2 - 1] + v[v.len() / 2])
        }
    };
    let stouffer = |d: &dyn Fn(usize) -> f64| -> f64 {
        (0..n).map(|s| if se[s] > 0.0 { d(s) / se[s] } else { 0.0 }).sum::<f64>() / (n as f64).sqrt()
    };
    let holding = |d: &dyn Fn(usize) -> f64| (0..n).filter(|&s| rule(s, d(s))).count();
    let med_obs = median(&mut observed.to_vec());
    let hold_obs = holding(&|s| observed[s]);
    let z_obs = stouffer(&|s| observed[s]);
    let (mut at_med, mut at_hold, mut at_z) = (0usize, 0usize, 0usize);
    // Replicate k is column k of every specification's row of `reps`.
    #[allow(clippy::needless_range_loop)]
    for k in 0..b {
        let null = |s: usize| reps[s][k] - observed[s];
        if median(&mut (0..n).map(null).collect()) <= med_obs {
            at_med += 1;
        }
        if holding(&null) >= hold_obs {
            at_hold += 1;
        }
        if stouffer(&null) <= z_obs {
            at_z += 1;
        }
    }
    let p = |m: usize| (1 + m) as f64 / (1 + b) as f64;
    NullTest { median: (med_obs, p(at_med)), holding: (hold_obs, p(at_hold)), stouffer: (z_obs, p(at_z)) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The replicate means as they were computed one replicate at a time.
    fn one_at_a_time(mats: &[Vec<f64>], rows: usize, cols: usize, b: usize, seed: u64) -> Vec<Vec<f64>> {
        let mean = |m: &[f64], rc: &[u32], cc: &[u32]| -> f64 {
            let mut s = 0.0;
            for i in 0..rows {
                if rc[i] == 0 {
                    continue;
                }
                let row: f64 = (0..cols).map(|j| f64::from(cc[j]) * m[i * cols + j]).sum();
                s += f64::from(rc[i]) * row;
            }
            s / (rows * cols) as f64
        };
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(7);
        let mut reps: Vec<Vec<f64>> = vec![Vec::new(); mats.len()];
        for _ in 0..b {
            let mut rc = vec![0u32; rows];
            let mut cc = vec![0u32; cols];
            for _ in 0..rows {
                rc[rng.gen_range(0..rows)] += 1;
            }
            for _ in 0..cols {
                cc[rng.gen_range(0..cols)] += 1;
            }
            for (s, m) in mats.iter().enumerate() {
                reps[s].push(mean(m, &rc, &cc));
            }
        }
        reps
    }

    #[test]
    fn batched_replicates_are_bit_identical_to_one_at_a_time() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for (rows, cols, specs, b) in [(2, 2, 1, 1), (3, 5, 2, 15), (7, 4, 3, 16), (26, 20, 8, 17), (9, 13, 5, 99)] {
            let mats: Vec<Vec<f64>> = (0..specs)
                .map(|_| {
                    (0..rows * cols).map(|_| rng.gen_range(-1.0..1.0) * 10f64.powi(rng.gen_range(-3..3))).collect()
                })
                .collect();
            let (new, old) = (replicate_means(&mats, (rows, cols), b, 11), one_at_a_time(&mats, rows, cols, b, 11));
            let bits =
                |r: &[Vec<f64>]| r.iter().map(|v| v.iter().map(|x| x.to_bits()).collect()).collect::<Vec<Vec<u64>>>();
            assert_eq!(bits(&new), bits(&old), "{rows} x {cols}, {specs} specifications, B = {b}");
        }
    }
}
