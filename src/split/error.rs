//! Why the data cannot support the design.

/// Why the data cannot support the design.
#[derive(Debug, thiserror::Error)]
pub enum SplitError {
    /// A condition the design uses is unknown for every recording.
    #[error("{design}: the design's conditions include {condition}, and it is unknown for every included recording (every one would fall in one group); give it in the file names, a `conditions name` pattern, or a conditions table with a `{condition}` column, or leave it out of `conditions`")]
    UnknownCondition {
        /// The condition.
        condition: String,
        /// The design file.
        design: String,
    },
    /// A multi-split design given where one split is prepared.
    #[error("the design declares {splits} splits (`factor split`), and this command prepares one split (`split` and `train` do): run the study with `crossaudit run DESIGN --out DIR` (with `--slurm` for a cluster), which runs each split in its own directory DIR/split-S")]
    SeveralSplits {
        /// How many.
        splits: usize,
    },
    /// Not enough deployment units for evaluation, validation and fitting.
    #[error("the design needs {needed} recordings ({evaluation} evaluation + {validation} validation + at least 1 for fitting), but only {available} usable deployment units remain (a deployment unit is one included recording, or one set of identical recordings under `duplicates group`; `crossaudit data audit DESIGN` lists which were included and why the others were not)")]
    TooFewRecordings {
        /// How many the design needs.
        needed: usize,
        /// Evaluation recordings declared.
        evaluation: usize,
        /// Validation recordings declared.
        validation: usize,
        /// How many are available.
        available: usize,
    },
    /// An evaluation recording has too few valid rollout starts.
    #[error("evaluation recording {recording} has {valid} valid rollout starts (>= {horizon} active samples after the start{within}), the design needs {needed}")]
    TooFewStarts {
        /// Recording name.
        recording: String,
        /// Valid rollout starts it has.
        valid: usize,
        /// How many the design needs.
        needed: usize,
        /// Rollout horizon, samples.
        horizon: usize,
        /// ` within its first P% of rows`, or empty.
        within: String,
    },
    /// A window set cannot be drawn at the declared size.
    #[error("{what}: the design needs {needed} windows, only {available} are available")]
    TooFewWindows {
        /// Which set.
        what: String,
        /// How many the design needs.
        needed: usize,
        /// How many are available.
        available: usize,
    },
    /// A derived arm's percentage replaces no window.
    #[error("arm {arm}: {percent}% of {windows} windows replaces {replaced} windows; nothing would be replaced")]
    NothingToReplace {
        /// Arm name.
        arm: String,
        /// Percentage of windows replaced.
        percent: f64,
        /// Number of windows.
        windows: usize,
        /// Windows that would be replaced.
        replaced: usize,
    },
    /// The data directory could not be audited.
    #[error(transparent)]
    Audit(#[from] crate::data::AuditError),
    /// A manifest or audit file could not be written.
    #[error(transparent)]
    Write(#[from] crate::io::WriteError),
    /// The evaluation windows at the declared distance from the evaluated
    /// segments are fewer than an arm replaces.
    #[error("arm {arm}: {needed} contaminating windows {clause} (design byte {offset}) were asked for, but the evaluation recordings hold {available} such windows{starts} (of {pool} in all); declare a smaller distance, a lower share, more evaluation recordings, or (for `after segments`) starts within a first part of each recording")]
    TooFewAtDistance {
        /// The arm (the first dose of a family that asks for the most).
        arm: String,
        /// The clause as written, e.g. `at least 5 s from segments`.
        clause: String,
        /// Byte offset of the clause in the design source.
        offset: usize,
        /// Windows the arm replaces.
        needed: usize,
        /// Windows at that distance.
        available: usize,
        /// ` that are not registered starts`, under `exclude starts`.
        starts: &'static str,
        /// Evaluation windows before the distance filter.
        pool: usize,
    },
    /// A pinned recording is not in the universe.
    #[error("{what} recording \"{name}\" (design byte {offset}) is not among the {available} recordings the split draws from{hint}")]
    NotInUniverse {
        /// `evaluation` or `validation`.
        what: &'static str,
        /// The name as written.
        name: String,
        /// Byte offset in the design source.
        offset: usize,
        /// Size of the universe.
        available: usize,
        /// Why it may be absent.
        hint: String,
    },
    /// A recording pinned for evaluation is also pinned for validation
    /// (itself, or an identical copy under `duplicates group`).
    #[error("validation recording \"{name}\" is an evaluation recording or an identical copy of one")]
    ListedTwice {
        /// The name.
        name: String,
    },
    /// Two pinned names are one deployment unit (identical recordings).
    #[error(
        "\"{first}\" and \"{second}\" are identical recordings, one deployment unit under `duplicates group`: list one"
    )]
    SameUnit {
        /// The first name.
        first: String,
        /// The second.
        second: String,
    },
    /// Drawn or pinned recordings without usable data, and the design does
    /// not allow them.
    #[error("the split drew or pinned {what} recordings without usable data (no CSV, or excluded by the data rules; see audit/recordings.csv): {names}; declare `missing csv allow` in the data block to proceed without them (each is then listed in manifests/absent_recordings.csv and the report)")]
    Absent {
        /// `evaluation` or `validation`.
        what: &'static str,
        /// The names, comma-separated.
        names: String,
    },
    /// A published split's fit roles hold copies of evaluation or
    /// validation recordings, and the design says `leaked refuse`.
    #[error("the published split {file} puts {count} identical cop(ies) of evaluation or validation recordings in its fit roles:\n{list}\n(`crossaudit audit split` reports every such copy; declare `leaked drop` in the `split published` statement to fit without them)")]
    PublishedLeak {
        /// The split file as written in the design.
        file: String,
        /// How many fit recordings are copies.
        count: usize,
        /// One line per copy.
        list: String,
    },
    /// Located version of an error about a name written in the design.
    #[error("{path}:{line}:{column}: {message}")]
    Located {
        /// The design file.
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A stratified evaluation draw (`stratify ... keep N`) the data
    /// cannot satisfy.
    #[error("{detail} (design byte {offset})")]
    Stratify {
        /// What could not be drawn and why.
        detail: String,
        /// Byte offset of the `stratify` clause in the design source.
        offset: usize,
    },
    /// An invariant failed; nothing may train.
    #[error("invariant check failed, nothing will train (see {path}):\n{list}")]
    Invariants {
        /// `audit/invariants.json`, which holds the details.
        path: String,
        /// The failed invariants, one per line.
        list: String,
    },
}
