//! Recording metadata: the `<name>_metadata.yaml` file (the authority for
//! trajectory type) and the file name
//! `<ID>_<shape>[_<speed>][_mell]_rep<N>` (speed, controller, repetition).

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

/// What the file name says.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct NameParts {
    /// Recording id prefix, e.g. `B9`.
    pub id: String,
    /// Trajectory shape, e.g. `trefoil` or `linear_ramp`.
    pub shape: String,
    /// slow, medium, fast, or `unknown` when the name has no speed token.
    pub speed: String,
    /// Controller (`_mell` suffix or the default PID).
    pub controller: Controller,
    /// `repN` suffix, if present.
    pub repetition: Option<u32>,
}

/// The flight controller a recording was flown with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Controller {
    /// The default cascaded PID.
    Pid,
    /// `_mell`: the Mellinger controller.
    Mellinger,
}

impl Controller {
    /// Lowercase name used in audit tables.
    pub fn name(self) -> &'static str {
        match self {
            Controller::Pid => "pid",
            Controller::Mellinger => "mellinger",
        }
    }
}

/// Splits a recording name. Shapes may contain underscores
/// (`linear_ramp`); the speed token, `mell` and `repN` are read from the end.
pub fn parse_name(name: &str) -> NameParts {
    let mut parts: Vec<&str> = name.split('_').collect();
    let id = if parts.len() > 1 { parts.remove(0).to_string() } else { String::new() };
    let mut repetition = None;
    if let Some(last) = parts.last() {
        if let Some(n) = last.strip_prefix("rep").and_then(|d| d.parse().ok()) {
            repetition = Some(n);
            parts.pop();
        }
    }
    let mut controller = Controller::Pid;
    if parts.last() == Some(&"mell") {
        controller = Controller::Mellinger;
        parts.pop();
    }
    let mut speed = "unknown".to_string();
    if let Some(last) = parts.last() {
        if matches!(*last, "slow" | "medium" | "fast") {
            speed = last.to_string();
            parts.pop();
        }
    }
    NameParts { id, shape: parts.join("_"), speed, controller, repetition }
}

/// The fields of `_metadata.yaml` the audit uses; unknown fields are kept
/// out of the way, missing ones are `None`.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
pub struct Metadata {
    /// Trajectory type, e.g. `trefoil`.
    pub trajectory_type: Option<String>,
    /// Trajectory identifier.
    pub trajectory_id: Option<String>,
    /// Upstream category label.
    pub category: Option<String>,
    /// Repetition number.
    pub repetition: Option<u32>,
    /// Battery voltage at take-off, volts.
    pub battery_voltage_start: Option<f64>,
    /// Battery voltage at landing, volts.
    pub battery_voltage_end: Option<f64>,
    /// Recording start, UTC.
    pub recording_start_utc: Option<String>,
    /// Recording end, UTC.
    pub recording_end_utc: Option<String>,
    /// Row counts per logged table, as upstream recorded them.
    #[serde(default)]
    pub row_counts: BTreeMap<String, u64>,
    /// Trajectory parameters; only the speed is read.
    #[serde(default)]
    pub params: Params,
}

/// The `params` mapping of a metadata file.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
pub struct Params {
    /// Commanded speed, m/s, when the trajectory has one.
    pub speed_mps: Option<f64>,
}

/// Reads a `_metadata.yaml` file; the error names the file, line and column.
pub fn read_metadata(path: &Path) -> Result<Metadata, String> {
    let bytes = crate::io::read_input(path, crate::io::MAX_SMALL_TEXT, "a metadata file")
        .map_err(|e| format!("{}: cannot read: {}", path.display(), e.reason()))?;
    let text = String::from_utf8(bytes).map_err(|e| format!("{}: cannot read: not UTF-8: {e}", path.display()))?;
    if text.trim().is_empty() {
        return Err(format!(
            "{}: the metadata file is empty (delete it if the recording has no metadata)",
            path.display()
        ));
    }
    serde_yaml_ng::from_str(&text).map_err(|e| {
        let at = e.location().map(|l| format!(" (line {}, column {})", l.line(), l.column())).unwrap_or_default();
        format!("{}: invalid metadata{at}: {e}", path.display())
    })
}

/// The metadata numbers no recording can have, each located by line and
/// column in `path`: a speed that is not a finite number >= 0 m/s, a
/// battery voltage that is not a finite number > 0 V. A speed label or a
/// battery check read from such a value would be a plausible wrong answer
/// (`.nan` and `-5` both compare as below every threshold), so the audit
/// refuses them whatever the design's strictness.
pub fn impossible_values(path: &Path, m: &Metadata) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let at = |key: &str| -> String {
        text.lines()
            .enumerate()
            .find_map(|(k, l)| {
                let start = l.len() - l.trim_start().len();
                let rest = l[start..].strip_prefix(key)?.strip_prefix(':')?;
                let value = start + key.len() + 1 + (rest.len() - rest.trim_start().len());
                Some(format!("line {}, column {}", k + 1, value + 1))
            })
            .unwrap_or_else(|| "line ?".to_string())
    };
    let mut out = Vec::new();
    // (key as written, name in messages, value, least value, whether the least is allowed)
    let checks = [
        ("speed_mps", "params.speed_mps", m.params.speed_mps, true, "a finite speed >= 0 m/s"),
        ("battery_voltage_start", "battery_voltage_start", m.battery_voltage_start, false, "a finite voltage > 0 V"),
        ("battery_voltage_end", "battery_voltage_end", m.battery_voltage_end, false, "a finite voltage > 0 V"),
    ];
    for (key, name, value, zero_ok, expected) in checks {
        let ok = |v: f64| v.is_finite() && (v > 0.0 || (zero_ok && v == 0.0));
        if let Some(v) = value.filter(|v| !ok(*v)) {
            out.push(format!("{}: {}: `{name}` is {v}, expected {expected}", path.display(), at(key)));
        }
    }
    // Labels become trajectory names in every table of every report.
    for (key, value) in
        [("trajectory_type", &m.trajectory_type), ("trajectory_id", &m.trajectory_id), ("category", &m.category)]
    {
        if let Some(v) = value.as_ref().filter(|v| v.chars().any(char::is_control)) {
            out.push(format!(
                "{}: {}: `{key}` is {v:?}, which holds a control character no label may",
                path.display(),
                at(key)
            ));
        } else if let Some(v) = value.as_ref().filter(|v| crate::io::formula_like(v)) {
            out.push(format!(
                "{}: {}: `{key}` is {v:?}, which a spreadsheet opening any CSV that names it would read as a formula (it begins with `{}`); no label may",
                path.display(),
                at(key),
                v.chars().next().unwrap_or('=')
            ));
        }
    }
    out
}
