//! `crossaudit simsum`: anyone's simulation study in. A replications CSV
//! or Parquet file (`io::read_text` turns Parquet into its CSV text)
//! (one row per method and replication: estimate, SE, optionally interval
//! limits, df, a replication id and by-factors; the true value and the
//! level as numbers or columns) is read with every bad field located at
//! its line and column, scored by [`crossaudit_stats::simsum`] (rsimsum's
//! measures with their MCSEs, methods paired by replication id), and
//! written as `simsum.csv` (tidy: one row per group, method and measure,
//! as rsimsum's `tidy()`) and `simsum.md` (by [`super::simsum_report`]).

use std::path::Path;

use crossaudit_stats::simsum::{simsum, Group, MethodPerformance, Replication};

/// Which columns hold what; `truth` and `level` are a number or a column.
#[derive(Debug, Clone)]
pub struct Columns {
    /// The estimate column.
    pub estimate: String,
    /// The SE column.
    pub se: String,
    /// The method column.
    pub method: String,
    /// The replication-id column, if any.
    pub rep: Option<String>,
    /// By-factor columns.
    pub by: Vec<String>,
    /// The true value: a number, or the column holding it.
    pub truth: String,
    /// The level: a number, or the column holding it.
    pub level: String,
    /// Lower and upper interval-limit columns, if any.
    pub ci: Option<(String, String)>,
    /// The df column, if any.
    pub df: Option<String>,
    /// The reference method; by default each group's first.
    pub reference: Option<String>,
    /// Target MCSEs (`cover`, 0.005): the replications each needs.
    pub targets: Vec<(String, f64)>,
}

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

