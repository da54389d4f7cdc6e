//! Why a data directory could not be audited.

/// Why a data directory could not be audited.
#[derive(Debug, thiserror::Error)]
pub enum AuditError {
    /// The directory could not be listed.
    #[error("cannot list data directory {dir}: {message}")]
    Dir {
        /// The directory.
        dir: String,
        /// The underlying error.
        message: String,
    },
    /// Two files load as recordings of the same name.
    #[error("{dir}: {first} and {second} would both load as recording {name}; keep one of them")]
    SameName {
        /// The directory.
        dir: String,
        /// The recording name.
        name: String,
        /// One file.
        first: String,
        /// The other.
        second: String,
    },
    /// The audit kept no recording at all (it is written all the same,
    /// with each file's reason).
    #[error("{dir}: none of its {files} log file(s) was included; each one's reason is in {written}{hint}")]
    NoneIncluded {
        /// The data directory.
        dir: String,
        /// How many log files it holds.
        files: usize,
        /// Where the audit was written.
        written: String,
        /// What to try, where one thing is likely.
        hint: String,
    },
    /// A split audit that found a log for none of the recordings the split
    /// lists: it could classify nothing (it is written all the same).
    #[error("{dir}: none of the {listed} recording(s) the split lists has a log here, so nothing could be classified; the audit is in {written}{hint}")]
    NoneListedFound {
        /// The data directory.
        dir: String,
        /// How many recordings the split lists.
        listed: usize,
        /// Where the audit was written.
        written: String,
        /// What to try, where one thing is likely.
        hint: String,
    },
    /// Files that look like flight logs but that no reader reads as
    /// named (a suffix in capitals, a compressed Parquet file): never
    /// passed over without a word.
    #[error("{dir}: {} file(s) look like flight logs but are not read as named: {}; rename or move them (a log ends in .csv, .csv.gz or .parquet, in lower case)", .files.len(), .files.join("; "))]
    NotRead {
        /// The directory.
        dir: String,
        /// Each file, relative to the directory, with why it is not read.
        files: Vec<String>,
    },
    /// A log's recording name (its file name without the suffix) begins
    /// or ends with a space: a name that prints the same as another.
    #[error("{dir}: the file name {name:?} gives a recording name that begins or ends with a space, which prints as the name without it and parses into other conditions; rename the file")]
    SpaceInName {
        /// The directory.
        dir: String,
        /// The file name.
        name: String,
    },
    /// A log's file name begins with `=`, `+`, `-` or `@`: its recording
    /// name, in every CSV that names it, would be a spreadsheet formula.
    #[error("{dir}: the file name {name:?} begins with `{}`, so its recording name would be read as a formula by a spreadsheet opening any CSV that names it (cells.csv, the manifests, the audit); rename the file", .name.chars().next().unwrap_or('='))]
    FormulaName {
        /// The directory.
        dir: String,
        /// The file name.
        name: String,
    },
    /// A log's file name holds a control character (a line break, a
    /// terminal escape): it would become a recording name.
    #[error("{dir}: the file name {name:?} holds a control character, which no recording name may; rename the file")]
    ControlInName {
        /// The directory.
        dir: String,
        /// The file name, escaped.
        name: String,
    },
    /// The audit kept fewer recordings than the design requires, or, without
    /// a requirement, lost more than half of the logs to unreadable files
    /// (it is written all the same, with each file's reason).
    #[error("{dir}: the audit kept {kept} of {found} log file(s): {why}; each file's reason is in {written}")]
    TooFew {
        /// The data directory.
        dir: String,
        /// Recordings kept.
        kept: usize,
        /// Log files found.
        found: usize,
        /// Which requirement failed, and the first unreadable file's reason.
        why: String,
        /// Where the audit was written.
        written: String,
    },
    /// A declared `refuse` policy met what it refuses: a missing value or a
    /// time gap, at its file, line and column.
    #[error("{policy}: {error}")]
    Refused {
        /// The policy, as the design writes it.
        policy: String,
        /// The located error.
        error: String,
    },
    /// The declared columns are not in the NanoBench schema.
    #[error("{0}")]
    Layout(String),
    /// `strict` data: files were excluded for reasons other than the declared rules.
    #[error("strict data rules: {count} file(s) could not be used for reasons other than the declared rules:\n{list}")]
    Strict {
        /// How many files.
        count: usize,
        /// One line per file and reason.
        list: String,
    },
    /// Metadata numbers no recording can have (a non-finite or negative
    /// speed, say), refused whatever the design's strictness.
    #[error("{count} metadata value(s) no recording can have:\n{list}")]
    Metadata {
        /// How many values.
        count: usize,
        /// One line per value: file, line, column and what is wrong.
        list: String,
    },
    /// An audit file could not be written.
    #[error(transparent)]
    Write(#[from] crate::io::WriteError),
}
