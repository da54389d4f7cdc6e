//! `FILE.design.lock`: the design's SHA-256, the SHA-256 of every file it
//! refers to (a `split published` file, a conditions table), the version of the language's
//! defaults it was written under, the tool version and the UTC time it was
//! locked. A run of a locked design checks all of them.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use serde::{Deserialize, Serialize};

use super::DesignFile;

/// The version of the design language's defaults: what a design means in
/// everything it leaves unsaid (optimizer settings, tolerances, inclusion
/// rules, ...). Bump it whenever a default changes: a design locked under
/// another version is then reported as changed, since the same bytes now
/// describe another study. Locks written before the version was recorded
/// read as version 1, the defaults up to and including this one.
pub const LANGUAGE_VERSION: u32 = 1;

/// The language version of a lock written before the field existed.
fn first_language() -> u32 {
    1
}

/// The contents of `FILE.design.lock`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LockFile {
    /// File name of the locked design.
    pub design: String,
    /// SHA-256 of the design file's bytes, lowercase hex.
    pub sha256: String,
    /// The version of the language's defaults it was locked under
    /// ([`LANGUAGE_VERSION`]).
    #[serde(default = "first_language")]
    pub language: u32,
    /// Every file the design refers to (as written in it) and its SHA-256;
    /// absent from locks written before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub files: Option<BTreeMap<String, String>>,
    /// Tool name (`crossaudit`).
    pub tool: String,
    /// Tool version that locked it.
    pub tool_version: String,
    /// RFC 3339, UTC, whole seconds.
    pub locked_at_utc: String,
    /// Earlier locks of this design that it replaced, oldest first
    /// (`crossaudit lock DESIGN --amend REASON`): every output of a run
    /// under an amended lock says so.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub amendments: Vec<Amendment>,
    /// Why the design was written (or locked) after results were known
    /// (`crossaudit lock DESIGN --posthoc REASON`): every output of a run
    /// under this lock says POST HOC, never preregistered. Kept by every
    /// later amendment; no command removes it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub posthoc: Option<String>,
}

/// The most characters an amendment's reason may have.
pub const MAX_REASON: usize = 2000;

/// One amendment of a locked design: the lock it replaced and why.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Amendment {
    /// The replaced lock's design hash.
    pub previous_sha256: String,
    /// When the replaced lock was made (RFC 3339, UTC).
    pub previous_locked_at_utc: String,
    /// Why the design was amended, in the researcher's words.
    pub reason: String,
}

impl Amendment {
    /// The sentence every report gives.
    pub fn describe(&self) -> String {
        format!(
            "the design was amended after it was first locked (lock of {}, sha256 {}, replaced): {}",
            self.previous_locked_at_utc,
            self.previous_sha256,
            crate::io::one_line(&self.reason)
        )
    }
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
        /// The earlier locks this one replaced, if it was amended.
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        amendments: Vec<Amendment>,
        /// Why the design was written after results were known, when its
        /// lock says so ([`LockFile::posthoc`]).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        posthoc: Option<String>,
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
    /// Locked, and the design's bytes are those locked, but what they mean
    /// changed: a file the design refers to changed, or the lock was made
    /// under other language defaults. Analyses are exploratory.
    LockedStale {
        /// What changed.
        reason: String,
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
            LockStatus::LockedChanged { .. } | LockStatus::LockedStale { .. } => "locked/changed",
        }
    }

    /// Whether the design, or something it depends on, changed after it was
    /// locked: a run needs `--exploratory` and every output says so.
    pub fn changed(&self) -> bool {
        matches!(self, LockStatus::LockedChanged { .. } | LockStatus::LockedStale { .. })
    }

    /// How near the state stands to a preregistration: 0 unlocked, 1
    /// changed since it was locked, 2 locked and unchanged but marked post
    /// hoc, 3 locked and unchanged. Of two states recorded for one run
    /// (when it began, now), the lower is the one it stands under.
    pub fn rank(&self) -> u8 {
        match self {
            LockStatus::Unlocked => 0,
            LockStatus::LockedChanged { .. } | LockStatus::LockedStale { .. } => 1,
            LockStatus::LockedUnchanged { posthoc: Some(_), .. } => 2,
            LockStatus::LockedUnchanged { .. } => 3,
        }
    }

    /// What changed after the lock, in words (empty unless [`Self::changed`]).
    pub fn reason(&self) -> String {
        match self {
            LockStatus::LockedChanged { locked_sha256, current_sha256, .. } => {
                format!("the design's sha256 is {current_sha256}, the lock records {locked_sha256}")
            }
            LockStatus::LockedStale { reason, .. } => reason.clone(),
            _ => String::new(),
        }
    }

    /// The amendments of a lock that holds, each as the sentence reports give.
    pub fn amendment_warnings(&self) -> Vec<String> {
        match self {
            LockStatus::LockedUnchanged { amendments, .. } => amendments.iter().map(Amendment::describe).collect(),
            _ => Vec::new(),
        }
    }
}

