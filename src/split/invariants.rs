//! The nine audit invariants as typed checks, run before any training.
//! Each reports pass / fail (or warn, or deferred to the stage that can
//! check it) with the numbers behind it.

use std::collections::BTreeSet;

use serde::{Deserialize, Serialize};
use serde_json::{json, Value};

use super::{Manifests, Split};
use crate::design::{ArmKind, Design, DuplicatePolicy, Seed};
use crate::plan::Plan;

/// The manifests one training job uses, by hash.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JobManifests {
    /// Model name.
    pub model: String,
    /// Arm name.
    pub arm: String,
    /// Training seed.
    pub seed: Seed,
    /// SHA-256 of `evaluation_recordings.csv`.
    pub evaluation_sha256: String,
    /// SHA-256 of `evaluation_starts.csv`.
    pub starts_sha256: String,
    /// SHA-256 of `validation_windows.csv`.
    pub validation_sha256: String,
    /// SHA-256 of the arm's `fit_ARM.csv`.
    pub fit_sha256: String,
}

impl JobManifests {
    /// The jobs of a plan, each pointing at the split's manifests.
    pub fn for_plan(plan: &Plan, m: &Manifests) -> Vec<JobManifests> {
        plan.jobs
            .iter()
            .map(|c| JobManifests {
                model: c.model.clone(),
                arm: c.arm.clone(),
                seed: c.seed,
                evaluation_sha256: m.sha256("evaluation_recordings.csv").to_string(),
                starts_sha256: m.sha256("evaluation_starts.csv").to_string(),
                validation_sha256: m.sha256("validation_windows.csv").to_string(),
                fit_sha256: m.sha256(&format!("fit_{}.csv", c.arm)).to_string(),
            })
            .collect()
    }
}

/// The outcome of one invariant check.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum InvariantStatus {
    /// Holds.
    Pass,
    /// Broken: the run stops.
    Fail,
    /// Holds only because the design chose so (e.g. `duplicates keep`).
    Warn,
    /// Checked by a later stage, named in the detail.
    Deferred,
}

/// One numbered invariant of the protocol and its outcome.
#[derive(Debug, Clone, Serialize)]
pub struct Invariant {
    /// Number in the protocol (DESIGN.md).
    pub id: u8,
    /// Short name.
    pub name: &'static str,
    /// Its outcome.
    pub status: InvariantStatus,
    /// What was checked, in words.
    pub detail: String,
    /// The counts behind the outcome, as JSON.
    pub numbers: Value,
}

/// Every invariant of a split.
#[derive(Debug, Clone, Serialize)]
pub struct InvariantReport {
    /// Whether none failed.
    pub all_pass: bool,
    /// In protocol order.
    pub invariants: Vec<Invariant>,
}

impl InvariantReport {
    /// The invariants that failed.
    pub fn failures(&self) -> Vec<&Invariant> {
        self.invariants.iter().filter(|i| i.status == InvariantStatus::Fail).collect()
    }

    /// Pretty JSON, for `invariants.json`.
    pub fn to_json(&self) -> String {
        crate::io::pretty_json(self)
    }
}

fn inv(id: u8, name: &'static str, ok: bool, detail: String, numbers: Value) -> Invariant {
    Invariant { id, name, status: if ok { InvariantStatus::Pass } else { InvariantStatus::Fail }, detail, numbers }
}

fn distinct<'a>(v: impl Iterator<Item = &'a String>) -> usize {
    v.collect::<BTreeSet<_>>().len()
}

/// Leakage of evaluation content: from the evaluation recordings
/// themselves always fails; from identical duplicates it fails unless
/// the design declared `duplicates keep`, where it is a warning.
fn leak_status(own: usize, dup: usize, policy: DuplicatePolicy) -> InvariantStatus {
    if own > 0 || (dup > 0 && policy != DuplicatePolicy::Keep) {
        InvariantStatus::Fail
    } else if dup > 0 {
        InvariantStatus::Warn
    } else {
        InvariantStatus::Pass
    }
}

fn keep_note(names: &BTreeSet<String>) -> String {
    format!(
        " ({}); allowed only because duplicates are kept (`duplicates keep`, declared or the default): declare `duplicates group` to make identical copies one recording, on one side of the split",
        names.iter().cloned().collect::<Vec<_>>().join(", ")
    )
}

