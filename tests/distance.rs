//! Contamination at a declared distance from the evaluated segments
//! (`at least G s from segments`, `G1 s to G2 s from segments`, issue 59):
//! every contaminating window the split draws lies at that distance, each
//! distance recomputed here from the manifests the real CLI writes (the
//! windows and the registered starts, by recording name and row); a
//! distance the recordings cannot supply is refused at its clause.

use std::collections::BTreeMap;
use std::path::Path;

use crate::common::{assert_ok, assert_refused, root};

/// The small simulated design (100 Hz, rollouts of 100 samples from 10
/// starts in each of 4 evaluation recordings, 750 windows replaced), its
/// contaminated arm given `clause`.
fn design_with(dir: &Path, name: &str, clause: &str) -> std::path::PathBuf {
    let text = std::fs::read_to_string(root().join("tests/designs/sim_small.design")).unwrap();
    let from = "exclude starts seed 7";
    assert!(text.contains(from));
    let path = dir.join(name);
    std::fs::write(&path, text.replace(from, &format!("exclude starts {clause} seed 7"))).unwrap();
    path
}

fn split(design: &Path, out: &Path) -> std::process::Output {
    crate::common::bin()
        .args(["split", &design.display().to_string(), "--out", &out.display().to_string()])
        .env("NO_COLOR", "1")
        .output()
        .unwrap()
}

/// A manifest's (recording, row) pairs.
fn rows(path: &Path) -> Vec<(String, usize)> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("recording,sample_index"), "{}", path.display());
    lines
        .map(|l| {
            let (r, t) = l.rsplit_once(',').unwrap();
            (r.to_string(), t.parse().unwrap())
        })
        .collect()
}

/// Each contaminating window's distance in samples to the nearest evaluated
/// segment of its recording (rows s to s + 100 from each start s; a window
/// is its rows t and t + 1), from the manifests alone.
// The three cases written out (before, after, sharing a row), not as the
// library's saturating subtraction: an independent count.
#[allow(clippy::implicit_saturating_sub)]
fn distances(out: &Path) -> Vec<usize> {
    const HORIZON: usize = 100;
    let mut starts: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (r, s) in rows(&out.join("manifests/evaluation_starts.csv")) {
        starts.entry(r).or_default().push(s);
    }
    rows(&out.join("manifests/contaminating_contaminated.csv"))
        .into_iter()
        .map(|(r, t)| {
            let of = starts.get(&r).unwrap_or_else(|| panic!("{r}: a contaminating window outside the evaluation set"));
            of.iter()
                .map(|&s| {
                    if t + 1 < s {
                        s - (t + 1)
                    } else if t > s + HORIZON {
                        t - (s + HORIZON)
                    } else {
                        0
                    }
                })
                .min()
                .unwrap()
        })
        .collect()
}

