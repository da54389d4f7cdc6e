//! Stage: flight logs. CSV(.gz) logs in NanoBench's schema or in the
//! columns a `data csv` block declares, + metadata -> [`Recording`]s, and
//! the inclusion audit that decides which recordings a study may use.

pub mod audit;
pub mod conditions;
pub mod cuts;
mod load;
pub mod log;
mod log_error;
pub mod metadata;

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::design::{Cmp, CutPolicy, DataSpec, GapPolicy, InclusionRule, Slots};
pub use audit::{audit, audit_and_hash_rows, audit_and_load, unread_sentence, Audit, AuditError, FileRow, Status};
pub use load::load_recording;
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
    /// The state per row, in the declared slot order (NanoBench: 14, its
    /// battery zeros forward/back-filled).
    pub state: Vec<Vec<f64>>,
    /// The action per row: the column / its scale, clipped to [0, 1]
    /// (NanoBench: 4, PWM / 65535).
    pub action: Vec<Vec<f64>>,
    /// The action columns before scaling (NanoBench: motor PWM), for plausibility.
    pub pwm: Vec<Vec<f64>>,
    /// The state and action layout (NanoBench's: 14 and 4, the first 10
    /// state slots predicted): which slots are predicted, which exogenous
    /// (written in from the log at every rollout step), and where the
    /// velocity and quaternion are, when declared.
    pub slots: Slots,
    /// Rows meeting the active rule (default: motor_motor_m1 > 1000).
    pub active: Vec<bool>,
    /// XXH3-128 of the values read (see [`log::Log::content_hash`]): equal
    /// for value-identical recordings, whatever format or digits wrote them.
    pub content_hash: String,
    /// XXH3-64 of each row's values read (see [`log::Log::row_hashes`]);
    /// empty unless the layout asks for them.
    pub row_hashes: Vec<u64>,
    /// The extrapolated onboard tail found in the file, if any (see [`onboard_tail`]).
    pub tail: Option<Tail>,
    /// Rows cut from the end of the file (`tails truncate`).
    pub rows_cut: usize,
    /// The largest |length - 1| of a logged quaternion over the rows it is
    /// checked on (active rows before any extrapolated tail), before any
    /// renormalisation; `None` without a logged quaternion.
    pub quaternion_deviation: Option<f64>,
    /// The rows a declared `missing values` or `gaps` policy cuts, in row
    /// order (see [`cuts`]); under `segment` each is inactive.
    pub cuts: Vec<cuts::Cut>,
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

/// The onboard columns NanoBench's tail detector reads, whatever the state columns.
pub const ONBOARD_COLUMNS: [&str; 7] = crate::design::NANOBENCH_EXTRAPOLATED;

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
            slots: Slots::NANOBENCH,
            active: Vec::new(),
            content_hash: String::new(),
            row_hashes: Vec::new(),
            tail: None,
            rows_cut: 0,
            quaternion_deviation: None,
            cuts: Vec::new(),
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
            _ => None,
        })
        .unwrap_or_else(|| ("motor_motor_m1".to_string(), Cmp::Gt, 1000.0))
}

/// Column layout needed to load recordings under a data declaration: the
/// data's `LogFormat` resolved into the columns one parse reads.
#[derive(Debug, Clone)]
pub struct Layout {
    schema: log::Schema,
    /// Declared rate, Hz.
    rate_hz: f64,
    /// The time column's name and position among the columns read.
    time: Option<(String, usize)>,
    /// Each state slot's position among the columns read.
    state: Vec<Option<usize>>,
    /// The Euler columns' positions, and whether in degrees.
    euler: Option<([usize; 3], bool)>,
    /// The quaternion's columns, as an error names them.
    quaternion_names: String,
    /// The Euler columns' names (roll, pitch, yaw), when declared.
    euler_names: Vec<String>,
    /// `norm within T`: the quaternion's tolerance, every row renormalised.
    quaternion_tolerance: Option<f64>,
    /// The layout the columns are read into.
    slots: Slots,
    actions: Vec<usize>,
    action_scale: f64,
    active: usize,
    active_cmp: Cmp,
    active_threshold: f64,
    /// The state slots whose zeros are filled.
    fill_zeros: Vec<usize>,
    /// The extrapolated-tail columns' positions.
    extrapolated: Vec<usize>,
    /// Whether each row is hashed ([`Recording::row_hashes`]).
    row_hashes: bool,
    /// The columns read, in order (as a cut names them).
    names: Vec<String>,
    /// `missing values P`.
    missing: Option<CutPolicy>,
    /// `gaps over T s P`.
    gaps: Option<GapPolicy>,
}

