//! The analysis of a record ([`super::record::Record`]): the crossed
//! analysis of its cells, labelled with the design's lock state, with
//! every statement the run folder's evidence supports (treatment strength,
//! condition coverage, warned invariants, unread logs, early training,
//! resumed builds, the run's notes) computed here, and, for a per-cell
//! file alone, the sections it cannot support named. A run and a
//! reanalysis of its folder both come through [`analyze_study`], so they
//! give the same report.

use std::collections::BTreeMap;

use super::coverage::{condition_coverage, ConditionCoverage, CoverageNote, Uncovered};
use super::family::{analyze_family, DoseSource, FamilyAnalysis};
use super::record::{Curve, LevelEvidence, Record, RunEvidence};
use super::training::{early_training, BestEpoch};
use super::{analyze, Analysis, AnalyzeOptions, FileAnalysisError, StudyAnalysis, TreatmentStrength};
use crate::design::{DoseAxis, ModelKind};
use crate::plan::Plan;

/// The preregistered analysis of a study of one run (a single study or a
/// dose-response family) from its record; errors name the per-cell file.
pub fn analyze_study(
    plan: &Plan,
    record: &Record,
    options: AnalyzeOptions,
) -> Result<StudyAnalysis, FileAnalysisError> {
    let err = |e| FileAnalysisError::new(&record.cells_path, e);
    if plan.is_family() {
        let mut a = analyze_family(plan, &record.cells, options).map_err(err)?;
        label(&mut a, record);
        family_evidence(&mut a, plan, record);
        return Ok(StudyAnalysis::Family(Box::new(a)));
    }
    let mut a = analyze(plan, &record.cells, options).map_err(err)?;
    label(&mut a, record);
    single_evidence(&mut a, plan, record);
    Ok(StudyAnalysis::Single(Box::new(a)))
}

/// What every analysis type carries in its header: the design, the lock
/// state, the cells and the warnings. One labelling routine for all.
pub trait Labelled {
    /// The design hash, the EXPLORATORY flag, the preregistered flag and
    /// the warnings.
    fn header(&mut self) -> (&mut Option<String>, &mut bool, &mut Option<bool>, &mut Vec<String>);
    /// Records the per-cell file and its SHA-256.
    fn cells(&mut self, name: &str, sha256: &str);
    /// Passes the labels on to the analyses it holds (a family's splits).
    fn propagate(&mut self) {}
}

impl Labelled for Analysis {
    fn header(&mut self) -> (&mut Option<String>, &mut bool, &mut Option<bool>, &mut Vec<String>) {
        (&mut self.design_sha256, &mut self.exploratory, &mut self.preregistered, &mut self.warnings)
    }
    fn cells(&mut self, name: &str, sha256: &str) {
        self.record_cells(std::path::Path::new(name), sha256);
    }
}

impl Labelled for FamilyAnalysis {
    fn header(&mut self) -> (&mut Option<String>, &mut bool, &mut Option<bool>, &mut Vec<String>) {
        (&mut self.design_sha256, &mut self.exploratory, &mut self.preregistered, &mut self.warnings)
    }
    fn cells(&mut self, name: &str, sha256: &str) {
        self.record_cells(std::path::Path::new(name), sha256);
    }
    fn propagate(&mut self) {
        let (sha, exploratory, preregistered) = (self.design_sha256.clone(), self.exploratory, self.preregistered);
        for a in self.splits.iter_mut().flat_map(|s| s.detail.iter_mut()) {
            a.design_sha256.clone_from(&sha);
            a.exploratory |= exploratory;
            a.preregistered = preregistered;
        }
    }
}

/// Labels `a` with the record's design: its hash, whether it is
/// preregistered (locked and unchanged, and the cells not from a run
/// labelled EXPLORATORY), and the lock's warning; then the per-cell file.
pub fn label(a: &mut impl Labelled, record: &Record) {
    let design = &record.design;
    let run_exploratory = record.run.as_ref().is_some_and(|r| r.exploratory);
    {
        let (sha, exploratory, preregistered, warnings) = a.header();
        *sha = Some(design.sha256.clone());
        let (changed, locked, warning) = super::lock_labels(&design.path, &design.status);
        *exploratory |= changed || run_exploratory;
        *preregistered = Some(locked && !*exploratory);
        warnings.extend(warning);
    }
    a.propagate();
    a.cells(&record.cells_file.0.clone(), &record.cells_file.1.clone());
}

/// The sentence a per-cell file alone gets in place of the run's evidence.
fn absent(sections: &str) -> String {
    format!(
        "analysed from a per-cell file alone: {sections} come from the run's folder and are not reported; analyse the run folder (`--cells RUN_DIR`) for them"
    )
}

/// A single study's statements from the run folder, in the order its
/// report gives them.
fn single_evidence(a: &mut Analysis, plan: &Plan, record: &Record) {
    let Some(run) = &record.run else {
        a.warnings.push(absent(
            "the data's provenance, treatment strength, condition coverage, the split's invariants and the training curves",
        ));
        return;
    };
    a.record_provenance(&run.data, &run.audit_sha256);
    a.warnings.extend(run.levels.iter().filter_map(|l| l.unread.clone()));
    for l in &run.levels {
        for i in &l.warned {
            a.warnings.push(format!("invariant {} ({}) holds with a warning: {}", i.id, i.name, i.detail));
        }
    }
    a.warnings.extend(resumed(run));
    a.warnings.extend(run.notes.iter().cloned());
    if let [level] = run.levels.as_slice() {
        a.treatment = level.treatment.as_ref().map(|t| strengths(t, plan.rate_hz)).unwrap_or_default();
    }
    a.coverage = statement(plan, &record.cells, &run.levels);
    a.curves = run.curves();
    if let Some(w) = early_training(plan, &best_epochs(plan, &a.curves), &record.cells).and_then(|e| e.warning()) {
        a.warnings.push(w);
    }
    a.warnings.extend(run.missing.iter().cloned());
}

