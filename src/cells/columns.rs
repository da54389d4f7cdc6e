//! A per-cell Parquet file's cells taken from its decoded columns,
//! without writing its CSV text: each value as the text's reader reads
//! it (`io::parquet::DecodedColumn`), and every check a row of that text
//! must pass. Anything the reader would refuse, or read otherwise than
//! the values say (a name that is not printable ASCII, whose line breaks
//! the text writes as spaces; a count or seed that is no integer column;
//! a row that fails a check; a damaged column), gives `None`: the text's
//! reader then reads the file and says where and why it refuses, so a
//! file gives the same cells, or the same error, either way.

use super::row::{trim, Names};
use super::{header_for, Cell, Emptiness};
use crate::io::parquet::{ColumnFile, DecodedColumn};
use crate::label::Label;

/// Rows decoded at a time: every column's values for them are held, then
/// their cells made.
const BATCH: usize = 65_536;

/// The cells of `file`, a per-cell Parquet file, from its columns; `None`
/// where its text must be read.
pub(super) fn from_columns(file: &ColumnFile) -> Option<Vec<Cell>> {
    from_columns_in(file, BATCH)
}

/// [`from_columns`], `batch` rows at a time.
pub(super) fn from_columns_in(file: &ColumnFile, batch: usize) -> Option<Vec<Cell>> {
    let names = file.names();
    let has_split = names.first().is_some_and(|n| n == "split");
    let has_dose = names.get(usize::from(has_split) + 2).is_some_and(|n| n == "dose");
    if !names.iter().map(String::as_str).eq(header_for(has_split, has_dose)) {
        return None;
    }
    let rows: usize = file.groups().iter().sum();
    // A cell records its line (its row + 1) in 4 bytes.
    if rows == 0 || u32::try_from(rows + 1).is_err() {
        return None;
    }
    let mut cells = Vec::with_capacity(rows);
    let (mut labels, mut rows_of, mut kinds) = (Names::default(), Batch::default(), 0);
    for (g, &n) in file.groups().iter().enumerate() {
        let mut group = file.group(g)?;
        let mut done = 0;
        while done < n {
            let take = (n - done).min(batch.max(1));
            for (c, name) in names.iter().enumerate() {
                rows_of.take(name, &group.next(c, take)?, &mut labels)?;
            }
            for i in 0..take {
                let cell = rows_of.cell(i, u32::try_from(cells.len() + 2).ok()?)?;
                kinds |= Emptiness::kinds(&cell);
                cells.push(cell);
            }
            done += take;
        }
    }
    (!Emptiness::damaged(kinds)).then_some(cells)
}

/// One batch of rows, column by column, as their cells take them.
#[derive(Default)]
struct Batch {
    split: Vec<u64>,
    dose: Vec<f64>,
    labels: [Vec<Label>; 5],
    seed: Vec<u64>,
    n_starts: Vec<u32>,
    n_divergent: Vec<u32>,
    horizon_s: Vec<f64>,
    fa_position_rmse_m: Vec<f64>,
    divergence_rate: Vec<f64>,
    conditional_position_rmse_m: Vec<Option<f64>>,
    velocity_rmse_mps: Vec<Option<f64>>,
    attitude_rmse_deg: Vec<Option<f64>>,
}

/// The label columns, in the order of [`Batch::labels`].
const LABELS: [&str; 5] = ["model", "arm", "recording", "trajectory", "speed"];

/// Whether a number passes the checks of a metric, a horizon or a dose:
/// finite, not negative, and 0 or at least `io::MIN_MAGNITUDE`.
fn plausible(x: f64) -> bool {
    x.is_finite() && x >= 0.0 && (x == 0.0 || x >= crate::io::MIN_MAGNITUDE)
}

/// `column`'s numbers, each plausible or (with `optional`) empty.
fn numbers(column: &DecodedColumn, optional: bool, out: &mut Vec<Option<f64>>) -> Option<()> {
    out.clear();
    for v in column.numbers()? {
        match v {
            Some(x) if plausible(x) => out.push(Some(x)),
            None if optional => out.push(None),
            _ => return None,
        }
    }
    Some(())
}

/// `column`'s integers, each one a `T` holds (none negative; a count at
/// most `u32::MAX`); no null.
fn integers<T: TryFrom<i64>>(column: &DecodedColumn, out: &mut Vec<T>) -> Option<()> {
    out.clear();
    for v in column.integers()? {
        out.push(T::try_from(v?).ok()?);
    }
    Some(())
}

