//! Multi-split and dose-response designs: the language, nested
//! contamination, the per-cell columns, the family analysis (snapshots of
//! the committed runs, lme4's pooled fit), the known-truth simulations, and
//! the real CLI end to end.

use std::fmt::Write as _;

use crossaudit::analysis::family::{analyze_family, FamilyAnalysis};
use crossaudit::analysis::StudyAnalysis;
use crossaudit::cells::{read_cells, read_cells_from, write_cells};
use crossaudit::design::{self, ArmKind};
use crossaudit::run::{run, Quiet, RunOptions};

use crate::common::bin;
use crate::common::{assert_rel, root, shared_logs};

/// The diagnostics a design text gets, joined.
fn errors(text: &str) -> String {
    match design::from_str("t.design", text) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

fn tiny_family() -> String {
    std::fs::read_to_string(root().join("tests/designs/tiny_family.design")).unwrap()
}

#[test]
fn dose_and_split_declarations_compile_to_arms_and_jobs() {
    let d = design::from_str("t", &tiny_family()).unwrap();
    assert_eq!(d.splits, vec![42, 43]);
    let names: Vec<&str> = d.arms.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["disjoint", "contaminated_5pct", "contaminated_25pct", "contaminated_50pct"]);
    assert!(d.arms[1..]
        .iter()
        .all(|a| matches!(&a.kind, ArmKind::Derived { family: Some(f), seed: 7, .. } if f == "contaminated")));
    let plan = crossaudit::compile(&d);
    // 1 model x 4 arms x 2 seeds x 2 splits.
    assert_eq!(plan.jobs.len(), 16);
    assert_eq!(plan.doses.iter().map(|d| d.percent).collect::<Vec<_>>(), [5.0, 25.0, 50.0]);
    // Units x (reference + doses) x I x J x splits.
    assert_eq!(plan.required_rows, 4 * 4 * 2 * 2);
    let one = plan.for_split(43);
    assert!(one.jobs.iter().all(|j| j.split.is_none()) && one.jobs.len() == 8);
    // Split 43 shifts every declared seed by 43 - 42 = 1; split 42 is the design itself.
    let s43 = d.for_split(43);
    assert_eq!((s43.recording.split_seed, s43.validation.seed), (43, 144));
    assert!(matches!(s43.arms[0].kind, ArmKind::Fit { seed: 43, .. }));
    assert!(matches!(s43.arms[2].kind, ArmKind::Derived { seed: 8, .. }));
    let s42 = d.for_split(42);
    assert_eq!(s42.arms, d.arms);
    assert_eq!(s42.validation, d.validation);
}

#[test]
fn bad_dose_and_split_declarations_are_refused_where_they_are_written() {
    let base = tiny_family();
    // A dose-response design must say which estimate the rule is on.
    let e = errors(&base.replace("decide grows on slope when", "decide grows when"));
    assert!(e.contains("decision target missing") && e.contains("on slope"), "{e}");
    let e = errors(&base.replace("decide grows on slope when", "decide grows on pooled when"));
    assert!(e.contains("ambiguous decision"), "{e}");
    // `on pooled` without splits, `on slope` without doses.
    let single = base.replace("factor split = 42..43\n", "").replace("5%, 25%, 50%", "25%");
    let e = errors(&single.replace("on slope", "on pooled"));
    assert!(e.contains("no pooled estimate") && e.contains("t.design:"), "{e}");
    let e = errors(&single);
    assert!(e.contains("no slope to decide on"), "{e}");
    // A repeated dose, a dose outside (0, 100], a dose replacing part of a window.
    let e = errors(&base.replace("5%, 25%, 50%", "5%, 25%, 5%"));
    assert!(e.contains("duplicate dose") && e.contains("5% is listed twice"), "{e}");
    let e = errors(&base.replace("5%, 25%, 50%", "5%, 150%"));
    assert!(e.contains("percentage out of range"), "{e}");
    let e = errors(&base.replace("5%, 25%, 50%", "5%, 0.01%"));
    assert!(e.contains("fraction of windows is not whole"), "{e}");
    // A dose arm whose name another arm already has.
    let e = errors(&base.replace(
        "arm contaminated {",
        "arm contaminated_5pct { from disjoint replace 10% with evaluation windows seed 3 }\narm contaminated {",
    ));
    assert!(e.contains("has the name of another arm"), "{e}");
    // One split value, a split that shifts a seed below zero, a split of pinned recordings.
    let e = errors(&base.replace("factor split = 42..43", "factor split = 42"));
    assert!(e.contains("split replication needs at least two splits"), "{e}");
    let e = errors(&base.replace("factor split = 42..43", "factor split = 0..1"));
    assert!(e.contains("split shifts a seed out of range") && e.contains("split 0 shifts"), "{e}");
    let pinned = base.replace(
        "evaluation 4 split_seed 42",
        "evaluation recordings \"B5_helix_rep1\", \"B2_circle_medium_rep1\" split_seed 42",
    );
    let e = errors(&pinned);
    assert!(e.contains("split factor on pinned recordings"), "{e}");
}

