//! The registered rollout starts: the rows of each evaluation recording
//! from which a rollout of the horizon stays on active rows, and the draw
//! of the design's number of them per recording.

use super::*;

/// A start at row t needs t and the `horizon` rows after it all active
/// (and, `within first P%`, inside the first P% of the recording's rows).
fn valid_starts(rec: &Recording, horizon: usize, within_pct: Option<f64>) -> Vec<usize> {
    let n = rec.rows;
    let end = within_pct.map_or(n, |p| ((p / 100.0 * n as f64).floor() as usize).min(n));
    let mut run_after = vec![0usize; n + 1];
    // run_after[t] = consecutive active rows from t onward.
    for t in (0..n).rev() {
        run_after[t] = if rec.active[t] { run_after[t + 1] + 1 } else { 0 };
    }
    (0..n).filter(|&t| run_after[t] > horizon && t + horizon < end).collect()
}

/// Draws `k` windows of a pool for the evaluation recording at a position.
type StartPicker<'a> = dyn FnMut(&[Window], usize, usize) -> Vec<Window> + 'a;

/// The registered rollout starts: `starts` valid starts per evaluation
/// recording, in the order given, each drawn by `pick(pool, k, position)`.
/// Returned sorted.
pub(super) fn draw_starts(
    rf: &RecordingFactor,
    info: &[RecordingInfo],
    recordings: &[Recording],
    evaluation: &[usize],
    pick: &mut StartPicker<'_>,
) -> Result<Vec<Window>, SplitError> {
    let mut starts = Vec::new();
    for (k, &r) in evaluation.iter().enumerate() {
        let valid = valid_starts(&recordings[r], rf.horizon, rf.starts_within_pct);
        if valid.len() < rf.starts {
            return Err(SplitError::TooFewStarts {
                recording: info[r].name.clone(),
                valid: valid.len(),
                needed: rf.starts,
                horizon: rf.horizon,
                within: rf.starts_within_pct.map(|p| format!(" within its first {p}% of rows")).unwrap_or_default(),
            });
        }
        let pool: Vec<Window> = valid.into_iter().map(|t| Window { recording: r, t }).collect();
        starts.extend(pick(&pool, rf.starts, k));
    }
    starts.sort();
    Ok(starts)
}
