//! The inclusion audit: every file gets a row saying what it is and which
//! declared rule kept or dropped it. A corrupt or unreadable file never
//! stops the audit (unless the design says `strict`).

mod bounds;
mod error;
mod files;
mod judge;
mod policies;
mod render;
mod row;

pub use bounds::{BATTERY_BOUNDS_V, PERCENTILES, PWM_BOUNDS, SETPOINT_Z_BOUNDS_M};
pub use error::AuditError;
use files::load_files;
use judge::{blank, labels, meta_path};
use row::Keep;
pub use row::{unread_sentence, Audit, FileRow, RowHashes, Status, Verdict};

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::metadata::{impossible_values, read_metadata};
use super::{natural_key, recording_name, Layout, Recording};
use crate::design::{DataSpec, DuplicatePolicy, InclusionRule, Strictness};

/// What [`list`] finds: the log files, the metadata-only names, and in
/// words the hidden files that look like logs (a name beginning with `.`,
/// as macOS's `._` copies are), which are not read.
type Listed = (Vec<PathBuf>, Vec<String>, Option<String>);

/// The log files and metadata-only names in `dir` (and its subfolders,
/// with `folders nested`), and the hidden files named like logs.
fn list(dir: &Path, nested: bool) -> Result<Listed, AuditError> {
    let err = |e: std::io::Error| AuditError::Dir { dir: dir.display().to_string(), message: e.to_string() };
    let mut csvs = Vec::new();
    let mut metas = Vec::new();
    let mut unread = Vec::new();
    let mut hidden = Vec::new();
    for path in crate::io::walk::files_below(dir, nested).map_err(err)? {
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        if name.starts_with('.') {
            if super::is_log_name(&name) || name.ends_with("_metadata.yaml") {
                hidden.push(crate::io::walk::relative(dir, &path));
            }
            continue;
        }
        let log = super::is_log_name(&name) || name.ends_with("_metadata.yaml");
        if log && crate::io::walk::relative(dir, &path).chars().any(char::is_control) {
            return Err(AuditError::ControlInName { dir: dir.display().to_string(), name });
        }
        if super::is_log_name(&name) && crate::io::formula_like(&recording_name(&path)) {
            return Err(AuditError::FormulaName { dir: dir.display().to_string(), name });
        }
        if super::is_log_name(&name) && recording_name(&path).trim() != recording_name(&path) {
            return Err(AuditError::SpaceInName { dir: dir.display().to_string(), name });
        }
        if super::is_log_name(&name) {
            csvs.push(path);
        } else if let Some(stem) = name.strip_suffix("_metadata.yaml") {
            metas.push(stem.to_string());
        } else if let Some(why) = not_read(&name) {
            unread.push(format!("{} ({why})", crate::io::walk::relative(dir, &path)));
        }
    }
    if !unread.is_empty() {
        return Err(AuditError::NotRead { dir: dir.display().to_string(), files: unread });
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
    let hidden = (!hidden.is_empty()).then(|| {
        format!(
            "{} hidden file(s) named like logs or metadata (the first: {}): a name beginning with `.` is hidden, as the `._` copies macOS leaves beside files are; rename one to read it",
            hidden.len(),
            hidden[0]
        )
    });
    Ok((csvs, missing, hidden))
}

/// Why a file that looks like a flight log is not read as named: a log's
/// suffix in other letters' case (`x.PARQUET`, `x.Csv`), or a compressed
/// form only `.csv.gz` has (`x.parquet.gz`, `x.csv.zst`); `None` for any
/// other file.
fn not_read(name: &str) -> Option<&'static str> {
    let lower = name.to_lowercase();
    if super::is_log_name(&lower) {
        return Some("a log's suffix is lower case");
    }
    let compressed = [".gz", ".bz2", ".xz", ".zst", ".zip", ".7z"];
    let inner = compressed.iter().find_map(|z| lower.strip_suffix(z))?;
    if inner.ends_with(".parquet") {
        Some("a Parquet file compresses inside itself: decompress it to .parquet")
    } else if inner.ends_with(".csv") {
        Some("only gzip is read (.csv.gz): recompress it with gzip or decompress it to .csv")
    } else {
        None
    }
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

/// The audit of `dir` under `spec`, and the recordings `keep` asks for
/// (entry `k` belongs to the audit's row `k`).
fn audit_with(spec: &DataSpec, dir: &Path, keep: Keep) -> Result<(Audit, Vec<Option<Recording>>), AuditError> {
    let layout = Layout::new(spec).map_err(AuditError::Layout)?;
    let layout = if keep == Keep::RowHashes { layout.with_row_hashes() } else { layout };
    implausible_columns(spec)?;
    let nested = spec.format.as_ref().is_some_and(|f| f.nested_folders);
    let (mut csvs, missing, hidden) = list(dir, nested)?;
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
        not_read: (!nested)
            .then(|| not_read_below(dir, spec.format.is_some()))
            .flatten()
            .into_iter()
            .chain(hidden)
            .collect(),
    };
    Ok((audit, recordings))
}

/// Flight logs below the top level of `dir`, which a design without
/// `folders nested` does not read, in words; `csv` when the design reads a
/// `data csv` block (which `folders nested` extends).
fn not_read_below(dir: &Path, csv: bool) -> Option<String> {
    let (n, first) = crate::io::walk::logs_in_subfolders(dir)?;
    let advice = if csv {
        "declare `folders nested` in the data block to read them, or move them out of the data folder"
    } else {
        "`data nanobench` reads the folder's top level only: move them there to read them, or out of the data folder"
    };
    Some(format!("{n} flight log(s) in subfolders are not read (the first: {first}): {advice}"))
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
                let stem = recording_name(Path::new(n.as_str()));
                let hint = if super::is_log_name(n) && csvs.iter().any(|p| recording_name(p) == stem) {
                    format!("a recording is named by its file name without the suffix (.csv, .csv.gz or .parquet): write `{stem}`")
                } else {
                    "a recording is named by its log's file name without the suffix (.csv, .csv.gz or .parquet)"
                        .to_string()
                };
                return Err(AuditError::Layout(format!(
                    "`exclude recordings` names {n:?}, which is not a recording in {}; {hint}",
                    dir.display()
                )));
            }
        }
    }
    Ok(())
}

/// A conditions table, by recording name, and the file it was read from.
type ConditionsTable = (BTreeMap<String, super::conditions::Conditions>, PathBuf);

/// The declared conditions table, read, and its path: a path from the data
/// folder (a bare name lies in it) or an absolute one; where it lies among
/// the logs `csvs`, it is taken out of them.
fn conditions_table(
    spec: &DataSpec,
    dir: &Path,
    csvs: &mut Vec<PathBuf>,
) -> Result<Option<ConditionsTable>, AuditError> {
    let Some(name) = spec.format.as_ref().and_then(|f| f.conditions_table.as_ref()) else { return Ok(None) };
    let path = dir.join(name);
    let same = |p: &PathBuf| match (std::fs::canonicalize(p), std::fs::canonicalize(&path)) {
        (Ok(a), Ok(b)) => a == b,
        _ => *p == path,
    };
    csvs.retain(|p| !same(p));
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
