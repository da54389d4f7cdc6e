//! The penalized system of a model with random slopes or of a GLMM,
//! Lambda'Z'W Z Lambda + I (optionally bordered with the fixed effects'
//! columns), held and factored as lme4 holds it: sparse, with a
//! fill-reducing ordering found once and a supernodal (or simplicial)
//! Cholesky factor recomputed at each theta.
//!
//! The pattern of the system is that of Z'Z: every observation joins the
//! columns of its levels, and Lambda, block diagonal with one block per
//! level, does not add to it (an observation's row of Z Lambda has its
//! nonzeros where its row of Z has them). The pattern, its approximate
//! minimum degree ordering (faer's `amd`, of the random effects' block)
//! and the symbolic factor are computed once per fit; each evaluation only
//! adds up the values and refactors. With the fixed effects bordering the
//! system, the ordering keeps them last, so that the factor is
//! [L 0; R_ZX' R_X'] as lme4 writes it: log|L|^2 is the sum over the
//! first q pivots, log|R_X|^2 over the last p, and (R_X'R_X)^-1 is the
//! fixed effects' block of the system's inverse.
//!
//! Memory and time are linear in the factor's nonzeros: a random slope
//! over 10,000 groups is 20,000 random effects in 2 x 2 blocks, and its
//! factor holds about 3 nonzeros per effect besides the fixed effects'
//! rows, where a dense factor would hold 200 million.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, supernodal, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Mat, Par, Side};

use super::MixedError;

/// The most nonzeros the Cholesky factor may hold: 200 million are 1.6 GB
/// of values (and as many again while a factorization runs).
pub const MAX_FACTOR_NONZEROS: usize = 200_000_000;

/// The pattern of one system and its symbolic factor.
pub(crate) struct Sparse {
    /// Random effects and fixed-effect columns.
    q: usize,
    p: usize,
    /// The lower triangle, column-compressed, in the original order; rows
    /// sorted within each column (so the diagonal comes first and the
    /// fixed effects' rows last).
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Per observation, where in the values each pair (a >= b) of its
    /// random-effect entries adds, pairs in the order
    /// [`Sparse::factor`] walks them.
    pair_start: Vec<usize>,
    pair_pos: Vec<usize>,
    /// The fill-reducing ordering: position i of the factor is column
    /// `forward[i]` of the system (the fixed effects last, unmoved).
    forward: Vec<usize>,
    /// The pattern in that order, and where each value goes.
    permuted: Permuted,
    symbolic: SymbolicCholesky<usize>,
}

/// A system's pattern in the factor's order: one triangle, column
/// compressed, and the position there of each value of the original
/// lower triangle.
struct Permuted {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    side: Side,
    map: Vec<usize>,
}

/// The lower triangle (`col_ptr`, `row_idx`) renumbered by `inverse`
/// (original column -> position), as the lower triangle or (`upper`) the
/// upper one, rows sorted.
fn permute(col_ptr: &[usize], row_idx: &[usize], inverse: &[usize], upper: bool) -> Permuted {
    let n = col_ptr.len() - 1;
    let mut entries: Vec<(usize, usize, usize)> = Vec::with_capacity(row_idx.len());
    for c in 0..n {
        for (k, &r) in row_idx.iter().enumerate().take(col_ptr[c + 1]).skip(col_ptr[c]) {
            let (a, b) = (inverse[r], inverse[c]);
            let (row, col) = if upper { (a.min(b), a.max(b)) } else { (a.max(b), a.min(b)) };
            entries.push((col, row, k));
        }
    }
    entries.sort_unstable();
    let mut out_ptr = vec![0usize; n + 1];
    let mut out_idx = Vec::with_capacity(entries.len());
    let mut map = vec![0usize; entries.len()];
    for (at, &(col, row, k)) in entries.iter().enumerate() {
        out_ptr[col + 1] += 1;
        out_idx.push(row);
        map[k] = at;
    }
    for c in 0..n {
        out_ptr[c + 1] += out_ptr[c];
    }
    Permuted { col_ptr: out_ptr, row_idx: out_idx, side: if upper { Side::Upper } else { Side::Lower }, map }
}