#[test]
#[ignore = "needs ../shared/nanobench"]
fn doses_are_nested_and_a_single_dose_draw_is_unchanged() {
    let _logs = crate::needs_shared_logs!();
    shared_logs();
    let out = tempfile::tempdir().unwrap();
    let file = design::load(&root().join("tests/designs/tiny_family.design")).unwrap();
    let split_file = design::DesignFile { design: file.design.for_split(42), ..file.clone() };
    let plan = crossaudit::compile(&split_file.design);
    let p = crossaudit::split::prepare(&split_file, &plan, &shared_logs(), out.path()).unwrap();
    let incoming = |arm: &str| -> Vec<crossaudit::split::Window> {
        p.split.contaminating.iter().find(|(n, _)| n == arm).unwrap().1.clone()
    };
    let (d5, d25, d50) =
        (incoming("contaminated_5pct"), incoming("contaminated_25pct"), incoming("contaminated_50pct"));
    assert_eq!((d5.len(), d25.len(), d50.len()), (100, 500, 1000));
    assert!(d5.iter().all(|w| d25.contains(w)) && d25.iter().all(|w| d50.contains(w)));
    // The replaced positions are nested too: what a dose keeps of the
    // disjoint fit set, every smaller dose keeps.
    let fit = |arm: &str| p.split.fit(arm).unwrap().to_vec();
    let disjoint = fit("disjoint");
    let kept = |arm: &str| -> Vec<crossaudit::split::Window> {
        fit(arm).into_iter().filter(|w| disjoint.binary_search(w).is_ok()).collect()
    };
    assert!(kept("contaminated_50pct").iter().all(|w| kept("contaminated_25pct").contains(w)));
    assert!(kept("contaminated_25pct").iter().all(|w| kept("contaminated_5pct").contains(w)));
    // The same arm declared alone (one dose) draws exactly what it drew before doses existed:
    // the committed manifests of the tiny design are unchanged (tests/split.rs locks them), and
    // here the one-dose 25% arm equals the family's 25% dose.
    let alone = tiny_family()
        .replace("5%, 25%, 50%", "25%")
        .replace("factor split = 42..43\n", "")
        .replace("decide grows on slope when upper < 0", "decide confirmed when upper < 0");
    let alone_file = design::DesignFile { design: design::from_str("t", &alone).unwrap(), ..file.clone() };
    let plan = crossaudit::compile(&alone_file.design);
    let q = crossaudit::split::prepare(&alone_file, &plan, &shared_logs(), out.path()).unwrap();
    assert_eq!(q.split.fit("contaminated").unwrap(), p.split.fit("contaminated_25pct").unwrap());
    assert_eq!(q.split.contaminating[0].1, d25);
}

#[test]
fn split_and_dose_columns_are_written_only_when_present_and_read_back() {
    let d = crate::common::minimal_design();
    let cells = crate::common::minimal_cells(&d);
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("plain.csv");
    write_cells(&plain, &cells).unwrap();
    let header = std::fs::read_to_string(&plain).unwrap().lines().next().unwrap().to_string();
    assert_eq!(header, crossaudit::cells::HEADER.join(","));
    let tagged: Vec<_> = cells
        .iter()
        .map(|c| crossaudit::cells::Cell {
            split: Some(7),
            dose: Some(if c.arm == "disjoint" { 0.0 } else { 2.5 }),
            ..c.clone()
        })
        .collect();
    let path = dir.path().join("tagged.csv");
    write_cells(&path, &tagged).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.starts_with("split,model,arm,dose,seed,recording,"), "{}", &text[..80]);
    let back = read_cells(&path).unwrap();
    assert_eq!(back.len(), tagged.len());
    assert!(back
        .iter()
        .zip(&tagged)
        .all(|(a, b)| a.split == b.split && a.dose == b.dose && a.fa_position_rmse_m == b.fa_position_rmse_m));
    // Bad values name the line and the field.
    let bad = text.replacen("\n7,", "\nseven,", 1);
    let e = read_cells_from("x.csv", bad.as_bytes()).unwrap_err().to_string();
    assert!(e.contains("line 2, field `split`"), "{e}");
    let bad = text.replacen(",2.5,", ",250,", 1);
    let e = read_cells_from("x.csv", bad.as_bytes()).unwrap_err().to_string();
    assert!(e.contains("field `dose`") && e.contains("exceeds 100"), "{e}");
    // A split column where the design has no split factor is refused, not pooled silently.
    let plan = crossaudit::compile(&d);
    let e = crossaudit::analysis::analyze(&plan, &back, Default::default()).unwrap_err().to_string();
    assert!(e.contains("`split` column, but the design has no split factor"), "{e}");
}

