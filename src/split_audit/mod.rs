//! Stage: the audit of a published split. Every recording a benchmark's
//! split file declares is loaded through the same loader and inclusion
//! rules as a study's data, and the audit reports, per role and across
//! roles:
//!
//! - declared against effective membership: entries with no CSV (a
//!   metadata file only, or nothing at all), files the rules drop (a loader
//!   that skips them silently changes the split), and the counts left;
//! - exact leakage: recordings that hold the same values read (one
//!   content-identity group) on two sides;
//! - near-leakage worth a look: two recordings on different sides sharing a
//!   run of at least `min_run_rows` identical rows (a partial copy), and
//!   recordings whose trajectory x speed also occurs on another side (a new
//!   repetition of a known manoeuvre: not a leak, but a different estimand);
//! - each role's trajectory x speed composition and its total-variation
//!   distance from the others.
//!
//! - distance in time: for each window of a role, the nearest window of
//!   another role in the same recording (or an identical copy), and
//!   the share within a declared gap (see [`distance`]). A per-window split
//!   lists one recording in several roles; comparisons of copies and
//!   conditions above are between different recordings.
//!
//! Recordings in the data directory that no role lists are reported as
//! unlisted.

mod composition;
pub mod distance;
mod render;
mod rows;
mod runs;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::data::{self, AuditError, FileRow, Status};
use crate::design::DataSpec;
use crate::published::{Format, PublishedSplit};
pub use distance::{PairDistance, RoleWindowDistance, DEFAULT_GAP_S};
pub use rows::{Effect, Presence, RecordingRow, RoleComposition};

/// Shared runs shorter than this many rows (1 s at 100 Hz) are not reported.
pub const DEFAULT_MIN_RUN_ROWS: usize = 100;

/// Knobs of the audit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AuditOptions {
    /// The shortest run of identical rows reported as near-leakage.
    pub min_run_rows: usize,
    /// The declared gap, seconds: a window whose nearest window of another
    /// role is closer than this is counted as within it.
    pub gap_s: f64,
}

impl Default for AuditOptions {
    fn default() -> AuditOptions {
        AuditOptions { min_run_rows: DEFAULT_MIN_RUN_ROWS, gap_s: DEFAULT_GAP_S }
    }
}

/// A content-identity group with members in two or more roles.
#[derive(Debug, Clone, Serialize)]
pub struct ExactLeak {
    /// XXH3-128 of the shared data rows.
    pub content_hash: String,
    /// Members as (role, recording, kept).
    pub members: Vec<(String, String, bool)>,
    /// Whether copies survive the rules in two or more roles.
    pub effective: bool,
}

/// Two recordings in different roles sharing a long run of identical rows.
#[derive(Debug, Clone, Serialize)]
pub struct SharedRun {
    /// One side: (role, recording, first row of the run, 1-based data row).
    pub a: (String, String, usize),
    /// The other side.
    pub b: (String, String, usize),
    /// Length of the longest shared run, rows.
    pub rows: usize,
}

/// Declared and effective membership of one role.
#[derive(Debug, Clone, Serialize)]
pub struct RoleSummary {
    /// Role name.
    pub role: String,
    /// Recordings the file declares in it.
    pub declared: usize,
    /// Windows it declares, in a per-window split (0: whole recordings).
    pub windows: usize,
    /// Of its windows in kept recordings, those that end more than one
    /// sample interval after the recording's last timestamp.
    pub windows_past_end: usize,
    /// Entries with a CSV.
    pub with_csv: usize,
    /// Entries with only a metadata file.
    pub metadata_only: usize,
    /// Entries the data directory does not know.
    pub unknown: usize,
    /// Entries present but dropped by the rules.
    pub dropped: usize,
    /// Entries kept: the effective size.
    pub effective: usize,
    /// Distinct contents among the kept ones.
    pub effective_distinct: usize,
    /// Entries with a CSV that have an identical copy in another role.
    pub with_identical_elsewhere: usize,
    /// Kept entries with a kept identical copy in another role.
    pub effective_with_identical_elsewhere: usize,
}