impl Batch {
    /// Takes column `name`'s values from `column`; `None` where one is a
    /// value the text's reader would refuse or read otherwise.
    fn take(&mut self, name: &str, column: &DecodedColumn, names: &mut Names) -> Option<()> {
        let mut optional = Vec::new();
        let required = |out: &mut Vec<f64>, scratch: &mut Vec<Option<f64>>| {
            numbers(column, false, scratch)?;
            out.clear();
            out.extend(scratch.iter().flatten());
            Some(())
        };
        match name {
            "split" => integers(column, &mut self.split),
            "seed" => integers(column, &mut self.seed),
            "n_starts" => integers(column, &mut self.n_starts),
            "n_divergent" => integers(column, &mut self.n_divergent),
            "dose" => required(&mut self.dose, &mut optional),
            "horizon_s" => required(&mut self.horizon_s, &mut optional),
            "fa_position_rmse_m" => required(&mut self.fa_position_rmse_m, &mut optional),
            "divergence_rate" => required(&mut self.divergence_rate, &mut optional),
            "conditional_position_rmse_m" => numbers(column, true, &mut self.conditional_position_rmse_m),
            "velocity_rmse_mps" => numbers(column, true, &mut self.velocity_rmse_mps),
            "attitude_rmse_deg" => numbers(column, true, &mut self.attitude_rmse_deg),
            _ => {
                let k = LABELS.iter().position(|l| *l == name)?;
                labels(column, names.interner(name)?, &mut self.labels[k])
            }
        }
    }

    /// Row `i`'s cell, on line `line`, where it passes the checks a row
    /// must pass beyond its fields' own (`row::parse_row`'s): at least one
    /// start, no more divergent starts than starts, a horizon above 0, a
    /// divergence rate that is their ratio, a dose of at most 100, and a
    /// conditional RMSE empty only where every start diverged.
    fn cell(&self, i: usize, line: u32) -> Option<Cell> {
        let label = |k: usize| self.labels[k].get(i).copied();
        let c = Cell {
            split: self.split.get(i).copied(),
            dose: self.dose.get(i).copied(),
            model: label(0)?,
            arm: label(1)?,
            seed: *self.seed.get(i)?,
            recording: label(2)?,
            trajectory: label(3)?,
            speed: label(4)?,
            horizon_s: *self.horizon_s.get(i)?,
            n_starts: *self.n_starts.get(i)?,
            n_divergent: *self.n_divergent.get(i)?,
            fa_position_rmse_m: *self.fa_position_rmse_m.get(i)?,
            conditional_position_rmse_m: *self.conditional_position_rmse_m.get(i)?,
            divergence_rate: *self.divergence_rate.get(i)?,
            velocity_rmse_mps: *self.velocity_rmse_mps.get(i)?,
            attitude_rmse_deg: *self.attitude_rmse_deg.get(i)?,
            line,
        };
        let expected = f64::from(c.n_divergent) / f64::from(c.n_starts);
        let consistent = c.n_starts >= 1
            && c.n_divergent <= c.n_starts
            && c.horizon_s > 0.0
            && (c.divergence_rate - expected).abs() <= 1e-6
            && c.dose.is_none_or(|d| d <= 100.0)
            && (c.conditional_position_rmse_m.is_some() || c.n_divergent == c.n_starts);
        consistent.then_some(c)
    }
}

/// `column`'s names, each interned as the text's reader interns it:
/// printable ASCII only (the text carries a line break as a space, and
/// the reader refuses other control characters), trimmed, not empty. A
/// name equal to the row's before takes its label at once.
fn labels(column: &DecodedColumn, interner: &mut crate::label::Interner, out: &mut Vec<Label>) -> Option<()> {
    out.clear();
    let mut last: Option<(&[u8], Label)> = None;
    for v in column.texts()? {
        let v = v?;
        if let Some((bytes, label)) = last.filter(|(bytes, _)| *bytes == v) {
            out.push(label);
            last = Some((bytes, label));
            continue;
        }
        let text = std::str::from_utf8(v).ok().filter(|t| t.bytes().all(|b| (0x20..0x7f).contains(&b)))?;
        let t = trim(text);
        if t.is_empty() {
            return None;
        }
        let label = interner.get(t);
        out.push(label);
        last = Some((v, label));
    }
    Some(())
}
