//! What a run directory holds, recorded so that a resume reuses only what
//! it can verify: `run.json` (design, data, audit, manifests, build) and
//! one `jobs/STEM.json` per finished job (the manifests it trained on, its
//! standardizers and seed, and the SHA-256 of every file it wrote). A job
//! record is written last, atomically: it is what marks a job finished.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{DataOrigin, RunError};
use crate::io::{pretty_json, sha256_file, write_atomic};
use crate::model::FeatureMap;
use crate::plan::TrainingJob;
use crate::split::JobManifests;

/// run.json: what a run directory holds, checked on resume.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// The study's name.
    pub study: String,
    /// SHA-256 of the design file.
    pub design_sha256: String,
    /// Where the flight logs came from.
    pub data: DataOrigin,
    /// SHA-256 of the inclusion audit (`audit/recordings.csv`).
    pub audit_sha256: String,
    /// SHA-256 of manifests.json.
    pub manifests_sha256: String,
    /// How the logs' content hashes in the audit and the manifests are
    /// defined: on the values read ([`ContentHashes::Values`], every run
    /// this build writes); absent in runs written before, whose hashes are
    /// of the logs' text ([`ContentHashes::Text`]), which a resume refuses
    /// by name rather than as other data.
    #[serde(default)]
    pub content_hashes: ContentHashes,
    /// SHA-256 of each file of evidence the split wrote beside the
    /// inclusion audit (`audit/invariants.json`, `audit/treatment.json`,
    /// by path in the folder): a reanalysis leaves out, and names, one
    /// edited since (its numbers feed the report, the condition coverage
    /// beside the verdict among them). Absent in runs written before it
    /// was recorded.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub evidence_sha256: BTreeMap<String, String>,
    /// Whether the run's outputs are labelled EXPLORATORY (kept on a
    /// resume: a label is never taken off).
    pub exploratory: bool,
    /// The design's lock state when the run began, kept over resumes: an
    /// analysis of the folder stands under the lower of it and the state
    /// now ([`crate::analysis::Standing::of_run`]), so a design locked
    /// after its run began is not preregistered for it. Absent in runs
    /// written before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lock: Option<crate::design::LockStatus>,
    /// The crossaudit build that last wrote the directory ([`crate::io::BUILD`]).
    pub crossaudit: String,
    /// The outer level this directory holds (`spec-s1`, `draw-2`,
    /// `split-3`), for a level of a multiverse, draw-replicated or
    /// multi-split study: a reanalysis refuses a level folder found under
    /// another level's name. Absent for a study of one run (and in runs
    /// written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level: Option<String>,
    /// SHA-256 of `cells.csv` as the run gathered it from its jobs: a
    /// reanalysis of the folder refuses a cells.csv edited since. Absent
    /// until the run finished (and in runs written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cells_sha256: Option<String>,
    /// Builds other than `crossaudit` that trained some of the cells (a
    /// resumed run), recorded when cells.csv is gathered: the report says
    /// so, and a reanalysis of the folder reads it here.
    #[serde(default, skip_serializing_if = "std::collections::BTreeSet::is_empty")]
    pub resumed_from: std::collections::BTreeSet<String>,
    /// What the run noted beyond its files (jobs reused from an earlier
    /// run, external models' predictions), recorded when cells.csv is
    /// gathered, for the report and any reanalysis of the folder.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    /// The device the run last trained on, where not the CPU
    /// ([`crate::model::Device::record`]): an execution choice, not part of
    /// the design's lock, and not compared on resume. Absent for the CPU.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device: Option<String>,
}

/// How a run's recorded content hashes of its logs are defined
/// ([`crate::data::log::Log::content_hash`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ContentHashes {
    /// Of each log's text as written (runs written before the definition
    /// was recorded): `0.10` and `0.1` hashed apart.
    #[default]
    Text,
    /// Of the values read: what this build computes.
    Values,
}

/// A record's seal broken, or the record unreadable, as the run's error.
pub(crate) fn opened(e: crate::io::seal::SealError, path: &Path, dir: &Path) -> RunError {
    let (path, dir) = (path.display().to_string(), dir.display().to_string());
    match e {
        crate::io::seal::SealError::Edited { now, recorded } => RunError::RecordEdited { path, dir, now, recorded },
        crate::io::seal::SealError::Json(reason) => RunError::BadRunRecord { path, dir, reason },
    }
}

