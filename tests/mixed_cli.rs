//! `crossaudit mixed` (the real binary) against lme4, lmerTest and
//! pbkrtest on twelve published data sets (lme4's Dyestuff, Dyestuff2,
//! Penicillin, Pastes, cake and sleepstudy; nlme's Rail, Oats, Machines,
//! ergoStool and Orthodont; R's ChickWeight): every expected number comes
//! from scripts/reference/mixed_published.R (lme4 1.1.31, lmerTest 3.1.3,
//! pbkrtest 0.5.2, BOBYQA to rhoend 1e-12), committed in
//! tests/fixtures/mixed_published/reference.csv with the data it fitted.

use std::collections::BTreeMap;
use std::process::Command;

use crate::common::root;

/// (dataset, criterion, quantity, name) -> value.
fn reference() -> BTreeMap<(String, String, String, String), f64> {
    let mut out = BTreeMap::new();
    let mut r = csv::Reader::from_path(root().join("tests/fixtures/mixed_published/reference.csv")).unwrap();
    for rec in r.records() {
        let rec = rec.unwrap();
        let key = (rec[0].to_string(), rec[1].to_string(), rec[2].to_string(), rec[3].to_string());
        out.insert(key, rec[4].trim().parse().unwrap());
    }
    out
}

fn formulas() -> Vec<(String, String)> {
    let mut r = csv::Reader::from_path(root().join("tests/fixtures/mixed_published/formulas.csv")).unwrap();
    r.records().map(|x| x.unwrap()).map(|x| (x[0].to_string(), x[1].to_string())).collect()
}

