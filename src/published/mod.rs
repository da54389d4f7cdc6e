//! Stage: published splits. A benchmark's own split file, read into roles
//! (`train`, `val`, `test`, `fold0`, ...) each listing recordings by name,
//! every name with the line and column it was written at.
//!
//! Three forms are read:
//! - NanoBench's `split_metadata.json`: an object whose `<role>_files`
//!   keys hold lists of paths (`train_files`, `val_files`, `test_files`);
//!   other keys must be scalars (`seed`) and are kept as notes.
//! - A role CSV with a header holding `recording` and `role` (any role names).
//! - A scikit-learn-style fold list: a JSON array of arrays of names (or an
//!   object whose `folds` key holds one), or a CSV with `recording` and
//!   `fold` columns. Fold `k` becomes role `fold<k>`.
//! - A per-window split: either CSV with `start_s` and `end_s` columns too.
//!   Each row is then one window `[start_s, end_s)` of its recording, in
//!   seconds from the recording's first timestamp, and one recording may
//!   have windows in several roles (the split the audit measures the
//!   distance in time between). The same window twice in one role is an
//!   error; a per-window split declares at most [`MAX_WINDOW_ROLES`] roles.
//!
//! A name is matched to a recording by its file stem: directories, `.csv`
//! `.gz` and `.parquet` are removed (`/x/y/B9_trefoil_slow_rep3.csv` is
//! `B9_trefoil_slow_rep3`), nothing else. A recording listed twice (in two
//! roles, or twice in one) is an error naming both places; so is an entry
//! that leaves no stem, an empty role, and a file with no roles at all.
//!
//! Nothing in a split file is dropped without a word: a JSON key written
//! twice in one object (JSON readers keep one), a `<role>_files` list
//! beside `folds`, any list or object that is neither, a CSV column other
//! than `recording`, `role` and `fold`, or one written twice, is an error
//! at its line and column. Lines are counted as an editor counts them,
//! whether they end in `\n`, `\r\n` or `\r`.

mod json;
mod types;

use std::collections::BTreeMap;
use std::path::Path;

use json::from_json;
use types::at;
pub use types::{
    stem, DeclaredRole, DeclaredWindow, Entry, Format, Place, PublishedError, PublishedSplit, MAX_ROLES,
    MAX_WINDOW_ROLES,
};

/// Reads a split file; the form is chosen by its extension (`.json` or
/// `.csv`) and, within it, by its shape.
///
/// ```
/// let s = crossaudit::published::read(std::path::Path::new("tests/fixtures/splits/nanobench_small.json")).unwrap();
/// assert_eq!(s.roles.iter().map(|r| r.name.as_str()).collect::<Vec<_>>(), ["train", "val", "test"]);
/// ```
pub fn read(path: &Path) -> Result<PublishedSplit, PublishedError> {
    let shown = path.display().to_string();
    let crate::io::Text { text, sha256, .. } = crate::io::read_text(path, crate::io::MAX_SPLIT_FILE, "a split file")
        .map_err(|e| PublishedError::Read { path: shown.clone(), message: e.reason() })?;
    let text = &*crate::io::lone_cr_to_lf(&text);
    let name = path.file_name().map(|n| n.to_string_lossy().to_lowercase()).unwrap_or_default();
    let (format, roles, notes) = if name.ends_with(".json") {
        from_json(&shown, text)?
    } else if name.ends_with(".csv") {
        let (f, r) = from_csv(&shown, text)?;
        (f, r, BTreeMap::new())
    } else {
        return Err(PublishedError::Read {
            path: shown,
            message: "unknown split file form: give a .json (NanoBench split_metadata.json or a fold list) or a .csv (recording,role or recording,fold)".into(),
        });
    };
    let split = PublishedSplit { path: shown, sha256, format, roles, notes };
    check(&split)?;
    Ok(split)
}

