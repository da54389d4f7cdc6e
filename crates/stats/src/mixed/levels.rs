//! Where each level of the eliminated factor writes into the reduced
//! system.
//!
//! Eliminating level s adds c_s v_s v_s' to the reduced matrix, v_s being
//! the level's row of Lambda2 Z1'Z2 followed by its row of Z1'X. The
//! columns each level touches are fixed by the data, so they are found
//! once, with the runs of consecutive columns among them; every evaluation
//! then adds a level's update a column at a time (the writes run down
//! memory) and each run as a slice, which the compiler vectorizes (a level
//! that has every column, as in a fully crossed design, is one run). Each
//! element takes the levels' terms in level order, so the sums are those
//! of the element-by-element loop to the bit (tested).

use faer::Mat;

/// The levels' entries, precomputed once per system.
#[derive(Debug, Clone)]
pub(super) struct LevelEntries {
    /// Where level s's entries start in `cols` (and in the per-evaluation
    /// values); one past the last at the end.
    start: Vec<usize>,
    /// The column (of the reduced system) of each entry, ascending within
    /// a level: its dense columns, then the p fixed effects.
    cols: Vec<usize>,
    /// Runs of consecutive columns, per level: (first entry, length), the
    /// entry counted from the level's start.
    runs: Vec<(usize, usize)>,
    runs_start: Vec<usize>,
}

impl LevelEntries {
    /// The entries of levels whose dense columns are `row[row_start[s]..
    /// row_start[s + 1]]` (ascending), each followed by the p columns of
    /// the fixed effects, `q2..q2 + p`.
    pub(super) fn new(row_start: &[usize], row: &[(usize, f64)], q2: usize, p: usize) -> LevelEntries {
        let levels = row_start.len() - 1;
        let (mut start, mut cols, mut runs, mut runs_start) = (vec![0], Vec::new(), Vec::new(), vec![0]);
        for s in 0..levels {
            let base = cols.len();
            cols.extend(row[row_start[s]..row_start[s + 1]].iter().map(|&(c, _)| c).chain(q2..q2 + p));
            let first_run = runs.len();
            for e in 0..cols.len() - base {
                match runs[first_run..].last_mut() {
                    Some((at, len)) if cols[base + *at] + *len == cols[base + e] => *len += 1,
                    _ => runs.push((e, 1)),
                }
            }
            start.push(cols.len());
            runs_start.push(runs.len());
        }
        LevelEntries { start, cols, runs, runs_start }
    }

    /// Entries in all (the length of the per-evaluation values).
    pub(super) fn len(&self) -> usize {
        self.cols.len()
    }

    /// Level s's entries: their range in the values, and their columns.
    pub(super) fn of(&self, s: usize) -> (std::ops::Range<usize>, &[usize]) {
        let r = self.start[s]..self.start[s + 1];
        (r.clone(), &self.cols[r])
    }
}

impl LevelEntries {
    /// Adds `wval[e] * val[f]` to `a[(col(e), col(f))]` for every level and
    /// every pair of its entries with e at or after f: the lower triangle of
    /// the sum over levels of c_s v_s v_s' (`wval` = c_s v_s, `val` = v_s).
    pub(super) fn add_outer_products(&self, a: &mut Mat<f64>, val: &[f64], wval: &[f64]) {
        for s in 0..self.start.len() - 1 {
            let base = self.start[s];
            let runs = &self.runs[self.runs_start[s]..self.runs_start[s + 1]];
            let mut first = 0;
            for f in 0..self.start[s + 1] - base {
                let col = a.col_as_slice_mut(self.cols[base + f]);
                let vj = val[base + f];
                if runs[first].0 + runs[first].1 <= f {
                    first += 1;
                }
                for &(at, len) in &runs[first..] {
                    let from = at.max(f);
                    let (e, n) = (base + from, at + len - from);
                    let i = self.cols[e];
                    if n == 1 {
                        col[i] += wval[e] * vj;
                    } else {
                        for (c, &w) in col[i..i + n].iter_mut().zip(&wval[e..e + n]) {
                            *c += w * vj;
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Runs and columns give the bits of the element-by-element loop.
    #[test]
    fn runs_equal_the_element_by_element_loop_to_the_bit() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for (levels, q2, p, density) in [(1, 1, 1, 1.0), (7, 12, 2, 0.3), (40, 30, 1, 0.9), (25, 9, 3, 1.0)] {
            let mut row_start = vec![0];
            let mut row = Vec::new();
            for _ in 0..levels {
                for c in 0..q2 {
                    if rng.gen::<f64>() < density {
                        row.push((c, rng.gen_range(1..4) as f64));
                    }
                }
                row_start.push(row.len());
            }
            let entries = LevelEntries::new(&row_start, &row, q2, p);
            let val: Vec<f64> = (0..entries.len()).map(|_| rng.gen_range(-2.0..2.0)).collect();
            let wval: Vec<f64> = val.iter().map(|v| v * rng.gen_range(0.1..1.0)).collect();
            let m = q2 + p;
            let start = Mat::<f64>::from_fn(m, m, |_, _| rng.gen_range(-1.0..1.0));
            let mut by_level = start.clone();
            for s in 0..levels {
                let (r, cols) = entries.of(s);
                for (e, &i) in cols.iter().enumerate() {
                    for (f, &j) in cols[..=e].iter().enumerate() {
                        by_level[(i, j)] += wval[r.start + e] * val[r.start + f];
                    }
                }
            }
            let mut by_runs = start.clone();
            entries.add_outer_products(&mut by_runs, &val, &wval);
            for j in 0..m {
                for i in 0..m {
                    assert_eq!(by_runs[(i, j)].to_bits(), by_level[(i, j)].to_bits(), "({i}, {j}) of {levels} levels");
                }
            }
        }
    }
}
