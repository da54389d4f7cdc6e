//! The inclusion audit: every file gets a row saying what it is and which
//! declared rule kept or dropped it. A corrupt or unreadable file never
//! stops the audit (unless the design says `strict`).

mod bounds;
mod error;
mod files;
mod policies;
mod render;

pub use error::AuditError;
use files::load_files;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::metadata::{impossible_values, parse_name, read_metadata, Metadata};
use super::{load_recording, natural_key, recording_name, Layout, Recording};
use crate::design::{
    DataSource, DataSpec, DuplicatePolicy, InclusionRule, Pooling, SpeedLabels, Strictness, TailPolicy,
};

/// Upstream NanoBench plausibility bounds over active rows, each checked at
/// the 0.5th and 99.5th percentiles.
pub const BATTERY_BOUNDS_V: (f64, f64) = (2.5, 4.5);
/// Setpoint z bounds, metres.
pub const SETPOINT_Z_BOUNDS_M: (f64, f64) = (-0.2, 3.0);
/// Motor PWM bounds.
pub const PWM_BOUNDS: (f64, f64) = (0.0, 65535.0);
/// The lower and upper percentiles at which every bound is checked.
pub const PERCENTILES: (f64, f64) = (0.005, 0.995);

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
    /// Identity group shared with byte-identical recordings, if any.
    pub duplicate_group: Option<String>,
    /// The extrapolated onboard tail, if the file has one.
    pub tail: Option<super::Tail>,
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
}

fn rule_label(rule: &InclusionRule) -> String {
    match rule {
        InclusionRule::Active { column, cmp, threshold, min_samples } => {
            format!("active({column} {} {threshold}) >= {min_samples} samples", cmp.symbol())
        }
        InclusionRule::Implausible => "plausible (upstream percentile bounds)".to_string(),
        InclusionRule::Named { .. } => "`exclude recordings`".to_string(),
        InclusionRule::Frozen { seconds } => format!("`exclude frozen position for {seconds} s`"),
        InclusionRule::Beyond { quantity, limit } => {
            let (what, unit) = quantity.words();
            format!("`exclude beyond {what} {limit} {unit}`")
        }
    }
}

fn labels(spec: &DataSpec) -> Vec<String> {
    let mut out: Vec<String> = spec.rules.iter().map(rule_label).collect();
    for (k, r) in spec.rules.iter().enumerate() {
        if *r == InclusionRule::Implausible {
            out[k] = match spec.plausibility {
                Pooling::Pooled => "plausible (upstream percentile bounds, motors pooled)".to_string(),
                Pooling::PerColumn => "plausible (upstream percentile bounds, per motor)".to_string(),
            };
        }
    }
    out.extend(policies::labels(spec));
    out
}

/// The log files and metadata-only names in `dir` (and its subfolders,
/// with `folders nested`).
fn list(dir: &Path, nested: bool) -> Result<(Vec<PathBuf>, Vec<String>), AuditError> {
    let err = |e: std::io::Error| AuditError::Dir { dir: dir.display().to_string(), message: e.to_string() };
    let mut csvs = Vec::new();
    let mut metas = Vec::new();
    for path in crate::io::walk::files_below(dir, nested).map_err(err)? {
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let log = super::is_log_name(&name) || name.ends_with("_metadata.yaml");
        if log && crate::io::walk::relative(dir, &path).chars().any(char::is_control) {
            return Err(AuditError::ControlInName { dir: dir.display().to_string(), name });
        }
        if super::is_log_name(&name) {
            csvs.push(path);
        } else if let Some(stem) = name.strip_suffix("_metadata.yaml") {
            metas.push(stem.to_string());
        }
    }
    csvs.sort_by_key(|p| (natural_key(&recording_name(p)), p.clone()));
    let names: Vec<String> = csvs.iter().map(|p| recording_name(p)).collect();
    if let Some(k) = (1..names.len()).find(|&k| names[k] == names[k - 1]) {
        let file = |p: &Path| crate::io::walk::relative(dir, p);
        return Err(AuditError::SameName {
            dir: dir.display().to_string(),
            name: names[k].clone(),
            first: file(&csvs[k - 1]),
            second: file(&csvs[k]),
        });
    }
    let mut missing: Vec<String> = metas.into_iter().filter(|m| !names.contains(m)).collect();
    missing.sort_by_key(|n| natural_key(n));
    Ok((csvs, missing))
}

/// Loads every recording in `dir` and applies the declared rules in order.
pub fn audit(spec: &DataSpec, dir: &Path) -> Result<Audit, AuditError> {
    audit_with(spec, dir, Keep::None).map(|(a, _)| a)
}

