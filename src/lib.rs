#![doc = include_str!("../ARCHITECTURE.md")]
#![warn(missing_docs)]

pub mod analysis;
pub mod cells;
pub mod data;
pub mod design;
mod error;
pub mod io;
pub mod label;
pub mod methods;
pub mod model;
pub mod plan;
pub mod published;
pub mod report;
pub mod rollout;
pub mod run;
pub mod sim;
pub mod split;
pub mod split_audit;
pub use crossaudit_stats as stats;

use std::path::Path;

/// This build ([`io::BUILD`]), re-exported for front ends.
pub use io::BUILD;

pub use analysis::{analyze, Analysis, AnalyzeOptions};
pub use design::{Design, DesignFile};
pub use error::Error;
pub use plan::{compile, compile_study, Plan, StudyPlan};

/// Loads a design and a per-cell CSV and runs the preregistered analysis:
/// [`design::load`], [`plan::compile_study`], [`cells::read_cells`] and
/// [`analysis::analyze`] in one call. A design whose lock no longer matches
/// is analysed but marked exploratory.
///
/// ```
/// use std::path::Path;
/// let a = crossaudit::analyze_files(
///     Path::new("designs/nanobench_confirmatory.design"),
///     Path::new("examples/cells/nanobench_synthetic.csv"),
///     Default::default(),
/// )
/// .unwrap();
/// assert_eq!(a.units.len(), 6);
/// ```
pub fn analyze_files(design_path: &Path, cells_path: &Path, options: AnalyzeOptions) -> Result<Analysis, Error> {
    let file = design::load(design_path)?;
    let study = compile_study(&file.design);
    analyze_with(&file, &study.plan, cells_path, options)
}

/// As [`analyze_files`], for a design already loaded and compiled: the
/// per-cell file read as a record ([`run::read_record`]: with its run
/// folder's evidence when it is a run's own `cells.csv`) and analysed by
/// [`analysis::analyze_study`].
pub fn analyze_with(
    file: &DesignFile,
    plan: &Plan,
    cells_path: &Path,
    options: AnalyzeOptions,
) -> Result<Analysis, Error> {
    let record = run::read_record(file, &compile_study(&file.design), cells_path)?;
    match analysis::analyze_study(plan, &record, options)? {
        analysis::StudyAnalysis::Single(a) => Ok(*a),
        _ => {
            let message = "the design has several splits or doses: analyse it with analyze_family_with".to_string();
            Err(analysis::FileAnalysisError::new(cells_path, analysis::AnalysisError::Family { message }).into())
        }
    }
}

/// Any study's preregistered analysis, as `crossaudit analyze` makes it:
/// a single study's or a dose-response or multi-split family's from the
/// per-cell file `cells`, or, for a multiverse or draw-replicated design,
/// the combined analysis of the run directory `cells`. Write it with
/// [`report::write_study`]; its decision line is
/// [`report::study_decision_line`].
///
/// ```
/// use std::path::Path;
/// let file = crossaudit::design::load(Path::new("designs/nanobench_confirmatory.design")).unwrap();
/// let study = crossaudit::compile_study(&file.design);
/// let cells = Path::new("examples/cells/nanobench_synthetic.csv");
/// let a = crossaudit::analyze_study(&file, &study, cells, Default::default()).unwrap();
/// assert_eq!(a.kind(), "single");
/// assert!(crossaudit::report::study_decision_line(&a).starts_with("decision: "));
/// ```
pub fn analyze_study(
    file: &DesignFile,
    study: &StudyPlan,
    cells: &Path,
    options: AnalyzeOptions,
) -> Result<analysis::StudyAnalysis, Error> {
    if study.combines_levels() {
        let a = run::outer::analyze_dir(file, study, cells)?;
        return Ok(analysis::StudyAnalysis::Multiverse(Box::new(a)));
    }
    let record = run::read_record(file, study, cells)?;
    Ok(analysis::analyze_study(&study.plan, &record, options)?)
}

/// The analysis of a dose-response or multi-split design's per-cell file
/// (with its `split` and `dose` columns), labelled with the design's hash
/// and lock state.
///
/// ```
/// use std::path::Path;
/// let a = crossaudit::analyze_family_files(
///     Path::new("designs/nanobench_dose_response.design"),
///     Path::new("results/dose_response/cells.csv"),
///     Default::default(),
/// )
/// .unwrap();
/// assert_eq!(a.doses.len(), 5);
/// assert!(a.splits[0].trend.is_some());
/// ```
pub fn analyze_family_files(
    design_path: &Path,
    cells_path: &Path,
    options: AnalyzeOptions,
) -> Result<analysis::family::FamilyAnalysis, Error> {
    let file = design::load(design_path)?;
    let study = compile_study(&file.design);
    analyze_family_with(&file, &study.plan, cells_path, options)
}

/// As [`analyze_family_files`], for a design already loaded and compiled.
pub fn analyze_family_with(
    file: &DesignFile,
    plan: &Plan,
    cells_path: &Path,
    options: AnalyzeOptions,
) -> Result<analysis::family::FamilyAnalysis, Error> {
    let record = run::read_record(file, &compile_study(&file.design), cells_path)?;
    match analysis::analyze_study(plan, &record, options)? {
        analysis::StudyAnalysis::Family(a) => Ok(*a),
        _ => {
            let message = "the design has one split and one dose: analyse it with analyze_with".to_string();
            Err(analysis::FileAnalysisError::new(cells_path, analysis::AnalysisError::Family { message }).into())
        }
    }
}