/// Runs invariants 1-8 on a split and its cells; 6, 8 and 9 are deferred
/// to the stage that can check them.
pub fn check_invariants(design: &Design, split: &Split, cells: &[JobManifests]) -> InvariantReport {
    let c = Context::new(design, split, cells);
    let out = vec![
        c.same_evaluation(),
        c.unique_starts(),
        c.validation_disjoint(),
        c.fit_sizes(),
        c.reference_disjoint(),
        deferred(
            6,
            "standardizers fitted on their own arm's fit set",
            "checked after training: recomputed from each job's fit manifest (audit/invariants_trained.json)",
        ),
        c.all_seeds(),
        deferred(
            8,
            "recording x seed matrices balanced with no missing cell",
            "checked on per-cell data by analyze (missing or duplicate cells are errors)",
        ),
        deferred(9, "quaternion and divergence metric unit tests pass", "checked in the test suite"),
    ];
    InvariantReport { all_pass: out.iter().all(|i| i.status != InvariantStatus::Fail), invariants: out }
}

fn deferred(id: u8, name: &'static str, detail: &str) -> Invariant {
    Invariant { id, name, status: InvariantStatus::Deferred, detail: detail.into(), numbers: Value::Null }
}

/// What every invariant reads: the split, the cells, and the evaluation
/// side by recording index and by content hash.
struct Context<'a> {
    design: &'a Design,
    split: &'a Split,
    cells: &'a [JobManifests],
    e: BTreeSet<usize>,
    e_hashes: BTreeSet<&'a str>,
}

impl<'a> Context<'a> {
    fn new(design: &'a Design, split: &'a Split, cells: &'a [JobManifests]) -> Self {
        let e = split.evaluation_side.iter().copied().collect();
        let e_hashes = split.evaluation_side.iter().map(|&r| split.recordings[r].content_hash.as_str()).collect();
        Context { design, split, cells, e, e_hashes }
    }

    /// Whether recording `r` is an identical copy (the same values read) of an evaluation
    /// recording without being one.
    fn is_duplicate(&self, r: usize) -> bool {
        !self.e.contains(&r) && self.e_hashes.contains(self.split.recordings[r].content_hash.as_str())
    }

    /// 1. Evaluation recordings and starts identical across arms, models, seeds.
    fn same_evaluation(&self) -> Invariant {
        let cells = self.cells;
        let (ne, ns) =
            (distinct(cells.iter().map(|c| &c.evaluation_sha256)), distinct(cells.iter().map(|c| &c.starts_sha256)));
        inv(
            1,
            "evaluation recordings and starts identical across arms, models and seeds",
            ne <= 1 && ns <= 1,
            format!("{} cells reference {ne} evaluation manifest(s) and {ns} start manifest(s)", cells.len()),
            json!({"cells": cells.len(), "evaluation_manifests": ne, "start_manifests": ns}),
        )
    }

    /// 2. No duplicate registered start. Two identical copies of one
    ///    flight among the evaluation recordings (possible under
    ///    `duplicates keep`) count that flight's starts twice: a warning
    ///    naming them.
    fn unique_starts(&self) -> Invariant {
        let split = self.split;
        let starts = &split.starts;
        let unique: BTreeSet<_> = starts.iter().collect();
        let dups = starts.len() - unique.len();
        let mut by_content: std::collections::BTreeMap<&str, Vec<&str>> = Default::default();
        for &r in &split.evaluation {
            let rec = &split.recordings[r];
            by_content.entry(rec.content_hash.as_str()).or_default().push(rec.name.as_str());
        }
        let copies: Vec<String> = by_content.values().filter(|v| v.len() > 1).map(|v| v.join(" = ")).collect();
        let status = if dups > 0 {
            InvariantStatus::Fail
        } else if !copies.is_empty() {
            InvariantStatus::Warn
        } else {
            InvariantStatus::Pass
        };
        let mut detail = format!("{} starts, {dups} duplicated", starts.len());
        if !copies.is_empty() {
            detail.push_str(&format!(
                "; identical copies among the evaluation recordings ({}): their starts are the same flight counted twice",
                copies.join("; ")
            ));
        }
        Invariant {
            id: 2,
            name: "no duplicate registered start",
            status,
            detail,
            numbers: json!({"starts": starts.len(), "duplicates": dups, "identical_evaluation_recordings": copies}),
        }
    }

