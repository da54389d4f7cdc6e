//! `crossaudit mixed`: a `mixed` formula fitted to a tidy CSV file, or
//! two compared on it, the file read under the rules of every input (a
//! regular file of at most 1 GiB, [`crate::io::read_input`]). The fit
//! itself is the statistics crate's ([`crossaudit_stats::mixed::formula`]),
//! which reads no file.

use crossaudit_stats::mixed;
use crossaudit_stats::mixed::formula::{
    compare_table, fit_glmm_with, fit_table_weighted, read_csv, Comparison, DfMethod, FileError, FormulaError,
    FormulaFit, GlmmFormulaFit, GlmmOptions, Table,
};

/// Reads the tidy CSV at `path` and compares two formulas on it by a
/// likelihood-ratio test (see [`compare_table`]).
pub fn compare_file(path: &std::path::Path, formula: &str, other: &str) -> Result<Comparison, FileError> {
    let fail = |error: FormulaError| FileError { file: path.display().to_string(), error };
    let table = read_file(path).map_err(fail)?;
    compare_table(formula, other, &table).map_err(fail)
}

/// The tidy CSV at `path`, read under the rules of every input.
fn read_file(path: &std::path::Path) -> Result<Table, FormulaError> {
    let bytes = crate::io::read_input(path, crate::io::MAX_CELLS_FILE, "a data file")
        .map_err(|e| FormulaError::Read(e.to_string()))?;
    let text = String::from_utf8(bytes)
        .map_err(|e| FormulaError::Read(format!("not UTF-8 text (byte {} is not)", e.utf8_error().valid_up_to())))?;
    read_csv(&text)
}

/// Reads the tidy CSV at `path` and fits `formula` to it, with lmer's
/// prior `weights` where given (see [`fit_table_weighted`]). A path that is
/// not a regular file (a folder, a FIFO, a device) or is over 1 GiB is
/// refused before it is read ([`crate::io::read_input`]).
pub fn fit_file(
    path: &std::path::Path,
    formula: &str,
    criterion: mixed::Criterion,
    df: DfMethod,
    profile: Option<f64>,
    weights: Option<&str>,
) -> Result<FormulaFit, FileError> {
    let fail = |error: FormulaError| FileError { file: path.display().to_string(), error };
    let table = read_file(path).map_err(fail)?;
    fit_table_weighted(formula, &table, criterion, df, profile, weights).map_err(fail)
}

/// Reads the tidy CSV at `path` and fits `formula` to it as a generalized
/// linear mixed model of `family`, with glmer's prior weights and nAGQ
/// (see [`fit_glmm_with`]).
pub fn fit_glmm_file(
    path: &std::path::Path,
    formula: &str,
    family: mixed::glmm::Family,
    profile: Option<f64>,
    options: &GlmmOptions,
) -> Result<GlmmFormulaFit, FileError> {
    let fail = |error: FormulaError| FileError { file: path.display().to_string(), error };
    let table = read_file(path).map_err(fail)?;
    fit_glmm_with(formula, &table, family, profile, options).map_err(fail)
}
