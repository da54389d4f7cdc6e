//! `conditions table "FILE"` (`data csv`): each recording's trajectory and
//! speed from one CSV table in the data folder, instead of the file names.
//! Its header names `recording` and at least one of `trajectory` and
//! `speed`; every recording file must have one row.

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

/// Reads the table: recording name to its conditions. Errors name the
/// file, the line and the column.
pub fn read_table(path: &Path) -> Result<BTreeMap<String, Conditions>, String> {
    let file = path.display();
    let bytes = crate::io::read_input(path, crate::io::MAX_SMALL_TEXT, "a conditions table")
        .map_err(|e| format!("{file}: cannot read the conditions table: {}", e.reason()))?;
    let text = String::from_utf8(bytes).map_err(|e| format!("{file}: the conditions table is not UTF-8: {e}"))?;
    let text = crate::io::lone_cr_to_lf(&text);
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        return Err(format!("{file}: the conditions table is empty"));
    };
    let names: Vec<&str> = header.split(',').map(|h| h.trim().trim_matches('"')).collect();
    let column = |want: &str| names.iter().position(|n| *n == want);
    let Some(rec) = column("recording") else {
        return Err(format!(
            "{file}: line 1: the conditions table needs a `recording` column (it has: {})",
            names.join(", ")
        ));
    };
    let (trajectory, speed) = (column("trajectory"), column("speed"));
    if trajectory.is_none() && speed.is_none() {
        return Err(format!(
            "{file}: line 1: the conditions table needs a `trajectory` or a `speed` column (it has: {})",
            names.join(", ")
        ));
    }
    let mut out: BTreeMap<String, (Conditions, usize)> = BTreeMap::new();
    for (k, line) in lines {
        let fields: Vec<&str> = line.split(',').map(|f| f.trim().trim_matches('"')).collect();
        if fields.len() != names.len() {
            return Err(format!("{file}: line {}: {} fields, the header has {}", k + 1, fields.len(), names.len()));
        }
        let value = |c: Option<usize>, what: &str| -> Result<Option<String>, String> {
            match c.map(|c| fields[c]) {
                Some("") => Err(format!("{file}: line {}, column `{what}`: empty", k + 1)),
                other => Ok(other.map(String::from)),
            }
        };
        let name = value(Some(rec), "recording")?.unwrap_or_default();
        let conditions = Conditions { trajectory: value(trajectory, "trajectory")?, speed: value(speed, "speed")? };
        if let Some((_, first)) = out.insert(name.clone(), (conditions, k + 1)) {
            return Err(format!("{file}: line {}: recording `{name}` is listed again (first on line {first})", k + 1));
        }
    }
    Ok(out.into_iter().map(|(k, (c, _))| (k, c)).collect())
}
