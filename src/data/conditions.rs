//! Where a `data csv` recording's conditions come from when its file name
//! is not NanoBench's: `conditions table "FILE"` (each recording's
//! trajectory and speed from one CSV table in the data folder; its header
//! names `recording` and at least one of `trajectory` and `speed`; every
//! recording file must have one row) or `conditions name "PATTERN"` (a
//! file-name pattern of the user's own, [`crate::design::NamePattern`]).
//! A table's columns may have other names (`columns speed = velocity`),
//! and `conditions folder trajectory|speed` takes one condition from the
//! first folder a recording sits in.

use std::collections::BTreeMap;
use std::path::Path;

/// A recording's conditions as the table gives them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Conditions {
    /// The trajectory, when the table has the column.
    pub trajectory: Option<String>,
    /// The speed label, when the table has the column.
    pub speed: Option<String>,
}

/// Reads the table: recording name to its conditions. A CSV file (quoted
/// fields may hold commas; a UTF-8 byte-order mark is dropped; blank lines
/// are skipped). Errors name the file, the line and the column: a column
/// named twice, a row of another width, an empty field, a recording listed
/// twice, a control character in a name.
///
/// `columns` maps a role (`recording`, `trajectory`, `speed`) to the
/// table's name for it; an unmapped role is its own name. A mapped column
/// the table lacks is an error, as is a `speed` column the folder gives
/// too (`folder`).
pub fn read_table(
    path: &Path,
    columns: &BTreeMap<String, String>,
    folder: Option<crate::design::Condition>,
) -> Result<BTreeMap<String, Conditions>, String> {
    let file = path.display();
    let bytes = crate::io::read_input(path, crate::io::MAX_SMALL_TEXT, "a conditions table")
        .map_err(|e| format!("{file}: cannot read the conditions table: {}", e.reason()))?;
    let text = String::from_utf8(bytes).map_err(|e| format!("{file}: the conditions table is not UTF-8: {e}"))?;
    let text = crate::io::lone_cr_to_lf(&text);
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let mut reader =
        csv::ReaderBuilder::new().has_headers(false).flexible(true).trim(csv::Trim::All).from_reader(text.as_bytes());
    let mut records = reader.records();
    let bad = |e: csv::Error| format!("{file}: {e}");
    let Some(header) = records.next().transpose().map_err(bad)? else {
        return Err(format!("{file}: the conditions table is empty"));
    };
    let names: Vec<String> = header.iter().map(String::from).collect();
    let line_of = |r: &csv::StringRecord| r.position().map_or(0, |p| p.line() as usize);
    let header_line = line_of(&header);
    let (rec, trajectory, speed) = condition_columns(path, header_line, &names, columns, folder)?;
    let mut out: BTreeMap<String, (Conditions, usize)> = BTreeMap::new();
    for record in records {
        let fields = record.map_err(bad)?;
        let line = line_of(&fields);
        if fields.len() != names.len() {
            return Err(format!("{file}: line {line}: {} fields, the header has {}", fields.len(), names.len()));
        }
        let value = |c: Option<usize>, what: &str| -> Result<Option<String>, String> {
            match c.map(|c| &fields[c]) {
                Some("") => Err(format!("{file}: line {line}, column `{what}`: empty")),
                Some(v) if v.chars().any(char::is_control) => Err(format!(
                    "{file}: line {line}, column `{what}`: {:?} holds a control character, which no name may",
                    v
                )),
                Some(v) if crate::io::formula_like(v) => Err(format!(
                    "{file}: line {line}, column `{what}`: {v:?} begins with `{}`, which a spreadsheet opening any CSV that names it would read as a formula; no name may",
                    v.chars().next().unwrap_or('=')
                )),
                other => Ok(other.map(String::from)),
            }
        };
        // A recording is named by its file name without the log's suffix; a
        // table that lists the files (`f01.csv.gz`, `f01.parquet`) names them.
        let name = value(Some(rec), "recording")?.unwrap_or_default();
        let name = if super::is_log_name(&name) { super::recording_name(Path::new(&name)) } else { name };
        let conditions = Conditions { trajectory: value(trajectory, "trajectory")?, speed: value(speed, "speed")? };
        if let Some((_, first)) = out.insert(name.clone(), (conditions, line)) {
            return Err(format!("{file}: line {line}: recording `{name}` is listed again (first on line {first})"));
        }
    }
    Ok(out.into_iter().map(|(k, (c, _))| (k, c)).collect())
}

