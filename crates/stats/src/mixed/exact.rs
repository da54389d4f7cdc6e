//! A response the model's columns reproduce exactly, found before the
//! fit. Where y lies in the span of the fixed effects and every random
//! factor's indicators, the REML (and ML) criterion falls without bound as
//! the residual variance goes to zero: the optimizer walks the variance
//! ratios out towards infinity until it gives up, which took 17 s on a
//! 50 x 20 additive table, and longer at every replication of a coverage
//! setting with no residual share, before [`MixedError::ZeroResidual`]
//! was said. Here the least-squares residual of y on those columns is
//! approached by backfitting (the fixed part by its normal equations, then
//! each factor's level means, or a random-slope term's columns fitted
//! within each of its levels, in turn), which on a balanced crossed table
//! is exact after one sweep, and the same refusal is given at once when
//! it is zero to rounding (a random-slope model on such data searched for
//! 6 s, then said its system was not positive definite at theta = 1e7).
//! Any other response goes on to the fit.

use faer::linalg::solvers::{Llt, Solve};
use faer::{Mat, Side};

use super::{MixedData, MixedError};

/// Sweeps at most: an unbalanced table converges geometrically, and one
/// whose residual is still above the bound after these goes to the fit,
/// which says what it finds.
const SWEEPS: usize = 30;

/// Fixed-effect columns at most for the check (their normal equations are
/// solved at every sweep); a model with more goes to the fit unchecked.
const MAX_COLUMNS: usize = 64;

/// One random term as the check sees it: each observation's level, and
/// the columns that vary over its levels (none: its intercept alone).
pub(super) struct Block<'a> {
    pub codes: &'a [usize],
    pub levels: usize,
    pub columns: Vec<&'a [f64]>,
}

/// [`MixedError::ZeroResidual`] where the fixed effects and the random
/// factors' levels reproduce `data`'s response to within 1e-20 of its
/// variance (the bound the fit applies to its residual variance).
pub(super) fn refuse_exact_fit(data: &MixedData) -> Result<(), MixedError> {
    let blocks = data.factors.iter().map(|f| Block { codes: &f.codes, levels: f.levels, columns: Vec::new() });
    refuse_exact(data, &blocks.collect::<Vec<_>>())
}

/// The check on the response and fixed effects of `data` and the random
/// terms `blocks` (a random-slope model's, from `slopes`).
pub(super) fn refuse_exact(data: &MixedData, blocks: &[Block]) -> Result<(), MixedError> {
    let (n, p) = (data.y.len(), data.p());
    if p > MAX_COLUMNS || n < 2 {
        return Ok(());
    }
    let mean = data.y.iter().sum::<f64>() / n as f64;
    let mut r: Vec<f64> = data.y.iter().map(|v| v - mean).collect();
    let ss = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
    let total = ss(&r);
    let bound = 1e-20 * total;
    let x = transpose(&data.design(), n, p);
    let fixed: Vec<&[f64]> = x.chunks_exact(n).collect();
    // Each fit's normal equations factored once: they do not change
    // from sweep to sweep, only the residual does.
    let fixed = Fit::new(&fixed, None);
    let slopes: Vec<Option<Fit>> = blocks
        .iter()
        .map(|b| (!b.columns.is_empty()).then(|| Fit::new(&b.columns, Some((b.codes, b.levels)))))
        .collect();
    let mut last = total;
    for _ in 0..SWEEPS {
        fixed.take_out(&mut r);
        for (b, slope) in blocks.iter().zip(&slopes) {
            match slope {
                Some(fit) => fit.take_out(&mut r),
                None => level_means_out(&mut r, b),
            }
        }
        let now = ss(&r);
        if now <= bound {
            let var = |s: f64| s / (n as f64 - 1.0);
            return Err(MixedError::ZeroResidual { residual: var(now), total: var(total) });
        }
        // Not converging to zero: a residual to fit.
        if now > 0.5 * last {
            return Ok(());
        }
        last = now;
    }
    Ok(())
}

/// `x` (n x p, row-major) as p columns of n, one after another.
fn transpose(x: &[f64], n: usize, p: usize) -> Vec<f64> {
    (0..p).flat_map(|a| (0..n).map(move |i| x[i * p + a])).collect()
}