#[test]
fn contaminating_windows_lie_at_the_declared_distance_from_every_evaluated_segment() {
    let dir = tempfile::tempdir().unwrap();
    // Without the clause, the draw reaches into the segments (the
    // treatment audit's "inside an evaluated segment").
    let plain = dir.path().join("plain");
    assert_ok(&split(&root().join("tests/designs/sim_small.design"), &plain));
    let near = distances(&plain);
    assert_eq!(near.len(), 750);
    assert!(near.iter().filter(|&&d| d == 0).count() > 100, "the plain draw has windows inside segments");
    assert!(near.iter().any(|&d| d > 0 && d < 200), "and windows within 2 s of one");

    // `at least 2 s`: 200 samples at 100 Hz, every window.
    let gap = design_with(dir.path(), "gap.design", "at least 2 s from segments");
    let out = dir.path().join("gap");
    let o = split(&gap, &out);
    assert_ok(&o);
    let d = distances(&out);
    assert_eq!(d.len(), 750, "the arm still replaces 25% of 3000 windows");
    assert!(d.iter().all(|&d| d >= 200), "closest: {:?}", d.iter().min());
    // The treatment audit's quartiles of that distance are these windows'
    // (R's quantile type 7 of the recomputed distances, in seconds).
    let audit: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("audit/treatment.json")).unwrap()).unwrap();
    let q = &audit["arms"][0]["segment_distance_quartiles_s"];
    let mut s: Vec<f64> = d.iter().map(|&d| d as f64 / 100.0).collect();
    s.sort_by(f64::total_cmp);
    for (k, p) in [0.25, 0.5, 0.75].into_iter().enumerate() {
        let h = (s.len() - 1) as f64 * p;
        let want = s[h.floor() as usize] + (h - h.floor()) * (s[h.ceil() as usize] - s[h.floor() as usize]);
        crate::common::assert_rel(q[k].as_f64().unwrap(), want, 1e-12, "a quartile of the distance to a segment");
    }
    assert!(q[0].as_f64().unwrap() >= 2.0);

    // A band: at least 0.5 s, less than 2 s (50 to 199 samples).
    let band = design_with(dir.path(), "band.design", "0.5 s to 2 s from segments");
    let out = dir.path().join("band");
    assert_ok(&split(&band, &out));
    let d = distances(&out);
    assert_eq!(d.len(), 750);
    assert!(d.iter().all(|&d| (50..200).contains(&d)), "range: {:?} to {:?}", d.iter().min(), d.iter().max());

    // `check` prints the clause with the arm.
    let o = crate::common::bin().args(["check", &gap.display().to_string()]).output().unwrap();
    assert_ok(&o);
    assert!(
        crate::common::stdout(&o).contains("registered starts excluded, at least 2 s from segments (seed 7)"),
        "{}",
        crate::common::stdout(&o)
    );
}

/// `after segments`: every contaminating window lies after the last
/// evaluated segment of its recording, recomputed from the manifests; with
/// the starts in the first 40% of each recording the rest supplies them;
/// with starts anywhere, too few are left and the split is refused at the
/// clause.
#[test]
fn after_segments_draws_only_from_the_part_past_the_last_segment() {
    const HORIZON: usize = 100;
    let dir = tempfile::tempdir().unwrap();
    let path = design_with(dir.path(), "after.design", "after segments");
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(&path, text.replace("starts 10 horizon 100", "starts 10 within first 40% horizon 100")).unwrap();
    let out = dir.path().join("after");
    assert_ok(&split(&path, &out));
    let mut last: BTreeMap<String, usize> = BTreeMap::new();
    for (r, s) in rows(&out.join("manifests/evaluation_starts.csv")) {
        let e = last.entry(r).or_default();
        *e = (*e).max(s);
    }
    let windows = rows(&out.join("manifests/contaminating_contaminated.csv"));
    assert_eq!(windows.len(), 750);
    for (r, t) in &windows {
        assert!(*t > last[r] + HORIZON, "{r} row {t}: not after the last segment, which ends at {}", last[r] + HORIZON);
    }
    assert!(
        windows.iter().map(|(r, _)| r).collect::<std::collections::BTreeSet<_>>().len() == 4,
        "from every recording"
    );
    let o = crate::common::bin().args(["check", &path.display().to_string()]).output().unwrap();
    assert_ok(&o);
    assert!(crate::common::stdout(&o).contains("registered starts excluded, after segments (seed 7)"));

    // Starts anywhere in the 15 s recordings leave too little after the
    // last segment for 60% of the 3,000 fit windows.
    let everywhere = design_with(dir.path(), "everywhere.design", "after segments");
    let text = std::fs::read_to_string(&everywhere).unwrap();
    std::fs::write(&everywhere, text.replace("replace 25%", "replace 60%")).unwrap();
    let o = split(&everywhere, &dir.path().join("everywhere"));
    assert_refused(&o, "contaminating windows after segments");
}

