//! Failure-aware metrics of open-loop rollouts.

use super::Trace;
use crate::model::features::State;

/// Shortest rotation angle between two unit quaternions (w, x, y, z), in
/// degrees: 2 acos(|<q1, q2>|). q and -q are the same rotation.
pub fn attitude_error_deg(a: &[f64], b: &[f64]) -> f64 {
    let dot: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>().abs().min(1.0);
    (2.0 * dot.acos()).to_degrees()
}

/// One start at one horizon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartOutcome {
    /// Position error above the cap, or non-finite, at or before the horizon.
    pub divergent: bool,
    /// Position error at the horizon (m).
    pub position_error: f64,
    /// Velocity error at the horizon (m/s); `None` without a declared velocity.
    pub velocity_error: Option<f64>,
    /// Attitude error at the horizon (degrees); `None` without a declared attitude.
    pub attitude_error_deg: Option<f64>,
}

impl StartOutcome {
    /// The outcome of trace `t` at horizon `step`: divergent if any position
    /// error up to it is non-finite or above `cap`.
    pub fn of(t: &Trace, step: usize, cap: f64) -> StartOutcome {
        let divergent = t.position_error[..step].iter().any(|e| !e.is_finite() || *e > cap);
        let (pred, truth): (State, State) =
            t.at.iter()
                .find(|(k, _, _)| *k == step)
                .map(|(_, p, m)| (p.clone(), m.clone()))
                .unwrap_or_else(|| (vec![f64::NAN; t.slots.state], vec![f64::NAN; t.slots.state]));
        let norm3 = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>().sqrt();
        StartOutcome {
            divergent,
            position_error: t.position_error[step - 1],
            velocity_error: t.slots.velocity_slots().map(|v| norm3(&pred[v.clone()], &truth[v])),
            attitude_error_deg: t.slots.quaternion_slots().map(|q| attitude_error_deg(&pred[q.clone()], &truth[q])),
        }
    }
}

/// Metrics of one recording at one horizon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HorizonMetrics {
    /// Starts that diverged.
    pub n_divergent: usize,
    /// sqrt(mean over starts of min(err, cap)^2), cap for divergent starts.
    pub fa_position_rmse: f64,
    /// RMSE over non-divergent starts; None when every start diverged.
    pub conditional_position_rmse: Option<f64>,
    /// Velocity RMSE over non-divergent starts; None when every start
    /// diverged or the layout has no velocity.
    pub velocity_rmse: Option<f64>,
    /// Attitude RMSE (degrees) over non-divergent starts; None when every
    /// start diverged or the layout has no attitude.
    pub attitude_rmse_deg: Option<f64>,
}

/// Failure-aware metrics of one recording's starts at one horizon.
pub fn failure_aware(outcomes: &[StartOutcome], cap: f64) -> HorizonMetrics {
    let n = outcomes.len().max(1) as f64;
    let fa =
        (outcomes.iter().map(|o| if o.divergent { cap * cap } else { o.position_error.min(cap).powi(2) }).sum::<f64>()
            / n)
            .sqrt();
    let finite: Vec<&StartOutcome> = outcomes.iter().filter(|o| !o.divergent).collect();
    // Empty when every start diverged, or when a start lacks the error
    // (a layout without velocity or attitude lacks it in every start).
    let rms = |f: &dyn Fn(&StartOutcome) -> Option<f64>| {
        let errors: Option<Vec<f64>> = finite.iter().map(|o| f(o)).collect();
        let errors = errors.filter(|e| !e.is_empty())?;
        Some((errors.iter().map(|e| e.powi(2)).sum::<f64>() / errors.len() as f64).sqrt())
    };
    HorizonMetrics {
        n_divergent: outcomes.len() - finite.len(),
        fa_position_rmse: fa,
        conditional_position_rmse: rms(&|o| Some(o.position_error)),
        velocity_rmse: rms(&|o| o.velocity_error),
        attitude_rmse_deg: rms(&|o| o.attitude_error_deg),
    }
}
