//! The pigeonhole bootstrap (Owen 2007, "The pigeonhole bootstrap", Ann.
//! Appl. Stat. 1(2)): rows and columns are resampled independently with
//! replacement and the replicate is the mean of the resampled I x J array.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::{quantile_type7, CrossedMatrix, StatsError};

/// A pigeonhole bootstrap percentile interval for the grand mean.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BootstrapInterval {
    /// Number of replicates B.
    pub replicates: usize,
    /// ChaCha8 seed.
    pub seed: u64,
    /// ChaCha8 stream, so that each contrast of one analysis gets its own
    /// reproducible sequence from the one design seed.
    pub stream: u64,
    /// Confidence level.
    pub level: f64,
    /// Standard deviation of the replicate means (divisor B - 1).
    pub se: f64,
    /// Percentile interval (type-7 quantiles of the replicate means).
    pub lower: f64,
    /// Upper percentile bound.
    pub upper: f64,
}

/// Runs `b` pigeonhole replicates and returns the percentile interval.
/// Deterministic for (`seed`, `stream`).
pub fn pigeonhole_bootstrap(
    m: &CrossedMatrix,
    b: usize,
    level: f64,
    seed: u64,
    stream: u64,
) -> Result<BootstrapInterval, StatsError> {
    if b == 0 {
        return Err(StatsError::NoReplicates);
    }
    if !(level > 0.0 && level < 1.0) {
        return Err(StatsError::Level(level));
    }
    let reps = replicate_means(m, b, seed, stream);
    let mean = reps.iter().sum::<f64>() / b as f64;
    let var = if b > 1 { reps.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (b - 1) as f64 } else { 0.0 };
    let mut sorted = reps;
    sorted.sort_by(f64::total_cmp);
    let alpha = 1.0 - level;
    Ok(BootstrapInterval {
        replicates: b,
        seed,
        stream,
        level,
        se: var.sqrt(),
        lower: quantile_type7(&sorted, alpha / 2.0),
        upper: quantile_type7(&sorted, 1.0 - alpha / 2.0),
    })
}

/// Replicates computed together: each keeps its own sums, in the same
/// order as one at a time, so the batch only lets the processor work on
/// several independent sums at once (vector lanes across replicates).
const BATCH: usize = 16;

/// The replicate means. Each replicate draws I row indices, then J column
/// indices; its mean is n' D m / (IJ) for the draw counts n (rows) and m
/// (columns), which costs O(IJ) without building the resampled array.
///
/// Replicates are drawn in order from one ChaCha8 stream and computed
/// [`BATCH`] at a time: for each row i, every replicate's sum over j of
/// d_ij m_j (in j order, starting from -0.0 as `Iterator::sum` does), then
/// added n_i times that sum to the replicate's total in i order, skipping
/// rows it did not draw. Every replicate's arithmetic is therefore the
/// same, operation for operation, as computing it alone.
pub fn replicate_means(m: &CrossedMatrix, b: usize, seed: u64, stream: u64) -> Vec<f64> {
    use rayon::prelude::*;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    let mut out = Vec::with_capacity(b);
    while out.len() < b {
        // A wave of batches: their draws in stream order, then their sums
        // in parallel. Each batch's arithmetic is its own, so the wave's
        // size and the thread count change no bit.
        let mut wave = Vec::with_capacity(WAVE);
        let mut drawn = out.len();
        while drawn < b && wave.len() < WAVE {
            let lanes = (b - drawn).min(BATCH);
            wave.push(draw_batch(&mut rng, m.rows(), m.cols(), lanes));
            drawn += lanes;
        }
        let means: Vec<Vec<f64>> = wave.par_iter().map(|d| batch_means(m, d)).collect();
        out.extend(means.into_iter().flatten());
    }
    out
}

/// Batches drawn before their sums are computed together: a bound on the
/// draw counts held at once.
const WAVE: usize = 32;

/// The draw counts of one batch: rows x BATCH and cols x BATCH, replicate
/// k in lane k, for its first `lanes` lanes.
struct Draws {
    lanes: usize,
    rows: Vec<[u32; BATCH]>,
    cols: Vec<[f64; BATCH]>,
}

/// Draws a batch's replicates in order from `rng`: each its I row
/// indices, then its J column indices.
fn draw_batch(rng: &mut ChaCha8Rng, rows: usize, cols: usize, lanes: usize) -> Draws {
    let mut d = Draws { lanes, rows: vec![[0u32; BATCH]; rows], cols: vec![[0.0f64; BATCH]; cols] };
    for k in 0..lanes {
        for _ in 0..rows {
            d.rows[rng.gen_range(0..rows)][k] += 1;
        }
        for _ in 0..cols {
            d.cols[rng.gen_range(0..cols)][k] += 1.0;
        }
    }
    d
}

/// The means of one batch's replicates, compiled for the widest vector
/// instructions the processor has (pulp's dispatch: AVX2 where present).
/// Each replicate keeps its own lane of plain multiplications and
/// additions, never fused, so every width gives the same bits.
fn batch_means(m: &CrossedMatrix, d: &Draws) -> Vec<f64> {
    struct Means<'a>(&'a CrossedMatrix, &'a Draws);
    impl pulp::WithSimd for Means<'_> {
        type Output = Vec<f64>;
        #[inline(always)]
        fn with_simd<S: pulp::Simd>(self, _: S) -> Vec<f64> {
            batch_means_in(self.0, self.1)
        }
    }
    pulp::Arch::new().dispatch(Means(m, d))
}

