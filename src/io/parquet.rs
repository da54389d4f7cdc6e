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
//!
//! A reader may take a table's values without its text, where they are
//! the ones the text gives (a flight log's declared columns,
//! [`DecodedColumns`]; a per-cell or a replications file's rows, a batch
//! of every column at a time, [`open_columns`]), and read the text
//! wherever they might not.

use bytes::Bytes;
use parquet::basic::{LogicalType, TimeUnit, TimestampType};
use parquet::data_type::ByteArray;
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::record::Field;

mod columns;
mod decode;
#[cfg(test)]
pub(crate) mod typed;
pub use columns::{open_columns, ColumnFile, DecodedColumn, GroupColumns};

/// The most bytes the CSV text of a number takes with its separator, with
/// room to spare: a double as Rust's `{:?}` writes it at most 24
/// ("-2.2250738585072014e-308"), an integer at most 20, a boolean 5. A
/// reader that takes a table's values without writing its text bounds
/// that text's size with it, to keep to the text reader's limit.
pub const NUMBER_TEXT: u64 = 32;
use decode::{decode_column, Column, Values};

/// Whether `path` names a Parquet file (`.parquet`).
pub fn is_parquet(path: &std::path::Path) -> bool {
    path.extension().is_some_and(|e| e == "parquet")
}

/// The CSV text of the Parquet file `raw`, at most `limit` bytes of it
/// (`what` names the file's kind in that error: "a flight log"); an error
/// is the reason alone, for the caller to place.
///
/// A file of flat columns of the common types (doubles, floats, signed
/// integers, timestamps, booleans, UTF-8 text, each with or without
/// nulls) is decoded column by column ([`columns_to_csv_text`]); any other
/// file, or any problem, goes through parquet's record API
/// ([`rows_to_csv_text`], the reference the columns are tested against,
/// byte for byte), which also words every error.
///
/// A file the parquet crate panics on (some corrupt ones) is refused
/// with its words, as every reader here refuses it.
pub fn to_csv_text(raw: impl Into<Bytes>, limit: u64, what: &str) -> Result<Vec<u8>, String> {
    let bytes = raw.into();
    undecodable(|| match columns_text(bytes.clone(), limit) {
        Some(text) => Ok(text),
        None => rows_text(bytes, limit, what),
    })
}

/// `read`'s result, or, where the parquet crate panics inside it, why.
fn undecodable<T>(read: impl FnOnce() -> Result<T, String>) -> Result<T, String> {
    super::caught::caught(read)
        .unwrap_or_else(|why| Err(format!("it cannot be decoded (a corrupt or truncated file?): {why}")))
}

/// A Parquet file's columns as decoded, row group by row group, and the
/// header line of its CSV text ([`to_csv_text`]), for a reader that takes
/// its values without writing that text.
pub struct DecodedColumns {
    /// The text's first line, without its `\n`.
    header: Vec<u8>,
    groups: Vec<DecodedGroup>,
    rows: usize,
    /// The most bytes the text may hold.
    limit: u64,
}

/// The columns of the Parquet file `raw`, where [`columns_to_csv_text`]
/// decodes it column by column (`None` where it does not); `limit`: the
/// most bytes its text may hold ([`DecodedColumns::fits`]).
pub fn decode_columns(raw: Bytes, limit: u64) -> Option<DecodedColumns> {
    super::caught::caught(|| decoded(raw, limit)).ok().flatten()
}

/// [`decode_columns`], where the parquet crate may panic.
fn decoded(raw: Bytes, limit: u64) -> Option<DecodedColumns> {
    let file = FlatFile::open(raw, limit)?;
    let groups = (0..file.groups()).map(|g| file.group(g)).collect::<Option<Vec<_>>>()?;
    let rows = groups.iter().map(|g| g.rows).sum();
    Some(DecodedColumns { header: file.header, groups, rows, limit })
}

impl DecodedColumns {
    /// The first line of the file's text (its columns' names), without
    /// its `\n`.
    pub fn header(&self) -> &[u8] {
        &self.header
    }