#[test]
fn a_distance_the_recordings_cannot_supply_is_refused_at_its_clause() {
    let dir = tempfile::tempdir().unwrap();
    // 15 s recordings: no window lies 12 s from every segment.
    let clause = "at least 12 s from segments";
    let path = design_with(dir.path(), "far.design", clause);
    let text = std::fs::read_to_string(&path).unwrap();
    let at = text.find(clause).unwrap();
    let line = text[..at].matches('\n').count() + 1;
    let column = at - text[..at].rfind('\n').map_or(0, |k| k + 1) + 1;
    let out = dir.path().join("out");
    let o = split(&path, &out);
    assert_refused(&o, &format!("far.design:{line}:{column}: arm contaminated: 750 contaminating windows {clause}"));
    assert!(crate::common::stderr(&o).contains("hold 0 such windows"), "{}", crate::common::stderr(&o));

    // A band that ends where it starts, or a negative distance, is a
    // design error at `check`.
    for (clause, needle) in [("2 s to 1 s from segments", "not beyond its start"), ("at least -1 s from segments", "")]
    {
        let path = design_with(dir.path(), "bad.design", clause);
        let o = crate::common::bin().args(["check", &path.display().to_string()]).output().unwrap();
        assert_eq!(o.status.code(), Some(1), "{clause}: {}", crate::common::stderr(&o));
        assert!(crate::common::stderr(&o).contains(needle), "{clause}: {}", crate::common::stderr(&o));
    }
}

/// The windows a derived arm kept of its base: its fit manifest less its
/// contaminating windows (the base holds no evaluation window).
fn kept(out: &Path, arm: &str) -> Vec<(String, usize)> {
    let incoming: std::collections::BTreeSet<(String, usize)> =
        rows(&out.join(format!("manifests/contaminating_{arm}.csv"))).into_iter().collect();
    let mut fit: Vec<(String, usize)> =
        rows(&out.join(format!("manifests/fit_{arm}.csv"))).into_iter().filter(|w| !incoming.contains(w)).collect();
    fit.sort();
    fit
}

/// A distance-dose family (`at least 0 s, 0.5 s, 2 s from segments`): one
/// arm per distance, each window at its own arm's distance, every arm
/// replacing the same positions of the reference arm, and the draws
/// coupled: a window the nearest arm drew that lies 2 s away is one the
/// 2 s arm drew too.
#[test]
fn a_distance_dose_family_shares_its_positions_and_couples_its_draws() {
    let dir = tempfile::tempdir().unwrap();
    let path = design_with(dir.path(), "family.design", "at least 0 s, 0.5 s, 2 s from segments");
    let text = std::fs::read_to_string(&path).unwrap();
    let rule = "decide confirmed when optimism >= 10% and upper < 0";
    assert!(text.contains(rule));
    std::fs::write(&path, text.replace(rule, "decide fades on slope when lower > 0")).unwrap();
    let out = dir.path().join("out");
    assert_ok(&split(&path, &out));
    let incoming =
        |arm: &str| -> Vec<(String, usize)> { rows(&out.join(format!("manifests/contaminating_{arm}.csv"))) };
    let arms = [("contaminated_0s", 0), ("contaminated_0p5s", 50), ("contaminated_2s", 200)];
    // Each arm's every window at its distance: the scan is distances()'s,
    // on the arm's own manifest.
    for (arm, least) in arms {
        let one = dir.path().join(format!("one-{arm}"));
        std::fs::create_dir_all(one.join("manifests")).unwrap();
        let starts = "manifests/evaluation_starts.csv";
        std::fs::copy(out.join(starts), one.join(starts)).unwrap();
        std::fs::copy(
            out.join(format!("manifests/contaminating_{arm}.csv")),
            one.join("manifests/contaminating_contaminated.csv"),
        )
        .unwrap();
        let d = distances(&one);
        assert_eq!(d.len(), 750, "{arm}: 25% of 3000");
        assert!(d.iter().all(|&d| d >= least), "{arm}: closest {:?}, declared {least} samples", d.iter().min());
    }
    // The same positions of the reference replaced in every arm.
    let base = kept(&out, "contaminated_0s");
    assert_eq!(base.len(), 2250);
    for (arm, _) in &arms[1..] {
        assert!(kept(&out, arm) == base, "{arm} replaced other positions than contaminated_0s");
    }
    // Coupled: the nearest arm's windows at 2 s or more are the 2 s arm's.
    let near: Vec<(String, usize)> = incoming("contaminated_0s");
    let far: std::collections::BTreeSet<(String, usize)> = incoming("contaminated_2s").into_iter().collect();
    let one = dir.path().join("one-contaminated_0s");
    let far_enough: Vec<&(String, usize)> =
        near.iter().zip(distances(&one)).filter(|(_, d)| *d >= 200).map(|(w, _)| w).collect();
    assert!(!far_enough.is_empty(), "the unrestricted draw reaches 2 s somewhere");
    assert!(
        far_enough.iter().all(|w| far.contains(*w)),
        "a window the 0 s arm drew at >= 2 s is missing from the 2 s arm"
    );

    // `check` names the family's distances; several shares at several
    // distances are refused at the second distance.
    let o = crate::common::bin().args(["check", &path.display().to_string()]).output().unwrap();
    assert_ok(&o);
    let said = crate::common::stdout(&o);
    assert!(
        said.contains("distances of contaminated from the evaluated segments, 25% replaced in each (one draw order): at least 0 s (contaminated_0s), at least 0.5 s (contaminated_0p5s), at least 2 s (contaminated_2s)"),
        "{said}"
    );
    let two = std::fs::read_to_string(&path).unwrap().replace("replace 25% with", "replace 10%, 25% with");
    let bad = dir.path().join("two.design");
    std::fs::write(&bad, two).unwrap();
    let o = crate::common::bin().args(["check", &bad.display().to_string()]).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(crate::common::stderr(&o).contains("doses on two axes"), "{}", crate::common::stderr(&o));
}

