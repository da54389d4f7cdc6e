//! Manifests as files: one CSV per manifest (recording, sample index), and
//! manifests.json with each one's SHA-256, row count and the seeds behind it.
//! The same design and data give byte-identical files.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::{Split, Window};
use crate::design::{ArmKind, Design};
use crate::io::{write_atomic, WriteError};

/// One manifest's text and hash.
#[derive(Debug, Clone, Serialize)]
pub struct ManifestSummary {
    pub sha256: String,
    pub rows: usize,
    #[serde(skip)]
    pub text: String,
}

/// All manifests of a split, keyed by file name.
#[derive(Debug, Clone, Serialize)]
pub struct Manifests {
    pub study: String,
    pub design_sha256: Option<String>,
    pub seeds: BTreeMap<String, u64>,
    pub files: BTreeMap<String, ManifestSummary>,
}

fn summary(text: String, rows: usize) -> ManifestSummary {
    ManifestSummary { sha256: crate::io::sha256_hex(text.as_bytes()), rows, text }
}

fn windows_csv(split: &Split, windows: &[Window]) -> ManifestSummary {
    let mut s = String::from("recording,sample_index\n");
    for w in windows {
        let _ = writeln!(s, "{},{}", split.recordings[w.recording].name, w.t);
    }
    summary(s, windows.len())
}

fn recordings_csv(split: &Split, which: &[usize]) -> ManifestSummary {
    let mut s = String::from("recording,trajectory,speed,duplicate_group,content_hash\n");
    for &r in which {
        let i = &split.recordings[r];
        let _ = writeln!(
            s,
            "{},{},{},{},{}",
            i.name,
            i.trajectory,
            i.speed,
            i.duplicate_group.clone().unwrap_or_default(),
            i.content_hash
        );
    }
    summary(s, which.len())
}

impl Manifests {
    pub fn new(design: &Design, design_sha256: Option<String>, split: &Split) -> Manifests {
        let mut files = BTreeMap::new();
        files.insert("evaluation_recordings.csv".to_string(), recordings_csv(split, &split.evaluation));
        files.insert("evaluation_starts.csv".to_string(), windows_csv(split, &split.starts));
        files.insert("validation_recordings.csv".to_string(), recordings_csv(split, &split.validation_recordings));
        files.insert("validation_windows.csv".to_string(), windows_csv(split, &split.validation));
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

    pub fn sha256(&self, file: &str) -> &str {
        self.files.get(file).map(|m| m.sha256.as_str()).unwrap_or("")
    }

    pub fn to_json(&self) -> String {
        let mut s = serde_json::to_string_pretty(self).expect("manifests serialize");
        s.push('\n');
        s
    }
}

/// Writes `manifests/*.csv` and `manifests/manifests.json` under `out`.
pub fn write_split(out: &Path, manifests: &Manifests) -> Result<PathBuf, WriteError> {
    let dir = out.join("manifests");
    std::fs::create_dir_all(&dir).map_err(|source| WriteError { path: dir.display().to_string(), source })?;
    for (name, m) in &manifests.files {
        write_atomic(&dir.join(name), m.text.as_bytes())?;
    }
    let json = dir.join("manifests.json");
    write_atomic(&json, manifests.to_json().as_bytes())?;
    Ok(json)
}