/// Why a replications file cannot be summarised.
#[derive(Debug, thiserror::Error)]
pub enum SimsumFileError {
    /// The file could not be read.
    #[error("cannot read {path}: {message}")]
    Read {
        /// The file.
        path: String,
        /// Why.
        message: String,
    },
    /// Something at a place in the file is wrong.
    #[error("{path}:{line}:{column}: {message}")]
    At {
        /// The file.
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column (the field's number).
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A command-line value is out of range.
    #[error("{0}")]
    Flag(String),
    /// The replications cannot be summarised.
    #[error("{path}: {source}")]
    Summary {
        /// The file.
        path: String,
        /// Why.
        source: crossaudit_stats::simsum::SimsumError,
    },
    /// An output could not be written.
    #[error(transparent)]
    Write(#[from] crate::io::WriteError),
    /// simsum.svg could not be drawn.
    #[error(transparent)]
    Draw(#[from] crate::report::charts::DrawError),
}

/// Reads `path` and scores it.
pub fn summarise(path: &Path, cols: &Columns) -> Result<(Vec<Group>, Vec<String>), SimsumFileError> {
    let shown = path.display().to_string();
    let (reps, notes) = read(path, cols)?;
    let groups =
        simsum(&reps, cols.reference.as_deref()).map_err(|source| SimsumFileError::Summary { path: shown, source })?;
    Ok((groups, notes))
}

/// A column whose name says what it holds (`rep`, `level`, `true`, `df`,
/// `lower`/`upper`) but that no flag names is not read: said in words,
/// with what is used instead and the flag that reads it, so that a file's
/// own replication ids or levels are never ignored without a word.
fn unused_columns(header: &[String], cols: &Columns) -> Vec<String> {
    let has = |names: &[&str]| header.iter().find(|h| names.contains(&h.to_ascii_lowercase().as_str())).cloned();
    let mut out = Vec::new();
    if let (None, Some(c)) = (&cols.rep, has(&["rep", "repetition", "replication", "rep_id"])) {
        out.push(format!("column `{c}` is not read (no --rep): methods are paired by their rows' order within each group; give --rep {c} to pair them by replication id"));
    }
    if let Some(c) = has(&["level", "conf_level"]).filter(|c| cols.level != *c) {
        out.push(format!(
            "column `{c}` is not read: every interval's level is --level {}; give --level {c} to read each row's",
            cols.level
        ));
    }
    if let Some(c) = has(&["true", "truth", "true_value", "theta"]).filter(|c| cols.truth != *c) {
        out.push(format!(
            "column `{c}` is not read: the true value is --true {}; give --true {c} to read each row's",
            cols.truth
        ));
    }
    // With --ci the file's own limits are scored and df do not enter.
    if let (None, None, Some(c)) = (&cols.df, &cols.ci, has(&["df"])) {
        out.push(format!("column `{c}` is not read (no --df): intervals from estimate and SE use the normal quantile; give --df {c} for t quantiles"));
    }
    if cols.ci.is_none() {
        let lo = has(&["lower", "lower_limit", "ci_lower", "lo"]);
        let hi = has(&["upper", "upper_limit", "ci_upper", "hi"]);
        if let (Some(l), Some(u)) = (lo, hi) {
            out.push(format!("columns `{l}` and `{u}` are not read (no --ci): intervals are the estimate plus or minus the quantile times the SE; give --ci {l},{u} to score the file's own"));
        }
    }
    out
}

/// Where each declared column is; the true value and level as a number
/// (`Ok`) or a column (`Err(index)`).
struct Located {
    estimate: usize,
    se: usize,
    method: usize,
    rep: Option<usize>,
    by: Vec<usize>,
    ci: Option<(usize, usize)>,
    df: Option<usize>,
    truth: Result<f64, usize>,
    level: Result<f64, usize>,
    level_column: usize,
}

type At<'a> = &'a dyn Fn(usize, usize, String) -> SimsumFileError;

fn locate(header: &[String], cols: &Columns, at: At) -> Result<Located, SimsumFileError> {
    let find = |name: &str, flag: &str| {
        header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| at(1, 1, format!("no column `{name}` ({flag}); the header has {}", header.join(","))))
    };
    let number_or_column = |v: &str, flag: &str| -> Result<Result<f64, usize>, SimsumFileError> {
        match v.parse::<f64>() {
            Ok(x) => Ok(Ok(x)),
            Err(_) => find(v, flag).map(Err),
        }
    };
    let ci = match &cols.ci {
        Some((l, u)) => Some((find(l, "--ci")?, find(u, "--ci")?)),
        None => None,
    };
    let truth = number_or_column(&cols.truth, "--true")?;
    if let Ok(x) = truth.as_ref().copied() {
        if !x.is_finite() || (x != 0.0 && x.abs() < MIN_MAGNITUDE) || x.abs() > MAX_MAGNITUDE {
            return Err(SimsumFileError::Flag(format!(
                "--true {} is not a finite number between 1e-60 and 1e75 in magnitude (or 0): bias, coverage and the MSE would be {} (a true value that varies is a column: --true COLUMN)",
                crate::io::one_line(&if cols.truth.chars().count() > 64 {
                    format!("{}...", cols.truth.chars().take(64).collect::<String>())
                } else {
                    cols.truth.clone()
                }),
                if x.is_nan() { "undefined" } else { "wrong" }
            )));
        }
    }
    let level = number_or_column(&cols.level, "--level")?;
    if let Ok(x) = level.as_ref().copied() {
        if !(x > 0.0 && x < 1.0) {
            return Err(SimsumFileError::Flag(format!("--level {x} is not between 0 and 1 (0.95 is a 95% interval)")));
        }
    }
    Ok(Located {
        estimate: find(&cols.estimate, "--estimate")?,
        se: find(&cols.se, "--se")?,
        method: find(&cols.method, "--method")?,
        rep: cols.rep.as_deref().map(|r| find(r, "--rep")).transpose()?,
        by: cols.by.iter().map(|b| find(b, "--by")).collect::<Result<_, _>>()?,
        ci,
        df: cols.df.as_deref().map(|d| find(d, "--df")).transpose()?,
        truth,
        level_column: level.err().map_or(1, |k| k + 1),
        level,
    })
}

fn read(path: &Path, cols: &Columns) -> Result<(Vec<Replication>, Vec<String>), SimsumFileError> {
    let shown = path.display().to_string();
    let at = |line: usize, column: usize, message: String| SimsumFileError::At {
        path: shown.clone(),
        line,
        column,
        message,
    };
    let text = crate::io::read_text(path, crate::io::MAX_CELLS_FILE, "a replications file").map_err(|e| match e {
        crate::io::TextError::NotUtf8 { line, column } => at(line, column, "not UTF-8".into()),
        other => SimsumFileError::Read { path: shown.clone(), message: other.reason() },
    })?;
    let text = text.text.as_str();
    let lines = crate::io::LineIndex::new(text.as_bytes());
    let mut reader = csv::ReaderBuilder::new().has_headers(true).flexible(false).from_reader(text.as_bytes());
    let header: Vec<String> =
        reader.headers().map_err(|e| at(1, 1, e.to_string()))?.iter().map(|h| h.trim().to_string()).collect();
    let loc = locate(&header, cols, &at)?;
    let notes = unused_columns(&header, cols);
    let mut out = Vec::new();
    for row in reader.records() {
        let row = row.map_err(|e| {
            let line = e.position().map(|p| lines.line_of(p.byte() as usize)).unwrap_or(1);
            at(line, 1, e.to_string())
        })?;
        let line = row.position().map(|p| lines.line_of(p.byte() as usize)).unwrap_or(1);
        out.push(replication(&row, line, &loc, &at)?);
    }
    if out.is_empty() {
        return Err(at(1, 1, "the file holds a header and no replications".into()));
    }
    Ok((out, notes))
}

/// One row as a replication; a bad field is an error at its column.
fn replication(row: &csv::StringRecord, line: usize, loc: &Located, at: At) -> Result<Replication, SimsumFileError> {
    let field = |k: usize| row.get(k).unwrap_or("").trim();
    // A missing value (empty, NA, NaN) is NaN; anything else must be a number.
    let value = |k: usize, what: &str| -> Result<f64, SimsumFileError> {
        match field(k) {
            "" | "NA" | "NaN" | "nan" => Ok(f64::NAN),
            v => v.parse::<f64>().ok().filter(|x| !x.is_infinite() || what == "df").ok_or_else(|| {
                at(line, k + 1, format!("{what} \"{v}\" is not a number (write NA for a missing value)"))
            }),
        }
    };
    let given = |v: &Result<f64, usize>, what: &str| -> Result<f64, SimsumFileError> {
        match v {
            Ok(x) => Ok(*x),
            Err(k) => match value(*k, what)? {
                x if x.is_finite() => Ok(x),
                _ => Err(at(line, k + 1, format!("the {what} is missing"))),
            },
        }
    };
    let truth = given(&loc.truth, "true value")?;
    let level = given(&loc.level, "level")?;
    if !(level > 0.0 && level < 1.0) {
        return Err(at(line, loc.level_column, format!("level {level} is not between 0 and 1")));
    }
    if field(loc.method).is_empty() {
        return Err(at(line, loc.method + 1, "empty method".into()));
    }
    let limits = match loc.ci {
        Some((l, u)) => Some((value(l, "lower limit")?, value(u, "upper limit")?)),
        None => None,
    };
    // Values the measures cannot use: squared (MSE, SEs) they must stay
    // finite; an SE is not negative, df are positive, an interval's lower
    // limit is not above its upper.
    let sized = |k: usize, what: &str, x: f64| sized(x, what).map_err(|m| at(line, k + 1, m));
    let estimate = sized(loc.estimate, "estimate", value(loc.estimate, "estimate")?)?;
    if let Err(k) = loc.truth {
        sized(k, "true value", truth)?;
    }
    let se = sized(loc.se, "SE", value(loc.se, "SE")?)?;
    if se < 0.0 {
        return Err(at(line, loc.se + 1, format!("SE {se} is negative")));
    }
    if let (Some((l, u)), Some((lo, hi))) = (loc.ci, limits) {
        sized(l, "lower limit", lo)?;
        sized(u, "upper limit", hi)?;
        if lo > hi {
            return Err(at(line, l + 1, format!("lower limit {lo} is above the upper limit {hi}")));
        }
    }
    if let Some(k) = loc.rep.filter(|&k| field(k).is_empty()) {
        return Err(at(
            line,
            k + 1,
            "the replication id is empty: with --rep every row needs one (leave --rep out to pair methods by their rows' order, rsimsum's rule)".into(),
        ));
    }
    let df = loc.df.map(|k| value(k, "df")).transpose()?;
    if let (Some(k), Some(d)) = (loc.df, df) {
        if d <= 0.0 {
            return Err(at(line, k + 1, format!("df {d} is not positive")));
        }
    }
    Ok(Replication {
        by: loc.by.iter().map(|&k| field(k).to_string()).collect(),
        method: field(loc.method).to_string(),
        rep: loc.rep.map(|k| field(k).to_string()),
        estimate,
        se,
        limits,
        df,
        truth,
        level,
    })
}

/// `x` unless the measures cannot use it: beyond +-1e75 its fourth power
/// overflows, below 1e-60 (not 0) it underflows. `what` names
/// it in the message.
fn sized(x: f64, what: &str) -> Result<f64, String> {
    if x.abs() > MAX_MAGNITUDE {
        return Err(format!("{what} {x:e} is beyond +-1e75: its fourth power, which the Monte Carlo SEs use, would overflow; rescale the column (divide it by a power of ten)"));
    }
    if x != 0.0 && x.abs() < MIN_MAGNITUDE {
        return Err(format!("{what} {x:e} is below 1e-60 in magnitude: the fourth powers that the Monte Carlo SEs use would underflow double precision and the measures come out wrong; rescale the column (multiply it by a power of ten)"));
    }
    Ok(x)
}

/// The largest magnitude of an estimate, SE, limit or true value: its
/// fourth power (the MSE's Monte Carlo SE) stays inside f64's range
/// (1.8e308).
const MAX_MAGNITUDE: f64 = 1e75;

/// The smallest nonzero magnitude of an estimate, SE, limit or true value:
/// its fourth power (the MSE's Monte Carlo SE) stays a normal double
/// (above 2.2e-308).
const MIN_MAGNITUDE: f64 = crate::io::MIN_MAGNITUDE;

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
