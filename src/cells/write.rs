//! Writing the per-cell table: `cells.csv` (the exact header, floats in
//! their shortest round-trip form, so the same values give the same bytes)
//! and its typed Parquet twin `cells.parquet`.

use std::path::Path;

use super::{header_for, Cell, CellsError, HEADER};

/// [`write_cells`] to a temporary file, then renamed over `path`: a reader
/// (or a resumed run) never sees half a file.
pub fn write_cells_atomic(path: &Path, cells: &[Cell]) -> Result<(), CellsError> {
    let tmp =
        crate::io::staged(path).map_err(|source| CellsError::Write { path: path.display().to_string(), source })?;
    write_cells(&tmp, cells)?;
    std::fs::rename(&tmp, path).map_err(|source| CellsError::Write { path: path.display().to_string(), source })
}

/// [`write_cells_atomic`], and the same table as `cells.parquet` beside
/// `path` (typed columns, `io::parquet::csv_to_parquet`: names as text,
/// counts and seeds as 64-bit integers, metrics as doubles, an empty
/// field a null), for pandas, polars and R's arrow; what a run writes.
/// The table is rendered once: the CSV's bytes are [`write_cells`]'s and
/// the Parquet file is made from them.
pub fn write_cells_and_parquet(path: &Path, cells: &[Cell]) -> Result<(), CellsError> {
    let csv = cells_bytes(cells);
    let io = |p: &Path, source| CellsError::Write { path: p.display().to_string(), source };
    crate::io::write_atomic(path, &csv).map_err(|e| io(path, e.source))?;
    let twin = path.with_extension("parquet");
    let bytes = crate::io::parquet::csv_to_parquet(&csv).map_err(|e| io(&twin, std::io::Error::other(e)))?;
    crate::io::write_atomic(&twin, &bytes).map_err(|e| io(&twin, e.source))
}

/// Writes cells with the exact header, and the `split` and `dose` columns
/// when the cells carry them. Floats use Rust's shortest round-trip form,
/// so the same values give the same bytes.
pub fn write_cells(path: &Path, cells: &[Cell]) -> Result<(), CellsError> {
    let p = path.display().to_string();
    let file = std::fs::File::create(path).map_err(|source| CellsError::Write { path: p.clone(), source })?;
    write_cells_to(&p, file, cells)
}

/// The bytes [`write_cells`] writes.
pub fn cells_bytes(cells: &[Cell]) -> Vec<u8> {
    let mut out = Vec::new();
    // Writing to memory cannot fail.
    let _ = write_cells_to("(memory)", &mut out, cells);
    out
}

fn write_cells_to(p: &str, sink: impl std::io::Write, cells: &[Cell]) -> Result<(), CellsError> {
    let io = |source: std::io::Error| CellsError::Write { path: p.to_string(), source };
    let (has_split, has_dose) = (cells.iter().any(|c| c.split.is_some()), cells.iter().any(|c| c.dose.is_some()));
    let mut w = csv::Writer::from_writer(sink);
    if !has_split && !has_dose {
        for c in cells {
            w.serialize(c).map_err(|e| io(e.into()))?;
        }
        if cells.is_empty() {
            w.write_record(HEADER).map_err(|e| io(e.into()))?;
        }
        return w.flush().map_err(io);
    }
    w.write_record(header_for(has_split, has_dose)).map_err(|e| io(e.into()))?;
    let opt = |v: Option<f64>| v.map(|x| x.to_string()).unwrap_or_default();
    for c in cells {
        let mut row: Vec<String> = Vec::with_capacity(16);
        if has_split {
            row.push(c.split.map(|s| s.to_string()).unwrap_or_default());
        }
        row.push(c.model.to_string());
        row.push(c.arm.to_string());
        if has_dose {
            row.push(opt(c.dose));
        }
        row.extend([
            c.seed.to_string(),
            c.recording.to_string(),
            c.trajectory.to_string(),
            c.speed.to_string(),
            c.horizon_s.to_string(),
            c.n_starts.to_string(),
            c.n_divergent.to_string(),
            c.fa_position_rmse_m.to_string(),
            opt(c.conditional_position_rmse_m),
            c.divergence_rate.to_string(),
            opt(c.velocity_rmse_mps),
            opt(c.attitude_rmse_deg),
        ]);
        w.write_record(&row).map_err(|e| io(e.into()))?;
    }
    w.flush().map_err(io)
}
