//! Plausibility rules: those any layout can declare (a frozen position, a
//! lost or crashed vehicle, and bounds on position, speed and rate) and
//! NanoBench's own percentile rule, each judged over the active rows with
//! what it measured in words.

use super::super::Recording;
use crate::design::{Bound, DataSpec, Pooling};
use crossaudit_stats::quantile_type7;

/// `exclude frozen position for T s`: fails when the position stays
/// exactly the same over `seconds` or more of consecutive active rows
/// while an action changes within them (a hovering vehicle's estimate
/// still moves; motion capture that lost it repeats its last reading).
pub(super) fn frozen(rec: &Recording, seconds: f64) -> (bool, String) {
    let same = |a: usize, b: usize| rec.state[a][..3] == rec.state[b][..3];
    // The longest frozen run with varying actions: (start, end) rows.
    let mut worst: Option<(usize, usize)> = None;
    let mut start = 0;
    for k in 0..=rec.rows {
        let continues = k < rec.rows && k > start && rec.active[k] && rec.active[k - 1] && same(k, k - 1);
        if continues {
            continue;
        }
        // Rows start..k-1 hold one position.
        if k > start + 1 {
            let end = k - 1;
            let acts = (start..=end).any(|r| rec.action[r] != rec.action[start]);
            let longer = worst.is_none_or(|(a, b)| rec.t[end] - rec.t[start] > rec.t[b] - rec.t[a]);
            if acts && rec.active[start] && longer {
                worst = Some((start, end));
            }
        }
        start = k;
    }
    match worst {
        Some((a, b)) => {
            let held = rec.t[b] - rec.t[a];
            let at = rec.t[a] - rec.t[0];
            let detail =
                format!("position unchanged for {held:.2} s from row {} (t = {at:.2} s) while the actions vary", a + 1);
            (held < seconds, detail)
        }
        None => (true, "the position never stays unchanged while the actions vary".into()),
    }
}

/// `exclude beyond position L m`, `speed L m/s` or `rate L rad/s`: fails
/// when an active row is beyond the bound. Speed is the declared
/// velocity's length, else the position's step over the time step between
/// consecutive active rows; the rate is the angle between consecutive
/// quaternions, 2 acos(|q_k . q_k-1| / (|q_k| |q_k-1|)), over the time
/// step (no rows without an attitude: `check` refuses the rule there).
pub(super) fn beyond(rec: &Recording, quantity: Bound, limit: f64) -> (bool, String) {
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let stepped = |k: usize| k > 0 && rec.active[k - 1] && rec.t[k] > rec.t[k - 1];
    let q = rec.slots.quaternion_slots();
    let values: Vec<(usize, f64)> = (0..rec.rows)
        .filter(|&k| rec.active[k])
        .filter_map(|k| match (quantity, rec.slots.velocity) {
            (Bound::Position, _) => Some((k, rec.state[k][..3].iter().fold(0.0f64, |m, x| m.max(x.abs())))),
            (Bound::Speed, true) => Some((k, norm(&rec.state[k][3..6]))),
            (Bound::Speed, false) => stepped(k).then(|| {
                let step: Vec<f64> = (0..3).map(|i| rec.state[k][i] - rec.state[k - 1][i]).collect();
                (k, norm(&step) / (rec.t[k] - rec.t[k - 1]))
            }),
            (Bound::Rate, _) => q.clone().filter(|_| stepped(k)).map(|q| {
                let (a, b) = (&rec.state[k][q.clone()], &rec.state[k - 1][q]);
                let dot = a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>().abs() / (norm(a) * norm(b));
                (k, 2.0 * dot.min(1.0).acos() / (rec.t[k] - rec.t[k - 1]))
            }),
        })
        .collect();
    let what = match quantity {
        Bound::Position => "|position|",
        Bound::Speed => "speed",
        Bound::Rate => "attitude rate",
    };
    let unit = quantity.words().1;
    match values.iter().copied().max_by(|a, b| a.1.total_cmp(&b.1)) {
        Some((k, v)) => {
            let at = rec.t[k] - rec.t[0];
            (v <= limit, format!("largest {what} {v:.3} {unit} at row {} (t = {at:.2} s)", k + 1))
        }
        None => (true, format!("no active rows to measure the {what} on")),
    }
}

/// The upstream rules: over active rows, the 0.5th and 99.5th percentiles
/// (linear interpolation, numpy's default) of battery voltage, setpoint z
/// and each motor's PWM must lie inside fixed bounds.
pub(super) fn plausible(spec: &DataSpec, rec: &Recording) -> (bool, String) {
    let active: Vec<usize> = (0..rec.rows).filter(|&k| rec.active[k]).collect();
    if active.is_empty() {
        return (false, "no active rows".into());
    }
    let col = |name: &str| spec.state_columns.iter().position(|c| c == name).expect("checked before loading");
    let (vbat, spz) = (col("pwr_pm_vbat"), col("sp_ctrltarget_z"));
    let mut checks: Vec<(String, Vec<f64>, (f64, f64))> = vec![
        ("battery".into(), active.iter().map(|&k| rec.state[k][vbat]).collect(), BATTERY_BOUNDS_V),
        ("setpoint z".into(), active.iter().map(|&k| rec.state[k][spz]).collect(), SETPOINT_Z_BOUNDS_M),
    ];
    match spec.plausibility {
        // Upstream: np.nanpercentile over the N x 4 array, all motors together.
        Pooling::Pooled => checks.push((
            "PWM (4 motors pooled)".into(),
            active.iter().flat_map(|&k| rec.pwm[k].iter().copied()).collect(),
            PWM_BOUNDS,
        )),
        Pooling::PerColumn => {
            for m in 0..4 {
                checks.push((format!("PWM m{}", m + 1), active.iter().map(|&k| rec.pwm[k][m]).collect(), PWM_BOUNDS));
            }
        }
    }
    let mut failures = Vec::new();
    for (what, mut v, (lo, hi)) in checks {
        v.sort_by(f64::total_cmp);
        let (p_lo, p_hi) = (quantile_type7(&v, PERCENTILES.0), quantile_type7(&v, PERCENTILES.1));
        if p_lo < lo || p_hi > hi {
            failures.push(format!("{what} p0.5..p99.5 = [{p_lo:.3}, {p_hi:.3}] outside [{lo}, {hi}]"));
        }
    }
    if failures.is_empty() {
        (true, "within bounds".into())
    } else {
        (false, failures.join("; "))
    }
}

/// Upstream NanoBench plausibility bounds over active rows, each checked at
/// the 0.5th and 99.5th percentiles.
pub const BATTERY_BOUNDS_V: (f64, f64) = (2.5, 4.5);
/// Setpoint z bounds, metres.
pub const SETPOINT_Z_BOUNDS_M: (f64, f64) = (-0.2, 3.0);
/// Motor PWM bounds.
pub const PWM_BOUNDS: (f64, f64) = (0.0, 65535.0);
/// The lower and upper percentiles at which every bound is checked.
pub const PERCENTILES: (f64, f64) = (0.005, 0.995);