/// One numeric factor of a [`Sparse`] system.
pub(crate) struct Factor<'a> {
    sparse: &'a Sparse,
    values: Vec<f64>,
    /// The factor's diagonal, in the factor's (permuted) order: the random
    /// effects' pivots first, the fixed effects' last.
    diagonal: Vec<f64>,
}

impl Sparse {
    /// The pattern of the system for the rows of Z `z_rows` (each row's
    /// columns increasing), `q` random effects and `p` fixed-effect
    /// columns bordering it (0 for none).
    pub fn new(z_rows: &[Vec<(usize, f64)>], q: usize, p: usize) -> Result<Sparse, MixedError> {
        let too_large = |what: String| MixedError::TooLarge(what);
        // Rows of each random-effect column's lower triangle.
        let mut rows: Vec<Vec<usize>> = (0..q).map(|b| vec![b]).collect();
        for row in z_rows {
            for (r, &(a, _)) in row.iter().enumerate() {
                for &(b, _) in &row[..r] {
                    rows[b].push(a);
                }
            }
        }
        let mut col_ptr = Vec::with_capacity(q + p + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for column in rows.iter_mut() {
            column.sort_unstable();
            column.dedup();
            row_idx.extend_from_slice(column);
            row_idx.extend(q..q + p);
            col_ptr.push(row_idx.len());
        }
        drop(rows);
        for d in 0..p {
            row_idx.extend(q + d..q + p);
            col_ptr.push(row_idx.len());
        }
        let n = q + p;
        let position = |a: usize, b: usize| -> usize {
            let column = &row_idx[col_ptr[b]..col_ptr[b + 1]];
            col_ptr[b] + column.binary_search(&a).unwrap_or_else(|_| unreachable!("the pattern holds every pair"))
        };
        let mut pair_start = Vec::with_capacity(z_rows.len() + 1);
        let mut pair_pos = Vec::new();
        pair_start.push(0);
        for row in z_rows {
            for (r, &(a, _)) in row.iter().enumerate() {
                for &(b, _) in &row[..=r] {
                    pair_pos.push(position(a, b));
                }
            }
            pair_start.push(pair_pos.len());
        }
        let (forward, inverse) = ordering(&col_ptr, &row_idx, q, p)?;
        // The system is stored already permuted (so that no factorization
        // permutes it again): its lower triangle, or its upper one where
        // the factor is simplicial (faer's simplicial factor reads the
        // upper triangle, its supernodal one the lower).
        let symbolic_of = |upper: bool| -> Result<(Permuted, SymbolicCholesky<usize>), MixedError> {
            let permuted = permute(&col_ptr, &row_idx, &inverse, upper);
            let pattern = SymbolicSparseColMatRef::new_checked(n, n, &permuted.col_ptr, None, &permuted.row_idx);
            let side = if upper { Side::Upper } else { Side::Lower };
            let symbolic = factorize_symbolic_cholesky(
                pattern,
                side,
                SymmetricOrdering::Identity,
                CholeskySymbolicParams::default(),
            )
            .map_err(|e| too_large(format!("the symbolic factor of the {n} x {n} system failed: {e:?}")))?;
            Ok((permuted, symbolic))
        };
        let (mut permuted, mut symbolic) = symbolic_of(false)?;
        if matches!(symbolic.raw(), SymbolicCholeskyRaw::Simplicial(_)) {
            (permuted, symbolic) = symbolic_of(true)?;
        }
        if symbolic.len_val() > MAX_FACTOR_NONZEROS {
            return Err(too_large(format!(
                "the Cholesky factor of the {n} x {n} penalized system would hold {} nonzeros, over the limit of {MAX_FACTOR_NONZEROS}",
                symbolic.len_val()
            )));
        }
        Ok(Sparse { q, p, col_ptr, row_idx, pair_start, pair_pos, forward, permuted, symbolic })
    }

    /// Adds up and factors the system for the rows of Z Lambda that `row`
    /// writes (observation i into its second argument; the same columns
    /// as the rows of Z the pattern was built from), the weights `w`
    /// (`None`: all 1) and the design `x` (n x p row-major; unused when
    /// p = 0). `None` when the system is not numerically positive
    /// definite.
    pub fn factor<F>(&self, n: usize, mut row: F, w: Option<&[f64]>, x: &[f64]) -> Option<Factor<'_>>
    where
        F: FnMut(usize, &mut Vec<(usize, f64)>),
    {
        let (q, p) = (self.q, self.p);
        let mut values = vec![0.0; self.row_idx.len()];
        for b in 0..q {
            values[self.col_ptr[b]] = 1.0;
        }
        let mut entries = Vec::new();
        let mut xx = vec![0.0; p * p];
        for i in 0..n {
            row(i, &mut entries);
            let wi = w.map_or(1.0, |w| w[i]);
            let positions = &self.pair_pos[self.pair_start[i]..self.pair_start[i + 1]];
            let mut at = 0;
            for (r, &(_, va)) in entries.iter().enumerate() {
                let wa = wi * va;
                for &(_, vb) in &entries[..=r] {
                    values[positions[at]] += wa * vb;
                    at += 1;
                }
            }
            if p > 0 {
                let xi = &x[i * p..(i + 1) * p];
                for &(b, vb) in &entries {
                    let end = self.col_ptr[b + 1];
                    let wb = wi * vb;
                    for (c, xc) in xi.iter().enumerate() {
                        values[end - p + c] += wb * xc;
                    }
                }
                for (c, xc) in xi.iter().enumerate() {
                    let wc = wi * xc;
                    for (d, xd) in xi[..=c].iter().enumerate() {
                        xx[c * p + d] += wc * xd;
                    }
                }
            }
        }
        for d in 0..p {
            for c in d..p {
                values[self.col_ptr[q + d] + (c - d)] = xx[c * p + d];
            }
        }
        let n_all = q + p;
        let mut ordered = vec![0.0; values.len()];
        for (k, v) in values.iter().enumerate() {
            ordered[self.permuted.map[k]] = *v;
        }
        let symbolic_a =
            SymbolicSparseColMatRef::new_checked(n_all, n_all, &self.permuted.col_ptr, None, &self.permuted.row_idx);
        let a = SparseColMatRef::new(symbolic_a, &ordered);
        let mut factor_values = vec![0.0; self.symbolic.len_val()];
        let mut buffer =
            MemBuffer::new(self.symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()));
        self.symbolic
            .factorize_numeric_llt(
                &mut factor_values,
                a,
                self.permuted.side,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut buffer),
                Default::default(),
            )
            .ok()?;
        let diagonal = diagonal(&self.symbolic, &factor_values);
        if diagonal.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            return None;
        }
        Some(Factor { sparse: self, values: factor_values, diagonal })
    }
}

