//! The divergence endpoint analysed by a crossed binomial GLMM (`endpoint
//! secondary divergence_rate ... glmm binomial`), through the real binary:
//! on the committed per-cell data of the confirmatory NanoBench run, the
//! report's odds ratio, interval and variance components are lme4's
//! (scripts/reference/divergence_glmm.R, its output committed beside it);
//! a rule `on divergence` reads that odds ratio; and what the GLMM cannot
//! be declared on, or decided by, is refused at its line and column.

use crate::common::root;

fn run(args: &[&str]) -> (i32, String, String) {
    let out = crate::common::bin().current_dir(root()).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `<what> <values...>` lines of scripts/reference/divergence_glmm.out.
fn reference(what: &str) -> Vec<String> {
    let text = std::fs::read_to_string(root().join("scripts/reference/divergence_glmm.out")).unwrap();
    let line = text.lines().find(|l| l.split_whitespace().next() == Some(what)).unwrap();
    line.split_whitespace().skip(1).map(str::to_string).collect()
}

fn number(what: &str, at: usize) -> f64 {
    reference(what)[at].parse().unwrap()
}

fn close(what: &str, ours: f64, theirs: f64, rel: f64) {
    assert!((ours - theirs).abs() <= rel * theirs.abs(), "{what}: crossaudit {ours}, lme4 {theirs}");
}

/// The design with its decision replaced by `decide`.
fn with_decision(decide: &str) -> String {
    let text = std::fs::read_to_string(root().join("designs/nanobench_divergence.design")).unwrap();
    text.lines()
        .map(|l| if l.starts_with("decide ") { decide.to_string() } else { l.to_string() })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn the_divergence_glmm_of_the_confirmatory_run_is_lme4s() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let cells = "results/nanobench_confirmatory/cells.csv";
    let (code, _, stderr) =
        run(&["analyze", "designs/nanobench_divergence.design", "--cells", cells, "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let unit = json["units"].as_array().unwrap().iter().find(|u| u.get("glmm").is_some()).unwrap();
    let g = &unit["glmm"];
    let diverged = reference("diverged");
    assert_eq!(g["diverged_treated"].as_u64().unwrap().to_string(), diverged[0]);
    assert_eq!(g["starts_treated"].as_u64().unwrap().to_string(), diverged[1]);
    assert_eq!(g["diverged_reference"].as_u64().unwrap().to_string(), diverged[2]);
    assert_eq!(g["starts_reference"].as_u64().unwrap().to_string(), diverged[3]);
    let e = &g["estimate"];
    let value = |k: &str| e[k].as_f64().unwrap();
    assert!(e["certified"].as_bool().unwrap());
    // -2 logLik to lme4's convergence; the arm's effect and its SE (lme4's
    // from a difference Hessian) to 1e-3.
    close("deviance", value("deviance"), number("deviance", 0), 1e-8);
    assert!(value("deviance") <= number("deviance", 0) + 1e-6, "crossaudit's optimum above lme4's");
    close("log odds ratio", value("log_odds_ratio"), number("log_odds_ratio", 0), 1e-3);
    close("se", value("se"), number("se", 0), 1e-3);
    close("odds ratio", value("odds_ratio"), number("odds_ratio", 0), 1e-4);
    close("odds ratio lower", value("odds_ratio_lower"), number("odds_ratio", 1), 1e-4);
    close("odds ratio upper", value("odds_ratio_upper"), number("odds_ratio", 2), 1e-4);
    let sd = |group: &str| -> f64 {
        let text = std::fs::read_to_string(root().join("scripts/reference/divergence_glmm.out")).unwrap();
        let line = text.lines().find(|l| l.starts_with(&format!("sd {group} "))).unwrap();
        line.split_whitespace().nth(2).unwrap().parse().unwrap()
    };
    close("sd recording:seed", value("sd_recording_seed"), sd("recording:seed"), 1e-3);
    close("sd seed", value("sd_seed"), sd("seed"), 1e-3);
    // The recordings' SD is large and flat (some recordings never
    // diverge, some nearly always): its digits are the optimizers'.
    close("sd recording", value("sd_recording"), sd("recording"), 2e-2);
    // The report gives it beside the endpoints, with what it measures.
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    let at = report.find("## Divergence by binomial GLMM").expect("the GLMM section");
    assert!(report.find("## Endpoints").unwrap() < at, "{report}");
    assert!(report[at..].contains("a conditional odds ratio, not the ratio of the arms' divergence rates"));
    assert!(report[at..].contains(&format!("{:.4}", number("odds_ratio", 0))), "{}", &report[at..]);
}

#[test]
fn a_rule_on_divergence_reads_the_glmms_odds_ratio() {
    let dir = tempfile::tempdir().unwrap();
    let design = dir.path().join("d.design");
    std::fs::write(&design, with_decision("decide fewer_failures on divergence when upper < 0")).unwrap();
    let out = dir.path().join("report");
    let cells = root().join("results/nanobench_confirmatory/cells.csv");
    let (code, _, stderr) =
        run(&["analyze", design.to_str().unwrap(), "--cells", cells.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let d = &json["decision"];
    // lme4's interval of the log odds ratio contains 0: the rule does not hold.
    let upper = number("odds_ratio", 2).ln();
    close("the upper bound the rule reads", d["conditions"][0]["value"].as_f64().unwrap(), upper, 1e-3);
    assert_eq!(d["holds"], false);
    assert!(d["unit"].as_str().unwrap().contains("log odds ratio of a diverged rollout, contaminated over disjoint"));
    // No unit's crossed estimate is decided by it.
    assert!(json["units"].as_array().unwrap().iter().all(|u| u["rule_holds"] == false));
    // Issue 72: beside the verdict, the recordings that hold the events.
    // Counted from the cells (n_divergent of world at 1 s, both arms):
    // 830 on B9_trefoil_fast_rep15 and 508 on B9_trefoil_fast_rep5 of 1340.
    let guard = json["guards"].as_array().unwrap().iter().find(|g| g["kind"] == "concentrated").expect("guard");
    let text = guard["text"].as_str().unwrap();
    assert!(text.contains("1338 of the 1340 diverged starts"), "{text}");
    assert!(text.contains("B9_trefoil_fast_rep15 (830), B9_trefoil_fast_rep5 (508)"), "{text}");
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("**The diverged rollouts come from few recordings**"), "{md}");
}

#[test]
fn a_glmm_where_it_has_no_meaning_is_refused_at_its_place() {
    let dir = tempfile::tempdir().unwrap();
    let base = with_decision("decide confirmed when optimism >= 10% and upper < 0");
    let cases: Vec<(String, &str)> = vec![
        (
            base.replace(
                "divergence_rate at 1.0 s model world glmm binomial",
                "fa_position_rmse at 1.5 s model world glmm binomial",
            ),
            "`glmm binomial` analyses failures out of trials; `fa_position_rmse` is not a count",
        ),
        (base.replace("glmm binomial", "glmm poisson"), "`poisson` is not a family of an endpoint's GLMM"),
        (
            base.replace(
                "endpoint primary   fa_position_rmse at 1.0 s cap 2 m  model world",
                "endpoint primary   divergence_rate at 0.5 s cap 2 m  model world glmm binomial",
            ),
            "the primary endpoint is the crossed contrast every report and sensitivity reads",
        ),
        (
            with_decision("decide fewer on divergence when optimism >= 10%"),
            "a rule `on divergence` reads the log odds ratio of a diverged rollout, which has no optimism",
        ),
        (
            with_decision("decide fewer on divergence when upper < 0")
                .replace("divergence_rate at 1.0 s model world glmm binomial", "divergence_rate at 1.0 s model world"),
            "`on divergence` reads the one endpoint declared `glmm binomial`",
        ),
    ];
    for (k, (text, message)) in cases.iter().enumerate() {
        let path = dir.path().join(format!("case{k}.design"));
        std::fs::write(&path, text).unwrap();
        let (code, _, stderr) = run(&["check", path.to_str().unwrap()]);
        assert_ne!(code, 0, "case {k}: {stderr}");
        assert!(stderr.contains(message), "case {k}: {stderr}");
        assert!(stderr.contains(&format!("case{k}.design:")), "case {k} names no place: {stderr}");
    }
}