/// Output entries that only a run writes: their presence without a
/// readable run.json means the record was lost or the folder is not a run.
const RUN_OUTPUTS: [&str; 5] = ["jobs", "cells", "models", "curves", "cells.csv"];

impl RunRecord {
    /// The record of a run of `file` on `data`, prepared as `prepared`.
    pub(crate) fn new(
        plan: &crate::plan::Plan,
        file: &crate::design::DesignFile,
        data: &super::Data,
        prepared: &crate::split::Prepared,
        exploratory: bool,
    ) -> RunRecord {
        RunRecord {
            study: plan.study.clone(),
            design_sha256: file.sha256.clone(),
            data: data.origin.clone(),
            audit_sha256: crate::io::sha256_hex(prepared.audit.to_csv().as_bytes()),
            manifests_sha256: crate::io::sha256_hex(prepared.manifests.to_json().as_bytes()),
            content_hashes: ContentHashes::Values,
            evidence_sha256: BTreeMap::from([
                ("audit/invariants.json".to_string(), crate::io::sha256_hex(prepared.invariants.to_json().as_bytes())),
                ("audit/treatment.json".to_string(), crate::io::sha256_hex(prepared.treatment.to_json().as_bytes())),
            ]),
            exploratory,
            lock: None,
            crossaudit: crate::io::BUILD.to_string(),
            level: None,
            cells_sha256: None,
            resumed_from: Default::default(),
            notes: Vec::new(),
            device: None,
        }
    }

    /// The record of the run in `out`: `None` for a directory no run has
    /// written into, an error when run.json is unreadable or missing beside
    /// a run's outputs (nothing there can be verified, so nothing is reused).
    pub fn read(out: &Path) -> Result<Option<RunRecord>, RunError> {
        let path = out.join("run.json");
        let unreadable = |reason: String| RunError::BadRunRecord {
            path: path.display().to_string(),
            dir: out.display().to_string(),
            reason,
        };
        match crate::io::read_own(&path) {
            Ok(bytes) => crate::io::seal::open(&bytes).map(Some).map_err(|e| opened(e, &path, out)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                match RUN_OUTPUTS.iter().find(|name| out.join(name).exists()) {
                    Some(name) => Err(unreadable(format!("it is missing, but {name} is there"))),
                    None => Ok(None),
                }
            }
            Err(e) => Err(unreadable(e.to_string())),
        }
    }

    /// Refuses a resume of another design, other data or other manifests,
    /// naming what differs.
    pub fn check_resume(&self, out: &Path, now: &RunRecord) -> Result<(), RunError> {
        let dir = out.display().to_string();
        if self.design_sha256 != now.design_sha256 {
            return Err(RunError::OtherDesign { dir, sha256: self.design_sha256.clone() });
        }
        if self.content_hashes != now.content_hashes {
            return Err(RunError::OtherContentHashes { dir, build: self.crossaudit.clone() });
        }
        let differs =
            |what: &str, was: String, is: String| RunError::OtherData { dir: dir.clone(), what: what.into(), was, is };
        // A directory may be named by another path (the audit hash below
        // checks its content); any other difference in the data is refused.
        let same_data = matches!((&self.data, &now.data), (DataOrigin::Directory { .. }, DataOrigin::Directory { .. }))
            || self.data == now.data;
        if !same_data {
            return Err(differs("data", self.data.describe(), now.data.describe()));
        }
        if self.audit_sha256 != now.audit_sha256 {
            return Err(differs("inclusion audit (sha256)", self.audit_sha256.clone(), now.audit_sha256.clone()));
        }
        if self.manifests_sha256 != now.manifests_sha256 {
            return Err(RunError::ManifestsChanged { dir });
        }
        if let (Some(was), Some(is)) = (&self.level, &now.level) {
            if was != is {
                return Err(RunError::WrongLevel { dir, was: was.clone(), is: is.clone() });
            }
        }
        Ok(())
    }

    /// Writes `out/run.json` atomically, sealed ([`crate::io::seal`]): a
    /// reanalysis or resume refuses it edited since.
    pub fn write(&self, out: &Path) -> Result<(), RunError> {
        Ok(write_atomic(&out.join("run.json"), crate::io::seal::sealed_json(self).as_bytes())?)
    }
}

