//! The measures of a coverage study's replications at each true mean and
//! level, scored as rsimsum scores them.

use super::{performance_at, shifted, usable, Estimate, Performance, Simulated};
use crate::IntervalMethod;

/// The performance of every estimator at every true mean and level
/// (means outer, then levels, then estimators), with the relative
/// precision against the first estimator, computed as rsimsum computes it.
pub fn measures(sim: &Simulated, means: &[f64]) -> Vec<Performance> {
    let mut out = Vec::new();
    for &mu in means {
        for (l, &level) in sim.levels.iter().enumerate() {
            let reps = &sim.replications[l];
            let theta =
                |k: usize| -> Vec<Option<f64>> { reps[k].iter().map(|(e, _, _)| usable(e).then_some(e.0)).collect() };
            let reference = theta(0);
            let empse_ref = crate::sample_variance(&reference.iter().flatten().copied().collect::<Vec<_>>()).sqrt();
            for (k, &method) in sim.methods.iter().enumerate() {
                let dfs: Vec<f64> = reps[k].iter().map(|(_, d, _)| *d).collect();
                let mut p = performance_around(&sim.label, method, &reps[k], &dfs, mu, level);
                // Over the replications scored, as every other measure.
                let at_boundary = reps[k].iter().filter(|(e, _, b)| usable(e) && *b).count() as f64;
                let n = p.reps as f64;
                p.boundary = at_boundary / n;
                p.boundary_mcse = if n >= 2.0 { (p.boundary * (1.0 - p.boundary) / n).sqrt() } else { f64::NAN };
                let mine = theta(k);
                let pairs: Vec<(f64, f64)> =
                    reference.iter().zip(&mine).filter_map(|(a, b)| Some(((*a)?, (*b)?))).collect();
                let ratio2 = (empse_ref / p.emp_se).powi(2);
                p.rel_precision = 100.0 * (ratio2 - 1.0);
                let rho = correlation(&pairs);
                // Equal estimates give rho = 1 up to rounding: 1 - rho^2 is then 0, not a negative rounding error.
                p.rel_precision_mcse = 200.0 * ratio2 * ((1.0 - rho * rho).max(0.0) / (p.reps as f64 - 1.0)).sqrt();
                out.push(p);
            }
        }
    }
    out
}

/// One estimator's performance at true mean `mu`, from its intervals
/// around 0. Every measure that does not move with the location (coverage,
/// the misses, widths, bias, the SEs, MSE) is scored around 0, where the
/// intervals were computed: shifted by a mean of 1e20 an interval of width
/// 1 rounds to width 0 and would cover nothing or everything. The measures
/// that depend on where the truth lies (power, rejection, type S, relative
/// bias) are scored at `mu`; relative bias as mean(estimate around 0) / mu,
/// which is the same quantity without the cancellation.
fn performance_around(
    setting: &str,
    method: IntervalMethod,
    reps: &[(Estimate, f64, bool)],
    dfs: &[f64],
    mu: f64,
    level: f64,
) -> Performance {
    let around: Vec<Estimate> = reps.iter().map(|(e, _, _)| *e).collect();
    let mut p = performance_at(setting, method, &around, dfs, 0.0, level);
    p.true_mean = mu;
    if mu != 0.0 {
        let est: Vec<Estimate> = around.iter().map(|e| shifted(*e, mu)).collect();
        let at = performance_at(setting, method, &est, dfs, mu, level);
        (p.power, p.power_mcse, p.rejection, p.rejection_mcse, p.type_s, p.type_s_mcse) =
            (at.power, at.power_mcse, at.rejection, at.rejection_mcse, at.type_s, at.type_s_mcse);
        p.rel_bias = p.bias / mu;
        p.rel_bias_mcse = p.bias_mcse / mu.abs();
    }
    p
}

/// Pearson's correlation (R's `cor`: centred sums, two passes).
pub(crate) fn correlation(pairs: &[(f64, f64)]) -> f64 {
    let n = pairs.len() as f64;
    let (ma, mb) = (pairs.iter().map(|p| p.0).sum::<f64>() / n, pairs.iter().map(|p| p.1).sum::<f64>() / n);
    let sab: f64 = pairs.iter().map(|(a, b)| (a - ma) * (b - mb)).sum();
    let saa: f64 = pairs.iter().map(|(a, _)| (a - ma).powi(2)).sum();
    let sbb: f64 = pairs.iter().map(|(_, b)| (b - mb).powi(2)).sum();
    sab / (saa * sbb).sqrt()
}
