//! A per-cell Parquet file's cells taken from its decoded columns,
//! without writing its CSV text: each value as the text's reader reads
//! it (`io::parquet::DecodedColumn`), and every check a row of that text
//! must pass. Anything the reader would refuse, or read otherwise than
//! the values say (a name that is not printable ASCII, whose line breaks
//! the text writes as spaces; a count or seed that is no integer column;
//! a row that fails a check; a damaged column), gives `None`: the text's
//! reader then reads the file and says where and why it refuses, so a
//! file gives the same cells, or the same error, either way.

use std::sync::atomic::{AtomicBool, Ordering};

use super::row::trim;
use super::{blank, header_for, Cell, Emptiness, Origin};
use crate::io::parquet::{ColumnFile, DecodedColumn, NUMBER_TEXT};
use crate::label::{Interner, Label};

/// Rows decoded at a time: every column's values for them are held, then
/// their cells made.
const BATCH: usize = 65_536;

/// The cells of `file`, a per-cell Parquet file, from its columns; `None`
/// where its text must be read (among others, where that text might pass
/// `limit` bytes, which its reader refuses).
pub(super) fn from_columns(file: &ColumnFile, limit: u64) -> Option<Vec<Cell>> {
    from_columns_in(file, BATCH, limit)
}

/// [`from_columns`], `batch` rows at a time: each batch's columns decoded
/// and read on every core, then its cells made on every core, each in its
/// place.
pub(super) fn from_columns_in(file: &ColumnFile, batch: usize, limit: u64) -> Option<Vec<Cell>> {
    use rayon::prelude::*;
    let names = file.names();
    let has_split = names.first().is_some_and(|n| n == "split");
    let has_dose = names.get(usize::from(has_split) + 2).is_some_and(|n| n == "dose");
    if !names.iter().map(String::as_str).eq(header_for(has_split, has_dose)) {
        return None;
    }
    let rows: usize = file.groups().iter().sum();
    // A cell records its row in 4 bytes.
    if rows == 0 || rows as u64 > Origin::MAX {
        return None;
    }
    // Room is made a batch at a time: the footer's count of rows is not
    // trusted with an allocation.
    let mut cells = Vec::new();
    // Each column's values for a batch, and the interner of each column
    // of names, kept from batch to batch.
    let mut parts: Vec<Part> = names.iter().map(|n| Part::for_column(n)).collect();
    let mut interners: Vec<Interner> = names.iter().map(|_| Interner::default()).collect();
    let mut kinds = 0;
    // At least as many bytes as the text would hold: its header line, then
    // each row's separators and each value's text at its longest.
    let mut text = names.iter().map(|n| n.len() as u64 + 1).sum::<u64>();
    for (g, &n) in file.groups().iter().enumerate() {
        let mut group = file.group(g)?;
        let mut done = 0;
        while done < n {
            let take = (n - done).min(batch.max(1));
            // One column a task: the columns of names take longest.
            let read = (parts.par_iter_mut().zip(group.next(take)).zip(interners.par_iter_mut()))
                .with_max_len(1)
                .map(|((part, column), interner)| part.fill(&column?, interner))
                .collect::<Option<Vec<u64>>>();
            text = read?.into_iter().fold(text + (take * names.len()) as u64, u64::saturating_add);
            if text > limit {
                return None;
            }
            // The batch's cells made on every core, each in its place; a
            // row that fails a check stands as a blank one and gives the
            // read up.
            let view = View::of(&names, &parts)?;
            let (first, refused) = (cells.len(), AtomicBool::new(false));
            // first + take <= rows, which fits 4 bytes (above).
            cells.par_extend((0..take).into_par_iter().map(|i| {
                view.cell(i, Origin::row((first + i + 1) as u64)).unwrap_or_else(|| {
                    refused.store(true, Ordering::Relaxed);
                    blank()
                })
            }));
            if refused.into_inner() {
                return None;
            }
            kinds |= cells[first..].par_iter().map(Emptiness::kinds).reduce(|| 0, |a, b| a | b);
            done += take;
        }
    }
    (!Emptiness::damaged(kinds)).then_some(cells)
}

/// One column of a batch of rows, as its cells take it.
enum Part {
    Labels(Vec<Label>),
    Integers(Vec<u64>),
    Counts(Vec<u32>),
    Numbers(Vec<f64>),
    Optional(Vec<Option<f64>>),
}

impl Part {
    /// The empty part of column `name`.
    fn for_column(name: &str) -> Part {
        match name {
            "split" | "seed" => Part::Integers(Vec::new()),
            "n_starts" | "n_divergent" => Part::Counts(Vec::new()),
            "dose" | "horizon_s" | "fa_position_rmse_m" | "divergence_rate" => Part::Numbers(Vec::new()),
            "conditional_position_rmse_m" | "velocity_rmse_mps" | "attitude_rmse_deg" => Part::Optional(Vec::new()),
            _ => Part::Labels(Vec::new()),
        }
    }

