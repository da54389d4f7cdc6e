//! The ANOVA tables of the arrays L(rho) = T - (1 - rho) R at several rho
//! in one pass over T and R, each bit for bit the table
//! [`crate::mean_squares`] gives the array built alone.
//!
//! Fieller's search ([`crate::ratio_interval_batched`]) evaluates L about
//! fifty times per edge of its set, and each table is two sums over every
//! cell that must be added in one fixed order. Such a sum waits on the
//! latency of each addition, and the other work per cell is small, so one
//! core has room for more: here [`ALONG_LANES`] arrays are summed side by side,
//! the values of one cell of all of them in one vector register, each
//! lane its own array's sums in its own order. Eight arrays then cost
//! about what one did, and the search spends them on both edges and on the
//! steps after the next (`ratio::roots`).

use super::crossed::anova_table;
use super::matrix::check_shape;
use super::{MeanSquares, StatsError};

/// The arrays summed side by side in one pass: the values of one cell of
/// all of them fill one 512-bit vector register.
pub const ALONG_LANES: usize = 8;

/// The ANOVA table of L(rho) = T - (1 - rho) R at each of `rhos`, for
/// complete `rows` x `cols` arrays `t` and `r` (row-major), each
/// bit for bit `mean_squares(&CrossedMatrix::new(rows, cols, L(rho))?)`,
/// and the same error where that would fail. With each table, whether every
/// row of L(rho) is one value repeated (bit for bit), as an array invariant
/// to the seed is. Up to [`ALONG_LANES`] rho cost about one pass over the data.
///
/// ```
/// use crossaudit_stats::{mean_squares, mean_squares_along, CrossedMatrix};
/// let t = [2.1, 2.0, 2.0, 2.3, 2.1, 1.9];
/// let r = [3.0, 3.2, 2.9, 3.4, 3.1, 2.8];
/// let tables = mean_squares_along(&t, &r, 3, 2, &[0.25, -0.5]);
/// for (rho, got) in [0.25, -0.5].into_iter().zip(tables) {
///     let l = t.iter().zip(&r).map(|(t, r)| t - (1.0 - rho) * r).collect();
///     let (table, constant) = got?;
///     assert_eq!(table, mean_squares(&CrossedMatrix::new(3, 2, l)?));
///     assert!(!constant);
/// }
/// # Ok::<(), crossaudit_stats::StatsError>(())
/// ```
pub fn mean_squares_along(
    t: &[f64],
    r: &[f64],
    rows: usize,
    cols: usize,
    rhos: &[f64],
) -> Vec<Result<(MeanSquares, bool), StatsError>> {
    // The shape is checked as `CrossedMatrix::new` checks it.
    let shape = check_shape(rows, cols, t.len()).and_then(|()| check_shape(rows, cols, r.len()));
    if let Err(e) = shape {
        return rhos.iter().map(|_| Err(e.clone())).collect();
    }
    // Compiled for the widest vector instructions the processor has
    // (pulp's dispatch): every lane is plain IEEE arithmetic, never fused,
    // the same bits at every width.
    struct Along<'a>(&'a [f64], &'a [f64], usize, &'a [f64]);
    impl pulp::WithSimd for Along<'_> {
        type Output = Vec<Result<(MeanSquares, bool), StatsError>>;
        #[inline(always)]
        fn with_simd<S: pulp::Simd>(self, _: S) -> Self::Output {
            let Along(t, r, cols, rhos) = self;
            let mut out = Vec::with_capacity(rhos.len());
            for group in rhos.chunks(ALONG_LANES) {
                // A short group fills its spare lanes with its last rho.
                let lanes: [f64; ALONG_LANES] = std::array::from_fn(|k| group[k.min(group.len() - 1)]);
                out.extend(tables(t, r, cols, lanes).into_iter().take(group.len()));
            }
            out
        }
    }
    pulp::Arch::new().dispatch(Along(t, r, cols, rhos))
}

