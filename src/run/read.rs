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

use super::{RunError, RunRecord, StudyRecord};
use crate::analysis::record::{Curve, DesignLabel, InvariantsFile, LevelEvidence, Record, RunEvidence, Treatment};
use crate::cells::read_cells_hashed;
use crate::plan::study::LevelRole;
use crate::plan::Plan;

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
        return Err(RunError::ran_other(shown, run.design_sha256, &design));
    }
    let cells_path = dir.join("cells.csv");
    let (cells, sha) = read_cells_hashed(&cells_path)?;
    if let Some(recorded) = run.cells_sha256.as_ref().filter(|r| **r != sha) {
        return Err(RunError::LevelChanged {
            dir: shown,
            reason: format!(
                "cells.csv has sha256 {sha}, but the run recorded {recorded} when it gathered it: it was edited after the run"
            ),
        });
    }
    // No recorded hash (taken out of run.json, or a run written before
    // it was recorded): its job records say what cells.csv must be.
    if run.cells_sha256.is_none() && dir.join("jobs").is_dir() {
        super::gathered::check_gathered(plan, dir, &design.sha256)?;
    }
    Ok(with_evidence(design, plan, dir, run, (cells, sha)))
}

/// As [`read_folder`], for the folder's `cells.csv` already read and hashed.
pub(crate) fn folder_record(
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
    let (curves, strength) = (!plan.is_family(), true);
    let here =
        LevelFolder { id: String::new(), draw: None, seed: None, plan, dir: dir.to_path_buf(), curves, strength };
    let level = read_level(&here, &mut missing);
    let evidence = RunEvidence {
        data: run.data.describe(),
        audit_sha256: run.audit_sha256.clone(),
        exploratory: run.exploratory,
        lock: run.lock.clone(),
        build: run.crossaudit.clone(),
        resumed_from: run.resumed_from.clone(),
        notes: run.notes.clone(),
        levels: vec![level],
        missing,
    };
    let cells_path = dir.join("cells.csv");
    Record {
        design,
        cells,
        cells_path,
        cells_file: ("cells.csv".to_string(), sha),
        run: Some(evidence),
        last_line_open: false,
    }
}

/// One level folder of a study of several: its name, draw and seed (under
/// per-seed draws), its plan and where it is.
pub struct LevelFolder<'a> {
    /// The level's folder name (`draw-3`, `split-42`).
    pub id: String,
    /// Its draw, under per-seed draws.
    pub draw: Option<u64>,
    /// Its one training seed, under per-seed draws.
    pub seed: Option<u64>,
    /// The level's own plan.
    pub plan: &'a Plan,
    /// Its folder.
    pub dir: PathBuf,
    /// Whether its training curves are read (a family's report draws none
    /// and checks none).
    pub curves: bool,
    /// Whether the report gives the treatment strength table (a
    /// multiverse's combined report does not).
    pub strength: bool,
}