    /// The values of `column` in place of the part's (a column of names
    /// interned by `interner`), and at least as many bytes as their text
    /// holds; `None` where one is a value the text's reader would refuse or
    /// read otherwise.
    fn fill(&mut self, column: &DecodedColumn, interner: &mut Interner) -> Option<u64> {
        let numbers = column.rows() as u64 * NUMBER_TEXT;
        match self {
            Part::Labels(v) => labels(column, interner, v),
            Part::Integers(v) => integers(column, v).map(|()| numbers),
            Part::Counts(v) => integers(column, v).map(|()| numbers),
            Part::Numbers(v) => {
                v.clear();
                column.numbers(|x| {
                    v.push(x.filter(|&x| plausible(x))?);
                    Some(())
                })?;
                Some(numbers)
            }
            Part::Optional(v) => {
                v.clear();
                column.numbers(|x| {
                    if x.is_some_and(|x| !plausible(x)) {
                        return None;
                    }
                    v.push(x);
                    Some(())
                })?;
                Some(numbers)
            }
        }
    }
}

/// A batch's columns as a cell's fields take them (a column the file has
/// not, `split` or `dose`, empty).
#[derive(Default)]
struct View<'a> {
    split: &'a [u64],
    dose: &'a [f64],
    labels: [&'a [Label]; 5],
    seed: &'a [u64],
    n_starts: &'a [u32],
    n_divergent: &'a [u32],
    horizon_s: &'a [f64],
    fa_position_rmse_m: &'a [f64],
    divergence_rate: &'a [f64],
    conditional_position_rmse_m: &'a [Option<f64>],
    velocity_rmse_mps: &'a [Option<f64>],
    attitude_rmse_deg: &'a [Option<f64>],
}

/// The label columns, in the order of [`View::labels`].
const LABELS: [&str; 5] = ["model", "arm", "recording", "trajectory", "speed"];

/// Whether a number passes the checks of a metric, a horizon or a dose:
/// finite, not negative, and 0 or at least `io::MIN_MAGNITUDE`.
fn plausible(x: f64) -> bool {
    x.is_finite() && x >= 0.0 && (x == 0.0 || x >= crate::io::MIN_MAGNITUDE)
}

/// `column`'s integers into `out`, each one a `T` holds (none negative; a
/// count at most `u32::MAX`); no null.
fn integers<T: TryFrom<i64>>(column: &DecodedColumn, out: &mut Vec<T>) -> Option<()> {
    out.clear();
    column.integers(|v| {
        out.push(T::try_from(v?).ok()?);
        Some(())
    })
}

impl<'a> View<'a> {
    /// The columns `parts`, named `names`; `None` where a part is not its
    /// column's.
    fn of(names: &[String], parts: &'a [Part]) -> Option<View<'a>> {
        let mut v = View::default();
        for (name, part) in names.iter().zip(parts) {
            match (name.as_str(), part) {
                ("split", Part::Integers(x)) => v.split = x,
                ("seed", Part::Integers(x)) => v.seed = x,
                ("n_starts", Part::Counts(x)) => v.n_starts = x,
                ("n_divergent", Part::Counts(x)) => v.n_divergent = x,
                ("dose", Part::Numbers(x)) => v.dose = x,
                ("horizon_s", Part::Numbers(x)) => v.horizon_s = x,
                ("fa_position_rmse_m", Part::Numbers(x)) => v.fa_position_rmse_m = x,
                ("divergence_rate", Part::Numbers(x)) => v.divergence_rate = x,
                ("conditional_position_rmse_m", Part::Optional(x)) => v.conditional_position_rmse_m = x,
                ("velocity_rmse_mps", Part::Optional(x)) => v.velocity_rmse_mps = x,
                ("attitude_rmse_deg", Part::Optional(x)) => v.attitude_rmse_deg = x,
                (name, Part::Labels(x)) => v.labels[LABELS.iter().position(|l| *l == name)?] = x,
                _ => return None,
            }
        }
        Some(v)
    }

    /// Row `i`'s cell, read at `origin`, where it passes the checks a row
    /// must pass beyond its fields' own (`row::parse_row`'s): at least one
    /// start, no more divergent starts than starts, a horizon above 0, a
    /// divergence rate that is their ratio, a dose of at most 100, and a
    /// conditional RMSE empty only where every start diverged.
    fn cell(&self, i: usize, origin: Origin) -> Option<Cell> {
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
            origin,
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

/// `column`'s names into `out`, each interned as the text's reader
/// interns it: printable ASCII only (the text carries a line break as a
/// space, and the reader refuses other control characters), trimmed, not
/// empty; a name equal to the row's before takes its label at once. With
/// at least as many bytes as their text holds (each quoted, every quote
/// doubled, at worst).
fn labels(column: &DecodedColumn, interner: &mut Interner, out: &mut Vec<Label>) -> Option<u64> {
    out.clear();
    let mut last: Option<(&[u8], Label)> = None;
    let mut text = 0u64;
    column.texts(|v| {
        let v = v?;
        text += 2 * v.len() as u64 + 2;
        let label = match last {
            Some((bytes, label)) if bytes == v => label,
            _ => {
                let text = std::str::from_utf8(v).ok().filter(|t| t.bytes().all(|b| (0x20..0x7f).contains(&b)))?;
                let t = trim(text);
                if t.is_empty() {
                    return None;
                }
                interner.get(t)
            }
        };
        out.push(label);
        last = Some((v, label));
        Some(())
    })?;
    Some(text)
}
