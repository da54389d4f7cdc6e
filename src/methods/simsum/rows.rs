//! A replications file's rows as its CSV text gives them, whichever
//! reader took them from the file: where each declared column is
//! ([`locate`]), one row's fields as a replication with every check a row
//! must pass ([`replication`], over [`Fields`]), and the text's own
//! reader ([`from_text`]), each bad field placed at its line and column.

use crossaudit_stats::simsum::Replication;

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

/// A column whose name says what it holds (`rep`, `level`, `true`, `df`,
/// `lower`/`upper`) but that no flag names is not read: said in words,
/// with what is used instead and the flag that reads it, so that a file's
/// own replication ids or levels are never ignored without a word.
pub(super) fn unused_columns(header: &[String], cols: &Columns) -> Vec<String> {
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
pub(super) struct Located {
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

impl Located {
    /// Which of a row's `width` fields [`replication`] reads as text (the
    /// method, the replication id, the by-factors) and which as numbers.
    pub(super) fn reads(&self, width: usize) -> (Vec<bool>, Vec<bool>) {
        let (mut texts, mut numbers) = (vec![false; width], vec![false; width]);
        let named = [self.method].into_iter().chain(self.rep).chain(self.by.iter().copied());
        named.for_each(|k| texts[k] = true);
        let limits = self.ci.into_iter().flat_map(|(l, u)| [l, u]);
        let given = [self.truth, self.level].into_iter().filter_map(Result::err);
        let read = [self.estimate, self.se].into_iter().chain(limits).chain(self.df).chain(given);
        read.for_each(|k| numbers[k] = true);
        (texts, numbers)
    }
}

pub(super) type At<'a> = &'a dyn Fn(usize, usize, String) -> SimsumFileError;

pub(super) fn locate(header: &[String], cols: &Columns, at: At) -> Result<Located, SimsumFileError> {
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

/// The replications (and the notes on columns not read) of a file's CSV
/// text; an error placed by `at`.
pub(super) fn from_text(
    text: &str,
    cols: &Columns,
    at: At,
) -> Result<(Vec<Replication>, Vec<String>), SimsumFileError> {
    let lines = crate::io::LineIndex::new(text.as_bytes());
    let mut reader = csv::ReaderBuilder::new().has_headers(true).flexible(false).from_reader(text.as_bytes());
    let header: Vec<String> =
        reader.headers().map_err(|e| at(1, 1, e.to_string()))?.iter().map(|h| h.trim().to_string()).collect();
    let loc = locate(&header, cols, at)?;
    let notes = unused_columns(&header, cols);
    let mut out = Vec::new();
    for row in reader.records() {
        let row = row.map_err(|e| {
            let line = e.position().map(|p| lines.line_of(p.byte() as usize)).unwrap_or(1);
            at(line, 1, e.to_string())
        })?;
        let line = row.position().map(|p| lines.line_of(p.byte() as usize)).unwrap_or(1);
        out.push(replication(&row, line, &loc, at)?);
    }
    if out.is_empty() {
        return Err(at(1, 1, "the file holds a header and no replications".into()));
    }
    Ok((out, notes))
}

/// One row's fields, as the replications file's CSV text gives them.
pub(super) trait Fields {
    /// Field `k`, trimmed; empty where the row has none.
    fn text(&self, k: usize) -> &str;
    /// Field `k` as a number ([`number`]).
    fn number(&self, k: usize) -> Option<f64>;
}

impl Fields for csv::StringRecord {
    fn text(&self, k: usize) -> &str {
        self.get(k).unwrap_or("").trim()
    }

    fn number(&self, k: usize) -> Option<f64> {
        number(self.text(k))
    }
}

/// A field's text (trimmed) as a number: NaN where it is missing (empty,
/// `NA`, `NaN`, `nan`), `None` where it is no number.
pub(super) fn number(field: &str) -> Option<f64> {
    match field {
        "" | "NA" | "NaN" | "nan" => Some(f64::NAN),
        v => v.parse::<f64>().ok(),
    }
}

/// One row as a replication; a bad field is an error at its column.
pub(super) fn replication(
    row: &impl Fields,
    line: usize,
    loc: &Located,
    at: At,
) -> Result<Replication, SimsumFileError> {
    let field = |k: usize| row.text(k);
    // A missing value (empty, NA, NaN) is NaN; anything else must be a
    // finite number (or, for df, infinite).
    let value = |k: usize, what: &str| -> Result<f64, SimsumFileError> {
        row.number(k).filter(|x| !x.is_infinite() || what == "df").ok_or_else(|| {
            at(line, k + 1, format!("{what} \"{}\" is not a number (write NA for a missing value)", field(k)))
        })
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
