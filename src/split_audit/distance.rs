//! Distance in time between roles: for each window of a role, the nearest
//! window of another role in the same recording or an identical copy
//! of it (same content hash), and what share of a role's windows lies
//! within a declared gap of the other's. A whole-recording entry is the
//! window from its first to its last timestamp, so in a split of whole
//! recordings two roles meet only through copies, and a copy overlaps
//! entirely.
//!
//! The distance between `[a0, a1)` and `[b0, b1)` is `max(0, b0 - a1,
//! a0 - b1)`: 0 where they touch or overlap; they overlap (share rows)
//! where `b0 < a1` and `b1 > a0` and the time they share begins within
//! the log, before its last timestamp `D` plus half a sample interval `h`:
//! `max(a0, b0) < D + h/2` (two windows that meet only past the end of the
//! log share no row; half an interval absorbs the rounding of timestamps
//! taken from the epoch).
//! Only kept recordings take part.

use std::collections::BTreeMap;

use serde::Serialize;

use super::rows::{Effect, RecordingRow};
use crate::published::{DeclaredWindow, PublishedSplit};

/// The gap checked when none is declared: 1 s.
pub const DEFAULT_GAP_S: f64 = 1.0;

/// The windows of `role` against those of `other`.
#[derive(Debug, Clone, Serialize)]
pub struct PairDistance {
    /// The role whose windows are measured.
    pub role: String,
    /// The role they are measured against.
    pub other: String,
    /// Windows of `role` in kept recordings.
    pub windows: usize,
    /// ...whose recording (or an identical copy) holds a window of `other`.
    pub in_shared_recording: usize,
    /// ...that overlap a window of `other`: rows in both roles.
    pub overlapping: usize,
    /// ...whose nearest window of `other` is less than the gap away
    /// (overlapping ones included).
    pub within_gap: usize,
    /// Minimum, first quartile, median, third quartile and maximum of the
    /// distance, seconds (R's `quantile` type 7), over the windows in a
    /// shared recording; `None` where there are none.
    pub quantiles_s: Option<[f64; 5]>,
}

/// One window's nearest window in another role.
#[derive(Debug, Clone, Serialize)]
pub struct RoleWindowDistance {
    /// Its role.
    pub role: String,
    /// Its recording.
    pub recording: String,
    /// The window, seconds from the recording's first timestamp.
    pub window: DeclaredWindow,
    /// Its line in the split file.
    pub line: usize,
    /// The other role.
    pub other: String,
    /// The nearest window of `other`: its recording (itself, or a
    /// identical copy), the window, and its line.
    pub nearest: (String, DeclaredWindow, usize),
    /// Seconds between them (0 where they touch or overlap).
    pub distance_s: f64,
    /// Whether they share rows.
    pub overlaps: bool,
    /// Whether the window ends more than one sample interval after its
    /// recording's last timestamp: it names time the log does not hold.
    pub past_end: bool,
}

/// A window of a kept recording, with what it is compared by.
struct Placed<'a> {
    role: &'a str,
    recording: &'a str,
    content: &'a str,
    window: DeclaredWindow,
    line: usize,
    past_end: bool,
    /// The end of the time its log holds, seconds from its first
    /// timestamp: the last one plus half a sample interval.
    held_s: f64,
}

/// What [`distances`] finds.
pub(super) struct Found {
    pub pairs: Vec<PairDistance>,
    pub windows: Vec<RoleWindowDistance>,
    /// Per role, its windows that end past their recording's last timestamp.
    pub past_end: BTreeMap<String, usize>,
}