/// As [`audit`], and also returns the included recordings (in audit row
/// order), loaded once.
///
/// ```
/// use std::path::Path;
/// let file = crossaudit::design::load(Path::new("tests/designs/fixture_data.design")).unwrap();
/// let (audit, recordings) =
///     crossaudit::data::audit_and_load(&file.design.data, Path::new("tests/fixtures/nanobench")).unwrap();
/// assert_eq!(audit.included().count(), recordings.len());
/// assert!(audit.files.len() > recordings.len()); // the implausible fixture is excluded
/// ```
pub fn audit_and_load(spec: &DataSpec, dir: &Path) -> Result<(Audit, Vec<Recording>), AuditError> {
    let (audit, recordings) = audit_with(spec, dir, Keep::Included)?;
    Ok((audit, recordings.into_iter().flatten().collect()))
}

/// As [`audit`], and also returns the row hashes (see
/// [`Recording::row_hashes`]) of every readable recording, excluded ones
/// too: entry `k` belongs to `audit.files[k]` (`None` for a file that could
/// not be read or has no CSV). The split audit reads excluded files as well,
/// since a loader with other rules would keep them; it keeps only the hashes.
pub fn audit_and_hash_rows(spec: &DataSpec, dir: &Path) -> Result<(Audit, Vec<RowHashes>), AuditError> {
    let (audit, recordings) = audit_with(spec, dir, Keep::RowHashes)?;
    Ok((audit, recordings.into_iter().map(|r| r.map(|r| r.row_hashes)).collect()))
}

/// The row hashes of one file of an audit, if it could be read.
pub type RowHashes = Option<Vec<u64>>;

/// Which loaded recordings an audit returns.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Keep {
    None,
    Included,
    /// Every readable recording, emptied of all but its row hashes.
    RowHashes,
}

/// The audit of `dir` under `spec`, and the recordings `keep` asks for
/// (entry `k` belongs to the audit's row `k`).
fn audit_with(spec: &DataSpec, dir: &Path, keep: Keep) -> Result<(Audit, Vec<Option<Recording>>), AuditError> {
    let layout = Layout::new(spec).map_err(AuditError::Layout)?;
    let layout = if keep == Keep::RowHashes { layout.with_row_hashes() } else { layout };
    implausible_columns(spec)?;
    let nested = spec.format.as_ref().is_some_and(|f| f.nested_folders);
    let (mut csvs, missing) = list(dir, nested)?;
    excluded_names_exist(spec, dir, &csvs)?;
    let table = conditions_table(spec, dir, &mut csvs)?;
    possible_metadata(dir, &csvs, &missing)?;
    let (mut files, mut recordings) = load_files(spec, dir, &csvs, &layout, keep)?;
    super::conditions::apply(spec, dir, &mut files, table.as_ref())?;
    let groups = duplicates(&mut files, spec.duplicates);
    if keep == Keep::Included {
        for (f, r) in files.iter().zip(recordings.iter_mut()) {
            if f.status != Status::Included {
                *r = None;
            }
        }
    }
    for name in missing {
        let meta = read_metadata(&dir.join(format!("{name}_metadata.yaml"))).ok();
        let mut row = blank(spec, &name, "", meta.as_ref());
        row.status = Status::Missing;
        row.reason = "listed by its metadata file, but no CSV is present".into();
        files.push(row);
        recordings.push(None);
    }
    if spec.strictness == Strictness::Strict {
        strict(&files)?;
    }
    let audit = Audit {
        data_dir: dir.display().to_string(),
        rules: labels(spec),
        duplicates: spec.duplicates,
        tails: spec.tails,
        quaternion_tolerance: spec.format.as_ref().and_then(|f| f.quaternion_tolerance),
        files,
        duplicate_groups: groups,
    };
    Ok((audit, recordings))
}

/// `exclude implausible` reads the battery and the setpoint's z: both
/// must be state columns.
fn implausible_columns(spec: &DataSpec) -> Result<(), AuditError> {
    if spec.rules.contains(&InclusionRule::Implausible) {
        for needed in ["pwr_pm_vbat", "sp_ctrltarget_z"] {
            if !spec.state_columns.iter().any(|c| c == needed) {
                return Err(AuditError::Layout(format!("`exclude implausible` needs `{needed}` in the state columns")));
            }
        }
    }
    Ok(())
}

/// A name the design excludes that is no log here: a typo, or the wrong
/// folder; the exclusion would silently exclude nothing.
fn excluded_names_exist(spec: &DataSpec, dir: &Path, csvs: &[PathBuf]) -> Result<(), AuditError> {
    for rule in &spec.rules {
        if let InclusionRule::Named { names } = rule {
            if let Some(n) = names.iter().find(|n| !csvs.iter().any(|p| recording_name(p) == **n)) {
                return Err(AuditError::Layout(format!(
                    "`exclude recordings` names {n:?}, which is not a log in {}; list the recordings by their file names without `.csv`",
                    dir.display()
                )));
            }
        }
    }
    Ok(())
}

