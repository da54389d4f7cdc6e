//! Stage: flight logs. NanoBench CSV(.gz) + metadata -> [`Recording`]s, and
//! the inclusion audit that decides which recordings a study may use.

pub mod audit;
pub mod log;
pub mod metadata;

use std::path::{Path, PathBuf};

use crate::design::{Cmp, DataSpec, InclusionRule};
pub use audit::{audit, audit_and_load, Audit, AuditError, FileRow, Status};
pub use log::{LogError, NANOBENCH_COLUMNS};
pub use metadata::{parse_name, Controller, Metadata, NameParts};

/// Full-scale PWM: actions are motor PWM / 65535, clipped to [0, 1].
pub const PWM_FULL_SCALE: f64 = 65535.0;

/// One recording, loaded under a design's data declaration.
#[derive(Debug, Clone)]
pub struct Recording {
    /// File stem without `.csv[.gz]`, e.g. `B9_trefoil_slow_rep3`.
    pub name: String,
    /// The file it was read from.
    pub path: PathBuf,
    /// Number of data rows.
    pub rows: usize,
    /// Time, seconds.
    pub t: Vec<f64>,
    /// The 14-d state per row, in the declared column order; battery zeros
    /// forward/back-filled.
    pub state: Vec<[f64; 14]>,
    /// The 4-d action per row: PWM / 65535 clipped to [0, 1].
    pub action: Vec<[f64; 4]>,
    /// Raw motor PWM (the action columns before scaling), for plausibility.
    pub pwm: Vec<[f64; 4]>,
    /// Rows meeting the active rule (default: motor_motor_m1 > 1000).
    pub active: Vec<bool>,
    /// XXH3-128 of the data rows (see [`log::Log::content_hash`]): equal for identical recordings.
    pub content_hash: String,
}

impl Recording {
    /// Rows meeting the active rule.
    pub fn active_rows(&self) -> usize {
        self.active.iter().filter(|a| **a).count()
    }

    /// Time from the first to the last row, seconds.
    pub fn duration_s(&self) -> f64 {
        match (self.t.first(), self.t.last()) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    }
}

/// The active-row rule of a data declaration (its first `include active`),
/// or NanoBench's `motor_motor_m1 > 1000`.
pub fn active_rule(spec: &DataSpec) -> (String, Cmp, f64) {
    spec.rules
        .iter()
        .find_map(|r| match r {
            InclusionRule::Active { column, cmp, threshold, .. } => Some((column.clone(), *cmp, *threshold)),
            InclusionRule::Implausible => None,
        })
        .unwrap_or_else(|| ("motor_motor_m1".to_string(), Cmp::Gt, 1000.0))
}

/// Column layout needed to load recordings under a data declaration.
#[derive(Debug, Clone)]
pub struct Layout {
    /// Schema indices: t, 14 state, 4 action, the active-rule column.
    keep: Vec<usize>,
    active_cmp: Cmp,
    active_threshold: f64,
    /// Index within the state of the battery column, if declared.
    battery: Option<usize>,
}

impl Layout {
    /// The layout of `spec`, or why its columns cannot be loaded.
    pub fn new(spec: &DataSpec) -> Result<Layout, String> {
        let (column, cmp, threshold) = active_rule(spec);
        let mut names = vec!["t".to_string()];
        names.extend(spec.state_columns.iter().cloned());
        names.extend(spec.action_columns.iter().cloned());
        names.push(column);
        let keep = log::column_indices(&names).map_err(|e| format!("data declaration: {e}"))?;
        let battery = spec.state_columns.iter().position(|c| c == "pwr_pm_vbat");
        Ok(Layout { keep, active_cmp: cmp, active_threshold: threshold, battery })
    }
}

/// Loads one recording (`.csv` or `.csv.gz`).
pub fn load_recording(path: &Path, layout: &Layout) -> Result<Recording, LogError> {
    let bytes = log::read_bytes(path)?;
    let parsed = log::parse(&path.display().to_string(), &bytes, &layout.keep)?;
    let cols = parsed.columns;
    let rows = parsed.rows;
    let mut state = vec![[0.0; 14]; rows];
    for (k, col) in cols[1..15].iter().enumerate() {
        for (s, v) in state.iter_mut().zip(col) {
            s[k] = *v;
        }
    }
    if let Some(b) = layout.battery {
        fill_zeros(&mut state, b);
    }
    let mut pwm = vec![[0.0; 4]; rows];
    let mut action = vec![[0.0; 4]; rows];
    for (k, col) in cols[15..19].iter().enumerate() {
        for ((p, a), v) in pwm.iter_mut().zip(action.iter_mut()).zip(col) {
            p[k] = *v;
            a[k] = (*v / PWM_FULL_SCALE).clamp(0.0, 1.0);
        }
    }
    let active = cols[19].iter().map(|v| layout.active_cmp.holds(*v, layout.active_threshold)).collect();
    Ok(Recording {
        name: recording_name(path),
        path: path.to_path_buf(),
        rows,
        t: cols[0].clone(),
        state,
        action,
        pwm,
        active,
        content_hash: parsed.content_hash,
    })
}

/// Battery is logged at 10 Hz and forward-filled with zeros before the
/// first reading: replace zeros by the previous reading, and leading zeros
/// by the first reading.
fn fill_zeros(state: &mut [[f64; 14]], k: usize) {
    let Some(first) = state.iter().map(|s| s[k]).find(|v| *v != 0.0) else { return };
    let mut last = first;
    for s in state.iter_mut() {
        if s[k] == 0.0 {
            s[k] = last;
        } else {
            last = s[k];
        }
    }
}

/// `dir/B9_trefoil_slow_rep3.csv.gz` -> `B9_trefoil_slow_rep3`.
pub fn recording_name(path: &Path) -> String {
    let file = path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
    file.trim_end_matches(".gz").trim_end_matches(".csv").to_string()
}

/// Orders names so that `rep2` comes before `rep10`.
pub fn natural_key(name: &str) -> Vec<(String, u64)> {
    let mut out = Vec::new();
    let mut text = String::new();
    let mut digits = String::new();
    for ch in name.chars() {
        if ch.is_ascii_digit() {
            digits.push(ch);
        } else {
            if !digits.is_empty() {
                out.push((std::mem::take(&mut text), digits.parse().unwrap_or(u64::MAX)));
                digits.clear();
            }
            text.push(ch);
        }
    }
    out.push((text, if digits.is_empty() { 0 } else { digits.parse().unwrap_or(u64::MAX) }));
    out
}
