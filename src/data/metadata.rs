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
