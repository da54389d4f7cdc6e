//! Why a flight log could not be read: each error names the file and,
//! where there is one, the line (1 = header) and column.

use serde::Serialize;

/// Why a log could not be read. Each names the file and, where there is
/// one, the line (1 = header) and column.
#[derive(Debug, Clone, PartialEq, thiserror::Error, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum LogError {
    /// The file could not be opened or read.
    #[error("{file}: cannot read: {message}")]
    Io {
        /// The file, as given.
        file: String,
        /// The underlying error.
        message: String,
    },
    /// The gzip stream ended early or is corrupt.
    #[error("{file}: gzip stream truncated or corrupt after {bytes} decompressed bytes (near line {line}): {message}")]
    Gzip {
        /// The file, as given.
        file: String,
        /// Bytes decompressed before the failure.
        bytes: usize,
        /// Line number (1 = header).
        line: usize,
        /// The underlying error.
        message: String,
    },
    /// A Parquet file that cannot be read.
    #[error("{file}: not a readable Parquet file: {message}")]
    Parquet {
        /// The file, as given.
        file: String,
        /// The Parquet reader's words.
        message: String,
    },
    /// The file has no bytes (or no header).
    #[error("{file}: empty file")]
    Empty {
        /// The file, as given.
        file: String,
    },
    /// A header field differs from the NanoBench schema.
    #[error("{file}: line 1, column {index}: expected header `{expected}`, found `{found}`")]
    Header {
        /// The file, as given.
        file: String,
        /// Column index (1-based).
        index: usize,
        /// The schema column expected there.
        expected: String,
        /// The header field found.
        found: String,
    },
    /// A line longer than [`crate::io::MAX_LOG_LINE`] bytes.
    #[error("{file}: line {line} is longer than {limit} bytes (it holds at least {bytes}): not a flight log row")]
    LongLine {
        /// The file, as given.
        file: String,
        /// Line number (1 = header).
        line: usize,
        /// Bytes in the line, up to the first past the limit.
        bytes: usize,
        /// The limit.
        limit: usize,
    },
    /// A header but no data rows.
    #[error("{file}: header only, no data rows")]
    NoRows {
        /// The file, as given.
        file: String,
    },
    /// A row with a different number of fields than the header.
    #[error("{file}: line {line}: {found} fields, the header has {expected}")]
    Ragged {
        /// The file, as given.
        file: String,
        /// Line number (1 = header).
        line: usize,
        /// Fields in the row.
        found: usize,
        /// Fields in the header.
        expected: usize,
    },
    /// A field that does not parse as a number.
    #[error("{file}: line {line}, column `{column}`: {}", not_a_number(value))]
    NonNumeric {
        /// The file, as given.
        file: String,
        /// Line number (1 = header).
        line: usize,
        /// Column name.
        column: String,
        /// The value as found.
        value: String,
    },
    /// A NaN or infinite field.
    #[error("{file}: line {line}, column `{column}`: non-finite value {value:?} ({MISSING_HINT})")]
    NonFinite {
        /// The file, as given.
        file: String,
        /// Line number (1 = header).
        line: usize,
        /// Column name.
        column: String,
        /// The value as found.
        value: String,
    },
    /// A value too large for the statistics to square and sum (|v| > 1e15):
    /// its arithmetic would overflow or lose every digit.
    #[error("{file}: line {line}, column `{column}`: {value:?} is larger in magnitude than 1e15, which no flight quantity is in SI units and whose squares the statistics cannot sum; is the column in the declared unit?")]
    TooLarge {
        /// The file, as given.
        file: String,
        /// Line number (1 = header).
        line: usize,
        /// Column name.
        column: String,
        /// The value as found.
        value: String,
    },
    /// A timestamp earlier than the previous row's.
    #[error("{file}: line {line}, column `{column}`: time {t} is before the previous row's {previous}")]
    NonMonotonicTime {
        /// The file, as given.
        file: String,
        /// The time column.
        column: String,
        /// Line number (1 = header).
        line: usize,
        /// This row's time, seconds.
        t: f64,
        /// The previous row's time, seconds.
        previous: f64,
    },
    /// A declared column that the header lacks (or holds twice).
    #[error("{file}: line 1: the design declares column `{column}`, but the header {}", missing_what(found))]
    MissingColumn {
        /// The file, as given.
        file: String,
        /// The declared column.
        column: String,
        /// The header's first names, or `twice`.
        found: String,
    },
    /// A time column whose median step disagrees with the declared rate.
    #[error("{file}: line {line}, column `{column}`: the median time step is {median_s} s, but `rate {rate_hz} Hz` means {expected_s} s (this is the first step more than 2% off; declare the logs' own rate)")]
    Rate {
        /// The file, as given.
        file: String,
        /// The first line whose step from the line before is more than 2% off.
        line: usize,
        /// The time column.
        column: String,
        /// The median step between rows, seconds.
        median_s: f64,
        /// The declared rate.
        rate_hz: f64,
        /// 1 / rate, seconds.
        expected_s: f64,
    },
    /// A step of the time column longer than [`super::MAX_GAP_STEPS`]
    /// samples: the log has a hole a window would step across.
    #[error("{file}: line {line}, column `{column}`: the time jumps by {gap_s:.3} s from the line before, {steps:.0} samples at {rate_hz} Hz, longer than {limit}; declare `gaps over T s segment` to cut the recording there, or `gaps over T s exclude` to leave it out", steps = .gap_s * .rate_hz)]
    Gap {
        /// The file, as given.
        file: String,
        /// The line after the gap.
        line: usize,
        /// The time column.
        column: String,
        /// The step, seconds.
        gap_s: f64,
        /// The declared rate.
        rate_hz: f64,
        /// The longest step allowed, in words.
        limit: String,
    },
    /// An Euler angle declared in radians beyond 2 pi.
    #[error("{file}: line {line}, column `{column}`: the angle {value} is beyond 2 pi, so it is not in radians as the design declares; if the angles are in degrees, declare `attitude euler degrees ...`")]
    EulerRange {
        /// The file, as given.
        file: String,
        /// The line.
        line: usize,
        /// The column.
        column: String,
        /// The value.
        value: f64,
    },
    /// An active row whose quaternion is further from unit length than
    /// the tolerance (0.01, or the declared `norm within`).
    #[error("{file}: line {line}, columns {columns}: the attitude quaternion has length {norm}, not 1 ({})", not_unit_hint(*tolerance, *largest, *declared))]
    NotUnit {
        /// The file, as given.
        file: String,
        /// Line number (1 = header).
        line: usize,
        /// The quaternion's columns, as declared.
        columns: String,
        /// Its length on that line.
        norm: f64,
        /// The tolerance it broke.
        tolerance: f64,
        /// The file's largest |length - 1| over the checked rows.
        largest: f64,
        /// Whether the tolerance was declared (`norm within`).
        declared: bool,
    },
}

