//! One file of a data audit: its row (`FileRow`: what the rules decided
//! and measured), the audit (`Audit`), and how a file's row is built
//! (blank, unreadable, judged by the rules), shared by the audit's parts.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::data::Tail;
use crate::design::{DuplicatePolicy, TailPolicy};

/// What the audit decided for one file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Passed every rule: usable by the split.
    Included,
    /// Failed a rule or could not be read; `reason` says which.
    Excluded,
    /// Listed by a metadata file, but no CSV is present.
    Missing,
}

/// A rule's verdict on one file.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verdict {
    /// The rule's label, e.g. `active motor_motor_m1 > 1000 >= 200`.
    pub rule: String,
    /// Whether the file passed it.
    pub pass: bool,
    /// What was measured, in words.
    pub detail: String,
}

/// One row of recordings.csv.
#[derive(Debug, Clone, Serialize)]
pub struct FileRow {
    /// Recording name (file stem).
    pub name: String,
    /// File name within the data directory.
    pub file: String,
    /// Data rows (0 when unreadable).
    pub rows: usize,
    /// Rows meeting the active rule.
    pub active_rows: usize,
    /// First to last timestamp, seconds.
    pub duration_s: f64,
    /// Trajectory shape from the file name.
    pub trajectory: String,
    /// Speed label: the file name's token, or from the metadata speed when
    /// the design says `speed from metadata`; `unknown` without one.
    pub speed: String,
    /// Metadata `params.speed_mps`, if any.
    pub speed_mps: Option<f64>,
    /// Controller from the file name (`pid` or `mellinger`).
    pub controller: String,
    /// Repetition number from the file name, if any.
    pub repetition: Option<u32>,
    /// Recording start time from the metadata, if any.
    pub start_utc: Option<String>,
    /// Battery voltage at the start, from the metadata.
    pub battery_start_v: Option<f64>,
    /// Battery voltage at the end, from the metadata.
    pub battery_end_v: Option<f64>,
    /// Identity group shared with identical recordings (the same values read), if any.
    pub duplicate_group: Option<String>,
    /// The extrapolated onboard tail, if the file has one.
    pub tail: Option<Tail>,
    /// Rows cut from the end (`tails truncate`).
    pub rows_cut: usize,
    /// The largest |length - 1| of the logged quaternion over the checked
    /// rows, before renormalisation (see [`super::Recording::quaternion_deviation`]).
    pub quaternion_deviation: Option<f64>,
    /// Metadata row counts of the onboard estimator and attitude streams.
    pub onboard_row_counts: (Option<u64>, Option<u64>),
    /// XXH3-128 of the data rows, hex.
    pub content_hash: String,
    /// Each declared rule's verdict, in declaration order.
    pub verdicts: Vec<Verdict>,
    /// Included, excluded or missing.
    pub status: Status,
    /// Why it was excluded; empty when included.
    pub reason: String,
    /// A metadata file that exists but cannot be used (empty, unreadable,
    /// invalid): a note in lenient data, an error under `strict`.
    #[serde(skip)]
    pub broken_metadata: Option<String>,
}

/// The inclusion audit of one data directory under a design's data declaration.
#[derive(Debug, Clone, Serialize)]
pub struct Audit {
    /// The audited directory, as given.
    pub data_dir: String,
    /// The declared rules' labels, in order.
    pub rules: Vec<String>,
    /// How identical recordings are treated.
    pub duplicates: DuplicatePolicy,
    /// What happens to extrapolated onboard tails.
    pub tails: TailPolicy,
    /// The declared `norm within` of a logged quaternion: recordings.csv
    /// then has each file's largest deviation, and the summary the largest.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub quaternion_tolerance: Option<f64>,
    /// Every file seen, in natural name order.
    pub files: Vec<FileRow>,
    /// Groups of identical recordings (two or more names each).
    pub duplicate_groups: BTreeMap<String, Vec<String>>,
    /// Files that look like flight logs but are not read, in words: the
    /// logs in the folder's subfolders, which a design without `folders
    /// nested` does not read (how many, the first, the clause that reads
    /// them), and hidden files (a name beginning with `.`, as macOS's `._`
    /// copies are). Named in the summary, never left out without a word.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub not_read: Vec<String>,
}

/// The row hashes of one file of an audit, if it could be read.
pub type RowHashes = Option<Vec<u64>>;

/// Which loaded recordings an audit returns.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Keep {
    None,
    Included,
    /// Every readable recording, emptied of all but its row hashes.
    RowHashes,
}

impl Audit {
    /// The included files, in order.
    pub fn included(&self) -> impl Iterator<Item = &FileRow> {
        self.files.iter().filter(|f| f.status == Status::Included)
    }

    /// The files excluded because they could not be read (damaged,
    /// truncated or not a flight log), which no declared rule excluded:
    /// `strict` data refuses them, lenient data names them on the console
    /// and in the report.
    pub fn unread(&self) -> impl Iterator<Item = &FileRow> {
        self.files.iter().filter(|f| f.status == Status::Excluded && f.content_hash.is_empty())
    }

    /// One sentence naming every [`Audit::unread`] file and why (each
    /// reason cut to 200 characters), or `None` when there is none.
    pub fn unread_warning(&self) -> Option<String> {
        let files: Vec<(String, String)> = self
            .unread()
            .map(|f| (if f.file.is_empty() { f.name.clone() } else { f.file.clone() }, f.reason.clone()))
            .collect();
        unread_sentence(&files)
    }
}

/// One sentence naming every unread log `(file, reason)` (each reason cut
/// to 200 characters), or `None` when there is none: what
/// [`Audit::unread_warning`] says, and what a reanalysis reads back from
/// `audit/recordings.csv`.
pub fn unread_sentence(files: &[(String, String)]) -> Option<String> {
    if files.is_empty() {
        return None;
    }
    let named: Vec<String> = files
        .iter()
        .map(|(file, reason)| {
            // The reason starts with the file's path, which the file's
            // name already gives: cut it, so that the excerpt does not
            // depend on where the data folder lies.
            let why = reason.split_once(&format!("{file}: ")).map_or(reason.as_str(), |(_, r)| r);
            format!("{file} ({})", crate::io::excerpt(why, 200))
        })
        .collect();
    Some(format!(
        "{} file(s) in the data folder could not be read and were excluded, although no declared rule excludes them (`strict` data refuses them): {}",
        named.len(),
        named.join("; ")
    ))
}