/// A conditions table, by recording name, and the file it was read from.
type ConditionsTable = (BTreeMap<String, super::conditions::Conditions>, PathBuf);

/// The declared conditions table, read, and its path; it is in the data
/// folder, and is taken out of the logs `csvs`.
fn conditions_table(
    spec: &DataSpec,
    dir: &Path,
    csvs: &mut Vec<PathBuf>,
) -> Result<Option<ConditionsTable>, AuditError> {
    let Some(name) = spec.format.as_ref().and_then(|f| f.conditions_table.as_ref()) else { return Ok(None) };
    csvs.retain(|p| p.file_name().is_none_or(|f| f.to_string_lossy() != *name));
    let path = dir.join(name);
    let format = spec.format.as_ref();
    let columns = format.map(|f| f.conditions_columns.clone()).unwrap_or_default();
    let folder = format.and_then(|f| f.conditions_folder);
    Ok(Some((super::conditions::read_table(&path, &columns, folder).map_err(AuditError::Layout)?, path)))
}

/// No metadata file, of a log here or of one listed as missing, holds an
/// impossible value: all of them are named at once.
fn possible_metadata(dir: &Path, csvs: &[PathBuf], missing: &[String]) -> Result<(), AuditError> {
    let metas = csvs.iter().map(|p| meta_path(p)).chain(missing.iter().map(|n| dir.join(format!("{n}_metadata.yaml"))));
    let impossible: Vec<String> =
        metas.flat_map(|p| read_metadata(&p).map(|m| impossible_values(&p, &m)).unwrap_or_default()).collect();
    if !impossible.is_empty() {
        return Err(AuditError::Metadata {
            count: impossible.len(),
            list: impossible.iter().map(|l| format!("  {l}")).collect::<Vec<_>>().join("\n"),
        });
    }
    Ok(())
}

/// Under `strict`, any file excluded for being unreadable (no rule's
/// verdict) or with broken metadata stops the audit, all named at once.
fn strict(files: &[FileRow]) -> Result<(), AuditError> {
    let mut bad: Vec<String> = files
        .iter()
        .filter(|f| f.status == Status::Excluded && f.verdicts.is_empty())
        .map(|f| format!("  {}", f.reason))
        .collect();
    bad.extend(files.iter().filter_map(|f| f.broken_metadata.as_ref()).map(|m| format!("  {m}")));
    if !bad.is_empty() {
        return Err(AuditError::Strict { count: bad.len(), list: bad.join("\n") });
    }
    Ok(())
}

fn meta_path(csv: &Path) -> PathBuf {
    csv.with_file_name(format!("{}_metadata.yaml", recording_name(csv)))
}

fn blank(spec: &DataSpec, name: &str, file: &str, meta: Option<&Metadata>) -> FileRow {
    let parts = parse_name(name);
    let speed_mps = meta.and_then(|m| m.params.speed_mps);
    let speed = match &spec.speed {
        SpeedLabels::Name => parts.speed.clone(),
        SpeedLabels::Metadata { labels, thresholds } => SpeedLabels::label(labels, thresholds, speed_mps),
    };
    let count = |k: &str| meta.and_then(|m| m.row_counts.get(k).copied());
    FileRow {
        name: name.to_string(),
        file: file.to_string(),
        rows: 0,
        active_rows: 0,
        duration_s: 0.0,
        trajectory: meta.and_then(|m| m.trajectory_type.clone()).unwrap_or_else(|| parts.shape.clone()),
        speed,
        speed_mps,
        // Declared (`data csv`), or NanoBench's names: `_mell` for
        // Mellinger, nothing for its PID.
        controller: match spec.format.as_ref().and_then(|f| f.controller.clone()) {
            Some(declared) => declared,
            None => parts.controller.name().to_string(),
        },
        // The file name's `repN` is the recording's identity; the metadata's
        // `repetition` sometimes disagrees (noted in `judged`).
        repetition: parts.repetition.or(meta.and_then(|m| m.repetition)),
        start_utc: meta.and_then(|m| m.recording_start_utc.clone()),
        battery_start_v: meta.and_then(|m| m.battery_voltage_start),
        battery_end_v: meta.and_then(|m| m.battery_voltage_end),
        duplicate_group: None,
        tail: None,
        rows_cut: 0,
        quaternion_deviation: None,
        onboard_row_counts: (count("estimator"), count("attitude")),
        content_hash: String::new(),
        verdicts: Vec::new(),
        broken_metadata: None,
        status: Status::Included,
        reason: String::new(),
    }
}