/// Why a lock could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// A time the lock records is not one `lock` writes, or is after now:
    /// the lock was edited by hand.
    #[error("lock file {path}: `{field}` \"{value}\" {why}; a lock is written by `crossaudit lock`, never by hand: restore it from version control, or delete it and lock again (which makes every run before that unpreregistered)")]
    Time {
        /// The lock file.
        path: String,
        /// The field.
        field: &'static str,
        /// Its value.
        value: String,
        /// What is wrong with it.
        why: &'static str,
    },
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
        "{path} is already locked (sha256 {sha256}, {locked_at_utc}); to re-lock the changed design as an amendment that every report discloses, run `crossaudit lock DESIGN --amend \"why\"`"
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
    /// An amendment's reason that cannot be recorded: too long, or with a
    /// control character, or one that would grow the lock past what the
    /// lock reader accepts (after which no command could use the design).
    #[error("{path}: the reason given {why}")]
    BadReason {
        /// The lock file.
        path: String,
        /// What is wrong with it.
        why: String,
    },
    /// `--amend` of a design that has no lock yet, or whose lock holds.
    #[error("{path}: nothing to amend: {why}; `--amend` replaces the lock of a design changed after it was locked")]
    NothingToAmend {
        /// The lock file.
        path: String,
        /// Why.
        why: String,
    },
    /// The design's bytes are those locked, but the lock no longer holds.
    #[error("{path} is already locked ({locked_at_utc}), but {reason}; delete the lock to re-lock the design as it now reads")]
    StaleLock {
        /// The path.
        path: String,
        /// What changed.
        reason: String,
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
    let lock: LockFile =
        serde_json::from_str(&text).map_err(|source| LockError::Parse { path: path.display().to_string(), source })?;
    check_times(&path, &lock, SystemTime::now())?;
    Ok(Some(lock))
}

/// Every time a lock records is a UTC time as `lock` writes it, and none
/// lies after `now` (a day of clock difference allowed): a lock whose time
/// was edited by hand would otherwise stand as "locked before this run".
fn check_times(path: &Path, lock: &LockFile, now: SystemTime) -> Result<(), LockError> {
    // The post hoc mark reaches every report's banner: a hand-edited one
    // holds no control character, as `lock --posthoc` refuses one.
    if let Some(why) = lock.posthoc.as_deref().filter(|w| w.chars().any(|c| c.is_control() && c != '\n' && c != '\t')) {
        return Err(LockError::BadReason {
            path: path.display().to_string(),
            why: format!(
                "in its `posthoc` mark, \"{}\", holds a control character; write it as plain text",
                crate::io::one_line(why)
            ),
        });
    }
    let bad = |field: &'static str, value: &str, why: &'static str| LockError::Time {
        path: path.display().to_string(),
        field,
        value: crate::io::one_line(value).into_owned(),
        why,
    };
    // A hash is 64 lower-case hex digits, as `lock` writes it.
    let hashes = std::iter::once(("sha256", &lock.sha256))
        .chain(lock.amendments.iter().map(|a| ("previous_sha256", &a.previous_sha256)));
    for (field, h) in hashes {
        if h.len() != 64 || !h.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b)) {
            return Err(bad(field, h, "is not a SHA-256 as `crossaudit lock` writes it (64 lower-case hex digits)"));
        }
    }
    // The amendments in the order they were made, each before the lock
    // that replaced it; the lock's own time last, and none after now.
    let times = lock
        .amendments
        .iter()
        .map(|a| ("previous_locked_at_utc", &a.previous_locked_at_utc))
        .chain(std::iter::once(("locked_at_utc", &lock.locked_at_utc)));
    let latest = now + std::time::Duration::from_secs(86_400);
    let mut before: Option<SystemTime> = None;
    for (field, t) in times {
        let why = match humantime::parse_rfc3339(t) {
            Err(_) => "is not a UTC time as `crossaudit lock` writes it (2026-12-05T09:57:33Z)",
            Ok(at) if at > latest => "lies in the future",
            Ok(at) if before.is_some_and(|b| at < b) => {
                "is earlier than a lock it replaced (amendments are recorded in the order they were made)"
            }
            Ok(at) => {
                before = Some(at);
                continue;
            }
        };
        return Err(bad(field, t, why));
    }
    Ok(())
}

