//! lme4's formula language for random-intercept models, and the model it
//! describes built from a table of columns, the way R builds it.
//!
//! `y ~ 1 + x + f + f:x + (1|a) + (1|b) + (1|a:c)`: a numeric response;
//! fixed terms that are columns, `factor(col)` (a numeric column taken as
//! categorical), interactions `a:b` and crossings `a*b` (= `a + b + a:b`);
//! random intercepts `(1|g)`, `(1|g:h)` (the interaction factor) and
//! `(1|g/h)` (= `(1|g) + (1|g:h)`). A column whose every value is a number
//! is numeric, any other is categorical, as R's `read.csv` reads them.
//!
//! The fixed-effect design is R's `model.matrix`: terms in order of degree
//! (as written within a degree), each categorical variable of a term coded
//! by treatment contrasts (the first level, sorted as R sorts them, is the
//! reference) when the term without it is in the model (the intercept
//! counts as the empty term), by indicators of every level otherwise; a
//! term's columns are the products of its variables' columns, the first
//! variable varying fastest, named as R names them (`fq:x`).
//!
//! Random slopes (`(x|g)`), a model without an intercept, and missing
//! values are refused with the column of the formula or the row and field
//! of the table: R drops rows with missing values silently, crossaudit
//! makes the user say so.

use std::collections::HashMap;

use super::{MixedData, MixedError};

/// The most variables one `*` crossing may join (2^10 - 1 = 1,023 terms).
pub const MAX_CROSSED: usize = 10;

/// The most random-intercept terms of one model.
pub const MAX_RANDOM: usize = 16;

/// A parsed formula.
#[derive(Debug, Clone, PartialEq)]
pub struct Formula {
    /// The response column.
    pub response: String,
    /// Fixed terms beside the intercept, each a list of variables, in R's
    /// order (by degree, then as written).
    pub fixed: Vec<Vec<Variable>>,
    /// Random-intercept grouping factors, each the columns it interacts.
    pub random: Vec<Vec<String>>,
}

/// A variable of a fixed term.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Variable {
    /// The column.
    pub name: String,
    /// Written `factor(name)`: categorical whatever its values.
    pub factor: bool,
}

/// Why a formula or a table cannot be turned into a model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FormulaError {
    /// The formula's text, at a 1-based character column.
    #[error("formula, column {column}: {message}")]
    Syntax {
        /// 1-based column in the formula.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A name the table does not have.
    #[error("formula: unknown column `{name}` (the table has: {available})")]
    UnknownColumn {
        /// The name.
        name: String,
        /// The table's columns.
        available: String,
    },
    /// A value of the table, at its 1-based data row and field.
    #[error("row {row}, field {field}: {message}")]
    Value {
        /// 1-based row of data (the header is row 0).
        row: usize,
        /// The column.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// The file cannot be read (its own message names it).
    #[error("{0}")]
    Read(String),
    /// The model the formula describes cannot be fitted.
    #[error(transparent)]
    Model(#[from] MixedError),
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Name(String),
    Number(String),
    Sym(char),
}

fn tokenize(text: &str) -> Result<Vec<(usize, Token)>, FormulaError> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let column = i + 1;
        if c.is_whitespace() {
            i += 1;
        } else if c == '`' {
            let end = chars[i + 1..]
                .iter()
                .position(|&d| d == '`')
                .ok_or(FormulaError::Syntax { column, message: "a backquoted name is not closed".into() })?;
            out.push((column, Token::Name(chars[i + 1..i + 1 + end].iter().collect())));
            i += end + 2;
        } else if c.is_ascii_alphabetic() || c == '.' || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_ascii_alphanumeric() || chars[i] == '.' || chars[i] == '_') {
                i += 1;
            }
            out.push((column, Token::Name(chars[start..i].iter().collect())));
        } else if c.is_ascii_digit() {
            let start = i;
            while i < chars.len() && (chars[i].is_ascii_digit() || chars[i] == '.') {
                i += 1;
            }
            out.push((column, Token::Number(chars[start..i].iter().collect())));
        } else if "~+:*()|/-".contains(c) {
            out.push((column, Token::Sym(c)));
            i += 1;
        } else {
            return Err(FormulaError::Syntax { column, message: format!("unexpected character `{c}`") });
        }
    }
    Ok(out)
}

