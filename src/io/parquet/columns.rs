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
/// would decode it by column (every top-level column a primitive one, and
/// at least a byte for each value and its separator within `limit`: the
/// text itself is not measured, which a reader that must keep to the
/// limit does); `None` where it would not.
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

/// Every column of one row group, read some rows at a time.
pub struct GroupColumns {
    streams: Vec<ColumnStream>,
}

impl GroupColumns {
    /// The next `rows` rows of every column, the columns decoded on every
    /// core; a column's `None` where fewer rows are left, or on a decoding
    /// error (or panic).
    pub fn next(&mut self, rows: usize) -> Vec<Option<DecodedColumn<'_>>> {
        use rayon::prelude::*;
        // One column a task: the columns of text take longest.
        self.streams
            .par_iter_mut()
            .with_max_len(1)
            .map(|stream| {
                let column = crate::io::caught::caught(move || stream.read(rows)).ok().flatten();
                column.map(|column| DecodedColumn { column, rows })
            })
            .collect()
    }
}

/// Some rows of one column, decoded.
pub struct DecodedColumn<'a> {
    column: &'a Column,
    rows: usize,
}

impl<'a> DecodedColumn<'a> {
    /// [`Column::each`] over its rows.
    fn each<T>(&self, value: impl FnMut(usize) -> Option<T>, f: impl FnMut(Option<T>) -> Option<()>) -> Option<()> {
        self.column.each(self.rows, value, f)
    }

    /// How many rows it holds.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Whether it holds one value for each of its rows that is not null,
    /// as every column its text can be written from does (a damaged one
    /// may hold fewer).
    pub fn whole(&self) -> bool {
        self.column.whole(self.rows)
    }

    /// Whether it is a column of text.
    pub fn is_text(&self) -> bool {
        matches!(self.column.values, Values::Text(_))
    }

    /// Gives `f` each row's integer (`None` for a null), for a column of
    /// signed integers that is no timestamp; `None` for any other column,
    /// or where `f` stops.
    pub fn integers(&self, f: impl FnMut(Option<i64>) -> Option<()>) -> Option<()> {
        match &self.column.values {
            Values::Int32(v) => self.each(|k| v.get(k).map(|&x| i64::from(x)), f),
            Values::Int64(v, None) => self.each(|k| v.get(k).copied(), f),
            _ => None,
        }
    }

    /// Gives `f` each row's number as the text's reader reads it
    /// (a double itself, a float or a timestamp the number its text writes,
    /// an integer the nearest double), `None` for a null; `None` for a column of
    /// text or booleans, or where `f` stops.
    pub fn numbers(&self, f: impl FnMut(Option<f64>) -> Option<()>) -> Option<()> {
        if matches!(self.column.values, Values::Bool(_) | Values::Text(_)) {
            return None;
        }
        let mut text = Vec::with_capacity(48);
        self.each(|k| self.column.values.number(k, &mut text), f)
    }

    /// Gives `f` each row's field as the reader of the text reads it back,
    /// unquoted (empty for a null): a number, timestamp or boolean as the
    /// text writes it, a text with its line breaks as spaces
    /// ([`super::breaks_as_spaces`]); `None` where a text is not UTF-8, or where
    /// `f` stops.
    pub fn fields(&self, mut f: impl FnMut(&str) -> Option<()>) -> Option<()> {
        if let Values::Text(v) = &self.column.values {
            return self.each(
                |k| v.get(k).map(|b| b.data()),
                |t| f(&super::breaks_as_spaces(std::str::from_utf8(t.unwrap_or_default()).ok()?)),
            );
        }
        let (mut text, mut next) = (Vec::with_capacity(48), 0);
        for row in 0..self.rows {
            text.clear();
            self.column.write(row, &mut next, &mut text)?;
            f(std::str::from_utf8(&text).ok()?)?;
        }
        Some(())
    }

    /// Gives `f` each row's text as its bytes (`None` for a null), for a
    /// column of text; `None` for any other column, or where `f` stops.
    pub fn texts(&self, f: impl FnMut(Option<&'a [u8]>) -> Option<()>) -> Option<()> {
        match &self.column.values {
            Values::Text(v) => self.each(|k| v.get(k).map(|b| b.data()), f),
            _ => None,
        }
    }
}
