//! The run folder read back as one typed record
//! ([`crate::analysis::record::Record`]): its cells, and every file of
//! evidence it holds beyond them, each through a serde type and verified
//! once (the folder's run.json is of this design, its cells.csv the one
//! the run gathered). A missing or unreadable evidence file is a sentence
//! in the record's `missing` (a warning in the report), never a silent
//! absence. A run's own finish and a reanalysis both read it here, so
//! both analyse the same record.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::Deserialize;

use super::{RunError, RunRecord};
use crate::analysis::record::{Curve, DesignLabel, InvariantsFile, LevelEvidence, Record, RunEvidence, Treatment};
use crate::cells::read_cells;
use crate::design::{lock, DesignFile};
use crate::plan::Plan;

/// The record of `cells` for the design `file` compiled as `plan`: a run
/// folder (its `cells.csv` and its evidence), a run's own `cells.csv`
/// (read with its folder's evidence when the folder's run.json records
/// this design and this file's hash), or any other per-cell file alone.
pub fn read_record(file: &DesignFile, plan: &Plan, cells: &Path) -> Result<Record, RunError> {
    let design =
        DesignLabel { path: file.path.display().to_string(), sha256: file.sha256.clone(), status: lock::status(file)? };
    if cells.is_dir() {
        return read_folder(design, plan, cells);
    }
    // Read (and so checked to be a regular file) before it is hashed.
    let rows = read_cells(cells)?;
    let sha = crate::cells::file_sha256(cells)?;
    let shown = cells.display().to_string();
    let beside = cells.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let own = cells.file_name().is_some_and(|n| n == "cells.csv")
        && matches!(RunRecord::read(beside), Ok(Some(r)) if r.design_sha256 == file.sha256 && r.cells_sha256.as_deref() == Some(&sha));
    if own {
        let mut record = folder_record(design, plan, beside, (rows, sha))?;
        (record.cells_file.0, record.cells_path) = (shown, cells.to_path_buf());
        return Ok(record);
    }
    Ok(Record { design, cells: rows, cells_path: cells.to_path_buf(), cells_file: (shown, sha), run: None })
}

/// The record of the run folder `dir` of a study of one run, labelled
/// with `design` (a run passes the lock state it opened under).
pub fn read_folder(design: DesignLabel, plan: &Plan, dir: &Path) -> Result<Record, RunError> {
    let shown = dir.display().to_string();
    let Some(run) = RunRecord::read(dir)? else {
        return Err(RunError::BadRunRecord {
            path: dir.join("run.json").display().to_string(),
            dir: shown,
            reason: "it is missing: the folder is not a run's (give its cells.csv to analyse the cells alone)"
                .to_string(),
        });
    };
    if run.design_sha256 != design.sha256 {
        return Err(RunError::OtherDesign { dir: shown, sha256: run.design_sha256 });
    }
    let cells_path = dir.join("cells.csv");
    let cells = read_cells(&cells_path)?;
    let sha = crate::cells::file_sha256(&cells_path)?;
    if let Some(recorded) = run.cells_sha256.as_ref().filter(|r| **r != sha) {
        return Err(RunError::LevelChanged {
            dir: shown,
            reason: format!(
                "cells.csv has sha256 {sha}, but the run recorded {recorded} when it gathered it: it was edited after the run"
            ),
        });
    }
    Ok(with_evidence(design, plan, dir, run, (cells, sha)))
}

/// As [`read_folder`], for the folder's `cells.csv` already read and hashed.
fn folder_record(
    design: DesignLabel,
    plan: &Plan,
    dir: &Path,
    cells: (Vec<crate::cells::Cell>, String),
) -> Result<Record, RunError> {
    let run = RunRecord::read(dir)?.ok_or_else(|| RunError::BadRunRecord {
        path: dir.join("run.json").display().to_string(),
        dir: dir.display().to_string(),
        reason: "it is missing".to_string(),
    })?;
    Ok(with_evidence(design, plan, dir, run, cells))
}

/// The record of a run folder whose run.json is `run` and whose cells are
/// `(cells, sha256)`: the evidence beside them read.
fn with_evidence(
    design: DesignLabel,
    plan: &Plan,
    dir: &Path,
    run: RunRecord,
    (cells, sha): (Vec<crate::cells::Cell>, String),
) -> Record {
    let mut missing = Vec::new();
    let level = read_level(plan, dir, String::new(), &mut missing);
    let evidence = RunEvidence {
        data: run.data.describe(),
        audit_sha256: run.audit_sha256.clone(),
        exploratory: run.exploratory,
        build: run.crossaudit.clone(),
        resumed_from: run.resumed_from.clone(),
        notes: run.notes.clone(),
        levels: vec![level],
        missing,
    };
    let cells_path = dir.join("cells.csv");
    Record { design, cells, cells_path, cells_file: ("cells.csv".to_string(), sha), run: Some(evidence) }
}

