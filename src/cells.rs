//! The per-cell CSV: the interface between running a study and analysing
//! it. One row per (model, arm, seed, recording, horizon), and per split in
//! a multi-split study.
//!
//! The header is [`HEADER`], with two optional columns: `split` first, in a
//! multi-split study, and `dose` after `arm` (the percentage of the
//! reference arm's windows replaced; 0 for the reference) in a
//! dose-response study. A file without them is read as before.

use std::path::Path;
use std::sync::atomic::{AtomicU8, Ordering};

use serde::Serialize;

use crate::io::{f64_text, opt_f64_text};
use crate::label::Label;

mod columns;
mod hashed;
mod origin;
mod row;
#[cfg(test)]
mod tests;
mod write;

// The row reader, for the two file readers here.
pub(crate) use row::{cell_of, Names};

pub use hashed::{file_sha256, last_line_open, read_cells_hashed};
pub use origin::Origin;
pub use write::{cells_bytes, write_cells, write_cells_and_parquet, write_cells_atomic};

/// The exact header, in order.
pub const HEADER: [&str; 14] = [
    "model",
    "arm",
    "seed",
    "recording",
    "trajectory",
    "speed",
    "horizon_s",
    "n_starts",
    "n_divergent",
    "fa_position_rmse_m",
    "conditional_position_rmse_m",
    "divergence_rate",
    "velocity_rmse_mps",
    "attitude_rmse_deg",
];

/// One cell's metrics: a row of the per-cell CSV.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Cell {
    /// The split, in a multi-split study (column `split`).
    #[serde(skip)]
    pub split: Option<u64>,
    /// The dose in percent, in a dose-response study (column `dose`).
    #[serde(skip)]
    pub dose: Option<f64>,
    /// The model's name.
    pub model: Label,
    /// The arm it was fitted on.
    pub arm: Label,
    /// The training seed.
    pub seed: u64,
    /// The evaluation recording.
    pub recording: Label,
    /// The recording's trajectory family.
    pub trajectory: Label,
    /// The recording's speed label.
    pub speed: Label,
    /// The rollout horizon in seconds.
    #[serde(serialize_with = "f64_text")]
    pub horizon_s: f64,
    /// Rollout starts in the recording.
    pub n_starts: u32,
    /// Starts whose rollout diverged (left the cap or became non-finite).
    pub n_divergent: u32,
    /// Failure-aware position RMSE (m): a diverged rollout counts at the cap.
    #[serde(serialize_with = "f64_text")]
    pub fa_position_rmse_m: f64,
    /// Position RMSE over finite rollouts; empty when every start diverged.
    #[serde(serialize_with = "opt_f64_text")]
    pub conditional_position_rmse_m: Option<f64>,
    /// n_divergent / n_starts.
    #[serde(serialize_with = "f64_text")]
    pub divergence_rate: f64,
    /// Over finite rollouts; empty when every start diverged.
    #[serde(serialize_with = "opt_f64_text")]
    pub velocity_rmse_mps: Option<f64>,
    /// Over finite rollouts; empty when every start diverged.
    #[serde(serialize_with = "opt_f64_text")]
    pub attitude_rmse_deg: Option<f64>,
    /// Where it was read: a line of a CSV, a row of a Parquet file (line
    /// 0 when built in memory).
    #[serde(skip)]
    pub origin: Origin,
}

// 144 bytes a row (10 million rows: 1.44 GB): names are 4-byte labels,
// the counts and the origin 4-byte integers, packed together.
#[cfg(target_pointer_width = "64")]
const _: () = assert!(std::mem::size_of::<Cell>() == 144);

/// A problem in a per-cell file, located by file, line (a Parquet file's
/// row) and field.
#[derive(Debug, thiserror::Error)]
pub enum CellsError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// The file could not be written.
    #[error("cannot write {path}: {source}")]
    Write {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// The header is not the per-cell header.
    #[error("{path}: {}\n  expected: {expected}\n  found:    {found}{}", wrong_header(*at), header_hint(found))]
    Header {
        /// The file.
        path: String,
        /// Line 1 of a CSV; a Parquet file's column names.
        at: Origin,
        /// The header required.
        expected: String,
        /// The header found.
        found: String,
    },
    /// A row is not valid CSV or has the wrong number of fields.
    #[error("{path}: {at}: {message}")]
    Csv {
        /// The file.
        path: String,
        /// The line (a Parquet file's row).
        at: Origin,
        /// What is wrong.
        message: String,
    },
    /// A `.parquet` per-cell file that is no readable Parquet file.
    #[error("{path}: not a readable Parquet file: {message}")]
    NotParquet {
        /// The file.
        path: String,
        /// The decoder's words.
        message: String,
    },
    /// A field's value is impossible.
    #[error("{path}: {at}, field `{field}`: {problem} (value: {value:?})")]
    Field {
        /// The file.
        path: String,
        /// The line (a Parquet file's row).
        at: Origin,
        /// The column.
        field: &'static str,
        /// The value found.
        value: String,
        /// Why it is refused.
        problem: String,
    },
    /// A column empty in a row though not every start diverged, and with
    /// a value in another: a damaged file.
    #[error("{path}: {at}, field `{field}`: is empty, but not every start diverged and {valued} has a value (only a layout without this state leaves the column empty, in every row) (value: \"\")")]
    Gap {
        /// The file.
        path: String,
        /// The first row where it is empty.
        at: Origin,
        /// The column.
        field: &'static str,
        /// The first row where it has a value.
        valued: Origin,
    },
    /// The file has a header and no rows.
    #[error("{path}: no data rows")]
    Empty {
        /// The file.
        path: String,
    },
}

