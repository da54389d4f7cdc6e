//! Writing results so that a reader never sees half a file: atomic writes,
//! directories created with their path in the error, pretty JSON with a
//! final newline, and the SHA-256 every manifest and lock is keyed by.
//!
//! Architecture Invariant: `io` imports nothing from the crate.

use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

/// A file or directory that could not be written, with its path.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {path}: {source}")]
pub struct WriteError {
    /// The path that could not be written.
    pub path: String,
    /// The operating system's reason.
    pub source: std::io::Error,
}

impl WriteError {
    /// The error for `path`.
    pub fn new(path: &Path, source: std::io::Error) -> WriteError {
        WriteError { path: path.display().to_string(), source }
    }
}

/// Temporary file in the same directory, then rename, so a reader never sees
/// half a file and an interrupted write never replaces a finished one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    let err = |source| WriteError::new(path, source);
    let tmp = tmp_path(path);
    std::fs::write(&tmp, bytes).map_err(err)?;
    std::fs::rename(&tmp, path).map_err(err)
}

/// `path` with `.tmp` appended: where [`write_atomic`] stages a file.
pub fn tmp_path(path: &Path) -> PathBuf {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    PathBuf::from(tmp)
}

/// `std::fs::create_dir_all`, with the path in the error.
pub fn create_dir_all(dir: &Path) -> Result<(), WriteError> {
    std::fs::create_dir_all(dir).map_err(|source| WriteError::new(dir, source))
}

/// Pretty JSON with a final newline: the form of every JSON file written.
pub fn pretty_json<T: serde::Serialize + ?Sized>(value: &T) -> String {
    // Serializing plain data structs (no maps with non-string keys) cannot fail.
    let mut s = serde_json::to_string_pretty(value).unwrap_or_default();
    s.push('\n');
    s
}

/// SHA-256 of `bytes`, lowercase hex.
///
/// ```
/// // FIPS 180-2, Appendix B.1: SHA-256("abc").
/// assert_eq!(
///     crossaudit::io::sha256_hex(b"abc"),
///     "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
/// );
/// ```
pub fn sha256_hex(bytes: &[u8]) -> String {
    let digest = Sha256::digest(bytes);
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 of a file's bytes, lowercase hex: how every file a resume
/// reuses is checked against its record.
pub fn sha256_file(path: &Path) -> std::io::Result<String> {
    Ok(sha256_hex(&std::fs::read(path)?))
}

/// Serializes an `f64` in Rust's shortest round-trip `Display` form (`1`,
/// `0.00001`), the form of every number in the CSV files written here, so
/// the same values always give the same bytes.
pub fn f64_text<S: serde::Serializer>(value: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(value)
}

/// As [`f64_text`]; `None` is an empty field.
pub fn opt_f64_text<S: serde::Serializer>(value: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match value {
        Some(v) => s.collect_str(v),
        None => s.serialize_none(),
    }
}

/// Degrees of freedom in JSON: a number when finite, `"infinite"` for the
/// normal quantile (z) and `"undefined"` where no df applies (a bootstrap
/// interval), which plain JSON numbers cannot tell apart (both would be
/// `null`).
pub fn df_json<S: serde::Serializer>(value: &f64, s: S) -> Result<S::Ok, S::Error> {
    if value.is_finite() {
        s.serialize_f64(*value)
    } else if value.is_infinite() {
        s.serialize_str("infinite")
    } else {
        s.serialize_str("undefined")
    }
}
