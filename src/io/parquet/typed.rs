//! Parquet files for tests: of typed columns, with nulls (the types a CSV
//! export never gives: 32-bit integers and floats, timestamps, booleans),
//! written by the parquet crate's own writer; and damaged copies of a file.

use std::sync::Arc;

use parquet::basic::{LogicalType, Repetition, TimeUnit, Type as Physical};
use parquet::column::writer::ColumnWriter;
use parquet::data_type::ByteArray;
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::Type;

/// One column of a file written by [`typed`], nulls as `None`.
pub(crate) enum Typed {
    Int32(Vec<Option<i32>>),
    Double(Vec<Option<f64>>),
    Float(Vec<Option<f32>>),
    Millis(Vec<Option<i64>>),
    Bool(Vec<Option<bool>>),
    Text(Vec<Option<Vec<u8>>>),
}

/// `columns` as a Parquet file of one row group, every column optional.
pub(crate) fn typed(columns: &[(&str, Typed)]) -> Vec<u8> {
    let fields = columns
        .iter()
        .map(|(name, c)| {
            let (physical, logical) = match c {
                Typed::Int32(_) => (Physical::INT32, None),
                Typed::Double(_) => (Physical::DOUBLE, None),
                Typed::Float(_) => (Physical::FLOAT, None),
                Typed::Millis(_) => (Physical::INT64, Some(LogicalType::timestamp(false, TimeUnit::MILLIS))),
                Typed::Bool(_) => (Physical::BOOLEAN, None),
                Typed::Text(_) => (Physical::BYTE_ARRAY, Some(LogicalType::String)),
            };
            let field = Type::primitive_type_builder(name, physical).with_logical_type(logical);
            Arc::new(field.with_repetition(Repetition::OPTIONAL).build().expect("field"))
        })
        .collect();
    let schema = Arc::new(Type::group_type_builder("table").with_fields(fields).build().expect("schema"));
    let mut out = Vec::new();
    let mut writer =
        SerializedFileWriter::new(&mut out, schema, Arc::new(WriterProperties::builder().build())).expect("writer");
    let mut group = writer.next_row_group().expect("group");
    for (_, column) in columns {
        let mut col = group.next_column().expect("column").expect("a column");
        fn split<T: Clone>(v: &[Option<T>]) -> (Vec<T>, Vec<i16>) {
            (v.iter().flatten().cloned().collect(), v.iter().map(|x| i16::from(x.is_some())).collect())
        }
        match (col.untyped(), column) {
            (ColumnWriter::Int32ColumnWriter(w), Typed::Int32(v)) => {
                w.write_batch(&split(v).0, Some(&split(v).1), None)
            }
            (ColumnWriter::DoubleColumnWriter(w), Typed::Double(v)) => {
                w.write_batch(&split(v).0, Some(&split(v).1), None)
            }
            (ColumnWriter::FloatColumnWriter(w), Typed::Float(v)) => {
                w.write_batch(&split(v).0, Some(&split(v).1), None)
            }
            (ColumnWriter::Int64ColumnWriter(w), Typed::Millis(v)) => {
                w.write_batch(&split(v).0, Some(&split(v).1), None)
            }
            (ColumnWriter::BoolColumnWriter(w), Typed::Bool(v)) => w.write_batch(&split(v).0, Some(&split(v).1), None),
            (ColumnWriter::ByteArrayColumnWriter(w), Typed::Text(v)) => {
                let (values, levels) = split(v);
                let values: Vec<ByteArray> = values.into_iter().map(ByteArray::from).collect();
                w.write_batch(&values, Some(&levels), None)
            }
            _ => panic!("type and writer disagree"),
        }
        .expect("written");
        col.close().expect("closed");
    }
    group.close().expect("group closed");
    writer.close().expect("file closed");
    out
}

/// A copy of the Parquet file `raw` with one to four bytes set at random
/// by `rng`: anywhere in the file, or (three times in ten) in its last 400
/// bytes, where its footer is.
pub(crate) fn damaged(raw: &[u8], rng: &mut impl rand::Rng) -> Vec<u8> {
    let mut bad = raw.to_vec();
    let footer = rng.gen_bool(0.3);
    for _ in 0..rng.gen_range(1..=4) {
        let at =
            if footer { rng.gen_range(raw.len().saturating_sub(400)..raw.len()) } else { rng.gen_range(0..raw.len()) };
        bad[at] = rng.gen();
    }
    bad
}