/// Every file `file`'s design refers to, as written in it, and its SHA-256:
/// a `split published` file (hashed when the design was loaded), and a
/// conditions table (`conditions table "FILE"`, in the design's data
/// folder: hashed now, or named unreadable), which decides every
/// recording's condition and so the verdict's coverage and groups.
pub fn referenced_files(file: &DesignFile) -> BTreeMap<String, String> {
    let mut out: BTreeMap<String, String> =
        file.design.published.iter().map(|p| (p.file.clone(), p.sha256.clone())).collect();
    let data = &file.design.data;
    let table = data.format.as_ref().and_then(|f| f.conditions_table.as_ref());
    if let (Some(table), Some(dir)) = (table, &data.path) {
        let shown = Path::new(dir).join(table);
        // The data folder as a run finds it: beside the design, else as written.
        let beside = file.path.parent().unwrap_or(Path::new("")).join(&shown);
        let path = if beside.exists() || shown.is_absolute() { beside } else { shown.clone() };
        let sha = crate::io::read_input(&path, crate::io::MAX_SMALL_TEXT, "a conditions table")
            .map(|bytes| crate::io::sha256_hex(&bytes))
            .unwrap_or_else(|e| format!("unreadable: {}", e.reason()));
        out.insert(shown.display().to_string(), sha);
    }
    out
}

/// Whether the design in `file` matches its lock: the design's bytes, the
/// bytes of every file it refers to, and the language defaults.
pub fn status(file: &DesignFile) -> Result<LockStatus, LockError> {
    let Some(lock) = read_lock(&file.path)? else { return Ok(LockStatus::Unlocked) };
    if lock.sha256 != file.sha256 {
        return Ok(LockStatus::LockedChanged {
            locked_sha256: lock.sha256,
            current_sha256: file.sha256.clone(),
            locked_at_utc: lock.locked_at_utc,
        });
    }
    Ok(match stale(&lock, &referenced_files(file)) {
        Some(reason) => LockStatus::LockedStale { reason, locked_at_utc: lock.locked_at_utc },
        None => LockStatus::LockedUnchanged {
            locked_at_utc: lock.locked_at_utc,
            amendments: lock.amendments,
            posthoc: lock.posthoc,
        },
    })
}

/// Why a lock whose design bytes match no longer holds, if it does not.
fn stale(lock: &LockFile, files: &BTreeMap<String, String>) -> Option<String> {
    if lock.language != LANGUAGE_VERSION {
        return Some(format!(
            "it was locked under the defaults of design language version {}, and this crossaudit applies version {LANGUAGE_VERSION}'s, so the same text may now describe another study",
            lock.language
        ));
    }
    let Some(locked) = &lock.files else {
        return (!files.is_empty()).then(|| {
            format!(
                "the lock records no hash of {}, which the design refers to (it predates recording them), so an edit to it cannot be ruled out",
                files.keys().map(|f| format!("`{f}`")).collect::<Vec<_>>().join(", ")
            )
        });
    };
    for (f, sha) in files {
        match locked.get(f) {
            None => return Some(format!("the lock records no hash of `{f}`, which the design refers to")),
            Some(l) if l != sha => {
                return Some(format!(
                "`{f}`, which the design refers to, changed after the lock: its sha256 is {sha}, the lock records {l}"
            ))
            }
            Some(_) => {}
        }
    }
    locked
        .keys()
        .find(|f| !files.contains_key(*f))
        .map(|f| format!("the lock records `{f}`, which the design no longer refers to"))
}

/// Writes the lock of the design in `file`: its hash, the hash of every
/// file it refers to and [`LANGUAGE_VERSION`]. Re-locking an unchanged
/// design is a no-op that returns the existing lock; a design with an
/// existing lock that no longer holds is refused.
pub fn write_lock(file: &DesignFile, now: SystemTime) -> Result<LockFile, LockError> {
    write_lock_amended(file, now, None)
}