/// Every ordered pair of roles' distances, and each window's nearest in
/// every other role where its recording is shared.
pub(super) fn distances(split: &PublishedSplit, rows: &[RecordingRow], gap_s: f64) -> Found {
    let kept: BTreeMap<(&str, &str), &RecordingRow> = rows
        .iter()
        .filter(|r| r.effect == Effect::Kept && !r.role.is_empty())
        .map(|r| ((r.role.as_str(), r.recording.as_str()), r))
        .collect();
    let placed: Vec<Placed> = split
        .entries()
        .filter_map(|(role, e)| {
            let r = kept.get(&(role.name.as_str(), e.name.as_str()))?;
            let window = e.window.unwrap_or(DeclaredWindow { start_s: 0.0, end_s: r.duration_s });
            let step = if r.rows > 1 { r.duration_s / (r.rows - 1) as f64 } else { 0.0 };
            let past_end = window.end_s > r.duration_s + step + 1e-9;
            Some(Placed {
                role: &role.name,
                recording: &e.name,
                content: &r.content_hash,
                window,
                line: e.at.line,
                past_end,
                held_s: r.duration_s + step / 2.0,
            })
        })
        .collect();
    let mut past_end: BTreeMap<String, usize> = BTreeMap::new();
    for p in placed.iter().filter(|p| p.past_end) {
        *past_end.entry(p.role.to_string()).or_default() += 1;
    }
    let mut pairs = Vec::new();
    let mut each = Vec::new();
    for role in &split.roles {
        for other in split.roles.iter().filter(|o| o.name != role.name) {
            let index = Index::new(placed.iter().filter(|p| p.role == other.name));
            let mine: Vec<&Placed> = placed.iter().filter(|p| p.role == role.name).collect();
            let (mut found, mut overlapping) = (Vec::new(), 0);
            for p in &mine {
                let Some((b, distance_s, overlaps)) = index.nearest(p.content, p.window, p.held_s) else {
                    continue;
                };
                found.push(distance_s);
                overlapping += usize::from(overlaps);
                each.push(RoleWindowDistance {
                    role: role.name.clone(),
                    recording: p.recording.to_string(),
                    window: p.window,
                    line: p.line,
                    other: other.name.clone(),
                    nearest: (b.recording.to_string(), b.window, b.line),
                    distance_s,
                    overlaps,
                    past_end: p.past_end,
                });
            }
            pairs.push(PairDistance {
                role: role.name.clone(),
                other: other.name.clone(),
                windows: mine.len(),
                in_shared_recording: found.len(),
                overlapping,
                within_gap: found.iter().filter(|&&d| d < gap_s).count(),
                quantiles_s: quantiles(&mut found),
            });
        }
    }
    Found { pairs, windows: each, past_end }
}

fn quantiles(v: &mut [f64]) -> Option<[f64; 5]> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some([0.0, 0.25, 0.5, 0.75, 1.0].map(|p| crossaudit_stats::quantile_type7(v, p)))
}

/// One role's windows by content, sorted by start, with the running
/// maximum of their ends: the nearest window to any query in O(log n).
struct Index<'a> {
    by_content: BTreeMap<&'a str, Sorted<'a>>,
}

struct Sorted<'a> {
    windows: Vec<&'a Placed<'a>>,
    /// For each k, the index of the window with the latest end among the
    /// first k + 1.
    latest_end: Vec<usize>,
}

impl<'a> Index<'a> {
    fn new(windows: impl Iterator<Item = &'a Placed<'a>>) -> Index<'a> {
        let mut by: BTreeMap<&str, Vec<&Placed>> = BTreeMap::new();
        for w in windows {
            by.entry(w.content).or_default().push(w);
        }
        let by_content = by
            .into_iter()
            .map(|(content, mut windows)| {
                windows.sort_by(|a, b| a.window.start_s.total_cmp(&b.window.start_s).then(a.line.cmp(&b.line)));
                let mut latest_end: Vec<usize> = Vec::with_capacity(windows.len());
                for k in 0..windows.len() {
                    let best = match latest_end.last() {
                        Some(&j) if windows[j].window.end_s >= windows[k].window.end_s => j,
                        _ => k,
                    };
                    latest_end.push(best);
                }
                (content, Sorted { windows, latest_end })
            })
            .collect();
        Index { by_content }
    }

    /// The nearest window of the same content to `w`, its distance, and
    /// whether `w` overlaps any window of them in time before `held_s`,
    /// the end of what the log holds (not only the nearest: at distance 0
    /// the nearest may touch where another overlaps); `None` where no
    /// window shares the content.
    fn nearest(&self, content: &str, w: DeclaredWindow, held_s: f64) -> Option<(&'a Placed<'a>, f64, bool)> {
        let s = self.by_content.get(content)?;
        // Windows before `j` start before `w` ends; those before `held`
        // also start within the recording.
        let j = s.windows.partition_point(|b| b.window.start_s < w.end_s);
        let within = |t: f64| t < held_s;
        let held = s.windows.partition_point(|b| b.window.start_s < w.end_s && within(b.window.start_s));
        let overlaps = within(w.start_s)
            && held.checked_sub(1).is_some_and(|k| s.windows[s.latest_end[k]].window.end_s > w.start_s);
        let before = j.checked_sub(1).map(|k| {
            let b = s.windows[s.latest_end[k]];
            (b, (w.start_s - b.window.end_s).max(0.0), overlaps)
        });
        let after = s.windows.get(j).map(|b| (*b, b.window.start_s - w.end_s, false));
        match (before, after) {
            (Some(x), Some(y)) => Some(if y.1 < x.1 { y } else { x }),
            (x, y) => x.or(y),
        }
    }
}
