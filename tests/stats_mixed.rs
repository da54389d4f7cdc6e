//! stats::mixed against lme4: every expected number comes from
//! scripts/reference/mixed_reference.R (lme4 1.1.31 with BOBYQA run to
//! rhoend 1e-12), output committed in scripts/reference/mixed_reference.out;
//! the balanced Penicillin fit also against the closed form.

use std::collections::BTreeMap;

use crate::common::root;
use crossaudit::stats::mixed::{fit, Criterion, MixedData, MixedError, MixedFit};

/// `name key values...` lines of the reference output.
fn reference() -> BTreeMap<(String, String), Vec<String>> {
    let text = std::fs::read_to_string(root().join("scripts/reference/mixed_reference.out")).unwrap();
    let mut out = BTreeMap::new();
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let f: Vec<&str> = line.split_whitespace().collect();
        if f[1] == "var" {
            out.insert((f[0].to_string(), format!("var {}", f[2])), vec![f[3].to_string()]);
        } else {
            out.insert((f[0].to_string(), f[1].to_string()), f[2..].iter().map(|s| s.to_string()).collect());
        }
    }
    out
}

/// A CSV fixture: response column, then factor columns (codes by first appearance).
fn data(file: &str, factors: &[(&str, &[usize])]) -> MixedData {
    let text = std::fs::read_to_string(root().join("tests/fixtures").join(file)).unwrap();
    let mut y = Vec::new();
    let mut cols: Vec<Vec<String>> = vec![Vec::new(); factors.len()];
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        y.push(f[0].parse::<f64>().unwrap());
        for (k, (_, parts)) in factors.iter().enumerate() {
            cols[k].push(parts.iter().map(|&p| f[p]).collect::<Vec<_>>().join(":"));
        }
    }
    let coded = factors
        .iter()
        .zip(cols)
        .map(|((name, _), col)| {
            let mut levels: Vec<String> = Vec::new();
            let codes = col
                .iter()
                .map(|v| match levels.iter().position(|l| l == v) {
                    Some(i) => i,
                    None => {
                        levels.push(v.clone());
                        levels.len() - 1
                    }
                })
                .collect();
            (name.to_string(), codes)
        })
        .collect();
    MixedData::new(y, coded).unwrap()
}

fn num(r: &BTreeMap<(String, String), Vec<String>>, name: &str, key: &str) -> f64 {
    r[&(name.to_string(), key.to_string())][0].parse().unwrap()
}

fn check(f: &MixedFit, name: &str, vars: &[&str]) {
    let r = reference();
    let close = |a: f64, b: f64, rel: f64, what: &str| {
        assert!((a - b).abs() <= rel * b.abs().max(1e-3), "{name} {what}: ours {a}, lme4 {b}");
    };
    // Tolerances, relative. The criterion is evaluated at each side's own
    // optimum, where it is flat: 1e-11. The intercept is a GLS mean, nearly
    // insensitive to theta: 1e-8. Variances, SEs and both df move with
    // theta, which each optimizer leaves a few parts in 10^8 from the
    // optimum (lme4's own results move by 2e-7 between runs of the R
    // script; we polish Nelder-Mead with Newton steps): 1e-6.
    close(f.deviance, num(&r, name, "criterion"), 1e-11, "REML/ML criterion");
    close(f.intercept, num(&r, name, "intercept"), 1e-8, "intercept");
    close(f.se, num(&r, name, "se"), 1e-6, "SE");
    close(f.residual, num(&r, name, "var Residual"), 1e-6, "residual variance");
    for (k, v) in vars.iter().enumerate() {
        close(f.variances[k], num(&r, name, &format!("var {v}")), 1e-6, v);
    }
    if let Some(df) = r.get(&(name.to_string(), "satterthwaite_df".to_string())) {
        // lmerTest differentiates the deviance numerically (numDeriv with
        // Richardson extrapolation), and so do we.
        close(f.df_satterthwaite.unwrap(), df[0].parse().unwrap(), 1e-6, "Satterthwaite df (lmerTest)");
    }
    match (f.kenward_roger, r.get(&(name.to_string(), "kr_df".to_string()))) {
        (Some(kr), Some(_)) => {
            // pbkrtest's vcovAdj and Lb_ddf, from n x n matrices in R; ours
            // from q x q products (closed forms in both, at each optimum).
            close(kr.se, num(&r, name, "kr_se"), 1e-6, "Kenward-Roger SE (pbkrtest)");
            close(kr.df, num(&r, name, "kr_df"), 1e-6, "Kenward-Roger df (pbkrtest)");
        }
        (None, None) => {}
        // Fits with fixed factors list the intercept's KR with the others.
        (Some(_), None) if r.contains_key(&(name.to_string(), "fixed_(Intercept)".to_string())) => {}
        (ours, theirs) => panic!("{name}: Kenward-Roger ours {ours:?}, pbkrtest {theirs:?}"),
    }
    let singular = r[&(name.to_string(), "singular".to_string())][0] == "TRUE";
    assert_eq!(f.singular, singular, "{name}: singular flag");
}