/// Each level's mean of `r` taken out of it.
fn level_means_out(r: &mut [f64], b: &Block) {
    let mut sums = vec![(0.0, 0usize); b.levels];
    for (v, &c) in r.iter().zip(b.codes) {
        sums[c].0 += v;
        sums[c].1 += 1;
    }
    for (v, &c) in r.iter_mut().zip(b.codes) {
        *v -= sums[c].0 / sums[c].1 as f64;
    }
}

/// A least-squares fit on `columns`, over all observations or within
/// each level of a factor, with each level's normal equations factored
/// (`None` for a level whose equations are singular: it is left as it is,
/// so the check only misses).
struct Fit<'a> {
    columns: &'a [&'a [f64]],
    codes: &'a [usize],
    factors: Vec<Option<Llt<f64>>>,
}

impl<'a> Fit<'a> {
    fn new(columns: &'a [&'a [f64]], by: Option<(&'a [usize], usize)>) -> Fit<'a> {
        let d = columns.len();
        let (codes, levels) = by.unwrap_or((&[], 1));
        let mut zz = vec![0.0; levels * d * d];
        for i in 0..columns.first().map_or(0, |c| c.len()) {
            let l = if codes.is_empty() { 0 } else { codes[i] };
            for a in 0..d {
                for c in 0..d {
                    zz[(l * d + a) * d + c] += columns[a][i] * columns[c][i];
                }
            }
        }
        let factors = (0..levels)
            .map(|l| Mat::<f64>::from_fn(d, d, |a, c| zz[(l * d + a) * d + c]).llt(Side::Lower).ok())
            .collect();
        Fit { columns, codes, factors }
    }

    fn level(&self, i: usize) -> usize {
        if self.codes.is_empty() {
            0
        } else {
            self.codes[i]
        }
    }

    /// The fit of `r` taken out of it.
    fn take_out(&self, r: &mut [f64]) {
        let d = self.columns.len();
        let mut zr = vec![0.0; self.factors.len() * d];
        for (i, v) in r.iter().enumerate() {
            let l = self.level(i);
            for a in 0..d {
                zr[l * d + a] += self.columns[a][i] * v;
            }
        }
        let coefficients: Vec<Option<Mat<f64>>> = (self.factors.iter().enumerate())
            .map(|(l, f)| f.as_ref().map(|llt| llt.solve(&Mat::<f64>::from_fn(d, 1, |a, _| zr[l * d + a]))))
            .collect();
        for (i, v) in r.iter_mut().enumerate() {
            if let Some(beta) = &coefficients[self.level(i)] {
                *v -= (0..d).map(|a| self.columns[a][i] * beta[(a, 0)]).sum::<f64>();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y = a_i + b_j exactly on a 50 x 20 table (and on an unbalanced
    /// one, a cell in three left out): refused at once, as the fit
    /// refuses it after its search; with noise added, not refused.
    #[test]
    fn an_additive_table_is_refused_before_the_fit() -> Result<(), MixedError> {
        let a: Vec<f64> = (0..50).map(|i| ((i * 37 % 11) as f64 - 5.0) * 0.3).collect();
        let b: Vec<f64> = (0..20).map(|j| ((j * 13 % 7) as f64 - 3.0) * 0.7).collect();
        let cells = |keep: &dyn Fn(usize, usize) -> bool, noise: f64| {
            let (mut y, mut rows, mut cols) = (Vec::new(), Vec::new(), Vec::new());
            for (i, ai) in a.iter().enumerate() {
                for (j, bj) in b.iter().enumerate().filter(|&(j, _)| keep(i, j)) {
                    y.push(ai + bj + noise * (((i * 31 + j * 17) % 23) as f64 - 11.0));
                    rows.push(i);
                    cols.push(j);
                }
            }
            MixedData::new(y, vec![("g".into(), rows), ("h".into(), cols)])
        };
        for keep in
            [&|_, _| true, &|i: usize, j: usize| !(i + 2 * j).is_multiple_of(3)] as [&dyn Fn(usize, usize) -> bool; 2]
        {
            let exact = cells(keep, 0.0)?;
            assert!(matches!(refuse_exact_fit(&exact), Err(MixedError::ZeroResidual { .. })));
            assert!(matches!(
                super::super::fit(&exact, super::super::Criterion::Reml),
                Err(MixedError::ZeroResidual { .. })
            ));
            assert!(refuse_exact_fit(&cells(keep, 0.01)?).is_ok());
        }
        Ok(())
    }
}
