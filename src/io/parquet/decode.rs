//! One column chunk of a Parquet file decoded, where its type is one
//! [`super::columns_to_csv_text`] writes: its values (and levels), read
//! all at once or some rows at a time.

use parquet::basic::{IntType, LogicalType, TimeUnit, TimestampType};
use parquet::column::reader::{ColumnReader, ColumnReaderImpl};
use parquet::data_type::{ByteArray, DataType};
use parquet::schema::types::ColumnDescriptor;

/// One column's values, decoded (each written as text by `Column::write`
/// in the parent module).
pub(super) enum Values {
    Bool(Vec<bool>),
    Int32(Vec<i32>),
    /// With the seconds per unit of a timestamp.
    Int64(Vec<i64>, Option<f64>),
    Float(Vec<f32>),
    Double(Vec<f64>),
    Text(Vec<ByteArray>),
}

/// A column decoded: its values and, for a column that may hold nulls,
/// each row's definition level (0: null, 1: a value).
pub(super) struct Column {
    pub(super) values: Values,
    pub(super) levels: Option<Vec<i16>>,
}

impl Column {
    /// Whether it holds one value for each of its first `rows` rows that
    /// is not null, as every column its text can be written from does (a
    /// damaged one may hold fewer).
    pub(super) fn whole(&self, rows: usize) -> bool {
        let present = match &self.levels {
            Some(levels) => levels.iter().take(rows).filter(|&&d| d == 1).count(),
            None => rows,
        };
        self.values.len() == present
    }

    /// Gives `f` each of the first `rows` rows' value by `value` (given the
    /// index of the row's value among the non-null ones), `None` for a
    /// null, in order; `None` where `value` is `None` for some value, or
    /// `f` stops.
    pub(super) fn each<T>(
        &self,
        rows: usize,
        mut value: impl FnMut(usize) -> Option<T>,
        mut f: impl FnMut(Option<T>) -> Option<()>,
    ) -> Option<()> {
        let mut next = 0;
        for row in 0..rows {
            if self.levels.as_ref().is_some_and(|l| l.get(row) != Some(&1)) {
                f(None)?;
            } else {
                f(Some(value(next)?))?;
                next += 1;
            }
        }
        Some(())
    }
}

/// Every value of one column chunk of `rows` rows, where its type is one
/// [`super::columns_to_csv_text`] writes.
pub(super) fn decode_column(reader: ColumnReader, desc: &ColumnDescriptor, rows: usize) -> Option<Column> {
    let mut stream = ColumnStream::new(reader, desc)?;
    stream.read(rows)?;
    Some(stream.into_column())
}

impl Values {
    /// How many values it holds.
    pub(super) fn len(&self) -> usize {
        match self {
            Values::Bool(v) => v.len(),
            Values::Int32(v) => v.len(),
            Values::Int64(v, _) => v.len(),
            Values::Float(v) => v.len(),
            Values::Double(v) => v.len(),
            Values::Text(v) => v.len(),
        }
    }

    /// Value `k` as a reader of the text reads it: a double as it is, a
    /// float and a timestamp as the number its text writes, an integer as
    /// the nearest double; `None` for text and booleans (whose text alone
    /// says what they hold) or past the end.
    /// `text` is scratch room for a float's text, reused from value to
    /// value.
    #[inline]
    pub(super) fn number(&self, k: usize, text: &mut Vec<u8>) -> Option<f64> {
        Some(match self {
            Values::Double(v) => *v.get(k)?,
            Values::Int32(v) => f64::from(*v.get(k)?),
            Values::Int64(v, None) => *v.get(k)? as f64,
            Values::Int64(v, Some(s)) => *v.get(k)? as f64 / s,
            Values::Float(v) => {
                text.clear();
                crate::io::float_text::debug_f32(*v.get(k)?, text);
                fast_float2::parse(&*text).ok()?
            }
            Values::Bool(_) | Values::Text(_) => return None,
        })
    }
}

