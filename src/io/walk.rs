//! Files under a folder, its subfolders included.

use std::path::{Path, PathBuf};

/// How a flight log's file name ends: CSV, gzipped CSV or Parquet.
pub const LOG_SUFFIXES: [&str; 3] = [".csv", ".csv.gz", ".parquet"];

/// Whether a file name is a flight log's (see [`LOG_SUFFIXES`]).
pub fn is_log_name(name: &str) -> bool {
    LOG_SUFFIXES.iter().any(|s| name.ends_with(s))
}

/// The most folder levels [`files_below`] descends.
pub const MAX_DEPTH: usize = 8;

/// Every entry of `dir` that is not a folder, and with `nested` those of
/// its subfolders too, at most [`MAX_DEPTH`] levels down, each as a path
/// under `dir`. Symbolic links to folders are not followed (a link cycle
/// would never end), and a folder deeper than the limit is an error naming
/// it, never skipped without a word.
pub fn files_below(dir: &Path, nested: bool) -> std::io::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let mut stack = vec![(dir.to_path_buf(), 0usize)];
    while let Some((d, depth)) = stack.pop() {
        for entry in std::fs::read_dir(&d)? {
            let entry = entry?;
            let path = entry.path();
            if nested && entry.file_type()?.is_dir() {
                if depth + 1 > MAX_DEPTH {
                    return Err(std::io::Error::other(format!(
                        "{} is more than {MAX_DEPTH} folders below {}",
                        path.display(),
                        dir.display()
                    )));
                }
                stack.push((path, depth + 1));
            } else {
                out.push(path);
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Where `dir` holds no flight log at its top level but its subfolders do
/// (a design that forgot `folders nested`): the hint to read them, with
/// how many there are and the first, relative to `dir`; `csv` when the
/// design reads them with a `data csv` block (which `folders nested`
/// extends), else the preset's way.
pub fn nested_logs_hint(dir: &Path, csv: bool) -> Option<String> {
    let is_log = |p: &PathBuf| p.file_name().is_some_and(|n| is_log_name(&n.to_string_lossy()));
    if files_below(dir, false).ok()?.iter().any(is_log) {
        return None;
    }
    let below = files_below(dir, true).ok()?;
    let logs: Vec<&PathBuf> = below.iter().filter(|p| is_log(p)).collect();
    let first = logs.first()?;
    let advice = if csv {
        "declare `folders nested` in the data block to read them"
    } else {
        "`data nanobench` reads the folder's top level only: move the logs there, or read them with a `data csv` block that declares `folders nested`"
    };
    Some(format!(
        "; the folder holds no flight log at its top level, but its subfolders hold {} (the first: {}): {advice}",
        logs.len(),
        relative(dir, first)
    ))
}

/// The flight logs in `dir`'s subfolders, which a design without `folders
/// nested` does not read: how many, and the first relative to `dir`.
pub fn logs_in_subfolders(dir: &Path) -> Option<(usize, String)> {
    let is_log = |p: &&PathBuf| p.file_name().is_some_and(|n| is_log_name(&n.to_string_lossy()));
    let below = files_below(dir, true).ok()?;
    let logs: Vec<&PathBuf> = below.iter().filter(|p| p.parent() != Some(dir)).filter(is_log).collect();
    Some((logs.len(), relative(dir, logs.first()?)))
}

/// `path` relative to `dir`, with `/` between folders, as an audit shows it.
pub fn relative(dir: &Path, path: &Path) -> String {
    let rel = path.strip_prefix(dir).unwrap_or(path);
    rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect::<Vec<_>>().join("/")
}
