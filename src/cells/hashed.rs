//! A per-cell file read and hashed at once.

use std::path::Path;

use super::{read_cells_with, Cell, CellsError};

/// SHA-256 of a per-cell file, for the provenance of its analysis.
pub fn file_sha256(path: &Path) -> Result<String, CellsError> {
    crate::io::sha256_file(path).map_err(|source| CellsError::Io { path: path.display().to_string(), source })
}

/// [`read_cells`](super::read_cells) and [`file_sha256`] of one reading: a
/// per-cell CSV is hashed as it is read (one core hashes each block while
/// the others parse it), a Parquet file from the bytes read, so the hash
/// is of the bytes the cells came from. A file the parallel reader gives
/// up on is hashed again once the reference reader has read it.
pub fn read_cells_hashed(path: &Path) -> Result<(Vec<Cell>, String), CellsError> {
    let (cells, sha) = read_cells_with(path, true)?;
    let sha = match sha {
        Some(sha) => sha,
        None => file_sha256(path)?,
    };
    Ok((cells, sha))
}
