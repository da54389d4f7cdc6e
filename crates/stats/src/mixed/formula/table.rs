//! The table a formula is fitted to (text columns as read from a CSV
//! file) and the model R builds from the two: `model.matrix`'s fixed
//! design, the grouping factors, R's levels and labels.

use std::collections::HashMap;

use super::{Formula, FormulaError, Variable};
use crate::mixed::slopes::{SlopeData, Term};
use crate::mixed::{MixedData, MixedError};

/// A table of text columns, as read from a CSV file.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Column names.
    pub names: Vec<String>,
    /// Columns, each a value per row.
    pub columns: Vec<Vec<String>>,
}

impl Table {
    pub(super) fn column(&self, name: &str) -> Result<&[String], FormulaError> {
        match self.names.iter().position(|n| n == name) {
            Some(i) => Ok(&self.columns[i]),
            None => Err(FormulaError::UnknownColumn { name: name.into(), available: self.names.join(", ") }),
        }
    }
}

fn is_missing(v: &str) -> bool {
    let t = v.trim();
    t.is_empty() || t == "NA" || t == "NaN" || t == "nan"
}

/// Checks a column has no missing value and no control character (a NUL
/// byte, a tab, an escape) in any value: such a byte is a corrupted file,
/// not a new level.
pub(super) fn present(table: &Table, name: &str) -> Result<(), FormulaError> {
    let col = table.column(name)?;
    for (row, value) in col.iter().enumerate() {
        if let Some((at, c)) = value.chars().enumerate().find(|(_, c)| c.is_control()) {
            return Err(FormulaError::Value {
                row: row + 1,
                field: name.into(),
                message: format!(
                    "the value contains the control character U+{:04X} at character {}: a value must be printable text (a NUL or other control byte means the file is corrupted)",
                    c as u32,
                    at + 1
                ),
            });
        }
    }
    if let Some(row) = col.iter().position(|v| is_missing(v)) {
        return Err(FormulaError::Value {
            row: row + 1,
            field: name.into(),
            message: "missing value: crossaudit does not drop rows (lme4's na.omit would); remove the row first".into(),
        });
    }
    Ok(())
}

