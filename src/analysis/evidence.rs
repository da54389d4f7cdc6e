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
use super::multiverse::{analyze_multiverse, LevelInput, MultiverseAnalysis, ReferenceCopies, UnitNotes};
use super::record::{Curve, DesignLabel, InvariantEntry, LevelEvidence, MultiverseRecord, Record, RunEvidence};
use super::training::{budget_training, early_training, BestEpoch};
use super::{analyze, Analysis, AnalyzeOptions, FileAnalysisError, StudyAnalysis, TreatmentStrength};
use crate::design::DoseAxis;
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
        a.guards = super::family::guards(&a);
        return Ok(StudyAnalysis::Family(Box::new(a)));
    }
    let mut a = analyze(plan, &record.cells, options).map_err(err)?;
    label(&mut a, record);
    single_evidence(&mut a, plan, record);
    a.guards = super::guards::guards(&a);
    Ok(StudyAnalysis::Single(Box::new(a)))
}

/// What every analysis type carries in its header: the design, the lock
/// state, the cells and the warnings. One labelling routine for all.
pub trait Labelled {
    /// The header (design hash, preregistration standing) and the warnings.
    fn header(&mut self) -> (&mut super::AnalysisHeader, &mut Vec<String>);
    /// Records the per-cell file and its SHA-256.
    fn cells(&mut self, name: &str, sha256: &str);
    /// Passes the labels on to the analyses it holds (a family's splits).
    fn propagate(&mut self) {}
}

impl Labelled for Analysis {
    fn header(&mut self) -> (&mut super::AnalysisHeader, &mut Vec<String>) {
        (&mut self.header, &mut self.warnings)
    }
    fn cells(&mut self, name: &str, sha256: &str) {
        self.provenance.cells = Some((name.to_string(), sha256.to_string()));
    }
}

impl Labelled for FamilyAnalysis {
    fn header(&mut self) -> (&mut super::AnalysisHeader, &mut Vec<String>) {
        (&mut self.header, &mut self.warnings)
    }
    fn cells(&mut self, name: &str, sha256: &str) {
        self.provenance.cells = Some((name.to_string(), sha256.to_string()));
    }
    fn propagate(&mut self) {
        for a in self.splits.iter_mut().flat_map(|s| s.detail.iter_mut()) {
            a.header.clone_from(&self.header);
        }
    }
}

/// Labels `a` with the record's design: its hash, whether it is
/// preregistered (locked and unchanged, and the cells not from a run
/// labelled EXPLORATORY), and the lock's warning; then the per-cell file.
pub fn label(a: &mut impl Labelled, record: &Record) {
    let run_exploratory = record.run.as_ref().is_some_and(|r| r.exploratory);
    let began = record.run.as_ref().and_then(|r| r.lock.as_ref());
    label_design(a, &record.design, (run_exploratory, began));
    a.cells(&record.cells_file.0.clone(), &record.cells_file.1.clone());
}

/// Labels `a` with `design`: its hash, its standing
/// ([`super::Standing::of_run`] its lock state, post hoc mark, the run's
/// label and the lock state the run `began` under) and the warnings they
/// give (a standing that is not the preregistered one, the lock's
/// amendments).
fn label_design(
    a: &mut impl Labelled,
    design: &DesignLabel,
    (run_exploratory, began): (bool, Option<&crate::design::LockStatus>),
) {
    {
        let (header, warnings) = a.header();
        header.design_sha256 = Some(design.sha256.clone());
        header.standing = super::Standing::of_run(&design.status, began, run_exploratory);
        warnings.extend(header.standing.warning(&design.path));
        warnings.extend(design.status.amendment_warnings());
    }
    a.propagate();
}

impl Labelled for MultiverseAnalysis {
    fn header(&mut self) -> (&mut super::AnalysisHeader, &mut Vec<String>) {
        (&mut self.header, &mut self.warnings)
    }
    fn cells(&mut self, _name: &str, _sha256: &str) {}
    fn propagate(&mut self) {
        for (_, a) in &mut self.levels {
            a.header.clone_from(&self.header);
        }
    }
}

