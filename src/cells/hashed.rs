//! A per-cell file read and hashed at once.

use std::path::Path;

use super::{read_cells_with, Cell, CellsError};

/// SHA-256 of a per-cell file, for the provenance of its analysis.
pub fn file_sha256(path: &Path) -> Result<String, CellsError> {
    crate::io::sha256_file(path).map_err(|source| CellsError::Io { path: path.display().to_string(), source })
}

/// Whether the per-cell CSV at `path` ends without a line break: a file
/// cut short while it was written ends so, and its last value may then be
/// cut too, which no reader can see (every per-cell file crossaudit writes
/// ends with one). Never for a Parquet file or an empty one.
pub fn last_line_open(path: &Path) -> Result<bool, CellsError> {
    use std::io::{Read, Seek, SeekFrom};
    if crate::io::parquet::is_parquet(path) {
        return Ok(false);
    }
    let io = |source| CellsError::Io { path: path.display().to_string(), source };
    let mut file = std::fs::File::open(path).map_err(io)?;
    if file.metadata().map_err(io)?.len() == 0 {
        return Ok(false);
    }
    file.seek(SeekFrom::End(-1)).map_err(io)?;
    let mut last = [0u8];
    file.read_exact(&mut last).map_err(io)?;
    Ok(last[0] != b'\n' && last[0] != b'\r')
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