/// The split a lab published as folders: each log under a subfolder of
/// `dir` is in the role named by its first folder (`train/run_1.parquet`,
/// `test/2024/run_9.csv` in `train` and `test`); logs directly in `dir` are
/// in none. Its hash is of the listing (each log's path under `dir`, one a
/// line), so moving a file between folders changes it; an entry's place is
/// its line in that listing.
pub fn from_folders(dir: &Path) -> Result<PublishedSplit, PublishedError> {
    let shown = dir.display().to_string();
    let files = crate::io::walk::files_below(dir, true)
        .map_err(|e| PublishedError::Read { path: shown.clone(), message: e.to_string() })?;
    // A role folder that is a symbolic link is not followed (a link cycle
    // would never end): named, not taken for a role with no logs.
    let linked: Vec<String> =
        files.iter().filter(|p| p.is_symlink() && p.is_dir()).map(|p| crate::io::walk::relative(dir, p)).collect();
    if !linked.is_empty() {
        return Err(PublishedError::Folders {
            dir: shown,
            message: format!(
                "{} is a symbolic link to a folder, which crossaudit does not follow (a link cycle would never end): copy or move the folder there",
                linked.join(", ")
            ),
        });
    }
    let listing: Vec<String> = files
        .iter()
        .map(|p| crate::io::walk::relative(dir, p))
        // A hidden file (`._x.parquet`, macOS's copy) is not a log: the
        // data audit names it and reads nothing from it.
        .filter(|r| {
            r.contains('/') && crate::io::walk::is_log_name(r) && !r.rsplit('/').next().unwrap_or("").starts_with('.')
        })
        .collect();
    let sha256 = crate::io::sha256_hex(listing.iter().map(|l| format!("{l}\n")).collect::<String>().as_bytes());
    let mut roles: Vec<DeclaredRole> = Vec::new();
    for (k, rel) in listing.iter().enumerate() {
        let at = Place { line: k + 1, column: 1 };
        let folder = rel.split('/').next().unwrap_or_default().to_string();
        let entry = Entry { name: stem(rel), listed: rel.clone(), at, window: None };
        match roles.iter_mut().find(|r| r.name == folder) {
            Some(r) => r.entries.push(entry),
            None => roles.push(DeclaredRole { name: folder, at, entries: vec![entry] }),
        }
    }
    // A recording is named by its file's stem: two files with one stem
    // (in two role folders, or two subfolders of one) are named with both
    // paths, not as a split file's line.
    let mut seen: BTreeMap<String, &String> = BTreeMap::new();
    for rel in &listing {
        if let Some(first) = seen.insert(stem(rel), rel) {
            return Err(PublishedError::Folders {
                dir: shown,
                message: format!(
                    "`{first}` and `{rel}` are one recording, `{}` (a recording is named by its file name without the log's suffix): rename or remove one",
                    stem(rel)
                ),
            });
        }
    }
    let split = PublishedSplit { path: shown, sha256, format: Format::Folders, roles, notes: BTreeMap::new() };
    check(&split)?;
    Ok(split)
}

/// No role empty, no recording twice (no window twice in one role, in a
/// per-window split), no entry without a stem.
fn check(split: &PublishedSplit) -> Result<(), PublishedError> {
    let path = &split.path;
    if split.roles.is_empty() {
        return Err(at(path, Place { line: 1, column: 1 }, "the split declares no roles"));
    }
    let windowed = split.is_windowed();
    let (cap, why) = if windowed {
        (
            MAX_WINDOW_ROLES,
            "a per-window split may declare, since its audit finds each window's nearest in every other role",
        )
    } else {
        (MAX_ROLES, "the audit compares pairwise")
    };
    if let Some(role) = split.roles.get(cap) {
        return Err(at(
            path,
            role.at,
            format!("the split declares {} roles (or folds), more than the {cap} {why}", split.roles.len()),
        ));
    }
    let mut named: BTreeMap<&str, &DeclaredRole> = BTreeMap::new();
    for role in &split.roles {
        if let Some(first) = named.insert(&role.name, role) {
            let (line, column) = (first.at.line, first.at.column);
            return Err(at(
                path,
                role.at,
                format!("role `{}` is declared twice (first at line {line}, column {column})", role.name),
            ));
        }
        if role.entries.is_empty() {
            return Err(at(path, role.at, format!("role `{}` lists no recordings", role.name)));
        }
        if let Some(e) = role.entries.iter().find(|e| e.name.is_empty()) {
            return Err(at(path, e.at, format!("entry \"{}\" names no recording file", e.listed)));
        }
        // Role names and entries become cells and lines of the audit's
        // files: a control character there would be structure, not text.
        let controls = |s: &str| s.chars().any(char::is_control);
        if controls(&role.name) {
            let name = crate::io::one_line(&role.name);
            return Err(at(path, role.at, format!("role \"{name}\" holds a control character, which no name may")));
        }
        if let Some(e) = role.entries.iter().find(|e| controls(&e.listed)) {
            let listed = crate::io::one_line(&e.listed);
            return Err(at(path, e.at, format!("entry \"{listed}\" holds a control character, which no name may")));
        }
    }
    if windowed {
        check_windows(split)
    } else {
        check_recordings(split)
    }
}

