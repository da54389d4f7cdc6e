//! Manifests as files: one CSV per manifest (recording, sample index), and
//! manifests.json with each one's SHA-256, row count and the seeds behind it.
//! The same design and data give byte-identical files.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::{Split, Window};
use crate::design::{ArmKind, Design};
use crate::io::{write_atomic, WriteError};

/// One manifest's text and hash.
#[derive(Debug, Clone, Serialize)]
pub struct ManifestSummary {
    /// SHA-256 of the text, lowercase hex.
    pub sha256: String,
    /// Data rows (without the header).
    pub rows: usize,
    /// The CSV text as written.
    #[serde(skip)]
    pub text: String,
}

/// All manifests of a split, keyed by file name.
#[derive(Debug, Clone, Serialize)]
pub struct Manifests {
    /// Study name.
    pub study: String,
    /// SHA-256 of the design file, when known.
    pub design_sha256: Option<String>,
    /// Every seed that drew part of the split, by name.
    pub seeds: BTreeMap<String, u64>,
    /// Manifest files by name.
    pub files: BTreeMap<String, ManifestSummary>,
}

fn summary(text: String, rows: usize) -> ManifestSummary {
    ManifestSummary { sha256: crate::io::sha256_hex(text.as_bytes()), rows, text }
}

/// Serializes rows to CSV text (header from the row type's field names).
fn to_csv<T: Serialize>(rows: impl Iterator<Item = T>, header: &[&str]) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut n = 0;
    for r in rows {
        // Writing plain records into memory cannot fail.
        let _ = w.serialize(r);
        n += 1;
    }
    if n == 0 {
        let _ = w.write_record(header);
    }
    String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
}

/// A row of a window or start manifest.
#[derive(Serialize)]
struct WindowRow<'a> {
    recording: &'a str,
    sample_index: usize,
}

/// A drawn recording without a CSV.
#[derive(Serialize)]
struct AbsentRow<'a> {
    role: &'a str,
    recording: &'a str,
}

/// A fit recording of a published split dropped as a copy of a held-out one.
#[derive(Serialize)]
struct LeakedRow<'a> {
    recording: &'a str,
    identical_to: &'a str,
}

/// A row of a recording manifest.
#[derive(Serialize)]
struct RecordingRow<'a> {
    recording: &'a str,
    trajectory: &'a str,
    speed: &'a str,
    duplicate_group: &'a str,
    content_hash: &'a str,
}

fn windows_csv(split: &Split, windows: &[Window]) -> ManifestSummary {
    let rows = windows.iter().map(|w| WindowRow { recording: &split.recordings[w.recording].name, sample_index: w.t });
    summary(to_csv(rows, &["recording", "sample_index"]), windows.len())
}

fn recordings_csv(split: &Split, which: &[usize]) -> ManifestSummary {
    let rows = which.iter().map(|&r| {
        let i = &split.recordings[r];
        RecordingRow {
            recording: &i.name,
            trajectory: &i.trajectory,
            speed: &i.speed,
            duplicate_group: i.duplicate_group.as_deref().unwrap_or(""),
            content_hash: &i.content_hash,
        }
    });
    let header = ["recording", "trajectory", "speed", "duplicate_group", "content_hash"];
    summary(to_csv(rows, &header), which.len())
}

impl Manifests {
    /// The manifests of `split` under `design`.
    pub fn new(design: &Design, design_sha256: Option<String>, split: &Split) -> Manifests {
        let mut files = BTreeMap::new();
        files.insert("evaluation_recordings.csv".to_string(), recordings_csv(split, &split.evaluation));
        files.insert("evaluation_starts.csv".to_string(), windows_csv(split, &split.starts));
        files.insert("validation_recordings.csv".to_string(), recordings_csv(split, &split.validation_recordings));
        files.insert("validation_windows.csv".to_string(), windows_csv(split, &split.validation));
        if !split.evaluation_absent.is_empty() || !split.validation_absent.is_empty() || !split.fit_absent.is_empty() {
            let rows = split
                .evaluation_absent
                .iter()
                .map(|n| AbsentRow { role: "evaluation", recording: n })
                .chain(split.validation_absent.iter().map(|n| AbsentRow { role: "validation", recording: n }))
                .chain(split.fit_absent.iter().map(|n| AbsentRow { role: "fit", recording: n }));
            let n = split.evaluation_absent.len() + split.validation_absent.len() + split.fit_absent.len();
            files.insert("absent_recordings.csv".to_string(), summary(to_csv(rows, &["role", "recording"]), n));
        }
        if !split.fit_leaked.is_empty() {
            let rows = split.fit_leaked.iter().map(|(copy, held)| LeakedRow { recording: copy, identical_to: held });
            let n = split.fit_leaked.len();
            files
                .insert("fit_leaked_dropped.csv".to_string(), summary(to_csv(rows, &["recording", "identical_to"]), n));
        }
        for (arm, w) in &split.fits {
            files.insert(format!("fit_{arm}.csv"), windows_csv(split, w));
        }
        for (arm, w) in &split.contaminating {
            files.insert(format!("contaminating_{arm}.csv"), windows_csv(split, w));
        }
        let mut seeds = BTreeMap::new();
        seeds.insert("split_seed".to_string(), design.recording.split_seed);
        seeds.insert("validation_seed".to_string(), design.validation.seed);
        for a in &design.arms {
            let seed = match a.kind {
                ArmKind::Fit { seed, .. } | ArmKind::Derived { seed, .. } => seed,
            };
            seeds.insert(format!("arm_{}_seed", a.name), seed);
        }
        Manifests { study: design.study.clone(), design_sha256, seeds, files }
    }

    /// The hash of one manifest file; empty if there is none of that name.
    pub fn sha256(&self, file: &str) -> &str {
        self.files.get(file).map(|m| m.sha256.as_str()).unwrap_or("")
    }

    /// Pretty JSON, for `manifests.json`.
    pub fn to_json(&self) -> String {
        crate::io::pretty_json(self)
    }
}

/// Writes `manifests/*.csv` and `manifests/manifests.json` under `out`.
pub fn write_split(out: &Path, manifests: &Manifests) -> Result<PathBuf, WriteError> {
    let dir = out.join("manifests");
    crate::io::create_dir_all(&dir)?;
    for (name, m) in &manifests.files {
        write_atomic(&dir.join(name), m.text.as_bytes())?;
    }
    let json = dir.join("manifests.json");
    write_atomic(&json, manifests.to_json().as_bytes())?;
    Ok(json)
}
