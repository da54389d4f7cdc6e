#![doc = include_str!("../ARCHITECTURE.md")]

pub mod analysis;
pub mod cells;
pub mod design;
pub mod pipeline;
pub mod report;
pub mod stats;

use std::path::Path;

pub use analysis::{analyze, Analysis, AnalyzeOptions};
pub use design::Design;
pub use pipeline::{compile, Plan};

/// Any error of the convenience calls, with the file it concerns.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Design(#[from] design::LoadError),
    #[error(transparent)]
    Lock(#[from] design::lock::LockError),
    #[error(transparent)]
    Cells(#[from] cells::CellsError),
    #[error("{path}: {source}")]
    Analysis { path: String, source: Box<analysis::AnalysisError> },
    #[error(transparent)]
    Write(#[from] report::WriteError),
    #[error(transparent)]
    Audit(#[from] data::AuditError),
    #[error("{0}")]
    Usage(String),
}

/// The data directory: `--data` if given, else the design's `path`
/// (relative to the current directory).
pub fn data_dir(design: &Design, data: Option<std::path::PathBuf>) -> Result<std::path::PathBuf, Error> {
    let dir = match (data, &design.data.path) {
        (Some(d), _) => d,
        (None, Some(p)) => std::path::PathBuf::from(p),
        (None, None) => return Err(Error::Usage("the design's data block has no `path`; pass --data DIR".into())),
    };
    if !dir.is_dir() {
        return Err(Error::Usage(format!("data directory {} does not exist", dir.display())));
    }
    Ok(dir)
}

/// Loads a design and per-cell CSV and runs the preregistered analysis. A
/// design whose lock no longer matches is analysed but marked exploratory.
pub fn analyze_files(design_path: &Path, cells_path: &Path, options: AnalyzeOptions) -> Result<Analysis, Error> {
    let file = design::load(design_path)?;
    let status = design::lock::status(design_path, &file.sha256)?;
    let cells = cells::read_cells(cells_path)?;
    let mut a = analysis::analyze(&file.design, &cells, options)
        .map_err(|source| Error::Analysis { path: cells_path.display().to_string(), source: Box::new(source) })?;
    a.design_sha256 = Some(file.sha256);
    if let design::LockStatus::LockedChanged { .. } = status {
        a.exploratory = true;
        a.warnings.push("the design changed after it was locked: results are EXPLORATORY".to_string());
    }
    Ok(a)
}
pub mod data;