impl<'a> LevelFolder<'a> {
    /// The levels of `outer` as folders of `dir` (a level sharing
    /// another's run, that one's folder).
    pub fn of(outer: &'a crate::plan::study::Outer, dir: &Path) -> Vec<LevelFolder<'a>> {
        let levels = &outer.levels;
        let family = outer.role == LevelRole::Redraw;
        (0..levels.len())
            .map(|k| LevelFolder::at(&levels[k], dir.join(&levels[levels[k].shares.unwrap_or(k)].id)))
            .map(|l| LevelFolder { curves: l.curves && !family, ..l })
            .collect()
    }

    /// The level `l` in the folder `dir`.
    pub fn at(l: &'a crate::plan::study::Level, dir: PathBuf) -> LevelFolder<'a> {
        let seed = if l.draw.is_some() { l.design.seeds.first().map(|s| s.0) } else { None };
        LevelFolder {
            id: l.id.clone(),
            draw: l.draw,
            seed,
            plan: &l.plan,
            dir,
            curves: !l.plan.is_family(),
            strength: true,
        }
    }
}

/// The record of the folder `dir` of a study of several level folders
/// (`draws per seed`, or a family of whole splits): its combined
/// `cells.csv`, verified against its `study.json`, and each level's
/// evidence from its own folder.
pub fn read_levels(design: DesignLabel, dir: &Path, levels: &[LevelFolder]) -> Result<Record, RunError> {
    let cells_path = dir.join("cells.csv");
    let (cells, sha) = read_cells_hashed(&cells_path)?;
    levels_record(design, dir, levels, (cells, sha))
}

/// As [`read_levels`], for the combined `cells.csv` already read and hashed.
pub(crate) fn levels_record(
    design: DesignLabel,
    dir: &Path,
    levels: &[LevelFolder],
    (cells, sha): (Vec<crate::cells::Cell>, String),
) -> Result<Record, RunError> {
    let shown = dir.display().to_string();
    let mut missing = Vec::new();
    let study = StudyRecord::read(dir)?;
    match &study {
        Some(s) if s.design_sha256 != design.sha256 => {
            return Err(RunError::ran_other(shown, s.design_sha256.clone(), &design))
        }
        Some(s) if s.cells_sha256 != sha => {
            return Err(RunError::LevelChanged {
                dir: shown,
                reason: format!(
                    "cells.csv has sha256 {sha}, but the run recorded {} in study.json when it combined its levels: it was edited after the run",
                    s.cells_sha256
                ),
            })
        }
        Some(_) => {}
        None => missing.push(format!(
            "{} is absent (a folder written before it was recorded): the run's notes (jobs reused or copied, external models) not reported, and cells.csv not verified against the run",
            dir.join("study.json").display()
        )),
    }
    let mut runs = Vec::new();
    for l in levels {
        match RunRecord::read(&l.dir)? {
            Some(r) if r.design_sha256 != design.sha256 => {
                return Err(RunError::ran_other(l.dir.display().to_string(), r.design_sha256, &design))
            }
            // A folder holding another level's run (folders swapped or
            // renamed) would credit its evidence to the wrong level.
            // (A level nested in a specification records `spec-s1/draw-1`.)
            Some(r)
                if r.level
                    .as_deref()
                    .is_some_and(|was| was.rsplit('/').next() != l.dir.file_name().and_then(|n| n.to_str())) =>
            {
                let is = l.dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
                return Err(RunError::WrongLevel {
                    dir: l.dir.display().to_string(),
                    was: r.level.unwrap_or_default(),
                    is,
                });
            }
            Some(r) => runs.push(r),
            None => missing.push(format!(
                "{} is absent: the level's data provenance, exploratory label and resumed builds not reported",
                l.dir.join("run.json").display()
            )),
        }
    }
    let levels = read_each(levels, &mut missing);
    let evidence = RunEvidence { levels, ..levels_evidence(&runs, study.as_ref(), missing) };
    Ok(Record {
        design,
        cells,
        cells_path: dir.join("cells.csv"),
        cells_file: ("cells.csv".to_string(), sha),
        run: Some(evidence),
        last_line_open: false,
    })
}

/// What the run.json of each level (`runs`) and the study's `study.json`
/// say of a study of several level folders: the data and audit of the
/// first level, EXPLORATORY when any level is, the build that combined
/// them, every level's resumed builds, the run's notes; no level's
/// evidence yet (`levels` empty), and what is `missing`.
pub(crate) fn levels_evidence(runs: &[RunRecord], study: Option<&StudyRecord>, missing: Vec<String>) -> RunEvidence {
    let first = runs.first();
    RunEvidence {
        data: first.map(|r| r.data.describe()).unwrap_or_default(),
        audit_sha256: first.map(|r| r.audit_sha256.clone()).unwrap_or_default(),
        exploratory: runs.iter().any(|r| r.exploratory),
        lock: runs.iter().filter_map(|r| r.lock.clone()).min_by_key(|l| l.rank()),
        build: study.map(|s| s.crossaudit.clone()).or_else(|| first.map(|r| r.crossaudit.clone())).unwrap_or_default(),
        resumed_from: runs.iter().flat_map(|r| r.resumed_from.iter().cloned()).collect(),
        notes: study.map(|s| s.notes.clone()).unwrap_or_default(),
        levels: Vec::new(),
        missing,
    }
}

/// Every level's evidence, in order; what the levels lack is said once
/// for all the levels that lack it ([`said_once`]).
pub fn read_each(levels: &[LevelFolder], missing: &mut Vec<String>) -> Vec<LevelEvidence> {
    let mut each = Vec::new();
    let read = levels
        .iter()
        .map(|l| {
            let mut lacks = Vec::new();
            let evidence = read_level(l, &mut lacks);
            each.push((l, lacks));
            evidence
        })
        .collect();
    missing.extend(said_once(&each));
    read
}

/// The sentences of `each` level (what it lacks), each said once: a
/// sentence that several levels share but for their folder's name is
/// said once with `LEVEL` in place of the name, and the levels it holds for.
fn said_once(each: &[(&LevelFolder, Vec<String>)]) -> Vec<String> {
    let mut order: Vec<String> = Vec::new();
    let mut by: BTreeMap<String, Vec<&str>> = BTreeMap::new();
    for (l, lacks) in each {
        let name = l.dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let shown = l.dir.display().to_string();
        let generic = shown.strip_suffix(&name).map(|parent| format!("{parent}LEVEL")).unwrap_or_else(|| shown.clone());
        for s in lacks {
            let key = if name.is_empty() { s.clone() } else { s.replace(&shown, &generic) };
            if !by.contains_key(&key) {
                order.push(key.clone());
            }
            by.entry(key).or_default().push(&l.id);
        }
    }
    order
        .into_iter()
        .map(|key| {
            let ids = &by[&key];
            match ids.as_slice() {
                [one] => key.replace("LEVEL", one),
                _ if ids.len() == each.len() => format!("in all {} level folders: {key}", ids.len()),
                _ => format!("in {} of {} level folders ({}): {key}", ids.len(), each.len(), ids.join(", ")),
            }
        })
        .collect()
}

/// What one run folder holds beyond its cells; each absent or unreadable
/// file a sentence in `missing`.
pub fn read_level(level: &LevelFolder, missing: &mut Vec<String>) -> LevelEvidence {
    let (plan, dir) = (level.plan, level.dir.as_path());
    let audit = dir.join("audit");
    // What the run recorded of its evidence as it wrote it (an unreadable
    // run.json is the caller's to refuse; here it verifies nothing).
    let run = RunRecord::read(dir).ok().flatten();
    let recorded = |name: &str| run.as_ref().and_then(|r| r.evidence_sha256.get(name).cloned());
    let treatment: Option<Treatment> = evidence(
        &audit.join("treatment.json"),
        recorded("audit/treatment.json"),
        "treatment strength and condition coverage",
        missing,
    );
    // What an older build's treatment audit lacks (every build since
    // writes both).
    let lacks = |t: &Treatment| {
        let quartiles = level.strength && t.arms.iter().any(|a| a.segment_distance_quartiles_s.is_none());
        match (quartiles, t.coverage.is_none()) {
            (true, true) => Some("the distance quartiles and the condition coverage: the treatment strength table gives the quartiles as not recorded, and the coverage of the evaluation conditions by each arm is not reported"),
            (true, false) => Some("the distance quartiles: the treatment strength table gives them as not recorded"),
            (false, true) => Some("the condition coverage: the coverage of the evaluation conditions by each arm is not reported"),
            (false, false) => None,
        }
    };
    if let Some(what) = treatment.as_ref().and_then(lacks) {
        missing
            .push(format!("{} was written by an older build, without {what}", audit.join("treatment.json").display()));
    }
    let invariants: Option<InvariantsFile> = evidence(
        &audit.join("invariants.json"),
        recorded("audit/invariants.json"),
        "the split's invariants that hold with a warning",
        missing,
    );
    let warned = invariants.map(|f| f.invariants.into_iter().filter(|i| i.status == "warn").collect());
    let (unread, inclusion) =
        unread(&audit.join("recordings.csv"), run.as_ref().map(|r| r.audit_sha256.clone()), missing);
    LevelEvidence {
        id: level.id.clone(),
        draw: level.draw,
        seed: level.seed,
        treatment,
        warned: warned.unwrap_or_default(),
        unread,
        inclusion,
        // A family's report draws no training curves.
        curves: if level.curves { curves(plan, dir, missing) } else { Vec::new() },
        sources: sources(plan, dir, missing),
    }
}

/// A JSON file of evidence through its serde type, or a sentence in
/// `missing` saying what the report cannot give without it: absent,
/// unreadable, or not the bytes the run `recorded` ([`edited`]).
fn evidence<T: DeserializeOwned>(
    path: &Path,
    recorded: Option<String>,
    gives: &str,
    missing: &mut Vec<String>,
) -> Option<T> {
    let parsed = match crate::io::read_own(path) {
        Ok(bytes) => match edited(&bytes, recorded) {
            Some(why) => Err(why),
            None => serde_json::from_slice(&bytes).map_err(|e| format!("is unreadable ({e})")),
        },
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

/// Why a file of evidence is not the one the run wrote: its SHA-256 is
/// not the one the run `recorded` when it wrote it (`None` where it is,
/// or where the run recorded none).
fn edited(bytes: &[u8], recorded: Option<String>) -> Option<String> {
    let now = crate::io::sha256_hex(bytes);
    recorded
        .filter(|want| *want != now)
        .map(|want| format!("was edited after the run (sha256 {now}, but run.json recorded {want})"))
}

/// The sentence naming the logs the audit could not read (`None` when it
/// read every one), and its rows counted by status; both `None`, with a
/// sentence in `missing`, when the audit is absent, unreadable or not the
/// one the run `recorded`.
fn unread(
    path: &Path,
    recorded: Option<String>,
    missing: &mut Vec<String>,
) -> (Option<String>, Option<crate::analysis::record::Inclusion>) {
    let read = crate::io::read_own(path).map_err(|e| format!("is unreadable ({e})")).and_then(|bytes| {
        if let Some(why) = edited(&bytes, recorded) {
            return Err(why);
        }
        let mut r = csv::Reader::from_reader(bytes.as_slice());
        r.deserialize::<AuditRow>().collect::<Result<Vec<_>, _>>().map_err(|e| format!("is unreadable ({e})"))
    });
    let rows = match read {
        Ok(rows) => rows,
        Err(why) => {
            missing.push(format!("{} {why}: logs it could not read not reported", path.display()));
            return (None, None);
        }
    };
    let count = |status: &str| rows.iter().filter(|r| r.status == status).count();
    let inclusion = crate::analysis::record::Inclusion {
        listed: rows.len(),
        included: count("included"),
        excluded: count("excluded"),
        missing: count("missing"),
    };
    let files: Vec<(String, String)> = rows
        .into_iter()
        .filter(|r| r.status == "excluded" && r.content_hash.is_empty())
        .map(|r| (if r.file.is_empty() { r.name } else { r.file }, r.reason))
        .collect();
    (crate::data::unread_sentence(&files), Some(inclusion))
}

/// The columns of a training curve the analysis reads.
#[derive(Deserialize)]
struct CurvePoint {
    epoch: f64,
    val_loss: f64,
}

/// The validation-loss curve of every fitted job, in file-name order; one
/// sentence in `missing` for those absent, unreadable, or not as the run
/// wrote them ([`curve`]).
fn curves(plan: &Plan, dir: &Path, missing: &mut Vec<String>) -> Vec<Curve> {
    // External models' training happened elsewhere: no curve.
    let mut jobs: Vec<_> = plan.jobs.iter().filter(|j| j.kind.has_curve()).collect();
    jobs.sort_by_key(|j| j.stem());
    let mut out = Vec::new();
    let mut lost = Vec::new();
    for j in jobs {
        let path = dir.join("curves").join(format!("{}.csv", j.stem()));
        match curve(dir, j, &path) {
            Ok(points) => out.push(Curve { model: j.model.clone(), arm: j.arm.clone(), seed: j.seed.0, points }),
            Err(e) => lost.push(format!("{} ({e})", path.display())),
        }
    }
    if !lost.is_empty() {
        let more = if lost.len() > 3 { format!("; and {} more", lost.len() - 3) } else { String::new() };
        missing.push(format!(
            "{} training curve(s) absent or unreadable, left out of the training curves figure and of the early-stopping check: {}{more}",
            lost.len(),
            lost[..lost.len().min(3)].join("; ")
        ));
    }
    out
}

/// The (epoch, validation loss) points of `job`'s curve at `path`, or
/// why it is left out: unreadable; not the bytes its job record (where
/// the folder keeps one) says the job wrote, so edited after the run; or
/// not a curve as a run writes one, its epochs 1, 2, 3, ... in order (an
/// edited epoch would move the early-stopping check's best epochs and
/// the figure's axis).
fn curve(dir: &Path, job: &crate::plan::TrainingJob, path: &Path) -> Result<Vec<(f64, f64)>, String> {
    let bytes = crate::io::read_own(path).map_err(|e| e.to_string())?;
    let name = format!("curves/{}.csv", job.stem());
    if let Some(record) = super::record::JobRecord::read(dir, job).map_err(|e| e.to_string())? {
        let now = crate::io::sha256_hex(&bytes);
        match record.files.get(&name) {
            Some(sha) if *sha == now => {}
            Some(sha) => {
                return Err(format!("sha256 {now}, but jobs/{}.json recorded {sha}: edited after the run", job.stem()))
            }
            None => return Err(format!("jobs/{}.json does not list it", job.stem())),
        }
    }
    let mut points = Vec::new();
    for (k, p) in csv::Reader::from_reader(bytes.as_slice()).deserialize::<CurvePoint>().enumerate() {
        let p = p.map_err(|e| e.to_string())?;
        if p.epoch != (k + 1) as f64 {
            return Err(format!("line {}: epoch {} where a run writes epoch {}", k + 2, p.epoch, k + 1));
        }
        points.push((p.epoch, p.val_loss));
    }
    Ok(points)
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
