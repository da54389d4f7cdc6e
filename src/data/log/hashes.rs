//! A log's content hash and row hashes, defined on the values read: the
//! declared columns, in the order the schema asks for them, each value
//! as its 8 bytes (little-endian; every NaN, a missing value, as the one
//! standard NaN). Two logs hash the same where the design reads the same
//! numbers from them, whatever wrote their text: a CSV file, a Parquet
//! file of the same values, a copy written again with other digits
//! (`0.015879000` and `0.015879`) or other columns the design does not
//! read. What DESIGN.md asks of duplicates (byte- or value-identical
//! recordings are one deployment unit), and what a Parquet log's reader
//! can give without writing its text.

use xxhash_rust::xxh3::{xxh3_64, Xxh3};

/// The content hash (XXH3-128, 32 hexadecimal digits) of the `rows` rows
/// of `columns` (each column's values, one per row) and, where
/// `hash_rows`, each row's hash (XXH3-64 of its values' bytes). The
/// content hash begins with the numbers of columns and rows, so a table
/// is not its own transpose's.
pub(super) fn hashes(columns: &[Vec<f64>], rows: usize, hash_rows: bool) -> (String, Vec<u64>) {
    let mut content = Xxh3::new();
    content.update(&(columns.len() as u64).to_le_bytes());
    content.update(&(rows as u64).to_le_bytes());
    let mut row_hashes = Vec::with_capacity(if hash_rows { rows } else { 0 });
    let mut row = Vec::with_capacity(8 * columns.len());
    for r in 0..rows {
        row.clear();
        for column in columns {
            row.extend_from_slice(&bits(column[r]).to_le_bytes());
        }
        content.update(&row);
        if hash_rows {
            row_hashes.push(xxh3_64(&row));
        }
    }
    (format!("{:032x}", content.digest128()), row_hashes)
}

/// A value's bits, every NaN's the standard NaN's (its sign and payload
/// are not a value: the reader reads `NaN`, `-nan` and an empty field alike).
fn bits(v: f64) -> u64 {
    if v.is_nan() {
        f64::NAN.to_bits()
    } else {
        v.to_bits()
    }
}

#[cfg(test)]
mod tests;