#[test]
fn a_family_refuses_a_split_or_dose_column_its_design_lacks() {
    // A trust review (round 6): a multi-split design analysed cells with a
    // `dose` column (50% where its arm replaces 25%) and ignored it; a dose
    // design given a `split` column said "needs at least 2 rows". Both are
    // refused at the first row, naming the column.
    let cells = |run: &str| read_cells(&root().join("results").join(run).join("cells.csv")).unwrap();
    let dosed: Vec<_> = cells("multi_split")
        .into_iter()
        .map(|c| crossaudit::cells::Cell { dose: Some(if c.arm == "disjoint" { 0.0 } else { 50.0 }), ..c })
        .collect();
    let plan = crossaudit::compile(&design::load(&root().join("designs/nanobench_multi_split.design")).unwrap().design);
    let e = analyze_family(&plan, &dosed, Default::default()).unwrap_err().to_string();
    assert!(e.contains("line 2: the file has a `dose` column, but the design has no dose-response contrast"), "{e}");
    let split: Vec<_> =
        cells("dose_response").into_iter().map(|c| crossaudit::cells::Cell { split: Some(42), ..c }).collect();
    let plan =
        crossaudit::compile(&design::load(&root().join("designs/nanobench_dose_response.design")).unwrap().design);
    let e = analyze_family(&plan, &split, Default::default()).unwrap_err().to_string();
    assert!(e.contains("line 2: the file has a `split` column, but the design has no split factor"), "{e}");
}

/// The committed run's family analysis, from its design and cells.csv.
fn committed(design: &str, run: &str) -> FamilyAnalysis {
    crossaudit::analyze_family_files(
        &root().join("designs").join(design),
        &root().join("results").join(run).join("cells.csv"),
        Default::default(),
    )
    .unwrap()
}

/// A family analysis as text, build and paths left out.
fn summary(a: &FamilyAnalysis) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{}", crossaudit::report::decision_summary(&a.decision));
    for sp in &a.splits {
        for d in &sp.doses {
            let e = &d.estimate;
            let _ = writeln!(
                s,
                "split {:?} dose {} ({}): d {:.6} se {:.6} df {:.2} [{:.6}, {:.6}] optimism {:.3}%",
                sp.split, d.percent, d.arm, e.mean, e.se, e.df, e.lower, e.upper, d.optimism_pct
            );
        }
        if let Some(t) = &sp.trend {
            let e = &t.slope;
            let _ = writeln!(
                s,
                "split {:?} slope {:.6e} se {:.6e} [{:.6e}, {:.6e}] optimism slope {:.4} [{:.4}, {:.4}] smallest {:?}",
                sp.split,
                e.mean,
                e.se,
                e.lower,
                e.upper,
                t.optimism_slope,
                t.optimism_slope_lower,
                t.optimism_slope_upper,
                t.smallest_dose_excluding_zero
            );
        }
    }
    if let Some(p) = &a.pooled {
        for e in p.doses.iter().chain(&p.slope) {
            let _ = writeln!(
                s,
                "pooled {}: n {} mu {:.6e} se {:.6e} df {:.3} [{:.6e}, {:.6e}] optimism {:.3}% split share {:.4}",
                e.label, e.n, e.mean, e.se, e.df, e.lower, e.upper, e.optimism_pct, e.split_share
            );
        }
    }
    s
}

#[test]
fn dose_response_analysis_of_the_committed_run_is_locked() {
    let a = committed("nanobench_dose_response.design", "dose_response");
    crate::snapshots!({ insta::assert_snapshot!(summary(&a)) });
}

#[test]
fn multi_split_analysis_of_the_committed_run_is_locked() {
    let a = committed("nanobench_multi_split.design", "multi_split");
    crate::snapshots!({ insta::assert_snapshot!(summary(&a)) });
}

