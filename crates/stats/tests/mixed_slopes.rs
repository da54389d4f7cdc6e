//! Random-slope models against lme4 and lmerTest: every fit of
//! `scripts/reference/mixed_slopes.R` (its output committed as
//! `mixed_slopes.out`), on data sets of R's own packages (lme4's
//! sleepstudy and cake, nlme's Orthodont, Machines, Oxboys, MathAchieve,
//! Oats and Pixel, datasets' ChickWeight) and two simulated designs, one
//! crossed and one singular, written by the script to
//! `tests/fixtures/slopes_*.csv`.
//!
//! For each fit: crossaudit's deviance at lme4's theta is lme4's criterion
//! (the same function, in the same parameterization and term order); the
//! optimum crossaudit finds is no higher than lme4's; theta, the variance
//! components and correlations, the fixed effects, their standard errors
//! and (REML) lmerTest's Satterthwaite df agree; the singular flag is
//! lme4's `isSingular`. Among them an offset and lmer's prior weights
//! (sleepstudy, REML and ML; issue 75).

mod common;

use std::collections::BTreeMap;

use common::{close, compare_varcorr, fixture, root, VarCorr};

use crossaudit_stats::mixed::formula::{
    build_model, fit_table, fit_table_weighted, parse, read_csv, DfMethod, FormulaModel,
};
use crossaudit_stats::mixed::slopes::deviance_at;
use crossaudit_stats::mixed::Criterion;

/// One fit of the reference: its lines, by what they give.
#[derive(Default, Debug)]
struct Reference {
    formula: String,
    reml: bool,
    /// lmer's prior weights (a column), where the fit has them.
    weights: Option<String>,
    criterion: f64,
    theta: Vec<f64>,
    /// (grp, var1, var2) -> (vcov, sdcor).
    vc: VarCorr,
    /// name -> (estimate, se).
    fixef: BTreeMap<String, (f64, f64)>,
    df: BTreeMap<String, f64>,
    /// name -> (Kenward-Roger SE, df), pbkrtest's.
    kr: BTreeMap<String, (f64, f64)>,
    singular: bool,
}

fn references() -> BTreeMap<String, Reference> {
    let text = std::fs::read_to_string(root().join("scripts/reference/mixed_slopes.out")).unwrap();
    let mut out: BTreeMap<String, Reference> = BTreeMap::new();
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let (name, rest) = line.split_once(' ').unwrap();
        let (what, values) = rest.split_once(' ').unwrap();
        let r = out.entry(name.to_string()).or_default();
        let words: Vec<&str> = values.split_whitespace().collect();
        let num = |w: &str| w.parse::<f64>().unwrap();
        match what {
            "formula" => r.formula = values.trim().to_string(),
            "reml" => r.reml = values.trim() == "TRUE",
            "weights" => r.weights = Some(values.trim().to_string()),
            "criterion" => r.criterion = num(words[0]),
            "theta" => r.theta = words.iter().map(|w| num(w)).collect(),
            "vc" => {
                let key = (words[0].to_string(), words[1].to_string(), words[2].to_string());
                r.vc.insert(key, (num(words[3]), num(words[4])));
            }
            "fixef" => {
                r.fixef.insert(words[0].to_string(), (num(words[1]), num(words[2])));
            }
            "df" => {
                r.df.insert(words[0].to_string(), num(words[1]));
            }
            "kr" => {
                r.kr.insert(words[0].to_string(), (num(words[1]), num(words[2])));
            }
            "singular" => r.singular = values.trim() == "TRUE",
            other => panic!("unknown line kind {other}"),
        }
    }
    out
}

/// The numbers of column `name` of the CSV `text`.
fn column(text: &str, name: &str) -> Vec<f64> {
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let at = header.iter().position(|h| *h == name).unwrap();
    text.lines().skip(1).map(|l| l.split(',').nth(at).unwrap().parse().unwrap()).collect()
}