    /// How many rows the file has.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// How many columns the file has.
    pub fn width(&self) -> usize {
        self.groups.first().map_or(0, |g| g.columns.len())
    }

    /// Whether the file's text ([`to_csv_text`]) certainly keeps to its
    /// limit and each of its lines to `line` bytes, every column whole (a
    /// value for each row that is not null: a damaged one may hold fewer)
    /// and every text UTF-8, as the text's writer needs them: what a
    /// reader that takes the columns without writing the text checks
    /// instead. Bounded, not measured: a number's text at most
    /// [`NUMBER_TEXT`] bytes, a text's twice its bytes and its quotes; a
    /// file whose bound passes is read through its text, which decides.
    /// `line`: the most bytes a line may hold, its `\n` included.
    pub fn fits(&self, line: usize) -> bool {
        let mut total = self.header.len() as u64 + 1;
        for group in &self.groups {
            // Each row's commas and `\n` and its numbers' bound (a null's
            // text is empty: the bound holds); each text's bound by row.
            let mut fixed = group.columns.len() as u64;
            let mut texts: Vec<u64> = Vec::new();
            for column in &group.columns {
                if !column.whole(group.rows) {
                    return false;
                }
                let Values::Text(v) = &column.values else {
                    fixed += NUMBER_TEXT;
                    continue;
                };
                texts.resize(group.rows, 0);
                let mut bounds = texts.iter_mut();
                let bounded = column.each(
                    group.rows,
                    |k| std::str::from_utf8(v.get(k)?.data()).ok().map(str::len),
                    |len| {
                        *bounds.next()? += len.map_or(0, |n| 2 * n as u64 + 2);
                        Some(())
                    },
                );
                if bounded.is_none() {
                    return false;
                }
            }
            if fixed + texts.iter().copied().max().unwrap_or(0) > line as u64 {
                return false;
            }
            let rows = fixed.saturating_mul(group.rows as u64);
            total = total.saturating_add(rows).saturating_add(texts.iter().sum());
        }
        total <= self.limit
    }

    /// Whether every row of column `c` holds a finite number: no null, no
    /// NaN or infinity, no text or booleans (text that holds numbers too
    /// is `false`: only its text says what it holds). What NanoBench's
    /// header asks of every field, read or not.
    pub fn finite(&self, c: usize) -> bool {
        self.groups.iter().all(|g| {
            g.columns.get(c).is_some_and(|column| {
                column.levels.as_ref().is_none_or(|l| l.iter().all(|&d| d == 1))
                    && match &column.values {
                        Values::Int32(_) | Values::Int64(..) => true,
                        Values::Float(v) => v.iter().all(|x| x.is_finite()),
                        Values::Double(v) => v.iter().all(|x| x.is_finite()),
                        Values::Bool(_) | Values::Text(_) => false,
                    }
            })
        })
    }

    /// Column `c`'s values as a reader of the text reads them: a double
    /// as it is, a float and a timestamp as the number its text writes,
    /// an integer as the nearest double, a null as NaN; `None` for a
    /// column of another type (text, booleans), whose text alone says
    /// what it holds.
    pub fn numbers(&self, c: usize) -> Option<Vec<f64>> {
        let mut out = Vec::with_capacity(self.rows);
        let mut text = Vec::with_capacity(48);
        for group in &self.groups {
            let column = group.columns.get(c)?;
            column.each(
                group.rows,
                |k| column.values.number(k, &mut text),
                |x| {
                    out.push(x.unwrap_or(f64::NAN));
                    Some(())
                },
            )?;
        }
        Some(out)
    }
}
/// [`to_csv_text`] through parquet's record API, a row at a time.
pub fn rows_to_csv_text(raw: Bytes, limit: u64, what: &str) -> Result<Vec<u8>, String> {
    undecodable(|| rows_text(raw, limit, what))
}