/// A simulated distance-dose study with leakage built in only within 1 s
/// of the evaluated segments: per cell, d at distance g is mu(g) + a_r +
/// b_s + e (recording, seed and residual effects drawn afresh per arm),
/// mu(g) = -0.04 m below 1 s and 0 from 1 s on. Over 300 simulated
/// studies, the estimate beyond 1 s is zero on average, each distance's
/// interval covers its truth and the trend's interval covers the true
/// slope at about the nominal 95% (the closed form: the least-squares slope
/// of mu over the distances), and step-down testing from the nearest
/// distance stops at the last leaking one, 0.5 s.
#[test]
fn leakage_within_a_known_distance_fades_beyond_it_and_the_trend_covers_the_truth() {
    use crossaudit::cells::Cell;
    use rand::{Rng, SeedableRng};
    let design = r#"study "distance-sim"
data nanobench { path "recordings" }
factor recording { evaluation 8 split_seed 1; starts 5 horizon 100 conditions trajectory }
factor seed = 1..6
validation 100 windows from 2 recordings seed 2
arm disjoint     { fit 400 windows }
arm contaminated { from disjoint replace 25% with evaluation windows exclude starts
                   at least 0 s, 0.5 s, 1 s, 2 s, 5 s from segments seed 3 }
model world = mlp(32, 32, 32) inputs world
train { adam lr 1e-3 batch 64 epochs 5 cosine patience 2 action_noise 0.02 }
endpoint primary fa_position_rmse at 1.0 s cap 2 m model world
contrast contaminated - disjoint
estimate crossed_mom level 0.95 df seed - 1
decide fades on slope when lower > 0
"#;
    let d = crossaudit::design::from_str("distance-sim.design", design).unwrap();
    let plan = crossaudit::compile(&d);
    let gaps = [0.0, 0.5, 1.0, 2.0, 5.0];
    let truth = |g: f64| if g < 1.0 { -0.04 } else { 0.0 };
    // The true slope: sum (g - mean g)(mu(g) - mean mu) / sum (g - mean g)^2.
    let mg = gaps.iter().sum::<f64>() / 5.0;
    let mm = gaps.iter().map(|&g| truth(g)).sum::<f64>() / 5.0;
    let true_slope = gaps.iter().map(|&g| (g - mg) * (truth(g) - mm)).sum::<f64>()
        / gaps.iter().map(|&g| (g - mg) * (g - mg)).sum::<f64>();
    let names: Vec<String> = gaps.iter().map(|g| crossaudit::design::distance_arm_name("contaminated", *g)).collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(59);
    // Box-Muller: one standard normal draw.
    let mut normal = move || {
        let (u, v): (f64, f64) = (rng.gen::<f64>().max(1e-300), rng.gen());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    };
    let template = crate::common::minimal_cells(&crate::common::minimal_design())[0].clone();
    let reps = 300;
    let (mut covered, mut slope_covered, mut stops_at_leak) = (vec![0usize; 5], 0usize, 0usize);
    let mut beyond_sum = 0.0;
    for _ in 0..reps {
        let mut cells = Vec::new();
        let mut push = |arm: &str, r: usize, s: u64, v: f64| {
            cells.push(Cell {
                arm: arm.into(),
                seed: s,
                recording: format!("R{r}_circle_fast_rep1").as_str().into(),
                trajectory: "circle".into(),
                speed: "fast".into(),
                horizon_s: 1.0,
                fa_position_rmse_m: v,
                conditional_position_rmse_m: Some(v),
                ..template.clone()
            });
        };
        let base: Vec<Vec<f64>> = (0..8)
            .map(|r| (1..=6).map(|s| 0.5 + 0.02 * r as f64 + 0.01 * s as f64 + 0.01 * normal()).collect())
            .collect();
        for (r, row) in base.iter().enumerate() {
            for (s, &v) in row.iter().enumerate() {
                push("disjoint", r, s as u64 + 1, v);
            }
        }
        for (k, &g) in gaps.iter().enumerate() {
            let a: Vec<f64> = (0..8).map(|_| 0.005 * normal()).collect();
            let b: Vec<f64> = (0..6).map(|_| 0.01 * normal()).collect();
            for (r, row) in base.iter().enumerate() {
                for (s, &v) in row.iter().enumerate() {
                    push(&names[k], r, s as u64 + 1, v + truth(g) + a[r] + b[s] + 0.01 * normal());
                }
            }
        }
        let a = crossaudit::analysis::family::analyze_family(&plan, &cells, Default::default()).unwrap();
        let sp = &a.splits[0];
        for (k, dose) in sp.doses.iter().enumerate() {
            assert_eq!(dose.distance_s, Some(gaps[k]));
            let e = &dose.estimate;
            covered[k] += usize::from(e.lower <= truth(gaps[k]) && truth(gaps[k]) <= e.upper);
            if gaps[k] >= 1.0 {
                beyond_sum += e.mean;
            }
        }
        let t = sp.trend.as_ref().unwrap();
        slope_covered += usize::from(t.slope.lower <= true_slope && true_slope <= t.slope.upper);
        stops_at_leak += usize::from(t.step_down_dose == Some(0.5));
    }
    // 300 studies: a 95% coverage has binomial SD 1.26 points, so 90% to
    // 99% is about four SD either side.
    let rate = |n: usize| n as f64 / reps as f64;
    for (k, &c) in covered.iter().enumerate() {
        assert!((0.90..=0.99).contains(&rate(c)), "distance {} s: coverage {}", gaps[k], rate(c));
    }
    assert!((0.90..=0.99).contains(&rate(slope_covered)), "trend coverage {}", rate(slope_covered));
    // Beyond 1 s the mean estimate is zero: its SD over 900 estimates is
    // at most 0.006 / 30 = 2e-4 m.
    assert!((beyond_sum / (3 * reps) as f64).abs() < 6e-4, "mean beyond 1 s: {}", beyond_sum / (3 * reps) as f64);
    assert!(rate(stops_at_leak) >= 0.85, "step-down stopped at 0.5 s in {}", rate(stops_at_leak));
    assert!(true_slope > 0.0, "the leak fades with distance: slope {true_slope}");
}

