//! The multi-split planner: from a pilot's pooled variance components over
//! whole redraws of the split, the SE, width and probability that the
//! decision rule holds for other numbers of splits, recordings and seeds.

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use super::power::{check_counts, refuse_degenerate, rule_power, slope_name, unit_of, PowerError};
use crate::io::{create_dir_all, write_atomic};
use crate::plan::Plan;
use crate::report::MdTable;
use crossaudit_stats::critical_value;

/// One row of the multi-split planner.
#[derive(Debug, Clone, Serialize)]
pub struct SplitPowerRow {
    /// Splits S.
    pub splits: usize,
    /// Evaluation recordings per split I.
    pub recordings: usize,
    /// Seeds J (shared by the splits).
    pub seeds: usize,
    /// Predicted SE of the pooled estimate.
    pub se: f64,
    /// Predicted interval width, 2 t(S - 1) SE.
    pub width: f64,
    /// P(the decision rule holds on the pooled estimate), normal approximation.
    pub power: f64,
}

/// The multi-split planner's answer for one design and pilot.
#[derive(Debug, Clone, Serialize)]
pub struct SplitPowerPlan {
    /// The primary unit's label.
    pub unit: String,
    /// Splits, recordings per split and seeds in the pilot.
    pub pilot: (usize, usize, usize),
    /// Pilot pooled mean d.
    pub mean_d: f64,
    /// Pilot reference-arm mean.
    pub mean_reference: f64,
    /// Pilot variance components: split, recording, seed, residual.
    pub variances: [f64; 4],
    /// The unit of the SE and width, for plan.md's headers.
    #[serde(skip)]
    pub value_unit: String,
    /// One row per (S, I, J) asked for.
    pub rows: Vec<SplitPowerRow>,
}

/// SE of the pooled mean with S splits of I recordings and J shared seeds,
/// treating the S x I evaluation recordings as distinct:
/// sqrt(s2_split/S + s2_rec/(S I) + s2_seed/J + s2_res/(S I J)). Recordings
/// that recur across splits average out less, so this is a lower bound on
/// the SE when the recording pool is small.
pub fn pooled_se(variances: [f64; 4], splits: f64, recordings: f64, seeds: f64) -> f64 {
    let [vs, vr, vj, ve] = variances;
    (vs / splits + vr / (splits * recordings) + vj / seeds + ve / (splits * recordings * seeds)).sqrt()
}

/// The planner for a multi-split design: from a pilot's pooled variance
/// components (the first dose's pooled fit), the SE ([`pooled_se`]), the
/// interval width 2 t(S - 1) SE (the split count limits the df; with a
/// split component near zero this is conservative) and the probability
/// that the decision rule holds, as `power_plan` computes it, for each
/// number of splits, recordings per split and seeds.
pub fn split_power_plan(
    plan: &Plan,
    family: &crate::analysis::family::FamilyAnalysis,
    splits: &[usize],
    recordings: &[usize],
    seeds: &[usize],
) -> Result<SplitPowerPlan, PowerError> {
    check_counts(&[splits, recordings, seeds])?;
    // The pooled estimate the rule is on: the slope, or the first dose's.
    let pooled = family.pooled.as_ref().ok_or(PowerError::NoPrimary)?;
    let on_slope = plan.rule_on_slope();
    let pooled = if on_slope {
        pooled.slope.as_ref().ok_or(PowerError::NoTrend)?
    } else {
        pooled.doses.first().ok_or(PowerError::NoPrimary)?
    };
    let first = family.splits.first().and_then(|s| s.doses.first()).ok_or(PowerError::NoPrimary)?;
    let mean_reference = first.mean_reference;
    refuse_degenerate(&family.unit, &pooled.variances, pooled.mean, mean_reference)?;
    let mut rows = Vec::new();
    for &s in splits {
        for &i in recordings {
            for &j in seeds {
                let se = pooled_se(pooled.variances, s as f64, i as f64, j as f64);
                let t = critical_value(plan.estimator.level, (s - 1) as f64)?;
                let power = rule_power(plan, pooled.mean, se, t, mean_reference)?;
                rows.push(SplitPowerRow { splits: s, recordings: i, seeds: j, se, width: 2.0 * t * se, power });
            }
        }
    }
    Ok(SplitPowerPlan {
        unit: if on_slope { format!("{} of {}", slope_name(family), family.unit) } else { family.unit.clone() },
        pilot: (family.splits.len(), first.estimate.rows, first.estimate.cols),
        mean_d: pooled.mean,
        mean_reference,
        variances: pooled.variances,
        value_unit: unit_of(plan.primary.metric.unit(), on_slope.then_some(family.dose_axis)),
        rows,
    })
}

impl SplitPowerPlan {
    /// plan.md.
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# Multi-split planner: {}\n", self.unit);
        let [vs, vr, vj, ve] = self.variances;
        let _ = writeln!(
            s,
            "Pilot: {} splits x {} recordings x {} seeds; pooled mean d {:.5}, reference mean {:.5}; sigma^2 split {vs:.3e}, recording {vr:.3e}, seed {vj:.3e}, residual {ve:.3e}.\n",
            self.pilot.0, self.pilot.1, self.pilot.2, self.mean_d, self.mean_reference
        );
        let _ = writeln!(
            s,
            "SE^2 = s2_split/S + s2_rec/(S I) + s2_seed/J + s2_res/(S I J), the S x I recordings taken as distinct (recordings that recur across splits make the real SE larger); width = 2 t(S - 1) SE.\n"
        );
        let (se_h, width_h) =
            (format!("predicted SE ({})", self.value_unit), format!("interval width ({})", self.value_unit));
        let cols = ["splits S", "recordings I", "seeds J", &se_h, &width_h, "P(decision rule holds)"];
        let mut table = MdTable::new(&cols, "rrrrrr");
        for r in &self.rows {
            table.row([
                r.splits.to_string(),
                r.recordings.to_string(),
                r.seeds.to_string(),
                format!("{:.5}", r.se),
                format!("{:.5}", r.width),
                format!("{:.3}", r.power),
            ]);
        }
        s.push_str(&table.render());
        s.push_str(
            "\n## Assumptions\n\n\
- The pilot's pooled variance components (split, recording, seed, residual) are the true ones, and splits, recordings and seeds added or removed are like the pilot's.\n\
- The S x I evaluation recordings are distinct; recordings that recur across splits average out less, so the predicted SE is a lower bound when the recording pool is small.\n\
- The pilot's pooled mean is the true effect, and the reference mean stays at the pilot's; a pilot chosen because its effect looked large makes every probability optimistic.\n\
- The estimate is normal with that SE, taken as known; the interval uses t(S - 1), conservative when the split component is near zero.\n\
- The rule holds when the estimate is at most min(-t SE, -c m_ref / 100); P(decision rule holds) = Phi((that bound - mean) / SE).\n",
        );
        s
    }

    /// Writes plan.md and plan.json into `out`.
    pub fn write(&self, out: &Path) -> Result<(), PowerError> {
        create_dir_all(out)?;
        write_atomic(&out.join("plan.md"), self.to_markdown().as_bytes())?;
        let json = serde_json::to_string_pretty(self).unwrap_or_default();
        write_atomic(&out.join("plan.json"), json.as_bytes())?;
        Ok(())
    }
}