/// [`rows_to_csv_text`], where the parquet crate may panic.
fn rows_text(raw: Bytes, limit: u64, what: &str) -> Result<Vec<u8>, String> {
    let reader = SerializedFileReader::new(raw).map_err(|e| e.to_string())?;
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
    let names: Vec<_> = fields.iter().map(|f| quoted(f.name())).collect();
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

/// One row group's columns, decoded.
struct DecodedGroup {
    columns: Vec<Column>,
    rows: usize,
}

/// A Parquet file of flat columns, opened: its reader and its text's
/// header line (without its `\n`).
struct FlatFile {
    reader: SerializedFileReader<Bytes>,
    schema: parquet::schema::types::SchemaDescPtr,
    header: Vec<u8>,
}

/// The text [`rows_to_csv_text`] gives, decoded column by column; `None`
/// for a file with another type, nesting or repetition, a decoding error,
/// text that is not UTF-8 or text past `limit`, which the record API reads
/// (and words). Each row group is decoded, written and dropped in turn.
pub fn columns_to_csv_text(raw: Bytes, limit: u64) -> Option<Vec<u8>> {
    super::caught::caught(|| columns_text(raw, limit)).ok().flatten()
}

/// [`columns_to_csv_text`], where the parquet crate may panic.
fn columns_text(raw: Bytes, limit: u64) -> Option<Vec<u8>> {
    let file = FlatFile::open(raw, limit)?;
    let mut out = file.header.clone();
    out.push(b'\n');
    let mut line = Vec::with_capacity(256);
    for g in 0..file.groups() {
        file.group(g)?.lines(&mut line, |l| {
            out.extend_from_slice(l);
            (out.len() as u64 <= limit).then_some(())
        })?;
    }
    Some(out)
}

impl FlatFile {
    /// `raw` opened, where every top-level column is a primitive one and
    /// its row groups' rows could be written in `limit` bytes of text (a
    /// row's line holds a comma between columns and a `\n`): the decoder
    /// is asked for no more values than that, whatever a corrupt footer
    /// says (the record API, a row at a time, reads such a file, up to
    /// the limit).
    fn open(raw: Bytes, limit: u64) -> Option<FlatFile> {
        let reader = SerializedFileReader::new(raw).ok()?;
        let schema = reader.metadata().file_metadata().schema_descr_ptr();
        let fields = schema.root_schema().get_fields();
        if fields.is_empty() || fields.len() != schema.num_columns() || fields.iter().any(|f| !f.is_primitive()) {
            return None;
        }
        let rows = reader
            .metadata()
            .row_groups()
            .iter()
            .try_fold(0u64, |n, g| n.checked_add(u64::try_from(g.num_rows()).ok()?))?;
        if rows.checked_mul(fields.len() as u64)? > limit {
            return None;
        }
        let header = fields.iter().map(|f| quoted(f.name())).collect::<Vec<_>>().join(",").into_bytes();
        Some(FlatFile { reader, schema, header })
    }

    /// How many row groups it has.
    fn groups(&self) -> usize {
        self.reader.num_row_groups()
    }

    /// Row group `g`, every column decoded.
    fn group(&self, g: usize) -> Option<DecodedGroup> {
        let group = self.reader.get_row_group(g).ok()?;
        let rows = usize::try_from(group.metadata().num_rows()).ok()?;
        let columns = (0..self.schema.num_columns())
            .map(|c| decode_column(group.get_column_reader(c).ok()?, &self.schema.column(c), rows))
            .collect::<Option<Vec<_>>>()?;
        Some(DecodedGroup { columns, rows })
    }
}

impl DecodedGroup {
    /// Writes each row's line (its `\n` included) into `line` and hands it
    /// to `each`, stopping at the first `None`.
    fn lines(&self, line: &mut Vec<u8>, mut each: impl FnMut(&[u8]) -> Option<()>) -> Option<()> {
        // Each column's next value (a null has none).
        let mut next = vec![0usize; self.columns.len()];
        for row in 0..self.rows {
            line.clear();
            for (c, (column, next)) in self.columns.iter().zip(&mut next).enumerate() {
                if c > 0 {
                    line.push(b',');
                }
                column.write(row, next, line)?;
            }
            line.push(b'\n');
            each(line)?;
        }
        Some(())
    }
}

impl Column {
    /// Writes row `row`'s value (nothing for a null) as [`text`] does;
    /// `next` is the column's next value, counted on past it.
    fn write(&self, row: usize, next: &mut usize, out: &mut Vec<u8>) -> Option<()> {
        if self.levels.as_ref().is_some_and(|l| l.get(row) != Some(&1)) {
            return Some(());
        }
        let k = *next;
        *next += 1;
        use crate::io::float_text::{debug_f32, debug_f64};
        match &self.values {
            Values::Bool(v) => out.extend_from_slice(if *v.get(k)? { b"true" } else { b"false" }),
            Values::Int32(v) => out.extend_from_slice(itoa::Buffer::new().format(*v.get(k)?).as_bytes()),
            Values::Int64(v, None) => out.extend_from_slice(itoa::Buffer::new().format(*v.get(k)?).as_bytes()),
            Values::Int64(v, Some(s)) => debug_f64(*v.get(k)? as f64 / s, out),
            Values::Float(v) => debug_f32(*v.get(k)?, out),
            Values::Double(v) => debug_f64(*v.get(k)?, out),
            Values::Text(v) => out.extend_from_slice(quoted(std::str::from_utf8(v.get(k)?.data()).ok()?).as_bytes()),
        }
        Some(())
    }
}

/// A CSV table (header first) as a Parquet file that pandas, polars and
/// R's arrow read as typed columns: a column whose every value is `true`
/// or `false` is `BOOLEAN`, one whose every value is an integer `INT64`,
/// one whose every value is a number `DOUBLE`, any other `UTF8` text; an
/// empty field is a null. Snappy, one row
/// group; the same table gives the same bytes. What a run writes as
/// `cells.parquet` and a report as `estimates.parquet`.
pub fn csv_to_parquet(text: &[u8]) -> Result<Vec<u8>, String> {
    csv_to_parquet_in(text, usize::MAX)
}

/// [`csv_to_parquet`], with at most `rows` rows in a row group (more than
/// one group: what readers of large files meet).
pub(crate) fn csv_to_parquet_in(text: &[u8], rows: usize) -> Result<Vec<u8>, String> {
    use parquet::basic::{Compression, Repetition, Type as Physical};
    use parquet::file::properties::WriterProperties;
    use parquet::file::writer::SerializedFileWriter;
    use parquet::schema::types::Type;
    use std::sync::Arc;
    let mut rdr = csv::ReaderBuilder::new().has_headers(true).from_reader(text);
    let names: Vec<String> = rdr.headers().map_err(|e| e.to_string())?.iter().map(str::to_string).collect();
    let mut columns: Vec<Vec<String>> = vec![Vec::new(); names.len()];
    for record in rdr.records() {
        let record = record.map_err(|e| e.to_string())?;
        for (c, v) in columns.iter_mut().zip(record.iter()) {
            c.push(v.to_string());
        }
    }
    let typed: Vec<Typed> = columns.iter().map(|c| Typed::of(c)).collect();
    let fields = names
        .iter()
        .zip(&typed)
        .map(|(name, t)| {
            let (physical, logical) = match t {
                Typed::Bool(_) => (Physical::BOOLEAN, None),
                Typed::Int(_) => (Physical::INT64, None),
                Typed::Double(_) => (Physical::DOUBLE, None),
                Typed::Text(_) => (Physical::BYTE_ARRAY, Some(LogicalType::String)),
            };
            Type::primitive_type_builder(name, physical)
                .with_logical_type(logical)
                .with_repetition(Repetition::OPTIONAL)
                .build()
                .map(Arc::new)
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let schema = Arc::new(Type::group_type_builder("table").with_fields(fields).build().map_err(|e| e.to_string())?);
    let props = Arc::new(WriterProperties::builder().set_compression(Compression::SNAPPY).build());
    let mut out = Vec::new();
    let mut writer = SerializedFileWriter::new(&mut out, schema, props).map_err(|e| e.to_string())?;
    // Row groups of `rows` rows; a table of no rows has one, empty.
    let total = columns.first().map_or(0, Vec::len);
    for start in (0..total.max(1)).step_by(rows.max(1)) {
        let end = total.min(start.saturating_add(rows));
        let mut group = writer.next_row_group().map_err(|e| e.to_string())?;
        for t in &typed {
            let mut column = group.next_column().map_err(|e| e.to_string())?.ok_or("a column too few")?;
            t.write(start..end, column.untyped()).map_err(|e| e.to_string())?;
            column.close().map_err(|e| e.to_string())?;
        }
        group.close().map_err(|e| e.to_string())?;
    }
    writer.close().map_err(|e| e.to_string())?;
    Ok(out)
}

/// One column's values, typed, `None` where the field was empty.
enum Typed {
    Bool(Vec<Option<bool>>),
    Int(Vec<Option<i64>>),
    Double(Vec<Option<f64>>),
    Text(Vec<Option<String>>),
}

impl Typed {
    /// The narrowest type every value of `values` reads as.
    fn of(values: &[String]) -> Typed {
        let present = || values.iter().filter(|v| !v.is_empty());
        let each = |v: &String| v.parse().ok().filter(|_| !v.is_empty());
        if present().all(|v| v == "true" || v == "false") && present().next().is_some() {
            Typed::Bool(values.iter().map(|v| (!v.is_empty()).then(|| v == "true")).collect())
        } else if present().all(|v| v.parse::<i64>().is_ok()) {
            Typed::Int(values.iter().map(each).collect())
        } else if present().all(|v| v.parse::<f64>().is_ok()) {
            Typed::Double(values.iter().map(|v| v.parse().ok().filter(|_| !v.is_empty())).collect())
        } else {
            Typed::Text(values.iter().map(|v| (!v.is_empty()).then(|| v.clone())).collect())
        }
    }

    /// Writes the values with their definition levels (1: a value, 0: null).
    fn write(
        &self,
        rows: std::ops::Range<usize>,
        writer: &mut parquet::column::writer::ColumnWriter,
    ) -> parquet::errors::Result<usize> {
        use parquet::column::writer::ColumnWriter as W;
        fn split<T: Clone>(v: &[Option<T>], rows: std::ops::Range<usize>) -> (Vec<T>, Vec<i16>) {
            let v = v.get(rows).unwrap_or(&[]);
            (v.iter().flatten().cloned().collect(), v.iter().map(|x| i16::from(x.is_some())).collect())
        }
        match (self, writer) {
            (Typed::Bool(v), W::BoolColumnWriter(w)) => {
                let (values, levels) = split(v, rows.clone());
                w.write_batch(&values, Some(&levels), None)
            }
            (Typed::Int(v), W::Int64ColumnWriter(w)) => {
                let (values, levels) = split(v, rows.clone());
                w.write_batch(&values, Some(&levels), None)
            }
            (Typed::Double(v), W::DoubleColumnWriter(w)) => {
                let (values, levels) = split(v, rows.clone());
                w.write_batch(&values, Some(&levels), None)
            }
            (Typed::Text(v), W::ByteArrayColumnWriter(w)) => {
                let (values, levels) = split(v, rows.clone());
                let values: Vec<ByteArray> = values.iter().map(|s| ByteArray::from(s.as_str())).collect();
                w.write_batch(&values, Some(&levels), None)
            }
            _ => Err(parquet::errors::ParquetError::General("a column's type and writer disagree".into())),
        }
    }
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
/// Most fields need neither, and are borrowed as they are.
fn quoted(s: &str) -> std::borrow::Cow<'_, str> {
    if !s.contains(['\n', '\r', ',', '"']) {
        return std::borrow::Cow::Borrowed(s);
    }
    let s = breaks_as_spaces(s).into_owned();
    std::borrow::Cow::Owned(if s.contains([',', '"']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s })
}

/// `s` as the reader of the CSV text reads its field back (or a column's
/// name): its line breaks as spaces, since a row is one line (unlike
/// `io::one_line`, which escapes them for a message).
pub fn breaks_as_spaces(s: &str) -> std::borrow::Cow<'_, str> {
    if s.contains(['\n', '\r']) {
        std::borrow::Cow::Owned(s.replace(['\n', '\r'], " "))
    } else {
        std::borrow::Cow::Borrowed(s)
    }
}
