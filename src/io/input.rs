//! A text input read whole: under a size limit, a Parquet file turned into
//! its CSV text (`io::parquet`), UTF-8 checked with the place of the first
//! bad byte, a byte-order mark removed. The per-cell, replications and
//! split readers share it, so each refuses the same damage the same way.

use std::path::Path;

/// A text input as read.
#[derive(Debug, Clone)]
pub struct Text {
    /// The text, without a leading byte-order mark; a Parquet file's CSV
    /// text.
    pub text: String,
    /// The SHA-256 of the file's bytes as they are on disk.
    pub sha256: String,
    /// Whether the file was Parquet, read as its CSV text.
    pub parquet: bool,
}

/// Why a text input could not be read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TextError {
    /// Not read (missing, not a regular file, too large): the reason.
    Read(String),
    /// A Parquet file whose rows could not be read: the reason.
    Parquet(String),
    /// Not UTF-8: the 1-based line and column of the first bad byte.
    NotUtf8 {
        /// Line.
        line: usize,
        /// Column, in bytes.
        column: usize,
    },
}

impl TextError {
    /// The reason, for a message that names the file itself.
    pub fn reason(&self) -> String {
        match self {
            TextError::Read(why) => why.clone(),
            TextError::Parquet(why) => format!("not a readable Parquet file: {why}"),
            TextError::NotUtf8 { line, column } => format!("not UTF-8 at line {line}, column {column}"),
        }
    }
}

/// Reads `path` as text (at most `limit` bytes; `what` names its kind in
/// the too-large error, "a replications file"); a `.parquet` file becomes
/// its CSV text, held to the same limit.
pub fn read_text(path: &Path, limit: u64, what: &'static str) -> Result<Text, TextError> {
    let raw = super::read_input(path, limit, what).map_err(|e| TextError::Read(e.reason()))?;
    text_of(raw, super::parquet::is_parquet(path), limit, what)
}

/// [`read_text`] of a file's bytes `raw`, already read (`parquet`: the
/// file is Parquet).
pub fn text_of(raw: Vec<u8>, parquet: bool, limit: u64, what: &'static str) -> Result<Text, TextError> {
    let sha256 = super::sha256_hex(&raw);
    let bytes = if parquet { super::parquet::to_csv_text(raw, limit, what).map_err(TextError::Parquet)? } else { raw };
    let text = String::from_utf8(bytes).map_err(|e| {
        let bad = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let line_start = bytes[..bad].iter().rposition(|&b| b == b'\n').map_or(0, |k| k + 1);
        let line = 1 + bytes[..bad].iter().filter(|&&b| b == b'\n').count();
        TextError::NotUtf8 { line, column: bad - line_start + 1 }
    })?;
    let text = match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => text,
    };
    Ok(Text { text, sha256, parquet })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_byte_is_placed_and_a_bom_removed() -> Result<(), Box<dyn std::error::Error>> {
        let tmp = tempfile::tempdir()?;
        let bad = tmp.path().join("bad.csv");
        std::fs::write(&bad, b"a,b\n1,2\n3,\xff4\n")?;
        assert_eq!(read_text(&bad, 1 << 20, "a file").unwrap_err(), TextError::NotUtf8 { line: 3, column: 3 });
        let bom = tmp.path().join("bom.csv");
        std::fs::write(&bom, "\u{feff}a,b\n")?;
        let t = read_text(&bom, 1 << 20, "a file").map_err(|e| format!("{e:?}"))?;
        assert_eq!((t.text.as_str(), t.parquet), ("a,b\n", false));
        assert_eq!(t.sha256, crate::io::sha256_hex("\u{feff}a,b\n".as_bytes()));
        Ok(())
    }
}
