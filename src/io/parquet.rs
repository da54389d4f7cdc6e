//! Parquet files, read natively: every row of the file becomes a line of
//! the CSV text crossaudit would write for it, and that text goes through
//! the reader of its CSV twin (a flight log's, `data::log`; a replications
//! file's, `methods::simsum`). So a Parquet file and its CSV twin give the
//! same columns, errors and (for a flight log) content hash and row hashes,
//! byte for byte; line L of a Parquet file is its row L - 1 (the header is
//! line 1).
//!
//! Each top-level column is one CSV column, named as in the file. Values
//! are written as text without losing a bit: a double as Rust's shortest
//! round-trip form (`0.1`, `1e-7`, `NaN`), a float as its own shortest
//! form (what a CSV export of a float32 column writes), integers as
//! integers, a timestamp as seconds since the epoch (the time column is
//! read in seconds), a missing value as an empty field, and text quoted
//! where CSV needs it, a line break in it (or in a column's name) carried
//! as a space, since a row is one line. Undeclared columns of any type are
//! carried as text and never read as numbers, so they never refuse or
//! exclude a file, whatever their names and values.

use bytes::Bytes;
use parquet::basic::{LogicalType, TimeUnit, TimestampType};
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::record::Field;

/// Whether `path` names a Parquet file (`.parquet`).
pub fn is_parquet(path: &std::path::Path) -> bool {
    path.extension().is_some_and(|e| e == "parquet")
}

/// The CSV text of the Parquet file `raw`, at most `limit` bytes of it
/// (`what` names the file's kind in that error: "a flight log"); an error
/// is the reason alone, for the caller to place.
pub fn to_csv_text(raw: Vec<u8>, limit: u64, what: &str) -> Result<Vec<u8>, String> {
    let reader = SerializedFileReader::new(Bytes::from(raw)).map_err(|e| e.to_string())?;
    let schema = reader.metadata().file_metadata().schema_descr_ptr();
    let fields = schema.root_schema().get_fields();
    if fields.is_empty() {
        return Err("it has no columns".into());
    }
    // Seconds per unit of each column stored as a timestamp.
    let per_second: Vec<Option<f64>> = fields
        .iter()
        .map(|f| match f.get_basic_info().logical_type_ref() {
            Some(LogicalType::Timestamp(TimestampType { unit, .. })) => Some(match unit {
                TimeUnit::MILLIS => 1e3,
                TimeUnit::MICROS => 1e6,
                TimeUnit::NANOS => 1e9,
            }),
            _ => None,
        })
        .collect();
    let mut out = Vec::new();
    let names: Vec<String> = fields.iter().map(|f| quoted(f.name())).collect();
    out.extend_from_slice(names.join(",").as_bytes());
    out.push(b'\n');
    let rows = reader.get_row_iter(None).map_err(|e| e.to_string())?;
    for (k, row) in rows.enumerate() {
        let row = row.map_err(|e| format!("row {}: {e}", k + 1))?;
        for (c, (_, field)) in row.get_column_iter().enumerate() {
            if c > 0 {
                out.push(b',');
            }
            text(field, per_second.get(c).copied().flatten(), &mut out);
        }
        out.push(b'\n');
        if out.len() as u64 > limit {
            return Err(format!("its rows as text exceed the {limit} bytes read from {what}"));
        }
    }
    Ok(out)
}

/// Writes one value as CSV text.
fn text(field: &Field, per_second: Option<f64>, out: &mut Vec<u8>) {
    use std::io::Write as _;
    let _ = match field {
        Field::Null => Ok(()),
        Field::Double(v) => write!(out, "{v:?}"),
        Field::Float(v) => write!(out, "{v:?}"),
        Field::Float16(v) => write!(out, "{:?}", f32::from(*v)),
        Field::Byte(v) => write!(out, "{v}"),
        Field::Short(v) => write!(out, "{v}"),
        Field::Int(v) => write!(out, "{v}"),
        Field::UByte(v) => write!(out, "{v}"),
        Field::UShort(v) => write!(out, "{v}"),
        Field::UInt(v) => write!(out, "{v}"),
        Field::ULong(v) => write!(out, "{v}"),
        Field::Long(v) => match per_second {
            Some(s) => write!(out, "{:?}", *v as f64 / s),
            None => write!(out, "{v}"),
        },
        Field::TimestampMillis(v) => write!(out, "{:?}", *v as f64 / 1e3),
        Field::TimestampMicros(v) => write!(out, "{:?}", *v as f64 / 1e6),
        // Dates and times of day as the numbers they store (days since
        // 1970-01-01, seconds since midnight): parquet's own rendering as a
        // calendar date panics on a value no calendar can show.
        Field::Date(v) => write!(out, "{v}"),
        Field::TimeMillis(v) => write!(out, "{:?}", f64::from(*v) / 1e3),
        Field::TimeMicros(v) => write!(out, "{:?}", *v as f64 / 1e6),
        Field::Bool(v) => write!(out, "{v}"),
        Field::Str(s) => out.write_all(quoted(s).as_bytes()),
        // A list, map or group renders its members, dates among them: it
        // is named, not rendered (no log column is one).
        Field::Group(_) | Field::ListInternal(_) | Field::MapInternal(_) => {
            out.write_all(quoted("a nested value (list, map or group)").as_bytes())
        }
        other => out.write_all(quoted(&other.to_string()).as_bytes()),
    };
}

/// `s` as one CSV field on one line: a line break becomes a space (a log's
/// row is one line, and a text column is never read as a number, so an
/// undeclared note with a line break excludes nothing), and the field is
/// quoted, with its quotes doubled, where it holds a comma or a quote.
fn quoted(s: &str) -> String {
    let s = s.replace(['\n', '\r'], " ");
    if s.contains([',', '"']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s
    }
}