/// A whole recording is in one role, once.
fn check_recordings(split: &PublishedSplit) -> Result<(), PublishedError> {
    let mut seen: BTreeMap<&str, (&DeclaredRole, &Entry)> = BTreeMap::new();
    for (role, e) in split.entries() {
        if let Some((r0, e0)) = seen.get(e.name.as_str()) {
            let how = if r0.name == role.name {
                format!("twice in role `{}`", role.name)
            } else {
                format!("in two roles, `{}` and `{}`", r0.name, role.name)
            };
            let same = if e0.listed == e.listed { String::new() } else { format!(" as \"{}\"", e0.listed) };
            return Err(at(
                &split.path,
                e.at,
                format!(
                    "recording {} is listed {how} (first at line {}, column {}{same})",
                    e.name, e0.at.line, e0.at.column
                ),
            ));
        }
        seen.insert(&e.name, (role, e));
    }
    Ok(())
}

/// A window is in a role once; the same window in two roles is what the
/// audit reports (an overlap), not an error of the file.
fn check_windows(split: &PublishedSplit) -> Result<(), PublishedError> {
    let mut seen: BTreeMap<(&str, &str, u64, u64), Place> = BTreeMap::new();
    for (role, e) in split.entries() {
        let w = e.window.unwrap_or(DeclaredWindow { start_s: 0.0, end_s: 0.0 });
        let key = (e.name.as_str(), role.name.as_str(), w.start_s.to_bits(), w.end_s.to_bits());
        if let Some(first) = seen.insert(key, e.at) {
            return Err(at(
                &split.path,
                e.at,
                format!(
                    "window [{}, {}) s of recording {} is listed twice in role `{}` (first at line {}, column {})",
                    w.start_s, w.end_s, e.name, role.name, first.line, first.column
                ),
            ));
        }
    }
    Ok(())
}

// ------------------------------------------------------------------ CSV

/// Where a split CSV's columns are.
struct Columns {
    format: Format,
    recording: usize,
    /// `role` or `fold`.
    key: usize,
    /// `start_s` and `end_s`, in a per-window split.
    window: Option<(usize, usize)>,
}

fn from_csv(path: &str, text: &str) -> Result<(Format, Vec<DeclaredRole>), PublishedError> {
    // Lines are counted here: the csv crate's count is one short after
    // each `\r\n`, the line ending Python's csv module writes.
    let lines = crate::io::LineIndex::new(text.as_bytes());
    let mut reader = csv::ReaderBuilder::new().has_headers(true).flexible(false).from_reader(text.as_bytes());
    let header = reader
        .headers()
        .map_err(|e| csv_error(path, &lines, &e))?
        .iter()
        .map(|h| h.trim().to_string())
        .collect::<Vec<_>>();
    let cols = csv_columns(path, text, &header)?;
    let mut roles: Vec<DeclaredRole> = Vec::new();
    // Role name -> index in `roles`, so a long file reads in linear time.
    let mut index: BTreeMap<String, usize> = BTreeMap::new();
    for row in reader.records() {
        let row = row.map_err(|e| csv_error(path, &lines, &e))?;
        let start = row.position().map(|p| skip_breaks(text, p.byte() as usize)).unwrap_or(0);
        let line = lines.line_of(start);
        let place = |field: usize| Place { line, column: column_of(text, start, field) };
        let listed = row.get(cols.recording).unwrap_or("").trim().to_string();
        let value = row.get(cols.key).unwrap_or("").trim();
        if listed.is_empty() {
            return Err(at(path, place(cols.recording), "empty `recording`"));
        }
        let role = match cols.format {
            Format::FoldCsv => match value.parse::<u32>() {
                Ok(k) => format!("fold{k}"),
                Err(_) => {
                    return Err(at(
                        path,
                        place(cols.key),
                        format!("fold \"{value}\" is not a fold number (0, 1, 2, ...)"),
                    ))
                }
            },
            _ if value.is_empty() => return Err(at(path, place(cols.key), "empty `role`")),
            _ => value.to_string(),
        };
        let window = match cols.window {
            Some((s, e)) => Some(window_of(path, &row, (s, place(s)), (e, place(e)))?),
            None => None,
        };
        let entry = Entry { name: stem(&listed), listed, at: place(cols.recording), window };
        match index.get(&role) {
            Some(&k) => roles[k].entries.push(entry),
            None => {
                index.insert(role.clone(), roles.len());
                roles.push(DeclaredRole { name: role, at: place(cols.key), entries: vec![entry] });
            }
        }
    }
    Ok((cols.format, roles))
}

