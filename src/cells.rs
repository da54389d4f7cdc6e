//! The per-cell CSV: the interface between running a study and analysing
//! it. One row per (model, arm, seed, recording, horizon).

use std::path::Path;

use serde::Serialize;

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

/// One cell's metrics.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Cell {
    pub model: String,
    pub arm: String,
    pub seed: u64,
    pub recording: String,
    pub trajectory: String,
    pub speed: String,
    pub horizon_s: f64,
    pub n_starts: u64,
    pub n_divergent: u64,
    pub fa_position_rmse_m: f64,
    /// Empty when every start diverged.
    pub conditional_position_rmse_m: Option<f64>,
    pub divergence_rate: f64,
    /// Over finite rollouts; empty when every start diverged.
    pub velocity_rmse_mps: Option<f64>,
    pub attitude_rmse_deg: Option<f64>,
    /// 1-based line in the file it was read from (0 when built in memory).
    #[serde(skip)]
    pub line: u64,
}

/// A problem in a per-cell file, located by file, line and field.
#[derive(Debug, thiserror::Error)]
pub enum CellsError {
    #[error("cannot read {path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{path}: line 1: wrong header\n  expected: {expected}\n  found:    {found}")]
    Header { path: String, expected: String, found: String },
    #[error("{path}: line {line}: {message}")]
    Csv { path: String, line: u64, message: String },
    #[error("{path}: line {line}, field `{field}`: {problem} (value: {value:?})")]
    Field { path: String, line: u64, field: &'static str, value: String, problem: String },
    #[error("{path}: no data rows")]
    Empty { path: String },
}

/// Reads and checks every row of a per-cell CSV. Checks here are the ones a
/// row can fail on its own; cross-row checks (missing or duplicate cells)
/// belong to the analysis, which knows the design.
pub fn read_cells(path: &Path) -> Result<Vec<Cell>, CellsError> {
    let p = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|source| CellsError::Io { path: p.clone(), source })?;
    read_cells_from(&p, file)
}

/// As [`read_cells`], from any reader; `name` is used in messages.
pub fn read_cells_from(name: &str, reader: impl std::io::Read) -> Result<Vec<Cell>, CellsError> {
    let mut rdr = csv::ReaderBuilder::new().has_headers(true).flexible(false).from_reader(reader);
    let header =
        rdr.headers().map_err(|e| CellsError::Csv { path: name.to_string(), line: 1, message: e.to_string() })?.clone();
    let found: Vec<&str> = header.iter().collect();
    if found != HEADER {
        return Err(CellsError::Header { path: name.to_string(), expected: HEADER.join(","), found: found.join(",") });
    }
    let mut cells = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| {
            let line = e.position().map(|p| p.line()).unwrap_or(0);
            CellsError::Csv { path: name.to_string(), line, message: csv_message(&e) }
        })?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        cells.push(parse_row(name, line, &rec)?);
    }
    if cells.is_empty() {
        return Err(CellsError::Empty { path: name.to_string() });
    }
    Ok(cells)
}

fn csv_message(e: &csv::Error) -> String {
    match e.kind() {
        csv::ErrorKind::UnequalLengths { expected_len, len, .. } => {
            format!("row has {len} fields, the header has {expected_len}")
        }
        _ => e.to_string(),
    }
}

struct Row<'a> {
    name: &'a str,
    line: u64,
    rec: &'a csv::StringRecord,
}