/// A dose-response family's statements from the run folder.
fn family_evidence(a: &mut FamilyAnalysis, plan: &Plan, record: &Record) {
    let Some(run) = &record.run else {
        a.warnings.push(absent("the data's provenance, treatment strength and condition coverage"));
        return;
    };
    a.provenance.data = Some(run.data.clone());
    a.provenance.audit_sha256 = Some(run.audit_sha256.clone());
    a.warnings.extend(run.levels.iter().filter_map(|l| l.unread.clone()));
    a.warnings.extend(run.notes.iter().cloned());
    if let [level] = run.levels.as_slice() {
        a.treatment = level.treatment.as_ref().map(|t| strengths(t, plan.rate_hz)).unwrap_or_default();
    }
    a.coverage = note(plan, &run.levels);
    a.sources = sources(plan, &run.levels);
    a.warnings.extend(resumed(run));
    a.warnings.extend(run.missing.iter().cloned());
}

/// A warning for each build other than the run's that trained cells.
fn resumed(run: &RunEvidence) -> Vec<String> {
    run.resumed_from
        .iter()
        .filter(|b| **b != run.build)
        .map(|b| format!("some cells were trained by crossaudit {b}; this run, which resumed them, is {}", run.build))
        .collect()
}

/// The split's treatment audit as the report shows it.
pub fn strengths(t: &super::record::Treatment, rate_hz: f64) -> Vec<TreatmentStrength> {
    let horizon_s = t.horizon_samples as f64 / rate_hz;
    t.arms
        .iter()
        .map(|a| TreatmentStrength {
            arm: a.arm.clone(),
            contaminating_windows: a.contaminating_windows,
            inside_evaluated_segment: a.inside_evaluated_segment,
            horizon_s,
            median_distance_s: a.median_distance_s,
            segment_distance_quartiles_s: a.segment_distance_quartiles_s,
        })
        .collect()
}

/// The recordings the reference arm leaves uncovered in any level, with
/// the number of levels each is uncovered in; `None` unless every level
/// records its coverage.
fn uncovered(plan: &Plan, levels: &[LevelEvidence]) -> Option<(String, Vec<Uncovered>)> {
    let mut condition = None;
    let mut count: BTreeMap<(String, String), usize> = BTreeMap::new();
    for l in levels {
        let c = l.treatment.as_ref()?.coverage.as_ref()?;
        condition.get_or_insert_with(|| c.condition.clone());
        for r in c.uncovered(&plan.contrast.reference) {
            *count.entry((r.recording.clone(), r.condition.clone())).or_default() += 1;
        }
    }
    let uncovered =
        count.into_iter().map(|((recording, condition), draws)| Uncovered { recording, condition, draws }).collect();
    Some((condition?, uncovered))
}

/// The coverage statement over the levels (one draw each).
pub fn statement(plan: &Plan, cells: &[crate::cells::Cell], levels: &[LevelEvidence]) -> Option<ConditionCoverage> {
    let (condition, out) = uncovered(plan, levels)?;
    Some(condition_coverage(plan, cells, &condition, levels.len(), out))
}

/// The coverage note of a combined report over the levels.
pub fn note(plan: &Plan, levels: &[LevelEvidence]) -> Option<CoverageNote> {
    let (condition, uncovered) = uncovered(plan, levels)?;
    Some(CoverageNote { condition, arm: plan.contrast.reference.clone(), levels: levels.len(), uncovered })
}

/// Per arm of a distance-dose family, the fewest and most evaluation
/// recordings its contaminating windows came from over the levels; empty
/// for any other study or where a level lacks its manifests.
pub fn sources(plan: &Plan, levels: &[LevelEvidence]) -> Vec<DoseSource> {
    if crate::plan::dose_axis(&plan.doses) != DoseAxis::Distance {
        return Vec::new();
    }
    let mut out = Vec::new();
    for d in &plan.doses {
        let counts: Option<Vec<(usize, usize)>> = levels.iter().map(|l| l.sources.get(&d.arm).copied()).collect();
        let Some(counts) = counts else { return Vec::new() };
        let (Some(fewest), Some(most), Some(of)) =
            (counts.iter().map(|c| c.0).min(), counts.iter().map(|c| c.0).max(), counts.iter().map(|c| c.1).min())
        else {
            return Vec::new();
        };
        out.push(DoseSource { arm: d.arm.clone(), fewest, most, of });
    }
    out
}

/// Each early-stopped curve's restored epoch: its best validation epoch. A
/// `restore final` model keeps its last epoch by design and is left out.
pub fn best_epochs(plan: &Plan, curves: &[Curve]) -> Vec<BestEpoch> {
    let last = |model: &str| {
        plan.models.iter().any(|m| m.name == model && matches!(m.kind, ModelKind::Mlp { restore_final: true, .. }))
    };
    curves
        .iter()
        .filter(|c| !last(&c.model))
        .filter_map(|c| {
            let best = c.points.iter().copied().reduce(|a, b| if b.1 < a.1 { b } else { a })?;
            Some(BestEpoch { model: c.model.clone(), arm: c.arm.clone(), seed: c.seed, epoch: best.0 })
        })
        .collect()
}
