//! lme4's formula language for linear mixed models, and the model it
//! describes built from a table of columns, the way R builds it.
//!
//! `y ~ 1 + x + f + f:x + (1|a) + (1|b) + (1|a:c)`: a numeric response;
//! fixed terms that are columns, `factor(col)` (a numeric column taken as
//! categorical), interactions `a:b` and crossings `a*b` (= `a + b + a:b`);
//! random intercepts `(1|g)`, `(1|g:h)` (the interaction factor) and
//! `(1|g/h)` (= `(1|g) + (1|h:g)`, lme4's expansion and names). A column whose every value is a number
//! is numeric, any other is categorical, as R's `read.csv` reads them; a
//! categorical numeric column (`factor(d)`, a grouping column) has R's
//! levels: by value, labelled as R prints the number ([`r_number_label`]).
//!
//! The fixed-effect design is R's `model.matrix`: terms in order of degree
//! (as written within a degree), each categorical variable of a term coded
//! by treatment contrasts (the first level, sorted as R sorts them, is the
//! reference) when the term without it is in the model (the intercept
//! counts as the empty term), by indicators of every level otherwise; a
//! term's variables are in order of their first appearance in the formula
//! (R's `terms`: `Type + conc:Type` has the term `Type:conc`), its columns
//! the products of its variables' columns, the first variable varying
//! fastest, named as R names them (`TypeQuebec:conc`).
//!
//! Random slopes: `(x|g)` (= `(1 + x|g)`), `(0 + x|g)`, `(x||g)` (lme4's
//! `(1|g) + (0 + x|g)`), their left side coded as a fixed part is (a
//! factor's columns), fitted by [`crate::mixed::slopes`].
//!
//! A model without a fixed intercept, the response
//! among the predictors, missing values, control characters in a value and
//! numbers whose sums overflow are refused with the column of the formula
//! or the row and field of the table: R drops rows with missing values
//! silently, crossaudit makes the user say so.

mod fit;
mod glmm_fit;
mod number;
mod slopes_fit;
mod table;

pub use fit::{
    compare_table, fit_table, fit_table_weighted, ComparedModel, Comparison, DfMethod, FileError, Fitted, FixedRow,
    FormulaFit, Likelihood,
};
pub use glmm_fit::{build_glmm, build_glmm_with, fit_glmm_table, fit_glmm_with, GlmmFormulaFit, GlmmOptions};
pub use table::{build, build_model, r_number_label, read_csv, FormulaModel, Table};

use super::MixedError;

/// The most variables one `*` crossing may join (2^10 - 1 = 1,023 terms).
pub const MAX_CROSSED: usize = 10;

/// The most random-intercept terms of one model.
pub const MAX_RANDOM: usize = 16;

/// A parsed formula.
#[derive(Debug, Clone, PartialEq)]
pub struct Formula {
    /// The response column (the successes of `cbind(successes, failures)`).
    pub response: String,
    /// The failures of a binomial response `cbind(successes, failures)`.
    pub failures: Option<String>,
    /// The trials of a binomial response written `cbind(successes,
    /// trials - successes)`: the failures are the difference.
    pub trials: Option<String>,
    /// `offset(col)` or `offset(log(col))`: a term of the linear predictor
    /// with its coefficient fixed at 1.
    pub offset: Option<Offset>,
    /// The denominator of a response written `a / b` (a binomial model's
    /// proportion with `--weights b`, glmer's `incidence / size` with
    /// `weights = size`).
    pub divisor: Option<String>,
    /// Fixed terms beside the intercept, each a list of variables, in R's
    /// order (by degree, then as written).
    pub fixed: Vec<Vec<Variable>>,
    /// Random-intercept grouping factors.
    pub random: Vec<RandomTerm>,
    /// Random terms written more than once and fitted once (lme4 fits
    /// each copy, with variances only their sum of which the data can
    /// tell: the same fit, its variance split between the copies).
    pub merged: usize,
}

