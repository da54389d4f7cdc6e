//! Condition coverage and stratified evaluation draws, on simulated logs
//! through the real binary: an evaluation set that takes every recording of
//! one trajectory family leaves the reference arm without that family, and
//! the report says so beside its verdict with a covered-only row; a
//! `stratify` clause draws an evaluation set the reference arm covers, or
//! refuses, at its line, a request the data cannot meet.

use std::path::Path;

use crate::common::crossaudit;

/// The quickstart's simulated flights (40: six each of circle, figure
/// eight, helix, oval and star, four trefoil, three lissajous, one each of
/// three system-identification shapes), a small network, 3 seeds.
fn design(recording_factor: &str) -> String {
    format!(
        r#"study "coverage-check"
data simulated {{
  recordings 40 seed 7 strength 1.0 duration 20 s
  rate       100 Hz
  include    active(motor_motor_m1 > 1000) >= 200 samples
  duplicates group
}}
{recording_factor}
factor seed = 1..3
validation 600 windows from 2 recordings seed 143
arm disjoint      {{ fit 3000 windows seed 42 }}
arm contaminated  {{ from disjoint replace 25% with evaluation windows exclude starts seed 7 }}
model world = mlp(32, 32, 32) inputs world
train {{ adam lr 1e-3 batch 256 epochs 8 cosine patience 8 action_noise 0.02 }}
endpoint primary fa_position_rmse at 1.0 s cap 2 m model world
contrast contaminated - disjoint
estimate crossed_mom level 0.95 df seed - 1
decide confirmed when optimism >= 10% and upper < 0
"#
    )
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn an_evaluation_set_holding_a_whole_family_is_named_beside_the_verdict() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("coverage.design");
    let factor = r#"factor recording {
  evaluation recordings "S19_lissajous_slow_rep1", "S20_lissajous_medium_rep1", "S21_lissajous_fast_rep1",
    "S01_circle_slow_rep1", "S04_figure_eight_slow_rep1", "S07_helix_slow_rep1", "S10_oval_slow_rep1",
    "S13_star_slow_rep1"
  split_seed 42; starts 10 horizon 100 conditions trajectory
}"#;
    std::fs::write(&path, design(factor)).unwrap();
    let out = dir.path().join("run");
    let o = crossaudit(&["run", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "--workers", "2"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    // The audit: the three lissajous flights are all in evaluation, so the
    // disjoint arm fits on none; the contaminated arm on the other two.
    let treatment = json(&out.join("audit/treatment.json"));
    let rows = treatment["coverage"]["recordings"].as_array().unwrap();
    assert_eq!(treatment["coverage"]["condition"], "trajectory");
    for r in rows {
        let lissajous = r["condition"] == "lissajous";
        assert_eq!(r["fit_recordings"]["disjoint"] == 0, lissajous, "{r}");
        if lissajous {
            assert_eq!(r["fit_recordings"]["contaminated"], 2, "{r}");
        }
    }

    // The analysis: the same three, their share of d, and a covered-only row
    // over the other five recordings that differs from the full contrast.
    let results = json(&out.join("report/results.json"));
    let c = &results["coverage"];
    let names: Vec<&str> =
        c["uncovered"].as_array().unwrap().iter().map(|u| u["recording"].as_str().unwrap()).collect();
    assert_eq!(names, ["S19_lissajous_slow_rep1", "S20_lissajous_medium_rep1", "S21_lissajous_fast_rep1"]);
    assert_eq!(c["covered_only"]["recordings"], 5);
    let full = results["units"][0]["estimate"]["mean"].as_f64().unwrap();
    let covered = c["covered_only"]["estimate"]["mean"].as_f64().unwrap();
    assert!((full - covered).abs() > 1e-6, "{full} vs {covered}");
    // The share of d, recomputed from cells.csv.
    let cells = crossaudit::cells::read_cells(&out.join("cells.csv")).unwrap();
    let d = |lissajous_only: bool| -> f64 {
        let value = |arm: &str, rec: &str, seed: u64| {
            cells
                .iter()
                .find(|x| x.arm.as_str() == arm && x.recording.as_str() == rec && x.seed == seed && x.horizon_s == 1.0)
                .unwrap()
                .fa_position_rmse_m
        };
        let mut s = 0.0;
        for x in cells.iter().filter(|x| x.arm.as_str() == "disjoint" && x.horizon_s == 1.0) {
            if !lissajous_only || x.trajectory.as_str() == "lissajous" {
                s += value("contaminated", x.recording.as_str(), x.seed) - x.fa_position_rmse_m;
            }
        }
        s
    };
    let share = c["share_of_d"].as_f64().unwrap();
    assert!((share - d(true) / d(false)).abs() < 1e-12, "{share}");

    // The report: beside the verdict (before the first section), then its section.
    let md = std::fs::read_to_string(out.join("report/report.md")).unwrap();
    let head = md.split("\n## ").next().unwrap();
    assert!(head.contains("**The contrast mixes condition novelty with recording leakage**"), "{head}");
    assert!(
        head.contains("S20\\_lissajous\\_medium\\_rep1 (lissajous)")
            || head.contains("S20_lissajous_medium_rep1 (lissajous)"),
        "{head}"
    );
    assert!(head.contains("Over the 5 covered recordings alone"), "{head}");
    assert!(md.contains("## Condition coverage") && md.contains("| covered only | 5 | m |"), "{md}");
}

/// Every evaluated condition's disjoint coverage, from a prepared split.
fn uncovered_after_split(factor: &str) -> Result<Vec<String>, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.design");
    std::fs::write(&path, design(factor)).unwrap();
    let out = dir.path().join("split");
    let o = crossaudit(&["split", path.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    if !o.status.success() {
        return Err(String::from_utf8_lossy(&o.stderr).into_owned());
    }
    let t = json(&out.join("audit/treatment.json"));
    Ok(t["coverage"]["recordings"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["fit_recordings"]["disjoint"] == 0)
        .map(|r| r["recording"].as_str().unwrap().to_string())
        .collect())
}

#[test]
fn a_stratified_draw_keeps_every_evaluated_condition_for_fitting() {
    // 16 of 40 drawn by a plain shuffle leave the reference arm without some
    // drawn family for at least one of these split seeds (single flights of
    // a shape are always uncovered when drawn); the stratified draw never does.
    let mut plain_uncovered = 0;
    for seed in [1, 2, 3, 4] {
        let plain = format!(
            "factor recording {{ evaluation 16 split_seed {seed}; starts 10 horizon 100 conditions trajectory }}"
        );
        plain_uncovered += uncovered_after_split(&plain).unwrap().len();
        let stratified = format!(
            "factor recording {{ evaluation 16 split_seed {seed}; stratify trajectory keep 1; starts 10 horizon 100 conditions trajectory }}"
        );
        assert_eq!(uncovered_after_split(&stratified).unwrap(), Vec::<String>::new(), "split seed {seed}");
    }
    assert!(plain_uncovered > 0, "the plain draws happened to cover everything: the check shows nothing");
}

#[test]
fn an_impossible_stratified_draw_is_refused_at_its_line() {
    // Keeping one of each family for fitting leaves at most 5 + 5 + 5 + 5 +
    // 5 + 3 + 2 = 30 drawable (three shapes have a single flight).
    let factor =
        "factor recording {\n  evaluation 31 split_seed 1\n  stratify trajectory keep 1\n  starts 10 horizon 100\n}";
    let err = uncovered_after_split(factor).unwrap_err();
    assert!(err.contains("s.design:10:3"), "{err}");
    assert!(err.contains("cannot draw 31 evaluation recordings: only 30 of the 40"), "{err}");
    assert!(err.contains("linear_ramp (1)"), "{err}");
    // 30 can be drawn: the boundary holds.
    let factor = factor.replace("evaluation 31", "evaluation 30");
    assert_eq!(uncovered_after_split(&factor).unwrap(), Vec::<String>::new());
}

#[test]
fn stratify_is_refused_with_a_pinned_evaluation_set() {
    let text = design(
        r#"factor recording { evaluation recordings "S01_circle_slow_rep1", "S02_circle_medium_rep1"
  stratify trajectory; split_seed 1; starts 10 horizon 100 }"#,
    );
    let err = crossaudit::design::from_str("p.design", &text).unwrap_err().to_string();
    assert!(err.contains("stratify with a fixed evaluation set"), "{err}");
}