#[test]
fn balanced_crossed_reml_is_the_closed_form_and_lme4() {
    let d = data("penicillin.csv", &[("plate", &[1]), ("sample", &[2])]);
    let f = fit(&d, Criterion::Reml).unwrap();
    check(&f, "penicillin_reml", &["plate", "sample"]);
    // Balanced, positive components: REML = the ANOVA estimates, exactly
    // (MS from scripts/reference/crossed_reference.out as fractions).
    let (ms_p, ms_s, ms_e) = (953.0 / 207.0, 4043.0 / 45.0, 313.0 / 1035.0);
    // The optimizer leaves theta a few parts in 10^8 from the optimum.
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
    assert!(rel(f.variances[0], (ms_p - ms_e) / 6.0) < 1e-6, "{}", f.variances[0]);
    assert!(rel(f.variances[1], (ms_s - ms_e) / 24.0) < 1e-6, "{}", f.variances[1]);
    assert!(rel(f.residual, ms_e) < 1e-6, "{}", f.residual);
    assert!((f.intercept - 827.0 / 36.0).abs() < 1e-10);
    // Balanced two-way: Var(mean) = (MS_p + MS_s - MS_e) / 144, and the
    // classical Satterthwaite df of that combination of mean squares.
    let df = (ms_p + ms_s - ms_e).powi(2) / (ms_p.powi(2) / 23.0 + ms_s.powi(2) / 5.0 + ms_e.powi(2) / 115.0);
    // Kenward-Roger on a balanced design: no adjustment to the variance,
    // and the df are the same classical Satterthwaite df (Kenward and Roger
    // 1997, section 4: exact for balanced variance-component designs).
    let kr = f.kenward_roger.unwrap();
    assert!(rel(kr.se, f.se) < 1e-10, "{} vs {}", kr.se, f.se);
    // Shares of Var(mean): on a balanced crossed array they are
    // sa/I, sb/J and se/(IJ) over their sum (24 plates, 6 samples).
    let parts = [(ms_p - ms_e) / 6.0 / 24.0, (ms_s - ms_e) / 24.0 / 6.0, ms_e / 144.0];
    let total: f64 = parts.iter().sum();
    for (k, p) in parts.iter().enumerate() {
        assert!((f.shares[k] - p / total).abs() < 1e-6, "share {k}: {} vs {}", f.shares[k], p / total);
    }
    assert!(rel(kr.df, df) < 1e-6, "{} vs {df}", kr.df);
    assert!(rel(f.df_satterthwaite.unwrap(), df) < 1e-6, "{:?} vs {df}", f.df_satterthwaite);
}

#[test]
fn balanced_crossed_ml_matches_lme4() {
    let d = data("penicillin.csv", &[("plate", &[1]), ("sample", &[2])]);
    check(&fit(&d, Criterion::Ml).unwrap(), "penicillin_ml", &["plate", "sample"]);
}