impl Formula {
    /// What a fit of this formula tells its reader where a random term is
    /// written more than once ([`Formula::merged`]).
    pub fn merged_note(&self) -> Option<String> {
        (self.merged > 0).then(|| {
            "a random term written more than once is fitted once (lme4 fits each copy, with variances the data cannot tell apart: the same fit, its variance split between the copies)".to_string()
        })
    }
}

/// A random-effect term: the grouping factor and what varies over its
/// levels (an intercept, and slopes).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RandomTerm {
    /// The columns the grouping factor interacts.
    pub columns: Vec<String>,
    /// lme4's name: `g:h` as written, `(1|g/h)` gives `g` and `h:g`,
    /// `(1|a/b/c)` gives `a`, `b:a` and `c:(b:a)`.
    pub name: String,
    /// Whether the term has an intercept (`(x|g)` and `(1 + x|g)` do,
    /// `(0 + x|g)` does not).
    pub intercept: bool,
    /// The slopes: terms of the left of `|`, as fixed terms are, in R's
    /// order (by degree, then as written). Empty for `(1|g)`.
    pub slopes: Vec<Vec<Variable>>,
}

impl RandomTerm {
    /// Whether the term has only an intercept, `(1|g)`.
    pub fn intercept_only(&self) -> bool {
        self.intercept && self.slopes.is_empty()
    }

    /// Whether `other` is the same term: the same grouping columns (as a
    /// set), intercept and slopes.
    fn same(&self, other: &RandomTerm) -> bool {
        let set = |a: &[String], b: &[String]| a.len() == b.len() && a.iter().all(|c| b.contains(c));
        set(&self.columns, &other.columns) && self.intercept == other.intercept && self.slopes == other.slopes
    }
}

/// The term `segment` nested in `outer` (columns and lme4's name), or
/// `segment` alone.
fn nest(segment: &[String], outer: Option<&(Vec<String>, String)>) -> (Vec<String>, String) {
    let inner = segment.join(":");
    match outer {
        None => (segment.to_vec(), inner),
        Some((columns, name)) => {
            let name = if name.contains(':') { format!("{inner}:({name})") } else { format!("{inner}:{name}") };
            (segment.iter().chain(columns).cloned().collect(), name)
        }
    }
}

