//! Treatment strength: how close the contaminating windows sit to what is
//! evaluated, and what the evaluation set is made of.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::Split;

/// One arm's treatment strength, as `audit/treatment.json` holds it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ArmTreatment {
    /// The arm.
    pub arm: String,
    /// Its windows from the evaluation recordings.
    pub contaminating_windows: usize,
    /// Windows inside at least one evaluated segment [start, start + horizon]
    /// of the same recording.
    pub inside_evaluated_segment: usize,
    /// inside_evaluated_segment / contaminating_windows.
    pub share_inside: f64,
    /// Median distance to the nearest registered start in the same recording.
    pub median_distance_samples: f64,
    /// The same, in seconds.
    pub median_distance_s: f64,
    /// Quartiles (first, median, third) of the distance from a window's
    /// nearest row to the nearest evaluated segment of its recording, in
    /// seconds ([`super::segment_distance`]: what `at least G s from
    /// segments` bounds; 0 for a window that shares a row with one).
    pub segment_distance_quartiles_s: [f64; 3],
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
    /// Which evaluation conditions each arm's fit set covers.
    pub coverage: FitCoverage,
}

/// Condition coverage: for each evaluation recording and each arm, how
/// many other recordings of its condition the arm's fit windows come from.
/// A recording the reference arm holds none of is a condition the
/// reference arm never saw: a contrast on it mixes condition novelty with
/// recording leakage.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FitCoverage {
    /// What a condition is: `trajectory`, or `trajectory x speed` when the
    /// recording factor declares `conditions trajectory, speed`.
    pub condition: String,
    /// One row per evaluation recording, in evaluation order.
    pub recordings: Vec<RecordingCoverage>,
}

/// One evaluation recording's coverage.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RecordingCoverage {
    /// The recording.
    pub recording: String,
    /// Its condition (`circle` or `circle / fast`).
    pub condition: String,
    /// Per arm: the other recordings of its condition that the arm's fit
    /// windows come from.
    pub fit_recordings: BTreeMap<String, usize>,
}

impl FitCoverage {
    /// The evaluation recordings of whose condition `arm` fits on no other
    /// recording.
    pub fn uncovered(&self, arm: &str) -> Vec<&RecordingCoverage> {
        self.recordings.iter().filter(|r| r.fit_recordings.get(arm) == Some(&0)).collect()
    }
}

/// The condition coverage of every arm of `split`, conditions by
/// `by_speed` (trajectory x speed) or trajectory alone.
fn condition_coverage(split: &Split, by_speed: bool) -> FitCoverage {
    let condition = |r: usize| {
        let i = &split.recordings[r];
        if by_speed {
            format!("{} / {}", i.trajectory, i.speed)
        } else {
            i.trajectory.clone()
        }
    };
    // Per arm: the recordings its fit windows come from, by condition.
    let pools: Vec<(String, BTreeMap<String, std::collections::BTreeSet<usize>>)> = split
        .fits
        .iter()
        .map(|(arm, windows)| {
            let mut by: BTreeMap<String, std::collections::BTreeSet<usize>> = BTreeMap::new();
            for w in windows {
                by.entry(condition(w.recording)).or_default().insert(w.recording);
            }
            (arm.clone(), by)
        })
        .collect();
    let recordings = split
        .evaluation
        .iter()
        .map(|&r| {
            let c = condition(r);
            let fit_recordings = pools
                .iter()
                .map(|(arm, by)| {
                    (arm.clone(), by.get(&c).map(|set| set.iter().filter(|&&x| x != r).count()).unwrap_or(0))
                })
                .collect();
            RecordingCoverage { recording: split.recordings[r].name.clone(), condition: c, fit_recordings }
        })
        .collect();
    FitCoverage { condition: if by_speed { "trajectory x speed" } else { "trajectory" }.to_string(), recordings }
}

/// The first quartile, median and third quartile of `v` (R's type 7:
/// linear interpolation between order statistics), NaN when empty.
fn quartiles(mut v: Vec<f64>) -> [f64; 3] {
    if v.is_empty() {
        return [f64::NAN; 3];
    }
    v.sort_by(f64::total_cmp);
    let at = |p: f64| {
        let h = (v.len() - 1) as f64 * p;
        let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
        v[lo] + (h - h.floor()) * (v[hi] - v[lo])
    };
    [at(0.25), at(0.5), at(0.75)]
}

pub use crossaudit_stats::median;

/// Summarises the treatment of every arm of `split`; condition coverage by
/// trajectory x speed when `by_speed` (the design's `conditions` name the
/// speed), by trajectory otherwise.
pub fn treatment_audit(split: &Split, by_speed: bool) -> TreatmentAudit {
    let starts_by_rec = super::build::starts_by_recording(&split.starts);
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
            let to_segment: Vec<f64> = windows
                .iter()
                .filter_map(|w| {
                    let starts = starts_by_rec.get(&w.recording).map_or(&[][..], Vec::as_slice);
                    super::segment_distance(w.t, starts, h)
                })
                .map(|n| n as f64 / split.rate_hz)
                .collect();
            ArmTreatment {
                arm: arm.clone(),
                contaminating_windows: windows.len(),
                inside_evaluated_segment: inside,
                share_inside: if windows.is_empty() { f64::NAN } else { inside as f64 / windows.len() as f64 },
                median_distance_samples: m,
                median_distance_s: m / split.rate_hz,
                segment_distance_quartiles_s: quartiles(to_segment),
            }
        })
        .collect();
    let mut counts: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    for &r in &split.evaluation {
        let i = &split.recordings[r];
        *counts.entry(i.trajectory.clone()).or_default().entry(i.speed.clone()).or_default() += 1;
    }
    TreatmentAudit {
        horizon_samples: h,
        arms,
        composition: Composition { counts, total: split.evaluation.len() },
        coverage: condition_coverage(split, by_speed),
    }
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
        for arm in self.coverage.recordings.first().map(|r| r.fit_recordings.keys()).into_iter().flatten() {
            let uncovered = self.coverage.uncovered(arm);
            if !uncovered.is_empty() {
                let names: Vec<String> =
                    uncovered.iter().map(|r| format!("{} ({})", r.recording, r.condition)).collect();
                let _ = writeln!(
                    s,
                    "condition coverage, arm {arm}: fits on no other recording of the {} of {} evaluation recording(s): {}",
                    self.coverage.condition,
                    uncovered.len(),
                    names.join(", ")
                );
            }
        }
        for a in &self.arms {
            let _ = writeln!(
                s,
                "treatment strength, arm {}: {} contaminating windows, {} ({:.1}%) inside an evaluated {}-sample segment, median distance to the nearest start {} samples ({:.2} s); distance to the nearest segment, quartiles {:.2} / {:.2} / {:.2} s",
                a.arm,
                a.contaminating_windows,
                a.inside_evaluated_segment,
                100.0 * a.share_inside,
                self.horizon_samples,
                a.median_distance_samples,
                a.median_distance_s,
                a.segment_distance_quartiles_s[0],
                a.segment_distance_quartiles_s[1],
                a.segment_distance_quartiles_s[2]
            );
        }
        s
    }
}