/// What a quaternion off unit length means and how to declare it: a
/// logged quaternion a little off (real estimators drift by about 1%) is
/// accepted and renormalised with `norm within`; one far off is not a
/// quaternion in the declared order.
fn not_unit_hint(tolerance: f64, largest: f64, declared: bool) -> String {
    let limit = if declared { format!("the declared `norm within {tolerance}`") } else { format!("{tolerance}") };
    let mut s = format!("more than {limit} off; the file's largest deviation is {largest:.4}");
    if largest <= 0.5 {
        // The next hundredth above the largest deviation.
        let suggested = ((largest * 100.0).floor() + 1.0) / 100.0;
        s.push_str(&format!(
            "; if the log's quaternion is not kept at unit length, declare `norm within {suggested}` after its columns to accept and renormalise it"
        ));
    } else {
        s.push_str(
            "; no tolerance explains that: are these the quaternion's columns, in their order (`wxyz` or `xyzw`)?",
        );
    }
    s
}

fn missing_what(found: &str) -> String {
    if found == "twice" {
        "holds it twice".to_string()
    } else {
        format!("has no such column (it has: {found})")
    }
}

/// What a declared policy can do about a missing value.
const MISSING_HINT: &str =
    "a missing value: in a column the design reads, `missing values segment` or `missing values exclude` in the data block decides what it does";

/// `"abc" is not a number`, or, for an empty field, that it is a missing value.
fn not_a_number(value: &str) -> String {
    if value.trim().is_empty() {
        format!("the field is empty ({MISSING_HINT})")
    } else {
        format!("{value:?} is not a number")
    }
}

impl LogError {
    /// Whether this is a missing value in a column read: an empty or
    /// non-finite field (what `missing values` declares a policy for).
    pub fn is_missing_value(&self) -> bool {
        match self {
            LogError::NonFinite { .. } => true,
            LogError::NonNumeric { value, .. } => value.trim().is_empty(),
            _ => false,
        }
    }

    /// Short machine-readable kind for audit tables.
    pub fn kind(&self) -> &'static str {
        match self {
            LogError::Io { .. } => "unreadable",
            LogError::Gzip { .. } => "truncated_gzip",
            LogError::Parquet { .. } => "unreadable_parquet",
            LogError::Empty { .. } => "empty_file",
            LogError::Header { .. } => "bad_header",
            LogError::NoRows { .. } => "empty_file",
            LogError::LongLine { .. } => "long_line",
            LogError::Ragged { .. } => "ragged_row",
            LogError::NonNumeric { .. } => "non_numeric",
            LogError::NonFinite { .. } => "non_finite",
            LogError::TooLarge { .. } => "too_large",
            LogError::NonMonotonicTime { .. } => "non_monotonic_time",
            LogError::MissingColumn { .. } => "missing_column",
            LogError::Rate { .. } => "rate_mismatch",
            LogError::Gap { .. } => "time_gap",
            LogError::EulerRange { .. } => "euler_not_radians",
            LogError::NotUnit { .. } => "not_unit_quaternion",
        }
    }
}
