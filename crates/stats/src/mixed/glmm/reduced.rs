//! The PIRLS system A = Lambda'Z'W Z Lambda + I of one weighting, with
//! the levels of the first term eliminated where that term is a random
//! intercept (its block of A is then diagonal: each observation has one
//! level), as the linear models' system eliminates its largest factor.
//! lme4's order puts the term with the most levels first, so an
//! observation-level effect (grouseticks' INDEX) or the recording x seed
//! interaction of the divergence model leaves a dense system over the
//! other terms' levels only.
//!
//! With A = [D B; B' C], D diagonal: log|A| = sum log D_s + log|S| and
//! S = C - B'D^-1 B (Cholesky), and A x = r is solved through S. Bordered
//! with the fixed effects (X'W Z Lambda, X'WX), the same elimination gives
//! R_X as the last block of S's Cholesky factor.

use faer::{Mat, Side};

/// A factored system.
pub(super) struct Reduced {
    /// Levels eliminated (0 when the first term is not an intercept).
    n1: usize,
    /// The diagonal of the eliminated block.
    d: Vec<f64>,
    /// Per eliminated level, its row of B: (dense column, value).
    b: Vec<Vec<(usize, f64)>>,
    /// Cholesky factor of S, lower.
    l: Mat<f64>,
    /// Dense columns: the other random effects (then the fixed effects).
    m: usize,
}

impl Reduced {
    /// Factors A (and, with `x` = (design, p), the system bordered with
    /// the fixed effects) for the rows `zl` of Z Lambda with weights `w`;
    /// `n1` levels of the first term are eliminated. `None` when S is not
    /// positive definite.
    pub fn new(
        zl: &[Vec<(usize, f64)>],
        w: &[f64],
        q: usize,
        n1: usize,
        x: Option<(&[f64], usize)>,
    ) -> Option<Reduced> {
        let p = x.map_or(0, |(_, p)| p);
        let m = q - n1 + p;
        let mut d = vec![1.0; n1];
        let mut b: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n1];
        let mut s = Mat::<f64>::zeros(m, m);
        for j in 0..q - n1 {
            s[(j, j)] = 1.0;
        }
        let mut dense: Vec<(usize, f64)> = Vec::new();
        for (i, row) in zl.iter().enumerate() {
            let wi = w[i];
            dense.clear();
            let mut first: Option<(usize, f64)> = None;
            for &(j, v) in row {
                if j < n1 {
                    first = Some((j, v));
                } else {
                    dense.push((j - n1, v));
                }
            }
            if let Some((xs, p)) = x {
                dense.extend((0..p).map(|c| (q - n1 + c, xs[i * p + c])));
            }
            if let Some((level, v)) = first {
                d[level] += wi * v * v;
                b[level].extend(dense.iter().map(|&(j, u)| (j, wi * v * u)));
            }
            for &(ja, va) in &dense {
                for &(jb, vb) in &dense {
                    if jb <= ja {
                        s[(ja, jb)] += wi * va * vb;
                    }
                }
            }
        }
        for (level, row) in b.iter_mut().enumerate() {
            row.sort_by_key(|e| e.0);
            let mut merged: Vec<(usize, f64)> = Vec::with_capacity(row.len());
            for &(j, v) in row.iter() {
                match merged.last_mut() {
                    Some(last) if last.0 == j => last.1 += v,
                    _ => merged.push((j, v)),
                }
            }
            let inverse = 1.0 / d[level];
            for &(ja, va) in &merged {
                for &(jb, vb) in &merged {
                    if jb <= ja {
                        s[(ja, jb)] -= va * vb * inverse;
                    }
                }
            }
            *row = merged;
        }
        let l = s.llt(Side::Lower).ok()?.L().to_owned();
        Some(Reduced { n1, d, b, l, m })
    }

    /// log|A| (the random effects' block only, when bordered).
    pub fn log_det(&self, q: usize) -> f64 {
        let dense = q - self.n1;
        self.d.iter().map(|v| v.ln()).sum::<f64>() + (0..dense).map(|j| 2.0 * self.l[(j, j)].ln()).sum::<f64>()
    }

    /// Solves A x = r (unbordered).
    pub fn solve(&self, r: &[f64]) -> Vec<f64> {
        let n1 = self.n1;
        let mut rhs = Mat::<f64>::from_fn(self.m, 1, |j, _| r[n1 + j]);
        for (level, row) in self.b.iter().enumerate() {
            let scaled = r[level] / self.d[level];
            for &(j, v) in row {
                rhs[(j, 0)] -= v * scaled;
            }
        }
        let llt_solve = |mut v: Mat<f64>| {
            use faer::linalg::triangular_solve::{solve_lower_triangular_in_place, solve_upper_triangular_in_place};
            solve_lower_triangular_in_place(self.l.as_ref(), v.as_mut(), faer::Par::Seq);
            solve_upper_triangular_in_place(self.l.transpose(), v.as_mut(), faer::Par::Seq);
            v
        };
        let y = llt_solve(rhs);
        let mut out = vec![0.0; n1 + self.m];
        for (level, row) in self.b.iter().enumerate() {
            let dot: f64 = row.iter().map(|&(j, v)| v * y[(j, 0)]).sum();
            out[level] = (r[level] - dot) / self.d[level];
        }
        for j in 0..self.m {
            out[n1 + j] = y[(j, 0)];
        }
        out
    }

    /// (R_X'R_X)^-1 of a bordered system with `p` fixed effects.
    pub fn rx_vcov(&self, p: usize) -> Mat<f64> {
        let lx = self.l.submatrix(self.m - p, self.m - p, p, p);
        let mut w = Mat::<f64>::identity(p, p);
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(lx, w.as_mut(), faer::Par::Seq);
        w.transpose() * &w
    }
}
