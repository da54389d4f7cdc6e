//! Separation of a GLMM's fixed effects, found from the data alone (not
//! from where the optimizer stopped), by linear programming as R's
//! `detectseparation` (Konis 2007) finds it.
//!
//! The likelihood grows without bound along a direction d of the fixed
//! effects when no observation's fit gets worse as beta moves along d:
//! x_i'd >= 0 where every trial succeeded (binomial k = m), x_i'd <= 0
//! where none did (k = 0; Poisson: a zero count), and x_i'd = 0 where the
//! outcome is mixed (0 < k < m; a positive count). The random effects can
//! stay at zero, so such a d makes the Laplace deviance of every theta fall
//! towards its infimum too. The cone of these directions is {0} exactly
//! when every estimate is finite (X has full rank, so x_i'd = 0 for every
//! i only at d = 0); coefficient j is infinite when some direction of the
//! cone has d_j != 0. For each j the program
//!
//! ```text
//! maximize  +-d_j   subject to  d in the cone,  -1 <= d <= 1
//! ```
//!
//! has optimum 0 or a positive value; it is solved through its dual (p
//! equality rows, one column per observation), which has a feasible basis
//! at once, by the simplex method with Bland's rule (no cycling), the
//! design's columns scaled to unit root mean square first.

use super::Family;

/// The optimum above which a direction counts: the scaled directions'
/// entries are at most 1, so a real one reaches order 1.
const TOLERANCE: f64 = 1e-7;

/// The fixed effects (indices into the design's columns) whose maximum
/// likelihood estimates are infinite, with the sign of the direction they
/// run in; `None` when the programs did not finish (never seen; the
/// caller then says nothing rather than something wrong).
pub(super) fn infinite(x: &[f64], p: usize, k: &[f64], m: &[f64], family: Family) -> Option<Vec<(usize, f64)>> {
    let n = k.len();
    if n == 0 || p == 0 {
        return Some(Vec::new());
    }
    let rms: Vec<f64> = (0..p)
        .map(|c| {
            let r = ((0..n).map(|i| x[i * p + c].powi(2)).sum::<f64>() / n as f64).sqrt();
            if r.is_finite() && r > 0.0 {
                r
            } else {
                1.0
            }
        })
        .collect();
    // The dual's columns: g = -s x_i (s = +1 where x_i'd >= 0 is asked,
    // -1 where x_i'd <= 0), both x_i and -x_i where x_i'd = 0 is asked.
    let mut columns: Vec<Vec<f64>> = Vec::with_capacity(n);
    for i in 0..n {
        let xi: Vec<f64> = (0..p).map(|c| x[i * p + c] / rms[c]).collect();
        let all = match family {
            Family::Binomial => k[i] >= m[i],
            Family::Poisson => false,
        };
        let none = k[i] <= 0.0;
        if all && !none {
            columns.push(xi.iter().map(|v| -v).collect());
        } else if none && !all {
            columns.push(xi);
        } else if !(all && none) {
            columns.push(xi.iter().map(|v| -v).collect());
            columns.push(xi);
        }
    }
    columns.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    columns.dedup();
    let mut out = Vec::new();
    for j in 0..p {
        for sign in [1.0, -1.0] {
            let mut c = vec![0.0; p];
            c[j] = sign;
            if simplex(&columns, &c)? > TOLERANCE {
                out.push((j, sign));
                break;
            }
        }
    }
    Some(out)
}

