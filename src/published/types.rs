//! What a published split is: its roles, their entries (recordings or
//! windows) with the place each was written at, and the errors reading one
//! gives.

use std::collections::BTreeMap;
use std::fmt;

use serde::Serialize;

/// The most roles (or folds) a split file may declare: the split audit
/// compares every ordered pair of roles, so its reports grow with the
/// square (a 2,000-fold list would write about a gigabyte).
pub const MAX_ROLES: usize = 200;

/// The most roles a per-window split may declare: its audit writes each
/// window's nearest window in every other role.
pub const MAX_WINDOW_ROLES: usize = 20;

/// The form a split file was read as.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    /// NanoBench's `split_metadata.json` (`<role>_files` lists).
    NanobenchJson,
    /// A CSV of `recording,role`.
    RoleCsv,
    /// A JSON list of folds (lists of names).
    FoldJson,
    /// A CSV of `recording,fold`.
    FoldCsv,
    /// The folders of a data folder: each recording's role is the first
    /// folder its file sits in (`train/run_1.parquet` is in `train`).
    Folders,
}

impl Format {
    /// Lowercase label used in reports.
    pub fn label(self) -> &'static str {
        match self {
            Format::NanobenchJson => "NanoBench split_metadata.json",
            Format::RoleCsv => "CSV recording,role",
            Format::FoldJson => "JSON fold list",
            Format::FoldCsv => "CSV recording,fold",
            Format::Folders => "the data folder's subfolders",
        }
    }
}

/// Where something was written in the split file (1-based).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Place {
    /// Line.
    pub line: usize,
    /// Column, in characters.
    pub column: usize,
}

impl fmt::Display for Place {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.line, self.column)
    }
}

/// A stretch `[start_s, end_s)` of one recording, in seconds from its
/// first timestamp.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DeclaredWindow {
    /// Start, seconds (at least 0).
    pub start_s: f64,
    /// End, seconds (after the start).
    pub end_s: f64,
}

/// One listed recording, or one window of it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Entry {
    /// The file stem it matches, e.g. `B9_trefoil_slow_rep3`.
    pub name: String,
    /// The entry as written, e.g. a path.
    pub listed: String,
    /// Where it was written.
    pub at: Place,
    /// The window it declares, in a per-window split; `None` for the whole
    /// recording.
    pub window: Option<DeclaredWindow>,
}

/// A role and the recordings declared in it, in file order.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DeclaredRole {
    /// Role name, e.g. `test`.
    pub name: String,
    /// Where the role was first named.
    pub at: Place,
    /// Its recordings.
    pub entries: Vec<Entry>,
}

/// A published split as read.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PublishedSplit {
    /// The file, as given.
    pub path: String,
    /// SHA-256 of its bytes.
    pub sha256: String,
    /// The form it was read as.
    pub format: Format,
    /// Roles in the order the file first names them.
    pub roles: Vec<DeclaredRole>,
    /// Scalar keys of a NanoBench JSON (e.g. `seed`), as written.
    pub notes: BTreeMap<String, String>,
}

/// Why a split file cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PublishedError {
    /// The file could not be read.
    #[error("cannot read split file {path}: {message}")]
    Read {
        /// The file.
        path: String,
        /// The underlying error.
        message: String,
    },
    /// A split published as folders cannot be used as it lies.
    #[error("{dir} (a split published as folders): {message}")]
    Folders {
        /// The data folder.
        dir: String,
        /// What is wrong, naming the files.
        message: String,
    },
    /// Something at a place in the file is wrong.
    #[error("{path}:{line}:{column}: {message}")]
    At {
        /// The file.
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
}

impl PublishedSplit {
    /// The role a recording is declared in, if any.
    pub fn role_of(&self, name: &str) -> Option<&DeclaredRole> {
        self.roles.iter().find(|r| r.entries.iter().any(|e| e.name == name))
    }

    /// The role called `name`.
    pub fn role(&self, name: &str) -> Option<&DeclaredRole> {
        self.roles.iter().find(|r| r.name == name)
    }

    /// Every declared entry with its role, in file order of the roles.
    pub fn entries(&self) -> impl Iterator<Item = (&DeclaredRole, &Entry)> {
        self.roles.iter().flat_map(|r| r.entries.iter().map(move |e| (r, e)))
    }

    /// The split itself where every entry is a whole recording; a
    /// per-window split is refused at its first window (a design's
    /// `split published` assigns recordings, not windows).
    pub fn whole_recordings(self) -> Result<PublishedSplit, PublishedError> {
        let first = self.entries().find(|(_, e)| e.window.is_some()).map(|(_, e)| e.at);
        match first {
            Some(place) => Err(at(
                &self.path,
                place,
                "this split assigns windows (`start_s`, `end_s`), not whole recordings: a design's `split published` takes whole recordings; measure this one with `crossaudit audit split`",
            )),
            None => Ok(self),
        }
    }

    /// Whether the file splits by window (`start_s`, `end_s`) rather than
    /// by whole recording.
    pub fn is_windowed(&self) -> bool {
        self.entries().any(|(_, e)| e.window.is_some())
    }
}

/// `/a/b/B9_trefoil_slow_rep3.csv.gz` -> `B9_trefoil_slow_rep3` (and
/// `train/run_07.parquet` -> `run_07`).
pub fn stem(listed: &str) -> String {
    let file = listed.rsplit(['/', '\\']).next().unwrap_or(listed).trim();
    if let Some(stem) = file.strip_suffix(".parquet") {
        return stem.to_string();
    }
    let file = file.strip_suffix(".gz").unwrap_or(file);
    file.strip_suffix(".csv").unwrap_or(file).to_string()
}

/// An error at `place` of the split file `path`.
pub(super) fn at(path: &str, place: Place, message: impl Into<String>) -> PublishedError {
    PublishedError::At { path: path.to_string(), line: place.line, column: place.column, message: message.into() }
}
