//! Stage 1: design text -> [`Ast`] (pest, with spans) -> validated [`Design`].
//!
//! The [`Design`] is the whole preregistered study in typed form: the parts
//! run by later stages (data, split, training) and the analysis compiled by
//! [`crate::plan::compile`].

mod analysis_spec;
mod ast;
mod data_spec;
mod diagnostic;
pub mod lock;
mod model_spec;
pub mod multiverse;
mod name_pattern;
mod parse;
pub mod reference;
mod rules;
mod types;
mod validate;
mod window_distance;

use std::path::Path;

use serde::{Deserialize, Serialize};

pub use analysis_spec::*;
pub use ast::{Ast, Cmp, Span};
pub use data_spec::*;
pub use diagnostic::{visible as diagnostic_visible, DesignError, Diagnostic};
pub use lock::{LockFile, LockStatus};
pub use model_spec::*;
pub use multiverse::{Choice, ChoiceRole, Combine, Multiverse, Specification};
pub use name_pattern::{NameConditions, NamePattern};
pub use rules::*;
pub use types::*;
pub use window_distance::WindowDistance;

/// Parses design text; `file` names it in diagnostics.
pub(crate) fn parse(file: &str, source: &str) -> Result<Ast, DesignError> {
    parse::parse(source).map_err(|diagnostics| DesignError {
        file: file.to_string(),
        source_text: source.to_string(),
        diagnostics,
    })
}

/// Validates a parsed design.
pub(crate) fn validate(file: &str, source: &str, ast: &Ast, base: &Path) -> Result<Design, DesignError> {
    validate::validate(ast, base).map_err(|diagnostics| DesignError {
        file: file.to_string(),
        source_text: source.to_string(),
        diagnostics,
    })
}

/// Parse and validate in one call. A `split published` file is read
/// relative to the current directory.
pub fn from_str(file: &str, source: &str) -> Result<Design, DesignError> {
    from_str_in(file, source, Path::new(""))
}

/// As [`from_str`], reading a `split published` file relative to `base`.
pub fn from_str_in(file: &str, source: &str, base: &Path) -> Result<Design, DesignError> {
    // pest and the diagnostics count lines by `\n`; a file saved with
    // lone `\r` line endings is read as the lines an editor shows.
    let source = &*crate::io::lone_cr_to_lf(source);
    let ast = parse(file, source)?;
    validate(file, source, &ast, base)
}

/// A design file read from disk, with its bytes kept for hashing and locking.
#[derive(Debug, Clone)]
pub struct DesignFile {
    /// Where it was read from.
    pub path: std::path::PathBuf,
    /// Its text.
    pub source: String,
    /// The validated design.
    pub design: Design,
    /// SHA-256 of the file's bytes, lowercase hex.
    pub sha256: String,
}

/// Why a design file could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read.
    #[error("cannot read design file {path}: {source}")]
    Io {
        /// The path.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The text is not a valid design.
    #[error("{0}")]
    Design(#[from] DesignError),
}

/// Reads, parses and validates a design file.
pub fn load(path: &Path) -> Result<DesignFile, LoadError> {
    load_copy(path, path)
}

/// Reads a verbatim copy of the design `original` from `copy`: its bytes
/// and hash are the copy's, while errors, the lock and a `split published`
/// file are looked up as for `original`. A run prepared for a cluster keeps
/// such a copy, so its jobs run the design as it was prepared.
pub fn load_copy(copy: &Path, original: &Path) -> Result<DesignFile, LoadError> {
    let bytes = crate::io::read_input(copy, crate::io::MAX_SMALL_TEXT, "a design file")
        .map_err(|e| LoadError::Io { path: copy.display().to_string(), source: e.into_io() })?;
    let path = original;
    let sha256 = crate::io::sha256_hex(&bytes);
    let source = String::from_utf8(bytes).map_err(|e| LoadError::Io {
        path: path.display().to_string(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, format!("not UTF-8: {e}")),
    })?;
    // Editors that save a UTF-8 byte-order mark hide it; columns are
    // counted as the editor shows them, after it. The hash covers the bytes.
    let source = match source.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => source,
    };
    // A published split file is read relative to the design file.
    let base = path.parent().unwrap_or(Path::new(""));
    let design = from_str_in(&path.display().to_string(), &source, base)?;
    Ok(DesignFile { path: path.to_path_buf(), source, design, sha256 })
}