/// `name key value...` lines of scripts/reference/multi_split_reference.out.
fn lme4(name: &str, key: &str) -> f64 {
    let text = std::fs::read_to_string(root().join("scripts/reference/multi_split_reference.out")).unwrap();
    for line in text.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() >= 3 && f[0] == name && f[1] == key {
            return f[f.len() - 1].parse().unwrap();
        }
        if f.len() == 4 && f[0] == name && f[1] == "var" && f[2] == key {
            return f[3].parse().unwrap();
        }
    }
    panic!("{name} {key} not in multi_split_reference.out")
}

/// The pooled estimate of the committed multi-split runs against lme4,
/// lmerTest and pbkrtest on the same cells
/// (scripts/reference/multi_split_reference.R, its output committed beside it).
#[test]
fn pooled_estimate_matches_lme4_on_the_committed_cells() {
    for (design, run, name) in [
        ("nanobench_multi_split.design", "multi_split", "multi_split"),
        ("simulated_splits_0.design", "simulated_family/splits_0", "simulated_family.splits_0"),
        ("simulated_splits_high.design", "simulated_family/splits_high", "simulated_family.splits_high"),
    ] {
        let a = committed(design, run);
        let p = &a.pooled.as_ref().unwrap().doses[0];
        assert_eq!(p.n as f64, lme4(name, "cells"));
        assert_rel(p.mean, lme4(name, "intercept"), 1e-6, "intercept");
        assert_rel(p.se, lme4(name, "se"), 1e-6, "se");
        assert_rel(p.df, lme4(name, "satterthwaite_df"), 1e-4, "Satterthwaite df");
        assert_rel(p.lower, lme4(name, "lower"), 1e-5, "lower");
        assert_rel(p.upper, lme4(name, "upper"), 1e-5, "upper");
        for (k, factor) in ["split", "recording", "seed", "Residual"].iter().enumerate() {
            let r = lme4(name, factor);
            // A component at the boundary is zero in both (or 1e-10 of the total).
            if r.abs() < 1e-10 {
                assert!(p.variances[k].abs() < 1e-8, "{name} {factor}: {} vs lme4 {r}", p.variances[k]);
            } else {
                assert_rel(p.variances[k], r, 1e-5, &format!("{name} var {factor}"));
            }
        }
    }
}

/// A fresh run of a simulated design with the real CLI's library path.
fn simulate(design: &str) -> FamilyAnalysis {
    let out = tempfile::tempdir().unwrap();
    let file = design::load(&root().join("designs").join(design)).unwrap();
    let study = crossaudit::compile_study(&file.design);
    let data = crossaudit::run::data_dir(&file.design, &file.path, None, out.path()).unwrap();
    let done = run(&file, &study, &data, out.path(), RunOptions { workers: 2, ..Default::default() }, &Quiet).unwrap();
    let StudyAnalysis::Family(a) = done.analysis else { panic!("{design}: not a family analysis") };
    // The run's cells.csv is the committed one, byte for byte.
    let run_dir = design.trim_start_matches("simulated_").trim_end_matches(".design");
    let committed = root().join("results/simulated_family").join(run_dir).join("cells.csv");
    assert_eq!(std::fs::read(out.path().join("cells.csv")).unwrap(), std::fs::read(&committed).unwrap(), "{design}");
    *a
}

/// Known truth, dose-response: at strength 0 evaluation windows carry
/// nothing new, so every dose's interval and the slope's cover zero; at
/// strength 1 the optimism slope's interval lies above zero.
#[test]
fn simulated_dose_response_recovers_the_known_truth() {
    let zero = simulate("simulated_dose_0.design");
    let s = &zero.splits[0];
    for d in &s.doses {
        assert!(d.estimate.lower < 0.0 && d.estimate.upper > 0.0, "strength 0, dose {}%: {:?}", d.percent, d.estimate);
    }
    let t = s.trend.as_ref().unwrap();
    assert!(t.slope.lower < 0.0 && t.slope.upper > 0.0, "strength 0 slope: {:?}", t.slope);
    assert_eq!(t.smallest_dose_excluding_zero, None);
    assert!(!zero.decision.holds);

    let high = simulate("simulated_dose_high.design");
    let t = high.splits[0].trend.as_ref().unwrap();
    assert!(
        t.optimism_slope_lower > 0.0,
        "strength 1 optimism slope: [{}, {}]",
        t.optimism_slope_lower,
        t.optimism_slope_upper
    );
    assert!(t.slope.upper < 0.0 && high.decision.holds);
}

/// Known truth, multi-split: at strength 0 the pooled interval covers zero.
#[test]
fn simulated_multi_split_at_strength_zero_covers_zero() {
    let zero = simulate("simulated_splits_0.design");
    let p = &zero.pooled.as_ref().unwrap().doses[0];
    assert!(p.lower < 0.0 && p.upper > 0.0, "strength 0 pooled: [{}, {}]", p.lower, p.upper);
    assert_eq!(zero.splits.len(), 5);
    assert!(!zero.decision.holds);
}

