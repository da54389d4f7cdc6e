//! Writing a file so that a reader never sees half of it: staged under a
//! temporary name and renamed, never over an input of the same command,
//! with its path in every error.

use std::path::{Path, PathBuf};

/// A file or directory that could not be written, with its path.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {path}: {source}")]
pub struct WriteError {
    /// The path that could not be written.
    pub path: String,
    /// The operating system's reason.
    pub source: std::io::Error,
}

impl WriteError {
    /// The error for `path`.
    pub fn new(path: &Path, source: std::io::Error) -> WriteError {
        WriteError { path: path.display().to_string(), source }
    }
}

/// Temporary file in the same directory, then rename, so a reader never sees
/// half a file and an interrupted write never replaces a finished one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    let err = |source| WriteError::new(path, source);
    if is_protected_input(path) {
        return Err(err(std::io::Error::other(
            "it is an input of this command, which writing here would replace: give another --out",
        )));
    }
    let tmp = staged(path).map_err(err)?;
    // A new file: a link planted at the temporary name after it was
    // cleared is not followed.
    let mut file = std::fs::OpenOptions::new().write(true).create_new(true).open(&tmp).map_err(err)?;
    std::io::Write::write_all(&mut file, bytes).map_err(err)?;
    drop(file);
    std::fs::rename(&tmp, path).map_err(err)
}

/// The temporary name a staged write of `path` uses (`path` with `.tmp`
/// added to its name), with whatever was left there removed first: a file
/// of an interrupted write, or a link, which writing through would follow
/// to another file (a run's cells.csv). A folder there is an error.
pub fn staged(path: &Path) -> std::io::Result<PathBuf> {
    let tmp = tmp_path(path);
    match std::fs::remove_file(&tmp) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e),
        _ => Ok(tmp),
    }
}

/// The files a command was given to read (`simsum FILE`, `analyze
/// --cells FILE`, `audit split SPLIT`, a design), canonical: no output of
/// that command may replace one ([`write_atomic`] refuses, naming it).
static PROTECTED_INPUTS: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Marks the file `path` as an input of this command, so that no output
/// written through [`write_atomic`] replaces it (an `--out` folder that
/// holds the input under an output's name would have lost it). A path
/// that is not a file is ignored.
pub fn protect_input(path: &Path) {
    if let (true, Ok(c)) = (path.is_file(), path.canonicalize()) {
        PROTECTED_INPUTS.lock().unwrap_or_else(|e| e.into_inner()).push(c);
    }
}

/// Refuses, before anything is written, an output folder `dir` that holds
/// an input of this command under a name `writes` says the command may
/// write there: checked per file at the write alone, the outputs written
/// before the refused one would be left looking like a whole report.
pub fn refuse_protected_in(dir: &Path, writes: impl Fn(&str) -> bool) -> Result<(), WriteError> {
    let Ok(d) = dir.canonicalize() else { return Ok(()) };
    let inputs = PROTECTED_INPUTS.lock().unwrap_or_else(|e| e.into_inner()).clone();
    for p in inputs.iter().filter(|p| p.parent() == Some(d.as_path())) {
        if p.file_name().and_then(|n| n.to_str()).is_some_and(&writes) {
            return Err(WriteError::new(
                &dir.join(p.file_name().unwrap_or_default()),
                std::io::Error::other(
                    "it is an input of this command, which writing here would replace: give another --out (nothing was written)",
                ),
            ));
        }
    }
    Ok(())
}

fn is_protected_input(path: &Path) -> bool {
    let Ok(c) = path.canonicalize() else { return false };
    PROTECTED_INPUTS.lock().unwrap_or_else(|e| e.into_inner()).contains(&c)
}

/// `path` with `.tmp` appended: where [`write_atomic`] stages a file.
fn tmp_path(path: &Path) -> PathBuf {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    PathBuf::from(tmp)
}

/// `std::fs::create_dir_all`, with the path in the error.
pub fn create_dir_all(dir: &Path) -> Result<(), WriteError> {
    std::fs::create_dir_all(dir).map_err(|source| WriteError::new(dir, source))
}
