//! A Parquet log parsed from its decoded columns. Its CSV text is still
//! written whole, since the content hash and the row hashes are defined on
//! that text (so a Parquet log and its CSV twin hash the same), but the
//! declared columns are taken from the values as decoded instead of being
//! parsed back from the text. Anything the CSV reader would refuse or
//! treat specially (a header it refuses, a column of text or booleans
//! declared, a missing or non-finite value it does not read as missing,
//! time going back, a value too large, a line too long, a one-column
//! file, whose empty rows read as blank lines) sends the text to the CSV
//! reader, which gives the same log, or says where and why it refuses.

use std::path::Path;

use super::{header, parse_with, read_bytes, read_raw, Header, Log, LogError, ParseOptions, Schema, MAX_MAGNITUDE};
use crate::io::parquet::{self, Decoded};

/// [`read_bytes`] and [`parse_with`]: the same log, or the same error; a
/// Parquet log's declared columns are read from its decoded values.
pub fn read_log(path: &Path, file: &str, schema: &Schema, options: ParseOptions) -> Result<Log, LogError> {
    if !parquet::is_parquet(path) {
        return parse_with(file, &read_bytes(path)?, schema, options);
    }
    let decoded = parquet::decode(read_raw(path)?, crate::io::MAX_LOG_DECOMPRESSED, "a flight log")
        .map_err(|message| LogError::Parquet { file: path.display().to_string(), message })?;
    match from_columns(file, &decoded, schema, options) {
        Some(log) => Ok(log),
        None => parse_with(file, &decoded.text, schema, options),
    }
}

/// The log [`parse_with`] reads from a decoded Parquet file's text, taken
/// from its columns; `None` where [`parse_with`] must read the text (the
/// file was not read by column, or the reader would refuse it or read it
/// specially).
pub fn from_columns(file: &str, decoded: &Decoded, schema: &Schema, options: ParseOptions) -> Option<Log> {
    let (text, columns) = (&decoded.text, decoded.columns.as_ref()?);
    // What the CSV reader changes before reading: a byte-order mark (a
    // first column's name may begin with one) and lone `\r` (the text
    // holds none: `io::parquet` writes every line break in a name or a
    // value as a space).
    if text.starts_with(b"\xef\xbb\xbf") {
        return None;
    }
    let Header { end, names, keep, time, check_all } = header(file, text, schema).ok()?;
    let rows = columns.row_ends.len();
    if check_all || names.len() < 2 || names.len() != columns.width() || rows == 0 {
        return None;
    }
    let body = text.get(end + 1..)?;
    // Each row's line, without its `\n`, in the body.
    let starts = std::iter::once(end + 1).chain(columns.row_ends.iter().map(|e| e + 1));
    let lines: Vec<(usize, usize)> = starts.zip(&columns.row_ends).map(|(s, &e)| (s - end - 1, e - end - 1)).collect();
    if lines.iter().any(|&(s, e)| e - s > crate::io::MAX_LOG_LINE) {
        return None;
    }
    let mut values = Vec::with_capacity(keep.len());
    for &c in &keep {
        let missing_ok = options.missing_as_nan && time != Some(c);
        let mut column = columns.numbers(c)?;
        let mut previous = f64::NEG_INFINITY;
        for v in &mut column {
            if !v.is_finite() {
                // Read as missing, as the CSV reader reads an empty or
                // non-finite field, or refused there.
                if !missing_ok {
                    return None;
                }
                *v = f64::NAN;
            } else if time == Some(c) {
                if *v < previous {
                    return None;
                }
                previous = *v;
            } else if v.abs() > MAX_MAGNITUDE {
                return None;
            }
        }
        values.push(column);
    }
    let row_hashes = if options.hash_rows {
        lines.iter().map(|&(s, e)| xxhash_rust::xxh3::xxh3_64(&body[s..e])).collect()
    } else {
        Vec::new()
    };
    let content_hash = format!("{:032x}", xxhash_rust::xxh3::xxh3_128(body));
    Some(Log { rows, columns: values, content_hash, row_hashes, blank_before: Vec::new() })
}