/// The tables of [`ALONG_LANES`] arrays side by side. Each array's sums are added
/// in the order of [`crate::mean_squares`]: the grand total in row-major
/// order from -0.0, each row's total in column order from -0.0, each
/// column's in row order from 0.0, then the residual squares in row-major
/// order from 0.0. The lanes only let the processor make the same
/// additions of all the arrays at once; no sum crosses another.
#[inline(always)]
fn tables(
    t: &[f64],
    r: &[f64],
    cols: usize,
    rhos: [f64; ALONG_LANES],
) -> [Result<(MeanSquares, bool), StatsError>; ALONG_LANES] {
    let rows = t.len() / cols;
    let (i_n, j_n) = (rows as f64, cols as f64);
    let shrink = rhos.map(|rho| 1.0 - rho);
    let mut cm = vec![[0.0f64; ALONG_LANES]; cols];
    let mut rm = Vec::with_capacity(rows);
    // Each lane's bits that differ from its row's first value, or'ed over
    // every cell: zero where every row is one value repeated.
    let (mut total, mut differ) = ([-0.0f64; ALONG_LANES], [0u64; ALONG_LANES]);
    for (tr, rr) in t.chunks_exact(cols).zip(r.chunks_exact(cols)) {
        let row;
        (total, row, differ) = row_sums(tr, rr, shrink, &mut cm, total, differ);
        rm.push(row.map(|x| x / j_n));
    }
    cm.iter_mut().for_each(|c| *c = c.map(|x| x / i_n));
    let mu = total.map(|x| x / (rows * cols) as f64);
    let mut ss_error = [0.0f64; ALONG_LANES];
    for ((tr, rr), ri) in t.chunks_exact(cols).zip(r.chunks_exact(cols)).zip(&rm) {
        ss_error = row_squares(tr, rr, shrink, (ri, &cm, mu), ss_error);
    }
    std::array::from_fn(|k| {
        if !total[k].is_finite() {
            // A value that is not finite makes the total so; find the first
            // (the total can also overflow from finite values alone).
            let bad = t.iter().zip(r).map(|(a, b)| a - shrink[k] * b).position(|v| !v.is_finite());
            if let Some(p) = bad {
                let value = t[p] - shrink[k] * r[p];
                return Err(StatsError::NonFinite { row: p / cols, col: p % cols, value });
            }
        }
        let (rm_k, cm_k): (Vec<f64>, Vec<f64>) = (rm.iter().map(|x| x[k]).collect(), cm.iter().map(|x| x[k]).collect());
        Ok((anova_table(mu[k], &rm_k, &cm_k, ss_error[k]), differ[k] == 0))
    })
}

// The two passes over a row, the lanes' running sums passed and returned
// by value, so that the compiler keeps them in registers; each loop over
// the lanes is one operation, which it turns into one vector instruction.

/// A row's first pass: each lane's values added to its grand total, its
/// row's sum (returned, from -0.0) and each column's sum (`cm`), and the
/// bits that differ from the row's first value or'ed into `differ`.
#[inline(always)]
fn row_sums(
    tr: &[f64],
    rr: &[f64],
    shrink: [f64; ALONG_LANES],
    cm: &mut [[f64; ALONG_LANES]],
    mut total: [f64; ALONG_LANES],
    mut differ: [u64; ALONG_LANES],
) -> ([f64; ALONG_LANES], [f64; ALONG_LANES], [u64; ALONG_LANES]) {
    let first = shrink.map(|s| (tr[0] - s * rr[0]).to_bits());
    let mut row = [-0.0f64; ALONG_LANES];
    for (c, (&a, &b)) in cm.iter_mut().zip(tr.iter().zip(rr)) {
        let v: [f64; ALONG_LANES] = std::array::from_fn(|k| a - shrink[k] * b);
        for k in 0..ALONG_LANES {
            total[k] += v[k];
        }
        for k in 0..ALONG_LANES {
            row[k] += v[k];
        }
        for k in 0..ALONG_LANES {
            c[k] += v[k];
        }
        for k in 0..ALONG_LANES {
            differ[k] |= v[k].to_bits() ^ first[k];
        }
    }
    (total, row, differ)
}