#[test]
fn unbalanced_crossed_reml_and_ml_match_lme4() {
    let d = data("penicillin_unbalanced.csv", &[("plate", &[1]), ("sample", &[2])]);
    assert_eq!(d.len(), 124);
    check(&fit(&d, Criterion::Reml).unwrap(), "penicillin_unbalanced_reml", &["plate", "sample"]);
    check(&fit(&d, Criterion::Ml).unwrap(), "penicillin_unbalanced_ml", &["plate", "sample"]);
}

#[test]
fn nested_factors_match_lme4() {
    // Casks nested in batches: the cask factor is batch:cask.
    let d = data("pastes.csv", &[("batch:cask", &[1, 2]), ("batch", &[1])]);
    check(&fit(&d, Criterion::Reml).unwrap(), "pastes_reml", &["batch:cask", "batch"]);
}

#[test]
fn a_boundary_fit_is_flagged_singular_as_lme4_flags_it() {
    let d = data("dyestuff2.csv", &[("Batch", &[1])]);
    let f = fit(&d, Criterion::Reml).unwrap();
    check(&f, "dyestuff2_reml", &["Batch"]);
    assert_eq!(f.theta, vec![0.0]);
}

#[test]
fn bad_inputs_are_typed_errors() {
    let e = MixedData::new(vec![1.0], vec![("a".into(), vec![0])]).unwrap_err();
    assert_eq!(e, MixedError::TooFewObservations(1));
    let e = MixedData::new(vec![1.0, f64::NAN], vec![("a".into(), vec![0, 1])]).unwrap_err();
    assert!(matches!(e, MixedError::NonFinite { row: 1, .. }));
    let e = MixedData::new(vec![1.0, 2.0], vec![("a".into(), vec![0])]).unwrap_err();
    assert!(matches!(e, MixedError::Length { found: 1, expected: 2, .. }));
    let e = MixedData::new(vec![1.0, 2.0], vec![("a".into(), vec![3, 3])]).unwrap_err();
    assert!(matches!(e, MixedError::TooFewLevels { levels: 1, .. }));
    assert_eq!(MixedData::new(vec![1.0, 2.0], vec![]).unwrap_err(), MixedError::NoFactor);
}

/// `run key value` lines of scripts/reference/mixed_cells_reference.out.
fn cells_reference(run: &str, key: &str) -> f64 {
    let text = std::fs::read_to_string(root().join("scripts/reference/mixed_cells_reference.out")).unwrap();
    let want: Vec<&str> = key.split(' ').collect();
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let f: Vec<&str> = line.split_whitespace().collect();
        if f[0] == run && f[1..f.len() - 1] == want[..] {
            return f[f.len() - 1].parse().unwrap();
        }
    }
    panic!("{run} {key} not in mixed_cells_reference.out")
}

/// The committed run's cells.csv without the rows R deleted at random
/// (tests/fixtures/deleted_cells_RUN.csv), analysed by the real CLI under
/// the REML reanalysis design; the primary unit against lme4, lmerTest and
/// pbkrtest on the same 454 pairs (scripts/reference/mixed_cells_reference.R).
fn reml_on_deleted_cells(run: &str) {
    let dir = tempfile::tempdir().unwrap();
    let (cells, deleted) = deleted_cells(run, dir.path());
    let design = root().join(format!("designs/reanalysis/{run}_reml.design"));
    let out = dir.path().join("report");
    let status = crate::common::bin()
        .args(["analyze", design.to_str().unwrap(), "--cells", cells.to_str().unwrap(), "--out"])
        .arg(&out)
        .output()
        .unwrap();
    reml_checked(run, &status, &out, &deleted);
}