/// An offset: a column, or its natural logarithm (`offset(log(t))`, an
/// exposure of a Poisson rate).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Offset {
    /// The column.
    pub column: String,
    /// Written `log(column)`.
    pub log: bool,
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
#[non_exhaustive]
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
    /// A numeric column whose values overflow the model's sums.
    #[error("column {field}: {message}")]
    Scale {
        /// The column (or a fixed-effect column of an interaction).
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A random term whose columns cannot be told apart (a slope on a
    /// constant column, two collinear slopes, a factor with one level):
    /// its variances would not be identified.
    #[error("random term ({term}): {message}")]
    RandomTerm {
        /// The term as its columns and group: `1 + x | g`.
        term: String,
        /// Which column depends on which.
        message: String,
    },
    /// Two formulas that cannot be compared.
    #[error("--compare: {0}")]
    Compare(String),
    /// What the model asks for that is not computed for it (its own
    /// message says what is).
    #[error("{0}")]
    Unsupported(String),
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
        } else if "~+:*()|/-,^".contains(c) {
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
    /// The response, which no term may use.
    response: String,
    /// The failures of a binomial response, which no term may use either.
    failures: Option<String>,
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
    /// A term that uses the response would explain it by itself (R fits
    /// `y ~ y` with a warning and a perfect, meaningless fit).
    fn not_response(&self, name: &str, column: usize, role: &str) -> Result<(), FormulaError> {
        if name == self.response || self.failures.as_deref() == Some(name) {
            return Err(FormulaError::Syntax {
                column,
                message: format!(
                    "the response `{name}` appears {role}: a model cannot explain a column by itself; remove it from the right of `~`"
                ),
            });
        }
        Ok(())
    }
    /// A grouping column after `|`, `:` or `/`.
    fn group(&mut self, what: &str) -> Result<String, FormulaError> {
        let column = self.column();
        let name = self.name(what)?;
        self.not_response(&name, column, "as a grouping factor")?;
        Ok(name)
    }
    /// `name` or `factor(name)`.
    fn variable(&mut self) -> Result<Variable, FormulaError> {
        let column = self.column();
        let name = self.name("a column name")?;
        if name == "factor" && self.peek() == Some(&Token::Sym('(')) {
            self.at += 1;
            let inner_column = self.column();
            let inner = self.name("a column name inside factor( )")?;
            self.not_response(&inner, inner_column, "among the predictors")?;
            self.expect(')', "to close factor(")?;
            return Ok(Variable { name: inner, factor: true });
        }
        self.not_response(&name, column, "among the predictors")?;
        if self.peek() == Some(&Token::Sym('(')) {
            return Err(FormulaError::Syntax {
                column,
                message: format!("`{name}(...)`: the only function a formula may use is factor()"),
            });
        }
        Ok(Variable { name, factor: false })
    }
}

impl Parser {
    /// The response: a column, or `cbind(successes, failures)` (two
    /// columns of a binomial response).
    /// The response: a column, `cbind(successes, failures)` (two columns
    /// of a binomial response) or `cbind(successes, trials - successes)`;
    /// the second of the pair is the failures' column, the third the
    /// trials' column.
    fn response(&mut self) -> Result<(String, Option<String>, Option<String>), FormulaError> {
        let name = self.name("the response column before `~`")?;
        if name != "cbind" || self.peek() != Some(&Token::Sym('(')) {
            return Ok((name, None, None));
        }
        self.cbind()
    }

    /// The denominator of a response `a / b`, after the response's name.
    fn divisor(&mut self) -> Result<Option<String>, FormulaError> {
        if self.peek() != Some(&Token::Sym('/')) {
            return Ok(None);
        }
        self.at += 1;
        let column = self.column();
        let name = self.name("the denominator's column after `/` in the response")?;
        if self.peek() == Some(&Token::Sym('(')) {
            return Err(FormulaError::Syntax { column, message: transformation(&name) });
        }
        Ok(Some(name))
    }

    /// `cbind(successes, failures)` or `cbind(successes, trials -
    /// successes)`, after `cbind`.
    fn cbind(&mut self) -> Result<(String, Option<String>, Option<String>), FormulaError> {
        self.at += 1;
        let successes = self.name("the successes' column inside cbind( )")?;
        self.expect(',', "between the successes' and the failures' columns of cbind( )")?;
        let second = self.name("the failures' column (or `trials - successes`) inside cbind( )")?;
        let mut trials = None;
        if self.peek() == Some(&Token::Sym('-')) {
            self.at += 1;
            let column = self.column();
            let subtracted = self.name("the successes' column after `-` inside cbind( )")?;
            if subtracted != successes {
                return Err(FormulaError::Syntax {
                    column,
                    message: format!(
                        "cbind({successes}, {second} - {subtracted}): the failures are the trials less the successes, `{second} - {successes}`; for any other arithmetic compute the column in the CSV first"
                    ),
                });
            }
            trials = Some(second.clone());
        }
        self.expect(
            ')',
            "to close cbind( ) (its arguments are the successes and the failures, or `trials - successes`)",
        )?;
        Ok(match trials {
            Some(t) => (successes, None, Some(t)),
            None => (successes, Some(second), None),
        })
    }

    /// `offset(col)` or `offset(log(col))`, after its name.
    fn offset(&mut self) -> Result<Offset, FormulaError> {
        self.expect('(', "after offset")?;
        let column = self.column();
        let name = self.name("a column name inside offset( )")?;
        let (name, log, column) = if name == "log" && self.peek() == Some(&Token::Sym('(')) {
            self.at += 1;
            let column = self.column();
            let inner = self.name("a column name inside offset(log( ))")?;
            self.expect(')', "to close log(")?;
            (inner, true, column)
        } else {
            (name, false, column)
        };
        if self.peek() == Some(&Token::Sym('(')) {
            return self.error(format!(
                "`{name}(...)` inside offset( ): an offset is a column or log(column); compute any other transformation in the CSV first"
            ));
        }
        self.not_response(&name, column, "in the offset")?;
        self.expect(')', "to close offset( ) (an offset is a column or log(column))")?;
        Ok(Offset { column: name, log })
    }

    /// A fixed term as written, `a:b * c`, expanded into its terms: every
    /// non-empty union of the crossed parts.
    fn crossed_terms(&mut self) -> Result<Vec<Vec<Variable>>, FormulaError> {
        let mut groups: Vec<Vec<Variable>> = vec![vec![self.variable()?]];
        loop {
            match self.peek() {
                Some(Token::Sym(':')) => {
                    self.at += 1;
                    let v = self.variable()?;
                    groups.last_mut().expect("one group at least").push(v);
                }
                Some(Token::Sym('*')) => {
                    self.at += 1;
                    groups.push(vec![self.variable()?]);
                }
                _ => break,
            }
        }
        if groups.len() > MAX_CROSSED {
            return self.error(format!(
                "{} variables crossed with `*` make {} terms; at most {MAX_CROSSED} may be crossed",
                groups.len(),
                if groups.len() < 64 { ((1u64 << groups.len()) - 1).to_string() } else { "more than 2^63".into() }
            ));
        }
        let mut terms = Vec::new();
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
            terms.push(term);
        }
        Ok(terms)
    }

    /// The left of `|` in a random term: whether it has an intercept (`1`,
    /// implied unless `0` is written) and its slopes, in R's order.
    fn random_effects(&mut self) -> Result<(bool, Vec<Vec<Variable>>), FormulaError> {
        let (mut intercept, mut slopes) = (true, Vec::new());
        let mut first = true;
        loop {
            if !first {
                match self.peek() {
                    Some(Token::Sym('+')) => self.at += 1,
                    Some(Token::Sym('|')) => break,
                    Some(Token::Sym('-')) => {
                        return self.error(
                            "removing terms (`-`) is not supported; write `0 + x` for a term without an intercept",
                        )
                    }
                    _ => return self.error("expected `+` or `|` in the random term"),
                }
            }
            first = false;
            match self.peek().cloned() {
                Some(Token::Number(n)) if n == "1" => self.at += 1,
                Some(Token::Number(n)) if n == "0" => {
                    self.at += 1;
                    intercept = false;
                }
                Some(Token::Name(_)) => slopes.extend(self.crossed_terms()?),
                Some(Token::Sym('-')) => {
                    return self
                        .error("removing terms (`-`) is not supported; write `0 + x` for a term without an intercept")
                }
                _ => return self.error("expected `1`, `0` or a column before `|` in the random term"),
            }
        }
        if !intercept && slopes.is_empty() {
            return self.error("a random term needs an intercept or a slope: `(0|g)` has neither");
        }
        Ok((intercept, canonical(slopes)))
    }

    /// A random term after its `(`: `1 + x | g`, `x || g`, `0 + x | g/h`,
    /// to its `)`. `(e || g)` is lme4's `(1|g) + (0 + x|g) + ...`, one
    /// term per part of `e`; `(e | g/h)` is `(e|g) + (e|h:g)`.
    fn random_term(&mut self) -> Result<Vec<RandomTerm>, FormulaError> {
        let (intercept, slopes) = self.random_effects()?;
        self.expect('|', "after the random term's effects")?;
        let uncorrelated = self.peek() == Some(&Token::Sym('|'));
        if uncorrelated {
            self.at += 1;
        }
        // `/` binds looser than `:`: a/b:c is a/(b:c). Each nested term is
        // lme4's: a/b/c gives a, b:a and c:(b:a).
        let mut groups: Vec<(Vec<String>, String)> = Vec::new();
        let mut segment = vec![self.group("a grouping column after `|`")?];
        let mut outer: Option<(Vec<String>, String)> = None;
        loop {
            match self.peek() {
                Some(Token::Sym(':')) => {
                    self.at += 1;
                    segment.push(self.group("a grouping column after `:`")?);
                }
                Some(Token::Sym('/')) => {
                    self.at += 1;
                    let term = nest(&segment, outer.as_ref());
                    groups.push(term.clone());
                    outer = Some(term);
                    segment = vec![self.group("a grouping column after `/`")?];
                }
                _ => break,
            }
        }
        self.expect(')', "to close the random term")?;
        groups.push(nest(&segment, outer.as_ref()));
        let parts: Vec<(bool, Vec<Vec<Variable>>)> = if uncorrelated {
            let own = intercept.then(|| (true, Vec::new()));
            own.into_iter().chain(slopes.into_iter().map(|t| (false, vec![t]))).collect()
        } else {
            vec![(intercept, slopes)]
        };
        Ok(groups
            .into_iter()
            .flat_map(|(columns, name)| {
                parts.iter().map(move |(intercept, slopes)| RandomTerm {
                    columns: columns.clone(),
                    name: name.clone(),
                    intercept: *intercept,
                    slopes: slopes.clone(),
                })
            })
            .collect())
    }
}

