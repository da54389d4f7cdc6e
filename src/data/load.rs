//! One log file read into a [`Recording`] under a [`Layout`]: parsed (its
//! missing values and gaps cut where a policy says so), its time column
//! checked against the rate, its state (Euler angles turned into
//! quaternions, zeros filled), actions, active rows, onboard tail and
//! logged quaternion's length checked, in that order.

use std::path::Path;

use super::{
    cuts, euler_zyx, log, norm4, onboard_tail, recording_name, Layout, LogError, Recording, Tail, MAX_GAP_STEPS,
};
use crate::design::{CutPolicy, GapPolicy};

/// The largest relative disagreement between the median time step and
/// 1 / rate, and between a quaternion's length and 1.
const RATE_TOLERANCE: f64 = 0.02;
const UNIT_TOLERANCE: f64 = 0.01;

/// Loads one recording (`.csv` or `.csv.gz`).
pub fn load_recording(path: &Path, layout: &Layout) -> Result<Recording, LogError> {
    let file = path.display().to_string();
    let (parsed, mut cut) = parse_log(path, &file, layout)?;
    let cols = &parsed.columns;
    let rows = parsed.rows;
    let t = match &layout.time {
        Some((name, k)) => {
            check_rate(&file, &parsed, &cols[*k], name, layout.rate_hz, layout.gaps)?;
            cols[*k].clone()
        }
        None => (0..rows).map(|k| k as f64 / layout.rate_hz).collect(),
    };
    if let Some(policy) = layout.gaps.filter(|g| g.policy != CutPolicy::Refuse) {
        cut.extend(cuts::gap_rows(&t, policy, |k| parsed.line_of(k)));
        cut.sort_by_key(|c| c.row);
    }
    let mut state = state_rows(&file, &parsed, layout)?;
    let (pwm, action) = action_rows(cols, rows, layout);
    let active = active_rows(cols, layout, &cut);
    let tail = if layout.extrapolated.is_empty() {
        None
    } else {
        let onboard: Vec<&[f64]> = layout.extrapolated.iter().map(|&c| cols[c].as_slice()).collect();
        onboard_tail(&t, &onboard, &active)
    };
    let quaternion_deviation = match (layout.euler, layout.slots.quaternion_slots()) {
        (None, Some(q_at)) => Some(check_quaternions(&file, &parsed, layout, (&mut state, q_at), &active, tail)?),
        _ => None,
    };
    Ok(Recording {
        name: recording_name(path),
        path: path.to_path_buf(),
        rows,
        t,
        state,
        action,
        pwm,
        slots: layout.slots,
        active,
        content_hash: parsed.content_hash,
        row_hashes: parsed.row_hashes,
        tail,
        rows_cut: 0,
        quaternion_deviation,
        cuts: cut,
    })
}

/// The file parsed under the layout's schema, with the rows a `missing
/// values` policy cuts (their values filled in); only a parse that reads
/// missing values as NaN can have any.
fn parse_log(path: &Path, file: &str, layout: &Layout) -> Result<(log::Log, Vec<cuts::Cut>), LogError> {
    let options = log::ParseOptions {
        hash_rows: layout.row_hashes,
        missing_as_nan: layout.missing.is_some_and(|p| p != CutPolicy::Refuse),
    };
    let mut parsed = log::read_log(path, file, &layout.schema, options)?;
    let mut cut = Vec::new();
    if options.missing_as_nan {
        cut = cuts::missing_rows(&parsed.columns, &layout.names, |k| parsed.line_of(k));
        if !cut.is_empty() {
            cuts::fill_missing(&mut parsed.columns);
        }
    }
    Ok((parsed, cut))
}

/// The state per row in the layout's slot order: the declared columns,
/// the quaternion from Euler angles where those are declared (refused at
/// the first angle beyond 2 pi when they are said to be radians), and the
/// zeros of the `fill_zeros` slots filled.
fn state_rows(file: &str, parsed: &log::Log, layout: &Layout) -> Result<Vec<Vec<f64>>, LogError> {
    let cols = &parsed.columns;
    let mut state = vec![vec![0.0; layout.state.len()]; parsed.rows];
    for (slot, col) in layout.state.iter().enumerate() {
        let Some(col) = col else { continue };
        for (s, v) in state.iter_mut().zip(&cols[*col]) {
            s[slot] = *v;
        }
    }
    if let (Some(([r, p, y], degrees)), Some(q_at)) = (layout.euler, layout.slots.quaternion_slots()) {
        // No angle in radians is beyond 2 pi in any convention: one that is
        // was written in degrees (a quaternion from it would be garbage).
        if !degrees {
            let beyond = |c: usize| cols[c].iter().position(|v| v.abs() > std::f64::consts::TAU).map(|k| (k, c));
            if let Some((k, c)) = [r, p, y].into_iter().filter_map(beyond).min() {
                let which = [r, p, y].iter().position(|&x| x == c).unwrap_or(0);
                return Err(LogError::EulerRange {
                    file: file.to_string(),
                    line: parsed.line_of(k),
                    column: layout.euler_names.get(which).cloned().unwrap_or_default(),
                    value: cols[c][k],
                });
            }
        }
        let scale = if degrees { std::f64::consts::PI / 180.0 } else { 1.0 };
        for (k, s) in state.iter_mut().enumerate() {
            let q = euler_zyx(cols[r][k] * scale, cols[p][k] * scale, cols[y][k] * scale);
            s[q_at.clone()].copy_from_slice(&q);
        }
    }
    for &b in &layout.fill_zeros {
        fill_zeros(&mut state, b);
    }
    Ok(state)
}