/// A column chunk's reader, where its type is one
/// [`super::columns_to_csv_text`] writes: its values read some rows at a
/// time into buffers kept from one read to the next.
pub(super) struct ColumnStream {
    reader: ColumnReader,
    /// The rows last read.
    column: Column,
}

impl ColumnStream {
    /// `reader`'s stream, where `desc`'s type is one it decodes.
    pub(super) fn new(reader: ColumnReader, desc: &ColumnDescriptor) -> Option<ColumnStream> {
        use parquet::basic::ConvertedType as C;
        if desc.max_rep_level() != 0 || desc.max_def_level() > 1 {
            return None;
        }
        let (logical, converted) = (desc.logical_type_ref(), desc.converted_type());
        let plain = logical.is_none() && converted == C::NONE;
        let signed = plain || matches!(logical, Some(LogicalType::Integer(IntType { is_signed: true, .. })));
        let per_second = match logical {
            Some(LogicalType::Timestamp(TimestampType { unit, .. })) => Some(match unit {
                TimeUnit::MILLIS => 1e3,
                TimeUnit::MICROS => 1e6,
                TimeUnit::NANOS => 1e9,
            }),
            _ => None,
        };
        let text = matches!(logical, Some(LogicalType::String)) || (logical.is_none() && converted == C::UTF8);
        let values = match &reader {
            ColumnReader::BoolColumnReader(_) if plain => Values::Bool(Vec::new()),
            ColumnReader::FloatColumnReader(_) if plain => Values::Float(Vec::new()),
            ColumnReader::DoubleColumnReader(_) if plain => Values::Double(Vec::new()),
            ColumnReader::Int32ColumnReader(_) if signed => Values::Int32(Vec::new()),
            ColumnReader::Int64ColumnReader(_) if signed || per_second.is_some() => {
                Values::Int64(Vec::new(), per_second)
            }
            ColumnReader::ByteArrayColumnReader(_) if text => Values::Text(Vec::new()),
            _ => return None,
        };
        let levels = (desc.max_def_level() == 1).then(Vec::new);
        Some(ColumnStream { reader, column: Column { values, levels } })
    }

    /// The next `rows` rows' values (and, for a column that may hold
    /// nulls, their levels); `None` where fewer are left, or on an error.
    pub(super) fn read(&mut self, rows: usize) -> Option<&Column> {
        let Column { values, levels } = &mut self.column;
        let read = match (&mut self.reader, values) {
            (ColumnReader::BoolColumnReader(r), Values::Bool(v)) => read_all(r, rows, levels, v),
            (ColumnReader::Int32ColumnReader(r), Values::Int32(v)) => read_all(r, rows, levels, v),
            (ColumnReader::Int64ColumnReader(r), Values::Int64(v, _)) => read_all(r, rows, levels, v),
            (ColumnReader::FloatColumnReader(r), Values::Float(v)) => read_all(r, rows, levels, v),
            (ColumnReader::DoubleColumnReader(r), Values::Double(v)) => read_all(r, rows, levels, v),
            (ColumnReader::ByteArrayColumnReader(r), Values::Text(v)) => read_all(r, rows, levels, v),
            _ => None,
        };
        read.map(|()| &self.column)
    }

    /// The column as last read.
    pub(super) fn into_column(self) -> Column {
        self.column
    }
}

/// Every value (and, for a column with nulls, every level) of the next
/// `rows` rows, into `values` and `levels` (cleared first).
fn read_all<T: DataType>(
    reader: &mut ColumnReaderImpl<T>,
    rows: usize,
    levels: &mut Option<Vec<i16>>,
    values: &mut Vec<T::T>,
) -> Option<()> {
    values.clear();
    values.reserve(rows);
    if let Some(l) = levels.as_mut() {
        l.clear();
        l.reserve(rows);
    }
    let mut read = 0;
    while read < rows {
        let (records, _, _) = reader.read_records(rows - read, levels.as_mut(), None, values).ok()?;
        if records == 0 {
            return None;
        }
        read += records;
    }
    let levels_read = levels.as_ref().map_or(rows, Vec::len);
    (levels_read == rows).then_some(())
}