/// Terms in R's order: each interaction's variables by their first
/// appearance, duplicates (as sets) dropped, then by degree, stably.
fn canonical(terms: Vec<Vec<Variable>>) -> Vec<Vec<Variable>> {
    let mut seen: Vec<Variable> = Vec::new();
    for v in terms.iter().flatten() {
        if !seen.contains(v) {
            seen.push(v.clone());
        }
    }
    let mut unique: Vec<Vec<Variable>> = Vec::new();
    for mut t in terms {
        t.sort_by_key(|v| seen.iter().position(|u| u == v));
        let same = |u: &Vec<Variable>| u.len() == t.len() && t.iter().all(|v| u.contains(v));
        if !unique.iter().any(same) {
            unique.push(t);
        }
    }
    unique.sort_by_key(|t| t.len());
    unique
}

/// The terms after `~`: fixed (each a set of variables), random, and the
/// offset.
type Terms = (Vec<Vec<Variable>>, Vec<RandomTerm>, Option<Offset>);

impl Parser {
    /// The terms after `~`: fixed terms as written (each a set of
    /// variables; a crossing expands), random terms and the offset.
    fn terms(&mut self) -> Result<Terms, FormulaError> {
        let mut fixed: Vec<Vec<Variable>> = Vec::new();
        let mut random: Vec<RandomTerm> = Vec::new();
        let mut offset: Option<Offset> = None;
        let mut first = true;
        loop {
            if !first {
                match self.peek() {
                    None => break,
                    Some(Token::Sym('+')) => self.at += 1,
                    Some(Token::Sym('-')) => return self.error("removing terms (`-`) is not supported"),
                    _ => return self.error("expected `+` between terms"),
                }
            }
            first = false;
            match self.peek().cloned() {
                None => return self.error("expected a term"),
                Some(Token::Number(n)) if n == "1" => self.at += 1,
                Some(Token::Number(n)) if n == "0" => {
                    return self.error("a model without an intercept (`0`) is not supported");
                }
                Some(Token::Number(n)) => {
                    return self.error(format!("`{n}`: a term is a column name, 1, or (1|group)"))
                }
                Some(Token::Sym('(')) => {
                    self.at += 1;
                    random.extend(self.random_term()?);
                }
                Some(Token::Name(n))
                    if n == "offset" && self.tokens.get(self.at + 1).map(|t| &t.1) == Some(&Token::Sym('(')) =>
                {
                    let column = self.column();
                    self.at += 1;
                    let o = self.offset()?;
                    if offset.is_some() {
                        return Err(FormulaError::Syntax {
                            column,
                            message: "a second offset( ): compute their sum in the CSV first".into(),
                        });
                    }
                    offset = Some(o);
                }
                Some(Token::Name(_)) => fixed.extend(self.crossed_terms()?),
                Some(_) => return self.error("expected a term"),
            }
        }
        Ok((fixed, random, offset))
    }
}