/// The action columns per row as logged (NanoBench: motor PWM) and
/// scaled by the layout's action scale, clipped to [0, 1].
fn action_rows(cols: &[Vec<f64>], rows: usize, layout: &Layout) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let mut pwm = vec![vec![0.0; layout.actions.len()]; rows];
    let mut action = vec![vec![0.0; layout.actions.len()]; rows];
    for (k, col) in layout.actions.iter().enumerate() {
        for ((p, a), v) in pwm.iter_mut().zip(action.iter_mut()).zip(&cols[*col]) {
            p[k] = *v;
            a[k] = (*v / layout.action_scale).clamp(0.0, 1.0);
        }
    }
    (pwm, action)
}

/// The rows meeting the active rule, less the cut rows whose policy is
/// `segment`.
fn active_rows(cols: &[Vec<f64>], layout: &Layout, cut: &[cuts::Cut]) -> Vec<bool> {
    let mut active: Vec<bool> =
        cols[layout.active].iter().map(|v| layout.active_cmp.holds(*v, layout.active_threshold)).collect();
    for c in cut {
        let policy = match c.why {
            cuts::CutReason::Missing { .. } => layout.missing,
            cuts::CutReason::Gap { .. } => layout.gaps.map(|g| g.policy),
        };
        if policy == Some(CutPolicy::Segment) {
            active[c.row] = false;
        }
    }
    active
}

/// The largest |length - 1| of the logged quaternion at slots `q_at`,
/// refused at the first row past the tolerance; with a declared
/// tolerance, every row's quaternion renormalised.
fn check_quaternions(
    file: &str,
    parsed: &log::Log,
    layout: &Layout,
    (state, q_at): (&mut [Vec<f64>], std::ops::Range<usize>),
    active: &[bool],
    tail: Option<Tail>,
) -> Result<f64, LogError> {
    // Active rows only (NanoBench's onboard estimator drifts off unit
    // length on the ground after landing), and not the rows of an
    // extrapolated tail: `tails` judges those.
    let checked = tail.map_or(parsed.rows, |tail| tail.start);
    let deviation = |k: usize| (norm4(&state[k][q_at.clone()]) - 1.0).abs();
    let largest = (0..checked).filter(|&k| active[k]).map(deviation).fold(0.0, f64::max);
    let tolerance = layout.quaternion_tolerance.unwrap_or(UNIT_TOLERANCE);
    if let Some(k) = (0..checked).find(|&k| active[k] && deviation(k) > tolerance) {
        return Err(LogError::NotUnit {
            file: file.to_string(),
            line: parsed.line_of(k),
            columns: layout.quaternion_names.clone(),
            norm: norm4(&state[k][q_at]),
            tolerance,
            largest,
            declared: layout.quaternion_tolerance.is_some(),
        });
    }
    if layout.quaternion_tolerance.is_some() {
        for s in state.iter_mut() {
            let n = norm4(&s[q_at.clone()]);
            if n > 0.0 {
                s[q_at.clone()].iter_mut().for_each(|v| *v /= n);
            }
        }
    }
    Ok(largest)
}

/// The median step of the time column must agree with 1 / rate to 2%, and
/// no step may be longer than [`MAX_GAP_STEPS`] samples (or, with a
/// declared `gaps` policy, only under `refuse` may none be longer than its
/// length); the error names the first step that does not.
fn check_rate(
    file: &str,
    log: &log::Log,
    t: &[f64],
    column: &str,
    rate_hz: f64,
    gaps: Option<GapPolicy>,
) -> Result<(), LogError> {
    if t.len() < 2 {
        return Ok(());
    }
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let expected = 1.0 / rate_hz;
    let off = |s: f64| (s / expected - 1.0).abs() > RATE_TOLERANCE;
    let first_off = steps.iter().position(|s| off(*s));
    steps.sort_by(f64::total_cmp);
    let median = if steps.len() % 2 == 1 {
        steps[steps.len() / 2]
    } else {
        (steps[steps.len() / 2 - 1] + steps[steps.len() / 2]) / 2.0
    };
    if !off(median) {
        // The rate holds, but a window across a gap would join two stretches
        // of flight as one step: refused at the step's line.
        let longest = match gaps {
            None => MAX_GAP_STEPS * expected,
            Some(g) if g.policy == CutPolicy::Refuse => g.over_s,
            Some(_) => return Ok(()),
        };
        if let Some(k) = t.windows(2).position(|w| w[1] - w[0] > longest) {
            let limit = match gaps {
                Some(g) => format!("the declared `gaps over {} s`", g.over_s),
                None => format!("the {MAX_GAP_STEPS} samples a log may miss in a row"),
            };
            return Err(LogError::Gap {
                file: file.to_string(),
                line: log.line_of(k + 1),
                column: column.to_string(),
                gap_s: t[k + 1] - t[k],
                rate_hz,
                limit,
            });
        }
        return Ok(());
    }
    Err(LogError::Rate {
        file: file.to_string(),
        line: log.line_of(first_off.unwrap_or(0) + 1),
        column: column.to_string(),
        median_s: median,
        rate_hz,
        expected_s: expected,
    })
}

/// Battery is logged at 10 Hz and forward-filled with zeros before the
/// first reading: replace zeros by the previous reading, and leading zeros
/// by the first reading.
fn fill_zeros(state: &mut [Vec<f64>], k: usize) {
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
