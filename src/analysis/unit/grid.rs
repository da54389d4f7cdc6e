//! The recording x seed grid of one arm, or of a difference: plain values,
//! NaN where a cell is missing.

use crate::design::Factor;
use crossaudit_stats::{CrossedMatrix, StatsError};

/// A rows x cols grid (recordings x seeds, row-major); NaN where a cell
/// is missing. Every value present is finite (the cells reader and
/// `analysis::check_values` refuse any other), so NaN marks nothing else,
/// and a grid is 8 bytes a cell, not an option's 16 (at 10M cells, 40 MB
/// a grid).
#[derive(Debug, Clone)]
pub(super) struct Grid {
    pub(super) rows: usize,
    pub(super) cols: usize,
    pub(super) v: Vec<f64>,
}

/// A grid's value where it is present.
fn present(x: f64) -> Option<f64> {
    (!x.is_nan()).then_some(x)
}

impl Grid {
    /// The grid of `values`, NaN where one is `None`.
    pub(super) fn of(rows: usize, cols: usize, values: impl IntoIterator<Item = Option<f64>>) -> Grid {
        Grid { rows, cols, v: values.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect() }
    }

    pub(super) fn get(&self, i: usize, j: usize) -> Option<f64> {
        present(self.v[i * self.cols + j])
    }

    /// The values present, in order.
    pub(super) fn present(&self) -> impl Iterator<Item = f64> + '_ {
        self.v.iter().copied().filter(|x| !x.is_nan())
    }

    /// The balanced matrix, when no cell is missing.
    pub(super) fn complete(&self) -> Option<Result<CrossedMatrix, StatsError>> {
        self.values().map(|v| CrossedMatrix::new(self.rows, self.cols, v.to_vec()))
    }

    /// Every value, when no cell is missing.
    pub(super) fn values(&self) -> Option<&[f64]> {
        (!self.v.iter().any(|x| x.is_nan())).then_some(&self.v[..])
    }

    /// Whether every row holds one value in every column (complete, at
    /// least 2 columns): nothing varies with the seed.
    pub(super) fn seed_invariant(&self) -> bool {
        self.cols >= 2
            && self.v.chunks(self.cols).all(|row| row.iter().all(|x| !x.is_nan() && x.to_bits() == row[0].to_bits()))
    }

    pub(super) fn missing(&self) -> usize {
        self.v.iter().filter(|x| x.is_nan()).count()
    }

    /// (row, col, value) of the cells present.
    pub(super) fn cells(&self) -> Vec<(usize, usize, f64)> {
        (0..self.rows)
            .flat_map(|i| (0..self.cols).map(move |j| (i, j)))
            .filter_map(|(i, j)| self.get(i, j).map(|x| (i, j, x)))
            .collect()
    }

    /// self - other where both are present (NaN, missing, where either
    /// is: finite values never subtract to NaN).
    pub(super) fn minus(&self, other: &Grid) -> Grid {
        let v = self.v.iter().zip(&other.v).map(|(a, b)| a - b).collect();
        Grid { rows: self.rows, cols: self.cols, v }
    }

    /// self where `mask` is present, in place: at 10M cells a grid is
    /// 80 MB.
    pub(super) fn masked(mut self, mask: &Grid) -> Grid {
        self.v.iter_mut().zip(&mask.v).for_each(|(a, m)| {
            if m.is_nan() {
                *a = f64::NAN;
            }
        });
        self
    }

    pub(super) fn mean(&self) -> f64 {
        mean(self.present())
    }

    pub(super) fn col_mean(&self, j: usize) -> f64 {
        mean((0..self.rows).filter_map(|i| self.get(i, j)))
    }

    pub(super) fn row_mean(&self, i: usize) -> f64 {
        mean((0..self.cols).filter_map(|j| self.get(i, j)))
    }

    pub(super) fn without(&self, factor: Factor, k: usize) -> Grid {
        let keep = |i: usize, j: usize| match factor {
            Factor::Seed => j != k,
            Factor::Recording => i != k,
        };
        let (rows, cols) = match factor {
            Factor::Seed => (self.rows, self.cols - 1),
            Factor::Recording => (self.rows - 1, self.cols),
        };
        let v = (0..self.rows)
            .flat_map(|i| (0..self.cols).map(move |j| (i, j)))
            .filter(|&(i, j)| keep(i, j))
            .map(|(i, j)| self.v[i * self.cols + j])
            .collect();
        Grid { rows, cols, v }
    }
}

/// Mean of the values; NaN when there are none.
fn mean(values: impl Iterator<Item = f64>) -> f64 {
    let (n, s) = values.fold((0usize, 0.0), |(n, s), x| (n + 1, s + x));
    if n == 0 {
        f64::NAN
    } else {
        s / n as f64
    }
}