struct Parser {
    tokens: Vec<(usize, Token)>,
    at: usize,
    end: usize,
}

impl Parser {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.at).map(|(_, t)| t)
    }
    fn column(&self) -> usize {
        self.tokens.get(self.at).map(|(c, _)| *c).unwrap_or(self.end)
    }
    fn error<T>(&self, message: impl Into<String>) -> Result<T, FormulaError> {
        Err(FormulaError::Syntax { column: self.column(), message: message.into() })
    }
    fn expect(&mut self, c: char, what: &str) -> Result<(), FormulaError> {
        if self.peek() == Some(&Token::Sym(c)) {
            self.at += 1;
            Ok(())
        } else {
            self.error(format!("expected `{c}` {what}"))
        }
    }
    fn name(&mut self, what: &str) -> Result<String, FormulaError> {
        match self.peek() {
            Some(Token::Name(n)) => {
                let n = n.clone();
                self.at += 1;
                Ok(n)
            }
            _ => self.error(format!("expected {what}")),
        }
    }
    /// `name` or `factor(name)`.
    fn variable(&mut self) -> Result<Variable, FormulaError> {
        let column = self.column();
        let name = self.name("a column name")?;
        if name == "factor" && self.peek() == Some(&Token::Sym('(')) {
            self.at += 1;
            let inner = self.name("a column name inside factor( )")?;
            self.expect(')', "to close factor(")?;
            return Ok(Variable { name: inner, factor: true });
        }
        if self.peek() == Some(&Token::Sym('(')) {
            return Err(FormulaError::Syntax {
                column,
                message: format!("`{name}(...)`: the only function a formula may use is factor()"),
            });
        }
        Ok(Variable { name, factor: false })
    }
}