/// The combined analysis of a multiverse or draw-replicated run from its
/// record: `inputs` are its units (their plans, and their cells from
/// `record`), labelled with the design, with each unit's notes from its
/// level folders, the splits the specifications share, and the run's
/// warnings; a unit that shares another's run says so in its own analysis.
pub fn analyze_multiverse_record(
    design: &crate::design::Design,
    inputs: &[LevelInput],
    record: &MultiverseRecord,
) -> Result<MultiverseAnalysis, FileAnalysisError> {
    let mut a = analyze_multiverse(design, inputs).map_err(|e| FileAnalysisError::new(&record.dir, e))?;
    label_design(&mut a, &record.design, (record.run.exploratory, record.run.lock.as_ref()));
    for (k, u) in inputs.iter().enumerate() {
        if let (Some(s), Some((_, level))) = (&u.shares, a.levels.get_mut(k)) {
            level.warnings.push(format!("trained nothing: its cells are those of {s} (only the analysis differs)"));
        }
    }
    a.notes =
        inputs.iter().zip(&record.units).map(|(u, (cells, levels))| unit_notes(&u.id, u.plan, levels, cells)).collect();
    a.shared = record.shared.clone();
    a.guards = super::multiverse::guards(&a);
    super::multiverse::attach_unit_guards(&mut a);
    let run = &record.run;
    let mut warnings: Vec<String> = resumed(run).into_iter().chain(run.notes.iter().cloned()).collect();
    warnings.extend(run.missing.iter().cloned());
    let mut seen: std::collections::BTreeSet<String> = a.warnings.iter().cloned().collect();
    a.warnings.extend(warnings.into_iter().filter(|w| seen.insert(w.clone())));
    Ok(a)
}

/// The notes on one unit of a multiverse (a specification, or a draw)
/// from its level folders: its reference arm's coverage and copies of
/// evaluation recordings, and its training.
fn unit_notes(id: &str, plan: &Plan, levels: &[LevelEvidence], cells: &[crate::cells::Cell]) -> UnitNotes {
    let copies: Vec<usize> = levels
        .iter()
        .filter_map(|l| l.warned.iter().find(|i| i.id == 5).map(InvariantEntry::from_evaluation))
        .collect();
    let reference_copies = match (copies.iter().min(), copies.iter().max()) {
        (Some(&fewest), Some(&most)) => {
            Some(ReferenceCopies { fewest, most, levels_with: copies.len(), levels: levels.len() })
        }
        _ => None,
    };
    let curves: Vec<Curve> = levels.iter().flat_map(|l| l.curves.iter().cloned()).collect();
    let best = best_epochs(plan, &curves);
    UnitNotes {
        id: id.to_string(),
        coverage: note(plan, levels),
        reference_copies,
        early: if best.is_empty() { None } else { early_training(plan, &best, cells) },
    }
}

/// The warning (and, worded by the guards, the guard) where the run's
/// folders record no condition coverage: which folders lack it. Every
/// run writes it (`audit/treatment.json`); a folder without it lost the
/// file, or an edit made it unreadable, or an older build wrote it.
pub(crate) fn coverage_unknown(levels: &[LevelEvidence]) -> String {
    let lacking: Vec<&str> = levels
        .iter()
        .filter(|l| l.treatment.as_ref().and_then(|t| t.coverage.as_ref()).is_none())
        .map(|l| l.id.as_str())
        .collect();
    let which = match (levels.len(), lacking.as_slice()) {
        (1, _) | (_, []) => "the run folder records no".to_string(),
        (n, ids) if ids.len() == n => format!("none of the {n} level folders records"),
        (n, ids) => format!("{} of the {n} level folders ({}) record no", ids.len(), ids.join(", ")),
    };
    format!(
        "{}{which} condition coverage (its treatment audit absent, unreadable, edited, or written by an older build: the warning above naming the file says which), so whether the reference arm fits on other recordings of every evaluated condition, and so whether the contrast also measured unseen conditions, is not known",
        super::guards::COVERAGE_UNKNOWN
    )
}

