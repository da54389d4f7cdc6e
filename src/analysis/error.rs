//! Why per-cell data cannot be analysed (`AnalysisError`), and the same
//! located in its per-cell file (`FileAnalysisError`).

use crossaudit_stats::StatsError;

use crate::cells::Origin;

/// Why per-cell data cannot be analysed under a plan.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    /// A row names a model, arm, seed or horizon the design does not declare.
    #[error("{at}, field `{field}`: {value:?} is not in the design ({known})")]
    NotInDesign {
        /// The row's line (a Parquet file's row).
        at: Origin,
        /// The column.
        field: &'static str,
        /// The value found.
        value: String,
        /// What the design declares.
        known: String,
    },
    /// A velocity or attitude value where the design's data declare none,
    /// or an empty one where they declare it and not every start diverged.
    #[error("{at}, field `{field}`: {problem}")]
    Layout {
        /// The row's line (a Parquet file's row).
        at: Origin,
        /// The column.
        field: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// Two rows for the same cell.
    #[error("{at}: duplicate cell (model={model} arm={arm} seed={seed} recording={recording} horizon={horizon} s), first seen on {first_at}")]
    Duplicate {
        /// The second row's line (a Parquet file's row).
        at: Origin,
        /// The first row's.
        first_at: Origin,
        /// The cell's model.
        model: String,
        /// The cell's arm.
        arm: String,
        /// The cell's seed.
        seed: u64,
        /// The cell's recording.
        recording: String,
        /// The cell's horizon (s).
        horizon: f64,
    },
    /// A recording labelled with two trajectories or speeds.
    #[error("{at}, field `{field}`: recording {recording} is labelled {value:?} here but {first:?} on {first_at}")]
    InconsistentLabel {
        /// The disagreeing row's line (a Parquet file's row).
        at: Origin,
        /// `trajectory` or `speed`.
        field: &'static str,
        /// The recording.
        recording: String,
        /// The label here.
        value: String,
        /// The label first seen.
        first: String,
        /// Where it was first seen.
        first_at: Origin,
    },
    /// Cells of the crossed matrix are missing.
    #[error(
        "{count} missing cell(s); the crossed method of moments needs every model x arm x seed x recording x horizon (a design with `estimate reml ... missing allow` analyses incomplete data):\n{list}"
    )]
    Missing {
        /// How many.
        count: usize,
        /// The first ten, one per line.
        list: String,
    },
    /// The data has a different number of evaluation recordings than declared.
    #[error("the per-cell data has {found} recording(s); the design declares `evaluation {declared}`{fewest}")]
    RecordingCount {
        /// Recordings in the data.
        found: usize,
        /// Recordings the design declares.
        declared: usize,
        /// Where the data has more: the recording in the fewest rows and
        /// where it first is (empty where it has fewer).
        fewest: String,
    },
    /// A value the metric cannot take under the design.
    #[error("{at}, field `{field}`: {} is impossible: {problem}", show(*.value))]
    Impossible {
        /// The row's line (a Parquet file's row).
        at: Origin,
        /// The metric column.
        field: &'static str,
        /// The value found.
        value: f64,
        /// Why it cannot be.
        problem: String,
    },
    /// Optimism is a percentage of a zero mean.
    #[error("{unit}: the {arm} arm's mean is zero, so optimism (a percentage of it) is undefined")]
    ZeroReferenceMean {
        /// The unit.
        unit: String,
        /// The reference arm.
        arm: String,
    },
    /// The unit's data have no variance to estimate an interval from.
    #[error("{unit}: {detail}")]
    Degenerate {
        /// The unit.
        unit: String,
        /// What is degenerate about it.
        detail: String,
    },
    /// The statistics refused the unit's matrix.
    #[error("{unit}: {source}")]
    Stats {
        /// The unit.
        unit: String,
        /// Why.
        source: StatsError,
    },
    /// More rows than the index numbers in 4 bytes (some 600 GB of cells:
    /// only cells built in memory could come near; a file's lines are
    /// limited to the same count).
    #[error("{rows} rows: one analysis indexes at most {most} rows")]
    TooManyRows {
        /// Rows given.
        rows: usize,
        /// The most it indexes.
        most: u32,
    },
    /// A dose-response or multi-split study's cells do not fit its design.
    #[error("{message}")]
    Family {
        /// What is wrong, with the line.
        message: String,
    },
}

/// An [`AnalysisError`] with the per-cell file it concerns.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {source}")]
pub struct FileAnalysisError {
    /// The per-cell file.
    pub path: String,
    /// Why it cannot be analysed.
    pub source: Box<AnalysisError>,
}

impl FileAnalysisError {
    /// `source`, located in the file at `path`.
    pub fn new(path: &std::path::Path, source: AnalysisError) -> FileAnalysisError {
        FileAnalysisError { path: path.display().to_string(), source: Box::new(source) }
    }
}

/// A value as a reader would write it: scientific notation when very large.
fn show(v: f64) -> String {
    if v.abs() >= 1e6 {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}
