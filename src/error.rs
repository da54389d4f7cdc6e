//! The crate's error: one variant per stage, each wrapping that stage's
//! typed error, so a caller can match on where a failure happened and a
//! person reads the stage's own located message.

/// Any error of the convenience calls and the command line.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The design file could not be read, parsed or validated.
    #[error(transparent)]
    Design(#[from] crate::design::LoadError),
    /// The lock file could not be read or written.
    #[error(transparent)]
    Lock(#[from] crate::design::lock::LockError),
    /// The data directory could not be audited.
    #[error(transparent)]
    Audit(#[from] crate::data::AuditError),
    /// The split could not be built or an invariant failed.
    #[error(transparent)]
    Split(#[from] crate::split::SplitError),
    /// A published split file cannot be read.
    #[error(transparent)]
    Published(#[from] crate::published::PublishedError),
    /// A published split could not be audited.
    #[error(transparent)]
    SplitAudit(#[from] crate::split_audit::SplitAuditError),
    /// A per-cell file is malformed.
    #[error(transparent)]
    Cells(#[from] crate::cells::CellsError),
    /// Per-cell data does not fit the plan.
    #[error(transparent)]
    Analysis(#[from] crate::analysis::FileAnalysisError),
    /// The report could not be written.
    #[error(transparent)]
    Report(#[from] crate::report::ReportError),
    /// A run or one of its jobs failed.
    #[error(transparent)]
    Run(#[from] crate::run::RunError),
    /// A coverage study failed.
    #[error(transparent)]
    Coverage(#[from] crate::methods::CoverageError),
    /// A replications file could not be summarised.
    #[error(transparent)]
    Simsum(#[from] crate::methods::simsum::SimsumFileError),
    /// The power planner failed.
    #[error(transparent)]
    Power(#[from] crate::methods::PowerError),
    /// The simulator's recordings could not be written.
    #[error(transparent)]
    Simulate(#[from] crate::sim::SimulateError),
    /// A mixed model could not be fitted from a formula and a CSV file.
    #[error(transparent)]
    Mixed(#[from] crossaudit_stats::mixed::formula::FileError),
    /// A file could not be written.
    #[error(transparent)]
    Write(#[from] crate::io::WriteError),
    /// Standard output could not be written: a full disk, or a pipe whose
    /// reader has gone (which the command line ends quietly).
    #[error("cannot write to standard output: {0}")]
    Stdout(std::io::Error),
}