/// What one run folder holds beyond its cells; each absent or unreadable
/// file a sentence in `missing`.
pub fn read_level(plan: &Plan, dir: &Path, id: String, missing: &mut Vec<String>) -> LevelEvidence {
    let audit = dir.join("audit");
    let treatment: Option<Treatment> =
        evidence(&audit.join("treatment.json"), "treatment strength and condition coverage", missing);
    let invariants: Option<InvariantsFile> =
        evidence(&audit.join("invariants.json"), "the split's invariants that hold with a warning", missing);
    let warned = invariants.map(|f| f.invariants.into_iter().filter(|i| i.status == "warn").collect());
    LevelEvidence {
        id,
        draw: None,
        treatment,
        warned: warned.unwrap_or_default(),
        unread: unread(&audit.join("recordings.csv"), missing),
        // A family's report draws no training curves.
        curves: if plan.is_family() { Vec::new() } else { curves(plan, dir, missing) },
        sources: sources(plan, dir, missing),
    }
}

/// A JSON file of evidence through its serde type, or a sentence in
/// `missing` saying what the report cannot give without it.
fn evidence<T: DeserializeOwned>(path: &Path, gives: &str, missing: &mut Vec<String>) -> Option<T> {
    let parsed = match crate::io::read_own(path) {
        Ok(bytes) => serde_json::from_slice(&bytes).map_err(|e| format!("is unreadable ({e})")),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err("is absent".to_string()),
        Err(e) => Err(format!("is unreadable ({e})")),
    };
    parsed.map_err(|why| missing.push(format!("{} {why}: {gives} not reported", path.display()))).ok()
}

/// One row of the inclusion audit (`audit/recordings.csv`), the columns
/// that say whether the log could be read.
#[derive(Deserialize)]
struct AuditRow {
    name: String,
    file: String,
    content_hash: String,
    status: String,
    reason: String,
}

/// The sentence naming the logs the audit could not read (`None` when it
/// read every one, or, with a sentence in `missing`, when the audit is
/// absent or unreadable).
fn unread(path: &Path, missing: &mut Vec<String>) -> Option<String> {
    let rows = csv::Reader::from_path(path)
        .and_then(|mut r| r.deserialize::<AuditRow>().collect::<Result<Vec<_>, _>>())
        .map_err(|e| {
            missing.push(format!("{} is unreadable ({e}): logs it could not read not reported", path.display()))
        })
        .ok()?;
    let files: Vec<(String, String)> = rows
        .into_iter()
        .filter(|r| r.status == "excluded" && r.content_hash.is_empty())
        .map(|r| (if r.file.is_empty() { r.name } else { r.file }, r.reason))
        .collect();
    crate::data::unread_sentence(&files)
}

/// The columns of a training curve the analysis reads.
#[derive(Deserialize)]
struct CurvePoint {
    epoch: f64,
    val_loss: f64,
}

/// The validation-loss curve of every fitted job, in file-name order; one
/// sentence in `missing` for those absent or unreadable.
fn curves(plan: &Plan, dir: &Path, missing: &mut Vec<String>) -> Vec<Curve> {
    // External models' training happened elsewhere: no curve.
    let mut jobs: Vec<_> = plan.jobs.iter().filter(|j| j.kind.has_curve()).collect();
    jobs.sort_by_key(|j| j.stem());
    let mut out = Vec::new();
    let mut lost = Vec::new();
    for j in jobs {
        let path = dir.join("curves").join(format!("{}.csv", j.stem()));
        let points = csv::Reader::from_path(&path).and_then(|mut r| {
            r.deserialize::<CurvePoint>().map(|p| p.map(|p| (p.epoch, p.val_loss))).collect::<Result<Vec<_>, _>>()
        });
        match points {
            Ok(points) => out.push(Curve { model: j.model.clone(), arm: j.arm.clone(), seed: j.seed.0, points }),
            Err(e) => lost.push(format!("{} ({e})", path.display())),
        }
    }
    if !lost.is_empty() {
        missing.push(format!(
            "{} training curve(s) absent or unreadable, left out of the training curves figure and of the early-stopping check: {}",
            lost.len(),
            lost.join("; ")
        ));
    }
    out
}

/// Per arm of a distance-dose family: the distinct evaluation recordings
/// its contaminating windows came from, and the evaluation recordings.
fn sources(plan: &Plan, dir: &Path, missing: &mut Vec<String>) -> BTreeMap<String, (usize, usize)> {
    if plan.doses.is_empty() || crate::plan::dose_axis(&plan.doses) != crate::design::DoseAxis::Distance {
        return BTreeMap::new();
    }
    let names = |path: PathBuf| -> Result<Vec<String>, String> {
        let mut r = csv::Reader::from_path(&path).map_err(|e| format!("{} ({e})", path.display()))?;
        r.records()
            .map(|row| row.map(|row| row.get(0).unwrap_or("").to_string()))
            .collect::<Result<_, _>>()
            .map_err(|e| format!("{} ({e})", path.display()))
    };
    let manifests = dir.join("manifests");
    let counted = || -> Result<BTreeMap<String, (usize, usize)>, String> {
        let evaluated = names(manifests.join("evaluation_recordings.csv"))?.len();
        let mut out = BTreeMap::new();
        for d in &plan.doses {
            let drawn: std::collections::BTreeSet<String> =
                names(manifests.join(format!("contaminating_{}.csv", d.arm)))?.into_iter().collect();
            out.insert(d.arm.clone(), (drawn.len(), evaluated));
        }
        Ok(out)
    };
    counted()
        .map_err(|e| {
            missing.push(format!("{e} is absent or unreadable: the sources of each distance's windows not reported"))
        })
        .unwrap_or_default()
}
