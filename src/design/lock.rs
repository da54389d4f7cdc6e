//! `FILE.design.lock`: the design's SHA-256, the tool version and the UTC
//! time it was locked. A run of a locked design checks the hash.

use std::path::{Path, PathBuf};
use std::time::SystemTime;

use serde::{Deserialize, Serialize};

/// The contents of `FILE.design.lock`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LockFile {
    /// File name of the locked design.
    pub design: String,
    /// SHA-256 of the design file's bytes, lowercase hex.
    pub sha256: String,
    /// Tool name (`crossaudit`).
    pub tool: String,
    /// Tool version that locked it.
    pub tool_version: String,
    /// RFC 3339, UTC, whole seconds.
    pub locked_at_utc: String,
}

/// Whether a design matches its lock.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "status")]
pub enum LockStatus {
    /// No lock file.
    Unlocked,
    /// Locked, and the file still has the locked hash.
    LockedUnchanged {
        /// When it was locked (RFC 3339, UTC).
        locked_at_utc: String,
    },
    /// Locked, but the file changed since: analyses are exploratory.
    LockedChanged {
        /// Hash recorded in the lock.
        locked_sha256: String,
        /// Hash of the file now.
        current_sha256: String,
        /// When it was locked (RFC 3339, UTC).
        locked_at_utc: String,
    },
}

impl LockStatus {
    /// Short label for reports.
    pub fn label(&self) -> &'static str {
        match self {
            LockStatus::Unlocked => "unlocked",
            LockStatus::LockedUnchanged { .. } => "locked/unchanged",
            LockStatus::LockedChanged { .. } => "locked/changed",
        }
    }
}

/// Why a lock could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// The lock file exists but could not be read.
    #[error("cannot read lock file {path}: {source}")]
    Read {
        /// The path.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The lock file is not valid JSON of the expected shape.
    #[error("lock file {path} is not valid: {source}")]
    Parse {
        /// The path.
        path: String,
        /// The underlying error.
        source: serde_json::Error,
    },
    /// The lock file could not be written.
    #[error("cannot write lock file {path}: {source}")]
    Write {
        /// The path.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    #[error(
        "{path} is already locked (sha256 {sha256}, {locked_at_utc}); delete the lock to re-lock a changed design"
    )]
    /// The design is locked already.
    AlreadyLocked {
        /// The path.
        path: String,
        /// Hash recorded in the lock.
        sha256: String,
        /// When it was locked (RFC 3339, UTC).
        locked_at_utc: String,
    },
}

/// `FILE.design` -> `FILE.design.lock`.
pub fn lock_path(design: &Path) -> PathBuf {
    let mut name = design.as_os_str().to_owned();
    name.push(".lock");
    PathBuf::from(name)
}

/// The lock of `design`, or `None` when it has none.
pub fn read_lock(design: &Path) -> Result<Option<LockFile>, LockError> {
    let path = lock_path(design);
    let read = crate::io::read_input(&path, crate::io::MAX_SMALL_TEXT, "a lock file").map_err(|e| e.into_io());
    let bytes = match read {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(LockError::Read { path: path.display().to_string(), source }),
    };
    let text = String::from_utf8_lossy(&bytes);
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|source| LockError::Parse { path: path.display().to_string(), source })
}

/// Whether `design`, whose bytes hash to `current_sha256`, matches its lock.
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
    crate::io::write_atomic(&path, text.as_bytes())
        .map_err(|e| LockError::Write { path: path.display().to_string(), source: e.source })?;
    Ok(lock)
}