/// The minimum of 1'(w+ + w-) subject to sum_i y_i g_i + w+ - w- = c,
/// y, w+, w- >= 0 (the dual of max c'd over the cone and the box), by the
/// revised simplex method with a dense basis inverse and Bland's rule.
fn simplex(columns: &[Vec<f64>], c: &[f64]) -> Option<f64> {
    let p = c.len();
    let g = columns.len();
    // Columns 0..g are the g_i (cost 0); g + r is e_r and g + p + r is
    // -e_r (cost 1).
    let column = |j: usize| -> Vec<f64> {
        if j < g {
            columns[j].clone()
        } else {
            let r = (j - g) % p;
            let mut e = vec![0.0; p];
            e[r] = if j < g + p { 1.0 } else { -1.0 };
            e
        }
    };
    let cost = |j: usize| if j < g { 0.0 } else { 1.0 };
    let total = g + 2 * p;
    let mut basis: Vec<usize> = (0..p).map(|r| if c[r] >= 0.0 { g + r } else { g + p + r }).collect();
    let mut inverse: Vec<Vec<f64>> = (0..p)
        .map(|r| {
            (0..p)
                .map(|s| {
                    if r == s {
                        if c[r] >= 0.0 {
                            1.0
                        } else {
                            -1.0
                        }
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    let mut values: Vec<f64> = c.iter().map(|v| v.abs()).collect();
    let limit = 50 * (total + p);
    for _ in 0..limit {
        // Prices pi = c_B' B^-1.
        let pi: Vec<f64> = (0..p).map(|s| (0..p).map(|r| cost(basis[r]) * inverse[r][s]).sum()).collect();
        // Bland: the first column with a negative reduced cost enters.
        let entering = (0..total).find(|&j| {
            !basis.contains(&j) && {
                let a = column(j);
                cost(j) - a.iter().zip(&pi).map(|(x, y)| x * y).sum::<f64>() < -1e-12
            }
        });
        let Some(entering) = entering else {
            return Some((0..p).map(|r| cost(basis[r]) * values[r]).sum());
        };
        let a = column(entering);
        let direction: Vec<f64> = (0..p).map(|r| (0..p).map(|s| inverse[r][s] * a[s]).sum()).collect();
        // Ratio test, ties to the smallest basic index (Bland).
        let mut leave: Option<(usize, f64)> = None;
        for r in 0..p {
            if direction[r] > 1e-12 {
                let ratio = values[r] / direction[r];
                match leave {
                    Some((l, best)) if ratio > best + 1e-15 || (ratio >= best - 1e-15 && basis[r] > basis[l]) => {}
                    _ => leave = Some((r, ratio)),
                }
            }
        }
        // Unbounded below cannot happen (every cost is non-negative).
        let (r, step) = leave?;
        for s in 0..p {
            values[s] -= step * direction[s];
        }
        values[r] = step;
        pivot(&mut inverse, &direction, r);
        basis[r] = entering;
    }
    None
}

/// Updates the basis inverse for the column whose direction (its image
/// under the old inverse) is `direction` entering at row `r`.
fn pivot(inverse: &mut [Vec<f64>], direction: &[f64], r: usize) {
    let p = inverse.len();
    let row: Vec<f64> = inverse[r].iter().map(|v| v / direction[r]).collect();
    for s in 0..p {
        if s != r {
            let f = direction[s];
            for t in 0..p {
                inverse[s][t] -= f * row[t];
            }
        }
    }
    inverse[r] = row;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed forms: x > 0 exactly where y = 1 separates x, and the
    /// intercept with it (d = (0.3, 1) keeps every fit from getting worse:
    /// the split between -0.5 and 0.5 may move, so the intercept is not
    /// identified either); overlapping outcomes separate nothing; a level
    /// with no success sends its indicator to minus infinity
    /// (quasi-complete separation) and leaves the intercept alone.
    #[test]
    fn separation_is_found_where_the_data_have_it_and_only_there() {
        let xs = [-2.0, -1.0, -0.5, 0.5, 1.0, 2.0];
        let design: Vec<f64> = xs.iter().flat_map(|&v| [1.0, v]).collect();
        let ones = vec![1.0; 6];
        let separated = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
        let found = infinite(&design, 2, &separated, &ones, Family::Binomial).unwrap();
        assert_eq!(found, vec![(0, 1.0), (1, 1.0)]);
        let mixed = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0];
        assert!(infinite(&design, 2, &mixed, &ones, Family::Binomial).unwrap().is_empty());
        // Arm indicator b: level b has no success in 3 x 4 trials.
        let design: Vec<f64> = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0].iter().flat_map(|&b| [1.0, b]).collect();
        let k = [1.0, 2.0, 0.0, 0.0, 0.0, 0.0];
        let m = [4.0; 6];
        let found = infinite(&design, 2, &k, &m, Family::Binomial).unwrap();
        assert_eq!(found, vec![(1, -1.0)]);
        // The same for zero counts of a Poisson level.
        let found = infinite(&design, 2, &k, &m, Family::Poisson).unwrap();
        assert_eq!(found, vec![(1, -1.0)]);
    }
}