/// The committed run's cells.csv written into `dir` without the rows R
/// deleted at random (tests/fixtures/deleted_cells_RUN.csv); its path and
/// the deleted (recording, seed, arm).
fn deleted_cells(run: &str, dir: &std::path::Path) -> (std::path::PathBuf, Vec<(String, String, String)>) {
    let deleted = std::fs::read_to_string(root().join(format!("tests/fixtures/deleted_cells_{run}.csv"))).unwrap();
    let deleted: Vec<(String, String, String)> = deleted
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[0].to_string(), f[1].to_string(), f[2].to_string())
        })
        .collect();
    let text = std::fs::read_to_string(root().join(format!("results/{run}/cells.csv"))).unwrap();
    let mut kept = Vec::new();
    let mut removed = 0;
    for (i, line) in text.lines().enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        let gone = i > 0
            && f[0] == "world"
            && f[6] == "1"
            && deleted.iter().any(|(r, s, a)| f[1] == a && f[2] == s && f[3] == r);
        if gone {
            removed += 1;
        } else {
            kept.push(line);
        }
    }
    assert_eq!(removed, 26);
    let cells = dir.join("cells.csv");
    std::fs::write(&cells, kept.join("\n") + "\n").unwrap();
    (cells, deleted)
}

/// The REML analysis of the deleted cells (in `out`) against lme4,
/// lmerTest and pbkrtest, every deleted cell listed.
fn reml_checked(run: &str, status: &std::process::Output, out: &std::path::Path, deleted: &[(String, String, String)]) {
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let e = &json["units"][0]["estimate"];
    assert_eq!(json["units"][0]["model"], "world");
    assert_eq!(json["missing_cells"].as_array().unwrap().len(), 26);
    let reml = &e["reml"];
    assert_eq!(reml["cells"], cells_reference(run, "cells") as u64);
    let get = |v: &serde_json::Value| v.as_f64().unwrap();
    let close = |ours: f64, key: &str, rel: f64| {
        let want = cells_reference(run, key);
        assert!((ours - want).abs() <= rel * want.abs(), "{run} {key}: ours {ours}, R {want}");
    };
    // Tolerances as in check() above: the criterion at each side's optimum
    // 1e-11, the GLS intercept 1e-8, everything that moves with theta 1e-6.
    close(get(&reml["criterion"]), "criterion", 1e-11);
    close(get(&e["mean"]), "intercept", 1e-8);
    close(get(&e["components"]["recording"]), "var recording", 1e-6);
    close(get(&e["components"]["seed"]), "var seed", 1e-6);
    close(get(&e["components"]["residual"]), "var Residual", 1e-6);
    close(get(&reml["se_model"]), "se", 1e-6);
    close(get(&e["se"]), "kr_se", 1e-6);
    close(get(&e["df"]), "kr_df", 1e-6);
    close(get(&reml["df_satterthwaite"]), "satterthwaite_df", 1e-6);
    close(get(&e["lower"]), "kr_lower", 1e-6);
    close(get(&e["upper"]), "kr_upper", 1e-6);
    // Every deleted cell is listed in the report.
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("## Missing cells"));
    for (r, s, a) in deleted {
        assert!(report.contains(&format!("arm={a} seed={s} recording={r} horizon=1 s")), "{r} {s} {a} not listed");
    }
}