/// The real CLI on a dose x split study of the real logs: every split's
/// directory, the pooled cells with both columns, the report and figures;
/// a rerun resumes every job; `analyze` of the written cells gives the
/// same decision.
#[test]
#[ignore = "needs ../shared/nanobench"]
fn cli_runs_a_dose_by_split_study_and_resumes_it() {
    let _logs = crate::needs_shared_logs!();
    shared_logs();
    let out = tempfile::tempdir().unwrap();
    let dir = out.path().join("run");
    let go = || {
        bin()
            .args(["run", "tests/designs/tiny_family.design", "--out"])
            .arg(&dir)
            .args(["--workers", "2"])
            .output()
            .unwrap()
    };
    let first = go();
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    let said = |o: &std::process::Output| {
        format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
    };
    assert!(said(&first).contains("16 cells trained, 0 resumed"), "{}", said(&first));
    for s in ["split-42", "split-43"] {
        for part in [
            "run.json",
            "audit/treatment.json",
            "audit/invariants.json",
            "manifests/manifests.json",
            "report/report.md",
        ] {
            assert!(dir.join(s).join(part).exists(), "{s}/{part}");
        }
    }
    for part in ["report/report.md", "report/results.json", "report/optimism_by_dose.svg", "report/forest_25.svg"] {
        assert!(dir.join(part).exists(), "{part}");
    }
    let cells = std::fs::read_to_string(dir.join("cells.csv")).unwrap();
    assert!(cells.starts_with("split,model,arm,dose,seed,"));
    assert_eq!(cells.lines().count(), 1 + 2 * 4 * 4 * 2);
    let second = go();
    assert!(second.status.success());
    assert!(said(&second).contains("0 cells trained, 16 resumed"), "{}", said(&second));
    assert_eq!(std::fs::read_to_string(dir.join("cells.csv")).unwrap(), cells);
    let again = bin()
        .args(["analyze", "tests/designs/tiny_family.design", "--cells"])
        .arg(dir.join("cells.csv"))
        .arg("--out")
        .arg(out.path().join("again"))
        .output()
        .unwrap();
    assert!(again.status.success(), "{}", String::from_utf8_lossy(&again.stderr));
    let line = |o: &std::process::Output| String::from_utf8_lossy(&o.stdout).lines().last().unwrap().to_string();
    assert_eq!(line(&again), line(&first));
    // A wrong dose value is refused with its line.
    let bad = cells.replacen(",disjoint,0,", ",disjoint,5,", 1);
    std::fs::write(out.path().join("bad.csv"), bad).unwrap();
    let o = bin()
        .args(["analyze", "tests/designs/tiny_family.design", "--cells"])
        .arg(out.path().join("bad.csv"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("line 2, field `dose`") && e.contains("disagrees with arm `disjoint`"), "{e}");
    // An arm the design does not have is refused, not left out of every contrast.
    let bad = cells.replacen(",disjoint,0,", ",other,0,", 1);
    std::fs::write(out.path().join("bad.csv"), bad).unwrap();
    let o = bin()
        .args(["analyze", "tests/designs/tiny_family.design", "--cells"])
        .arg(out.path().join("bad.csv"))
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("line 2, field `arm`: \"other\" is not in the design"), "{e}");
}

#[test]
fn family_analysis_refuses_cells_without_the_split_column() {
    let d = design::from_str("t", &tiny_family()).unwrap();
    let plan = crossaudit::compile(&d);
    let c = crossaudit::cells::Cell {
        split: None,
        arm: "disjoint".into(),
        ..crate::common::minimal_cells(&crate::common::minimal_design())[0].clone()
    };
    let e = analyze_family(&plan, &[c], Default::default()).unwrap_err().to_string();
    assert!(e.contains("every row needs a `split` value"), "{e}");
}

