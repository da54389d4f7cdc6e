//! Stage: the experiment both arms share, as immutable manifests.
//!
//! From the included recordings and the design: evaluation recordings E
//! (split seed; a duplicate group is one unit), rollout starts in E,
//! validation recordings V from R\E (validation seed) and their windows,
//! the disjoint fit set from R\E\V, and the contaminated fit set (the
//! disjoint set with a declared fraction replaced by E windows that are not
//! registered starts).
//!
//! The universe a split draws from is the included recordings (and, under
//! `universe metadata`, the names a metadata file lists without a CSV),
//! sorted naturally or bytewise; a duplicate group under `duplicates group`
//! is one entry, named by its first member.
//!
//! Draws (`generator`):
//! - `chacha8` (default): each draw on its own ChaCha8 stream of its seed:
//!   E = a shuffle of the universe (split seed, stream 0), first I; the
//!   starts of the k-th evaluation recording on stream 1 + k; V = a shuffle
//!   of the rest (validation seed, stream 0), its windows on stream 1; each
//!   fit arm's windows (its seed, stream 0); a derived arm's replaced
//!   positions (stream 0) and incoming windows (stream 1).
//! - `numpy_legacy`: one numpy `RandomState` per seed, its calls in this
//!   order: `RandomState(split_seed)`: `permutation(len(universe))[:I]`,
//!   then `choice(n_valid, starts, replace=False)` per evaluation recording
//!   in universe order; `RandomState(validation_seed)`:
//!   `permutation(len(rest))[:V]`, then `choice(n_windows, windows,
//!   replace=False)`; `RandomState(arm_seed).choice(n_pool, windows,
//!   replace=False)`; `RandomState(seed)`: `choice(n_fit, k)` positions, then
//!   `choice(n_pool, k)` incoming windows. Drawn sets are stored sorted.

mod arms;
mod build;
mod coupled;
mod error;
mod invariants;
mod manifest;
mod numpy_legacy;
mod pinned;
mod prepare;
mod starts;
mod stratify;
mod treatment;

use std::collections::BTreeSet;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::data::{natural_key, Audit, Recording, Status};
use crate::design::{
    ArmKind, Condition, Design, DuplicatePolicy, LeakPolicy, ListedName, PublishedPin, RecordingFactor,
};

pub use build::{build, segment_distance};
pub use coupled::key as coupled_key;
pub use error::SplitError;
pub use invariants::{check_invariants, Invariant, InvariantReport, InvariantStatus, JobManifests};
pub use manifest::{write_split, ManifestSummary, Manifests};
pub use numpy_legacy::RandomState;
pub use prepare::{prepare, rebuild, write_prepared, Prepared};
pub use treatment::{
    median, treatment_audit, ArmTreatment, Composition, FitCoverage, RecordingCoverage, TreatmentAudit,
};

/// A one-step window or a rollout start: (recording index, row index).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
pub struct Window {
    /// Index into [`Split::recordings`].
    pub recording: usize,
    /// Row index within the recording.
    pub t: usize,
}

/// A deployment unit: one recording, or a group of identical recordings.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DeploymentUnit {
    /// Recording indices, representative first.
    pub members: Vec<usize>,
    /// Identity group name, when the unit groups identical recordings.
    pub group: Option<String>,
}

/// The shared experiment.
#[derive(Debug, Clone, Serialize)]
pub struct Split {
    /// Included recordings, natural name order; every index refers here.
    pub recordings: Vec<RecordingInfo>,
    /// Deployment units, in recording order.
    pub units: Vec<DeploymentUnit>,
    /// Evaluation recordings (unit representatives), sorted.
    pub evaluation: Vec<usize>,
    /// Every recording on the evaluation side (all members of E's units).
    pub evaluation_side: Vec<usize>,
    /// Rollout starts, by evaluation recording.
    pub starts: Vec<Window>,
    /// Recordings the validation windows come from.
    pub validation_recordings: Vec<usize>,
    /// The shared validation windows.
    pub validation: Vec<Window>,
    /// Fit sets per arm, in design order.
    pub fits: Vec<(String, Vec<Window>)>,
    /// The E windows each derived arm received.
    pub contaminating: Vec<(String, Vec<Window>)>,
    /// Rollout horizon, samples.
    pub horizon: usize,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Evaluation recordings the split drew that have no CSV (`missing csv allow`).
    pub evaluation_absent: Vec<String>,
    /// Validation recordings the split drew that have no CSV.
    pub validation_absent: Vec<String>,
    /// Fit recordings a published split lists that have no usable data.
    pub fit_absent: Vec<String>,
    /// Fit recordings of a published split dropped under `leaked drop`:
    /// (the copy, the evaluation or validation recording it repeats).
    pub fit_leaked: Vec<(String, String)>,
}

/// What the split needs to know of an included recording.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RecordingInfo {
    /// Recording name.
    pub name: String,
    /// Trajectory shape.
    pub trajectory: String,
    /// Speed token.
    pub speed: String,
    /// Identity group, if it has identical copies (the same values read).
    pub duplicate_group: Option<String>,
    /// XXH3-128 of its data rows, hex.
    pub content_hash: String,
}