/// The fill-reducing ordering (forward, inverse) of the system whose
/// lower triangle is (`col_ptr`, `row_idx`): AMD's of the random effects'
/// block, the `p` fixed effects keeping the last places.
fn ordering(col_ptr: &[usize], row_idx: &[usize], q: usize, p: usize) -> Result<(Vec<usize>, Vec<usize>), MixedError> {
    let n = q + p;
    let (mut forward, mut inverse) = (vec![0usize; n], vec![0usize; n]);
    if q > 0 {
        let random_nnz = col_ptr[q] - q * p;
        let mut random_ptr = Vec::with_capacity(q + 1);
        let mut random_idx = Vec::with_capacity(random_nnz);
        random_ptr.push(0);
        for b in 0..q {
            random_idx.extend_from_slice(&row_idx[col_ptr[b]..col_ptr[b + 1] - p]);
            random_ptr.push(random_idx.len());
        }
        let pattern = SymbolicSparseColMatRef::new_checked(q, q, &random_ptr, None, &random_idx);
        let mut buffer = MemBuffer::try_new(amd::order_scratch::<usize>(q, random_nnz))
            .map_err(|_| MixedError::TooLarge(format!("the ordering of {q} random effects does not fit in memory")))?;
        amd::order(&mut forward[..q], &mut inverse[..q], pattern, amd::Control::default(), MemStack::new(&mut buffer))
            .map_err(|e| MixedError::TooLarge(format!("the ordering of {q} random effects failed: {e:?}")))?;
    }
    for j in q..n {
        forward[j] = j;
        inverse[j] = j;
    }
    Ok((forward, inverse))
}

