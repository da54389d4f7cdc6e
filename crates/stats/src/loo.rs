//! Leave-one-out of the crossed method of moments in closed form: every
//! fit with one row (recording) or one column (seed) deleted, from one
//! decomposition of the full array, in O(IJ) for all of them together
//! instead of O(IJ) for each.
//!
//! Write the complete I x J array as d_ij = mu + a_i + b_j + g_ij with
//! a_i = row mean - mu, b_j = column mean - mu and g_ij the interaction
//! residual, so that a, b and every row and column of g sum to zero.
//! Deleting row k (I' = I - 1) leaves the other rows' means unchanged, and
//!
//! - the grand mean is mu - a_k / I';
//! - the column means less the new grand mean are b_j - g_kj / I';
//! - the residuals of the rows kept are g_ij + g_kj / I',
//!
//! because sum_{i != k} a_i = -a_k and sum_{i != k} g_ij = -g_kj. Summing
//! squares with A = sum a_i^2, B = sum b_j^2 and G = sum g_ij^2:
//!
//! - SS_rows' = J (A - a_k^2 I / I')
//! - SS_cols' = I' B - 2 sum_j b_j g_kj + sum_j g_kj^2 / I'
//! - SS_error' = G - (I / I') sum_j g_kj^2
//!
//! and a deleted column is the same with rows and columns exchanged. Every
//! term is a sum of squares of centred quantities, so no large sums cancel
//! (unlike SS = sum d^2 - n mean^2). The estimates then go through the same
//! code as [`super::crossed_mom`]'s.

use super::crossed::{mom_from_squares, MeanSquares};
use super::{CrossedEstimate, CrossedMatrix, DfRule, StatsError};

/// Which index a leave-one-out deletes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// A row (a recording).
    Rows,
    /// A column (a seed).
    Cols,
}