/// Counts for an ordered pair of roles: of the `role` recordings, how many...
#[derive(Debug, Clone, Serialize)]
pub struct PairCounts {
    /// The role counted.
    pub role: String,
    /// The other role.
    pub other: String,
    /// ...have an identical copy in `other` (CSV present).
    pub identical: usize,
    /// ...have one with both copies kept.
    pub identical_effective: usize,
    /// ...share a run of identical rows with a recording of `other`
    /// (identical copies not counted).
    pub shared_run: usize,
    /// ...kept, whose trajectory x speed occurs among `other`'s kept ones.
    pub same_condition: usize,
}

/// The audit of one published split.
#[derive(Debug, Clone, Serialize)]
pub struct SplitAudit {
    /// The split file, as given.
    pub split_file: String,
    /// Its SHA-256.
    pub split_sha256: String,
    /// The form it was read as.
    pub format: Format,
    /// Scalar notes of the file (e.g. its seed).
    pub notes: BTreeMap<String, String>,
    /// The data directory.
    pub data_dir: String,
    /// Where the rules came from: a design file, or upstream's task-2 loader.
    pub rules_from: String,
    /// The inclusion rules applied, in order.
    pub rules: Vec<String>,
    /// The knobs.
    pub options: AuditOptions,
    /// Roles in file order.
    pub roles: Vec<RoleSummary>,
    /// Every ordered pair of distinct roles.
    pub pairs: Vec<PairCounts>,
    /// Identity groups spanning roles.
    pub exact: Vec<ExactLeak>,
    /// Shared runs across roles, longest first.
    pub shared_runs: Vec<SharedRun>,
    /// Composition of the kept recordings.
    pub composition: RoleComposition,
    /// Whether the split assigns windows rather than whole recordings.
    pub windowed: bool,
    /// Distance in time, every ordered pair of distinct roles.
    pub distances: Vec<PairDistance>,
    /// Each window's nearest window in each other role where they share a
    /// recording (split_windows.csv; not in the JSON).
    #[serde(skip)]
    pub windows: Vec<RoleWindowDistance>,
    /// Every declared entry, then every unlisted recording.
    pub recordings: Vec<RecordingRow>,
}

