//! Where a cell was read ([`Origin`]): a line of a per-cell CSV, or a row
//! of a per-cell Parquet file, which has rows and column names but no
//! lines, so every error about it names a row.

/// Where a cell was read: the 1-based line of a per-cell CSV (its header
/// is line 1, its first cell line 2), or the 1-based row of a per-cell
/// Parquet file (its first cell is row 1; row 0 stands for its column
/// names). `line 0` where the cell was built in memory.
///
/// Four bytes, the top bit saying which: a per-cell file holds at most
/// `io::MAX_CELLS_FILE` (1 GiB), so fewer than 2^30 lines or rows.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Origin(u32);

impl Origin {
    const ROW: u32 = 1 << 31;

    /// The most a line's or a row's number can be.
    pub const MAX: u64 = (1 << 31) - 1;

    /// Line `n` of a per-cell CSV (at most [`Origin::MAX`]: a larger
    /// number is taken as that, which no file within the limit reaches).
    pub fn line(n: u64) -> Origin {
        Origin(n.min(Self::MAX) as u32)
    }

    /// Row `n` of a per-cell Parquet file (row 0: its column names; at
    /// most [`Origin::MAX`], as for a line).
    pub fn row(n: u64) -> Origin {
        Origin(Self::line(n).0 | Self::ROW)
    }

    /// The line's or the row's number.
    pub fn number(self) -> u64 {
        u64::from(self.0 & !Self::ROW)
    }

    /// Whether it is a row of a Parquet file.
    pub fn is_row(self) -> bool {
        self.0 & Self::ROW != 0
    }

    /// The same place in the Parquet file whose CSV text (its column names
    /// on line 1, then a line a row) was read: line L is row L - 1.
    pub fn in_parquet(self) -> Origin {
        match self.is_row() || self.0 == 0 {
            true => self,
            false => Origin((self.0 - 1) | Self::ROW),
        }
    }
}

impl std::fmt::Display for Origin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (self.is_row(), self.number()) {
            (true, 0) => write!(f, "its column names"),
            (true, n) => write!(f, "row {n}"),
            (false, n) => write!(f, "line {n}"),
        }
    }
}

impl std::fmt::Debug for Origin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Origin({self})")
    }
}

#[cfg(test)]
mod tests {
    use super::Origin;

    #[test]
    fn a_line_of_the_text_is_the_row_before_it_in_the_parquet_file() {
        let at = Origin::line;
        assert_eq!(at(2).in_parquet(), Origin::row(1));
        assert_eq!(at(2).in_parquet().in_parquet(), Origin::row(1));
        assert_eq!(at(1).in_parquet().to_string(), "its column names");
        assert_eq!(at(642).in_parquet().to_string(), "row 641");
        assert_eq!(at(642).to_string(), "line 642");
        assert_eq!(Origin::default().in_parquet().to_string(), "line 0");
        // Four bytes: 2^31 - 1 is the last number either can hold.
        assert_eq!(Origin::row(1 << 31).number(), (1 << 31) - 1);
        assert_eq!(Origin::line(u64::MAX).number(), (1 << 31) - 1);
        assert!(Origin::row(3).is_row() && !at(3).is_row() && !Origin::line(u64::MAX).is_row());
    }
}