impl Layout {
    /// The layout of `spec`, or why its columns cannot be loaded.
    pub fn new(spec: &DataSpec) -> Result<Layout, String> {
        let format = spec.log_format();
        let (column, cmp, threshold) = active_rule(spec);
        let mut names: Vec<String> = Vec::new();
        let mut at = |name: &str| {
            names.push(name.to_string());
            names.len() - 1
        };
        let time = format.time.as_ref().map(|t| (t.clone(), at(t)));
        let state: Vec<Option<usize>> = format.state.iter().map(|c| c.as_deref().map(&mut at)).collect();
        let euler =
            format.euler.as_ref().map(|e| ([at(&e.columns[0]), at(&e.columns[1]), at(&e.columns[2])], e.degrees));
        let actions = format.actions.iter().map(|c| at(c)).collect();
        let active = at(&column);
        let extrapolated = format.extrapolated.iter().map(|c| at(c)).collect();
        let slots = format.slots();
        let quaternion_names = format.state[slots.quaternion_slots().unwrap_or(0..0)]
            .iter()
            .map(|c| format!("`{}`", c.as_deref().unwrap_or("")))
            .collect::<Vec<_>>()
            .join(", ");
        let schema = if format.nanobench_header {
            log::Schema::Nanobench(log::column_indices(&names).map_err(|e| format!("data declaration: {e}"))?)
        } else {
            log::Schema::Named { columns: names.clone(), time: format.time.clone() }
        };
        Ok(Layout {
            schema,
            rate_hz: spec.rate_hz,
            time,
            state,
            euler,
            quaternion_names,
            euler_names: format.euler.as_ref().map(|e| e.columns.to_vec()).unwrap_or_default(),
            quaternion_tolerance: format.quaternion_tolerance,
            slots,
            actions,
            action_scale: format.action_scale,
            active,
            active_cmp: cmp,
            active_threshold: threshold,
            fill_zeros: format.fill_zeros.clone(),
            extrapolated,
            row_hashes: false,
            names,
            missing: spec.missing_values,
            gaps: spec.gaps,
        })
    }

    /// The same layout, also hashing every row (for the split audit).
    pub fn with_row_hashes(self) -> Layout {
        Layout { row_hashes: true, ..self }
    }
}

/// A note when actions were clipped to [0, 1]: a declared scale below the
/// logs' largest command saturates the model's inputs without a word.
pub fn clipped_actions(rec: &Recording, scale: f64) -> Option<String> {
    let beyond = |v: f64| if v < 0.0 { -v } else { v - scale };
    // How many lie outside, and the farthest, with the data row (1-based,
    // after the header) and time it was read at: where to look in the log.
    let (outside, far) = rec
        .pwm
        .iter()
        .enumerate()
        .flat_map(|(k, r)| r.iter().map(move |v| (k, *v)))
        .filter(|(_, v)| *v < 0.0 || *v > scale)
        .fold((0usize, None), |(n, far): (usize, Option<(usize, f64)>), (k, v)| match far {
            Some((_, w)) if beyond(w) >= beyond(v) => (n + 1, far),
            _ => (n + 1, Some((k, v))),
        });
    let (row, value) = far?;
    let at = rec.t.get(row).map(|t| format!(", t = {t} s")).unwrap_or_default();
    Some(format!(
        "{outside} action value(s) outside [0, {scale}] clipped to [0, 1] (the farthest {value}, at data row {}{at}); is the action `scale` right?",
        row + 1
    ))
}

/// The Euclidean length of a quaternion (or any vector).
pub(crate) fn norm4(q: &[f64]) -> f64 {
    q.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// The unit quaternion (w, x, y, z) of roll, pitch and yaw (radians),
/// rotations about z, then y, then x (the aerospace Z-Y-X convention).
pub fn euler_zyx(roll: f64, pitch: f64, yaw: f64) -> [f64; 4] {
    let (sr, cr) = (roll / 2.0).sin_cos();
    let (sp, cp) = (pitch / 2.0).sin_cos();
    let (sy, cy) = (yaw / 2.0).sin_cos();
    [cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy]
}

/// The longest step between rows, in samples at the declared rate, that a
/// log may have: the NanoBench logs drop at most 4 samples in a row.
pub const MAX_GAP_STEPS: f64 = 10.0;

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

/// `dir/B9_trefoil_slow_rep3.csv.gz` -> `B9_trefoil_slow_rep3` (and
/// `run_07.parquet` -> `run_07`).
pub fn recording_name(path: &Path) -> String {
    let file = path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
    match file.strip_suffix(".parquet") {
        Some(stem) => stem.to_string(),
        None => file.trim_end_matches(".gz").trim_end_matches(".csv").to_string(),
    }
}

/// Whether a file name is a flight log's: `.csv`, `.csv.gz` or `.parquet`.
pub fn is_log_name(name: &str) -> bool {
    crate::io::walk::is_log_name(name)
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