/// The table's recording, trajectory and speed columns, found by name in
/// the header (or by the design's `columns ROLE = NAME`): each header name
/// once, a recording column, a trajectory or a speed column, and none that
/// the folder (`conditions folder`) gives too.
fn condition_columns(
    path: &Path,
    header_line: usize,
    names: &[String],
    columns: &BTreeMap<String, String>,
    folder: Option<crate::design::Condition>,
) -> Result<(usize, Option<usize>, Option<usize>), String> {
    let file = path.display();
    for (k, n) in names.iter().enumerate() {
        if let Some(first) = names[..k].iter().position(|m| m == n) {
            return Err(format!(
                "{file}: line {header_line}: column `{}` is named twice (columns {} and {}); which one holds the conditions is ambiguous",
                crate::io::one_line(n),
                first + 1,
                k + 1
            ));
        }
    }
    let joined = names.join(", ");
    let has = crate::io::one_line(&joined);
    let column = |role: &str| -> Result<Option<usize>, String> {
        let Some(name) = columns.get(role) else { return Ok(names.iter().position(|n| n == role)) };
        match names.iter().position(|n| n == name) {
            Some(k) => Ok(Some(k)),
            None => {
                let name = crate::io::one_line(name);
                Err(format!(
                    "{file}: line {header_line}: the conditions table has no column `{name}`, which the design maps to {role} (`columns {role} = {name}`); it has: {has}"
                ))
            }
        }
    };
    let Some(rec) = column("recording")? else {
        return Err(format!(
            "{file}: line {header_line}: the conditions table needs a `recording` column (it has: {has}); map another with `columns recording = NAME`"
        ));
    };
    let (mut trajectory, mut speed) = (column("trajectory")?, column("speed")?);
    // The folder gives this condition; a table column of the same name
    // would give it twice, and one of them would be silently ignored.
    for (c, slot) in
        [(crate::design::Condition::Trajectory, &mut trajectory), (crate::design::Condition::Speed, &mut speed)]
    {
        if folder == Some(c) {
            if let Some(k) = slot.take() {
                return Err(format!(
                    "{file}: line {header_line}: column {} `{}` gives each recording's {} too, which `conditions folder {}` takes from its folder; keep one of them",
                    k + 1,
                    crate::io::one_line(&names[k]),
                    c.name(),
                    c.name()
                ));
            }
        }
    }
    if trajectory.is_none() && speed.is_none() {
        return Err(format!(
            "{file}: line {header_line}: the conditions table needs a `trajectory` or a `speed` column (it has: {has}); map one of another name with `columns speed = NAME`"
        ));
    }
    Ok((rec, trajectory, speed))
}

/// Sets each file's trajectory, speed (and, from a pattern, repetition)
/// from the design's `conditions name` pattern or its conditions `table`
/// (read from `path`): a file the pattern does not match, a file without a
/// row, or a speed the design's speed rule cannot give stops the audit.
pub(super) fn apply(
    spec: &crate::design::DataSpec,
    dir: &Path,
    files: &mut [super::FileRow],
    table: Option<&(BTreeMap<String, Conditions>, std::path::PathBuf)>,
) -> Result<(), super::AuditError> {
    if let Some(pattern) = spec.format.as_ref().and_then(|f| f.conditions_name.as_ref()) {
        from_pattern(pattern, dir, files)?;
    }
    if let Some((table, path)) = table {
        from_table(table, path, files)?;
    }
    let folder = spec.format.as_ref().and_then(|f| f.conditions_folder);
    if let Some(c) = folder {
        from_folder(c, dir, files)?;
    }
    if table.is_some() || spec.format.as_ref().is_some_and(|f| f.conditions_name.is_some()) || folder.is_some() {
        // A table's or a pattern's speed must be one the design's speed rule
        // can give: the analysis refuses any other label in the cells.
        let labels = spec.speed_labels();
        if let Some(f) = files.iter().find(|f| !labels.contains(&f.speed)) {
            let source = match (&table, folder) {
                (_, Some(crate::design::Condition::Speed)) => format!("{}: `conditions folder speed`", dir.display()),
                (Some((_, path)), _) => format!("{}: the conditions table", path.display()),
                (None, _) => format!("{}: the conditions pattern", dir.display()),
            };
            return Err(super::AuditError::Layout(format!(
                "{source} gives {} the speed `{}`, which the data block's speed rule cannot give (known: {}); use those labels, or trajectory only",
                f.file,
                f.speed,
                labels.join(", ")
            )));
        }
    }
    Ok(())
}

