//! A replications Parquet file's rows taken from its decoded columns,
//! without writing its CSV text: each field as the text's reader reads it
//! back (`io::parquet::DecodedColumn::fields`), each number as that reader
//! parses it (a column of numbers its values as decoded), and every check
//! a row of that text must pass ([`super::replication`]). Anything that
//! reader would refuse or read otherwise (a header it refuses, a name
//! beginning with a byte-order mark, a one-column file, whose empty rows
//! read as blank lines, text that is not UTF-8 or might pass the size
//! limit, a row that fails a check, a damaged column) gives `None`: the
//! text's reader then reads the file and says where and why it refuses,
//! so a file gives the same replications, or the same error, either way.

use bytes::Bytes;
use crossaudit_stats::simsum::Replication;

use super::rows::{locate, number, replication, unused_columns, Columns, Fields, SimsumFileError};
use crate::io::parquet::{breaks_as_spaces, open_columns, DecodedColumn, NUMBER_TEXT};

/// Rows decoded at a time: every column's values for them are held, then
/// their replications made.
const BATCH: usize = 65_536;

/// The replications (and the notes on columns not read) of the Parquet
/// file `raw` from its columns; `None` where its text must be read.
pub(super) fn from_columns(raw: Bytes, cols: &Columns, limit: u64) -> Option<(Vec<Replication>, Vec<String>)> {
    from_columns_in(raw, cols, limit, BATCH)
}

/// [`from_columns`], `batch` rows at a time.
fn from_columns_in(raw: Bytes, cols: &Columns, limit: u64, batch: usize) -> Option<(Vec<Replication>, Vec<String>)> {
    let file = open_columns(raw, limit)?;
    let names = file.names();
    if names.len() < 2 || names[0].starts_with('\u{feff}') {
        return None;
    }
    let header: Vec<String> = names.iter().map(|n| breaks_as_spaces(n).trim().to_string()).collect();
    // Any error here sends the file to the text's reader, which words it.
    let at = |_: usize, _: usize, _: String| SimsumFileError::Flag(String::new());
    let loc = locate(&header, cols, &at).ok()?;
    let (texts, numbers) = loc.reads(names.len());
    let mut parts: Vec<Part> = texts.into_iter().zip(numbers).map(|(t, n)| Part::new(t, n)).collect();
    // At least as many bytes as the text holds: every field quoted with
    // its quotes doubled, and a separator after each.
    let mut text = names.iter().map(|n| 2 * n.len() as u64 + 3).sum::<u64>();
    let mut out = Vec::new();
    for (g, &n) in file.groups().iter().enumerate() {
        let mut group = file.group(g)?;
        let mut done = 0;
        while done < n {
            let take = (n - done).min(batch.max(1));
            for (part, column) in parts.iter_mut().zip(group.next(take)) {
                text = text.saturating_add(part.fill(&column?)?);
            }
            if text > limit {
                return None;
            }
            for row in 0..take {
                out.push(replication(&Row { row, parts: &parts }, 0, &loc, &at).ok()?);
            }
            done += take;
        }
    }
    (!out.is_empty()).then(|| (out, unused_columns(&header, cols)))
}

/// One column of a batch of rows: each row's field (trimmed) where the
/// replications read it as text, its number where they read it as one.
struct Part {
    /// Whether the fields are kept as text, as numbers.
    keep: (bool, bool),
    texts: Vec<String>,
    numbers: Vec<Option<f64>>,
}

impl Part {
    /// The empty part of a column read as text (`texts`), as numbers, or
    /// neither.
    fn new(texts: bool, numbers: bool) -> Part {
        Part { keep: (texts, numbers), texts: Vec::new(), numbers: Vec::new() }
    }

    /// The fields and numbers of `column` in place of the part's, and at
    /// least as many bytes as their text holds; `None` where a field is no
    /// UTF-8 text (read or not, the text's reader refuses it), or where the
    /// column is damaged.
    fn fill(&mut self, column: &DecodedColumn) -> Option<u64> {
        let ((texts, numbers), keep) = ((&mut self.texts, &mut self.numbers), self.keep);
        texts.clear();
        numbers.clear();
        if !column.whole() {
            return None;
        }
        if !column.is_text() {
            // A column of numbers (or booleans): each number as decoded
            // (a missing value or any NaN the NaN its text's `NaN` or
            // empty field reads as), each name as the text writes it.
            if keep.1 {
                column.numbers(|x| {
                    numbers.push(Some(x.filter(|x| !x.is_nan()).unwrap_or(f64::NAN)));
                    Some(())
                })?;
            }
            if keep.0 {
                column.fields(|t| {
                    texts.push(t.trim().to_string());
                    Some(())
                })?;
            }
            return Some(column.rows() as u64 * NUMBER_TEXT);
        }
        // A column of text: each field as the text's reader reads it, and
        // parsed as that reader parses it.
        let mut bytes = 0u64;
        column.fields(|t| {
            bytes += 2 * t.len() as u64 + 3;
            let t = t.trim();
            if keep.1 {
                numbers.push(number(t));
            }
            if keep.0 {
                texts.push(t.to_string());
            }
            Some(())
        })?;
        Some(bytes)
    }
}

/// Row `row` of a batch, as the text's row gives its fields.
struct Row<'a> {
    row: usize,
    parts: &'a [Part],
}

impl Fields for Row<'_> {
    fn text(&self, k: usize) -> &str {
        self.parts.get(k).and_then(|p| p.texts.get(self.row)).map_or("", String::as_str)
    }

    fn number(&self, k: usize) -> Option<f64> {
        self.parts.get(k).and_then(|p| p.numbers.get(self.row)).copied().flatten()
    }
}

#[cfg(test)]
mod tests;