/// A distance-dose family with per-seed draws runs end to end through the
/// real CLI: one draw per seed, the family analysis over the seeds' draws,
/// the estimand note and the recordings each arm drew from beside the
/// verdict, and the treatment table's values the medians over the draws'
/// own audits (recomputed here from each draw's audit/treatment.json).
#[test]
fn a_distance_family_with_per_seed_draws_reports_what_it_measured() {
    let dir = tempfile::tempdir().unwrap();
    let path = design_with(dir.path(), "seeds.design", "at least 0 s, 0.5 s, 1.5 s from segments");
    let text = std::fs::read_to_string(&path).unwrap();
    let text = text
        .replace("decide confirmed when optimism >= 10% and upper < 0", "decide fades on slope when lower > 0")
        .replace("factor seed = 1..2", "factor seed = 1..3\ndraws per seed")
        .replace("epochs 15 cosine patience 15", "epochs 2 cosine patience 2");
    std::fs::write(&path, text).unwrap();
    let out = dir.path().join("out");
    let o = crate::common::bin()
        .args(["run", &path.display().to_string(), "--out", &out.display().to_string(), "--workers", "2"])
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    assert_ok(&o);
    let report = std::fs::read_to_string(out.join("report/report.md")).unwrap();
    let verdict = report.find("**decision:").unwrap();
    let measures = report.find("What this measures: each arm replaces the same 25%").expect("the estimand note");
    assert!(measures > verdict && measures < report.find("## Per split and dose").unwrap(), "beside the verdict");
    assert!(report.contains("contaminated_0s from 4 of 4"), "{report}");
    // results.json carries the note as the family's guard of kind distance.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report/results.json")).unwrap()).unwrap();
    let guard = json["guards"].as_array().unwrap().iter().find(|g| g["kind"] == "distance").expect("the guard");
    assert!(report[measures..].starts_with(guard["text"].as_str().unwrap()), "{guard}");
    // Each treatment value is the median over the three draws' own.
    let draws: Vec<serde_json::Value> = (1..=3)
        .map(|k| {
            let t = std::fs::read_to_string(out.join(format!("draw-{k}/audit/treatment.json"))).unwrap();
            serde_json::from_str(&t).unwrap()
        })
        .collect();
    for (i, arm) in ["contaminated_0s", "contaminated_0p5s", "contaminated_1p5s"].iter().enumerate() {
        let mut inside: Vec<u64> =
            draws.iter().map(|d| d["arms"][i]["inside_evaluated_segment"].as_u64().unwrap()).collect();
        let mut q2: Vec<f64> =
            draws.iter().map(|d| d["arms"][i]["segment_distance_quartiles_s"][1].as_f64().unwrap()).collect();
        assert_eq!(draws[0]["arms"][i]["arm"], *arm);
        inside.sort();
        q2.sort_by(f64::total_cmp);
        let row = report.lines().find(|l| l.starts_with(&format!("| {arm} | 750 |"))).expect("the arm's row");
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        assert_eq!(cells[3], inside[1].to_string(), "{row}");
        assert!(cells[7].contains(&format!(" / {:.2} / ", q2[1])), "{row}: median of {q2:?}");
    }
    assert!(report.contains("the median over the 3 draws"), "{report}");
}

/// A distance that is not a whole number of samples (0.005 s at the
/// design's 100 Hz: half a sample) is refused by `check` at its clause,
/// with the multiple to write; it would otherwise act as one sample.
#[test]
fn a_distance_between_samples_is_refused_by_check() {
    let dir = tempfile::tempdir().unwrap();
    for (clause, bad) in [
        ("at least 0.005 s from segments", "0.005 s is 0.5 samples at 100 Hz"),
        ("0.5 s to 1.234 s from segments", "1.234 s is 123.4"),
    ] {
        let path = design_with(dir.path(), "half.design", clause);
        let o = crate::common::crossaudit(&["check", path.to_str().unwrap()]);
        crate::common::assert_refused(&o, "distance not a whole number of samples");
        let e = crate::common::stderr(&o);
        assert!(e.contains(bad) && e.contains("write a multiple of 0.01 s"), "{e}");
    }
    let ok = design_with(dir.path(), "whole.design", "at least 0.01 s from segments");
    crate::common::assert_ok(&crate::common::crossaudit(&["check", ok.to_str().unwrap()]));
}
