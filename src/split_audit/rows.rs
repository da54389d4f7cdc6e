//! One recording of a split audit (`RecordingRow`: where it was found and
//! what a loader makes of it) and the make-up of each role, which the
//! audit's parts (composition, distance) read.

use serde::Serialize;

/// Where a declared name was found in the data directory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Presence {
    /// A CSV of that name is there.
    Csv,
    /// Only its metadata file is there.
    MetadataOnly,
    /// Neither: the name is unknown to the data directory.
    Unknown,
}

/// What a loader under the audit's rules makes of a declared recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    /// Loaded and kept: it is in the effective split.
    Kept,
    /// Present but dropped by a rule (or unreadable).
    Dropped,
    /// Not there to load.
    Absent,
}

/// One recording of the audit: a declared entry, or a file no role lists.
#[derive(Debug, Clone, Serialize)]
pub struct RecordingRow {
    /// Recording name (file stem).
    pub recording: String,
    /// Declared role; empty when no role lists it.
    pub role: String,
    /// The entry as written in the split file.
    pub listed_as: String,
    /// Its line in the split file (0 when unlisted).
    pub line: usize,
    /// Its column in the split file.
    pub column: usize,
    /// Windows the role lists of it, in a per-window split (line and
    /// column are the first's); 0 where the entry is the whole recording.
    pub windows: usize,
    /// Whether the data directory holds it.
    pub presence: Presence,
    /// Kept, dropped or absent under the audit's rules.
    pub effect: Effect,
    /// Why it was dropped or is absent; empty when kept.
    pub reason: String,
    /// Trajectory shape.
    pub trajectory: String,
    /// Speed label.
    pub speed: String,
    /// Data rows.
    pub rows: usize,
    /// Active rows.
    pub active_rows: usize,
    /// First to last timestamp, seconds.
    pub duration_s: f64,
    /// XXH3-128 of its data rows.
    pub content_hash: String,
    /// Byte-identical recordings in other roles, as `role:name`.
    pub identical_in_other_roles: Vec<String>,
    /// The longest run of identical rows shared with a recording of another
    /// role that is not an identical copy, and with which (`role:name`).
    pub longest_shared_run: Option<(usize, String)>,
    /// Kept recordings of other roles with the same trajectory and speed.
    pub same_condition_in_other_roles: usize,
}

/// The trajectory x speed make-up of each role's kept recordings.
#[derive(Debug, Clone, Serialize)]
pub struct RoleComposition {
    /// The (trajectory, speed) cells, sorted.
    pub cells: Vec<(String, String)>,
    /// Per role, the count in each cell.
    pub counts: Vec<(String, Vec<usize>)>,
    /// Per role, the total-variation distance of its cell shares from those
    /// of all other roles together (0 = same mix, 1 = no cell in common).
    pub distance_from_rest: Vec<(String, f64)>,
    /// Total-variation distance for each pair of roles.
    pub pairwise: Vec<(String, String, f64)>,
}