/// study.json: what the folder of a study of several level folders (a
/// `draws per seed` study, a family of whole splits, a multiverse)
/// records beside its combined cells, for a reanalysis of the folder to
/// read: the levels it combined, the hash of the combined cells file, the
/// run's notes and, for a multiverse, what its specifications' splits share. Each level's own evidence is in its level folder's run.json.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StudyRecord {
    /// The study's name.
    pub study: String,
    /// SHA-256 of the design file.
    pub design_sha256: String,
    /// The crossaudit build that combined the levels ([`crate::io::BUILD`]).
    pub crossaudit: String,
    /// The level folders combined, in order (relative to this folder).
    pub levels: Vec<String>,
    /// SHA-256 of the combined `cells.csv` as the run wrote it.
    pub cells_sha256: String,
    /// What the run noted beyond its files (jobs reused from an earlier
    /// run or copied between levels, external models' predictions).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    /// For a multiverse: the evaluation recordings, starts and reference
    /// fit windows each pair of specifications' splits share.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shared: Vec<crate::analysis::multiverse::SharedDraws>,
}

impl StudyRecord {
    /// `dir/study.json`: `None` where absent (a folder written before it
    /// was recorded), an error naming the file where unreadable.
    pub fn read(dir: &Path) -> Result<Option<StudyRecord>, RunError> {
        let path = dir.join("study.json");
        let unreadable = |reason: String| RunError::BadRunRecord {
            path: path.display().to_string(),
            dir: dir.display().to_string(),
            reason,
        };
        match crate::io::read_own(&path) {
            Ok(bytes) => crate::io::seal::open(&bytes).map(Some).map_err(|e| opened(e, &path, dir)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(unreadable(e.to_string())),
        }
    }

    /// Writes `dir/study.json` atomically, sealed ([`crate::io::seal`]).
    pub fn write(&self, dir: &Path) -> Result<(), RunError> {
        Ok(write_atomic(&dir.join("study.json"), crate::io::seal::sealed_json(self).as_bytes())?)
    }
}

/// `jobs/STEM.json`: what one finished job trained on and wrote.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JobRecord {
    /// The model.
    pub model: String,
    /// The arm it was fitted on.
    pub arm: String,
    /// The training seed it used.
    pub seed: u64,
    /// SHA-256 of the design it ran under.
    pub design_sha256: String,
    /// SHA-256 of each manifest it read, as it read them.
    pub manifests: JobManifests,
    /// The standardizers it fitted (fitted models only).
    pub standardizers: Option<FeatureMap>,
    /// Every file it wrote (path relative to the run directory) and its SHA-256.
    pub files: BTreeMap<String, String>,
    /// The crossaudit build that ran it ([`crate::io::BUILD`]).
    pub crossaudit: String,
    /// An external model's trajectories with a non-finite predicted state
    /// (absent for built-in models).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub non_finite_starts: Option<usize>,
    /// The job's content key (`run::reuse`): what decides every file it
    /// writes. Absent in records written before keys were recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub key: Option<String>,
    /// The run folder (and its design's hash) the job was copied from by
    /// `run --reuse`; absent for a job trained in this folder.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reused_from: Option<String>,
    /// The device its network trained on, where not the CPU
    /// ([`crate::model::Device::record`]): an execution choice, not part
    /// of the design's lock. Absent for the CPU.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device: Option<String>,
}

/// `out/jobs/STEM.json`.
pub fn job_record_path(out: &Path, job: &TrainingJob) -> PathBuf {
    out.join("jobs").join(format!("{}.json", job.stem()))
}

impl JobRecord {
    /// The SHA-256 of each of `files` (paths relative to `out`).
    pub fn hash_files(out: &Path, files: &[String]) -> Result<BTreeMap<String, String>, RunError> {
        files
            .iter()
            .map(|f| {
                let path = out.join(f);
                let sha = sha256_file(&path).map_err(|e| RunError::Write(crate::io::WriteError::new(&path, e)))?;
                Ok((f.clone(), sha))
            })
            .collect()
    }

    /// Writes the record atomically: from now on the job counts as finished.
    pub fn write(&self, out: &Path, job: &TrainingJob) -> Result<(), RunError> {
        let path = job_record_path(out, job);
        crate::io::create_dir_all(path.parent().unwrap_or(out))?;
        Ok(write_atomic(&path, pretty_json(self).as_bytes())?)
    }

