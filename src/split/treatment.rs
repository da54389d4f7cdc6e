//! Treatment strength: how close the contaminating windows sit to what is
//! evaluated, and what the evaluation set is made of.

use std::collections::BTreeMap;

use serde::Serialize;

use super::Split;

#[derive(Debug, Clone, Serialize)]
pub struct ArmTreatment {
    pub arm: String,
    pub contaminating_windows: usize,
    /// Windows inside at least one evaluated segment [start, start + horizon]
    /// of the same recording.
    pub inside_evaluated_segment: usize,
    pub share_inside: f64,
    /// Median distance to the nearest registered start in the same recording.
    pub median_distance_samples: f64,
    pub median_distance_s: f64,
}

/// Evaluation recordings by trajectory x speed.
#[derive(Debug, Clone, Serialize)]
pub struct Composition {
    /// Counts by trajectory, then speed.
    pub counts: BTreeMap<String, BTreeMap<String, usize>>,
    /// Evaluation recordings in all.
    pub total: usize,
}

/// What each arm's treatment is: how close its windows lie to the rollout starts.
#[derive(Debug, Clone, Serialize)]
pub struct TreatmentAudit {
    /// Rollout horizon, samples.
    pub horizon_samples: usize,
    /// One summary per arm, in design order.
    pub arms: Vec<ArmTreatment>,
    /// The evaluation set's trajectory x speed composition.
    pub composition: Composition,
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

/// Summarises the treatment of every arm of `split`.
pub fn treatment_audit(split: &Split) -> TreatmentAudit {
    let mut starts_by_rec: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for s in &split.starts {
        starts_by_rec.entry(s.recording).or_default().push(s.t);
    }
    let h = split.horizon;
    let arms = split
        .contaminating
        .iter()
        .map(|(arm, windows)| {
            let mut inside = 0;
            let mut dist = Vec::with_capacity(windows.len());
            for w in windows {
                let starts = starts_by_rec.get(&w.recording).map(|v| v.as_slice()).unwrap_or(&[]);
                if starts.iter().any(|&s| s <= w.t && w.t <= s + h) {
                    inside += 1;
                }
                if let Some(d) = starts.iter().map(|&s| s.abs_diff(w.t)).min() {
                    dist.push(d as f64);
                }
            }
            let m = median(dist);
            ArmTreatment {
                arm: arm.clone(),
                contaminating_windows: windows.len(),
                inside_evaluated_segment: inside,
                share_inside: if windows.is_empty() { f64::NAN } else { inside as f64 / windows.len() as f64 },
                median_distance_samples: m,
                median_distance_s: m / split.rate_hz,
            }
        })
        .collect();
    let mut counts: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    for &r in &split.evaluation {
        let i = &split.recordings[r];
        *counts.entry(i.trajectory.clone()).or_default().entry(i.speed.clone()).or_default() += 1;
    }
    TreatmentAudit { horizon_samples: h, arms, composition: Composition { counts, total: split.evaluation.len() } }
}

impl TreatmentAudit {
    /// Pretty JSON.
    pub fn to_json(&self) -> String {
        crate::io::pretty_json(self)
    }

    /// Plain-text summary for the terminal.
    pub fn render_text(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ = writeln!(s, "evaluation recordings by trajectory x speed ({} in all):", self.composition.total);
        let speeds = ["slow", "medium", "fast", "unknown"];
        let _ = writeln!(
            s,
            "  {:<20} {:>6} {:>6} {:>6} {:>8} {:>6}",
            "trajectory", "slow", "medium", "fast", "unknown", "total"
        );
        for (t, row) in &self.composition.counts {
            let c: Vec<usize> = speeds.iter().map(|sp| row.get(*sp).copied().unwrap_or(0)).collect();
            let _ = writeln!(
                s,
                "  {:<20} {:>6} {:>6} {:>6} {:>8} {:>6}",
                t,
                c[0],
                c[1],
                c[2],
                c[3],
                c.iter().sum::<usize>()
            );
        }
        for a in &self.arms {
            let _ = writeln!(
                s,
                "treatment strength, arm {}: {} contaminating windows, {} ({:.1}%) inside an evaluated {}-sample segment, median distance to the nearest start {} samples ({:.2} s)",
                a.arm,
                a.contaminating_windows,
                a.inside_evaluated_segment,
                100.0 * a.share_inside,
                self.horizon_samples,
                a.median_distance_samples,
                a.median_distance_s
            );
        }
        s
    }
}
