//! Output folders a run can trust: never the data folder, inside it or
//! around it (the tool's own CSV files would be read back as recordings),
//! and never written by two crossaudit processes at once (an OS lock on
//! the folder itself, released however the process ends).

use std::fs::{File, TryLockError};
use std::path::{Component, Path, PathBuf};

use super::RunError;
use crate::io::{create_dir_all, WriteError};

/// `p` as an absolute path with symlinks resolved as far as it exists
/// (an output folder may not exist yet), and `.`/`..` removed from the rest.
fn resolved(p: &Path) -> PathBuf {
    let abs = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir().map(|d| d.join(p)).unwrap_or_else(|_| p.to_path_buf())
    };
    let mut existing = abs.as_path();
    let mut rest = Vec::new();
    loop {
        if let Ok(real) = existing.canonicalize() {
            let mut out = real;
            for c in rest.iter().rev() {
                match c {
                    Component::ParentDir => {
                        out.pop();
                    }
                    Component::CurDir => {}
                    other => out.push(other),
                }
            }
            return out;
        }
        match (existing.parent(), existing.components().next_back()) {
            (Some(parent), Some(last)) => {
                rest.push(last);
                existing = parent;
            }
            _ => return abs,
        }
    }
}

/// Refuses an output folder that is the data folder, lies inside it or
/// holds it: what the tool writes there (`recordings.csv`, `cells.csv`,
/// simulated data) would be read back as flight logs, or a data file
/// overwritten.
pub fn check_out_dir(data: &Path, out: &Path) -> Result<(), RunError> {
    let (d, o) = (resolved(data), resolved(out));
    let how = if d == o {
        "is the data folder"
    } else if o.starts_with(&d) {
        "is inside the data folder"
    } else if d.starts_with(&o) {
        "holds the data folder"
    } else {
        return Ok(());
    };
    Err(RunError::OutInData { out: out.display().to_string(), data: data.display().to_string(), how })
}

/// A lock on an output folder, held until dropped (or the process ends).
#[derive(Debug)]
pub struct FolderLock {
    _file: File,
}

/// Creates `dir` if needed and takes an exclusive lock on it, or with
/// `shared` a shared one, as each Slurm job of a run does: the jobs train
/// side by side, and a `run`, `train` or `gather` on the folder is refused
/// while any of them holds it. A folder another crossaudit process holds
/// is refused with [`RunError::FolderBusy`], never waited for.
pub fn lock_folder(dir: &Path, shared: bool) -> Result<FolderLock, RunError> {
    create_dir_all(dir)?;
    let file = File::open(dir).map_err(|e| WriteError::new(dir, e))?;
    let got = if shared { file.try_lock_shared() } else { file.try_lock() };
    match got {
        Ok(()) => Ok(FolderLock { _file: file }),
        Err(TryLockError::WouldBlock) => Err(RunError::FolderBusy { dir: dir.display().to_string() }),
        Err(TryLockError::Error(e)) => Err(WriteError::new(dir, e).into()),
    }
}