/// R's `as.character` of a double, the label `factor()` gives a level of
/// a numeric column: 15 significant digits, in fixed notation unless
/// scientific is narrower (`1`, `2.5`, `1e+05`, `1e-04`, `123456`).
pub fn r_number_label(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    if !v.is_finite() {
        return if v.is_nan() {
            "NaN".into()
        } else if v > 0.0 {
            "Inf".into()
        } else {
            "-Inf".into()
        };
    }
    let sign = if v < 0.0 { "-" } else { "" };
    let sci = format!("{:.14e}", v.abs());
    let (mantissa, exp) = sci.split_once('e').unwrap_or((&sci, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    let digits = mantissa.replace('.', "");
    let digits = digits.trim_end_matches('0');
    let sig = digits.len().max(1) as i32;
    let fixed_width = if exp >= 0 { (exp + 1).max(sig) + i32::from(sig > exp + 1) } else { 1 - exp + sig };
    let sci_width = sig + i32::from(sig > 1) + if exp.abs() >= 100 { 5 } else { 4 };
    if fixed_width <= sci_width {
        let decimals = (sig - 1 - exp).max(0) as usize;
        format!("{sign}{:.*}", decimals, v.abs())
    } else {
        let mantissa = if sig > 1 { format!("{}.{}", &digits[..1], &digits[1..]) } else { digits[..1].to_string() };
        format!("{sign}{mantissa}e{}{:02}", if exp < 0 { '-' } else { '+' }, exp.abs())
    }
}

/// A column's labels as R's `factor()` makes them: the values as written
/// (trimmed) for a text column; for a column numeric in every row, each
/// value as R prints it, so that `1`, `1.0` and `1e0` are one level.
fn labels(table: &Table, name: &str) -> Result<Vec<String>, FormulaError> {
    Ok(match numbers(table, name)? {
        Some(values) => {
            // Each distinct value is formatted once: a factor column has
            // few levels and many rows.
            let mut seen: HashMap<u64, String> = HashMap::new();
            values.iter().map(|v| seen.entry(v.to_bits()).or_insert_with(|| r_number_label(*v)).clone()).collect()
        }
        None => table.column(name)?.iter().map(|s| s.trim().to_string()).collect(),
    })
}

/// Checks that a numeric column's sums and sums of squares (about its
/// mean, and about zero where `raw`) stay finite in double precision: a
/// column of values near 1e305 overflows where the model's products are
/// formed, and the fit would report nonsense.
fn check_scale(name: &str, values: &[f64], raw: bool) -> Result<(), FormulaError> {
    let n = values.len() as f64;
    let largest = values.iter().copied().map(f64::abs).fold(0.0, f64::max);
    let sum: f64 = values.iter().sum();
    let mean = sum / n;
    let centred: f64 = values.iter().map(|v| (v - mean).powi(2)).sum();
    let squares: f64 = if raw { values.iter().map(|v| v * v).sum() } else { 0.0 };
    // Values below 1e-60 (not 0): their squares' squares, which the
    // variances' derivatives and df use, underflow double precision, and
    // the fit reports a residual of 0 or p < 2e-16 for nothing.
    if let Some(row) = values.iter().position(|v| *v != 0.0 && v.abs() < 1e-60) {
        return Err(FormulaError::Scale {
            field: name.into(),
            message: format!(
                "its values are too small for double precision: {:e} (row {}) is below 1e-60 in magnitude, where the squares of squares the fit uses underflow; rescale the column (multiply it by a power of ten) and fit again",
                values[row],
                row + 1
            ),
        });
    }
    if sum.is_finite() && centred.is_finite() && squares.is_finite() {
        return Ok(());
    }
    let row = values.iter().position(|v| v.abs() == largest).unwrap_or(0) + 1;
    Err(FormulaError::Scale {
        field: name.into(),
        message: format!(
            "its values are too large for double precision: {} overflows (largest |value| {largest:e}, row {row}); rescale the column (divide it by a power of ten) and fit again",
            if sum.is_finite() { "the sum of their squares" } else { "their sum" },
        ),
    })
}

pub(super) fn numbers(table: &Table, name: &str) -> Result<Option<Vec<f64>>, FormulaError> {
    let col = table.column(name)?;
    let parsed: Vec<Option<f64>> = col.iter().map(|v| v.trim().parse::<f64>().ok()).collect();
    if parsed.iter().all(Option::is_some) {
        let values: Vec<f64> = parsed.into_iter().flatten().collect();
        if let Some(row) = values.iter().position(|v| !v.is_finite()) {
            return Err(FormulaError::Value {
                row: row + 1,
                field: name.into(),
                message: format!("`{}` is not a finite number", col[row]),
            });
        }
        Ok(Some(values))
    } else {
        Ok(None)
    }
}

/// A variable's columns in a term: (suffix per column, values per column).
fn coded(table: &Table, v: &Variable, contrasts: bool) -> Result<Vec<(String, Vec<f64>)>, FormulaError> {
    present(table, &v.name)?;
    let numeric = numbers(table, &v.name)?;
    match (&numeric, v.factor) {
        (Some(values), false) => Ok(vec![(v.name.clone(), values.clone())]),
        _ => {
            // R's levels: sorted as text (C locale) for a text column, by
            // value for a numeric one, labelled as R prints the number.
            let labels = labels(table, &v.name)?;
            let levels: Vec<String> = match &numeric {
                Some(values) => {
                    let mut pairs: Vec<(f64, &String)> = values.iter().copied().zip(&labels).collect();
                    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
                    let mut levels: Vec<String> = pairs.into_iter().map(|(_, l)| l.clone()).collect();
                    levels.dedup();
                    levels
                }
                None => {
                    let mut levels = labels.clone();
                    levels.sort();
                    levels.dedup();
                    levels
                }
            };
            if levels.len() > crate::mixed::MAX_DENSE {
                return Err(MixedError::TooLarge(format!(
                    "the categorical variable {} has {} levels, over the limit of {} fixed-effect columns",
                    v.name,
                    levels.len(),
                    crate::mixed::MAX_DENSE
                ))
                .into());
            }
            let skip = usize::from(contrasts);
            Ok(levels
                .iter()
                .skip(skip)
                .map(|l| {
                    let values = labels.iter().map(|s| if s == l { 1.0 } else { 0.0 }).collect();
                    let label = if v.factor { format!("factor({}){l}", v.name) } else { format!("{}{l}", v.name) };
                    (label, values)
                })
                .collect())
        }
    }
}

/// Whether a variable is categorical in `table`.
fn categorical(table: &Table, v: &Variable) -> Result<bool, FormulaError> {
    Ok(v.factor || numbers(table, &v.name)?.is_none())
}

/// The model a formula describes: random intercepts only, or with slopes.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum FormulaModel {
    /// Every random term `(1|g)`: [`crate::mixed::fit`] fits it.
    Intercepts(MixedData),
    /// Some term with slopes or without an intercept:
    /// [`crate::mixed::slopes::fit_slopes`] fits it.
    Slopes(SlopeData),
}

/// The model `formula` describes, on `table`, when every random term is a
/// random intercept (see [`build_model`] for any formula).
pub fn build(formula: &Formula, table: &Table) -> Result<MixedData, FormulaError> {
    match build_model(formula, table)? {
        FormulaModel::Intercepts(data) => Ok(data),
        FormulaModel::Slopes(_) => Err(FormulaError::Syntax {
            column: 1,
            message: "the formula has random slopes; build it with build_model".into(),
        }),
    }
}

/// The model `formula` describes, on `table`: response, fixed-effect
/// columns by R's rules, and the random terms.
pub fn build_model(formula: &Formula, table: &Table) -> Result<FormulaModel, FormulaError> {
    let (base, factors) = response_and_fixed(formula, table)?;
    if formula.random.iter().all(|t| t.intercept_only()) {
        return Ok(FormulaModel::Intercepts(base));
    }
    Ok(FormulaModel::Slopes(slope_data(formula, table, base, &factors)?))
}

/// The model as the random-slope engine's data, random intercepts
/// included (the same model, fitted with the sparse factor where the
/// intercept engine's dense reduced system would not fit, or with prior
/// weights).
pub(super) fn build_sparse(formula: &Formula, table: &Table) -> Result<SlopeData, FormulaError> {
    let (base, factors) = response_and_fixed(formula, table)?;
    slope_data(formula, table, base, &factors)
}

/// `base` with the random terms of `formula` over its grouping `factors`.
fn slope_data(
    formula: &Formula,
    table: &Table,
    base: MixedData,
    factors: &[(String, Vec<usize>)],
) -> Result<SlopeData, FormulaError> {
    let terms = random_terms(formula, table, factors, base.len())?;
    Ok(SlopeData::new(base, terms)?)
}

/// A model's response and fixed effects, and its grouping factors (name,
/// codes).
type Grouped = (MixedData, Vec<(String, Vec<usize>)>);

/// The response (less its offset) and fixed effects of `formula`, with
/// one grouping factor per random term's group.
fn response_and_fixed(formula: &Formula, table: &Table) -> Result<Grouped, FormulaError> {
    present(table, &formula.response)?;
    let Some(y) = numbers(table, &formula.response)? else {
        let col = table.column(&formula.response)?;
        let row = col.iter().position(|v| v.trim().parse::<f64>().is_err()).unwrap_or(0);
        return Err(FormulaError::Value {
            row: row + 1,
            field: formula.response.clone(),
            message: format!("the response must be a number, found `{}`", col[row]),
        });
    };
    check_scale(&formula.response, &y, false)?;
    // An offset of a linear model moves the response: y - o has the same
    // likelihood in the other parameters (lmer's offset).
    let y = match offset_values(formula, table)? {
        Some(o) => {
            let moved: Vec<f64> = y.iter().zip(&o).map(|(a, b)| a - b).collect();
            check_scale(&formula.response, &moved, false)?;
            moved
        }
        None => y,
    };
    let n = y.len();
    // One factor per grouping (a group with an intercept and a slope term
    // is one factor of the response's data).
    let mut factors: Vec<(String, Vec<usize>)> = Vec::new();
    for term in &formula.random {
        if !factors.iter().any(|(name, _)| *name == term.name) {
            factors.push((term.name.clone(), group_codes(table, &term.columns, n)?));
        }
    }
    let columns = term_columns(&formula.fixed, true, table, n)?;
    let base = MixedData::new(y, factors.clone())?.with_columns(columns)?;
    Ok((base, factors))
}

/// The values of `formula`'s offset (the column, or its logarithm), or
/// an error at the first row where one is missing, not a number or (under
/// `log`) not above 0.
pub(super) fn offset_values(formula: &Formula, table: &Table) -> Result<Option<Vec<f64>>, FormulaError> {
    let Some(offset) = &formula.offset else { return Ok(None) };
    let name = &offset.column;
    present(table, name)?;
    let col = table.column(name)?;
    let Some(values) = numbers(table, name)? else {
        let row = col.iter().position(|v| v.trim().parse::<f64>().is_err()).unwrap_or(0);
        return Err(FormulaError::Value {
            row: row + 1,
            field: name.clone(),
            message: format!("the offset must be a number, found `{}`", col[row].trim()),
        });
    };
    let out: Vec<f64> = if offset.log { values.iter().map(|v| v.ln()).collect() } else { values };
    if let Some(row) = out.iter().position(|v| !v.is_finite()) {
        return Err(FormulaError::Value {
            row: row + 1,
            field: name.clone(),
            message: if offset.log {
                format!("offset(log({name})): `{}` has no finite logarithm (an exposure is above 0)", col[row].trim())
            } else {
                format!("the offset `{}` is not finite", col[row].trim())
            },
        });
    }
    Ok(Some(out))
}

/// Every random term of `formula` with its columns (`(Intercept)` and
/// the slopes' columns, coded as `model.matrix` codes the left of `|`),
/// its grouping factor's codes taken from `factors`.
pub(super) fn random_terms(
    formula: &Formula,
    table: &Table,
    factors: &[(String, Vec<usize>)],
    n: usize,
) -> Result<Vec<Term>, FormulaError> {
    let mut terms = Vec::new();
    for term in &formula.random {
        let codes = factors.iter().find(|(name, _)| *name == term.name).map(|(_, c)| c.clone()).unwrap_or_default();
        let levels = codes.iter().max().map_or(0, |m| m + 1);
        let mut coded: Vec<(String, Vec<f64>)> = Vec::new();
        if term.intercept {
            coded.push(("(Intercept)".to_string(), vec![1.0; n]));
        }
        let slopes = term_columns(&term.slopes, term.intercept, table, n)?;
        if !term.slopes.is_empty() && slopes.is_empty() {
            return Err(FormulaError::RandomTerm {
                term: format!("... | {}", term.name),
                message: "its slope gives no column (a factor with one level): the term is its intercept alone; remove the slope".into(),
            });
        }
        coded.extend(slopes);
        independent_columns(&coded, &term.name)?;
        let (names, columns) = coded.into_iter().unzip();
        terms.push(Term { group: term.name.clone(), factor: term.name.clone(), codes, levels, names, columns });
    }
    separable_terms(&terms)?;
    Ok(terms)
}

/// The terms of one grouping factor (`(x || g)` is `(1|g) + (0 + x|g)`)
/// have linearly independent columns between them too, or their variances
/// cannot be told apart: `(f || g)` with a factor f gives `(1|g)` and
/// `(0 + f|g)`, whose columns (every level's indicator) add up to the
/// intercept, and lme4 fits it with the warning that the model is nearly
/// unidentifiable. Refused, naming the terms and what to write instead.
fn separable_terms(terms: &[Term]) -> Result<(), FormulaError> {
    for (i, t) in terms.iter().enumerate() {
        let same: Vec<&Term> = terms[..i].iter().filter(|u| u.factor == t.factor).collect();
        if same.is_empty() {
            continue;
        }
        let mut coded: Vec<(String, Vec<f64>)> = Vec::new();
        for u in same.iter().copied().chain(std::iter::once(t)) {
            coded.extend(u.names.iter().cloned().zip(u.columns.iter().cloned()));
        }
        if independent_columns(&coded, &t.factor).is_err() {
            let show = |u: &Term| {
                let names: Vec<&str> =
                    u.names.iter().map(|n| if n == "(Intercept)" { "1" } else { n.as_str() }).collect();
                let zero = if u.names.first().map(String::as_str) == Some("(Intercept)") { "" } else { "0 + " };
                format!("({zero}{} | {})", names.join(" + "), u.factor)
            };
            let earlier: Vec<String> = same.iter().map(|u| show(u)).collect();
            return Err(FormulaError::RandomTerm {
                term: format!("{} and {}", earlier.join(", "), show(t)),
                message: format!(
                    "these terms of the grouping factor {} have columns that depend on each other (a factor's level indicators add up to the intercept, as in `(f || g)` with a categorical f), so their variances cannot be told apart (lme4 fits it and warns that the model is nearly unidentifiable); write `(f | g)` for correlated effects, or `(1 | g) + (1 | g:f)`",
                    t.factor
                ),
            });
        }
    }
    Ok(())
}

/// A random term's columns (its intercept and slopes over every row) are
/// linearly independent, or the term is refused naming the first column
/// that depends on those before it: a constant slope (the intercept
/// again), a column of zeros (a factor with one level), or a combination
/// of the others (two collinear slopes). Gram-Schmidt, relative tolerance
/// 1e-9: a term has a handful of columns.
fn independent_columns(coded: &[(String, Vec<f64>)], group: &str) -> Result<(), FormulaError> {
    let term = || {
        let names: Vec<&str> = coded.iter().map(|(n, _)| if n == "(Intercept)" { "1" } else { n.as_str() }).collect();
        format!("{} | {group}", names.join(" + "))
    };
    let mut basis: Vec<Vec<f64>> = Vec::new();
    for (name, column) in coded {
        let norm = column.iter().map(|x| x * x).sum::<f64>().sqrt();
        let mut rest = column.clone();
        for b in &basis {
            let dot: f64 = rest.iter().zip(b).map(|(x, y)| x * y).sum();
            rest.iter_mut().zip(b).for_each(|(x, y)| *x -= dot * y);
        }
        let left = rest.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm == 0.0 || left <= 1e-9 * norm {
            let first = column.first().copied().unwrap_or(0.0);
            let message = if norm == 0.0 {
                format!("its column {name} is 0 in every row (a factor with one level?): its variance cannot be estimated; remove it")
            } else if column.iter().all(|x| *x == first) {
                format!("its column {name} is constant ({first} in every row): a slope on it is the intercept again, and their variances cannot be told apart; remove it")
            } else {
                format!("its column {name} is a linear combination of the term's columns before it (collinear slopes): their variances cannot be told apart; remove one")
            };
            return Err(FormulaError::RandomTerm { term: term(), message });
        }
        basis.push(rest.into_iter().map(|x| x / left).collect());
    }
    Ok(())
}

/// The level code of each row of the grouping `columns` (their
/// interaction), numbered by first appearance.
pub(super) fn group_codes(table: &Table, group: &[String], n: usize) -> Result<Vec<usize>, FormulaError> {
    for g in group {
        present(table, g)?;
    }
    let cols: Vec<Vec<String>> = group.iter().map(|g| labels(table, g)).collect::<Result<_, _>>()?;
    Ok(if let [col] = cols.as_slice() {
        // One column (the usual `(1|g)`): its labels are the keys.
        let mut map: HashMap<&str, usize> = HashMap::new();
        col.iter()
            .map(|label| {
                let next = map.len();
                *map.entry(label.as_str()).or_insert(next)
            })
            .collect()
    } else {
        let mut map: HashMap<Vec<&str>, usize> = HashMap::new();
        (0..n)
            .map(|i| {
                let key: Vec<&str> = cols.iter().map(|c| c[i].as_str()).collect();
                let next = map.len();
                *map.entry(key).or_insert(next)
            })
            .collect()
    })
}

/// The design columns of `terms` (beside the intercept, when `intercept`)
/// by R's `model.matrix`: a categorical variable is coded by treatment
/// contrasts when the term without it is in the model (the intercept is
/// the empty term), by indicators of every level otherwise; without an
/// intercept, R codes the first categorical main effect by indicators and
/// the rest as if the intercept were there.
pub(super) fn term_columns(
    terms: &[Vec<Variable>],
    intercept: bool,
    table: &Table,
    n: usize,
) -> Result<Vec<(String, Vec<f64>)>, FormulaError> {
    let mut columns: Vec<(String, Vec<f64>)> = Vec::new();
    let mut empty_in_model = intercept;
    let in_model = |term: &[&Variable], empty: bool| -> bool {
        if term.is_empty() {
            return empty;
        }
        terms.iter().any(|t| t.len() == term.len() && term.iter().all(|v| t.contains(v)))
    };
    for term in terms {
        let mut parts: Vec<Vec<(String, Vec<f64>)>> = Vec::new();
        for v in term {
            let contrasts = if categorical(table, v)? {
                let without: Vec<&Variable> = term.iter().filter(|u| *u != v).collect();
                let coded_by_contrasts = in_model(&without, empty_in_model);
                if without.is_empty() {
                    empty_in_model = true;
                }
                coded_by_contrasts
            } else {
                true
            };
            parts.push(coded(table, v, contrasts)?);
        }
        // Products, the first variable varying fastest.
        let mut acc: Vec<(String, Vec<f64>)> = vec![(String::new(), vec![1.0; n])];
        for part in &parts {
            let width = columns.len() + acc.len() * part.len();
            if width > crate::mixed::MAX_DENSE || width.saturating_mul(n) > crate::mixed::MAX_DESIGN_VALUES {
                return Err(MixedError::TooLarge(format!(
                    "the fixed effects would have {width} columns for {n} observations, over the limits of {} columns and {} values",
                    crate::mixed::MAX_DENSE,
                    crate::mixed::MAX_DESIGN_VALUES
                ))
                .into());
            }
            let mut next = Vec::new();
            for (name_b, vb) in part {
                for (name_a, va) in &acc {
                    let name = if name_a.is_empty() { name_b.clone() } else { format!("{name_a}:{name_b}") };
                    next.push((name, va.iter().zip(vb).map(|(a, b)| a * b).collect()));
                }
            }
            acc = next;
        }
        for (name, values) in &acc {
            check_scale(name, values, true)?;
        }
        columns.extend(acc);
    }
    Ok(columns)
}

/// Reads a tidy CSV (a header row of names, then one row per observation)
/// from `text`.
pub fn read_csv(text: &str) -> Result<Table, FormulaError> {
    // A byte-order mark (spreadsheet exports) is not part of the first name.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut reader = csv::ReaderBuilder::new().has_headers(true).flexible(false).from_reader(text.as_bytes());
    let names: Vec<String> = match reader.headers() {
        Ok(h) => h.iter().map(|s| s.trim().trim_matches('"').to_string()).collect(),
        Err(e) => return Err(FormulaError::Value { row: 0, field: "header".into(), message: e.to_string() }),
    };
    if names.is_empty() || names.iter().all(String::is_empty) {
        return Err(FormulaError::Value { row: 0, field: "header".into(), message: "the file has no header".into() });
    }
    for (i, name) in names.iter().enumerate() {
        if names[..i].contains(name) {
            return Err(FormulaError::Value {
                row: 0,
                field: name.clone(),
                message: format!(
                    "the header names column `{name}` twice (fields {} and {})",
                    names[..i].iter().position(|n| n == name).unwrap_or(0) + 1,
                    i + 1
                ),
            });
        }
    }
    let mut columns: Vec<Vec<String>> = vec![Vec::new(); names.len()];
    for (row, record) in reader.records().enumerate() {
        let record = record.map_err(|e| FormulaError::Value {
            row: row + 1,
            field: "*".into(),
            message: match e.kind() {
                csv::ErrorKind::UnequalLengths { expected_len, len, .. } => {
                    format!("{len} fields where the header has {expected_len}")
                }
                _ => e.to_string(),
            },
        })?;
        for (c, v) in record.iter().enumerate() {
            columns[c].push(v.to_string());
        }
    }
    Ok(Table { names, columns })
}
