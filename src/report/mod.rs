//! Stage 5: an [`Analysis`] rendered for people and for other tools:
//! `report.md` (tables like the paper's Table 2), `results.json` and
//! `results.tex` (one LaTeX macro per reported number).

pub mod figures;
mod markdown;
mod tex;

use std::path::{Path, PathBuf};

use crate::analysis::Analysis;

pub use markdown::render_markdown;
pub use tex::render_tex;

#[derive(Debug, thiserror::Error)]
#[error("cannot write {path}: {source}")]
pub struct WriteError {
    pub path: String,
    pub source: std::io::Error,
}

pub fn render_json(a: &Analysis) -> String {
    let mut s = serde_json::to_string_pretty(a).expect("an Analysis always serializes");
    s.push('\n');
    s
}

/// Writes report.md, results.json and results.tex into `dir` (created if
/// needed), each atomically (temporary file + rename). Returns the paths.
pub fn write_all(a: &Analysis, dir: &Path) -> Result<Vec<PathBuf>, WriteError> {
    std::fs::create_dir_all(dir).map_err(|source| WriteError { path: dir.display().to_string(), source })?;
    let mut out = Vec::new();
    for (name, text) in
        [("report.md", render_markdown(a)), ("results.json", render_json(a)), ("results.tex", render_tex(a))]
    {
        let path = dir.join(name);
        write_atomic(&path, text.as_bytes())?;
        out.push(path);
    }
    Ok(out)
}

/// Temporary file in the same directory, then rename, so a reader never sees
/// half a file and an interrupted write never replaces a finished one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    let err = |source| WriteError { path: path.display().to_string(), source };
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    std::fs::write(&tmp, bytes).map_err(err)?;
    std::fs::rename(&tmp, path).map_err(err)
}

/// Fixed-point formatting used in every table; NaN prints as "NA".
pub(crate) fn f(v: f64, decimals: usize) -> String {
    if v.is_nan() {
        "NA".to_string()
    } else if v.is_infinite() {
        if v > 0.0 { "inf" } else { "-inf" }.to_string()
    } else {
        let s = format!("{v:.decimals$}");
        // "-0.0000" reads as a sign error; print zero plainly.
        if s.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
            s.trim_start_matches('-').to_string()
        } else {
            s
        }
    }
}