/// Marks the design in `file` post hoc (`why`: when and why it was written
/// after results were known), locking it now if it has no lock: a lock
/// that holds keeps its hashes and time and gains the mark. Refused where
/// the lock no longer holds (amend it first) or already says another
/// reason; the same reason again is a no-op.
pub fn mark_posthoc(file: &DesignFile, now: SystemTime, why: &str) -> Result<LockFile, LockError> {
    let path = lock_path(&file.path);
    check_reason(&path, why)?;
    let bad = |why: String| LockError::BadReason { path: path.display().to_string(), why };
    if why.trim().is_empty() {
        return Err(bad("is empty: say when and why the design was written after results were known".into()));
    }
    let mut lock = match read_lock(&file.path)? {
        None => write_lock(file, now)?,
        Some(_) => {
            if let s @ (LockStatus::LockedChanged { .. } | LockStatus::LockedStale { .. }) = status(file)? {
                return Err(bad(format!(
                    "cannot mark a lock that no longer holds ({}); amend the lock first (`--amend`)",
                    s.reason()
                )));
            }
            write_lock(file, now)?
        }
    };
    match &lock.posthoc {
        Some(existing) if existing == why => return Ok(lock),
        Some(existing) => {
            return Err(bad(format!("differs from the lock's own post hoc reason, which stays: {existing}")))
        }
        None => lock.posthoc = Some(why.to_string()),
    }
    write_lock_file(&path, &lock)?;
    Ok(lock)
}

/// Refuses a reason the lock cannot record: too long, or holding a
/// control character.
fn check_reason(path: &Path, reason: &str) -> Result<(), LockError> {
    let bad = |why: String| LockError::BadReason { path: path.display().to_string(), why };
    let chars = reason.chars().count();
    if chars > MAX_REASON {
        return Err(bad(format!(
            "has {chars} characters, more than the {MAX_REASON} a reason may have; say why in a sentence or two, and put the details in the design's comments"
        )));
    }
    if let Some(c) = reason.chars().find(|c| c.is_control() && *c != '\n' && *c != '\t') {
        return Err(bad(format!("holds the control character {:?}; write it as plain text", c)));
    }
    Ok(())
}

/// [`write_lock`], or with `amend` (the reason) the lock of a design
/// changed after it was locked: the new lock keeps the replaced one's hash,
/// time and the reason in its amendments, which every report states.
pub fn write_lock_amended(file: &DesignFile, now: SystemTime, amend: Option<&str>) -> Result<LockFile, LockError> {
    let design = &file.path;
    let path = lock_path(design);
    let files = referenced_files(file);
    let mut amendments = Vec::new();
    let mut posthoc = None;
    if let Some(reason) = amend {
        check_reason(&path, reason)?;
    }
    if let (Some(existing), Some(reason)) = (read_lock(design)?, amend) {
        if existing.sha256 != file.sha256 || stale(&existing, &files).is_some() {
            amendments = existing.amendments.clone();
            posthoc.clone_from(&existing.posthoc);
            amendments.push(Amendment {
                previous_sha256: existing.sha256,
                previous_locked_at_utc: existing.locked_at_utc,
                reason: reason.to_string(),
            });
        }
    }
    if let Some(existing) = read_lock(design)?.filter(|_| amendments.is_empty()) {
        if existing.sha256 != file.sha256 {
            return Err(LockError::AlreadyLocked {
                path: path.display().to_string(),
                sha256: existing.sha256,
                locked_at_utc: existing.locked_at_utc,
            });
        }
        if let Some(reason) = stale(&existing, &files) {
            return Err(LockError::StaleLock {
                path: path.display().to_string(),
                reason,
                locked_at_utc: existing.locked_at_utc,
            });
        }
        return Ok(existing);
    }
    let lock = LockFile {
        design: design.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        sha256: file.sha256.clone(),
        language: LANGUAGE_VERSION,
        files: Some(files),
        tool: env!("CARGO_PKG_NAME").to_string(),
        tool_version: env!("CARGO_PKG_VERSION").to_string(),
        locked_at_utc: humantime::format_rfc3339_seconds(now).to_string(),
        amendments,
        posthoc,
    };
    write_lock_file(&path, &lock)?;
    Ok(lock)
}

/// Writes `lock` to `path` atomically, never one its own reader refuses.
fn write_lock_file(path: &Path, lock: &LockFile) -> Result<(), LockError> {
    let text = crate::io::pretty_json(lock);
    // Never write a lock its own reader refuses.
    if text.len() as u64 > crate::io::MAX_SMALL_TEXT {
        return Err(LockError::BadReason {
            path: path.display().to_string(),
            why: format!(
                "would grow the lock to {} bytes, more than the {} a lock may have (it records {} amendments); the lock was left as it was",
                text.len(),
                crate::io::MAX_SMALL_TEXT,
                lock.amendments.len()
            ),
        });
    }
    crate::io::write_atomic(path, text.as_bytes())
        .map_err(|e| LockError::Write { path: path.display().to_string(), source: e.source })
}
