//! Estimates pooled over splits: for each dose and for the slope, a REML
//! fit of value = mu + split + recording + seed + residual (lme4's
//! `(1|split) + (1|recording) + (1|seed)`), certified by the optimizer.

use std::collections::BTreeMap;

use super::trend::{as_optimism, slopes, smallest_excluding_zero, step_down};
use super::{Pooled, PooledEstimate, Values};
use crate::analysis::AnalysisError;
use crate::plan::{dose_axis, DoseArm, Plan};
use crossaudit_stats::mixed::{self, Criterion, MixedData};
use crossaudit_stats::{DfRule, StatsError};

/// The pooled REML estimates over splits.
pub(super) fn pool(
    plan: &Plan,
    splits: &[Option<u64>],
    values: &[Values],
    doses: &[DoseArm],
) -> Result<Pooled, AnalysisError> {
    let mut ref_sum = 0.0;
    let mut ref_n = 0.0;
    for v in values {
        let n = (v.recordings.len() * v.seeds.len()) as f64;
        ref_sum += v.mean_reference * n;
        ref_n += n;
    }
    let mean_reference = ref_sum / ref_n;
    let mut out = Vec::new();
    for (k, dose) in doses.iter().enumerate() {
        let per: Vec<Vec<Option<f64>>> = values.iter().map(|v| v.d[k].clone()).collect();
        let label = if dose.percent.is_nan() { dose.arm.clone() } else { format!("dose {}", dose.label()) };
        let mut e = pooled_estimate(plan, &label, splits, values, &per, mean_reference)?;
        // A dose's optimism is the paper's ratio of arm means over every cell.
        let mean_d = mean_present(&per);
        e.optimism_pct = as_optimism(mean_d, mean_reference);
        out.push(e);
    }
    let slope = if doses.len() >= 2 {
        let per: Vec<Vec<Option<f64>>> = values.iter().map(|v| slopes(v, doses)).collect();
        Some(pooled_estimate(plan, "slope", splits, values, &per, mean_reference)?)
    } else {
        None
    };
    let intervals = || doses.iter().zip(&out).map(|(d, e)| (d.dose(), e.lower, e.upper)).filter(|x| !x.0.is_nan());
    let axis = dose_axis(doses);
    let smallest = smallest_excluding_zero(axis, intervals());
    let step = step_down(axis, intervals());
    Ok(Pooled { doses: out, slope, smallest_dose_excluding_zero: smallest, step_down_dose: step })
}

fn mean_present(per: &[Vec<Option<f64>>]) -> f64 {
    let all: Vec<f64> = per.iter().flatten().filter_map(|x| *x).collect();
    all.iter().sum::<f64>() / all.len().max(1) as f64
}

fn pooled_estimate(
    plan: &Plan,
    label: &str,
    splits: &[Option<u64>],
    values: &[Values],
    per: &[Vec<Option<f64>>],
    mean_reference: f64,
) -> Result<PooledEstimate, AnalysisError> {
    let mut recording_codes: BTreeMap<&str, usize> = BTreeMap::new();
    let (mut y, mut fs, mut fr, mut fj) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (si, (v, vals)) in values.iter().zip(per).enumerate() {
        for (i, r) in v.recordings.iter().enumerate() {
            let next = recording_codes.len();
            let rc = *recording_codes.entry(r.as_str()).or_insert(next);
            for (j, &seed) in v.seeds.iter().enumerate() {
                if let Some(x) = vals[i * v.seeds.len() + j] {
                    y.push(x);
                    fs.push(si);
                    fr.push(rc);
                    fj.push(seed as usize);
                }
            }
        }
    }
    let n = y.len();
    let stats = |e: mixed::MixedError| AnalysisError::Stats {
        unit: format!("pooled {label}"),
        source: StatsError::Invalid(e.to_string()),
    };
    let data =
        MixedData::new(y, vec![("split".to_string(), fs), ("recording".to_string(), fr), ("seed".to_string(), fj)])
            .map_err(stats)?;
    let fit = mixed::fit(&data, Criterion::Reml).and_then(|f| f.certified()).map_err(stats)?;
    let kr = plan.estimator.df == DfRule::KenwardRoger;
    let (se, df, df_rule, lower, upper) = fit
        .intercept_interval(kr, plan.estimator.level)
        .map_err(|e| AnalysisError::Stats { unit: format!("pooled {label}"), source: e })?;
    let variances = [fit.variances[0], fit.variances[1], fit.variances[2], fit.residual];
    let total: f64 = variances.iter().sum();
    let (a, b) = (as_optimism(upper, mean_reference), as_optimism(lower, mean_reference));
    let _ = splits;
    Ok(PooledEstimate {
        label: label.to_string(),
        n,
        levels: fit.levels.clone(),
        mean: fit.intercept,
        se,
        df,
        df_rule: df_rule.to_string(),
        lower,
        upper,
        optimism_pct: as_optimism(fit.intercept, mean_reference),
        optimism_lower: a.min(b),
        optimism_upper: a.max(b),
        variances,
        split_share: if total > 0.0 { variances[0] / total } else { 0.0 },
        se2_shares: fit.shares.clone(),
        singular: fit.singular,
    })
}