/// Parses `response ~ terms`.
pub fn parse(text: &str) -> Result<Formula, FormulaError> {
    let tokens = tokenize(text)?;
    // A name followed by `(` is a function call: R transforms a column in
    // the formula (`log(y)`, `poly(x, 2)`, `I(x^2)`); here the column must
    // exist in the file (factor() aside).
    for (at, w) in tokens.windows(2).enumerate() {
        if let ((column, Token::Name(f)), (_, Token::Sym('('))) = (&w[0], &w[1]) {
            if f == "factor" || (f == "cbind" && at == 0) || f == "offset" {
                continue;
            }
            // log( ) directly inside offset( ).
            if f == "log" && at >= 2 && tokens[at - 2].1 == Token::Name("offset".into()) {
                continue;
            }
            return Err(FormulaError::Syntax { column: *column, message: transformation(f) });
        }
    }
    if let Some((column, _)) = tokens.iter().find(|(_, t)| *t == Token::Sym('^')) {
        let message = "powers (`^`) are not supported in a formula: compute the column in the CSV first (R: `d$x2 <- d$x^2`; pandas: `df[\"x2\"] = df[\"x\"] ** 2`) and name it; for an interaction of two columns write `a:b` or `a*b`";
        return Err(FormulaError::Syntax { column: *column, message: message.into() });
    }
    let end = text.chars().count() + 1;
    let mut p = Parser { tokens, at: 0, end, response: String::new(), failures: None };
    let (response, failures, trials) = p.response()?;
    let divisor = if failures.is_none() && trials.is_none() { p.divisor()? } else { None };
    p.response = response.clone();
    p.failures = failures.clone().or_else(|| trials.clone());
    p.expect('~', "after the response")?;
    let (fixed, random, offset) = p.terms()?;
    // R's terms order an interaction's variables by their first appearance
    // in the formula (`Type + conc:Type` is `Type:conc`), whatever order
    // the term writes them in.
    let unique = canonical(fixed);
    // The same term twice is one term (lme4 would fit it twice, with
    // variances it cannot tell apart).
    let mut groups: Vec<RandomTerm> = Vec::new();
    let written = random.len();
    for term in random {
        if !groups.iter().any(|g| g.same(&term)) {
            groups.push(term);
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
    let merged = written - groups.len();
    Ok(Formula { response, failures, trials, offset, divisor, fixed: unique, random: groups, merged })
}

/// Why a response `a / b` is refused where it is not a binomial
/// proportion with prior weights.
fn divided_response(formula: &Formula) -> FormulaError {
    FormulaError::Unsupported(format!(
        "the response {} / {} is a binomial model's proportion with its trials as --weights (glmer's `incidence / size` with `weights = size`: --family binomial --weights {}); for any other ratio compute the column in the CSV first",
        formula.response,
        formula.divisor.as_deref().unwrap_or(""),
        formula.divisor.as_deref().unwrap_or("")
    ))
}

/// What to say about a function call `f(...)` in a formula.
fn transformation(f: &str) -> String {
    format!(
        "transformations such as `{f}(...)` are not supported in a formula (the only function it may use is factor()): compute the transformed column in the CSV first (R: `d${f}_y <- {f}(d$y)`; pandas: `df[\"{f}_y\"] = ...`) and name that column"
    )
}
