//! A Parquet table read a column at a time, some rows at a time, each value as
//! the reader of the file's CSV text ([`super::to_csv_text`]) reads it, for
//! a reader that takes a table from its columns without writing its text
//! (`cells`). What it cannot decode by column (another type, nesting,
//! repetition, a file the parquet crate panics on) is `None`: its caller
//! then reads the text, which says what and where.

use bytes::Bytes;
use parquet::file::reader::FileReader;

use super::decode::{Column, ColumnStream, Values};
use super::FlatFile;

/// A Parquet file of flat columns, opened: each column of each row group
/// read when asked for ([`ColumnFile::group`]).
pub struct ColumnFile {
    file: FlatFile,
    /// The rows of each row group.
    groups: Vec<usize>,
}

/// `raw` opened to be read by column, where [`super::columns_to_csv_text`]
/// would decode it by column (every top-level column a primitive one, its
/// rows' text within `limit` bytes); `None` where it would not.
pub fn open_columns(raw: Bytes, limit: u64) -> Option<ColumnFile> {
    crate::io::caught::caught(|| {
        let file = FlatFile::open(raw, limit)?;
        let meta = file.reader.metadata();
        let groups = meta.row_groups().iter().map(|g| usize::try_from(g.num_rows()).ok()).collect::<Option<_>>()?;
        Some(ColumnFile { file, groups })
    })
    .ok()
    .flatten()
}

impl ColumnFile {
    /// The columns' names, in order.
    pub fn names(&self) -> Vec<String> {
        self.file.schema.root_schema().get_fields().iter().map(|f| f.name().to_string()).collect()
    }

    /// The rows of each row group, in order.
    pub fn groups(&self) -> &[usize] {
        &self.groups
    }

    /// Row group `g`'s columns, to be read some rows at a time; `None`
    /// where one is of a type it does not decode.
    pub fn group(&self, g: usize) -> Option<GroupColumns> {
        crate::io::caught::caught(|| {
            let group = self.file.reader.get_row_group(g).ok()?;
            let streams = (0..self.file.schema.num_columns())
                .map(|c| ColumnStream::new(group.get_column_reader(c).ok()?, &self.file.schema.column(c)))
                .collect::<Option<Vec<_>>>()?;
            Some(GroupColumns { streams })
        })
        .ok()
        .flatten()
    }
}

/// Every column of one row group, each read some rows at a time.
pub struct GroupColumns {
    streams: Vec<ColumnStream>,
}

impl GroupColumns {
    /// The next `rows` rows of column `c`; `None` where fewer are left, or
    /// on a decoding error (or panic).
    pub fn next(&mut self, c: usize, rows: usize) -> Option<DecodedColumn> {
        let stream = self.streams.get_mut(c)?;
        crate::io::caught::caught(|| stream.read(rows)).ok().flatten().map(|column| DecodedColumn { column, rows })
    }
}

/// Some rows of one column, decoded.
pub struct DecodedColumn {
    column: Column,
    rows: usize,
}

impl DecodedColumn {
    /// Each row's value by `value` (given the index of the row's value
    /// among the non-null ones), `None` for a null; `None` where `value`
    /// is for some value.
    fn each<T>(&self, value: impl Fn(usize) -> Option<T>) -> Option<Vec<Option<T>>> {
        let mut out = Vec::with_capacity(self.rows);
        let mut next = 0;
        for row in 0..self.rows {
            if self.column.levels.as_ref().is_some_and(|l| l.get(row) != Some(&1)) {
                out.push(None);
            } else {
                out.push(Some(value(next)?));
                next += 1;
            }
        }
        Some(out)
    }

    /// Each row's integer (`None` for a null), for a column of signed
    /// integers that is no timestamp; `None` for any other column.
    pub fn integers(&self) -> Option<Vec<Option<i64>>> {
        match &self.column.values {
            Values::Int32(v) => self.each(|k| v.get(k).map(|&x| i64::from(x))),
            Values::Int64(v, None) => self.each(|k| v.get(k).copied()),
            _ => None,
        }
    }

    /// Each row's number as the text's reader reads it
    /// ([`Values::number`]), `None` for a null; `None` for a column of
    /// text or booleans.
    pub fn numbers(&self) -> Option<Vec<Option<f64>>> {
        if matches!(self.column.values, Values::Bool(_) | Values::Text(_)) {
            return None;
        }
        self.each(|k| self.column.values.number(k))
    }

    /// Each row's text as its bytes (`None` for a null), for a column of
    /// text; `None` for any other column.
    pub fn texts(&self) -> Option<Vec<Option<&[u8]>>> {
        match &self.column.values {
            Values::Text(v) => self.each(|k| v.get(k).map(|b| b.data())),
            _ => None,
        }
    }
}
