//! Where a declared policy cuts a recording: rows with a missing value in
//! a column read (`missing values exclude|segment`) and the first row after
//! a time gap (`gaps over T s exclude|segment`).
//!
//! Under `segment` each such row is made inactive, so no training window
//! (a pair of consecutive active rows) and no rollout (a run of active
//! rows) reaches across it: the recording is used as the segments between
//! its cuts. The segments stay one recording, so a split never puts them
//! in different arms. A missing value is replaced by the last reading
//! before it (the first after it for leading rows), only so that no NaN
//! reaches any statistic; the row itself is never used.

use serde::Serialize;

use crate::design::{CutPolicy, GapPolicy};

/// One cut: a row the recording cannot use, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Cut {
    /// The data row (0-based).
    pub row: usize,
    /// Its line in the file (1 = header).
    pub line: usize,
    /// Why.
    pub why: CutReason,
}

/// Why a row is cut.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum CutReason {
    /// A missing (empty or non-finite) value in this column.
    Missing {
        /// The first column of the row with one.
        column: String,
    },
    /// The time steps by this many seconds from the row before.
    Gap {
        /// The step, seconds.
        seconds: f64,
    },
}

impl Cut {
    /// `line 14, column \`vx\`: missing` or `line 540: the time jumps by 5 s`.
    pub fn describe(&self) -> String {
        match &self.why {
            CutReason::Missing { column } => format!("line {}, column `{column}`: missing value", self.line),
            CutReason::Gap { seconds } => format!("line {}: the time jumps by {seconds:.3} s", self.line),
        }
    }
}

/// The rows of `cols` (the columns read, named `names`) with a NaN, each
/// with the first such column; `line_of` gives a row's file line.
pub(super) fn missing_rows(cols: &[Vec<f64>], names: &[String], line_of: impl Fn(usize) -> usize) -> Vec<Cut> {
    let rows = cols.first().map_or(0, Vec::len);
    (0..rows)
        .filter_map(|k| {
            let c = cols.iter().position(|col| col[k].is_nan())?;
            let column = names.get(c).cloned().unwrap_or_default();
            Some(Cut { row: k, line: line_of(k), why: CutReason::Missing { column } })
        })
        .collect()
}

/// Replaces each NaN by the last finite value before it in its column (or
/// the first after it; 0 in a column without one).
pub(super) fn fill_missing(cols: &mut [Vec<f64>]) {
    for col in cols.iter_mut() {
        let Some(first) = col.iter().copied().find(|v| v.is_finite()) else {
            col.iter_mut().for_each(|v| *v = 0.0);
            continue;
        };
        let mut last = first;
        for v in col.iter_mut() {
            if v.is_nan() {
                *v = last;
            } else {
                last = *v;
            }
        }
    }
}

/// The first row after each step of `t` longer than the policy's length.
pub(super) fn gap_rows(t: &[f64], policy: GapPolicy, line_of: impl Fn(usize) -> usize) -> Vec<Cut> {
    t.windows(2)
        .enumerate()
        .filter(|(_, w)| w[1] - w[0] > policy.over_s)
        .map(|(k, w)| Cut { row: k + 1, line: line_of(k + 1), why: CutReason::Gap { seconds: w[1] - w[0] } })
        .collect()
}

/// The audit's verdict on a recording's cuts of one kind under `policy`:
/// (passes, what was found).
pub fn verdict(cuts: &[&Cut], policy: CutPolicy) -> (bool, String) {
    let Some(first) = cuts.first() else { return (true, "none".to_string()) };
    let count = cuts.len();
    let kind = match first.why {
        CutReason::Missing { .. } => "row(s) with a missing value",
        CutReason::Gap { .. } => "gap(s)",
    };
    match policy {
        CutPolicy::Segment => (true, format!("{count} {kind}, cut there (first {})", first.describe())),
        _ => (false, format!("{count} {kind} (first {})", first.describe())),
    }
}