/// The diagonal of a numeric factor, in its order.
fn diagonal(symbolic: &SymbolicCholesky<usize>, values: &[f64]) -> Vec<f64> {
    let n = symbolic.nrows();
    let mut out = vec![0.0; n];
    match symbolic.raw() {
        // Each column of a simplicial factor starts with its diagonal.
        SymbolicCholeskyRaw::Simplicial(s) => {
            let col_ptr = s.col_ptr();
            for (j, v) in out.iter_mut().enumerate() {
                *v = values[col_ptr[j]];
            }
        }
        SymbolicCholeskyRaw::Supernodal(s) => {
            let factor = supernodal::SupernodalLltRef::new(s, values);
            for node in 0..s.n_supernodes() {
                let node = factor.supernode(node);
                let (start, val) = (node.start(), node.val());
                for j in 0..val.ncols() {
                    out[start + j] = val[(j, j)];
                }
            }
        }
    }
    out
}

impl Factor<'_> {
    /// log|Lambda'Z'W Z Lambda + I|: twice the logarithms of the random
    /// effects' pivots.
    pub fn log_det_random(&self) -> f64 {
        self.diagonal[..self.sparse.q].iter().map(|v| 2.0 * v.ln()).sum()
    }

    /// log|R_X|^2: twice the logarithms of the fixed effects' pivots.
    pub fn log_det_fixed(&self) -> f64 {
        self.diagonal[self.sparse.q..].iter().map(|v| 2.0 * v.ln()).sum()
    }

    /// Solves the system for the columns of `rhs` (q + p rows), in place.
    pub fn solve(&self, rhs: &mut Mat<f64>) {
        let (symbolic, forward) = (&self.sparse.symbolic, &self.sparse.forward);
        let mut x = Mat::<f64>::from_fn(rhs.nrows(), rhs.ncols(), |i, j| rhs[(forward[i], j)]);
        let mut buffer = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(rhs.ncols(), Par::Seq));
        LltRef::new(symbolic, &self.values).solve_in_place_with_conj(
            Conj::No,
            x.as_mut(),
            Par::Seq,
            MemStack::new(&mut buffer),
        );
        for j in 0..rhs.ncols() {
            for (i, &f) in forward.iter().enumerate() {
                rhs[(f, j)] = x[(i, j)];
            }
        }
    }

    /// Solves the system for one right-hand side.
    pub fn solve_vec(&self, rhs: &[f64]) -> Vec<f64> {
        let mut m = Mat::<f64>::from_fn(rhs.len(), 1, |i, _| rhs[i]);
        self.solve(&mut m);
        (0..rhs.len()).map(|i| m[(i, 0)]).collect()
    }

    /// (R_X'R_X)^-1: the fixed effects' block of the bordered system's
    /// inverse (the inverse of its Schur complement).
    pub fn rx_inv(&self) -> Mat<f64> {
        let (q, p) = (self.sparse.q, self.sparse.p);
        let mut e = Mat::<f64>::zeros(q + p, p);
        for c in 0..p {
            e[(q + c, c)] = 1.0;
        }
        self.solve(&mut e);
        Mat::<f64>::from_fn(p, p, |i, j| 0.5 * (e[(q + i, j)] + e[(q + j, i)]))
    }
}
