//! `run DESIGN --out NEW --reuse OLD`: finished jobs of an earlier run
//! whose inputs are identical are copied instead of trained again. This is
//! how a locked per-seed study grows: amend the seed factor (`lock
//! --amend`), run the amended design into a new folder with the first run
//! as `--reuse`, and only the new seeds train; the analysis then covers
//! every seed.
//!
//! A job's content key (`job_key`) hashes everything that decides the
//! files it writes: the manifests it reads (by hash), the inclusion audit's
//! hash, the data block, the model, the training, the seed, the horizons,
//! the cap and the rate. Every job record carries its key; a job of the new
//! run is taken from the earlier one only when the key and the job's name
//! (model, arm, seed) are equal and every file the earlier record lists
//! still has its recorded SHA-256. The copied record keeps the build that
//! trained it and names the run it came from.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::record::{job_record_path, JobRecord};
use super::{RunError, RunRecord};
use crate::design::Design;
use crate::io::{create_dir_all, sha256_file, write_atomic};
use crate::plan::{Plan, TrainingJob};

/// What decides every file a job writes: the manifests it reads (by hash),
/// the data they index (the inclusion audit's hash and the data block:
/// columns, tails, duplicates), the model, the training (fitted models
/// only), the seed, the horizons, the cap and the rate.
pub(crate) fn job_key(
    design: &Design,
    plan: &Plan,
    job: &TrainingJob,
    manifests: &crate::split::JobManifests,
    record: &RunRecord,
) -> String {
    let key = serde_json::json!({
        "manifests": manifests,
        "audit_sha256": record.audit_sha256,
        "data": design.data,
        "model": job.kind,
        "training": if job.trains() { serde_json::to_value(&plan.training).unwrap_or_default() } else { serde_json::Value::Null },
        "seed": job.seed,
        "horizons_s": job.horizons_s,
        "cap": plan.cap.0,
        "rate_hz": plan.rate_hz,
    });
    crate::io::sha256_hex(key.to_string().as_bytes())
}

/// Every job's key in a run folder `dir` of `design` and `plan`, opened
/// with `record` and `manifests`.
pub(crate) fn keys(
    design: &Design,
    plan: &Plan,
    manifests: &crate::split::Manifests,
    record: &RunRecord,
) -> Vec<(TrainingJob, String)> {
    crate::split::JobManifests::for_plan(plan, manifests)
        .iter()
        .zip(&plan.jobs)
        .map(|(m, j)| (j.clone(), job_key(design, plan, j, m, record)))
        .collect()
}

/// Writes each finished job's key into its record where the record has
/// none (a job trained or copied by this run).
pub(crate) fn stamp(dir: &Path, keys: &[(TrainingJob, String)]) -> Result<(), RunError> {
    for (job, key) in keys {
        if let Some(mut r) = JobRecord::read(dir, job)? {
            if r.key.is_none() {
                r.key = Some(key.clone());
                r.write(dir, job)?;
            }
        }
    }
    Ok(())
}

/// The finished jobs of an earlier run, by key and name.
pub(crate) struct ReuseIndex {
    from: PathBuf,
    jobs: BTreeMap<(String, String), (PathBuf, JobRecord)>,
}

/// Folders below a run directory that may hold job records: the run
/// itself, its levels (`draw-K`, `spec-ID`, `split-S`) and a multiverse's
/// per-seed levels (`spec-ID/draw-K`).
const MAX_DEPTH: usize = 2;