/// The multi-split planner from the committed five-split pilot: at the
/// pilot's own size its SE is lme4's pooled SE up to the recordings that
/// recur across splits (scripts/reference/multi_split_reference.out:
/// 0.0162481280580901), each row follows the closed form, and more splits
/// narrow the interval.
#[test]
fn split_planner_predicts_the_pilots_se_and_narrows_with_splits() {
    let design = root().join("designs/nanobench_multi_split.design");
    let file = design::load(&design).unwrap();
    let plan = crossaudit::compile(&file.design);
    let a = committed("nanobench_multi_split.design", "multi_split");
    let p = crossaudit::methods::split_power_plan(&plan, &a, &[5, 10], &[26], &[10, 20]).unwrap();
    assert_eq!(p.pilot, (5, 26, 10));
    let at = |s: usize, j: usize| p.rows.iter().find(|r| r.splits == s && r.seeds == j).unwrap().clone();
    let pilot = at(5, 10);
    let lme4_se = lme4("multi_split", "se");
    assert!(pilot.se < lme4_se && pilot.se > 0.95 * lme4_se, "planner {} vs lme4 {lme4_se}", pilot.se);
    let [vs, vr, vj, ve] = ["split", "recording", "seed", "Residual"].map(|f| lme4("multi_split", f));
    let closed = (vs / 10.0 + vr / 260.0 + vj / 20.0 + ve / 5200.0).sqrt();
    assert_rel(at(10, 20).se, closed, 1e-5, "closed-form SE at 10 splits, 20 seeds");
    assert!(at(10, 10).width < pilot.width && at(10, 10).power >= pilot.power);
    // The CLI writes the plan for a multi-split design.
    let out = tempfile::tempdir().unwrap();
    let o = bin()
        .args(["plan", "designs/nanobench_multi_split.design", "--cells", "results/multi_split/cells.csv"])
        .args(["--splits", "3,5,10", "--recordings", "26", "--seeds", "10", "--out"])
        .arg(out.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(out.path().join("plan.md")).unwrap();
    assert!(
        md.starts_with("# Multi-split planner") && md.lines().filter(|l| l.starts_with("| 10 |")).count() == 1,
        "{md}"
    );
}

/// A value of scripts/reference/dose_slope_reference.out (base R: per-cell
/// lm slopes of the committed dose-response cells, their two-way ANOVA
/// components and the closed-form SE).
fn r_slope(key: &str) -> f64 {
    let text = std::fs::read_to_string(root().join("scripts/reference/dose_slope_reference.out")).unwrap();
    let line = text.lines().find(|l| l.starts_with(&format!("dose_response {key} "))).expect(key);
    line.split_whitespace().last().unwrap().parse().unwrap()
}

/// The dose-response planner on the committed pilot: its components and
/// predicted SEs are R's, and the pilot-size SE is the report's.
#[test]
fn dose_planner_matches_r_on_the_committed_pilot() {
    let file = design::load(&root().join("designs/nanobench_dose_response.design")).unwrap();
    let plan = crossaudit::compile(&file.design);
    let a = committed("nanobench_dose_response.design", "dose_response");
    let p = crossaudit::methods::dose_power_plan(&plan, &a, &[13, 24, 26, 52], &[5, 10, 20, 40]).unwrap();
    assert_eq!((p.pilot_recordings, p.pilot_seeds), (24, 10));
    assert!(p.unit.starts_with("slope over doses of world fa_position_rmse"), "{}", p.unit);
    assert_rel(p.mean_d, r_slope("mean_slope"), 1e-10, "mean slope");
    assert_rel(p.sigma2_recording, r_slope("var recording"), 1e-8, "recording component");
    assert_rel(p.sigma2_seed, r_slope("var seed"), 1e-8, "seed component");
    assert_rel(p.sigma2_residual, r_slope("var residual"), 1e-8, "residual component");
    for (i, j) in [(24, 10), (13, 5), (26, 20), (52, 40)] {
        let row = p.rows.iter().find(|r| r.recordings == i && r.seeds == j).unwrap();
        assert_rel(row.se, r_slope(&format!("se_at {i} {j}")), 1e-8, &format!("SE at {i} x {j}"));
    }
    let pilot = p.rows.iter().find(|r| r.recordings == 24 && r.seeds == 10).unwrap();
    assert_rel(pilot.se, a.splits[0].trend.as_ref().unwrap().slope.se, 1e-12, "pilot SE vs the report's");
    // A design without doses has no trend to plan.
    let single = crossaudit::compile(&design::load(&root().join("tests/designs/sim_small.design")).unwrap().design);
    let no_trend = FamilyAnalysis {
        splits: vec![crossaudit::analysis::family::SplitResult { trend: None, ..a.splits[0].clone() }],
        ..a.clone()
    };
    let e = crossaudit::methods::dose_power_plan(&single, &no_trend, &[13], &[5]).unwrap_err();
    assert!(e.to_string().contains("no trend over doses"), "{e}");

    // The CLI plans the slope of a dose-response design.
    let out = tempfile::tempdir().unwrap();
    let o = bin()
        .args(["plan", "designs/nanobench_dose_response.design", "--cells", "results/dose_response/cells.csv"])
        .args(["--recordings", "13,26", "--seeds", "5,10", "--out"])
        .arg(out.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(out.path().join("plan.md")).unwrap();
    assert!(md.contains("mean slope (per dose point)") && md.contains("| 13 | 5 | 3.381e-4 |"), "{md}");
}

/// With doses and splits and a rule on the slope, the multi-split planner
/// plans the pooled slope, not the first dose.
#[test]
fn split_planner_plans_the_pooled_slope_when_the_rule_is_on_it() {
    let file = design::load(&root().join("tests/designs/sim_splits_small.design")).unwrap();
    let study = crossaudit::compile_study(&file.design);
    let plan = &study.plan;
    let out = tempfile::tempdir().unwrap();
    let data = crossaudit::run::data_dir(&file.design, &file.path, None, out.path()).unwrap();
    let done = run(&file, &study, &data, out.path(), RunOptions { workers: 2, ..Default::default() }, &Quiet).unwrap();
    let StudyAnalysis::Family(a) = done.analysis else { panic!("a dose x split study is a family") };
    let slope = a.pooled.as_ref().unwrap().slope.clone().unwrap();
    let p = crossaudit::methods::split_power_plan(plan, &a, &[2], &[4], &[2]).unwrap();
    assert!(p.unit.starts_with("slope over doses of"), "{}", p.unit);
    assert_eq!((p.mean_d, p.variances), (slope.mean, slope.variances));
    assert_rel(p.rows[0].se, crossaudit::methods::pooled_se(slope.variances, 2.0, 4.0, 2.0), 1e-15, "closed form");
}

/// Commands that prepare one split refuse a multi-split design instead of
/// silently running its first split (`run --slurm` prepares every split:
/// tests/slurm.rs).
#[test]
#[ignore = "needs ../shared/nanobench"]
fn one_split_commands_refuse_a_multi_split_design() {
    let _logs = crate::needs_shared_logs!();
    shared_logs();
    let out = tempfile::tempdir().unwrap();
    let train = ["train", "tests/designs/tiny_family.design", "--model", "world", "--arm", "disjoint", "--seed", "1"];
    for args in [vec!["split", "tests/designs/tiny_family.design", "--out"], [&train[..], &["--out"]].concat()] {
        let o = bin().args(&args).arg(out.path().join("x")).output().unwrap();
        assert!(!o.status.success(), "{args:?}");
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(e.contains("declares 2 splits") && e.contains("DIR/split-S"), "{args:?}: {e}");
    }
}

/// Each dose's own report carries the family's preregistration labels
/// (issue 30, class 8: every output of a locked design says it is
/// preregistered, and an exploratory family's every output says EXPLORATORY).
#[test]
fn every_dose_report_of_a_family_carries_its_preregistration_labels() {
    let out = tempfile::tempdir().unwrap();
    let o = bin()
        .args([
            "analyze",
            "designs/nanobench_dose_response.design",
            "--cells",
            "results/dose_response/cells.csv",
            "--out",
        ])
        .arg(out.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for dose in ["1pct", "5pct", "10pct", "25pct", "50pct"] {
        let path = out.path().join(format!("contaminated_{dose}/results.json"));
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        assert_eq!(v["preregistered"], true, "{}", path.display());
        assert_eq!(v["exploratory"], false, "{}", path.display());
        assert!(v["design_sha256"].is_string(), "{}", path.display());
        // The family decides on the slope; a dose's own report is descriptive.
        let decides = v["decision"]["member_of"]["decides_on"].as_str().unwrap_or("");
        assert!(decides.starts_with("slope over doses"), "{}: {decides}", path.display());
    }
}

/// A family reports every endpoint its design declares: the multi-split
/// study's secondaries (world at 0.5 s and 2.0 s) per split, each with the
/// arms' plain means recomputed here from cells.csv (the crossed estimate
/// of a complete array's mean is its mean), in results.json, report.md and
/// estimates.csv alike.
#[test]
fn a_family_reports_its_declared_secondary_endpoints() {
    let a = committed("nanobench_multi_split.design", "multi_split");
    let text = std::fs::read_to_string(root().join("results/multi_split/cells.csv")).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| head.iter().position(|h| *h == n).unwrap();
    let (split, model, arm, h, v) =
        (col("split"), col("model"), col("arm"), col("horizon_s"), col("fa_position_rmse_m"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let mean = |s: u64, m: &str, r: &str, at: f64| {
        let x: Vec<f64> = rows
            .iter()
            .filter(|c| c[split] == s.to_string() && c[model] == m && c[arm] == r && c[h].parse::<f64>().unwrap() == at)
            .map(|c| c[v].parse().unwrap())
            .collect();
        x.iter().sum::<f64>() / x.len() as f64
    };
    assert_eq!(a.secondary.len(), 5 * 2, "5 splits x 2 secondary horizons: {:?}", a.secondary.len());
    for r in &a.secondary {
        let s = r.split.unwrap();
        let (t, rf) = (mean(s, &r.model, &r.arm, r.horizon_s), mean(s, &r.model, &a.reference, r.horizon_s));
        assert!((r.mean_treated - t).abs() < 1e-12 && (r.mean_reference - rf).abs() < 1e-12, "{r:?}");
        assert!((r.estimate.mean - (t - rf)).abs() < 1e-12, "{r:?}");
        assert!([0.5, 2.0].contains(&r.horizon_s), "{r:?}");
    }
    let table = crossaudit::report::study_table(&crossaudit::analysis::StudyAnalysis::Family(Box::new(a.clone())));
    let secondary: Vec<&str> = table.lines().filter(|l| l.contains(",secondary,")).collect();
    assert_eq!(secondary.len(), 2 * a.secondary.len(), "an endpoint and an optimism row each");
    let md = crossaudit::report::family::render_family_markdown(&a);
    assert!(md.contains("## Secondary endpoints"), "{md}");
}

/// Before: each split's report of a multi-split family opened with its
/// own verdict and "Preregistered" while the family decides on the pooled
/// estimate, and carried no condition-coverage guard though its split left
/// evaluation conditions unseen by the reference arm. Each member report
/// is now descriptive in every view (title, banner, results.json,
/// results.tex, estimates.csv) and names the family's verdict; its
/// coverage guard names the recordings its own split's audit
/// (`split-S/audit/treatment.json`, read here) gives no disjoint fit
/// recording of their condition.
#[test]
fn a_familys_member_reports_are_descriptive_with_their_own_coverage_guard() {
    let out = tempfile::tempdir().unwrap();
    let o = bin()
        .args(["analyze", "designs/nanobench_multi_split.design", "--cells", "results/multi_split", "--out"])
        .arg(out.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json =
        |p: std::path::PathBuf| -> serde_json::Value { serde_json::from_slice(&std::fs::read(&p).unwrap()).unwrap() };
    let family = json(out.path().join("results.json"));
    let name = family["decision"]["name"].as_str().unwrap().to_uppercase();
    let verdict = if family["decision"]["holds"] == true { name } else { format!("NOT {name}") };
    for s in [42, 43, 44, 45, 46] {
        let dir = out.path().join(format!("split-{s}"));
        let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
        let title = md.lines().next().unwrap();
        let want = format!("# nanobench-multi-split: DESCRIPTIVE (split {s} of a family; the family's verdict: {verdict}, on pooled over 5 splits");
        assert!(title.starts_with(&want), "{title}\nwanted {want}");
        assert!(!md.contains("\ndecision: "), "{md}");
        let r = json(dir.join("results.json"));
        assert_eq!(r["decision"]["member_of"]["verdict"].as_str(), Some(verdict.as_str()));
        assert_eq!(r["decision"]["member_of"]["report"].as_str(), Some("../report.md"));
        let tex = std::fs::read_to_string(dir.join("results.tex")).unwrap();
        assert!(tex.contains("\\newcommand{\\caDecision}{descriptive}"), "{tex}");
        let csv = std::fs::read_to_string(dir.join("estimates.csv")).unwrap();
        assert!(csv.lines().skip(1).all(|l| l.ends_with(',')), "no row decides: {csv}");
        let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
        assert!(html.contains("<div class=\"banner descriptive\""), "split {s}");
        // The split's own audit: evaluation recordings whose condition the
        // reference arm fits on no other recording of.
        let audit = json(root().join(format!("results/multi_split/split-{s}/audit/treatment.json")));
        let rows = audit["coverage"]["recordings"].as_array().unwrap();
        let uncovered: Vec<&str> = rows
            .iter()
            .filter(|r| r["fit_recordings"]["disjoint"] == 0)
            .map(|r| r["recording"].as_str().unwrap())
            .collect();
        assert!(!uncovered.is_empty(), "every split of the committed study leaves some uncovered");
        let head = md.split("\n## ").next().unwrap();
        let guard = head
            .lines()
            .find(|l| l.starts_with("**The contrast mixes condition novelty with recording leakage**"))
            .unwrap_or_else(|| panic!("split {s}: no coverage guard beside the line:\n{head}"));
        assert!(guard.contains(&format!("of {} of {} evaluation recordings", uncovered.len(), rows.len())), "{guard}");
        for u in uncovered {
            assert!(guard.contains(u), "split {s}: {u} not in {guard}");
        }
    }
}