fn file_name(path: &Path) -> String {
    path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default()
}

fn unreadable(spec: &DataSpec, path: &Path, meta: Result<Metadata, String>, why: String) -> FileRow {
    let mut row = blank(spec, &recording_name(path), &file_name(path), meta.as_ref().ok());
    row.status = Status::Excluded;
    row.reason = why;
    row
}

fn judged(spec: &DataSpec, rec: &Recording, meta: Result<Metadata, String>) -> FileRow {
    let mut row = blank(spec, &rec.name, &file_name(&rec.path), meta.as_ref().ok());
    row.tail = rec.tail;
    row.rows_cut = rec.rows_cut;
    row.quaternion_deviation = rec.quaternion_deviation;
    row.rows = rec.rows;
    row.active_rows = rec.active_rows();
    row.duration_s = rec.duration_s();
    row.content_hash = rec.content_hash.clone();
    for (rule, label) in spec.rules.iter().zip(labels(spec)) {
        let (pass, detail) = match rule {
            InclusionRule::Active { min_samples, .. } => {
                let n = rec.active_rows() as u64;
                (n >= *min_samples, format!("{n} active rows"))
            }
            InclusionRule::Implausible => bounds::plausible(spec, rec),
            InclusionRule::Named { names } => match names.contains(&rec.name) {
                true => (false, "listed by name in the design".to_string()),
                false => (true, "not listed".to_string()),
            },
            InclusionRule::Frozen { seconds } => bounds::frozen(rec, *seconds),
            InclusionRule::Beyond { quantity, limit } => bounds::beyond(rec, *quantity, *limit),
        };
        if !pass && row.status == Status::Included {
            row.status = Status::Excluded;
            row.reason = format!("{label}: {detail}");
        }
        row.verdicts.push(Verdict { rule: label, pass, detail });
    }
    let policy_labels = labels(spec).into_iter().skip(spec.rules.len());
    for (label, (pass, detail)) in policy_labels.zip(policies::verdicts(spec, rec)) {
        if !pass && row.status == Status::Included {
            row.status = Status::Excluded;
            row.reason = format!("{label}: {detail}");
        }
        row.verdicts.push(Verdict { rule: label, pass, detail });
    }
    if let (Some(tail), TailPolicy::Exclude) = (rec.tail, spec.tails) {
        if row.status == Status::Included {
            row.status = Status::Excluded;
            row.reason = format!(
                "tails exclude: onboard streams end at row {} ({} extrapolated rows, {} active)",
                tail.start + 1,
                tail.rows,
                tail.active
            );
        }
    }
    let note = match &meta {
        Err(e) => Some(e.clone()),
        Ok(m) => match (m.repetition, parse_name(&rec.name).repetition) {
            (Some(a), Some(b)) if a != b => Some(format!("metadata says repetition {a}, the file name rep{b}")),
            _ => super::clipped_actions(rec, spec.action_scale()),
        },
    };
    if let Some(note) = note {
        row.reason =
            if row.reason.is_empty() { format!("note: {note}") } else { format!("{}; note: {note}", row.reason) };
    }
    row
}

/// Groups identical content and applies the policy. Groups are named
/// `dup1`, `dup2`, ... in the order of their first member.
fn duplicates(files: &mut [FileRow], policy: DuplicatePolicy) -> BTreeMap<String, Vec<String>> {
    let mut by_hash: Vec<(String, Vec<usize>)> = Vec::new();
    for (k, f) in files.iter().enumerate() {
        if f.content_hash.is_empty() {
            continue;
        }
        match by_hash.iter_mut().find(|(h, _)| *h == f.content_hash) {
            Some((_, members)) => members.push(k),
            None => by_hash.push((f.content_hash.clone(), vec![k])),
        }
    }
    let mut groups = BTreeMap::new();
    let mut n = 0;
    for (_, members) in by_hash.into_iter().filter(|(_, m)| m.len() > 1) {
        n += 1;
        let id = format!("dup{n:02}");
        for &k in &members {
            files[k].duplicate_group = Some(id.clone());
        }
        if policy == DuplicatePolicy::First {
            let keeper = members.iter().copied().find(|&k| files[k].status == Status::Included);
            for &k in &members {
                if Some(k) != keeper && files[k].status == Status::Included {
                    let first = keeper.map(|j| files[j].name.clone()).unwrap_or_default();
                    files[k].status = Status::Excluded;
                    files[k].reason = format!("duplicates first: identical content to {first}");
                }
            }
        }
        groups.insert(id, members.iter().map(|&k| files[k].name.clone()).collect());
    }
    groups
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