impl CellsError {
    /// The same error in the Parquet file whose CSV text was read: its
    /// lines named as the file's rows ([`Origin::in_parquet`]).
    fn in_parquet(self) -> CellsError {
        match self {
            CellsError::Header { path, at, expected, found } => {
                CellsError::Header { path, at: at.in_parquet(), expected, found }
            }
            CellsError::Csv { path, at, message } => CellsError::Csv { path, at: at.in_parquet(), message },
            CellsError::Field { path, at, field, value, problem } => {
                CellsError::Field { path, at: at.in_parquet(), field, value, problem }
            }
            CellsError::Gap { path, at, field, valued } => {
                CellsError::Gap { path, at: at.in_parquet(), field, valued: valued.in_parquet() }
            }
            other => other,
        }
    }
}

/// A wrong header, where it is: a CSV's line 1, a Parquet file's column
/// names.
fn wrong_header(at: Origin) -> String {
    match at.is_row() {
        true => "wrong column names".to_string(),
        false => format!("{at}: wrong header"),
    }
}

/// What a wrong header's columns suggest: pandas wrote its index (a first
/// column without a name in a CSV, which pandas reads back as
/// `Unnamed: 0`; `__index_level_0__` in a Parquet file).
fn header_hint(found: &str) -> &'static str {
    let fields = || found.split(',');
    if fields().any(|f| f.starts_with("__index_level_")) {
        "\n  (`__index_level_0__` is the index pandas wrote as a column: write the file with `to_parquet(path, index=False)`)"
    } else if found.starts_with(',') || found.starts_with("Unnamed: 0,") {
        "\n  (the first column is the index pandas wrote: write the file with `to_csv(path, index=False)`)"
    } else {
        ""
    }
}

/// Reads and checks every row of a per-cell CSV (or its Parquet twin, a
/// `.parquet` file with the same columns). Checks here are the ones a row
/// can fail on its own; cross-row checks (missing or duplicate cells)
/// belong to the analysis, which knows the design.
pub fn read_cells(path: &Path) -> Result<Vec<Cell>, CellsError> {
    read_cells_with(path, false).map(|(cells, _)| cells)
}

/// [`read_cells`], and with `hash`, the SHA-256 of the file's bytes taken
/// as they were read (`None` where the reference reader read them, which
/// hashes nothing).
fn read_cells_with(path: &Path, hash: bool) -> Result<(Vec<Cell>, Option<String>), CellsError> {
    use sha2::Digest;
    let p = path.display().to_string();
    let limit = crate::io::MAX_CELLS_FILE;
    // A Parquet file (`.parquet`) with the same columns: its cells taken
    // from its decoded columns where they are the ones its CSV text gives;
    // anywhere else, its rows as the CSV text crossaudit would write for
    // them, read by the same reader, so its errors name the same rows and
    // fields (row L of the file is line L + 1).
    if crate::io::parquet::is_parquet(path) {
        let raw = bytes::Bytes::from(
            crate::io::read_input(path, limit, "a per-cell Parquet file")
                .map_err(|e| CellsError::Io { path: p.clone(), source: e.into_io() })?,
        );
        // The file hashed on one core while the others read its columns.
        let (sha, cells) = rayon::join(
            || hash.then(|| crate::io::sha256_hex(&raw)),
            || crate::io::parquet::open_columns(raw.clone(), limit).and_then(|f| columns::from_columns(&f, limit)),
        );
        if let Some(cells) = cells {
            return Ok((cells, sha));
        }
        let text = crate::io::parquet::to_csv_text(raw, limit, "a per-cell file")
            .map_err(|message| CellsError::NotParquet { path: p.clone(), message })?;
        let chunked = read_chunked(&p, (text.as_slice(), text.len() as u64), crate::io::chunked::CHUNK, |_| {});
        let mut cells = match chunked {
            Some(cells) => cells,
            None => read_cells_from(&p, text.as_slice()).map_err(CellsError::in_parquet)?,
        };
        cells.iter_mut().for_each(|c| c.origin = c.origin.in_parquet());
        return Ok((cells, sha));
    }
    crate::io::check_regular(path, limit, "a per-cell CSV")
        .map_err(|e| CellsError::Io { path: p.clone(), source: e.into_io() })?;
    let open = || std::fs::File::open(path).map_err(|source| CellsError::Io { path: p.clone(), source });
    // On every core where it can; where it cannot, or the file has an
    // error, the reference reader reads it and says where.
    let file = open()?;
    let size = file.metadata().map_or(0, |m| m.len());
    let mut hasher = hash.then(sha2::Sha256::new);
    let seen = |bytes: &[u8]| hasher.iter_mut().for_each(|h| h.update(bytes));
    if let Some(cells) = read_chunked(&p, (file, size), crate::io::chunked::CHUNK, seen) {
        return Ok((cells, hasher.map(|h| crate::io::hex(&h.finalize()))));
    }
    Ok((read_cells_from(&p, open()?)?, None))
}

