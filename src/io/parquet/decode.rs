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

/// Every value of one column chunk of `rows` rows, where its type is one
/// [`super::columns_to_csv_text`] writes.
pub(super) fn decode_column(reader: ColumnReader, desc: &ColumnDescriptor, rows: usize) -> Option<Column> {
    ColumnStream::new(reader, desc)?.read(rows)
}

impl Values {
    /// Value `k` as a reader of the text reads it: a double as it is, a
    /// float and a timestamp as the number its text writes, an integer as
    /// the nearest double; `None` for text and booleans (whose text alone
    /// says what they hold) or past the end.
    pub(super) fn number(&self, k: usize) -> Option<f64> {
        Some(match self {
            Values::Double(v) => *v.get(k)?,
            Values::Int32(v) => f64::from(*v.get(k)?),
            Values::Int64(v, None) => *v.get(k)? as f64,
            Values::Int64(v, Some(s)) => *v.get(k)? as f64 / s,
            Values::Float(v) => {
                let mut text = Vec::with_capacity(48);
                crate::io::float_text::debug_f32(*v.get(k)?, &mut text);
                fast_float2::parse(&text).ok()?
            }
            Values::Bool(_) | Values::Text(_) => return None,
        })
    }
}

/// A column chunk's reader, where its type is one [`super::columns_to_csv_text`]
/// writes: its values read some rows at a time.
pub(super) struct ColumnStream {
    reader: ColumnReader,
    /// The seconds per unit of a timestamp.
    per_second: Option<f64>,
    /// Whether the column may hold nulls.
    nullable: bool,
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
        let decoded = match &reader {
            ColumnReader::BoolColumnReader(_) | ColumnReader::FloatColumnReader(_) => plain,
            ColumnReader::DoubleColumnReader(_) => plain,
            ColumnReader::Int32ColumnReader(_) => signed,
            ColumnReader::Int64ColumnReader(_) => signed || per_second.is_some(),
            ColumnReader::ByteArrayColumnReader(_) => text,
            _ => false,
        };
        decoded.then_some(ColumnStream { reader, per_second, nullable: desc.max_def_level() == 1 })
    }

    /// The next `rows` rows' values (and, for a column that may hold
    /// nulls, their levels); `None` where fewer are left, or on an error.
    pub(super) fn read(&mut self, rows: usize) -> Option<Column> {
        let mut levels = Vec::with_capacity(rows);
        let lv = self.nullable.then_some(&mut levels);
        let values = match &mut self.reader {
            ColumnReader::BoolColumnReader(r) => Values::Bool(read_all(r, rows, lv)?),
            ColumnReader::Int32ColumnReader(r) => Values::Int32(read_all(r, rows, lv)?),
            ColumnReader::Int64ColumnReader(r) => Values::Int64(read_all(r, rows, lv)?, self.per_second),
            ColumnReader::FloatColumnReader(r) => Values::Float(read_all(r, rows, lv)?),
            ColumnReader::DoubleColumnReader(r) => Values::Double(read_all(r, rows, lv)?),
            ColumnReader::ByteArrayColumnReader(r) => Values::Text(read_all(r, rows, lv)?),
            _ => return None,
        };
        Some(Column { values, levels: self.nullable.then_some(levels) })
    }
}

/// Every value (and, for a column with nulls, every level) of `rows` rows.
fn read_all<T: DataType>(
    reader: &mut ColumnReaderImpl<T>,
    rows: usize,
    mut levels: Option<&mut Vec<i16>>,
) -> Option<Vec<T::T>> {
    let mut values = Vec::with_capacity(rows);
    let mut read = 0;
    while read < rows {
        let (records, _, _) = reader.read_records(rows - read, levels.as_deref_mut(), None, &mut values).ok()?;
        if records == 0 {
            return None;
        }
        read += records;
    }
    let levels_read = levels.as_ref().map_or(rows, |l| l.len());
    (levels_read == rows).then_some(values)
}
