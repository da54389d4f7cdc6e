//! Stage: flight logs. NanoBench CSV(.gz) + metadata -> [`Recording`]s, and
//! the inclusion audit that decides which recordings a study may use.

pub mod audit;
pub mod log;
pub mod metadata;

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::design::{Cmp, DataSpec, InclusionRule};
pub use audit::{audit, audit_and_hash_rows, audit_and_load, Audit, AuditError, FileRow, Status};
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
    /// XXH3-64 of each data row as written (see [`log::Log::row_hashes`]);
    /// empty unless the layout asks for them.
    pub row_hashes: Vec<u64>,
    /// The extrapolated onboard tail found in the file, if any (see [`onboard_tail`]).
    pub tail: Option<Tail>,
    /// Rows cut from the end of the file (`tails truncate`).
    pub rows_cut: usize,
}

/// The rows after a log's onboard streams end: the upstream merge
/// extrapolates every onboard column linearly in time to the last Vicon
/// row, so the onboard estimator's velocity and attitude quaternion lie
/// exactly on straight lines there (speeds up to 60 m/s, quaternion norms
/// up to 13 on this snapshot).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Tail {
    /// First extrapolated row (0-based data row).
    pub start: usize,
    /// Rows from `start` to the end of the file.
    pub rows: usize,
    /// Active rows among them.
    pub active: usize,
}

/// The onboard columns the tail detector reads, whatever the state columns.
pub const ONBOARD_COLUMNS: [&str; 7] = [
    "est_stateEstimate_vx",
    "est_stateEstimate_vy",
    "est_stateEstimate_vz",
    "att_stateEstimate_qw",
    "att_stateEstimate_qx",
    "att_stateEstimate_qy",
    "att_stateEstimate_qz",
];

/// A final straight run shorter than this (0.5 s at 100 Hz) is the ordinary
/// end of the onboard log, not a tail.
pub const MIN_TAIL_ROWS: usize = 50;

/// The extrapolated onboard tail of a log: the longest final run of rows on
/// which every column of `onboard` is a linear function of time (successive
/// slopes equal to a relative 1e-6), when it is at least [`MIN_TAIL_ROWS`]
/// long and holds an active row. Real estimator output is never exactly
/// linear over more than a few rows; the extrapolation always is.
pub fn onboard_tail(t: &[f64], onboard: &[&[f64]], active: &[bool]) -> Option<Tail> {
    let n = t.len();
    if n < MIN_TAIL_ROWS || onboard.is_empty() {
        return None;
    }
    let slope = |v: &[f64], k: usize| (v[k + 1] - v[k]) / (t[k + 1] - t[k]);
    let mut start = 0;
    for v in onboard {
        let last = slope(v, n - 2);
        // Rows k..n are on the line while the slope of (k-1, k) equals it.
        let mut k = n - 2;
        while k > 0 {
            let s = slope(v, k - 1);
            if !s.is_finite() || !last.is_finite() || (s - last).abs() > 1e-6 * last.abs().max(1.0) {
                break;
            }
            k -= 1;
        }
        start = start.max(k);
    }
    let rows = n - start;
    let active = active[start..].iter().filter(|a| **a).count();
    (rows >= MIN_TAIL_ROWS && active > 0).then_some(Tail { start, rows, active })
}

impl Recording {
    /// A recording with no rows (a placeholder to move fields out of).
    pub(crate) fn empty() -> Recording {
        Recording {
            name: String::new(),
            path: PathBuf::new(),
            rows: 0,
            t: Vec::new(),
            state: Vec::new(),
            action: Vec::new(),
            pwm: Vec::new(),
            active: Vec::new(),
            content_hash: String::new(),
            row_hashes: Vec::new(),
            tail: None,
            rows_cut: 0,
        }
    }

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
    /// Whether the schema's onboard columns were kept for the tail detector.
    onboard: bool,
    /// Whether each row is hashed ([`Recording::row_hashes`]).
    row_hashes: bool,
}

impl Layout {
    /// The layout of `spec`, or why its columns cannot be loaded.
    pub fn new(spec: &DataSpec) -> Result<Layout, String> {
        let (column, cmp, threshold) = active_rule(spec);
        let mut names = vec!["t".to_string()];
        names.extend(spec.state_columns.iter().cloned());
        names.extend(spec.action_columns.iter().cloned());
        names.push(column);
        let onboard = spec.source == crate::design::DataSource::Nanobench;
        if onboard {
            names.extend(ONBOARD_COLUMNS.iter().map(|c| c.to_string()));
        }
        let keep = log::column_indices(&names).map_err(|e| format!("data declaration: {e}"))?;
        let battery = spec.state_columns.iter().position(|c| c == "pwr_pm_vbat");
        Ok(Layout { keep, active_cmp: cmp, active_threshold: threshold, battery, onboard, row_hashes: false })
    }

    /// The same layout, also hashing every row (for the split audit).
    pub fn with_row_hashes(self) -> Layout {
        Layout { row_hashes: true, ..self }
    }
}

/// Loads one recording (`.csv` or `.csv.gz`).
pub fn load_recording(path: &Path, layout: &Layout) -> Result<Recording, LogError> {
    let bytes = log::read_bytes(path)?;
    let file = path.display().to_string();
    let parsed = if layout.row_hashes {
        log::parse_with_row_hashes(&file, &bytes, &layout.keep)?
    } else {
        log::parse(&file, &bytes, &layout.keep)?
    };
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
    let active: Vec<bool> = cols[19].iter().map(|v| layout.active_cmp.holds(*v, layout.active_threshold)).collect();
    let tail = if layout.onboard {
        let onboard: Vec<&[f64]> = cols[20..27].iter().map(|c| c.as_slice()).collect();
        onboard_tail(&cols[0], &onboard, &active)
    } else {
        None
    };
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
        row_hashes: parsed.row_hashes,
        tail,
        rows_cut: 0,
    })
}

impl Recording {
    /// Cuts the log at its onboard tail (`tails truncate`); no tail, no change.
    pub fn truncate_tail(&mut self) {
        let Some(tail) = self.tail else { return };
        let n = tail.start;
        self.t.truncate(n);
        self.state.truncate(n);
        self.action.truncate(n);
        self.pwm.truncate(n);
        self.active.truncate(n);
        self.row_hashes.truncate(n);
        self.rows_cut = self.rows - n;
        self.rows = n;
    }
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
