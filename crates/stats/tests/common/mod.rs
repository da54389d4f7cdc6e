//! What the reference tests of the statistics crate share: where the
//! repository lies, the fixtures R wrote, and the comparison that
//! collects every failure before the test fails.

use std::path::PathBuf;

/// The repository's root (the reference outputs and fixtures lie there).
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The fixture a reference fit's data are in: `<prefix>_<first word of
/// the fit's name>.csv` under `tests/fixtures`.
pub fn fixture(prefix: &str, fit: &str) -> String {
    let stem = fit.split('_').next().unwrap();
    std::fs::read_to_string(root().join(format!("tests/fixtures/{prefix}_{stem}.csv"))).unwrap()
}

/// Records a failure when `ours` differs from lme4's `theirs` by more than
/// `rel` of it plus `abs`.
pub fn close(what: &str, ours: f64, theirs: f64, rel: f64, abs: f64, failures: &mut Vec<String>) {
    let diff = (ours - theirs).abs();
    if diff.is_nan() || diff > rel * theirs.abs() + abs {
        failures.push(format!("{what}: crossaudit {ours:.12e}, lme4 {theirs:.12e} (difference {diff:.2e})"));
    }
}

/// lme4's VarCorr rows: (grp, var1, var2) -> (vcov, sdcor), var2 `NA` for
/// a variance.
pub type VarCorr = std::collections::BTreeMap<(String, String, String), (f64, f64)>;

/// Compares every variance, SD, covariance and correlation of `terms` with
/// lme4's VarCorr row of the same names: variances and covariances to
/// `rel` of lme4's value plus 1e-6, correlations to 1e-4; returns how
/// many rows were compared (the caller checks that none was left out).
/// Panics when `terms` has a component lme4 has no row for.
pub fn compare_varcorr(
    name: &str,
    terms: &[crossaudit_stats::mixed::slopes::TermFit],
    vc: &VarCorr,
    rel: f64,
    failures: &mut Vec<String>,
) -> usize {
    let mut seen = 0;
    for t in terms {
        let k = t.names.len();
        for i in 0..k {
            let key = (t.group.clone(), t.names[i].clone(), "NA".to_string());
            let (vcov, sd) = vc.get(&key).unwrap_or_else(|| panic!("{name}: no lme4 row {key:?}"));
            close(&format!("{name} var {key:?}"), t.covariance[i * k + i], *vcov, rel, 1e-6, failures);
            close(&format!("{name} sd {key:?}"), t.sd[i], *sd, rel, 1e-6, failures);
            seen += 1;
            for j in 0..i {
                let key = (t.group.clone(), t.names[j].clone(), t.names[i].clone());
                let (cov, cor) = vc.get(&key).unwrap_or_else(|| panic!("{name}: no lme4 row {key:?}"));
                close(&format!("{name} cov {key:?}"), t.covariance[i * k + j], *cov, rel, 1e-6, failures);
                let ours = t.correlations[i * (i - 1) / 2 + j].unwrap_or(f64::NAN);
                close(&format!("{name} cor {key:?}"), ours, *cor, 1e-4, 1e-4, failures);
                seen += 1;
            }
        }
    }
    seen
}
