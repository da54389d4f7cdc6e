//! `FILE.design.lock`: the design's SHA-256, the tool version and the UTC
//! time it was locked. A run of a locked design checks the hash.

use std::path::{Path, PathBuf};
use std::time::SystemTime;

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LockFile {
    /// File name of the locked design.
    pub design: String,
    /// SHA-256 of the design file's bytes, lowercase hex.
    pub sha256: String,
    pub tool: String,
    pub tool_version: String,
    /// RFC 3339, UTC, whole seconds.
    pub locked_at_utc: String,
}

/// Whether a design matches its lock.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case", tag = "status")]
pub enum LockStatus {
    Unlocked,
    LockedUnchanged { locked_at_utc: String },
    LockedChanged { locked_sha256: String, current_sha256: String, locked_at_utc: String },
}

impl LockStatus {
    pub fn label(&self) -> &'static str {
        match self {
            LockStatus::Unlocked => "unlocked",
            LockStatus::LockedUnchanged { .. } => "locked/unchanged",
            LockStatus::LockedChanged { .. } => "locked/changed",
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error("cannot read lock file {path}: {source}")]
    Read { path: String, source: std::io::Error },
    #[error("lock file {path} is not valid: {source}")]
    Parse { path: String, source: serde_json::Error },
    #[error("cannot write lock file {path}: {source}")]
    Write { path: String, source: std::io::Error },
    #[error(
        "{path} is already locked (sha256 {sha256}, {locked_at_utc}); delete the lock to re-lock a changed design"
    )]
    AlreadyLocked { path: String, sha256: String, locked_at_utc: String },
}

/// `FILE.design` -> `FILE.design.lock`.
pub fn lock_path(design: &Path) -> PathBuf {
    let mut name = design.as_os_str().to_owned();
    name.push(".lock");
    PathBuf::from(name)
}

pub fn read_lock(design: &Path) -> Result<Option<LockFile>, LockError> {
    let path = lock_path(design);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(LockError::Read { path: path.display().to_string(), source }),
    };
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|source| LockError::Parse { path: path.display().to_string(), source })
}

pub fn status(design: &Path, current_sha256: &str) -> Result<LockStatus, LockError> {
    Ok(match read_lock(design)? {
        None => LockStatus::Unlocked,
        Some(lock) if lock.sha256 == current_sha256 => {
            LockStatus::LockedUnchanged { locked_at_utc: lock.locked_at_utc }
        }
        Some(lock) => LockStatus::LockedChanged {
            locked_sha256: lock.sha256,
            current_sha256: current_sha256.to_string(),
            locked_at_utc: lock.locked_at_utc,
        },
    })
}

/// Writes the lock for a design whose bytes hash to `sha256`. Re-locking an
/// unchanged design is a no-op that returns the existing lock; a changed
/// design with an existing lock is refused.
pub fn write_lock(design: &Path, sha256: &str, now: SystemTime) -> Result<LockFile, LockError> {
    let path = lock_path(design);
    if let Some(existing) = read_lock(design)? {
        if existing.sha256 == sha256 {
            return Ok(existing);
        }
        return Err(LockError::AlreadyLocked {
            path: path.display().to_string(),
            sha256: existing.sha256,
            locked_at_utc: existing.locked_at_utc,
        });
    }
    let lock = LockFile {
        design: design.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        sha256: sha256.to_string(),
        tool: env!("CARGO_PKG_NAME").to_string(),
        tool_version: env!("CARGO_PKG_VERSION").to_string(),
        locked_at_utc: humantime::format_rfc3339_seconds(now).to_string(),
    };
    let text = crate::io::pretty_json(&lock);
    std::fs::write(&path, text).map_err(|source| LockError::Write { path: path.display().to_string(), source })?;
    Ok(lock)
}