/// A window at row t needs rows t and t + 1 both active.
fn windows_of(rec: &Recording, index: usize) -> Vec<Window> {
    (0..rec.rows.saturating_sub(1))
        .filter(|&t| rec.active[t] && rec.active[t + 1])
        .map(|t| Window { recording: index, t })
        .collect()
}

fn rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(stream);
    r
}

/// `k` of `pool`, uniformly without replacement, returned sorted.
fn draw(pool: &[Window], k: usize, rng: &mut ChaCha8Rng) -> Vec<Window> {
    let mut picked: Vec<Window> = rand::seq::index::sample(rng, pool.len(), k).into_iter().map(|i| pool[i]).collect();
    picked.sort();
    picked
}

/// `k` of `pool` by numpy's `choice(len(pool), k, replace=False)`, sorted.
fn draw_numpy(pool: &[Window], k: usize, rs: &mut RandomState) -> Vec<Window> {
    let mut picked: Vec<Window> = rs.choice(pool.len(), k).into_iter().map(|i| pool[i]).collect();
    picked.sort();
    picked
}

/// A numpy seed: the validator refuses seeds above 2^32 - 1 under `numpy_legacy`.
fn np_seed(seed: u64) -> u32 {
    u32::try_from(seed).unwrap_or(u32::MAX)
}

/// An entry of the universe: a deployment unit with data, or a name that a
/// metadata file lists without a CSV. (Pinned names of files the data rules
/// exclude are also `Absent`, appended after the universe so that no draw
/// reaches them.)
#[derive(Debug, Clone)]
enum Slot {
    Unit(usize),
    Absent(String),
}

/// The universe, in the declared order, each entry with its name.
fn universe(design: &Design, audit: &Audit, info: &[RecordingInfo], units: &[DeploymentUnit]) -> Vec<(String, Slot)> {
    let mut slots: Vec<(String, Slot)> =
        units.iter().enumerate().map(|(u, unit)| (info[unit.members[0]].name.clone(), Slot::Unit(u))).collect();
    if design.data.universe.metadata {
        let absent = audit.files.iter().filter(|f| f.status == Status::Missing);
        slots.extend(absent.map(|f| (f.name.clone(), Slot::Absent(f.name.clone()))));
    }
    if design.data.universe.bytewise {
        slots.sort_by(|a, b| a.0.cmp(&b.0));
    } else {
        slots.sort_by_key(|(name, _)| natural_key(name));
    }
    slots
}

/// The evaluation recordings in universe order (the order numpy's starts
/// are drawn in), without absent names.
fn universe_order(e_slots: &[usize], slots: &[(String, Slot)], units: &[DeploymentUnit]) -> Vec<usize> {
    let mut ordered: Vec<usize> = e_slots.to_vec();
    ordered.sort();
    ordered
        .iter()
        .filter_map(|&c| match slots[c].1 {
            Slot::Unit(u) => Some(units[u].members[0]),
            Slot::Absent(_) => None,
        })
        .collect()
}

fn sorted(v: impl Iterator<Item = usize>) -> Vec<usize> {
    let mut v: Vec<usize> = v.collect();
    v.sort();
    v
}

/// Every one-step window of the recordings `rs`, in order.
fn pool_of(rs: &[usize], recordings: &[Recording]) -> Vec<Window> {
    rs.iter().flat_map(|&r| windows_of(&recordings[r], r)).collect()
}

/// What the split keeps of each included recording, with the audit's labels.
fn recording_info(audit: &Audit, recordings: &[Recording]) -> Vec<RecordingInfo> {
    recordings
        .iter()
        .map(|r| {
            let row = audit.files.iter().find(|f| f.name == r.name);
            RecordingInfo {
                name: r.name.clone(),
                trajectory: row.map(|f| f.trajectory.clone()).unwrap_or_default(),
                speed: row.map(|f| f.speed.clone()).unwrap_or_default(),
                duplicate_group: row.and_then(|f| f.duplicate_group.clone()),
                content_hash: r.content_hash.clone(),
            }
        })
        .collect()
}

/// Deployment units. With `duplicates group`, identical recordings form one
/// unit; otherwise each recording is its own.
fn units(info: &[RecordingInfo], policy: DuplicatePolicy) -> Vec<DeploymentUnit> {
    let mut out: Vec<DeploymentUnit> = Vec::new();
    for (k, r) in info.iter().enumerate() {
        if policy == DuplicatePolicy::Group {
            if let Some(g) = &r.duplicate_group {
                if let Some(u) = out.iter_mut().find(|u| u.group.as_ref() == Some(g)) {
                    u.members.push(k);
                    continue;
                }
            }
            out.push(DeploymentUnit { members: vec![k], group: r.duplicate_group.clone() });
        } else {
            out.push(DeploymentUnit { members: vec![k], group: None });
        }
    }
    out
}

impl Split {
    /// The fit set of `arm`, if the design declares it.
    pub fn fit(&self, arm: &str) -> Option<&[Window]> {
        self.fits.iter().find(|(n, _)| n == arm).map(|(_, w)| w.as_slice())
    }
}
