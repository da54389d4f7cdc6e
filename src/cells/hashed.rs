//! A per-cell file read and hashed at once.

use std::path::Path;

use super::{read_cells, read_chunked, Cell, CellsError};

/// SHA-256 of a per-cell file, for the provenance of its analysis.
pub fn file_sha256(path: &Path) -> Result<String, CellsError> {
    crate::io::sha256_file(path).map_err(|source| CellsError::Io { path: path.display().to_string(), source })
}

/// [`read_cells`] and [`file_sha256`] of one reading: a per-cell CSV is
/// hashed as it is read (one core hashes each block while the others
/// parse it), so the hash is of the bytes the cells came from. A file the
/// parallel reader gives up on is read and hashed again.
pub fn read_cells_hashed(path: &Path) -> Result<(Vec<Cell>, String), CellsError> {
    use sha2::Digest;
    let p = path.display().to_string();
    if !crate::io::parquet::is_parquet(path) {
        crate::io::check_regular(path, crate::io::MAX_CELLS_FILE, "a per-cell CSV")
            .map_err(|e| CellsError::Io { path: p.clone(), source: e.into_io() })?;
        let file = std::fs::File::open(path).map_err(|source| CellsError::Io { path: p.clone(), source })?;
        let size = file.metadata().map_or(0, |m| m.len());
        let mut hasher = sha2::Sha256::new();
        if let Some(cells) = read_chunked(&p, (file, size), crate::io::chunked::CHUNK, |bytes| hasher.update(bytes)) {
            return Ok((cells, crate::io::hex(&hasher.finalize())));
        }
    }
    Ok((read_cells(path)?, file_sha256(path)?))
}