/// A row's second pass: each lane's squared residuals x - row mean - column
/// mean + grand mean added to its running sum `ss`.
#[inline(always)]
fn row_squares(
    tr: &[f64],
    rr: &[f64],
    shrink: [f64; ALONG_LANES],
    (ri, cm, mu): (&[f64; ALONG_LANES], &[[f64; ALONG_LANES]], [f64; ALONG_LANES]),
    mut ss: [f64; ALONG_LANES],
) -> [f64; ALONG_LANES] {
    for (c, (&a, &b)) in cm.iter().zip(tr.iter().zip(rr)) {
        let e: [f64; ALONG_LANES] = std::array::from_fn(|k| a - shrink[k] * b - ri[k] - c[k] + mu[k]);
        for k in 0..ALONG_LANES {
            ss[k] += e[k] * e[k];
        }
    }
    ss
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{mean_squares, CrossedMatrix};

    /// Each array's table equals the one `mean_squares` gives it alone, bit
    /// for bit, whether it is summed alone or beside up to nine others
    /// (past eight, in two passes), on data whose sums round at every step
    /// (values of mixed magnitude).
    #[test]
    fn side_by_side_tables_are_the_tables_alone() -> Result<(), StatsError> {
        let (rows, cols) = (37usize, 23usize);
        let mut u = crate::lcg_uniform(0x9e37_79b9_7f4a_7c15u64);
        let r: Vec<f64> = (0..rows * cols).map(|k| 1e3 * u() + (k % 7) as f64 * 1e-3).collect();
        let t: Vec<f64> = r.iter().map(|x| 0.9 * x + u() * 1e-2).collect();
        let rhos = [0.1, -0.37, 1e-9, 0.1 + 1e-16, 2.5, -7.0, 0.333, 1.0, -1e-12, 0.75];
        for n in 1..=rhos.len() {
            for (rho, got) in rhos[..n].iter().zip(mean_squares_along(&t, &r, rows, cols, &rhos[..n])) {
                let l = t.iter().zip(&r).map(|(t, r)| t - (1.0 - rho) * r).collect();
                let alone = mean_squares(&CrossedMatrix::new(rows, cols, l)?);
                let (table, constant) = got?;
                assert_eq!(format!("{table:?}"), format!("{alone:?}"), "rho {rho} among {n}");
                assert_eq!(table.ss_error.to_bits(), alone.ss_error.to_bits());
                assert!(!constant);
            }
        }
        Ok(())
    }

    /// Rows that are one value repeated are reported so; the shape and a
    /// value that is not finite are refused as `CrossedMatrix::new` refuses
    /// them.
    #[test]
    fn constant_rows_and_the_errors_of_the_array_built_alone() {
        let r = [1.0, 1.0, 2.0, 2.0, 4.0, 4.0];
        let t = [0.5, 0.5, 1.0, 1.0, 3.0, 3.0];
        let got = mean_squares_along(&t, &r, 3, 2, &[0.0, 0.5]);
        assert!(got.iter().all(|g| matches!(g, Ok((_, true)))));
        let huge = [1.0, f64::MAX, 2.0, 2.0, 4.0, 4.0];
        let got = mean_squares_along(&t, &huge, 3, 2, &[0.0, -1.0]);
        let l: Vec<f64> = t.iter().zip(&huge).map(|(t, r)| t - 2.0 * r).collect();
        let alone = CrossedMatrix::new(3, 2, l).err();
        assert_eq!(got[1].as_ref().err(), alone.as_ref());
        assert!(matches!(alone, Some(StatsError::NonFinite { row: 0, col: 1, .. })));
        assert!(got[0].is_ok());
        for (rows, cols, n) in [(1, 2, 2), (3, 1, 3), (3, 2, 5)] {
            let alone = CrossedMatrix::new(rows, cols, vec![0.0; n]).err();
            let got = mean_squares_along(&vec![0.0; n], &vec![0.0; n], rows, cols, &[0.0]);
            assert_eq!(got[0].as_ref().err(), alone.as_ref(), "{rows} x {cols}, {n} values");
        }
    }
}
