use super::StatsError;

/// A balanced I x J array (rows = recordings, columns = seeds), row-major,
/// every value finite.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossedMatrix {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

impl CrossedMatrix {
    /// Validates shape (at least 2 x 2) and finiteness.
    pub fn new(rows: usize, cols: usize, data: Vec<f64>) -> Result<Self, StatsError> {
        check_shape(rows, cols, data.len())?;
        if let Some(k) = data.iter().position(|v| !v.is_finite()) {
            return Err(StatsError::NonFinite { row: k / cols, col: k % cols, value: data[k] });
        }
        Ok(CrossedMatrix { rows, cols, data })
    }

    /// Builds from rows of equal length.
    pub fn from_rows(rows: &[Vec<f64>]) -> Result<Self, StatsError> {
        let cols = rows.first().map(|r| r.len()).unwrap_or(0);
        if let Some(bad) = rows.iter().find(|r| r.len() != cols) {
            return Err(StatsError::Shape { rows: rows.len(), cols, expected: cols, found: bad.len() });
        }
        Self::new(rows.len(), cols, rows.concat())
    }

    /// Number of rows I.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns J.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// The value at row `i`, column `j`.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.data[i * self.cols + j]
    }

    /// Row `i`.
    pub fn row(&self, i: usize) -> &[f64] {
        &self.data[i * self.cols..(i + 1) * self.cols]
    }

    /// All values, row-major.
    pub fn values(&self) -> &[f64] {
        &self.data
    }

    /// Grand mean.
    pub fn mean(&self) -> f64 {
        self.data.iter().sum::<f64>() / self.data.len() as f64
    }

    /// The values, row-major, given back (for a buffer to be reused).
    pub fn into_values(self) -> Vec<f64> {
        self.data
    }

    /// Mean of each row.
    pub fn row_means(&self) -> Vec<f64> {
        (0..self.rows).map(|i| self.row(i).iter().sum::<f64>() / self.cols as f64).collect()
    }

    /// Mean of each column.
    pub fn col_means(&self) -> Vec<f64> {
        let mut m = vec![0.0; self.cols];
        for i in 0..self.rows {
            for (acc, v) in m.iter_mut().zip(self.row(i)) {
                *acc += v;
            }
        }
        m.iter_mut().for_each(|v| *v /= self.rows as f64);
        m
    }

    /// Element-wise `self - other` (e.g. the world - relative interaction).
    pub fn minus(&self, other: &CrossedMatrix) -> Result<CrossedMatrix, StatsError> {
        if self.rows != other.rows || self.cols != other.cols {
            return Err(StatsError::Shape {
                rows: self.rows,
                cols: self.cols,
                expected: self.data.len(),
                found: other.data.len(),
            });
        }
        let data = self.data.iter().zip(&other.data).map(|(a, b)| a - b).collect();
        CrossedMatrix::new(self.rows, self.cols, data)
    }

    /// Multiplies every value by `c`.
    pub fn scaled(&self, c: f64) -> Result<CrossedMatrix, StatsError> {
        CrossedMatrix::new(self.rows, self.cols, self.data.iter().map(|v| v * c).collect())
    }

    /// The array without row `i` (leave one recording out).
    pub fn without_row(&self, i: usize) -> Result<CrossedMatrix, StatsError> {
        let data = (0..self.rows).filter(|&r| r != i).flat_map(|r| self.row(r).to_vec()).collect();
        CrossedMatrix::new(self.rows - 1, self.cols, data)
    }

    /// The array without column `j` (leave one seed out).
    pub fn without_col(&self, j: usize) -> Result<CrossedMatrix, StatsError> {
        let data = (0..self.rows)
            .flat_map(|r| self.row(r).iter().enumerate().filter(|(c, _)| *c != j).map(|(_, v)| *v).collect::<Vec<_>>())
            .collect();
        CrossedMatrix::new(self.rows, self.cols - 1, data)
    }

    /// Averages rows within groups: `group[i]` is row i's group in
    /// `0..n_groups`; every group must be non-empty. The result is
    /// n_groups x J.
    pub fn group_rows(&self, group: &[usize], n_groups: usize) -> Result<CrossedMatrix, StatsError> {
        if group.len() != self.rows {
            return Err(StatsError::Groups(format!("{} labels for {} rows", group.len(), self.rows)));
        }
        let mut sums = vec![0.0; n_groups * self.cols];
        let mut counts = vec![0usize; n_groups];
        for (i, &g) in group.iter().enumerate() {
            if g >= n_groups {
                return Err(StatsError::Groups(format!("row {i} has group {g}, but there are {n_groups} groups")));
            }
            counts[g] += 1;
            for (acc, v) in sums[g * self.cols..(g + 1) * self.cols].iter_mut().zip(self.row(i)) {
                *acc += v;
            }
        }
        if let Some(g) = counts.iter().position(|&c| c == 0) {
            return Err(StatsError::Groups(format!("group {g} has no rows")));
        }
        for (g, &c) in counts.iter().enumerate() {
            sums[g * self.cols..(g + 1) * self.cols].iter_mut().for_each(|v| *v /= c as f64);
        }
        CrossedMatrix::new(n_groups, self.cols, sums)
    }

    /// Rows and columns reordered: row `i` of the result is row `row_perm[i]`.
    pub fn permuted(&self, row_perm: &[usize], col_perm: &[usize]) -> Result<CrossedMatrix, StatsError> {
        for (perm, n, what) in [(row_perm, self.rows, "row"), (col_perm, self.cols, "column")] {
            let mut sorted = perm.to_vec();
            sorted.sort_unstable();
            if sorted != (0..n).collect::<Vec<_>>() {
                return Err(StatsError::Invalid(format!("{what} order {perm:?} is not a permutation of 0..{n}")));
            }
        }
        let data =
            row_perm.iter().flat_map(|&r| col_perm.iter().map(move |&c| (r, c))).map(|(r, c)| self.get(r, c)).collect();
        CrossedMatrix::new(row_perm.len(), col_perm.len(), data)
    }
}

/// What [`CrossedMatrix::new`] refuses about an array's shape: fewer than
/// two rows or columns, or `len` values that do not fill `rows` x `cols`.
pub(crate) fn check_shape(rows: usize, cols: usize, len: usize) -> Result<(), StatsError> {
    if rows < 2 {
        return Err(StatsError::TooFew { what: "rows (recordings)", found: rows });
    }
    if cols < 2 {
        return Err(StatsError::TooFew { what: "columns (seeds)", found: cols });
    }
    if len != rows * cols {
        return Err(StatsError::Shape { rows, cols, expected: rows * cols, found: len });
    }
    Ok(())
}
