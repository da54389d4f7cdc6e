#![doc = include_str!("../ARCHITECTURE.md")]

pub mod analysis;
pub mod cells;
pub mod design;
pub mod pipeline;
pub mod report;
pub mod stats;
pub mod workbench;

use std::path::Path;

pub use analysis::{analyze, Analysis, AnalyzeOptions};
pub use design::Design;
pub use pipeline::{compile, Plan};

/// Any error of the convenience calls, with the file it concerns.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Design(#[from] design::LoadError),
    #[error(transparent)]
    Lock(#[from] design::lock::LockError),
    #[error(transparent)]
    Cells(#[from] cells::CellsError),
    #[error("{path}: {source}")]
    Analysis { path: String, source: Box<analysis::AnalysisError> },
    #[error(transparent)]
    Write(#[from] report::WriteError),
    #[error(transparent)]
    Audit(#[from] data::AuditError),
    #[error("{0}")]
    Usage(String),
    #[error(transparent)]
    Split(#[from] split::SplitError),
    #[error(transparent)]
    Net(#[from] model::NetError),
    #[error("{0}")]
    Cell(String),
    #[error("invariant check failed, nothing will train (see {path}):\n{list}")]
    Invariants { path: String, list: String },
}

/// What `split` produced.
#[derive(Debug, Clone)]
pub struct SplitOutcome {
    /// The included recordings the split indexes into.
    pub recordings: Vec<data::Recording>,
    pub audit: data::Audit,
    pub split: split::Split,
    pub manifests: split::Manifests,
    pub invariants: split::InvariantReport,
    pub treatment: split::TreatmentAudit,
}

/// Audit the data, build the split, write manifests, invariants and the
/// treatment audit under `out`. A failed invariant is an error, returned
/// after `audit/invariants.json` is written so the reason can be read.
pub fn split_stage(
    file: &design::DesignFile,
    dir: &std::path::Path,
    out: &std::path::Path,
) -> Result<SplitOutcome, Error> {
    let design = &file.design;
    let (audit, recordings) = data::audit_and_load(&design.data, dir)?;
    audit.write(&out.join("audit"))?;
    let split = split::build(design, &audit, &recordings)?;
    let manifests = split::Manifests::new(design, Some(file.sha256.clone()), &split);
    split::write_split(out, &manifests)?;
    let plan = pipeline::compile(design);
    let cells = split::CellManifests::for_plan(&plan, &manifests);
    let invariants = split::check_invariants(design, &split, &cells);
    let treatment = split::treatment_audit(&split);
    let audit_dir = out.join("audit");
    let inv_path = audit_dir.join("invariants.json");
    report::write_atomic(&inv_path, invariants.to_json().as_bytes())?;
    report::write_atomic(&audit_dir.join("treatment.json"), treatment.to_json().as_bytes())?;
    if !invariants.all_pass {
        let list = invariants
            .failures()
            .iter()
            .map(|i| format!("  ({}) {}: {}", i.id, i.name, i.detail))
            .collect::<Vec<_>>()
            .join("\n");
        return Err(Error::Invariants { path: inv_path.display().to_string(), list });
    }
    Ok(SplitOutcome { recordings, audit, split, manifests, invariants, treatment })
}

/// The data directory: `--data` if given; for `data simulated`, the
/// simulator's recordings, generated once into `out/simulated_data`; else
/// the design's `path` (relative to the current directory).
pub fn data_dir(
    design: &Design,
    data: Option<std::path::PathBuf>,
    out: &std::path::Path,
) -> Result<std::path::PathBuf, Error> {
    let dir = match (data, &design.data.path, &design.data.simulated) {
        (Some(d), _, _) => d,
        (None, _, Some(sim)) => {
            let dir = out.join("simulated_data");
            let expected = data::simulate::catalogue(sim.recordings);
            let complete = expected.iter().all(|(name, ..)| dir.join(format!("{name}.csv")).exists());
            if !complete {
                data::simulate::simulate(sim, &dir).map_err(|e| {
                    Error::Usage(format!("cannot write simulated recordings to {}: {e}", dir.display()))
                })?;
            }
            dir
        }
        (None, Some(p), None) => std::path::PathBuf::from(p),
        (None, None, None) => {
            return Err(Error::Usage("the design's data block has no `path`; pass --data DIR".into()))
        }
    };
    if !dir.is_dir() {
        return Err(Error::Usage(format!("data directory {} does not exist", dir.display())));
    }
    Ok(dir)
}

/// Loads a design and per-cell CSV and runs the preregistered analysis. A
/// design whose lock no longer matches is analysed but marked exploratory.
pub fn analyze_files(design_path: &Path, cells_path: &Path, options: AnalyzeOptions) -> Result<Analysis, Error> {
    let file = design::load(design_path)?;
    let status = design::lock::status(design_path, &file.sha256)?;
    let cells = cells::read_cells(cells_path)?;
    let mut a = analysis::analyze(&file.design, &cells, options)
        .map_err(|source| Error::Analysis { path: cells_path.display().to_string(), source: Box::new(source) })?;
    a.design_sha256 = Some(file.sha256);
    if let design::LockStatus::LockedChanged { .. } = status {
        a.exploratory = true;
        a.warnings.push("the design changed after it was locked: results are EXPLORATORY".to_string());
    }
    Ok(a)
}
pub mod cell;
pub mod data;
pub mod model;
pub mod rollout;
pub mod run;
pub mod split;
