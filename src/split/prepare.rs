//! The shared experiment prepared on disk before anything trains: the
//! inclusion audit, the split, its manifests, the invariants and the
//! treatment-strength audit, each written under the output directory.

use std::path::Path;

use super::{check_invariants, treatment_audit, write_split, JobManifests, Manifests, Split, SplitError};
use super::{InvariantReport, TreatmentAudit};
use crate::data::{self, Audit, Recording};
use crate::design::DesignFile;
use crate::io::write_atomic;
use crate::plan::Plan;

/// What [`prepare`] produced: everything a training job reads.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// The included recordings the split indexes into.
    pub recordings: Vec<Recording>,
    /// The inclusion audit of the data directory.
    pub audit: Audit,
    /// Evaluation recordings, starts, validation and fit sets.
    pub split: Split,
    /// The manifests, with their hashes.
    pub manifests: Manifests,
    /// The invariants checked before training.
    pub invariants: InvariantReport,
    /// How strong the treatment is.
    pub treatment: TreatmentAudit,
}

/// Points an error about a name written in the design at its line and column.
fn locate(file: &DesignFile, e: SplitError) -> SplitError {
    let offset = match &e {
        SplitError::NotInUniverse { offset, .. }
        | SplitError::Stratify { offset, .. }
        | SplitError::TooFewAtDistance { offset, .. } => offset,
        _ => return e,
    };
    let before = &file.source[..(*offset).min(file.source.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map(|l| l.chars().count()).unwrap_or(0) + 1;
    let message = e.to_string();
    let message = match message.split_once(" (design byte ") {
        Some((head, tail)) => format!("{head}{}", tail.split_once(')').map(|t| t.1).unwrap_or("")),
        None => message,
    };
    SplitError::Located { path: file.path.display().to_string(), line, column, message }
}

/// Audits the data, builds the split, and writes `audit/`, `manifests/`,
/// `audit/invariants.json` and `audit/treatment.json` under `out`. A failed
/// invariant is an error, returned after `audit/invariants.json` is written
/// so the reason can be read.
///
/// ```
/// use std::path::Path;
/// // A small study on the built-in simulator (its logs are generated into `out`).
/// let file = crossaudit::design::load(Path::new("tests/designs/sim_small.design")).unwrap();
/// let plan = crossaudit::compile(&file.design);
/// let out = tempfile::tempdir().unwrap();
/// let data = crossaudit::run::data_dir(&file.design, &file.path, None, out.path()).unwrap();
/// let p = crossaudit::split::prepare(&file, &plan, &data.dir, out.path()).unwrap();
/// assert!(p.invariants.all_pass);
/// assert_eq!(p.split.evaluation.len(), 4);
/// assert!(out.path().join("manifests/manifests.json").exists());
/// ```
pub fn prepare(file: &DesignFile, plan: &Plan, dir: &Path, out: &Path) -> Result<Prepared, SplitError> {
    prepare_into(file, plan, dir, out, true)
}

/// As [`prepare`], writing nothing: what a job on a cluster node does with
/// a run directory that [`prepare`] already wrote (and that other jobs may
/// be reading). `out` only names where the invariants would be written.
pub fn rebuild(file: &DesignFile, plan: &Plan, dir: &Path, out: &Path) -> Result<Prepared, SplitError> {
    prepare_into(file, plan, dir, out, false)
}

/// Writes what [`prepare`] writes, for a split already built (by
/// [`rebuild`], and found to be the one a run directory records).
pub fn write_prepared(prepared: &Prepared, out: &Path) -> Result<(), SplitError> {
    prepared.audit.write(&out.join("audit"))?;
    write_split(out, &prepared.manifests)?;
    let audit_dir = out.join("audit");
    write_atomic(&audit_dir.join("invariants.json"), prepared.invariants.to_json().as_bytes())?;
    write_atomic(&audit_dir.join("treatment.json"), prepared.treatment.to_json().as_bytes())?;
    Ok(())
}

fn prepare_into(file: &DesignFile, plan: &Plan, dir: &Path, out: &Path, write: bool) -> Result<Prepared, SplitError> {
    let design = &file.design;
    if !design.splits.is_empty() {
        return Err(SplitError::SeveralSplits { splits: design.splits.len() });
    }
    let (audit, recordings) = data::audit_and_load(&design.data, dir)?;
    if write {
        audit.write(&out.join("audit"))?;
    }
    let written = out.join("audit").join("recordings.csv");
    // No log at the top of the data folder, but some below it: the
    // `folders nested` the design forgot, said before any count.
    let nested = design.data.format.as_ref().is_some_and(|f| f.nested_folders);
    if let Some(hint) = (audit.files.is_empty() && !nested)
        .then(|| crate::io::walk::nested_logs_hint(dir, design.data.format.is_some()))
        .flatten()
    {
        let dir = dir.display().to_string();
        return Err(
            data::AuditError::NoneIncluded { dir, files: 0, written: written.display().to_string(), hint }.into()
        );
    }
    audit.kept_enough(&design.data, &written)?;
    // A condition the design stratifies, groups or covers by, unknown for
    // every recording (a conditions table whose speed column has another
    // name): every recording would fall in one group, silently.
    for c in &plan.conditions {
        let (name, value): (&str, fn(&data::FileRow) -> &str) = match c {
            crate::design::Condition::Trajectory => ("trajectory", |f| f.trajectory.as_str()),
            crate::design::Condition::Speed => ("speed", |f| f.speed.as_str()),
        };
        let mut included = audit.included().peekable();
        if included.peek().is_some() && included.all(|f| value(f).is_empty() || value(f) == "unknown") {
            return Err(SplitError::UnknownCondition {
                condition: name.to_string(),
                design: file.path.display().to_string(),
            });
        }
    }
    let split = super::build(design, &audit, &recordings).map_err(|e| locate(file, e))?;
    let manifests = Manifests::new(design, Some(file.sha256.clone()), &split);
    if write {
        write_split(out, &manifests)?;
    }
    let jobs = JobManifests::for_plan(plan, &manifests);
    let invariants = check_invariants(design, &split, &jobs);
    let treatment = treatment_audit(&split, plan.conditions.contains(&crate::design::Condition::Speed));
    let audit_dir = out.join("audit");
    let inv_path = audit_dir.join("invariants.json");
    if write {
        write_atomic(&inv_path, invariants.to_json().as_bytes())?;
        write_atomic(&audit_dir.join("treatment.json"), treatment.to_json().as_bytes())?;
    }
    if !invariants.all_pass {
        let list = invariants
            .failures()
            .iter()
            .map(|i| format!("  ({}) {}: {}", i.id, i.name, i.detail))
            .collect::<Vec<_>>()
            .join("\n");
        return Err(SplitError::Invariants { path: inv_path.display().to_string(), list });
    }
    Ok(Prepared { recordings, audit, split, manifests, invariants, treatment })
}