/// The crossed MoM estimate of `m` with each row (or each column) left out
/// in turn, in index order: element k is `crossed_mom` of `m` without row
/// (column) k, to rounding. Needs at least 3 of what is deleted.
///
/// ```
/// use crossaudit_stats::{crossed_mom, leave_one_out_mom, Axis, CrossedMatrix, DfRule};
/// let m = CrossedMatrix::from_rows(&[vec![1.0, 2.0, 4.0], vec![2.0, 5.0, 3.0], vec![0.5, 1.0, 3.5]]).unwrap();
/// let fits = leave_one_out_mom(&m, Axis::Rows, 0.95, DfRule::Satterthwaite).unwrap();
/// let refit = crossed_mom(
///     &CrossedMatrix::from_rows(&[vec![1.0, 2.0, 4.0], vec![0.5, 1.0, 3.5]]).unwrap(),
///     0.95,
///     DfRule::Satterthwaite,
/// )
/// .unwrap();
/// assert!((fits[1].upper - refit.upper).abs() < 1e-12);
/// ```
pub fn leave_one_out_mom(
    m: &CrossedMatrix,
    axis: Axis,
    level: f64,
    df_rule: DfRule,
) -> Result<Vec<CrossedEstimate>, StatsError> {
    let (rows, cols) = (m.rows(), m.cols());
    let deleted = if axis == Axis::Rows { rows } else { cols };
    if deleted < 3 {
        let what =
            if axis == Axis::Rows { "rows (recordings) to leave one out" } else { "columns (seeds) to leave one out" };
        return Err(StatsError::TooFew { what, found: deleted });
    }
    // Everything below is computed on d - c for c the grand mean, so that
    // effects small beside a mean far from zero keep their digits (d - c is
    // exact wherever d is within a factor of 2 of c).
    let c = m.mean();
    let (mut row_sum, mut col_sum) = (vec![0.0; rows], vec![0.0; cols]);
    for (i, rs) in row_sum.iter_mut().enumerate() {
        for (cs, &d) in col_sum.iter_mut().zip(m.row(i)) {
            *rs += d - c;
            *cs += d - c;
        }
    }
    let mu_c = row_sum.iter().sum::<f64>() / (rows * cols) as f64;
    let mu = c + mu_c;
    let a: Vec<f64> = row_sum.iter().map(|r| r / cols as f64 - mu_c).collect();
    let b: Vec<f64> = col_sum.iter().map(|s| s / rows as f64 - mu_c).collect();
    // Per row and per column of g: its sum of squares and its cross product
    // with the other factor's effects.
    let (mut g_row, mut gb_row) = (vec![0.0; rows], vec![0.0; rows]);
    let (mut g_col, mut ga_col) = (vec![0.0; cols], vec![0.0; cols]);
    for (i, (row, &ai)) in (0..rows).map(|i| m.row(i)).zip(&a).enumerate() {
        let (mut sq, mut cross) = (0.0, 0.0);
        for (j, (&d, &bj)) in row.iter().zip(&b).enumerate() {
            let g = (d - c - mu_c) - ai - bj;
            sq += g * g;
            cross += bj * g;
            g_col[j] += g * g;
            ga_col[j] += ai * g;
        }
        g_row[i] = sq;
        gb_row[i] = cross;
    }
    let sum_sq = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>();
    let (big_a, big_b, big_g) = (sum_sq(&a), sum_sq(&b), g_row.iter().sum::<f64>());
    (0..deleted)
        .map(|k| {
            // The deleted index's own factor ("own": n levels, effects e)
            // and the other factor (m levels, effects f).
            let (n, other, e_k, own_ss, other_ss, cross, g_k) = match axis {
                Axis::Rows => (rows as f64, cols as f64, a[k], big_a, big_b, gb_row[k], g_row[k]),
                Axis::Cols => (cols as f64, rows as f64, b[k], big_b, big_a, ga_col[k], g_col[k]),
            };
            let n1 = n - 1.0;
            let ss_own = other * (own_ss - e_k * e_k * n / n1);
            let ss_other = n1 * other_ss - 2.0 * cross + g_k / n1;
            let ss_error = (big_g - n / n1 * g_k).max(0.0);
            let (df_own, df_other) = (n1 - 1.0, other - 1.0);
            let (ss_rows, ss_cols, df_rows, df_cols) = match axis {
                Axis::Rows => (ss_own, ss_other, df_own, df_other),
                Axis::Cols => (ss_other, ss_own, df_other, df_own),
            };
            let df_error = df_rows * df_cols;
            let ms = MeanSquares {
                grand_mean: mu - e_k / n1,
                ss_rows,
                ss_cols,
                ss_error,
                df_rows,
                df_cols,
                df_error,
                ms_rows: ss_rows / df_rows,
                ms_cols: ss_cols / df_cols,
                ms_error: ss_error / df_error,
            };
            let (r, c) = match axis {
                Axis::Rows => (rows - 1, cols),
                Axis::Cols => (rows, cols - 1),
            };
            mom_from_squares(ms, r, c, level, df_rule)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::crossed_mom;

    /// `m` without row (or column) k, refitted from scratch on the array
    /// less `offset` (exact in floating point for these values, by
    /// Sterbenz's lemma, and the mean squares do not depend on a shift), so
    /// that the refit itself loses no digits to a mean far from zero.
    fn refit(m: &CrossedMatrix, offset: f64, axis: Axis, k: usize, df: DfRule) -> CrossedEstimate {
        let rows: Vec<Vec<f64>> = (0..m.rows())
            .filter(|&i| axis == Axis::Cols || i != k)
            .map(|i| {
                let row = m.row(i).iter().enumerate().filter(|&(j, _)| axis == Axis::Rows || j != k);
                row.map(|(_, v)| v - offset).collect()
            })
            .collect();
        let mut e = crossed_mom(&CrossedMatrix::from_rows(&rows).unwrap(), 0.95, df).unwrap();
        (e.mean, e.lower, e.upper) = (e.mean + offset, e.lower + offset, e.upper + offset);
        e
    }

    /// Closed form against refits on random arrays of many shapes (square
    /// and not, 3 to 40 levels), with component sizes from zero (so that the
    /// truncation at zero and the Satterthwaite branches are all taken) to
    /// dominant, and a mean far from zero (where SS = sum d^2 - n mean^2
    /// would lose digits): every number of the estimate to 1e-12 relative
    /// (means and interval ends relative to the data's size, mean squares
    /// relative to the largest).
    #[test]
    fn the_closed_form_equals_the_refit_on_random_arrays() {
        let mut rng = ChaCha8Rng::seed_from_u64(45);
        let mut worst = 0.0f64;
        for case in 0..300 {
            let (rows, cols) = (rng.gen_range(3..40), rng.gen_range(3..40));
            let scales: Vec<f64> = (0..3).map(|_| [0.0, 0.01, 1.0, 30.0][rng.gen_range(0..4)]).collect();
            let offset = [0.0, -0.03, 100.0][case % 3];
            let offset = if scales[0].max(scales[1]).max(scales[2]) < offset / 8.0 { offset } else { 0.0 };
            let ra: Vec<f64> = (0..rows).map(|_| scales[0] * rng.gen_range(-1.0..1.0)).collect();
            let cb: Vec<f64> = (0..cols).map(|_| scales[1] * rng.gen_range(-1.0..1.0)).collect();
            let v: Vec<f64> = (0..rows * cols)
                .map(|k| offset + ra[k / cols] + cb[k % cols] + (scales[2] + 1e-3) * rng.gen_range(-1.0..1.0))
                .collect();
            let m = CrossedMatrix::new(rows, cols, v).unwrap();
            // Means and interval ends near zero are compared relative to
            // the data's own size (their rounding is of that size).
            let spread = m.values().iter().map(|v| (v - offset).abs()).fold(0.0, f64::max);
            for df in [DfRule::Satterthwaite, DfRule::SeedsMinusOne, DfRule::Normal] {
                for axis in [Axis::Rows, Axis::Cols] {
                    let fits = leave_one_out_mom(&m, axis, 0.95, df).unwrap();
                    assert_eq!(fits.len(), if axis == Axis::Rows { rows } else { cols });
                    for (k, fit) in fits.iter().enumerate() {
                        let want = refit(&m, offset, axis, k, df);
                        let (a, b) = (fit.mean_squares.unwrap(), want.mean_squares.unwrap());
                        // A mean square far below the largest one carries
                        // the rounding of the data at that one's size (a
                        // row effect of 1e-4 computed from values of 30
                        // has about 1e-11 of relative rounding in any
                        // method, the refit included): compared relative
                        // to the largest.
                        let top = b.ms_rows.max(b.ms_cols).max(b.ms_error);
                        let pairs = [
                            (fit.mean, want.mean, spread),
                            (fit.lower, want.lower, spread),
                            (fit.upper, want.upper, spread),
                            (fit.se, want.se, 0.0),
                            (fit.df, want.df, 0.0),
                            (a.ms_rows, b.ms_rows, top),
                            (a.ms_cols, b.ms_cols, top),
                            (a.ms_error, b.ms_error, top),
                            (fit.components.recording, want.components.recording, top),
                            (fit.components.seed, want.components.seed, top),
                        ];
                        for (n, (got, expected, floor)) in pairs.into_iter().enumerate() {
                            if got == expected {
                                continue;
                            }
                            let rel = (got - expected).abs() / expected.abs().max(floor);
                            worst = worst.max(rel);
                            assert!(
                                rel < 1e-12,
                                "case {case} ({rows} x {cols}, {axis:?} {k}, {df:?}), number {n}: {got} against the refit's {expected}"
                            );
                        }
                        assert_eq!((fit.rows, fit.cols), (want.rows, want.cols));
                    }
                }
            }
        }
        eprintln!("largest relative difference from the refits: {worst:.2e}");
    }

    #[test]
    fn fewer_than_three_levels_to_delete_are_refused() {
        let m = CrossedMatrix::from_rows(&[vec![1.0, 2.0, 4.0], vec![2.0, 5.0, 3.0]]).unwrap();
        assert!(matches!(
            leave_one_out_mom(&m, Axis::Rows, 0.95, DfRule::Satterthwaite),
            Err(StatsError::TooFew { found: 2, .. })
        ));
        assert_eq!(leave_one_out_mom(&m, Axis::Cols, 0.95, DfRule::Satterthwaite).unwrap().len(), 3);
    }
}