impl Row<'_> {
    fn text(&self, k: usize) -> &str {
        self.rec.get(k).unwrap_or("")
    }

    fn fail(&self, k: usize, problem: impl Into<String>) -> CellsError {
        CellsError::Field {
            path: self.name.to_string(),
            line: self.line,
            field: HEADER[k],
            value: self.text(k).to_string(),
            problem: problem.into(),
        }
    }

    fn label(&self, k: usize) -> Result<String, CellsError> {
        let t = self.text(k).trim();
        if t.is_empty() {
            return Err(self.fail(k, "is empty"));
        }
        Ok(t.to_string())
    }

    fn uint(&self, k: usize) -> Result<u64, CellsError> {
        self.text(k).trim().parse::<u64>().map_err(|_| self.fail(k, "is not a non-negative integer"))
    }

    fn float(&self, k: usize) -> Result<f64, CellsError> {
        let t = self.text(k).trim();
        if t.is_empty() {
            return Err(self.fail(k, "is empty"));
        }
        let v: f64 = t.parse().map_err(|_| self.fail(k, "is not a number"))?;
        if !v.is_finite() {
            return Err(self.fail(k, "is not finite"));
        }
        if v < 0.0 {
            return Err(self.fail(k, "is negative"));
        }
        Ok(v)
    }

    /// A metric that is empty exactly when every start diverged.
    fn finite_only(&self, k: usize, all_diverged: bool) -> Result<Option<f64>, CellsError> {
        if self.text(k).trim().is_empty() {
            if all_diverged {
                Ok(None)
            } else {
                Err(self.fail(k, "is empty, but not every start diverged"))
            }
        } else {
            self.float(k).map(Some)
        }
    }
}

fn parse_row(name: &str, line: u64, rec: &csv::StringRecord) -> Result<Cell, CellsError> {
    let r = Row { name, line, rec };
    let n_starts = r.uint(7)?;
    if n_starts == 0 {
        return Err(r.fail(7, "must be at least 1"));
    }
    let n_divergent = r.uint(8)?;
    if n_divergent > n_starts {
        return Err(r.fail(8, format!("exceeds n_starts ({n_starts})")));
    }
    let all_diverged = n_divergent == n_starts;
    let horizon_s = r.float(6)?;
    if horizon_s <= 0.0 {
        return Err(r.fail(6, "must be > 0"));
    }
    let divergence_rate = r.float(11)?;
    let expected = n_divergent as f64 / n_starts as f64;
    if (divergence_rate - expected).abs() > 1e-6 {
        return Err(r.fail(11, format!("disagrees with n_divergent / n_starts = {expected}")));
    }
    Ok(Cell {
        model: r.label(0)?,
        arm: r.label(1)?,
        seed: r.uint(2)?,
        recording: r.label(3)?,
        trajectory: r.label(4)?,
        speed: r.label(5)?,
        horizon_s,
        n_starts,
        n_divergent,
        fa_position_rmse_m: r.float(9)?,
        conditional_position_rmse_m: r.finite_only(10, all_diverged)?,
        divergence_rate,
        velocity_rmse_mps: r.finite_only(12, all_diverged)?,
        attitude_rmse_deg: r.finite_only(13, all_diverged)?,
        line,
    })
}

/// Writes cells with the exact header. Floats use Rust's shortest
/// round-trip form, so the same values give the same bytes.
pub fn write_cells(path: &Path, cells: &[Cell]) -> Result<(), CellsError> {
    let p = path.display().to_string();
    let io = |source: std::io::Error| CellsError::Io { path: p.clone(), source };
    let mut w = csv::Writer::from_path(path).map_err(|e| io(e.into()))?;
    w.write_record(HEADER).map_err(|e| io(e.into()))?;
    let opt = |v: Option<f64>| v.map(|x| x.to_string()).unwrap_or_default();
    for c in cells {
        w.write_record([
            c.model.clone(),
            c.arm.clone(),
            c.seed.to_string(),
            c.recording.clone(),
            c.trajectory.clone(),
            c.speed.clone(),
            c.horizon_s.to_string(),
            c.n_starts.to_string(),
            c.n_divergent.to_string(),
            c.fa_position_rmse_m.to_string(),
            opt(c.conditional_position_rmse_m),
            c.divergence_rate.to_string(),
            opt(c.velocity_rmse_mps),
            opt(c.attitude_rmse_deg),
        ])
        .map_err(|e| io(e.into()))?;
    }
    w.flush().map_err(io)
}
