//! The random-effect structure of a model with random slopes: Z as sparse
//! rows, the block of Lambda each term repeats over its levels, and the
//! parameterization of theta (lme4's, and the scaled one the searches
//! use). Shared by the linear models (`system`) and the generalized ones
//! (`crate::mixed::glmm`).

use super::Term;

/// Z and the layout of Lambda.
pub(crate) struct Structure {
    /// Random effects over every level of every term.
    pub q: usize,
    /// Per term: its columns k and the position of its first effect in u
    /// (the block of level l starts at offset + l k).
    pub blocks: Vec<(usize, usize)>,
    /// Per theta parameter, the root mean square of the column of Z its
    /// row of T multiplies (1 for an intercept).
    scales: Vec<f64>,
    /// Per observation, its nonzero entries of Z as (column, value).
    pub z_rows: Vec<Vec<(usize, f64)>>,
}

/// The k x k lower triangular block, row-major, from its entries column
/// by column (lme4's theta order).
pub(crate) fn lower_triangle(theta: &[f64], k: usize) -> Vec<f64> {
    let mut t = vec![0.0; k * k];
    let mut at = 0;
    for j in 0..k {
        for i in j..k {
            t[i * k + j] = theta[at];
            at += 1;
        }
    }
    t
}

impl Structure {
    /// The structure of `terms` over `n` observations.
    pub fn new(terms: &[Term], n: usize) -> Structure {
        let mut blocks = Vec::new();
        let mut q = 0;
        let mut scales = Vec::new();
        for t in terms {
            let k = t.columns.len();
            blocks.push((k, q));
            q += t.levels * k;
            let rms: Vec<f64> = t
                .columns
                .iter()
                .map(|c| {
                    let r = (c.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
                    if r.is_finite() && r > 0.0 {
                        r
                    } else {
                        1.0
                    }
                })
                .collect();
            for j in 0..k {
                scales.extend(rms[j..].iter().copied());
            }
        }
        let z_rows: Vec<Vec<(usize, f64)>> = (0..n)
            .map(|i| {
                terms
                    .iter()
                    .zip(&blocks)
                    .flat_map(|(t, &(k, offset))| {
                        let start = offset + t.codes[i] * k;
                        t.columns.iter().enumerate().map(move |(j, c)| (start + j, c[i]))
                    })
                    .collect()
            })
            .collect();
        Structure { q, blocks, scales, z_rows }
    }

    /// Per theta parameter, its scale: theta_k times its scale is the
    /// entry of T for the column of Z divided by its root mean square, a
    /// parameterization in which every entry is of the order of the
    /// standard deviations' ratio whatever the columns' units (a slope in
    /// a temperature of 200 has an entry 200 times smaller than its
    /// intercept's in lme4's theta).
    pub fn scales(&self) -> &[f64] {
        &self.scales
    }

    /// Number of theta parameters.
    pub fn parameters(&self) -> usize {
        self.blocks.iter().map(|(k, _)| k * (k + 1) / 2).sum()
    }

    /// The positions in theta of the diagonal entries (lme4's lower bound
    /// 0, the ones `isSingular` reads).
    pub fn diagonal(&self) -> Vec<usize> {
        let mut out = Vec::new();
        let mut at = 0;
        for &(k, _) in &self.blocks {
            for j in 0..k {
                out.push(at);
                at += k - j;
            }
        }
        out
    }

    /// `theta` with each column of each T whose diagonal entry is negative
    /// negated: the same T T', in lme4's parameterization.
    pub fn normalized(&self, theta: &[f64]) -> Vec<f64> {
        let mut out = theta.to_vec();
        let mut at = 0;
        for &(k, _) in &self.blocks {
            for j in 0..k {
                let column = at..at + (k - j);
                if out[at] < 0.0 {
                    out[column].iter_mut().for_each(|v| *v = -*v);
                }
                at += k - j;
            }
        }
        out
    }

    /// lme4's start: every diagonal entry 1, the rest 0.
    pub fn start(&self) -> Vec<f64> {
        let mut theta = vec![0.0; self.parameters()];
        for j in self.diagonal() {
            theta[j] = 1.0;
        }
        theta
    }

    /// Each term's block T, row-major.
    pub fn lambda(&self, theta: &[f64]) -> Vec<Vec<f64>> {
        let mut at = 0;
        self.blocks
            .iter()
            .map(|&(k, _)| {
                let t = lower_triangle(&theta[at..at + k * (k + 1) / 2], k);
                at += k * (k + 1) / 2;
                t
            })
            .collect()
    }

    /// Levels of term `b`.
    fn levels(&self, b: usize) -> usize {
        let (k, offset) = self.blocks[b];
        let end = self.blocks.get(b + 1).map_or(self.q, |&(_, o)| o);
        (end - offset) / k
    }

    /// Row i of Z Lambda as (column, value): each term's entries of the
    /// row times its T.
    pub fn z_lambda_row(&self, i: usize, lambda: &[Vec<f64>], out: &mut Vec<(usize, f64)>) {
        out.clear();
        let row = &self.z_rows[i];
        let mut at = 0;
        for (b, &(k, _)) in self.blocks.iter().enumerate() {
            let t = &lambda[b];
            let entries = &row[at..at + k];
            let start = entries[0].0;
            for jj in 0..k {
                out.push((start + jj, (0..k).map(|j| entries[j].1 * t[j * k + jj]).sum()));
            }
            at += k;
        }
    }

    /// Lambda u: each level's block of u times its T.
    pub fn lambda_times(&self, lambda: &[Vec<f64>], u: &[f64]) -> Vec<f64> {
        let mut b = vec![0.0; self.q];
        for (t_index, &(k, offset)) in self.blocks.iter().enumerate() {
            let t = &lambda[t_index];
            for level in 0..self.levels(t_index) {
                let c0 = offset + level * k;
                for i in 0..k {
                    b[c0 + i] = (0..k).map(|j| t[i * k + j] * u[c0 + j]).sum();
                }
            }
        }
        b
    }
}