/// Parses `response ~ terms`.
pub fn parse(text: &str) -> Result<Formula, FormulaError> {
    let tokens = tokenize(text)?;
    let end = text.chars().count() + 1;
    let mut p = Parser { tokens, at: 0, end };
    let response = p.name("the response column before `~`")?;
    p.expect('~', "after the response")?;
    // Fixed terms as written: each a set of variables (a crossing expands).
    let mut fixed: Vec<Vec<Variable>> = Vec::new();
    let mut random: Vec<Vec<String>> = Vec::new();
    let mut first = true;
    loop {
        if !first {
            match p.peek() {
                None => break,
                Some(Token::Sym('+')) => p.at += 1,
                Some(Token::Sym('-')) => return p.error("removing terms (`-`) is not supported"),
                _ => return p.error("expected `+` between terms"),
            }
        }
        first = false;
        match p.peek().cloned() {
            None => return p.error("expected a term"),
            Some(Token::Number(n)) if n == "1" => p.at += 1,
            Some(Token::Number(n)) if n == "0" => {
                return p.error("a model without an intercept (`0`) is not supported");
            }
            Some(Token::Number(n)) => return p.error(format!("`{n}`: a term is a column name, 1, or (1|group)")),
            Some(Token::Sym('(')) => {
                p.at += 1;
                match p.peek() {
                    Some(Token::Number(n)) if n == "1" => p.at += 1,
                    Some(Token::Name(_)) | Some(Token::Number(_)) => {
                        return p.error("random slopes are not supported: only random intercepts (1|group)");
                    }
                    _ => return p.error("expected `1|group` inside the parentheses"),
                }
                if p.peek() == Some(&Token::Sym('|')) {
                    p.at += 1;
                } else if p.peek() == Some(&Token::Sym('+')) {
                    return p.error("random slopes are not supported: only random intercepts (1|group)");
                } else {
                    return p.error("expected `|` after `(1`");
                }
                let mut path = vec![p.name("a grouping column after `|`")?];
                loop {
                    match p.peek() {
                        Some(Token::Sym(':')) => {
                            p.at += 1;
                            path.push(p.name("a grouping column after `:`")?);
                        }
                        Some(Token::Sym('/')) => {
                            p.at += 1;
                            // g/h: (1|g) + (1|g:h); the outer part stands alone.
                            random.push(path.clone());
                            path.push(p.name("a grouping column after `/`")?);
                        }
                        _ => break,
                    }
                }
                p.expect(')', "to close the random term")?;
                random.push(path);
            }
            Some(Token::Name(_)) => {
                let mut groups: Vec<Vec<Variable>> = vec![vec![p.variable()?]];
                loop {
                    match p.peek() {
                        Some(Token::Sym(':')) => {
                            p.at += 1;
                            let v = p.variable()?;
                            groups.last_mut().expect("one group at least").push(v);
                        }
                        Some(Token::Sym('*')) => {
                            p.at += 1;
                            groups.push(vec![p.variable()?]);
                        }
                        _ => break,
                    }
                }
                // a:b * c:d = every non-empty union of the crossed parts.
                if groups.len() > MAX_CROSSED {
                    return p.error(format!(
                        "{} variables crossed with `*` make {} terms; at most {MAX_CROSSED} may be crossed",
                        groups.len(),
                        if groups.len() < 64 {
                            ((1u64 << groups.len()) - 1).to_string()
                        } else {
                            "more than 2^63".into()
                        }
                    ));
                }
                for mask in 1..(1u32 << groups.len()) {
                    let mut term: Vec<Variable> = Vec::new();
                    for (g, part) in groups.iter().enumerate() {
                        if mask & (1 << g) != 0 {
                            for v in part {
                                if !term.contains(v) {
                                    term.push(v.clone());
                                }
                            }
                        }
                    }
                    fixed.push(term);
                }
            }
            Some(_) => return p.error("expected a term"),
        }
    }
    // Duplicates dropped (as sets), then R's order: by degree, stably.
    let mut unique: Vec<Vec<Variable>> = Vec::new();
    for t in fixed {
        let same = |u: &Vec<Variable>| u.len() == t.len() && t.iter().all(|v| u.contains(v));
        if !unique.iter().any(same) {
            unique.push(t);
        }
    }
    unique.sort_by_key(|t| t.len());
    let mut groups: Vec<Vec<String>> = Vec::new();
    for r in random {
        if !groups.contains(&r) {
            groups.push(r);
        }
    }
    if groups.is_empty() {
        return Err(FormulaError::Syntax {
            column: end,
            message: "a mixed model needs a random term (1|group)".into(),
        });
    }
    if groups.len() > MAX_RANDOM {
        return Err(FormulaError::Syntax {
            column: end,
            message: format!(
                "{} random-intercept terms; at most {MAX_RANDOM} (the optimizer searches one variance ratio per term)",
                groups.len()
            ),
        });
    }
    Ok(Formula { response, fixed: unique, random: groups })
}

/// A table of text columns, as read from a CSV file.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Column names.
    pub names: Vec<String>,
    /// Columns, each a value per row.
    pub columns: Vec<Vec<String>>,
}

