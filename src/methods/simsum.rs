//! `crossaudit simsum`: anyone's simulation study in. A replications CSV
//! or Parquet file (read from its columns where they give what its CSV
//! text gives, `simsum::columns`; anywhere else as that text)
//! (one row per method and replication: estimate, SE, optionally interval
//! limits, df, a replication id and by-factors; the true value and the
//! level as numbers or columns) is read with every bad field located at
//! its line and column, scored by [`crossaudit_stats::simsum`] (rsimsum's
//! measures with their MCSEs, methods paired by replication id), and
//! written as `simsum.csv` (tidy: one row per group, method and measure,
//! as rsimsum's `tidy()`) and `simsum.md` (by [`super::simsum_report`]).

use std::path::Path;

use crossaudit_stats::simsum::{simsum, Group, MethodPerformance, Replication};

mod columns;
mod rows;
use rows::from_text;
pub use rows::{Columns, SimsumFileError};

/// The measures a target MCSE may name.
pub const PLANNABLE: [&str; 12] = [
    "bias",
    "rbias",
    "empse",
    "mse",
    "relprec",
    "modelse",
    "relerror",
    "cover",
    "becover",
    "power",
    "cover_ac",
    "interval_score",
];

/// Reads `cover=0.005,bias=0.01`: each name one of [`PLANNABLE`], each
/// target a number above 0.
pub fn parse_targets(text: &str) -> Result<Vec<(String, f64)>, SimsumFileError> {
    text.split(',')
        .map(|item| {
            let (name, value) = item.split_once('=').unwrap_or((item, ""));
            let (name, value) = (name.trim(), value.trim());
            if !PLANNABLE.contains(&name) {
                return Err(SimsumFileError::Flag(format!(
                    "--target-mcse: `{name}` is not a measure with an MCSE; give MEASURE=VALUE with MEASURE one of {}",
                    PLANNABLE.join(", ")
                )));
            }
            match value.parse::<f64>() {
                Ok(v) if v.is_finite() && v >= 1e-12 => Ok((name.to_string(), v)),
                // The replications needed grow as 1 / target^2: a coverage
                // MCSE of 1e-12 already needs about 1e23.
                Ok(v) if v > 0.0 => Err(SimsumFileError::Flag(format!(
                    "--target-mcse: {name}={value}: a target below 1e-12 needs more replications than any simulation runs (a coverage MCSE of 1e-12 needs about 1e23); give a larger one"
                ))),
                _ => Err(SimsumFileError::Flag(format!(
                    "--target-mcse: {name}={value}: the target is not a number above 0"
                ))),
            }
        })
        .collect()
}

/// The replications a measure needs for its MCSE to fall to `target`:
/// every MCSE here shrinks as 1 / sqrt(n), so n (MCSE / target)^2, rounded
/// up (for the coverage this is p (1 - p) / target^2, the closed form).
/// None where the pilot gives no MCSE.
pub fn reps_needed(m: &MethodPerformance, measure: &str, target: f64) -> Option<u64> {
    let p = &m.performance;
    let (n, mcse) = match measure {
        "cover_ac" => (p.reps as f64 + 4.0, m.coverage_mcse_adjusted),
        "interval_score" => (p.reps as f64, m.interval_score.1),
        _ => (p.reps as f64, stat(p, measure).1),
    };
    // Rounded up, but not past a whole number that rounding lifted by an ulp.
    let needed = (n * (mcse / target).powi(2) * (1.0 - 1e-12)).ceil();
    let needed = if measure == "cover_ac" { needed - 4.0 } else { needed };
    (needed.is_finite() && mcse.is_finite()).then_some(needed.max(2.0) as u64)
}

/// Reads `path` and scores it.
pub fn summarise(path: &Path, cols: &Columns) -> Result<(Vec<Group>, Vec<String>), SimsumFileError> {
    let shown = path.display().to_string();
    let (reps, notes) = read(path, cols)?;
    let groups =
        simsum(&reps, cols.reference.as_deref()).map_err(|source| SimsumFileError::Summary { path: shown, source })?;
    Ok((groups, notes))
}

/// The replications of the file `path`, and the notes on columns not read
/// ([`Columns`]); a bad field is an error at its line and column.
fn read(path: &Path, cols: &Columns) -> Result<(Vec<Replication>, Vec<String>), SimsumFileError> {
    let shown = path.display().to_string();
    let at = |line: usize, column: usize, message: String| SimsumFileError::At {
        path: shown.clone(),
        line,
        column,
        message,
    };
    let (limit, what) = (crate::io::MAX_CELLS_FILE, "a replications file");
    let raw = bytes::Bytes::from(
        crate::io::read_input(path, limit, what)
            .map_err(|e| SimsumFileError::Read { path: shown.clone(), message: e.reason() })?,
    );
    // A Parquet file's replications taken from its decoded columns where
    // they are the ones its CSV text gives; anywhere else, that text read.
    let parquet = crate::io::parquet::is_parquet(path);
    if parquet {
        if let Some(read) = columns::from_columns(raw.clone(), cols, limit) {
            return Ok(read);
        }
    }
    // The bytes are no longer shared: taken back without a copy.
    let text = crate::io::text_of(Vec::from(raw), parquet, limit, what)
        .map_err(|e| match e {
            crate::io::TextError::NotUtf8 { line, column } => at(line, column, "not UTF-8".into()),
            other => SimsumFileError::Read { path: shown.clone(), message: other.reason() },
        })?
        .text;
    from_text(&text, cols, &at)
}

/// The measures written, in rsimsum's names and order, then crossaudit's.
pub(crate) const STATS: [&str; 14] = [
    "nsim",
    "bias",
    "rbias",
    "empse",
    "mse",
    "relprec",
    "modelse",
    "relerror",
    "cover",
    "becover",
    "power",
    "width",
    "undefined",
    "rejection",
];

/// One measure of `p` by its simsum.csv name, and its MCSE.
pub(crate) fn stat(p: &crossaudit_stats::coverage::Performance, name: &str) -> (f64, f64) {
    match name {
        "nsim" => (p.reps as f64, f64::NAN),
        "bias" => (p.bias, p.bias_mcse),
        "rbias" => (p.rel_bias, p.rel_bias_mcse),
        "empse" => (p.emp_se, p.emp_se_mcse),
        "mse" => (p.mse, p.mse_mcse),
        "relprec" => (p.rel_precision, p.rel_precision_mcse),
        "modelse" => (p.mod_se, p.mod_se_mcse),
        "relerror" => (p.rel_error_mod_se, p.rel_error_mod_se_mcse),
        "cover" => (p.coverage, p.coverage_mcse),
        "becover" => (p.be_coverage, p.be_coverage_mcse),
        "power" => (p.power, p.power_mcse),
        "width" => (p.mean_width, p.mean_width_mcse),
        "undefined" => (p.undefined as f64, f64::NAN),
        _ => (p.rejection, p.rejection_mcse),
    }
}