/// Why a split could not be audited.
#[derive(Debug, thiserror::Error)]
pub enum SplitAuditError {
    /// The data directory could not be audited.
    #[error(transparent)]
    Data(#[from] AuditError),
    /// An output could not be written.
    #[error(transparent)]
    Write(#[from] crate::io::WriteError),
}

impl SplitAudit {
    /// Whether two roles hold identical recordings (CSV present on
    /// both sides), or, in a per-window split, windows that share rows.
    pub fn has_exact_leak(&self) -> bool {
        !self.exact.is_empty() || self.distances.iter().any(|d| d.overlapping > 0)
    }

    /// Whether a window of one role lies within the declared gap of a
    /// window of another.
    pub fn has_gap_violation(&self) -> bool {
        self.distances.iter().any(|d| d.within_gap > 0)
    }

    /// Writes split_audit.md, split_audit.json, split_recordings.csv and
    /// split_windows.csv into `dir`.
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>, SplitAuditError> {
        crate::io::create_dir_all(dir)?;
        let mut out = Vec::new();
        for (name, text) in [
            ("split_audit.md", self.to_markdown()),
            ("split_audit.json", crate::io::pretty_json(self)),
            ("split_recordings.csv", self.to_csv()),
            ("split_windows.csv", self.windows_csv()),
        ] {
            let path = dir.join(name);
            crate::io::write_atomic(&path, text.as_bytes())?;
            out.push(path);
        }
        Ok(out)
    }
}

/// Audits `split` against the recordings in `dir` under the data rules
/// `spec`; `rules_from` says where those came from.
///
/// ```
/// use std::path::Path;
/// let split = crossaudit::published::read(Path::new("tests/fixtures/splits/nanobench_small.json")).unwrap();
/// let spec = crossaudit::design::DataSpec::upstream_task2();
/// let audit = crossaudit::split_audit::audit(&split, &spec, "upstream", Path::new("tests/fixtures/nanobench"), Default::default()).unwrap();
/// assert_eq!(audit.roles.len(), 3);
/// ```
pub fn audit(
    split: &PublishedSplit,
    spec: &DataSpec,
    rules_from: &str,
    dir: &Path,
    options: AuditOptions,
) -> Result<SplitAudit, SplitAuditError> {
    let (data_audit, loaded) = data::audit_and_hash_rows(spec, dir)?;
    let by_name: BTreeMap<&str, usize> =
        data_audit.files.iter().enumerate().map(|(k, f)| (f.name.as_str(), k)).collect();
    // One row per role and recording: a per-window split lists a
    // recording once per window.
    let mut rows: Vec<RecordingRow> = Vec::new();
    let mut row_at: BTreeMap<(&str, &str), usize> = BTreeMap::new();
    for (role, e) in split.entries() {
        if let Some(&k) = row_at.get(&(role.name.as_str(), e.name.as_str())) {
            rows[k].windows += 1;
            continue;
        }
        let file = by_name.get(e.name.as_str()).map(|&k| &data_audit.files[k]);
        let mut row = row_of(&e.name, file);
        row.role = role.name.clone();
        row.listed_as = e.listed.clone();
        (row.line, row.column) = (e.at.line, e.at.column);
        row.windows = usize::from(e.window.is_some());
        row_at.insert((&role.name, &e.name), rows.len());
        rows.push(row);
    }
    let declared: BTreeSet<&str> = split.entries().map(|(_, e)| e.name.as_str()).collect();
    for f in data_audit.files.iter().filter(|f| !declared.contains(f.name.as_str())) {
        rows.push(row_of(&f.name, Some(f)));
    }
    let exact = exact_leaks(&mut rows);
    let listed: Vec<usize> = (0..rows.len()).filter(|&k| !rows[k].role.is_empty()).collect();
    let hashes_of = |k: usize| by_name.get(rows[k].recording.as_str()).and_then(|&i| loaded[i].as_deref());
    let hashed: Vec<(usize, &[u64])> = listed.iter().filter_map(|&k| hashes_of(k).map(|h| (k, h))).collect();
    let shared_runs = shared_runs(&mut rows, &hashed, options.min_run_rows);
    same_conditions(&mut rows);
    let role_names: Vec<String> = split.roles.iter().map(|r| r.name.clone()).collect();
    let found = distance::distances(split, &rows, options.gap_s);
    let mut roles: Vec<RoleSummary> = role_names.iter().map(|r| summary(r, &rows)).collect();
    for r in &mut roles {
        r.windows_past_end = found.past_end.get(&r.role).copied().unwrap_or(0);
    }
    let pairs = pair_counts(&role_names, &rows, &shared_runs);
    let composition = composition::composition(&role_names, &rows);
    Ok(SplitAudit {
        split_file: split.path.clone(),
        split_sha256: split.sha256.clone(),
        format: split.format,
        notes: split.notes.clone(),
        data_dir: dir.display().to_string(),
        rules_from: rules_from.to_string(),
        rules: data_audit.rules.clone(),
        options,
        roles,
        pairs,
        exact,
        shared_runs,
        composition,
        windowed: split.is_windowed(),
        distances: found.pairs,
        windows: found.windows,
        recordings: rows,
    })
}

fn row_of(name: &str, file: Option<&FileRow>) -> RecordingRow {
    let parts = data::parse_name(name);
    let mut row = RecordingRow {
        recording: name.to_string(),
        role: String::new(),
        listed_as: String::new(),
        line: 0,
        column: 0,
        windows: 0,
        presence: Presence::Unknown,
        effect: Effect::Absent,
        reason: "no CSV and no metadata file of this name in the data directory".into(),
        trajectory: parts.shape,
        speed: parts.speed,
        rows: 0,
        active_rows: 0,
        duration_s: 0.0,
        content_hash: String::new(),
        identical_in_other_roles: Vec::new(),
        longest_shared_run: None,
        same_condition_in_other_roles: 0,
    };
    let Some(f) = file else { return row };
    row.trajectory = f.trajectory.clone();
    row.speed = f.speed.clone();
    row.rows = f.rows;
    row.active_rows = f.active_rows;
    row.duration_s = f.duration_s;
    row.content_hash = f.content_hash.clone();
    // Notes (`note: ...`) on kept files are the data audit's, not a reason to drop.
    let reason = f.reason.split("; note: ").next().unwrap_or("").to_string();
    (row.presence, row.effect, row.reason) = match f.status {
        Status::Included => (Presence::Csv, Effect::Kept, String::new()),
        Status::Excluded => (Presence::Csv, Effect::Dropped, reason),
        Status::Missing => (Presence::MetadataOnly, Effect::Absent, "only a metadata file; no CSV".into()),
    };
    row
}

/// Whether `b` is another recording in another role: copies and shared
/// conditions are counted between such pairs only (in a per-window split
/// a recording sits in several roles; its windows' distance is measured
/// in [`distance`]).
fn elsewhere(a: &RecordingRow, b: &RecordingRow) -> bool {
    !b.role.is_empty() && a.role != b.role && a.recording != b.recording
}

/// Groups listed recordings by content; a group holding two recordings in
/// two roles is a leak.
fn exact_leaks(rows: &mut [RecordingRow]) -> Vec<ExactLeak> {
    let mut groups: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (k, r) in rows.iter().enumerate() {
        if !r.role.is_empty() && !r.content_hash.is_empty() {
            groups.entry(r.content_hash.clone()).or_default().push(k);
        }
    }
    let mut leaks = Vec::new();
    for (hash, members) in groups {
        let spans = |kept: bool| {
            members.iter().any(|&i| {
                members.iter().any(|&j| {
                    elsewhere(&rows[i], &rows[j])
                        && (!kept || (rows[i].effect == Effect::Kept && rows[j].effect == Effect::Kept))
                })
            })
        };
        if !spans(false) {
            continue;
        }
        let effective = spans(true);
        for &k in &members {
            rows[k].identical_in_other_roles = members
                .iter()
                .filter(|&&j| elsewhere(&rows[k], &rows[j]))
                .map(|&j| format!("{}:{}", rows[j].role, rows[j].recording))
                .collect();
        }
        let members = members
            .iter()
            .map(|&k| (rows[k].role.clone(), rows[k].recording.clone(), rows[k].effect == Effect::Kept))
            .collect();
        leaks.push(ExactLeak { content_hash: hash, members, effective });
    }
    // In the order of the split file's first member.
    leaks.sort_by_key(|l| {
        l.members.iter().filter_map(|(_, name, _)| rows.iter().position(|r| &r.recording == name)).min()
    });
    leaks
}

/// Finds runs of at least `min_rows` identical rows shared by recordings of
/// two roles that are not identical copies; records the longest per row.
fn shared_runs(rows: &mut [RecordingRow], hashed: &[(usize, &[u64])], min_rows: usize) -> Vec<SharedRun> {
    let found = runs::longest_shared(hashed, min_rows, &|a, b| {
        rows[a].role != rows[b].role && rows[a].content_hash != rows[b].content_hash
    });
    let mut out = Vec::new();
    for run in found {
        let (a, b) = (run.a, run.b);
        for (me, other) in [(a, b), (b, a)] {
            let longer = rows[me].longest_shared_run.as_ref().is_none_or(|(n, _)| run.rows > *n);
            if longer {
                let label = format!("{}:{}", rows[other].role, rows[other].recording);
                rows[me].longest_shared_run = Some((run.rows, label));
            }
        }
        out.push(SharedRun {
            a: (rows[a].role.clone(), rows[a].recording.clone(), run.start_a + 1),
            b: (rows[b].role.clone(), rows[b].recording.clone(), run.start_b + 1),
            rows: run.rows,
        });
    }
    out.sort_by(|x, y| y.rows.cmp(&x.rows).then_with(|| x.a.1.cmp(&y.a.1)).then_with(|| x.b.1.cmp(&y.b.1)));
    out
}

/// For each kept listed recording: kept recordings of other roles with the
/// same trajectory and speed.
fn same_conditions(rows: &mut [RecordingRow]) {
    let kept = |r: &RecordingRow| !r.role.is_empty() && r.effect == Effect::Kept;
    let counts: Vec<usize> = rows
        .iter()
        .map(|r| {
            let same =
                |o: &&RecordingRow| kept(o) && elsewhere(r, o) && o.trajectory == r.trajectory && o.speed == r.speed;
            if kept(r) {
                rows.iter().filter(same).count()
            } else {
                0
            }
        })
        .collect();
    for (r, n) in rows.iter_mut().zip(counts) {
        r.same_condition_in_other_roles = n;
    }
}

fn summary(role: &str, rows: &[RecordingRow]) -> RoleSummary {
    let mine: Vec<&RecordingRow> = rows.iter().filter(|r| r.role == role).collect();
    let count = |f: &dyn Fn(&RecordingRow) -> bool| mine.iter().filter(|r| f(r)).count();
    let kept_hashes: BTreeSet<&str> =
        mine.iter().filter(|r| r.effect == Effect::Kept).map(|r| r.content_hash.as_str()).collect();
    let kept_elsewhere = |r: &RecordingRow| {
        rows.iter().any(|o| elsewhere(r, o) && o.effect == Effect::Kept && o.content_hash == r.content_hash)
    };
    RoleSummary {
        role: role.to_string(),
        declared: mine.len(),
        windows: mine.iter().map(|r| r.windows).sum(),
        windows_past_end: 0,
        with_csv: count(&|r| r.presence == Presence::Csv),
        metadata_only: count(&|r| r.presence == Presence::MetadataOnly),
        unknown: count(&|r| r.presence == Presence::Unknown),
        dropped: count(&|r| r.effect == Effect::Dropped),
        effective: count(&|r| r.effect == Effect::Kept),
        effective_distinct: kept_hashes.len(),
        with_identical_elsewhere: count(&|r| !r.identical_in_other_roles.is_empty()),
        effective_with_identical_elsewhere: count(&|r| r.effect == Effect::Kept && kept_elsewhere(r)),
    }
}

fn pair_counts(roles: &[String], rows: &[RecordingRow], runs: &[SharedRun]) -> Vec<PairCounts> {
    let mut out = Vec::new();
    for role in roles {
        for other in roles.iter().filter(|o| *o != role) {
            let mine: Vec<&RecordingRow> = rows.iter().filter(|r| &r.role == role).collect();
            let copies = |r: &RecordingRow, kept: bool| {
                !r.content_hash.is_empty()
                    && (!kept || r.effect == Effect::Kept)
                    && rows.iter().any(|o| {
                        &o.role == other
                            && o.recording != r.recording
                            && o.content_hash == r.content_hash
                            && (!kept || o.effect == Effect::Kept)
                    })
            };
            let identical = mine.iter().filter(|r| copies(r, false)).count();
            let identical_effective = mine.iter().filter(|r| copies(r, true)).count();
            let sharing: BTreeSet<&str> = runs
                .iter()
                .flat_map(|s| [(&s.a, &s.b), (&s.b, &s.a)])
                .filter(|(me, them)| &me.0 == role && &them.0 == other)
                .map(|(me, _)| me.1.as_str())
                .collect();
            let theirs: Vec<&RecordingRow> =
                rows.iter().filter(|o| &o.role == other && o.effect == Effect::Kept).collect();
            let same_condition = mine
                .iter()
                .filter(|r| {
                    r.effect == Effect::Kept
                        && theirs
                            .iter()
                            .any(|o| o.recording != r.recording && o.trajectory == r.trajectory && o.speed == r.speed)
                })
                .count();
            out.push(PairCounts {
                role: role.clone(),
                other: other.clone(),
                identical,
                identical_effective,
                shared_run: sharing.len(),
                same_condition,
            });
        }
    }
    out
}
