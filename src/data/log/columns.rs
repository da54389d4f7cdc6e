//! A Parquet log parsed from its decoded columns, never through its CSV
//! text: the declared columns are taken from the values as decoded, and
//! the content hash and row hashes are those of the values read
//! ([`super::hashes`]), so a Parquet log and its CSV twin hash the same.
//! Anything the CSV reader would refuse or treat specially (a header it
//! refuses, a column of text or booleans declared, a missing or
//! non-finite value it does not read as missing, time going back, a
//! value too large, a text that might hold a line too long or pass the
//! size limit, a damaged column, a one-column file, whose empty rows read
//! as blank lines; under NanoBench's header, a column not read that holds
//! anything but finite numbers) sends the file's whole text to the CSV
//! reader, which gives the same log, or says where and why it refuses.

use std::path::Path;

use super::{header, parse_with, read_bytes, read_raw, Header, Log, LogError, ParseOptions, Schema, MAX_MAGNITUDE};
use crate::io::parquet::{self, DecodedColumns};

/// [`read_bytes`] and [`parse_with`]: the same log, or the same error; a
/// Parquet log's declared columns are read from its decoded values.
pub fn read_log(path: &Path, file: &str, schema: &Schema, options: ParseOptions) -> Result<Log, LogError> {
    if !parquet::is_parquet(path) {
        return parse_with(file, &read_bytes(path)?, schema, options);
    }
    let raw = bytes::Bytes::from(read_raw(path)?);
    let limit = crate::io::MAX_LOG_DECOMPRESSED;
    if let Some(log) = parquet::decode_columns(raw.clone(), limit).and_then(|c| from_columns(file, &c, schema, options))
    {
        return Ok(log);
    }
    let text = parquet::to_csv_text(raw, limit, "a flight log")
        .map_err(|message| LogError::Parquet { file: path.display().to_string(), message })?;
    parse_with(file, &text, schema, options)
}

/// The log [`parse_with`] reads from a Parquet file's text
/// ([`parquet::to_csv_text`]), taken from its decoded columns; `None`
/// where [`parse_with`] must read the text (the reader would refuse it or
/// read it specially).
pub fn from_columns(file: &str, columns: &DecodedColumns, schema: &Schema, options: ParseOptions) -> Option<Log> {
    let mut head = columns.header().to_vec();
    head.push(b'\n');
    // What the CSV reader changes before reading: a byte-order mark (a
    // first column's name may begin with one) and lone `\r` (the text
    // holds none: `io::parquet` writes every line break in a name or a
    // value as a space).
    if head.starts_with(b"\xef\xbb\xbf") {
        return None;
    }
    let Header { names, keep, time, check_all, .. } = header(file, &head, schema).ok()?;
    let rows = columns.rows();
    if names.len() < 2 || names.len() != columns.width() || rows == 0 {
        return None;
    }
    // NanoBench's header: every field a finite number, read or not (the
    // columns read are checked below, as any schema's are).
    if check_all && !(0..names.len()).all(|c| keep.contains(&c) || columns.finite(c)) {
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
    // What the text's reader would refuse for its size alone: the text
    // is not written, so its lines are bounded instead.
    if !columns.fits(crate::io::MAX_LOG_LINE) {
        return None;
    }
    let (content_hash, row_hashes) = super::hashes::hashes(&values, rows, options.hash_rows);
    Some(Log { rows, columns: values, content_hash, row_hashes, blank_before: Vec::new() })
}