/// The sentence a per-cell file alone gets in place of the run's evidence.
fn absent(sections: &str) -> String {
    format!(
        "analysed from a per-cell file alone: {sections} come from the run's folder and are not reported; analyse the run folder (`--cells RUN_DIR`) for them"
    )
}

/// The warning for a per-cell file alone whose last line ends without a
/// line break: a file cut short while it was written ends so, and its last
/// value may be cut with it (`0.123` read as `0.1`), which no check of the
/// values can see; a run's recorded hash would, a file alone has none.
fn open_end(record: &Record) -> Option<String> {
    let last = record.cells.last().filter(|_| record.last_line_open)?;
    let value = last.attitude_rmse_deg.map_or_else(|| "empty".to_string(), |v| v.to_string());
    Some(format!(
        "{}: its last line ({}) ends without a line break, as a file cut short while it was written does; if it was cut, its last value (`attitude_rmse_deg`, read as {value}) may be cut too (every per-cell file crossaudit writes ends with a line break)",
        record.cells_file.0,
        last.origin.number()
    ))
}

/// A single study's statements from the run folder (or, under per-seed
/// draws, its level folders), in the order its report gives them.
fn single_evidence(a: &mut Analysis, plan: &Plan, record: &Record) {
    let Some(run) = &record.run else {
        a.warnings.push(absent(
            "the data's provenance, treatment strength, condition coverage, the split's invariants and the training curves",
        ));
        a.warnings.extend(open_end(record));
        return;
    };
    a.treatment = provenance_and_warnings(&mut a.provenance, &mut a.warnings, plan, run);
    a.coverage = statement(plan, &record.cells, &run.levels);
    a.curves = run.curves();
    let best = best_epochs(plan, &a.curves);
    if let Some(w) = early_training(plan, &best, &record.cells).and_then(|e| e.warning()) {
        a.warnings.push(w);
    }
    a.warnings.extend(budget_training(plan, &best));
    a.warnings.extend(run.missing.iter().cloned());
    if a.coverage.is_none() {
        a.warnings.push(coverage_unknown(&run.levels));
    }
}

/// A dose-response family's statements from the run folder (or its
/// level folders: whole splits, or per-seed draws).
fn family_evidence(a: &mut FamilyAnalysis, plan: &Plan, record: &Record) {
    let Some(run) = &record.run else {
        a.warnings.push(absent("the data's provenance, treatment strength and condition coverage"));
        a.warnings.extend(open_end(record));
        return;
    };
    a.treatment = provenance_and_warnings(&mut a.provenance, &mut a.warnings, plan, run);
    a.coverage = note(plan, &run.levels);
    a.sources = sources(plan, &run.levels);
    a.warnings.extend(run.missing.iter().cloned());
    if a.coverage.is_none() {
        a.warnings.push(coverage_unknown(&run.levels));
    }
    member_coverage(a, plan, record, &run.levels);
}

/// Each contrast of a family (a split's, a dose's) with its own condition
/// coverage statement, over its split's level folder (or every level),
/// and the guards its report gives beside its descriptive line.
fn member_coverage(a: &mut FamilyAnalysis, plan: &Plan, record: &Record, levels: &[LevelEvidence]) {
    let doses = a.doses.clone();
    for sp in a.splits.iter_mut() {
        let own: Vec<LevelEvidence> = match sp.split {
            Some(s) => levels.iter().filter(|l| l.id == crate::plan::split_dir(s)).cloned().collect(),
            None => levels.to_vec(),
        };
        for (dose, detail) in doses.iter().zip(sp.detail.iter_mut()) {
            let (p, cells) = super::family::member(plan, sp.split, dose, &record.cells);
            detail.coverage = statement(&p, &cells, &own);
            if detail.coverage.is_none() && !own.is_empty() {
                detail.warnings.push(coverage_unknown(&own));
            }
            detail.guards = super::guards::guards(detail);
        }
    }
}