/// The cells of the per-cell CSV `reader` (named `name`), read on every
/// core by `io::chunked` in chunks of about `chunk` bytes; `None` where
/// [`read_cells_from`] must read it (and, for a file with an error, say
/// where).
fn read_chunked(
    name: &str,
    (reader, size): (impl std::io::Read + Send, u64),
    chunk: usize,
    seen: impl FnMut(&[u8]) + Send,
) -> Option<Vec<Cell>> {
    let header = |h: &csv::StringRecord| {
        let found: Vec<&str> = h.iter().collect();
        let has_split = found.first() == Some(&"split");
        let has_dose = found.get(usize::from(has_split) + 2) == Some(&"dose");
        (found == header_for(has_split, has_dose)).then_some((has_split, has_dose))
    };
    // The kinds of emptiness any row has shown (`Emptiness::kinds`), noted
    // as the rows are parsed: each core's state notes a kind once.
    let kinds = AtomicU8::new(0);
    let row = |&(split, dose): &(bool, bool), line, fields: &[&str], names: &mut Names| {
        let cell = cell_of(name, line, fields, split, dose, names).ok()?;
        let new = Emptiness::kinds(&cell) & !names.kinds;
        if new != 0 {
            names.kinds |= new;
            kinds.fetch_or(new, Ordering::Relaxed);
        }
        Some(cell)
    };
    // What stands in for a refused row, which gives the read up.
    let fill = blank();
    let limits = (crate::io::MAX_CELLS_FILE, size, chunk);
    let cells = crate::io::chunked::read(reader, limits, header, (row, &fill), seen)?;
    // A column with a value in one row and a gap in another is damaged:
    // the reference reader finds the lines to name.
    (!cells.is_empty() && !Emptiness::damaged(kinds.into_inner())).then_some(cells)
}

/// A cell of no row: what stands in for a row not read yet (or refused).
fn blank() -> Cell {
    Cell {
        split: None,
        dose: None,
        model: Label::default(),
        arm: Label::default(),
        seed: 0,
        recording: Label::default(),
        trajectory: Label::default(),
        speed: Label::default(),
        horizon_s: 0.0,
        n_starts: 0,
        n_divergent: 0,
        fa_position_rmse_m: 0.0,
        conditional_position_rmse_m: None,
        divergence_rate: 0.0,
        velocity_rmse_mps: None,
        attitude_rmse_deg: None,
        origin: Origin::default(),
    }
}

