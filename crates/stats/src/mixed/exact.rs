//! A response the model's columns reproduce exactly, found before the
//! fit. Where y lies in the span of the fixed effects and every random
//! factor's indicators, the REML (and ML) criterion falls without bound as
//! the residual variance goes to zero: the optimizer walks the variance
//! ratios out towards infinity until it gives up, which took 17 s on a
//! 50 x 20 additive table, and longer at every replication of a coverage
//! setting with no residual share, before [`MixedError::ZeroResidual`]
//! was said. Here the least-squares residual of y on those columns is
//! approached by backfitting (the fixed part by its normal equations, then
//! each factor's level means, in turn), which on a balanced crossed table
//! is exact after one sweep, and the same refusal is given at once when
//! it is zero to rounding. Any other response goes on to the fit.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

use super::{MixedData, MixedError};

/// Sweeps at most: an unbalanced table converges geometrically, and one
/// whose residual is still above the bound after these goes to the fit,
/// which says what it finds.
const SWEEPS: usize = 30;

/// Fixed-effect columns at most for the check (their normal equations are
/// solved at every sweep); a model with more goes to the fit unchecked.
const MAX_COLUMNS: usize = 64;

/// [`MixedError::ZeroResidual`] where the fixed effects and the random
/// factors' levels reproduce `data`'s response to within 1e-20 of its
/// variance (the bound the fit applies to its residual variance).
pub(super) fn refuse_exact_fit(data: &MixedData) -> Result<(), MixedError> {
    let (n, p) = (data.y.len(), data.p());
    if p > MAX_COLUMNS || n < 2 {
        return Ok(());
    }
    let mean = data.y.iter().sum::<f64>() / n as f64;
    let mut r: Vec<f64> = data.y.iter().map(|v| v - mean).collect();
    let ss = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
    let total = ss(&r);
    let bound = 1e-20 * total;
    let x = data.design();
    let xtx = Mat::<f64>::from_fn(p, p, |a, b| (0..n).map(|i| x[i * p + a] * x[i * p + b]).sum());
    let Ok(llt) = xtx.llt(Side::Lower) else { return Ok(()) };
    let mut sums = Vec::new();
    let mut last = total;
    for _ in 0..SWEEPS {
        let xtr = Mat::<f64>::from_fn(p, 1, |a, _| (0..n).map(|i| x[i * p + a] * r[i]).sum());
        let beta = llt.solve(&xtr);
        for (i, v) in r.iter_mut().enumerate() {
            *v -= (0..p).map(|a| x[i * p + a] * beta[(a, 0)]).sum::<f64>();
        }
        for f in &data.factors {
            sums.clear();
            sums.resize(f.levels, (0.0, 0usize));
            for (v, &c) in r.iter().zip(&f.codes) {
                sums[c].0 += v;
                sums[c].1 += 1;
            }
            for (v, &c) in r.iter_mut().zip(&f.codes) {
                *v -= sums[c].0 / sums[c].1 as f64;
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
