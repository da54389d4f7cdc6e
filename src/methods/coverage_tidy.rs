//! A coverage study's replications as one tidy CSV that R's rsimsum reads
//! unchanged: one row per setting, true mean, level, estimator and
//! replication, with the estimate, its SE and interval (NA where the
//! estimator gave none) and the true value. `simsum(data, estvarname =
//! "estimate", se = "se", true = "true_mean", methodvar = "method",
//! ref = <first estimator>, by = c("setting", "level"), ci.limits =
//! c("ci_lower", "ci_upper"))` (rsimsum reserves `lower` and `upper`) reproduces coverage.csv's measures
//! (scripts/reference/rsimsum_check.R).

use std::fmt::Write as _;

use crossaudit_stats::coverage::{shifted, usable, Simulated};

/// R's text for a number: the shortest text that reads back to the same
/// bits, `Inf` / `-Inf`, and `NA` for NaN.
fn r_number(x: f64) -> String {
    if x.is_nan() {
        "NA".into()
    } else if x.is_infinite() {
        if x > 0.0 { "Inf" } else { "-Inf" }.into()
    } else {
        format!("{x:?}")
    }
}

/// replications.csv: every replication of every setting at every true
/// mean and level, in the order coverage.csv lists them. A replication
/// that is not usable (an estimate, SE or interval end that is not a
/// number) is written NA throughout, so that rsimsum leaves out the
/// replications crossaudit leaves out.
pub fn replications_csv(sims: &[Simulated], means: &[f64]) -> String {
    let mut out = String::from("setting,true_mean,level,method,rep,estimate,se,ci_lower,ci_upper,df\n");
    for sim in sims {
        let setting = format!("\"{}\"", sim.label.replace('"', "\"\""));
        for &mu in means {
            for (l, &level) in sim.levels.iter().enumerate() {
                for (k, method) in sim.methods.iter().enumerate() {
                    for (r, (e, df, _)) in sim.replications[l][k].iter().enumerate() {
                        let (est, se, lower, upper, df) = if usable(e) {
                            let s = shifted(*e, mu);
                            (r_number(s.0), r_number(s.1), r_number(s.2), r_number(s.3), r_number(*df))
                        } else {
                            let na = || "NA".to_string();
                            (na(), na(), na(), na(), na())
                        };
                        let _ = writeln!(
                            out,
                            "{setting},{},{},{method:?},{},{est},{se},{lower},{upper},{df}",
                            r_number(mu),
                            r_number(level),
                            r + 1
                        );
                    }
                }
            }
        }
    }
    out
}
