//! The ANOVA tables of the arrays L(rho) = T - (1 - rho) R at several rho
//! in one pass over T and R, each bit for bit the table
//! [`crate::mean_squares`] gives the array built alone.
//!
//! Fieller's search ([`crate::ratio_interval_batched`]) evaluates L at one
//! rho per edge of its set, about fifty times per edge, and each table is
//! two sums over every cell that must be added in one fixed order. One such
//! sum waits on the latency of each addition, so one core has room for
//! several of them at once: here the arrays of both edges are summed side
//! by side, each in its own order, for about the time of one.

use super::crossed::anova_table;
use super::matrix::check_shape;
use super::{MeanSquares, StatsError};

/// The most arrays summed side by side in one pass: two sums of each
/// array wait on additions per cell in the first pass, so two arrays fill
/// four chains of additions, enough to keep a core's adders busy.
const GROUP: usize = 2;

/// The ANOVA table of L(rho) = T - (1 - rho) R at each of `rhos`, for
/// complete `rows` x `cols` arrays `t` and `r` (row-major), each
/// bit for bit `mean_squares(&CrossedMatrix::new(rows, cols, L(rho))?)`,
/// and the same error where that would fail. With each table, whether every
/// row of L(rho) is one value repeated (bit for bit), as an array invariant
/// to the seed is.
///
/// ```
/// use crossaudit_stats::{mean_squares, mean_squares_along, CrossedMatrix};
/// let t = [2.1, 2.0, 2.0, 2.3, 2.1, 1.9];
/// let r = [3.0, 3.2, 2.9, 3.4, 3.1, 2.8];
/// let tables = mean_squares_along(&t, &r, 3, 2, &[0.25, -0.5]);
/// for (rho, got) in [0.25, -0.5].into_iter().zip(tables) {
///     let l = t.iter().zip(&r).map(|(t, r)| t - (1.0 - rho) * r).collect();
///     let (table, constant) = got.unwrap();
///     assert_eq!(table, mean_squares(&CrossedMatrix::new(3, 2, l).unwrap()));
///     assert!(!constant);
/// }
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
    let mut out = Vec::with_capacity(rhos.len());
    for group in rhos.chunks(GROUP) {
        match *group {
            [a] => out.extend(tables::<1>(t, r, rows, cols, [a])),
            [a, b] => out.extend(tables::<2>(t, r, rows, cols, [a, b])),
            _ => {}
        }
    }
    out
}

/// The tables of `P` arrays side by side. Each array's sums are added in
/// the order of [`crate::mean_squares`]: the grand total in row-major
/// order from -0.0, each row's total in column order from -0.0, each
/// column's in row order from 0.0, then the residual squares in row-major
/// order from 0.0. Only the order in which the processor meets the `P`
/// arrays' additions differs, and no sum crosses another.
fn tables<const P: usize>(
    t: &[f64],
    r: &[f64],
    rows: usize,
    cols: usize,
    rhos: [f64; P],
) -> [Result<(MeanSquares, bool), StatsError>; P] {
    let (i_n, j_n) = (rows as f64, cols as f64);
    let shrink = rhos.map(|rho| 1.0 - rho);
    // Each array's values of the current row, then its squared residuals.
    let mut x = [(); P].map(|_| vec![0.0f64; cols]);
    let mut cm = [(); P].map(|_| vec![0.0f64; cols]);
    let mut rm = [(); P].map(|_| Vec::with_capacity(rows));
    let mut total = [-0.0f64; P];
    let mut constant = [true; P];
    for (tr, rr) in t.chunks_exact(cols).zip(r.chunks_exact(cols)) {
        for k in 0..P {
            for ((v, &a), &b) in x[k].iter_mut().zip(tr).zip(rr) {
                *v = a - shrink[k] * b;
            }
            for (c, &v) in cm[k].iter_mut().zip(&x[k]) {
                *c += v;
            }
            constant[k] = constant[k] && x[k].iter().all(|v| v.to_bits() == x[k][0].to_bits());
        }
        let row = add_row(&x, &mut total);
        for k in 0..P {
            rm[k].push(row[k] / j_n);
        }
    }
    let mut mu = [0.0f64; P];
    for k in 0..P {
        cm[k].iter_mut().for_each(|c| *c /= i_n);
        mu[k] = total[k] / (rows * cols) as f64;
    }
    let mut ss_error = [0.0f64; P];
    for (i, (tr, rr)) in t.chunks_exact(cols).zip(r.chunks_exact(cols)).enumerate() {
        for k in 0..P {
            let (ri, m) = (rm[k][i], mu[k]);
            for (((v, &a), &b), &c) in x[k].iter_mut().zip(tr).zip(rr).zip(&cm[k]) {
                *v = (a - shrink[k] * b - ri - c + m).powi(2);
            }
        }
        add_squares(&x, &mut ss_error);
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
        Ok((anova_table(mu[k], &rm[k], &cm[k], ss_error[k]), constant[k]))
    })
}

/// Adds each array's row `x[k]` to its running total, in column order, and
/// gives the row's own sums (from -0.0). Two arrays' four sums are added
/// in one loop, their accumulators in registers, so that the processor
/// works on the four chains at once.
fn add_row<const P: usize>(x: &[Vec<f64>; P], total: &mut [f64; P]) -> [f64; P] {
    let mut row = [-0.0f64; P];
    if let ([a, b], [ta, tb], [ra, rb]) = (x.as_slice(), total.as_mut_slice(), row.as_mut_slice()) {
        let (mut t0, mut t1, mut r0, mut r1) = (*ta, *tb, *ra, *rb);
        for (&u, &v) in a.iter().zip(b) {
            t0 += u;
            r0 += u;
            t1 += v;
            r1 += v;
        }
        (*ta, *tb, *ra, *rb) = (t0, t1, r0, r1);
    } else {
        for k in 0..P {
            let (mut t, mut r) = (total[k], row[k]);
            for &u in &x[k] {
                t += u;
                r += u;
            }
            (total[k], row[k]) = (t, r);
        }
    }
    row
}

/// Adds each array's squared residuals `x[k]` to its sum, in column order;
/// two arrays' sums in one loop, as in [`add_row`].
fn add_squares<const P: usize>(x: &[Vec<f64>; P], ss: &mut [f64; P]) {
    if let ([a, b], [sa, sb]) = (x.as_slice(), ss.as_mut_slice()) {
        let (mut s0, mut s1) = (*sa, *sb);
        for (&u, &v) in a.iter().zip(b) {
            s0 += u;
            s1 += v;
        }
        (*sa, *sb) = (s0, s1);
    } else {
        for k in 0..P {
            ss[k] = x[k].iter().fold(ss[k], |s, &u| s + u);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{mean_squares, CrossedMatrix};

    /// Each array's table equals the one `mean_squares` gives it alone, bit
    /// for bit, whether it is summed alone or beside up to six others, on
    /// data whose sums round at every step (values of mixed magnitude).
    #[test]
    fn side_by_side_tables_are_the_tables_alone() -> Result<(), StatsError> {
        let (rows, cols) = (37usize, 23usize);
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut u = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let r: Vec<f64> = (0..rows * cols).map(|k| 1e3 * u() + (k % 7) as f64 * 1e-3).collect();
        let t: Vec<f64> = r.iter().map(|x| 0.9 * x + u() * 1e-2).collect();
        let rhos = [0.1, -0.37, 1e-9, 0.1 + 1e-16, 2.5, -7.0, 0.333];
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