/// Each file's trajectory, speed and repetition from the design's
/// `conditions name` pattern, which must match every file name.
fn from_pattern(pattern: &str, dir: &Path, files: &mut [super::FileRow]) -> Result<(), super::AuditError> {
    use super::AuditError;
    let parsed = crate::design::NamePattern::parse(pattern).map_err(AuditError::Layout)?;
    let unmatched: Vec<&str> =
        files.iter().filter(|f| parsed.conditions(&f.name).is_none()).map(|f| f.file.as_str()).collect();
    if !unmatched.is_empty() {
        return Err(AuditError::Layout(format!(
            "{}: the conditions pattern \"{pattern}\" does not match {} recording file name(s): {}",
            dir.display(),
            unmatched.len(),
            crate::io::excerpt(&unmatched.join(", "), 600)
        )));
    }
    for f in files.iter_mut() {
        let c = parsed.conditions(&f.name).unwrap_or_default();
        f.trajectory = c.trajectory.unwrap_or_else(|| f.trajectory.clone());
        f.speed = c.speed.unwrap_or_else(|| f.speed.clone());
        f.repetition = c.repetition.or(f.repetition);
    }
    Ok(())
}

/// Each file's trajectory and speed from the conditions table (read from
/// `path`), which must have a row for every file.
fn from_table(
    table: &BTreeMap<String, Conditions>,
    path: &Path,
    files: &mut [super::FileRow],
) -> Result<(), super::AuditError> {
    use super::AuditError;
    let unlisted: Vec<&str> = files.iter().filter(|f| !table.contains_key(&f.name)).map(|f| f.file.as_str()).collect();
    if !unlisted.is_empty() {
        return Err(AuditError::Layout(format!(
            "{}: the conditions table has no row for {} recording file(s): {}",
            path.display(),
            unlisted.len(),
            crate::io::excerpt(&unlisted.join(", "), 600)
        )));
    }
    for f in files.iter_mut() {
        let c = &table[&f.name];
        f.trajectory = c.trajectory.clone().unwrap_or_else(|| f.trajectory.clone());
        f.speed = c.speed.clone().unwrap_or_else(|| f.speed.clone());
    }
    Ok(())
}

/// Each file's trajectory or speed (`c`) from the first folder of its path
/// below the data folder `dir`; a file in no folder is refused.
fn from_folder(c: crate::design::Condition, dir: &Path, files: &mut [super::FileRow]) -> Result<(), super::AuditError> {
    use super::AuditError;
    // The first folder of the path below the data folder.
    if let Some(f) = files.iter().find(|f| !f.file.contains('/')) {
        return Err(AuditError::Layout(format!(
            "{}: {} sits in no folder, and `conditions folder {}` takes each recording's {} from the folder it sits in; move it into one",
            dir.display(),
            f.file,
            c.name(),
            c.name()
        )));
    }
    for f in files.iter_mut() {
        let first = f.file.split('/').next().unwrap_or_default().to_string();
        match c {
            crate::design::Condition::Trajectory => f.trajectory = first,
            crate::design::Condition::Speed => f.speed = first,
        }
    }
    Ok(())
}