impl ReuseIndex {
    /// Reads every job record under `from` (the run, its levels and their
    /// levels). A record without a key (written before keys were recorded)
    /// cannot be matched and is left out; `from` without any record is
    /// refused, so a mistyped folder does not silently train everything.
    pub(crate) fn read(from: &Path) -> Result<ReuseIndex, RunError> {
        let mut jobs = BTreeMap::new();
        let mut unkeyed = 0usize;
        let mut stack = vec![(from.to_path_buf(), 0usize)];
        while let Some((dir, depth)) = stack.pop() {
            let Ok(entries) = std::fs::read_dir(&dir) else { continue };
            let mut entries: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
            entries.sort();
            for path in entries {
                let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
                if name == "run.json" {
                    refuse_text_hashes(from, &dir)?;
                } else if name == "jobs" && path.is_dir() {
                    for rec in std::fs::read_dir(&path).map_err(|e| reuse_error(&path, e.to_string()))? {
                        let rec = rec.map_err(|e| reuse_error(&path, e.to_string()))?.path();
                        if rec.extension().is_none_or(|x| x != "json") {
                            continue;
                        }
                        let bytes = crate::io::read_own(&rec).map_err(|e| reuse_error(&rec, e.to_string()))?;
                        let r: JobRecord =
                            serde_json::from_slice(&bytes).map_err(|e| reuse_error(&rec, e.to_string()))?;
                        match &r.key {
                            Some(k) => {
                                let stem =
                                    rec.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
                                jobs.insert((k.clone(), stem), (dir.clone(), r));
                            }
                            None => unkeyed += 1,
                        }
                    }
                } else if depth < MAX_DEPTH && path.is_dir() && !path.is_symlink() {
                    stack.push((path, depth + 1));
                }
            }
        }
        if jobs.is_empty() {
            let why = if unkeyed > 0 {
                format!("its {unkeyed} job record(s) were written before records carried their content key, so none can be matched; rerun them once with this build (a resumed run records the keys), then reuse the folder")
            } else {
                "it holds no finished job (no jobs/*.json in it or in its level folders)".to_string()
            };
            return Err(reuse_error(from, why));
        }
        Ok(ReuseIndex { from: from.to_path_buf(), jobs })
    }

    /// Copies the earlier run's finished job with `key` and the same name
    /// as `job` into `to` (the new run's folder of `design_sha256`), after
    /// checking every file it lists against its recorded SHA-256; `false`
    /// when there is none.
    pub(crate) fn take(&self, key: &str, to: &Path, job: &TrainingJob, design_sha256: &str) -> Result<bool, RunError> {
        let Some((dir, old)) = self.jobs.get(&(key.to_string(), job.stem())) else { return Ok(false) };
        for (name, sha) in &old.files {
            let path = dir.join(name);
            let now = sha256_file(&path).map_err(|e| reuse_error(&path, e.to_string()))?;
            if now != *sha {
                return Err(reuse_error(
                    &path,
                    format!(
                        "sha256 {now}, but {} recorded {sha}: it changed after the job wrote it",
                        job_record_path(dir, job).display()
                    ),
                ));
            }
        }
        for name in old.files.keys() {
            let target = to.join(name);
            create_dir_all(target.parent().unwrap_or(to))?;
            let bytes = std::fs::read(dir.join(name)).map_err(|e| crate::io::WriteError::new(&dir.join(name), e))?;
            write_atomic(&target, &bytes)?;
        }
        let record = JobRecord {
            design_sha256: design_sha256.to_string(),
            reused_from: Some(format!("{} (design sha256 {})", dir.display(), old.design_sha256)),
            ..old.clone()
        };
        record.write(to, job)?;
        Ok(true)
    }

    /// The folder reused, as the report names it.
    pub(crate) fn from(&self) -> &Path {
        &self.from
    }
}

/// The report's line for jobs copied by `run --reuse`.
pub(crate) fn reused_note(taken: usize, of: usize, from: &Path) -> String {
    format!(
        "{taken} of {of} jobs were copied from the earlier run {} instead of trained (`--reuse`): their inputs (manifests, data, model, training, seed, horizons) are identical by content key, every file was checked against its recorded SHA-256, and each job record names the run it came from",
        from.display()
    )
}

/// Refuses to reuse `from` where the run folder `dir` (it or one of its
/// levels) hashed its logs' text: every job key holds the audit's and the
/// manifests' hashes, so none could match this build's, and the run would
/// silently train everything again.
fn refuse_text_hashes(from: &Path, dir: &Path) -> Result<(), RunError> {
    match RunRecord::read(dir) {
        Ok(Some(r)) if r.content_hashes == super::ContentHashes::Text => Err(reuse_error(
            from,
            format!(
                "{} was written by crossaudit {}, whose content hashes of the logs are of their text; this build hashes the values read, so none of its jobs' content keys (which hold the audit's and the manifests' hashes) can match: run it again with this build, then reuse that run",
                dir.display(),
                r.crossaudit
            ),
        )),
        _ => Ok(()),
    }
}

fn reuse_error(path: &Path, reason: String) -> RunError {
    RunError::Reuse { path: path.display().to_string(), reason }
}