fn run(args: &[&str]) -> (i32, String, String) {
    let out = crate::common::bin().current_dir(root()).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn close(name: &str, got: f64, want: f64, rel: f64, abs: f64) {
    assert!((got - want).abs() <= rel * want.abs() + abs, "{name}: crossaudit {got}, R {want}");
}

#[test]
fn mixed_matches_lme4_lmertest_and_pbkrtest_on_twelve_published_data_sets() {
    let r = reference();
    let sets = formulas();
    assert_eq!(sets.len(), 12);
    for (set, formula) in &sets {
        let file = format!("tests/fixtures/mixed_published/{set}.csv");
        for (criterion, flags) in [("reml", vec![]), ("reml_kr", vec!["--df", "kenward-roger"]), ("ml", vec!["--ml"])] {
            let mut args = vec!["mixed", &file, "--formula", formula, "--json"];
            args.extend(flags.iter().copied());
            let (code, stdout, stderr) = run(&args);
            assert_eq!(code, 0, "{set} {criterion}: {stderr}");
            let j: serde_json::Value = serde_json::from_str(&stdout).unwrap();
            let crit = if criterion == "ml" { "ml" } else { "reml" };
            let want = |q: &str, n: &str| r.get(&(set.clone(), crit.into(), q.into(), n.into())).copied();
            let label = |what: &str| format!("{set} {criterion} {what}");
            let fit = &j["fit"];
            assert_eq!(fit["certificate"]["certified"], true, "{}", label("certificate"));
            close(&label("criterion"), fit["deviance"].as_f64().unwrap(), want("criterion", "").unwrap(), 1e-9, 1e-7);
            assert_eq!(
                fit["singular"].as_bool().unwrap(),
                want("singular", "").unwrap() == 1.0,
                "{}",
                label("singular")
            );
            let residual = fit["residual"].as_f64().unwrap();
            close(&label("residual"), residual, want("variance", "Residual").unwrap(), 1e-5, 0.0);
            for (k, factor) in fit["factors"].as_array().unwrap().iter().enumerate() {
                let factor = factor.as_str().unwrap();
                let v = fit["variances"][k].as_f64().unwrap();
                close(&label(factor), v, want("variance", factor).unwrap(), 1e-4, 1e-8 * residual);
            }
            let rows = j["fixed"].as_array().unwrap();
            for row in rows {
                let name = row["name"].as_str().unwrap();
                let est = want("estimate", name).unwrap_or_else(|| panic!("{}: no R coefficient", label(name)));
                let se = want("se", name).unwrap();
                close(&label(&format!("{name} estimate")), row["estimate"].as_f64().unwrap(), est, 1e-6, 1e-6 * se);
                match criterion {
                    "reml" => {
                        close(&label(&format!("{name} se")), row["se"].as_f64().unwrap(), se, 1e-5, 0.0);
                        let df = want("df", name).unwrap();
                        close(&label(&format!("{name} df")), row["df"].as_f64().unwrap(), df, 2e-3, 0.0);
                        let p = want("p", name).unwrap();
                        close(&label(&format!("{name} p")), row["p"].as_f64().unwrap(), p, 2e-3, 1e-12);
                    }
                    "reml_kr" => {
                        let kse = want("kr_se", name).unwrap();
                        close(&label(&format!("{name} KR se")), row["se"].as_f64().unwrap(), kse, 1e-5, 0.0);
                        let kdf = want("kr_df", name).unwrap();
                        close(&label(&format!("{name} KR df")), row["df"].as_f64().unwrap(), kdf, 2e-3, 0.0);
                    }
                    _ => {
                        close(&label(&format!("{name} se")), row["se"].as_f64().unwrap(), se, 1e-5, 0.0);
                        assert!(row["df"].is_null(), "{}", label("ML has no df"));
                    }
                }
            }
            // Every R coefficient is in crossaudit's table.
            let n_r = r.keys().filter(|k| k.0 == *set && k.1 == crit && k.2 == "estimate").count();
            assert_eq!(rows.len(), n_r, "{}", label("coefficient count"));
        }
    }
}

#[test]
fn mixed_summary_reads_like_lme4s_and_flags_a_singular_fit() {
    let (code, stdout, _) =
        run(&["mixed", "tests/fixtures/mixed_published/dyestuff2.csv", "--formula", "Yield ~ 1 + (1|Batch)"]);
    assert_eq!(code, 0);
    // lme4: REML criterion at convergence: 161.8283 (summary(lmer(Yield ~ 1 + (1|Batch), Dyestuff2))).
    assert!(stdout.contains("REML criterion at convergence: 161.8283"), "{stdout}");
    assert!(stdout.contains("boundary (singular) fit"), "{stdout}");
    assert!(stdout.contains("optimum certified"), "{stdout}");
}

/// A random term written twice is fitted once, and the fit says so in
/// its notes (the summary's and the JSON's): two copies of `(1|plate)`
/// give Z D Z' with D the sum of their variances, so lme4 fits the same
/// likelihood with that sum split between the copies. The fit is the
/// single term's (itself checked against lme4 on Penicillin above), and
/// the note says why it differs from lme4's table.
#[test]
fn a_random_term_written_twice_is_fitted_once_and_said_so() -> Result<(), Box<dyn std::error::Error>> {
    let file = "tests/fixtures/mixed_published/penicillin.csv";
    let once = "diameter ~ 1 + (1|plate) + (1|sample)";
    let twice = "diameter ~ 1 + (1|plate) + (1|sample) + (1 | plate)";
    let note = "a random term written more than once is fitted once (lme4 fits each copy";
    let (code, single, stderr) = run(&["mixed", file, "--formula", once, "--json"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(!single.contains(note), "{single}");
    let (code, double, stderr) = run(&["mixed", file, "--formula", twice, "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let (mut single, mut double): (serde_json::Value, serde_json::Value) =
        (serde_json::from_str(&single)?, serde_json::from_str(&double)?);
    assert!(single["fit"].is_object(), "{single}");
    let notes = double["fit"]["notes"].as_array().ok_or("the fit's notes")?.clone();
    assert!(notes.iter().any(|n| n.as_str().is_some_and(|n| n.starts_with(note))), "{notes:?}");
    // Beside the note, the same fit.
    single["fit"]["notes"] = serde_json::json!([]);
    double["fit"]["notes"] = serde_json::json!([]);
    assert_eq!(single["fit"], double["fit"]);
    let (code, summary, stderr) = run(&["mixed", file, "--formula", twice]);
    assert_eq!(code, 0, "{stderr}");
    assert!(summary.contains(&format!("note: {note}")), "{summary}");
    Ok(())
}

/// A random-slope fit through the real binary: lme4's summary of
/// `lmer(Reaction ~ Days + (Days | Subject), sleepstudy)` prints "REML
/// criterion at convergence: 1743.6", Subject's variances 612.09 and
/// 35.07 with correlation 0.066, and lmerTest's df 17 for both fixed
/// effects, and pbkrtest's Kenward-Roger df 17 too
/// (scripts/reference/mixed_slopes.R gives every digit); what is computed
/// for random intercepts only is refused by name.
#[test]
fn mixed_fits_random_slopes_and_refuses_what_it_does_not_compute_for_them() {
    let file = "tests/fixtures/slopes_sleepstudy.csv";
    let formula = "Reaction ~ Days + (Days | Subject)";
    let (code, stdout, stderr) = run(&["mixed", file, "--formula", formula]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("REML criterion at convergence: 1743.6283"), "{stdout}");
    let row = |name: &str| {
        let mut table = stdout.lines().skip_while(|l| !l.starts_with("Random effects:"));
        table.find(|l| l.split_whitespace().any(|w| w == name)).unwrap_or("")
    };
    let number = |line: &str, at: usize| line.split_whitespace().nth(at).and_then(|v| v.parse::<f64>().ok());
    let intercept = number(row("(Intercept)"), 2).unwrap_or(f64::NAN);
    let slope = number(row("Days"), 1).unwrap_or(f64::NAN);
    assert!(row("(Intercept)").starts_with(" Subject") && (intercept - 612.0897).abs() < 1e-3, "{stdout}");
    assert!((slope - 35.0717).abs() < 1e-3 && row("Days").ends_with(" 0.066"), "{stdout}");
    assert!(stdout.contains("optimum certified"), "{stdout}");
    let (code, json, _) = run(&["mixed", file, "--formula", formula, "--json"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["fit"]["terms"][0]["names"][1], "Days");
    let df = v["fixed"][1]["df"].as_f64().unwrap();
    assert!((df - 17.0).abs() < 1e-3, "{df}");
    // pbkrtest: Kenward-Roger df 17 for both (scripts/reference/mixed_slopes.R).
    let (code, json, _) = run(&["mixed", file, "--formula", formula, "--df", "kenward-roger", "--json"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let df = v["fixed"][1]["df"].as_f64().unwrap();
    assert!((df - 17.0).abs() < 1e-3, "{df}");
    let (code, _, stderr) = run(&["mixed", file, "--formula", formula, "--profile", "0.95"]);
    assert_eq!(code, 1, "{stderr}");
    let message = "--profile is computed for random-intercept models only";
    assert!(stderr.contains(file) && stderr.contains(message), "{stderr}");
}

/// A binomial GLMM through the real binary: lme4's
/// `glmer(cbind(incidence, size - incidence) ~ period + (1 | herd), cbpp,
/// binomial)` prints deviance 184.1 and herd's variance 0.4123
/// (scripts/reference/glmm_reference.R gives every digit), and with
/// `--profile` lme4's profile intervals of its fixed effects
/// (scripts/reference/glmm_profile.R: period2 in [-1.6167, -0.4078]); what
/// a GLMM does not compute, and a binomial response given to a linear
/// model, are refused by name, and a response that is not 0/1 by its row
/// and field.
#[test]
fn mixed_fits_a_binomial_glmm_and_refuses_what_it_does_not_compute() {
    let file = "tests/fixtures/glmm_cbpp.csv";
    let formula = "cbind(incidence, healthy) ~ factor(period) + (1 | herd)";
    let (code, stdout, stderr) = run(&["mixed", file, "--formula", formula, "--family", "binomial"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("Family: binomial  ( logit )"), "{stdout}");
    assert!(stdout.contains("  184.0526 "), "{stdout}");
    assert!(stdout.contains("0.412"), "{stdout}");
    assert!(stdout.contains("optimum certified"), "{stdout}");
    let (code, stdout, stderr) =
        run(&["mixed", file, "--formula", formula, "--family", "binomial", "--profile", "0.95"]);
    assert_eq!(code, 0, "{stderr}");
    let line = stdout.lines().find(|l| l.trim_start().starts_with("factor(period)2 [")).unwrap_or("");
    assert!(line.contains("[-1.616") && line.contains(", -0.407"), "{stdout}");
    for (args, message) in [
        (
            vec!["--family", "binomial", "--df", "kenward-roger"],
            "--df kenward-roger is computed for linear mixed models only",
        ),
        (
            vec!["--family", "poisson", "--compare", "incidence ~ 1 + (1|herd)"],
            "--compare is computed for linear mixed models only",
        ),
        (vec![], "cbind(successes, failures) is the response of a binomial model: add --family binomial"),
    ] {
        let mut all = vec!["mixed", file, "--formula", formula];
        all.extend(args);
        let (code, _, stderr) = run(&all);
        assert_eq!(code, 1, "{stderr}");
        assert!(stderr.contains(file) && stderr.contains(message), "{stderr}");
    }
    let (code, _, stderr) =
        run(&["mixed", file, "--formula", "incidence ~ factor(period) + (1 | herd)", "--family", "binomial"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("row 1, field incidence") && stderr.contains("cbind(successes, failures)"), "{stderr}");
}

#[test]
fn mixed_refuses_bad_formulas_and_tables_with_located_errors() {
    let file = "tests/fixtures/mixed_published/penicillin.csv";
    let cases: &[(&str, &str)] = &[
        ("diameter ~ 1 + (1|plates)", "unknown column `plates`"),
        ("diameter ~ 1 + (plate|sample)", "the random term of sample has 24 columns; a term may have 1 to 8"),
        ("diameter ~ 1 + (0|plate)", "column 18: a random term needs an intercept or a slope"),
        ("diameter ~ 1 + (1 - sample|plate)", "column 19: removing terms (`-`) is not supported"),
        ("diameter ~ 1 + (|plate)", "column 17: expected `1`, `0` or a column before `|`"),
        ("diameter ~ 1 + (sample plate)", "column 24: expected `+` or `|` in the random term"),
        ("diameter ~ 0 + (1|plate)", "column 12: a model without an intercept"),
        ("diameter ~ 1 + (1|plate", "column 24: expected `)` to close the random term"),
        ("diameter 1 + (1|plate)", "column 10: expected `~`"),
        ("diameter ~ 1", "a mixed model needs a random term"),
        ("diameter ~ 1 + log(plate) + (1|plate)", "column 16: transformations such as `log(...)` are not supported"),
        ("log(diameter) ~ 1 + (1|plate)", "column 1: transformations such as `log(...)` are not supported"),
        ("diameter ~ 1 + poly(sample, 2) + (1|plate)", "compute the transformed column in the CSV first"),
        ("diameter ~ 1 + I(sample^2) + (1|plate)", "column 16: transformations such as `I(...)`"),
        ("diameter ~ 1 + sample^2 + (1|plate)", "column 22: powers (`^`) are not supported"),
        ("plate ~ 1 + (1|sample)", "row 1, field plate: the response must be a number"),
        (
            "diameter ~ a*b*c*d*e*f*g*h*i*j*k*l + (1|plate)",
            "column 36: 12 variables crossed with `*` make 4095 terms; at most 10 may be crossed",
        ),
        ("diameter ~ 1 + (1|a/b/c/d/e/f/g/h/i/j/k/l/m/n/o/p/q)", "column 53: 17 random-intercept terms; at most 16"),
    ];
    for (formula, message) in cases {
        let (code, _, stderr) = run(&["mixed", file, "--formula", formula]);
        assert_eq!(code, 1, "{formula}: {stderr}");
        assert!(stderr.contains(file) && stderr.contains(message), "{formula}: {stderr}");
        assert!(!stderr.contains("panicked"), "{formula}: {stderr}");
    }
}

/// lme4 refuses a grouping factor with as many levels as observations
/// ("number of levels of each grouping factor must be < number of
/// observations"): its variance cannot be told from the residual's. So
/// does crossaudit, where it used to split the variance arbitrarily; and
/// a factor that groups exactly as another does.
#[test]
fn unidentifiable_random_factors_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("d.csv");
    let mut text = String::from("y,a,obs,b\n");
    for i in 0..24 {
        text.push_str(&format!("{},{},{},{}\n", (i * 7 % 11) as f64 + 0.5 * (i % 3) as f64, i % 6, i, 10 + i % 6));
    }
    std::fs::write(&file, text).unwrap();
    let f = file.to_str().unwrap();
    let (code, _, stderr) = run(&["mixed", f, "--formula", "y ~ 1 + (1|a) + (1|obs)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("factor obs is not identifiable: it has 24 levels for 24 observations"), "{stderr}");
    let (code, _, stderr) = run(&["mixed", f, "--formula", "y ~ 1 + (1|a) + (1|b)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("factor b is not identifiable: it groups the observations exactly as factor a"),
        "{stderr}"
    );
    let (code, _, stderr) = run(&["mixed", f, "--formula", "y ~ 1 + (1|a:obs) + (1|a)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("factor a:obs is not identifiable"), "{stderr}");
}

/// Two crossed factors of 30,000 levels each (the intercept engine's dense
/// reduced system would be 30,001 square, 7.2 GB) are fitted by the sparse
/// factor instead, as lme4 fits them, with a note that says so (issue 75),
/// to lmer's REML criterion, intercept and SE
/// (scripts/reference/mixed_sparse_intercepts.R);
/// Kenward-Roger df over every level and a categorical fixed effect with
/// 30,000 levels are still refused before anything is allocated.
#[test]
fn a_model_too_large_for_memory_is_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("big.csv");
    let mut text = String::from("y,a,b\n");
    for i in 0..60_000usize {
        text.push_str(&format!("{},{},{}\n", (i * 37 % 101) as f64, i % 30_000, (i * 7 + i / 30_000) % 30_000));
    }
    std::fs::write(&file, text).unwrap();
    let f = file.to_str().unwrap();
    let (code, stdout, stderr) = run(&["mixed", f, "--formula", "y ~ 1 + (1|a) + (1|b)"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("so the model is fitted with the sparse Cholesky factor over every level"), "{stdout}");
    assert!(stdout.contains("Number of obs: 60000, groups:  a, 30000; b, 30000"), "{stdout}");
    // Against lmer on the same data (scripts/reference/mixed_sparse_intercepts.R).
    let reference = std::fs::read_to_string(root().join("scripts/reference/mixed_sparse_intercepts.out")).unwrap();
    let line = |key: &str| -> Vec<f64> {
        let l = reference.lines().find(|l| l.starts_with(&format!("{key} "))).unwrap();
        l.split_whitespace().skip(1).map(|w| w.parse().unwrap()).collect()
    };
    let (code, json, stderr) = run(&["mixed", f, "--json", "--formula", "y ~ 1 + (1|a) + (1|b)"]);
    assert_eq!(code, 0, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&json).unwrap();
    let reml = json["likelihood"]["reml_criterion"].as_f64().unwrap();
    assert!(reml <= line("reml")[0] * (1.0 + 1e-12), "{reml} above lmer's {}", line("reml")[0]);
    close("REML criterion", reml, line("reml")[0], 1e-10, 0.0);
    let fixed = &json["fixed"][0];
    close("intercept", fixed["estimate"].as_f64().unwrap(), line("intercept")[0], 1e-9, 0.0);
    close("intercept SE", fixed["se"].as_f64().unwrap(), line("intercept")[1], 1e-5, 0.0);
    let (code, _, stderr) = run(&["mixed", f, "--formula", "y ~ 1 + (1|a) + (1|b)", "--df", "kenward-roger"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("the model is too large: the random factors but the largest have 30000 levels"),
        "{stderr}"
    );
    let (code, _, stderr) = run(&["mixed", f, "--formula", "y ~ factor(a) + (1|b)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("the model is too large: the categorical variable a has 30000 levels"), "{stderr}");
}

/// A byte-order mark is not part of the first column's name, and a header
/// that names a column twice is refused (which of the two would be used?).
#[test]
fn mixed_reads_a_bom_and_refuses_a_repeated_column_name() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("tests/fixtures/mixed_published/penicillin.csv")).unwrap();
    let bom = dir.path().join("bom.csv");
    std::fs::write(&bom, format!("\u{feff}{text}")).unwrap();
    let (code, stdout, stderr) =
        run(&["mixed", bom.to_str().unwrap(), "--formula", "diameter ~ 1 + (1|plate) + (1|sample)"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("Number of obs: 144"), "{stdout}");
    let twice = dir.path().join("twice.csv");
    std::fs::write(&twice, text.replacen("sample", "plate", 1)).unwrap();
    let (code, _, stderr) = run(&["mixed", twice.to_str().unwrap(), "--formula", "diameter ~ 1 + (1|plate)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("row 0, field plate: the header names column `plate` twice (fields 2 and 3)"), "{stderr}");
}

/// What `crossaudit mixed` reads is held to the rules of every input: a
/// FIFO is refused before it is opened (opening it would block), a
/// symbolic link to /dev/zero is refused (it would be read until memory
/// runs out), and a closed standard output ends quietly.
#[test]
fn mixed_refuses_a_fifo_and_a_device_and_survives_a_closed_pipe() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("fifo.csv");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let (code, _, stderr) = run(&["mixed", fifo.to_str().unwrap(), "--formula", "y ~ 1 + (1|a)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("fifo.csv") && stderr.contains("FIFO"), "{stderr}");
    let zero = dir.path().join("zero.csv");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    let (code, _, stderr) = run(&["mixed", zero.to_str().unwrap(), "--formula", "y ~ 1 + (1|a)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("/dev/zero"), "{stderr}");
    let mut child = crate::common::bin()
        .current_dir(root())
        .args(["mixed", "tests/fixtures/mixed_published/penicillin.csv", "--formula", "diameter ~ 1 + (1|plate)"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"), "{}", String::from_utf8_lossy(&out.stderr));
}

/// `"quantity","name","value"` rows of scripts/reference/mixed_inputs.out
/// (R 4.2.2, lme4 1.1.31; the script is beside it).
fn input_reference() -> Vec<(String, String, String)> {
    let mut r = csv::Reader::from_path(root().join("scripts/reference/mixed_inputs.out")).unwrap();
    r.records().map(|x| x.unwrap()).map(|x| (x[0].to_string(), x[1].to_string(), x[2].to_string())).collect()
}

/// Issue 39, task 1: a factor of a numeric column has R's levels. R's
/// `factor()` of the numbers 1, 1.0 and 1e0 is one level labelled `1`, its
/// levels sorted by value (1, 2, 10, not the text order 1, 10, 2); each
/// level's label is R's `as.character` of the number.
#[test]
fn a_factor_of_a_numeric_column_has_rs_levels_and_labels() {
    let r = input_reference();
    let labels: Vec<_> = r.iter().filter(|(q, _, _)| q == "label").collect();
    assert!(labels.len() >= 20);
    for (_, number, label) in labels {
        let v: f64 = number.parse().unwrap();
        assert_eq!(crossaudit::stats::mixed::formula::r_number_label(v), *label, "as.character({number})");
    }
    let file = "tests/fixtures/mixed_inputs/spellings.csv";
    let (code, stdout, stderr) = run(&["mixed", file, "--formula", "y ~ factor(d) + (1|g)", "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let j: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let rows = j["fixed"].as_array().unwrap();
    let want = |q: &str, n: &str| -> f64 {
        r.iter().find(|(a, b, _)| a == q && b == n).unwrap_or_else(|| panic!("R has no {q} {n}")).2.parse().unwrap()
    };
    let names: Vec<&str> = rows.iter().map(|x| x["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["(Intercept)", "factor(d)2", "factor(d)10"], "R: levels {:?}", want("criterion", "REML"));
    for row in rows {
        let name = row["name"].as_str().unwrap();
        close(name, row["estimate"].as_f64().unwrap(), want("estimate", name), 1e-6, 1e-9);
        close(name, row["se"].as_f64().unwrap(), want("se", name), 1e-5, 0.0);
    }
    close("REML criterion", j["fit"]["deviance"].as_f64().unwrap(), want("criterion", "REML"), 1e-9, 0.0);
}

/// Issue 39, task 1: inputs that used to give a wrong fit or blame the
/// wrong thing are refused with a message that names the row and column
/// (a control character in a label, values whose sums overflow) or the
/// formula's column (the response among the predictors).
#[test]
fn control_characters_the_response_as_predictor_and_overflow_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path.to_str().unwrap().to_string()
    };
    let nul = write("nul.csv", "y,d,g\n1.5,a,a\n2.5,c,a\n3.1,a\0b,b\n4.2,c,b\n2.2,a,c\n3.3,c,c\n2.9,a,a\n");
    let (code, _, stderr) = run(&["mixed", &nul, "--formula", "y ~ d + (1|g)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("row 3, field d: the value contains the control character U+0000 at character 2"),
        "{stderr}"
    );
    let esc = write("esc.csv", "y,d,g\n1.5,a,a\n2.5,c,a\n3.1,a,b\n4.2,c,b\n2.2,a,c\n3.3,c,c\n2.9,a,\u{1b}a\n");
    let (code, _, stderr) = run(&["mixed", &esc, "--formula", "y ~ d + (1|g)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("row 7, field g: the value contains the control character U+001B at character 1"),
        "{stderr}"
    );
    let file = "tests/fixtures/mixed_inputs/spellings.csv";
    for (formula, column) in [("y ~ y + (1|g)", 5), ("y ~ d + factor(y) + (1|g)", 16), ("y ~ d:y + (1|g)", 7)] {
        let (code, _, stderr) = run(&["mixed", file, "--formula", formula]);
        assert_eq!(code, 1, "{formula}: {stderr}");
        let want = format!("formula, column {column}: the response `y` appears among the predictors");
        assert!(stderr.contains(&want) && !stderr.contains("random factors"), "{formula}: {stderr}");
    }
    let (code, _, stderr) = run(&["mixed", file, "--formula", "y ~ d + (1|y)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("column 12: the response `y` appears as a grouping factor"), "{stderr}");
    let big = write(
        "big.csv",
        "y,x,g\n1e305,1,a\n1.7e305,2,a\n1.2e305,3,b\n1.5e305,4,b\n1.1e305,5,c\n1.9e305,6,c\n1.3e305,7,a\n",
    );
    let (code, _, stderr) = run(&["mixed", &big, "--formula", "y ~ 1 + (1|g)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("column y: its values are too large for double precision: the sum of their squares overflows (largest |value| 1.9e305, row 6)")
            && !stderr.contains("random factors"),
        "{stderr}"
    );
    let (code, _, stderr) = run(&["mixed", &big, "--formula", "x ~ y + (1|g)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("column y: its values are too large for double precision"), "{stderr}");
}

/// Issue 39, task 1: `crossaudit mixed ... >&-` wrote the fit nowhere and
/// exited 0 (Rust's runtime opens /dev/null in place of a closed standard
/// output, so every write succeeds); it must fail. `> /dev/null`, a
/// deliberate discard, still succeeds.
#[test]
fn mixed_with_standard_output_closed_fails() {
    let bin = env!("CARGO_BIN_EXE_crossaudit");
    let args = ["mixed", "tests/fixtures/mixed_published/penicillin.csv", "--formula", "diameter ~ 1 + (1|plate)"];
    for (redirect, ok) in [(">&-", false), ("> /dev/null", true)] {
        let out = Command::new("sh")
            .current_dir(root())
            .arg("-c")
            .arg(format!("exec \"$0\" \"$@\" {redirect}"))
            .arg(bin)
            .args(args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        if ok {
            assert_eq!(out.status.code(), Some(0), "{redirect}: {stderr}");
        } else {
            assert_eq!(out.status.code(), Some(1), "{redirect}: {stderr}");
            assert!(stderr.contains("standard output is closed"), "{stderr}");
        }
    }
}

/// Issue 39, task 2: profile-likelihood intervals agree with an exact
/// profile to 1e-5 relative, REML and ML, on nlme's Gun
/// (`rounds ~ Method + (1|Team)`), OrchardSprays as a crossed Latin square
/// and nlme's Assay (split-block: Block, Block:sample, Block:dilut). The
/// exact profile is scripts/reference/mixed_profile.R: lme4's own deviance
/// function, each point minimised by BOBYQA to rhoend 1e-12 with restarts,
/// each limit by uniroot to 1e-13 (output: mixed_profile.out). The upper
/// limit of the residual SD was 0.26% (REML) and 0.43% (ML) short on
/// OrchardSprays: the inner search, restarted from a point where both
/// factor SDs were zero, never left zero.
#[test]
fn profile_intervals_agree_with_an_exact_profile() {
    let mut r = csv::Reader::from_path(root().join("scripts/reference/mixed_profile.out")).unwrap();
    let mut want: BTreeMap<(String, String, String), (f64, f64, f64)> = BTreeMap::new();
    for rec in r.records() {
        let rec = rec.unwrap();
        let v = |i: usize| rec[i].trim().parse::<f64>().unwrap();
        want.insert((rec[0].to_string(), rec[1].to_string(), rec[2].to_string()), (v(3), v(4), v(5)));
    }
    assert_eq!(want.len(), 18);
    let sets = [
        ("gun", "rounds ~ Method + (1|Team)"),
        ("orchardsprays", "decrease ~ treatment + (1|rowpos) + (1|colpos)"),
        ("assay", "logDens ~ sample * factor(dilut) + (1|Block) + (1|Block:sample) + (1|Block:dilut)"),
    ];
    let mut checked = 0;
    for (set, formula) in sets {
        let file = format!("tests/fixtures/mixed_profile/{set}.csv");
        for criterion in ["reml", "ml"] {
            let mut args = vec!["mixed", &file, "--formula", formula, "--profile", "0.95", "--json"];
            if criterion == "ml" {
                args.push("--ml");
            }
            let (code, stdout, stderr) = run(&args);
            assert_eq!(code, 0, "{set} {criterion}: {stderr}");
            let j: serde_json::Value = serde_json::from_str(&stdout).unwrap();
            for i in j["profile"][1].as_array().unwrap() {
                let name = i["name"].as_str().unwrap();
                let (est, lower, upper) = want[&(set.to_string(), criterion.to_string(), name.to_string())];
                let label = |what: &str| format!("{set} {criterion} {name} {what}");
                close(&label("estimate"), i["estimate"].as_f64().unwrap(), est, 1e-4, 0.0);
                close(&label("lower"), i["lower"].as_f64().unwrap(), lower, 1e-5, 0.0);
                close(&label("upper"), i["upper"].as_f64().unwrap(), upper, 1e-5, 0.0);
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 18);
}

/// Issue 39, task 3: rank-deficient fixed effects are fitted as lme4 fits
/// them, the aliased columns dropped (lme4's chkRank.drop.cols) and named:
/// lme4's cake without the cell recipe C x temp 215 (`recipe *
/// factor(temp)`: `recipeC:factor(temp)215` has no data) and R's CO2 with
/// `Type:Treatment` without its margins (five columns of rank four).
/// Expected: scripts/reference/mixed_rank.R (lme4 1.1.31), output
/// committed in mixed_rank.out; REML and ML.
#[test]
fn rank_deficient_fixed_effects_are_dropped_as_lme4_drops_them() {
    let mut r = csv::Reader::from_path(root().join("scripts/reference/mixed_rank.out")).unwrap();
    let rows: Vec<Vec<String>> = r.records().map(|x| x.unwrap().iter().map(String::from).collect()).collect();
    let sets = [
        (
            "cake_empty_cell",
            "tests/fixtures/mixed_rank/cake_empty_cell.csv",
            "angle ~ recipe * factor(temp) + (1|replicate)",
        ),
        ("co2_no_margins", "tests/fixtures/mixed_rank/co2.csv", "uptake ~ Type:Treatment + (1|Plant)"),
    ];
    for (set, file, formula) in sets {
        for criterion in ["reml", "ml"] {
            let of = |q: &str| -> Vec<(String, String)> {
                rows.iter()
                    .filter(|x| x[0] == set && x[1] == criterion && x[2] == q)
                    .map(|x| (x[3].clone(), x[4].clone()))
                    .collect()
            };
            let label = |what: &str| format!("{set} {criterion} {what}");
            let mut args = vec!["mixed", file, "--formula", formula];
            if criterion == "ml" {
                args.push("--ml");
            }
            let (code, text, stderr) = run(&args);
            assert_eq!(code, 0, "{}: {stderr}", label("text"));
            let message = &of("message")[0].1;
            assert!(message.starts_with("fixed-effect model matrix is rank deficient"), "{message}");
            let dropped: Vec<String> = of("dropped").into_iter().map(|x| x.0).collect();
            assert!(text.contains(&format!("{message}: {}", dropped.join(", "))), "{text}");
            args.push("--json");
            let (code, stdout, stderr) = run(&args);
            assert_eq!(code, 0, "{}: {stderr}", label("json"));
            let j: serde_json::Value = serde_json::from_str(&stdout).unwrap();
            let got: Vec<&str> = j["fit"]["dropped"].as_array().unwrap().iter().map(|x| x.as_str().unwrap()).collect();
            assert_eq!(got, dropped, "{}", label("dropped"));
            let names: Vec<&str> = j["fixed"].as_array().unwrap().iter().map(|x| x["name"].as_str().unwrap()).collect();
            let want_names: Vec<String> = of("estimate").into_iter().map(|x| x.0).collect();
            assert_eq!(names, want_names, "{}", label("names"));
            let want = |q: &str, n: &str| -> f64 { of(q).into_iter().find(|x| x.0 == n).unwrap().1.parse().unwrap() };
            for row in j["fixed"].as_array().unwrap() {
                let name = row["name"].as_str().unwrap();
                close(&label(name), row["estimate"].as_f64().unwrap(), want("estimate", name), 1e-6, 1e-8);
                close(&label(name), row["se"].as_f64().unwrap(), want("se", name), 1e-5, 0.0);
            }
            close(&label("criterion"), j["fit"]["deviance"].as_f64().unwrap(), want("criterion", ""), 1e-9, 0.0);
        }
    }
}

/// Issue 39, task 4: R's names. An interaction's variables come in order
/// of their first appearance in the formula (`Type + conc:Type` gives
/// `TypeMississippi:conc`, `Treatment:conc:Type` after `conc + Type` gives
/// `conc:TypeMississippi:Treatmentchilled`), and `(1|a/b)` is lme4's
/// `(1|a) + (1|b:a)` (`(1|a/b/c)`: `a`, `b:a`, `c:(b:a)`; `(1|a/b:c)`:
/// `a`, `b:c:a`). Expected: scripts/reference/mixed_names.R (lme4
/// 1.1.31), output committed in mixed_names.out: fixed-effect names in R's
/// order with their estimates, random terms with their variances.
#[test]
fn fixed_and_random_terms_have_rs_names() {
    let mut r = csv::Reader::from_path(root().join("scripts/reference/mixed_names.out")).unwrap();
    let rows: Vec<Vec<String>> = r.records().map(|x| x.unwrap().iter().map(String::from).collect()).collect();
    let mut cases: Vec<(String, String)> = rows.iter().map(|x| (x[0].clone(), x[1].clone())).collect();
    cases.dedup();
    assert_eq!(cases.len(), 7);
    for (case, file) in &cases {
        let of = |q: &str| -> Vec<(String, String)> {
            rows.iter().filter(|x| &x[0] == case && x[2] == q).map(|x| (x[3].clone(), x[4].clone())).collect()
        };
        let formula = &of("formula")[0].1;
        let (code, stdout, stderr) = run(&["mixed", file, "--formula", formula, "--json"]);
        assert_eq!(code, 0, "{case}: {stderr}");
        let j: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        let fixed = j["fixed"].as_array().unwrap();
        let names: Vec<&str> = fixed.iter().map(|x| x["name"].as_str().unwrap()).collect();
        let want: Vec<(String, String)> = of("fixed");
        assert_eq!(names, want.iter().map(|x| x.0.as_str()).collect::<Vec<_>>(), "{case}: fixed-effect names");
        for (row, (name, value)) in fixed.iter().zip(&want) {
            close(&format!("{case} {name}"), row["estimate"].as_f64().unwrap(), value.parse().unwrap(), 1e-6, 1e-9);
        }
        let fit = &j["fit"];
        let residual = fit["residual"].as_f64().unwrap();
        let random = of("random");
        let mut factors: Vec<&str> = fit["factors"].as_array().unwrap().iter().map(|x| x.as_str().unwrap()).collect();
        let mut want_factors: Vec<&str> = random.iter().map(|x| x.0.as_str()).filter(|n| *n != "Residual").collect();
        factors.sort();
        want_factors.sort();
        assert_eq!(factors, want_factors, "{case}: random terms");
        for (k, name) in fit["factors"].as_array().unwrap().iter().enumerate() {
            let name = name.as_str().unwrap();
            let want: f64 = random.iter().find(|x| x.0 == name).unwrap().1.parse().unwrap();
            close(&format!("{case} {name}"), fit["variances"][k].as_f64().unwrap(), want, 1e-4, 1e-6 * residual);
        }
        close(
            &format!("{case} criterion"),
            fit["deviance"].as_f64().unwrap(),
            of("criterion")[0].1.parse().unwrap(),
            1e-9,
            0.0,
        );
    }
}

/// Issue 39, task 5: the likelihood summary lme4 users look for, and
/// `--compare`, lme4's `anova(m1, m2)` (both models refitted by ML), on
/// sleepstudy (a fixed slope), Penicillin (a random term) and Machines (a
/// fixed factor beside nested random terms). Expected:
/// scripts/reference/mixed_compare.R (lme4 1.1.31), output committed in
/// mixed_compare.out.
#[test]
fn loglik_aic_bic_and_the_likelihood_ratio_test_match_lme4() {
    let mut r = csv::Reader::from_path(root().join("scripts/reference/mixed_compare.out")).unwrap();
    let rows: Vec<Vec<String>> = r.records().map(|x| x.unwrap().iter().map(String::from).collect()).collect();
    let mut sets: Vec<String> = rows.iter().map(|x| x[0].clone()).collect();
    sets.dedup();
    assert_eq!(sets, ["sleepstudy", "penicillin", "machines"]);
    for set in &sets {
        let get = |q: &str, n: &str| -> String {
            rows.iter().find(|x| &x[0] == set && x[1] == q && x[2] == n).unwrap_or_else(|| panic!("{set} {q} {n}"))[3]
                .clone()
        };
        let num = |q: &str, n: &str| -> f64 { get(q, n).parse().unwrap() };
        let file = format!("tests/fixtures/mixed_published/{set}.csv");
        let (large, small) = (get("formula", "large"), get("formula", "small"));
        for criterion in ["reml", "ml"] {
            let mut args = vec!["mixed", &file, "--formula", &large, "--json"];
            if criterion == "ml" {
                args.push("--ml");
            }
            let (code, stdout, stderr) = run(&args);
            assert_eq!(code, 0, "{set} {criterion}: {stderr}");
            let j: serde_json::Value = serde_json::from_str(&stdout).unwrap();
            let l = &j["likelihood"];
            let label = |what: &str| format!("{set} {criterion} {what}");
            assert_eq!(l["npar"].as_f64().unwrap(), num(criterion, "npar"), "{}", label("npar"));
            assert_eq!(l["df_resid"].as_f64().unwrap(), num(criterion, "df.resid"), "{}", label("df.resid"));
            close(&label("logLik"), l["loglik"].as_f64().unwrap(), num(criterion, "logLik"), 1e-9, 0.0);
            close(&label("AIC"), l["aic"].as_f64().unwrap(), num(criterion, "AIC"), 1e-9, 0.0);
            close(&label("BIC"), l["bic"].as_f64().unwrap(), num(criterion, "BIC"), 1e-9, 0.0);
            let (field, name) =
                if criterion == "ml" { ("deviance", "deviance") } else { ("reml_criterion", "REMLcrit") };
            close(&label(name), l[field].as_f64().unwrap(), num(criterion, name), 1e-9, 0.0);
            // The text output prints them too (to 4 decimals, as here).
            args.retain(|a| *a != "--json");
            let (_, text, _) = run(&args);
            assert!(text.contains(&format!("{:.4}", num(criterion, "AIC"))), "{}: {text}", label("text AIC"));
            assert!(text.contains(&format!("{:.4}", num(criterion, "logLik"))), "{}: {text}", label("text logLik"));
        }
        let (code, stdout, stderr) = run(&["mixed", &file, "--formula", &large, "--compare", &small, "--json"]);
        assert_eq!(code, 0, "{set} compare: {stderr}");
        let j: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        let models = j["models"].as_array().unwrap();
        assert_eq!(models.len(), 2);
        for (m, row) in models.iter().zip(["anova_small", "anova_large"]) {
            let label = |what: &str| format!("{set} {row} {what}");
            assert_eq!(m["npar"].as_f64().unwrap(), num(row, "npar"), "{}", label("npar"));
            for (field, name) in [("aic", "AIC"), ("bic", "BIC"), ("loglik", "logLik"), ("deviance", "deviance")] {
                close(&label(name), m[field].as_f64().unwrap(), num(row, name), 1e-9, 0.0);
            }
            if get(row, "Chisq") == "NA" {
                assert!(m["chisq"].is_null() && m["df"].is_null() && m["p"].is_null(), "{}", label("first row"));
            } else {
                close(&label("Chisq"), m["chisq"].as_f64().unwrap(), num(row, "Chisq"), 1e-6, 1e-7);
                assert_eq!(m["df"].as_f64().unwrap(), num(row, "Df"), "{}", label("Df"));
                close(&label("p"), m["p"].as_f64().unwrap(), num(row, "Pr(>Chisq)"), 1e-5, 1e-300);
            }
        }
        let (code, text, stderr) = run(&["mixed", &file, "--formula", &large, "--compare", &small]);
        assert_eq!(code, 0, "{stderr}");
        assert!(text.contains("Pr(>Chisq)") && text.contains(&format!("m2: {large}")), "{text}");
    }
    // Two different responses cannot be compared.
    let (code, _, stderr) = run(&[
        "mixed",
        "tests/fixtures/mixed_published/sleepstudy.csv",
        "--formula",
        "Reaction ~ Days + (1|Subject)",
        "--compare",
        "Days ~ 1 + (1|Subject)",
    ]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("--compare: the two formulas model different responses"), "{stderr}");
}

/// A random term whose variances cannot be identified is refused, naming
/// the term and the column: a slope on a constant column (the intercept
/// again), two collinear slopes, a factor slope with one level. Before,
/// each was certified and printed one arbitrary set of variances.
#[test]
fn a_random_term_whose_columns_cannot_be_told_apart_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("d.csv");
    let mut text = String::from("y,x,x2,c,f,g\n");
    for g in 0..8 {
        for k in 0..6 {
            let x = k as f64;
            let y = 1.0 + 0.5 * x + (g as f64) * 0.3 + ((g * 7 + k * 3) % 5) as f64 * 0.1;
            text += &format!("{y},{x},{},3,only,g{g}\n", 2.0 * x + 1.0);
        }
    }
    std::fs::write(&path, text).unwrap();
    let p = path.to_str().unwrap();
    for (formula, needle) in [
        ("y ~ x + (c | g)", "random term (1 + c | g): its column c is constant (3 in every row)"),
        ("y ~ x + (x + x2 | g)", "random term (1 + x + x2 | g): its column x2 is a linear combination"),
        ("y ~ x + (f | g)", "its slope gives no column (a factor with one level)"),
    ] {
        let (code, _, err) = run(&["mixed", p, "--formula", formula]);
        assert_eq!(code, 1, "{formula}: {err}");
        assert!(err.contains(needle), "{formula}: {err}");
    }
    // The identified model fits.
    let (code, _, err) = run(&["mixed", p, "--formula", "y ~ x + (x | g)"]);
    assert_eq!(code, 0, "{err}");
}

/// A Poisson count above 1e15 is named as too large for an exact
/// likelihood, not as "not a whole number".
#[test]
fn a_count_beyond_exact_doubles_is_named_as_too_large() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.csv");
    let mut text = String::from("y,g\n");
    for k in 0..12 {
        text += &format!("{},g{}\n", if k == 5 { "1.002e15".to_string() } else { (k % 4).to_string() }, k % 3);
    }
    std::fs::write(&path, text).unwrap();
    let (code, _, err) = run(&["mixed", path.to_str().unwrap(), "--formula", "y ~ 1 + (1 | g)", "--family", "poisson"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("row 6, field y: `1.002e15` is larger than 1e15"), "{err}");
    assert!(!err.contains("not a whole number"), "{err}");
}

/// Issue 75, item 3: separation is found from the data, not from where
/// the optimizer stopped. By construction (a closed form): y = 1 exactly
/// where x > 0.3, so x (and the intercept with it: the split point may
/// move) run to infinity; the fit is reported, not certified, with the
/// separated coefficients named, and `--profile` is refused at once
/// instead of searching for a bound that is not there. A level of a
/// factor with no success separates its indicator alone.
#[test]
fn separated_data_are_named_and_profile_refuses_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("sep.csv");
    let mut text = String::from("y,x,arm,g\n");
    for i in 0..120usize {
        let x = ((i * 37) % 101) as f64 / 50.0 - 1.0;
        let arm = if i % 2 == 0 { "a" } else { "b" };
        text.push_str(&format!("{},{x},{arm},g{}\n", u8::from(x > 0.3), i % 8));
    }
    std::fs::write(&file, &text).unwrap();
    let f = file.to_str().unwrap();
    let (code, stdout, stderr) = run(&["mixed", f, "--family", "binomial", "--formula", "y ~ x + (1|g)"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("note: the data separate (Intercept), x:"), "{stdout}");
    assert!(stdout.contains("optimizer: NOT CERTIFIED"), "{stdout}");
    let start = std::time::Instant::now();
    let (code, _, stderr) =
        run(&["mixed", f, "--family", "binomial", "--profile", "0.95", "--formula", "y ~ x + (1|g)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("the data separate (Intercept), x, so the profile of the deviance does not reach a bound"),
        "{stderr}"
    );
    assert!(start.elapsed().as_secs() < 30, "the refusal took {:?}", start.elapsed());
    // Quasi-complete: arm b never succeeds; x is no longer a predictor.
    let mut text = String::from("y,arm,g\n");
    for i in 0..120usize {
        let arm = if i % 2 == 0 { "a" } else { "b" };
        let y = u8::from(arm == "a" && i % 3 == 0);
        text.push_str(&format!("{y},{arm},g{}\n", i % 8));
    }
    std::fs::write(&file, &text).unwrap();
    let (code, stdout, stderr) = run(&["mixed", f, "--family", "binomial", "--formula", "y ~ arm + (1|g)"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("note: the data separate armb:"), "{stdout}");
    // Data that overlap are not named.
    let text = std::fs::read_to_string(root().join("tests/fixtures/glmm_bacteria.csv")).unwrap();
    std::fs::write(&file, text).unwrap();
    let (code, stdout, stderr) = run(&["mixed", f, "--family", "binomial", "--formula", "y ~ trt + week + (1|ID)"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(!stdout.contains("separate"), "{stdout}");
}

/// Issue 75, item 3: random-effect structures lme4 cannot identify are
/// refused by name: `(f || g)` with a categorical f (its levels'
/// indicators add up to the intercept of `(1|g)`; lme4 warns "nearly
/// unidentifiable"), and (as before) a slope term with as many random
/// effects as observations (lme4 stops: "number of observations <= number
/// of random effects").
#[test]
fn unidentifiable_random_structures_are_refused_by_name() {
    let f = "tests/fixtures/slopes_machines.csv";
    let header = std::fs::read_to_string(root().join(f)).unwrap();
    assert!(header.starts_with("score,Machine,Worker"), "{}", &header[..40]);
    let (code, _, stderr) = run(&["mixed", f, "--formula", "score ~ Machine + (Machine || Worker)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("(1 | Worker) and (0 + MachineA + MachineB + MachineC | Worker)"), "{stderr}");
    assert!(stderr.contains("cannot be told apart"), "{stderr}");
    // 12 groups of 2 observations, a random intercept and slope: 24
    // random effects for 24 observations.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("few.csv");
    let mut text = String::from("y,x,g\n");
    for i in 0..24usize {
        text.push_str(&format!("{},{},g{}\n", (i * 7 % 11) as f64 / 3.0, i % 2, i / 2));
    }
    std::fs::write(&file, text).unwrap();
    let (code, _, stderr) = run(&["mixed", file.to_str().unwrap(), "--formula", "y ~ x + (x|g)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("its term has 24 random effects (12 levels x 2 columns) for 24 observations"), "{stderr}");
}

/// Issue 75, item 2: `--offset COL` is `offset(COL)` in the formula (the
/// same fit, byte for byte), an offset given twice is refused, and
/// `--weights` is refused where it has no meaning (a Poisson exposure is an
/// offset) or no interval (a weighted linear model's profile). The fits themselves are checked against
/// lmer and glmer in crates/stats/tests (sleepstudy_offset, cbpp_exposure,
/// cbpp_weights, cbpp_trials).
#[test]
fn offset_and_weights_options_are_the_formulas_and_refused_where_meaningless() {
    let cbpp = "tests/fixtures/glmm_cbpp.csv";
    let args = |formula: &'static str, extra: &[&'static str]| -> Vec<&'static str> {
        let mut a = vec!["mixed", cbpp, "--family", "poisson", "--json", "--formula", formula];
        a.extend_from_slice(extra);
        a
    };
    let (code, in_formula, stderr) = run(&args("incidence ~ factor(period) + offset(period) + (1|herd)", &[]));
    assert_eq!(code, 0, "{stderr}");
    let (code, option, stderr) = run(&args("incidence ~ factor(period) + (1|herd)", &["--offset", "period"]));
    assert_eq!(code, 0, "{stderr}");
    let fit = |text: &str| serde_json::from_str::<serde_json::Value>(text).unwrap()["fit"].clone();
    assert_eq!(fit(&in_formula), fit(&option));
    let (code, _, stderr) =
        run(&args("incidence ~ factor(period) + offset(log(size)) + (1|herd)", &["--offset", "size"]));
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("give the offset once"), "{stderr}");
    let (code, _, stderr) = run(&args("incidence ~ factor(period) + (1|herd)", &["--weights", "size"]));
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("offset(log(size))"), "{stderr}");
    let (code, _, stderr) = run(&[
        "mixed",
        cbpp,
        "--formula",
        "incidence ~ factor(period) + (1|herd)",
        "--weights",
        "size",
        "--profile",
        "0.95",
    ]);
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("a weighted linear mixed model is fitted with Satterthwaite df and no profile intervals"),
        "{stderr}"
    );
    // A proportion times its weight that is not a whole number of
    // successes is refused at its row.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("prop.csv");
    let text = std::fs::read_to_string(root().join(cbpp)).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let prop = header.iter().position(|h| *h == "prop").unwrap();
    let mut row: Vec<String> = lines[3].split(',').map(String::from).collect();
    row[prop] = "0.123".into();
    lines[3] = row.join(",");
    std::fs::write(&file, lines.join("\n") + "\n").unwrap();
    let (code, _, stderr) = run(&[
        "mixed",
        file.to_str().unwrap(),
        "--family",
        "binomial",
        "--weights",
        "size",
        "--formula",
        "prop ~ factor(period) + (1|herd)",
    ]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("row 3, field prop: the proportion 0.123 of"), "{stderr}");
}

/// Issue 75, item 1: random slopes and GLMMs are no longer bounded by a
/// dense system (4,000 columns before): `(x|g)` over 2,500 groups (5,000
/// random effects) fits and is certified. That the sparse factor gives
/// lme4's numbers is checked on every reference fit
/// (crates/stats/tests/mixed_slopes.rs, glmm.rs); its speed and criterion
/// beside lmer's at 1,500 to 10,000 groups are in
/// results/benchmarks/mixed_sparse.txt.
#[test]
fn a_random_slope_over_thousands_of_groups_fits() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("big.csv");
    let mut text = String::from("y,x,g\n");
    for i in 0..50_000usize {
        let g = i / 20;
        let x = ((i * 7919) % 1000) as f64 / 500.0 - 1.0;
        let b0 = ((g * 31) % 17) as f64 / 8.0 - 1.0;
        let b1 = ((g * 13) % 11) as f64 / 10.0 - 0.5;
        let e = ((i * 104_729) % 1009) as f64 / 504.5 - 1.0;
        text.push_str(&format!("{},{x},g{g}\n", 1.0 + 0.3 * x + b0 + b1 * x + e));
    }
    std::fs::write(&file, text).unwrap();
    let (code, stdout, stderr) = run(&["mixed", file.to_str().unwrap(), "--formula", "y ~ x + (x|g)"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("Number of obs: 50000, groups:  g, 2500"), "{stdout}");
    assert!(stdout.contains("optimizer: optimum certified"), "{stdout}");
}

/// Issue 75, item 6: `--nagq N` fits by adaptive Gauss-Hermite quadrature
/// (checked against glmer's nAGQ 9 and 25 in crates/stats/tests/glmm.rs)
/// and says so in the summary's first line; it is refused, as glmer
/// refuses it, for a model with more than one scalar random effect, and
/// for a linear model, whose likelihood needs no quadrature.
#[test]
fn quadrature_is_named_and_refused_where_glmer_refuses_it() {
    let cbpp = "tests/fixtures/glmm_cbpp.csv";
    let (code, stdout, stderr) = run(&[
        "mixed",
        cbpp,
        "--family",
        "binomial",
        "--nagq",
        "9",
        "--formula",
        "cbind(incidence, healthy) ~ factor(period) + (1|herd)",
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.starts_with(
            "Generalized linear mixed model fit by maximum likelihood (Adaptive Gauss-Hermite Quadrature, nAGQ = 9)"
        ),
        "{stdout}"
    );
    let (code, _, stderr) = run(&[
        "mixed",
        cbpp,
        "--family",
        "binomial",
        "--nagq",
        "9",
        "--formula",
        "cbind(incidence, healthy) ~ factor(period) + (1|herd) + (1|obs)",
    ]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("nAGQ = 9 is defined for one scalar random effect"), "{stderr}");
    let (code, _, stderr) = run(&["mixed", cbpp, "--nagq", "5", "--formula", "incidence ~ factor(period) + (1|herd)"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("quadrature is for a generalized model"), "{stderr}");
}