#[test]
fn random_slope_fits_match_lme4_and_lmertest() {
    let refs = references();
    assert!(refs.len() >= 16, "{} reference fits", refs.len());
    let mut failures = Vec::new();
    for (name, r) in &refs {
        let text = fixture("slopes", name);
        let table = read_csv(&text).unwrap();
        let criterion = if r.reml { Criterion::Reml } else { Criterion::Ml };
        let formula = parse(&r.formula).unwrap();
        let FormulaModel::Slopes(data) = build_model(&formula, &table).unwrap() else {
            panic!("{name}: not a random-slope model")
        };
        let data = match &r.weights {
            Some(w) => data.with_weights(column(&text, w)).unwrap(),
            None => data,
        };
        // The same function: crossaudit's deviance at lme4's theta.
        let at_lme4 = deviance_at(&data, &r.theta, criterion).unwrap();
        close(&format!("{name} deviance at lme4's theta"), at_lme4, r.criterion, 1e-11, 0.0, &mut failures);
        let fit =
            fit_table_weighted(&r.formula, &table, criterion, DfMethod::Satterthwaite, None, r.weights.as_deref())
                .unwrap();
        let f = fit.fit.slopes().unwrap();
        assert!(f.certificate.certified, "{name}: {}", fit.summary());
        if f.deviance > r.criterion + 1e-9 * r.criterion.abs() {
            failures
                .push(format!("{name}: crossaudit's optimum {:.12} is above lme4's {:.12}", f.deviance, r.criterion));
        }
        close(&format!("{name} criterion"), f.deviance, r.criterion, 1e-10, 0.0, &mut failures);
        assert_eq!(f.theta.len(), r.theta.len(), "{name}");
        for (j, (a, b)) in f.theta.iter().zip(&r.theta).enumerate() {
            close(&format!("{name} theta[{j}]"), *a, *b, 1e-4, 1e-4, &mut failures);
        }
        assert_eq!(f.singular, r.singular, "{name}: singular");
        // Variance components and correlations, by lme4's names.
        let seen = compare_varcorr(name, &f.terms, &r.vc, 1e-4, &mut failures);
        let (vcov, _) = r.vc[&("Residual".to_string(), "NA".to_string(), "NA".to_string())];
        close(&format!("{name} residual"), f.residual, vcov, 1e-6, 0.0, &mut failures);
        assert_eq!(seen + 1, r.vc.len(), "{name}: every lme4 component compared");
        assert_eq!(fit.fixed.len(), r.fixef.len(), "{name}");
        for row in &fit.fixed {
            let (est, se) = r.fixef[&row.name];
            close(&format!("{name} {} estimate", row.name), row.estimate, est, 1e-6, 1e-8, &mut failures);
            close(&format!("{name} {} se", row.name), row.se, se, 1e-5, 0.0, &mut failures);
            match (row.df, r.df.get(&row.name)) {
                (Some(ours), Some(theirs)) => {
                    close(&format!("{name} {} df", row.name), ours, *theirs, 1e-4, 0.0, &mut failures)
                }
                (None, None) => {}
                (ours, theirs) => {
                    failures.push(format!("{name} {} df: crossaudit {ours:?}, lmerTest {theirs:?}", row.name))
                }
            }
        }
    }
    assert!(failures.is_empty(), "{} disagreements:\n{}", failures.len(), failures.join("\n"));
}

/// Kenward-Roger's adjusted SEs and df of the random-slope fits against
/// pbkrtest's `vcovAdj` and `Lb_ddf` (the `kr` lines of
/// mixed_slopes.out: every REML fit of at most 1,000 observations), at
/// crossaudit's optimum: SE to 1e-5 and df to 1e-4 relative (2e-3 at a
/// singular fit, whose flat directions move the df with the optimum); on
/// this machine all 31 agree to 1e-6 and 1e-5.
#[test]
fn random_slope_kenward_roger_matches_pbkrtest() {
    let refs = references();
    let mut failures = Vec::new();
    let mut compared = 0;
    for (name, r) in refs.iter().filter(|(_, r)| !r.kr.is_empty()) {
        let table = read_csv(&fixture("slopes", name)).unwrap();
        let fit = fit_table(&r.formula, &table, Criterion::Reml, DfMethod::KenwardRoger, None).unwrap();
        let df_tolerance = if r.singular { 2e-3 } else { 1e-4 };
        for row in &fit.fixed {
            let (se, df) = r.kr[&row.name];
            close(&format!("{name} {} KR se", row.name), row.se, se, 1e-5, 0.0, &mut failures);
            close(
                &format!("{name} {} KR df", row.name),
                row.df.unwrap_or(f64::NAN),
                df,
                df_tolerance,
                0.0,
                &mut failures,
            );
            compared += 1;
        }
    }
    assert!(compared >= 30, "{compared} coefficients compared");
    assert!(failures.is_empty(), "{} disagreements:\n{}", failures.len(), failures.join("\n"));
}