    /// The record of `job` in `out`, if it finished: `None` when there is
    /// no record, an error when the record cannot be read or describes
    /// another job.
    pub fn read(out: &Path, job: &TrainingJob) -> Result<Option<JobRecord>, RunError> {
        let path = job_record_path(out, job);
        let bad = |reason: String| RunError::BadJobRecord { path: path.display().to_string(), reason };
        let bytes = match crate::io::read_own(&path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(bad(e.to_string())),
        };
        let record: JobRecord = serde_json::from_slice(&bytes).map_err(|e| bad(e.to_string()))?;
        if (record.model.as_str(), record.arm.as_str(), record.seed)
            != (job.model.as_str(), job.arm.as_str(), job.seed.0)
        {
            return Err(bad(format!("it records {}/{}/{}", record.model, record.arm, record.seed)));
        }
        Ok(Some(record))
    }

    /// The files a finished `job` writes (relative to the run directory):
    /// always its per-cell rows; an MLP's weights, their metadata and its
    /// training curve too; a linear model's weights (one JSON file).
    pub fn expected_files(job: &TrainingJob) -> Vec<String> {
        let stem = job.stem();
        let mut files = vec![format!("cells/{stem}.csv")];
        if job.kind.is_external() {
            files.extend([format!("predictions/{stem}.json"), format!("predictions/{stem}.npy")]);
        } else if job.trains() && !job.kind.has_curve() {
            files.push(format!("models/{stem}.json"));
        } else if job.trains() {
            files.extend([
                format!("curves/{stem}.csv"),
                format!("models/{stem}.json"),
                format!("models/{stem}.safetensors"),
            ]);
        }
        files.sort();
        files
    }

    /// Refuses a finished job that is not this run's: a record of another
    /// design than `design_sha256`, one whose `files` are not exactly those
    /// such a job writes (an emptied or edited list verifies nothing), or a
    /// file that changed since the job wrote it.
    pub fn verify(&self, out: &Path, job: &TrainingJob, design_sha256: &str) -> Result<(), RunError> {
        let path = job_record_path(out, job);
        let bad = |reason: String| RunError::BadJobRecord { path: path.display().to_string(), reason };
        if self.design_sha256 != design_sha256 {
            return Err(bad(format!(
                "it records design sha256 {}, but the run in {} is of design sha256 {design_sha256}",
                self.design_sha256,
                out.display()
            )));
        }
        let listed: Vec<&String> = self.files.keys().collect();
        let expected = JobRecord::expected_files(job);
        if listed != expected.iter().collect::<Vec<_>>() {
            let shown = |v: Vec<&String>| {
                if v.is_empty() {
                    "nothing".to_string()
                } else {
                    v.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
                }
            };
            return Err(bad(format!(
                "its `files` lists {}, but the job writes {}",
                shown(listed),
                shown(expected.iter().collect())
            )));
        }
        self.verify_files(out, job)
    }

    /// As [`JobRecord::verify`] for a reanalysis: the design, and the
    /// job's per-cell file unchanged (weights are not read; a training
    /// curve is checked against the record where the report reads it).
    pub fn verify_cells(&self, out: &Path, job: &TrainingJob, design_sha256: &str) -> Result<(), RunError> {
        let path = job_record_path(out, job);
        let bad = |reason: String| RunError::BadJobRecord { path: path.display().to_string(), reason };
        if self.design_sha256 != design_sha256 {
            return Err(bad(format!(
                "it records design sha256 {}, but the run in {} is of design sha256 {design_sha256}",
                self.design_sha256,
                out.display()
            )));
        }
        let cells = format!("cells/{}.csv", job.stem());
        let Some(want) = self.files.get(&cells) else {
            return Err(bad(format!("its `files` does not list {cells}")));
        };
        let now = sha256_file(&out.join(&cells)).map_err(|e| bad(format!("{cells}: {e}")))?;
        if now != *want {
            return Err(bad(format!(
                "{cells} has sha256 {now}, but the job recorded {want}: it was edited after the run"
            )));
        }
        Ok(())
    }

    /// Refuses a finished job whose files changed since it wrote them.
    fn verify_files(&self, out: &Path, job: &TrainingJob) -> Result<(), RunError> {
        for (file, sha) in &self.files {
            let path = out.join(file);
            let changed = |reason: String| RunError::JobFileChanged {
                path: path.display().to_string(),
                record: job_record_path(out, job).display().to_string(),
                reason,
            };
            let now = sha256_file(&path).map_err(|e| changed(e.to_string()))?;
            if now != *sha {
                return Err(changed(format!("sha256 {now}, recorded {sha}")));
            }
        }
        Ok(())
    }
}