/// What every study of a run folder states first: the data's provenance,
/// the run's warnings ([`run_warnings`]) and each arm's treatment strength
/// (returned, its note among the warnings).
fn provenance_and_warnings(
    provenance: &mut super::Provenance,
    warnings: &mut Vec<String>,
    plan: &Plan,
    run: &RunEvidence,
) -> Vec<TreatmentStrength> {
    provenance.data = Some(run.data.clone());
    provenance.audit_sha256 = Some(run.audit_sha256.clone());
    // Every level reads the same logs under the same rules: the first's.
    provenance.inclusion = run.levels.first().and_then(|l| l.inclusion);
    let mut said = run_warnings(plan, run);
    let strengths = treatment(plan, &run.levels, &mut said);
    warnings.extend(said);
    strengths
}

/// The run's warnings, in report order, each once: what its level folders
/// are, the logs it could not read, the split's invariants that hold with
/// a warning, the builds that resumed it, and the run's own notes.
fn run_warnings(plan: &Plan, run: &RunEvidence) -> Vec<String> {
    let mut out = Vec::new();
    let outer = run.levels.len() > 1 || run.levels.iter().any(|l| !l.id.is_empty());
    if outer {
        out.push(levels_note(plan, &run.levels));
    }
    out.extend(run.levels.iter().filter_map(|l| l.unread.clone()));
    if outer {
        out.extend(invariants_over_levels(&run.levels));
    } else {
        for i in run.levels.iter().flat_map(|l| &l.warned) {
            out.push(warned_invariant(i.id, &i.name, &i.detail));
        }
    }
    out.extend(resumed(run));
    out.extend(run.notes.iter().cloned());
    let mut seen = std::collections::BTreeSet::new();
    out.retain(|w| seen.insert(w.clone()));
    out
}

/// An invariant the split met only with a warning (a duplicate the
/// design's `duplicates keep` allows, identical evaluation recordings), as
/// a run's warnings and `check` say it.
pub fn warned_invariant(id: impl std::fmt::Display, name: &str, detail: &str) -> String {
    format!("invariant {id} ({name}) is not met in full, which the design allows (a warning): {detail}")
}

/// What the level folders of a study of several are.
fn levels_note(plan: &Plan, levels: &[LevelEvidence]) -> String {
    if !plan.splits.is_empty() {
        return "each split's audit, manifests, invariants, treatment audit and full report are in the run directory's split-S/"
            .to_string();
    }
    if levels.iter().all(|l| l.seed.is_none()) {
        // Whole runs, combined: no level is a seed's draw.
        let runs: Vec<&str> = levels.iter().map(|l| l.id.as_str()).collect();
        return format!(
            "each combined run's audit, manifests, invariants, treatment audit and training curves are in its own folder: {}",
            runs.join(", ")
        );
    }
    let seeds: Vec<String> = levels
        .iter()
        .map(|l| match l.seed {
            Some(seed) => format!("seed {seed} draw {}", l.draw.unwrap_or(1)),
            None => format!("the whole run {}", l.id),
        })
        .collect();
    format!(
        "draws per seed: each seed trained and was evaluated on its own draw of the validation, fit and contamination windows (the evaluation recordings fixed), so the seed component carries the draw variance; {} (each in its folder draw-K)",
        seeds.join(", ")
    )
}

/// A level as the warnings name it: `draw 3`, `split 42`.
fn level_name(l: &LevelEvidence) -> String {
    match l.draw {
        Some(d) => format!("draw {d}"),
        None => l.id.replacen('-', " ", 1),
    }
}