impl Table {
    fn column(&self, name: &str) -> Result<&[String], FormulaError> {
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

/// Checks a column has no missing value.
fn present(table: &Table, name: &str) -> Result<(), FormulaError> {
    if let Some(row) = table.column(name)?.iter().position(|v| is_missing(v)) {
        return Err(FormulaError::Value {
            row: row + 1,
            field: name.into(),
            message: "missing value: crossaudit does not drop rows (lme4's na.omit would); remove the row first".into(),
        });
    }
    Ok(())
}

fn numbers(table: &Table, name: &str) -> Result<Option<Vec<f64>>, FormulaError> {
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
            let col = table.column(&v.name)?;
            let mut levels: Vec<String> = col.iter().map(|s| s.trim().to_string()).collect();
            levels.sort();
            levels.dedup();
            // R sorts a numeric vector's levels numerically.
            if numeric.is_some() {
                levels.sort_by(|a, b| a.parse::<f64>().unwrap_or(0.0).total_cmp(&b.parse::<f64>().unwrap_or(0.0)));
            }
            if levels.len() > super::MAX_DENSE {
                return Err(MixedError::TooLarge(format!(
                    "the categorical variable {} has {} levels, over the limit of {} fixed-effect columns",
                    v.name,
                    levels.len(),
                    super::MAX_DENSE
                ))
                .into());
            }
            let skip = usize::from(contrasts);
            Ok(levels
                .iter()
                .skip(skip)
                .map(|l| {
                    let values = col.iter().map(|s| if s.trim() == l { 1.0 } else { 0.0 }).collect();
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

/// The model `formula` describes, on `table`: response, fixed-effect
/// columns by R's rules, and the random factors.
pub fn build(formula: &Formula, table: &Table) -> Result<MixedData, FormulaError> {
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
    let mut factors = Vec::new();
    for group in &formula.random {
        for g in group {
            present(table, g)?;
        }
        let cols: Vec<&[String]> = group.iter().map(|g| table.column(g)).collect::<Result<_, _>>()?;
        let mut map: HashMap<Vec<&str>, usize> = HashMap::new();
        let codes = (0..y.len())
            .map(|i| {
                let key: Vec<&str> = cols.iter().map(|c| c[i].trim()).collect();
                let next = map.len();
                *map.entry(key).or_insert(next)
            })
            .collect();
        factors.push((group.join(":"), codes));
    }
    let mut columns: Vec<(String, Vec<f64>)> = Vec::new();
    let in_model = |term: &[&Variable]| -> bool {
        term.is_empty() || formula.fixed.iter().any(|t| t.len() == term.len() && term.iter().all(|v| t.contains(v)))
    };
    for term in &formula.fixed {
        let mut parts: Vec<Vec<(String, Vec<f64>)>> = Vec::new();
        for v in term {
            let contrasts = if categorical(table, v)? {
                let without: Vec<&Variable> = term.iter().filter(|u| *u != v).collect();
                in_model(&without)
            } else {
                true
            };
            parts.push(coded(table, v, contrasts)?);
        }
        // Products, the first variable varying fastest.
        let mut acc: Vec<(String, Vec<f64>)> = vec![(String::new(), vec![1.0; y.len()])];
        for part in &parts {
            let width = columns.len() + acc.len() * part.len();
            if width > super::MAX_DENSE || width.saturating_mul(y.len()) > super::MAX_DESIGN_VALUES {
                return Err(MixedError::TooLarge(format!(
                    "the fixed effects would have {width} columns for {} observations, over the limits of {} columns and {} values",
                    y.len(),
                    super::MAX_DENSE,
                    super::MAX_DESIGN_VALUES
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
        columns.extend(acc);
    }
    Ok(MixedData::new(y, factors)?.with_columns(columns)?)
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

/// Which small-sample df the summary's t tests use (REML fits).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DfMethod {
    /// lmerTest's default.
    Satterthwaite,
    /// pbkrtest's, with its adjusted standard errors.
    KenwardRoger,
}

/// A model fitted from a formula and a table, with what lme4's and
/// lmerTest's summaries print.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FormulaFit {
    /// The formula as given.
    pub formula: String,
    /// The df method of the `fixed` table (`None` for ML fits, which lme4
    /// summarises with t values only).
    pub df_method: Option<DfMethod>,
    /// The fit.
    pub fit: super::MixedFit,
    /// Per fixed effect: name, estimate, SE (Kenward-Roger's adjusted SE
    /// under that method), df, t and two-sided p.
    pub fixed: Vec<FixedRow>,
    /// Profile-likelihood intervals of the standard deviations, when asked.
    pub profile: Option<(f64, Vec<super::ProfileInterval>)>,
}

/// One row of the fixed-effects table.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FixedRow {
    /// R's column name.
    pub name: String,
    /// Estimate.
    pub estimate: f64,
    /// Standard error.
    pub se: f64,
    /// Denominator df (`None` for ML, or where the method is undefined).
    pub df: Option<f64>,
    /// t value.
    pub t: f64,
    /// Two-sided p from t on `df`.
    pub p: Option<f64>,
}

/// Fits `formula` to `table` by `criterion`, with the fixed-effect table
/// on `df` and, with `profile`, profile intervals at that level.
pub fn fit_table(
    formula_text: &str,
    table: &Table,
    criterion: super::Criterion,
    df: DfMethod,
    profile: Option<f64>,
) -> Result<FormulaFit, FormulaError> {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    let formula = parse(formula_text)?;
    let data = build(&formula, table)?;
    if let Some(level) = profile {
        if level.is_nan() || level <= 0.0 || level >= 1.0 {
            return Err(MixedError::Level(level).into());
        }
    }
    // Kenward-Roger (and the shares) need the q x q matrices over every
    // level; Satterthwaite needs only deviance evaluations.
    let inference = match (criterion, df) {
        (super::Criterion::Reml, DfMethod::KenwardRoger) => super::Inference::Full,
        (super::Criterion::Reml, DfMethod::Satterthwaite) => super::Inference::Satterthwaite,
        (super::Criterion::Ml, _) => super::Inference::Estimates,
    };
    let fit = super::fit_with(&data, criterion, inference)?;
    let reml = criterion == super::Criterion::Reml;
    let fixed = fit
        .fixed
        .iter()
        .map(|f| {
            let (se, dof) = match (reml, df) {
                (false, _) => (f.se, None),
                (true, DfMethod::Satterthwaite) => (f.se, f.df_satterthwaite),
                (true, DfMethod::KenwardRoger) => match f.kenward_roger {
                    Some(kr) => (kr.se, Some(kr.df)),
                    None => (f.se, None),
                },
            };
            let t = f.estimate / se;
            let p = dof
                .filter(|d| d.is_finite() && *d > 0.0)
                .and_then(|d| StudentsT::new(0.0, 1.0, d).ok().map(|dist| 2.0 * dist.sf(t.abs())));
            FixedRow { name: f.name.clone(), estimate: f.estimate, se, df: dof, t, p }
        })
        .collect();
    let profile = match profile {
        Some(level) => Some((level, super::profile_intervals(&data, criterion, level)?)),
        None => None,
    };
    Ok(FormulaFit { formula: formula_text.to_string(), df_method: reml.then_some(df), fit, fixed, profile })
}

impl FormulaFit {
    /// The summary as lme4 and lmerTest print it, with the optimizer's
    /// certificate and any warning on their own lines.
    pub fn summary(&self) -> String {
        use std::fmt::Write;
        let f = &self.fit;
        let mut s = String::new();
        let (what, crit) = match f.criterion {
            super::Criterion::Reml => ("REML", "REML criterion at convergence"),
            super::Criterion::Ml => ("maximum likelihood", "deviance"),
        };
        let df = match self.df_method {
            Some(DfMethod::Satterthwaite) => ". t-tests use Satterthwaite's method",
            Some(DfMethod::KenwardRoger) => ". t-tests use the Kenward-Roger method",
            None => "",
        };
        let _ = writeln!(s, "Linear mixed model fit by {what}{df}");
        let _ = writeln!(s, "Formula: {}\n", self.formula);
        let _ = writeln!(s, "{crit}: {:.4}\n", f.deviance);
        let _ = writeln!(s, "Random effects:");
        let width = f.factors.iter().map(|n| n.len()).max().unwrap_or(0).max(8);
        let _ = writeln!(s, " {:<width$} {:<11} {:>12} {:>12}", "Groups", "Name", "Variance", "Std.Dev.");
        for (name, v) in f.factors.iter().zip(&f.variances) {
            let _ = writeln!(s, " {:<width$} {:<11} {:>12.6} {:>12.6}", name, "(Intercept)", v, v.sqrt());
        }
        let _ = writeln!(s, " {:<width$} {:<11} {:>12.6} {:>12.6}", "Residual", "", f.residual, f.residual.sqrt());
        let groups: Vec<String> = f.factors.iter().zip(&f.levels).map(|(n, l)| format!("{n}, {l}")).collect();
        let _ = writeln!(s, "Number of obs: {}, groups:  {}\n", f.n, groups.join("; "));
        let _ = writeln!(s, "Fixed effects:");
        let width = self.fixed.iter().map(|r| r.name.len()).max().unwrap_or(0).max(11);
        let with_df = self.df_method.is_some();
        if with_df {
            let _ = writeln!(
                s,
                "{:<width$} {:>12} {:>12} {:>10} {:>9} {:>10}",
                "", "Estimate", "Std. Error", "df", "t value", "Pr(>|t|)"
            );
        } else {
            let _ = writeln!(s, "{:<width$} {:>12} {:>12} {:>9}", "", "Estimate", "Std. Error", "t value");
        }
        for r in &self.fixed {
            if with_df {
                let dof = r.df.map(|d| format!("{d:.3}")).unwrap_or_else(|| "NA".into());
                let p = r.p.map(|p| format!("{p:.3e}")).unwrap_or_else(|| "NA".into());
                let _ = writeln!(
                    s,
                    "{:<width$} {:>12.6} {:>12.6} {:>10} {:>9.3} {:>10}",
                    r.name, r.estimate, r.se, dof, r.t, p
                );
            } else {
                let _ = writeln!(s, "{:<width$} {:>12.6} {:>12.6} {:>9.3}", r.name, r.estimate, r.se, r.t);
            }
        }
        if let Some((level, intervals)) = &self.profile {
            let _ = writeln!(s, "\nProfile-likelihood intervals of the standard deviations ({:.1}%):", 100.0 * level);
            for i in intervals {
                let _ = writeln!(s, " {:<20} {:>12.6} [{:.6}, {:.6}]", i.name, i.estimate, i.lower, i.upper);
            }
        }
        let c = &f.certificate;
        let boundary: Vec<String> =
            f.factors.iter().zip(&c.boundary).filter_map(|(n, d)| d.map(|d| format!("{n} {d:.3e}"))).collect();
        let _ = writeln!(
            s,
            "\noptimizer: {} ({} deviance evaluations, {} restarts); max |gradient| {:.2e}, predicted decrease {:.2e}{}",
            if c.certified { "optimum certified" } else { "NOT CERTIFIED" },
            f.evaluations,
            c.restarts,
            c.gradient,
            c.predicted_decrease,
            if boundary.is_empty() {
                String::new()
            } else {
                format!("; boundary d(criterion)/d(theta^2): {}", boundary.join(", "))
            }
        );
        if !c.certified {
            let _ = writeln!(s, "warning: the optimizer could not certify this point as the optimum; do not use it");
        }
        if f.singular {
            let _ = writeln!(
                s,
                "boundary (singular) fit: a variance is estimated at (or within 1e-4 of) zero, as lme4's isSingular says"
            );
            if self.df_method.is_some() {
                let _ = writeln!(s, "note: at a singular fit Satterthwaite holds the zero component fixed while Kenward-Roger keeps it (a generalized inverse), so their df differ");
            }
        }
        s
    }
}

/// A formula fit that failed, with the data file it was on.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {error}")]
pub struct FileError {
    /// The data file.
    pub file: String,
    /// What went wrong.
    pub error: FormulaError,
}

/// Reads the tidy CSV at `path` and fits `formula` to it (see
/// [`fit_table`]). A path that is not a regular file (a folder, a FIFO, a
/// device) or is over 1 GiB is refused before it is read
/// ([`crate::io::read_input`]).
pub fn fit_file(
    path: &std::path::Path,
    formula: &str,
    criterion: super::Criterion,
    df: DfMethod,
    profile: Option<f64>,
) -> Result<FormulaFit, FileError> {
    let fail = |error: FormulaError| FileError { file: path.display().to_string(), error };
    let read = |message: String| fail(FormulaError::Read(message));
    let bytes =
        crate::io::read_input(path, crate::io::MAX_CELLS_FILE, "a data file").map_err(|e| read(e.to_string()))?;
    let text = String::from_utf8(bytes)
        .map_err(|e| read(format!("not UTF-8 text (byte {} is not)", e.utf8_error().valid_up_to())))?;
    let table = read_csv(&text).map_err(fail)?;
    fit_table(formula, &table, criterion, df, profile).map_err(fail)
}