/// [`batch_means`]'s arithmetic, inlined into each dispatched width. The
/// rows some replicate drew are summed two at a time: each row's sums in
/// j order, as alone, the two rows' side by side only so that the
/// processor adds both at once (one row's sums wait on each addition);
/// the totals then take each row's sums in row order.
#[inline(always)]
fn batch_means_in(m: &CrossedMatrix, d: &Draws) -> Vec<f64> {
    let norm = (m.rows() * m.cols()) as f64;
    let mut total = [0.0f64; BATCH];
    let drawn: Vec<usize> = (0..m.rows()).filter(|&i| d.rows[i].iter().any(|&x| x != 0)).collect();
    for pair in drawn.chunks(2) {
        let sums = match *pair {
            [a, b] => row_sums(m.row(a), m.row(b), &d.cols),
            [a] => row_sums(m.row(a), m.row(a), &d.cols),
            _ => continue,
        };
        for (&i, acc) in pair.iter().zip(&sums) {
            let n = &d.rows[i];
            for k in 0..d.lanes {
                if n[k] != 0 {
                    total[k] += f64::from(n[k]) * acc[k];
                }
            }
        }
    }
    total[..d.lanes].iter().map(|t| t / norm).collect()
}

/// Two rows' sums over j of d_ij m_j for every replicate (lane), each from
/// -0.0 in j order; the sums are returned by value, so that they stay in
/// registers.
#[inline(always)]
fn row_sums(a: &[f64], b: &[f64], cols: &[[f64; BATCH]]) -> [[f64; BATCH]; 2] {
    let (mut sa, mut sb) = ([-0.0f64; BATCH], [-0.0f64; BATCH]);
    for ((&u, &v), c) in a.iter().zip(b).zip(cols) {
        for k in 0..BATCH {
            sa[k] += u * c[k];
        }
        for k in 0..BATCH {
            sb[k] += v * c[k];
        }
    }
    [sa, sb]
}

/// The exact variance of one pigeonhole replicate mean given the data.
///
/// Write d_ij = mu + alpha_i + beta_j + gamma_ij with the effects summing to
/// zero over each index. A replicate mean is
/// mu + mean_a alpha_{r_a} + mean_b beta_{c_b} + mean_ab gamma_{r_a c_b}
/// with r_a, c_b independent uniform draws. The three parts are uncorrelated
/// (every cross moment contains a zero-sum), and within the gamma part only
/// pairs with the same row draw and the same column draw survive, so
///
/// Var* = sum alpha_i^2 / I^2 + sum beta_j^2 / J^2 + sum gamma_ij^2 / (IJ)^2
///      = (I-1) MS_r / (I^2 J) + (J-1) MS_c / (I J^2) + (I-1)(J-1) MS_e / (IJ)^2.
///
/// Compared with the MoM SE^2 = sa/I + sb/J + se/(IJ), the seed term is
/// shrunk by (J-1)/J, so with few seeds and a dominant seed component the
/// bootstrap is anti-conservative.
pub fn pigeonhole_variance(m: &CrossedMatrix) -> f64 {
    let ms = super::mean_squares(m);
    let (i_n, j_n) = (m.rows() as f64, m.cols() as f64);
    ms.df_rows * ms.ms_rows / (i_n * i_n * j_n)
        + ms.df_cols * ms.ms_cols / (i_n * j_n * j_n)
        + ms.df_error * ms.ms_error / (i_n * j_n).powi(2)
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;

    /// One replicate at a time, as every earlier build computed them: the
    /// reference the batched replicates must equal bit for bit.
    fn one_at_a_time(m: &CrossedMatrix, b: usize, seed: u64, stream: u64) -> Vec<f64> {
        let (rows, cols) = (m.rows(), m.cols());
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(stream);
        let (mut rc, mut cc) = (vec![0u32; rows], vec![0u32; cols]);
        (0..b)
            .map(|_| {
                rc.iter_mut().for_each(|c| *c = 0);
                cc.iter_mut().for_each(|c| *c = 0);
                for _ in 0..rows {
                    rc[rng.gen_range(0..rows)] += 1;
                }
                for _ in 0..cols {
                    cc[rng.gen_range(0..cols)] += 1;
                }
                let mut total = 0.0;
                for (i, &n) in rc.iter().enumerate() {
                    if n != 0 {
                        let row_sum: f64 = m.row(i).iter().zip(&cc).map(|(v, &c)| v * f64::from(c)).sum();
                        total += f64::from(n) * row_sum;
                    }
                }
                total / (rows * cols) as f64
            })
            .collect()
    }

    #[test]
    fn batched_replicates_equal_one_at_a_time_bit_for_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(40);
        for case in 0..40 {
            let (rows, cols) = (rng.gen_range(2..30), rng.gen_range(2..30));
            let v: Vec<f64> =
                (0..rows * cols).map(|_| rng.gen_range(-1.0..1.0) * 10f64.powi(rng.gen_range(-3..3))).collect();
            let m = CrossedMatrix::new(rows, cols, v).unwrap();
            // Batches full, partial and single.
            for b in [1, 15, 16, 17, 99] {
                let (got, want) = (replicate_means(&m, b, case, 3), one_at_a_time(&m, b, case, 3));
                let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&got), bits(&want), "case {case}: {rows} x {cols}, B = {b}");
            }
        }
    }
}