/// As [`read_cells`], from any reader; `name` is used in messages. The
/// rows are parsed as they stream in: memory holds the cells, not the text.
pub fn read_cells_from(name: &str, reader: impl std::io::Read) -> Result<Vec<Cell>, CellsError> {
    // Lines are counted here: the csv crate's count is one short after
    // each `\r\n`, the line ending Python's csv module writes.
    let counted = crate::io::LineCounting::new(reader, crate::io::MAX_CELLS_FILE);
    let mut rdr = csv::ReaderBuilder::new().has_headers(true).flexible(false).from_reader(counted);
    let io_error = |e: &csv::Error| match e.kind() {
        csv::ErrorKind::Io(io) => {
            Some(CellsError::Io { path: name.to_string(), source: std::io::Error::new(io.kind(), io.to_string()) })
        }
        _ => None,
    };
    let header = rdr
        .headers()
        .map_err(|e| {
            io_error(&e).unwrap_or(CellsError::Csv {
                path: name.to_string(),
                at: Origin::line(1),
                message: e.to_string(),
            })
        })?
        .clone();
    let found: Vec<&str> = header.iter().collect();
    let has_split = found.first() == Some(&"split");
    let has_dose = found.get(usize::from(has_split) + 2) == Some(&"dose");
    if found != header_for(has_split, has_dose) {
        return Err(CellsError::Header {
            path: name.to_string(),
            at: Origin::line(1),
            expected: format!("{} (optionally `split` first and `dose` after `arm`)", HEADER.join(",")),
            found: found.join(","),
        });
    }
    let mut cells = Vec::new();
    let mut emptiness = Emptiness::default();
    let mut names = Names::default();
    // One record, reused: a row's fields are borrowed from it, not copied.
    let mut rec = csv::StringRecord::new();
    let line_of = |rdr: &csv::Reader<crate::io::LineCounting<_>>, p: Option<&csv::Position>| {
        p.map(|p| rdr.get_ref().line_of(p.byte() as usize) as u64).unwrap_or(0)
    };
    loop {
        match rdr.read_record(&mut rec) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => {
                if let Some(io) = io_error(&e) {
                    return Err(io);
                }
                let line = line_of(&rdr, e.position());
                return Err(CellsError::Csv {
                    path: name.to_string(),
                    at: Origin::line(line),
                    message: csv_message(&e),
                });
            }
        }
        let line = line_of(&rdr, rec.position());
        let fields: Vec<&str> = rec.iter().collect();
        let cell = cell_of(name, line, &fields, has_split, has_dose, &mut names)?;
        emptiness.see(&cell);
        cells.push(cell);
    }
    if cells.is_empty() {
        return Err(CellsError::Empty { path: name.to_string() });
    }
    emptiness.check(name)?;
    Ok(cells)
}

/// Where the velocity and attitude RMSE are empty though not every start
/// diverged, and where they have a value. A layout without a velocity (or
/// attitude) leaves its column empty in every row; a file with values in
/// some rows and such gaps in others is damaged.
#[derive(Default)]
struct Emptiness {
    /// Per column: the first line with a value, and the first line empty
    /// though not every start diverged.
    seen: [(Option<Origin>, Option<Origin>); 2],
}

impl Emptiness {
    const FIELDS: [&'static str; 2] = ["velocity_rmse_mps", "attitude_rmse_deg"];

    /// What row `c` shows, as bits: for column k (velocity, attitude), bit
    /// 2k where it has a value, bit 2k + 1 where it is empty though not
    /// every start diverged.
    fn kinds(c: &Cell) -> u8 {
        let all_diverged = c.n_divergent == c.n_starts;
        let of = |v: Option<f64>| match v {
            Some(_) => 0b01,
            None if !all_diverged => 0b10,
            None => 0,
        };
        of(c.velocity_rmse_mps) | of(c.attitude_rmse_deg) << 2
    }

    /// Whether rows that showed `kinds` between them damage a column.
    fn damaged(kinds: u8) -> bool {
        (0..Self::FIELDS.len()).any(|k| kinds >> (2 * k) & 0b11 == 0b11)
    }

    fn see(&mut self, c: &Cell) {
        let kinds = Self::kinds(c);
        for (k, (value, gap)) in self.seen.iter_mut().enumerate() {
            if kinds >> (2 * k) & 0b01 != 0 {
                *value = value.or(Some(c.origin));
            }
            if kinds >> (2 * k) & 0b10 != 0 {
                *gap = gap.or(Some(c.origin));
            }
        }
    }

    fn check(&self, name: &str) -> Result<(), CellsError> {
        for (k, (value, gap)) in self.seen.iter().enumerate() {
            if let (Some(value), Some(gap)) = (value, gap) {
                let (at, field, valued) = (*gap, Self::FIELDS[k], *value);
                return Err(CellsError::Gap { path: name.to_string(), at, field, valued });
            }
        }
        Ok(())
    }
}

fn csv_message(e: &csv::Error) -> String {
    match e.kind() {
        csv::ErrorKind::UnequalLengths { expected_len, len, .. } => {
            format!("row has {len} fields, the header has {expected_len}")
        }
        _ => e.to_string(),
    }
}

/// The header with the optional columns.
fn header_for(split: bool, dose: bool) -> Vec<&'static str> {
    let mut h: Vec<&'static str> = Vec::with_capacity(HEADER.len() + 2);
    if split {
        h.push("split");
    }
    h.extend(&HEADER[..2]);
    if dose {
        h.push("dose");
    }
    h.extend(&HEADER[2..]);
    h
}