/// One warning per invariant met only with a warning in any level, with
/// the range of its counts over the levels and the first level's detail.
fn invariants_over_levels(levels: &[LevelEvidence]) -> Vec<String> {
    let mut by_id: BTreeMap<u64, Vec<(&LevelEvidence, &InvariantEntry)>> = BTreeMap::new();
    for l in levels {
        for i in &l.warned {
            by_id.entry(i.id).or_default().push((l, i));
        }
    }
    let kind = |l: &LevelEvidence| if l.draw.is_some() { "draws" } else { "splits" };
    by_id
        .into_iter()
        .map(|(id, found)| {
            let counts: Vec<usize> = found.iter().map(|(_, i)| i.from_evaluation()).collect();
            let (lo, hi) = (counts.iter().min().copied().unwrap_or(0), counts.iter().max().copied().unwrap_or(0));
            let (first_level, first) = found[0];
            let per = kind(first_level).trim_end_matches('s');
            format!(
                "invariant {id} ({}) is not met in full, which the design allows (a warning), in {} of {} {}: {lo} to {hi} windows per {per} from evaluation recordings or identical copies of them; {}: {}",
                first.name,
                found.len(),
                levels.len(),
                kind(first_level),
                level_name(first_level),
                first.detail
            )
        })
        .collect()
}

/// Each arm's treatment strength: one level's own, or over several, per
/// field the median over the levels (with a warning in `warnings` saying
/// so). Empty where a level lacks its audit or an arm is missing from one.
fn treatment(plan: &Plan, levels: &[LevelEvidence], warnings: &mut Vec<String>) -> Vec<TreatmentStrength> {
    let per: Option<Vec<Vec<TreatmentStrength>>> =
        levels.iter().map(|l| l.treatment.as_ref().map(|t| strengths(t, plan.rate_hz))).collect();
    let per = per.unwrap_or_default();
    match per.as_slice() {
        [] => Vec::new(),
        [one] => one.clone(),
        [first, ..] => {
            let mut out = Vec::new();
            for arm in first {
                let of: Option<Vec<&TreatmentStrength>> =
                    per.iter().map(|level| level.iter().find(|t| t.arm == arm.arm)).collect();
                let Some(of) = of else { return Vec::new() };
                let m =
                    |f: &dyn Fn(&TreatmentStrength) -> f64| crossaudit_stats::median(of.iter().map(|t| f(t)).collect());
                // The quartiles' medians where every level measured them.
                let quartiles = of.iter().all(|t| t.segment_distance_quartiles_s.is_some()).then(|| {
                    let q = |k: usize| m(&|t| t.segment_distance_quartiles_s.map_or(f64::NAN, |q| q[k]));
                    [q(0), q(1), q(2)]
                });
                out.push(TreatmentStrength {
                    arm: arm.arm.clone(),
                    contaminating_windows: m(&|t| t.contaminating_windows as f64).round() as usize,
                    inside_evaluated_segment: m(&|t| t.inside_evaluated_segment as f64).round() as usize,
                    horizon_s: m(&|t| t.horizon_s),
                    median_distance_s: m(&|t| t.median_distance_s),
                    segment_distance_quartiles_s: quartiles,
                });
            }
            let (n, one) = (levels.len(), if plan.splits.is_empty() { "draw" } else { "split" });
            warnings.push(format!(
                "treatment strength: each value is the median over the {n} {one}s of that {one}'s own (each {one}'s audit/treatment.json)"
            ));
            out
        }
    }
}

/// A warning for each build other than the run's that trained cells.
fn resumed(run: &RunEvidence) -> Vec<String> {
    run.resumed_from
        .iter()
        .filter(|b| **b != run.build)
        .map(|b| format!("some cells were trained by crossaudit {b}; this run, which resumed them, is {}", run.build))
        .collect()
}

/// The split's treatment audit as the report shows it (without distance
/// quartiles where an older build wrote the audit).
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
    curves
        .iter()
        .filter(|c| plan.restores_best_epoch(&c.model))
        .filter_map(|c| {
            let best = c.points.iter().copied().reduce(|a, b| if b.1 < a.1 { b } else { a })?;
            let last = c.points.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
            Some(BestEpoch { model: c.model.clone(), arm: c.arm.clone(), seed: c.seed, epoch: best.0, last })
        })
        .collect()
}