/// The header's columns: `recording`, one of `role` and `fold`, and
/// `start_s` with `end_s` or neither; nothing else, nothing twice.
fn csv_columns(path: &str, text: &str, header: &[String]) -> Result<Columns, PublishedError> {
    let first = Place { line: 1, column: 1 };
    let header_at = |k: usize| Place { line: 1, column: column_of(text, 0, k) };
    let mut columns: BTreeMap<&str, usize> = BTreeMap::new();
    for (k, h) in header.iter().enumerate() {
        if let Some(j) = columns.insert(h, k) {
            return Err(at(
                path,
                header_at(k),
                format!("column `{h}` appears twice in the header (first as column {})", j + 1),
            ));
        }
    }
    let find = |name: &str| columns.get(name).copied();
    let recording = find("recording")
        .ok_or_else(|| at(path, first, format!("the header ({}) has no `recording` column", header.join(","))))?;
    let (format, key) = match (find("role"), find("fold")) {
        (Some(k), None) => (Format::RoleCsv, k),
        (None, Some(k)) => (Format::FoldCsv, k),
        (Some(_), Some(_)) => return Err(at(path, first, "the header has both `role` and `fold`; give one")),
        (None, None) => {
            return Err(at(
                path,
                first,
                format!("the header ({}) has neither a `role` nor a `fold` column", header.join(",")),
            ))
        }
    };
    let expected = "a split CSV has the columns `recording` and `role` (or `fold`), and for a per-window split `start_s` and `end_s`, nothing else";
    for (k, h) in header.iter().enumerate() {
        if !matches!(h.as_str(), "recording" | "role" | "fold" | "start_s" | "end_s") {
            return Err(at(
                path,
                header_at(k),
                if h.is_empty() && k == 0 {
                    format!("an unnamed first column (pandas writes its index there unless `to_csv(..., index=False)`): {expected}")
                } else {
                    format!("unknown column `{h}`: {expected}")
                },
            ));
        }
    }
    let window =
        match (find("start_s"), find("end_s")) {
            (Some(s), Some(e)) => Some((s, e)),
            (None, None) => None,
            (Some(k), None) | (None, Some(k)) => return Err(at(
                path,
                header_at(k),
                "a per-window split gives both `start_s` and `end_s` (seconds from the recording's first timestamp)",
            )),
        };
    Ok(Columns { format, recording, key, window })
}

/// `[start_s, end_s)` of one row: numbers, the start at least 0, the end
/// after it.
fn window_of(
    path: &str,
    row: &csv::StringRecord,
    (s, s_at): (usize, Place),
    (e, e_at): (usize, Place),
) -> Result<DeclaredWindow, PublishedError> {
    let number = |k: usize, place: Place, name: &str| -> Result<f64, PublishedError> {
        let v = row.get(k).unwrap_or("").trim();
        match v.parse::<f64>() {
            Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
            _ if v.is_empty() => Err(at(path, place, format!("empty `{name}`"))),
            _ => Err(at(path, place, format!("`{name}` \"{v}\" is not a time in seconds (a number, 0 or more)"))),
        }
    };
    let (start_s, end_s) = (number(s, s_at, "start_s")?, number(e, e_at, "end_s")?);
    if end_s <= start_s {
        return Err(at(path, e_at, format!("the window ends at {end_s} s, not after its start at {start_s} s")));
    }
    Ok(DeclaredWindow { start_s, end_s })
}

fn csv_error(path: &str, lines: &crate::io::LineIndex, e: &csv::Error) -> PublishedError {
    let line = e.position().map(|p| lines.line_of(p.byte() as usize)).unwrap_or(1);
    let message = match e.kind() {
        csv::ErrorKind::UnequalLengths { expected_len, len, .. } => {
            format!("this row has {len} fields, the header {expected_len}")
        }
        csv::ErrorKind::Utf8 { .. } => "not UTF-8".to_string(),
        _ => e.to_string(),
    };
    at(path, Place { line, column: 1 }, message)
}

/// `offset` moved past any line breaks (the csv crate reports a record
/// after `\r\n` as starting on its `\n`).
fn skip_breaks(text: &str, offset: usize) -> usize {
    let rest = text.get(offset..).unwrap_or("");
    offset + (rest.len() - rest.trim_start_matches(['\r', '\n']).len())
}

/// The 1-based character column where field `field` starts in the record
/// that starts at byte `start` (plain CSV; quoted commas are honoured).
fn column_of(text: &str, start: usize, field: usize) -> usize {
    let rest = text.get(start..).unwrap_or("");
    let l = rest.split(['\r', '\n']).next().unwrap_or("");
    let mut quoted = false;
    let mut k = 0;
    for (col, ch) in l.chars().enumerate() {
        if k == field {
            return col + 1;
        }
        match ch {
            '"' => quoted = !quoted,
            ',' if !quoted => k += 1,
            _ => {}
        }
    }
    l.chars().count() + 1
}

// ----------------------------------------------------------------- JSON