    /// 3. Validation has no evaluation recording (nor a duplicate of one)
    ///    and is identical across arms.
    fn validation_disjoint(&self) -> Invariant {
        let split = self.split;
        let v_own = split.validation.iter().filter(|w| self.e.contains(&w.recording)).count();
        let v_dup_names: BTreeSet<String> = split
            .validation
            .iter()
            .filter(|w| self.is_duplicate(w.recording))
            .map(|w| split.recordings[w.recording].name.clone())
            .collect();
        let v_dup = split.validation.iter().filter(|w| self.is_duplicate(w.recording)).count();
        let nv = distinct(self.cells.iter().map(|c| &c.validation_sha256));
        let status = leak_status(v_own + usize::from(nv > 1), v_dup, self.design.data.duplicates);
        let mut detail = format!(
            "{v_own} validation windows from evaluation recordings, {v_dup} from duplicates of them; {nv} validation manifest(s) across cells"
        );
        if status == InvariantStatus::Warn {
            detail.push_str(&keep_note(&v_dup_names));
        }
        Invariant {
            id: 3,
            name: "validation disjoint from evaluation (and its duplicates), identical across arms",
            status,
            detail,
            numbers: json!({"validation_windows": split.validation.len(), "from_evaluation": v_own, "from_duplicates": v_dup, "duplicate_recordings": v_dup_names, "validation_manifests": nv}),
        }
    }

    /// 4. Fit sets of the declared size; derived arms hold exactly the
    ///    declared number of evaluation windows, none a registered start.
    fn fit_sizes(&self) -> Invariant {
        let design = self.design;
        let starts: BTreeSet<_> = self.split.starts.iter().copied().collect();
        let mut ok = true;
        let mut numbers = serde_json::Map::new();
        let mut details = Vec::new();
        for arm in &design.arms {
            let fit = self.split.fit(&arm.name).unwrap_or(&[]);
            let in_e = fit.iter().filter(|w| self.e.contains(&w.recording)).count();
            let (declared, declared_e, starts_ok) = match &arm.kind {
                ArmKind::Fit { windows, .. } => (*windows, 0, true),
                ArmKind::Derived { from, percent, .. } => {
                    let base = design.arms.iter().find(|a| a.name == *from);
                    let n = match base.map(|b| &b.kind) {
                        Some(ArmKind::Fit { windows, .. }) => *windows,
                        _ => 0,
                    };
                    let hits = fit.iter().filter(|w| starts.contains(w)).count();
                    (n, (percent / 100.0 * n as f64).round() as usize, hits == 0)
                }
            };
            ok &= fit.len() == declared && in_e == declared_e && starts_ok;
            details.push(format!(
                "{}: {} windows (declared {declared}), {in_e} from evaluation (declared {declared_e})",
                arm.name,
                fit.len()
            ));
            numbers.insert(arm.name.clone(), json!({"windows": fit.len(), "declared": declared, "evaluation_windows": in_e, "declared_evaluation_windows": declared_e, "registered_starts_used": !starts_ok}));
        }
        inv(
            4,
            "fit sets of the declared size with the declared number of evaluation windows",
            ok,
            details.join("; "),
            Value::Object(numbers),
        )
    }

    /// 5. The reference (fit) arms hold no evaluation recording nor a
    ///    duplicate of one.
    fn reference_disjoint(&self) -> Invariant {
        let (mut own, mut dup) = (0, 0);
        let mut dup_names = BTreeSet::new();
        let is_reference =
            |arm: &str| self.design.arms.iter().any(|a| a.name == arm && matches!(a.kind, ArmKind::Fit { .. }));
        for (_, fit) in self.split.fits.iter().filter(|(arm, _)| is_reference(arm)) {
            for w in fit {
                if self.e.contains(&w.recording) {
                    own += 1;
                } else if self.is_duplicate(w.recording) {
                    dup += 1;
                    dup_names.insert(self.split.recordings[w.recording].name.clone());
                }
            }
        }
        let status = leak_status(own, dup, self.design.data.duplicates);
        let mut detail =
            format!("{own} disjoint-fit windows from evaluation recordings, {dup} from duplicates of them");
        if status == InvariantStatus::Warn {
            detail.push_str(&keep_note(&dup_names));
        }
        Invariant {
            id: 5,
            name: "disjoint fit holds no evaluation recording nor a duplicate of one",
            status,
            detail,
            numbers: json!({"from_evaluation": own, "from_duplicates": dup, "duplicate_recordings": dup_names}),
        }
    }

    /// 7. All seeds present for both models and arms.
    fn all_seeds(&self) -> Invariant {
        let (design, cells) = (self.design, self.cells);
        let mut missing = Vec::new();
        for m in &design.models {
            for a in &design.arms {
                for s in &design.seeds {
                    if !cells.iter().any(|c| c.model == m.name && c.arm == a.name && c.seed == *s) {
                        missing.push(format!("{}/{}/{}", m.name, a.name, s.0));
                    }
                }
            }
        }
        inv(
            7,
            "all seeds present for every model and arm",
            missing.is_empty(),
            if missing.is_empty() {
                format!("{} cells", cells.len())
            } else {
                format!("missing cells: {}", missing.join(", "))
            },
            json!({"cells": cells.len(), "missing": missing}),
        )
    }
}