/// Issue 75, item 4: `--compare-intervals` on an incomplete array gives
/// every interval the array allows and names each other with its reason.
/// REML as above (lme4); the naive iid interval and the one-way
/// cluster-robust ones by recording and by seed against their closed forms
/// computed here from the per-cell d (naive: SD / sqrt(N); CR1, as
/// sandwich::vcovCL(type = "HC1") for an intercept-only model:
/// V = G / (G - 1) sum_g (sum of the cluster's residuals)^2 / N^2,
/// Cameron & Miller 2015, eq. 11 with its small-sample factor), and the
/// two-way one (Cameron, Gelbach & Miller 2011) likewise.
#[test]
fn compared_intervals_on_an_incomplete_array_give_what_it_allows_and_name_the_rest() {
    let run = "nanobench_paper";
    let dir = tempfile::tempdir().unwrap();
    let (cells, deleted) = deleted_cells(run, dir.path());
    let design = root().join(format!("designs/reanalysis/{run}_reml.design"));
    let out = dir.path().join("report");
    let status = crate::common::bin()
        .args(["analyze", design.to_str().unwrap(), "--cells", cells.to_str().unwrap(), "--compare-intervals", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    // The REML analysis is what it is without the option.
    reml_checked(run, &status, &out, &deleted);
    // d per (recording, seed) where both arms are present: world, 1 s.
    let text = std::fs::read_to_string(&cells).unwrap();
    let mut arms: BTreeMap<(String, String), (Option<f64>, Option<f64>)> = BTreeMap::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f[0] != "world" || f[6] != "1" {
            continue;
        }
        let e = arms.entry((f[3].to_string(), f[2].to_string())).or_default();
        let v: f64 = f[9].parse().unwrap();
        match f[1] {
            "contaminated" => e.0 = Some(v),
            "disjoint" => e.1 = Some(v),
            other => panic!("arm {other}"),
        }
    }
    let d: Vec<((String, String), f64)> = arms.into_iter().filter_map(|(k, (c, r))| Some((k, c? - r?))).collect();
    let n = d.len() as f64;
    let mean = d.iter().map(|x| x.1).sum::<f64>() / n;
    let naive = (d.iter().map(|x| (x.1 - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt();
    let cr1 = |key: &dyn Fn(&(String, String)) -> String| {
        let mut sums: BTreeMap<String, f64> = BTreeMap::new();
        for (k, v) in &d {
            *sums.entry(key(k)).or_default() += v - mean;
        }
        let g = sums.len() as f64;
        ((g / (g - 1.0)) * sums.values().map(|s| s * s).sum::<f64>() / (n * n)).sqrt()
    };
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let intervals = json["units"][0]["intervals"].as_array().unwrap();
    assert_eq!(intervals.len(), 18, "every method has its row");
    let row = |m: &str| intervals.iter().find(|i| i["method"] == m).unwrap_or_else(|| panic!("no {m}"));
    let se = |m: &str| row(m)["se"].as_f64().unwrap();
    for (m, want) in
        [("naive_iid", naive), ("cluster_recording", cr1(&|k| k.0.clone())), ("cluster_seed", cr1(&|k| k.1.clone()))]
    {
        assert!((se(m) - want).abs() <= 1e-12 * want, "{m}: {} against {want}", se(m));
        assert!((row(m)["estimate"].as_f64().unwrap() - mean).abs() <= 1e-12 * mean.abs());
    }
    assert_eq!(row("cluster_recording")["df"].as_f64().unwrap(), 23.0);
    assert_eq!(row("cluster_seed")["df"].as_f64().unwrap(), 19.0);
    // Two-way (CGM, sandwich::vcovCL(lm(d ~ 1), cluster = ~ recording +
    // seed)): V_recording + V_seed - V_cell, each with its G / (G - 1).
    let mut by: [BTreeMap<String, f64>; 2] = Default::default();
    for (k, v) in &d {
        *by[0].entry(k.0.clone()).or_default() += v - mean;
        *by[1].entry(k.1.clone()).or_default() += v - mean;
    }
    let part = |m: &BTreeMap<String, f64>| {
        let g = m.len() as f64;
        g / (g - 1.0) * m.values().map(|s| s * s).sum::<f64>() / (n * n)
    };
    let cells_part = n / (n - 1.0) * d.iter().map(|x| (x.1 - mean).powi(2)).sum::<f64>() / (n * n);
    let cgm = (part(&by[0]) + part(&by[1]) - cells_part).sqrt();
    assert!((se("two_way_cluster") - cgm).abs() <= 1e-12 * cgm, "two-way: {} against {cgm}", se("two_way_cluster"));
    assert_eq!(row("two_way_cluster")["df"].as_f64().unwrap(), 19.0);
    // Every other one is named in report.md with its reason.
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    // (Only the primary unit's cells were deleted: the others are complete
    // and give all 18.)
    let named = report.matches("undefined: it needs a complete recording x seed array").count();
    assert_eq!(named, 12, "{report}");
}

#[test]
fn reml_on_the_paper_run_with_cells_deleted_matches_lme4() {
    reml_on_deleted_cells("nanobench_paper");
}

#[test]
fn reml_on_the_audited_run_with_cells_deleted_matches_lme4() {
    reml_on_deleted_cells("nanobench_paper_audited");
}

#[test]
fn shares_add_up_on_unbalanced_data() {
    let d = data("penicillin_unbalanced.csv", &[("plate", &[1]), ("sample", &[2])]);
    let f = fit(&d, Criterion::Reml).unwrap();
    // An identity (Euler), up to the rounding of the q x q inverse.
    assert!((f.shares.iter().sum::<f64>() - 1.0).abs() < 1e-10, "{:?}", f.shares);
    assert!(f.shares.iter().all(|s| *s > 0.0));
}

#[test]
fn a_constant_response_or_a_perfect_fit_is_a_typed_error() {
    let e = MixedData::new(vec![2.0; 4], vec![("a".into(), vec![0, 0, 1, 1])]).unwrap_err();
    assert_eq!(e, MixedError::ConstantResponse(2.0));
    // d_ij = a_i exactly: REML has no finite optimum (residual variance 0).
    let y = vec![1.0, 1.0, 1.0, 3.0, 3.0, 3.0, -2.0, -2.0, -2.0];
    let rows = vec![0, 0, 0, 1, 1, 1, 2, 2, 2];
    let cols = vec![0, 1, 2, 0, 1, 2, 0, 1, 2];
    let d = MixedData::new(y, vec![("row".into(), rows), ("col".into(), cols)]).unwrap();
    let r = fit(&d, Criterion::Reml);
    assert!(matches!(r, Err(MixedError::ZeroResidual { .. })), "{r:?}");
}

/// The strong simulated control has cells in which every start diverged.
/// The conditional-RMSE contrast pairs the arms: the means in the analysis
/// are recomputed here from cells.csv over the recording x seed pairs where
/// both arms have a value.
#[test]
fn the_conditional_rmse_contrast_is_paired() {
    let run = root().join("results/simulated_controls/strength_high");
    let a = crossaudit::analyze_files(
        &root().join("designs/simulated_control_high.design"),
        &run.join("cells.csv"),
        Default::default(),
    )
    .unwrap();
    let text = std::fs::read_to_string(run.join("cells.csv")).unwrap();
    let mut checked = 0;
    for u in &a.units {
        let mut arms: BTreeMap<(String, String), [Option<f64>; 2]> = BTreeMap::new();
        for line in text.lines().skip(1) {
            let f: Vec<&str> = line.split(',').collect();
            if f[0] != u.model || f[6].parse::<f64>().unwrap() != u.horizon_s {
                continue;
            }
            let k = if f[1] == a.treated { 0 } else { 1 };
            arms.entry((f[3].to_string(), f[2].to_string())).or_default()[k] = f[10].parse::<f64>().ok();
        }
        let pairs: Vec<(f64, f64)> = arms.values().filter_map(|[t, r]| Some(((*t)?, (*r)?))).collect();
        let dropped = arms.len() - pairs.len();
        let c = &u.conditional;
        assert_eq!(c.pairs_dropped, dropped);
        let mean = |k: usize| pairs.iter().map(|p| if k == 0 { p.0 } else { p.1 }).sum::<f64>() / pairs.len() as f64;
        assert!((c.mean_conditional_treated.unwrap() - mean(0)).abs() < 1e-12);
        assert!((c.mean_conditional_reference.unwrap() - mean(1)).abs() < 1e-12);
        if dropped > 0 {
            let e = c.difference.as_ref().unwrap();
            assert_eq!(e.reml.unwrap().cells, pairs.len());
            checked += 1;
        }
    }
    assert!(checked > 0, "the control should have units with dropped pairs");
}

/// Issue 30: with pairs dropped, the conditional contrast used REML with
/// Kenward-Roger df whatever was preregistered. A REML design now gets its
/// own df rule (here Satterthwaite); a method-of-moments design, which
/// needs every pair, gets REML with Kenward-Roger df, as its report says.
#[test]
fn the_conditional_contrast_keeps_the_preregistered_reml_df_rule() {
    let run = root().join("results/simulated_controls/strength_high");
    let text = std::fs::read_to_string(root().join("designs/simulated_control_high.design")).unwrap();
    assert!(text.contains("estimate crossed_mom level 0.95 df seed - 1"));
    let dir = tempfile::tempdir().unwrap();
    let reml = dir.path().join("reml.design");
    std::fs::write(
        &reml,
        text.replace("estimate crossed_mom level 0.95 df seed - 1", "estimate reml level 0.95 df satterthwaite"),
    )
    .unwrap();
    for (design, rule) in [
        (reml, crossaudit::stats::DfRule::Satterthwaite),
        (root().join("designs/simulated_control_high.design"), crossaudit::stats::DfRule::KenwardRoger),
    ] {
        let a = crossaudit::analyze_files(&design, &run.join("cells.csv"), Default::default()).unwrap();
        let mut checked = 0;
        for u in a.units.iter().filter(|u| u.conditional.pairs_dropped > 0) {
            let e = u.conditional.difference.as_ref().unwrap();
            assert_eq!(e.reml.unwrap().df_rule, rule, "{}", design.display());
            checked += 1;
        }
        assert!(checked > 0);
    }
}

#[test]
fn three_factors_crossed_and_nested_match_lme4() {
    // a crossed with b, c nested in a (the factor a:c), 14 of 144 cells
    // removed: y ~ 1 + (1|a) + (1|b) + (1|a:c).
    let d = data("three_factor.csv", &[("a:c", &[1, 3]), ("a", &[1]), ("b", &[2])]);
    assert_eq!(d.len(), 130);
    check(&fit(&d, Criterion::Reml).unwrap(), "three_factor_reml", &["a:c", "a", "b"]);
}

/// Machines (nlme): score ~ Machine + (1 | Worker) + (1 | Worker:Machine).
fn machines(file: &str) -> MixedData {
    let d = data(file, &[("Worker", &[1]), ("Worker:Machine", &[1, 2])]);
    let text = std::fs::read_to_string(root().join("tests/fixtures").join(file)).unwrap();
    let machine: Vec<String> = text.lines().skip(1).map(|l| l.split(',').nth(2).unwrap().to_string()).collect();
    d.with_fixed("Machine", &machine).unwrap()
}

#[test]
fn fixed_categorical_effects_match_lme4_lmertest_and_pbkrtest() {
    let r = reference();
    for (file, name) in [("machines.csv", "machines_reml"), ("machines_unbalanced.csv", "machines_unbalanced_reml")] {
        let f = fit(&machines(file), Criterion::Reml).unwrap();
        check(&f, name, &["Worker", "Worker:Machine"]);
        let names: Vec<&str> = f.fixed.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["(Intercept)", "MachineB", "MachineC"], "R's treatment-contrast names");
        for c in &f.fixed {
            let want: Vec<f64> =
                r[&(name.to_string(), format!("fixed_{}", c.name))].iter().map(|v| v.parse().unwrap()).collect();
            let close = |a: f64, b: f64, rel: f64, what: &str| {
                assert!((a - b).abs() <= rel * b.abs(), "{name} {} {what}: ours {a}, R {b}", c.name);
            };
            // Same tolerances as the intercept-only fits (see `check`).
            close(c.estimate, want[0], 1e-8, "estimate");
            close(c.se, want[1], 1e-6, "SE");
            // lmerTest's df come from numDeriv's Hessian: on the balanced
            // design, where they are exactly 10 (the Worker:Machine stratum),
            // lmerTest reports 10.0000008; ours are closer. 1e-6 covers both.
            close(c.df_satterthwaite.unwrap(), want[2], 1e-6, "Satterthwaite df (lmerTest)");
            let kr = c.kenward_roger.unwrap();
            close(kr.se, want[3], 1e-6, "Kenward-Roger SE (pbkrtest)");
            close(kr.df, want[4], 1e-6, "Kenward-Roger df (pbkrtest)");
        }
    }
}

/// Aliased columns are dropped as lme4 drops them (issue 39, task 3; the
/// lme4 comparison is tests/mixed_cli.rs): Machine given twice fits as
/// Machine once, the copy's columns named as dropped.
#[test]
fn aliased_fixed_effects_are_dropped_as_lme4_drops_them() {
    // Machine given twice: the second copy's columns repeat the first's.
    let text = std::fs::read_to_string(root().join("tests/fixtures/machines.csv")).unwrap();
    let machine: Vec<String> = text.lines().skip(1).map(|l| l.split(',').nth(2).unwrap().to_string()).collect();
    let once = fit(&machines("machines.csv"), Criterion::Reml).unwrap();
    let d = machines("machines.csv").with_fixed("Again", &machine).unwrap();
    let twice = fit(&d, Criterion::Reml).unwrap();
    assert_eq!(twice.dropped, ["AgainB", "AgainC"]);
    assert!(
        twice.notes[0].starts_with("fixed-effect model matrix is rank deficient so dropping 2 columns / coefficients")
    );
    assert_eq!(twice.fixed.len(), once.fixed.len());
    assert!((twice.deviance - once.deviance).abs() < 1e-9 * once.deviance.abs());
    for (a, b) in twice.fixed.iter().zip(&once.fixed) {
        assert_eq!(a.name, b.name);
        assert!((a.estimate - b.estimate).abs() < 1e-8 * b.estimate.abs().max(1.0), "{}", a.name);
    }
    // A fixed factor with one level, or the wrong length.
    let d = machines("machines.csv");
    assert!(matches!(d.clone().with_fixed("One", &vec!["a".to_string(); 54]), Err(MixedError::TooFewLevels { .. })));
    assert!(matches!(d.with_fixed("Short", &["a".to_string(), "b".to_string()]), Err(MixedError::Length { .. })));
}

#[test]
fn profile_intervals_match_lme4_confint() {
    use crossaudit::stats::mixed::profile_intervals;
    let r = reference();
    let cases: [(&str, MixedData, &[&str]); 4] = [
        ("penicillin", data("penicillin.csv", &[("plate", &[1]), ("sample", &[2])]), &["plate", "sample"]),
        (
            "penicillin_unbalanced",
            data("penicillin_unbalanced.csv", &[("plate", &[1]), ("sample", &[2])]),
            &["plate", "sample"],
        ),
        ("pastes", data("pastes.csv", &[("batch", &[1]), ("batch:cask", &[1, 2])]), &["batch", "batch:cask"]),
        ("machines_unbalanced", machines("machines_unbalanced.csv"), &["Worker", "Worker:Machine"]),
    ];
    for (name, d, factors) in cases {
        // lme4 profiles the ML deviance (devfun2 refits by ML).
        let iv = profile_intervals(&d, Criterion::Ml, 0.95).unwrap();
        for (k, group) in factors.iter().chain(&["Residual"]).enumerate() {
            let want: Vec<f64> =
                r[&(name.to_string(), format!("profile_{group}"))].iter().map(|v| v.parse().unwrap()).collect();
            assert_eq!(iv[k].name, *group);
            // lme4 steps along the profile and interpolates it with a
            // spline; ours solves for each limit to 1e-9. The spline's error
            // sets the tolerance: 1e-4 relative. A lower limit of exactly 0
            // (Pastes' batch) is 0 in both.
            for (ours, theirs, what) in [(iv[k].lower, want[0], "lower"), (iv[k].upper, want[1], "upper")] {
                assert!(
                    (ours - theirs).abs() <= 1e-4 * theirs.abs(),
                    "{name} {group} {what}: ours {ours}, lme4 {theirs}"
                );
            }
            assert!(iv[k].lower <= iv[k].estimate && iv[k].estimate <= iv[k].upper);
        }
    }
}
