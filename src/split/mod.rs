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

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::data::{natural_key, Audit, Recording, Status};
use crate::design::{
    ArmKind, Condition, Design, DuplicatePolicy, Generator, LeakPolicy, ListedName, PublishedPin, RecordingFactor,
    StartsPolicy,
};
use coupled::Purpose;

use arms::{contaminate, draw_fit_arms, Draw};
pub use coupled::key as coupled_key;
pub use error::SplitError;
pub use invariants::{check_invariants, Invariant, InvariantReport, InvariantStatus, JobManifests};
pub use manifest::{write_split, ManifestSummary, Manifests};
pub use numpy_legacy::RandomState;
use pinned::{pinned, published_fit, resolve};
pub use prepare::{prepare, rebuild, write_prepared, Prepared};
use starts::draw_starts;
pub use treatment::{treatment_audit, Composition, ConditionCoverage, RecordingCoverage, TreatmentAudit};

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
    /// Identity group, if it has byte-identical copies.
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

/// Builds the split. `recordings` are the audit's included recordings.
pub fn build(design: &Design, audit: &Audit, recordings: &[Recording]) -> Result<Split, SplitError> {
    let info = recording_info(audit, recordings);
    let units = units(&info, design.data.duplicates);
    let rf = &design.recording;
    let val = &design.validation;
    let mut slots = universe(design, audit, &info, &units);
    let drawable = slots.len();
    if !rf.listed.is_empty() || !val.listed.is_empty() {
        let excluded = audit.files.iter().filter(|f| f.status == Status::Excluded);
        slots.extend(excluded.map(|f| (f.name.clone(), Slot::Absent(f.name.clone()))));
    }
    // A published split may list names that have only a metadata file.
    if design.published.is_some() && !design.data.universe.metadata {
        let missing = audit.files.iter().filter(|f| f.status == Status::Missing);
        slots.extend(missing.map(|f| (f.name.clone(), Slot::Absent(f.name.clone()))));
    }
    let members = |u: usize| -> Vec<String> { units[u].members.iter().map(|&m| info[m].name.clone()).collect() };
    let numpy = design.generator == Generator::NumpyLegacy;
    let coupled = design.coupled;
    let allowed = design.data.missing_csv_allowed;
    let needed = rf.evaluation + val.recordings + 1;
    // Pinned names are checked one by one instead (absent ones listed, unknown ones refused).
    let drawn = rf.listed.is_empty() || val.listed.is_empty();
    if drawn && drawable < needed {
        return Err(SplitError::TooFewRecordings {
            needed,
            evaluation: rf.evaluation,
            validation: val.recordings,
            available: drawable,
        });
    }
    // E: pinned, or the first I of a shuffle of the universe (split seed).
    let mut split_rs = RandomState::new(np_seed(rf.split_seed));
    // `stratify`: each drawable slot's condition, for the walks below.
    let strata = rf.stratify.as_ref().map(|s| {
        let label = |r: usize| {
            let parts: Vec<&str> = s
                .conditions
                .iter()
                .map(|c| match c {
                    Condition::Trajectory => info[r].trajectory.as_str(),
                    Condition::Speed => info[r].speed.as_str(),
                })
                .collect();
            parts.join(" / ")
        };
        let of = |c: usize| match slots[c].1 {
            Slot::Unit(u) => Some(label(units[u].members[0])),
            Slot::Absent(_) => None,
        };
        stratify::Strata::new(s, (0..drawable).map(of).collect())
    });
    let e_slots: Vec<usize> = if !rf.listed.is_empty() {
        pinned(&rf.listed, &slots, &members, "evaluation", design.data.universe.metadata)?
    } else {
        // The generator's shuffle of the universe (numpy: `choice(n, I)`
        // is the first I of `permutation(n)`, the same draws).
        let order = if numpy {
            split_rs.permutation(drawable)
        } else if coupled {
            coupled::order(drawable, rf.split_seed, Purpose::Evaluation, &|c| slots[c].0.clone(), &|_| 0)
        } else {
            let mut order: Vec<usize> = (0..drawable).collect();
            order.shuffle(&mut rng(rf.split_seed, 0));
            order
        };
        match &strata {
            Some(s) => s.evaluation(&order, rf.evaluation)?,
            None => order.into_iter().take(rf.evaluation).collect(),
        }
    };
    let (e_units, evaluation_absent) = resolve(&e_slots, &slots, "evaluation", allowed)?;
    let evaluation = sorted(e_units.iter().map(|&u| units[u].members[0]));
    let evaluation_side = sorted(e_units.iter().flat_map(|&u| units[u].members.clone()));
    // Draw k of a draw-replicated design redraws the starts with the
    // evaluation set fixed: seed split_seed + k - 1 (numpy: a fresh
    // RandomState of it; chacha8: streams 2^32 + position).
    let redraw = design.draw.filter(|&k| k > 1).map(|k| rf.split_seed.saturating_add(k - 1));
    let name = |r: usize| info[r].name.clone();
    let starts = if coupled {
        let seed = redraw.unwrap_or(rf.split_seed);
        draw_starts(rf, &info, recordings, &evaluation, &mut |pool, k, _| {
            coupled::draw(pool, k, seed, Purpose::Starts, &name)
        })?
    } else if let Some(seed) = redraw {
        if numpy {
            let mut rs = RandomState::new(np_seed(seed));
            let in_order = universe_order(&e_slots, &slots, &units);
            draw_starts(rf, &info, recordings, &in_order, &mut |pool, k, _| draw_numpy(pool, k, &mut rs))?
        } else {
            draw_starts(rf, &info, recordings, &evaluation, &mut |pool, k, idx| {
                draw(pool, k, &mut rng(seed, (1 << 32) + idx as u64))
            })?
        }
    } else if numpy {
        // In universe order, continuing the split seed's RandomState.
        let in_order = universe_order(&e_slots, &slots, &units);
        draw_starts(rf, &info, recordings, &in_order, &mut |pool, k, _| draw_numpy(pool, k, &mut split_rs))?
    } else {
        draw_starts(rf, &info, recordings, &evaluation, &mut |pool, k, idx| {
            draw(pool, k, &mut rng(rf.split_seed, 1 + idx as u64))
        })?
    };

    // V: pinned, or from the rest of the universe with the validation seed;
    // under a published split of train and test alone (no validation
    // role), from its fit roles' recordings.
    let e_set: BTreeSet<usize> = e_slots.iter().copied().collect();
    let from_fit_roles: Option<BTreeSet<&str>> = design
        .published
        .as_ref()
        .filter(|p| p.validation_roles.is_empty())
        .map(|p| p.fit.iter().map(|l| l.name.as_str()).collect());
    let rest: Vec<usize> = (0..drawable)
        .filter(|c| !e_set.contains(c))
        .filter(|&c| from_fit_roles.as_ref().is_none_or(|fit| fit.contains(slots[c].0.as_str())))
        .collect();
    let mut val_rs = RandomState::new(np_seed(val.seed));
    let v_slots: Vec<usize> = if !val.listed.is_empty() {
        let v = pinned(&val.listed, &slots, &members, "validation", design.data.universe.metadata)?;
        if let Some(k) = v.iter().position(|c| e_set.contains(c)) {
            return Err(SplitError::ListedTwice { name: val.listed[k].name.clone() });
        }
        v
    } else {
        let order: Vec<usize> = if coupled {
            let order = coupled::order(
                rest.len(),
                val.seed,
                Purpose::ValidationRecordings,
                &|i| slots[rest[i]].0.clone(),
                &|_| 0,
            );
            order.into_iter().map(|i| rest[i]).collect()
        } else if numpy {
            val_rs.permutation(rest.len()).into_iter().map(|k| rest[k]).collect()
        } else {
            let mut r = rest.clone();
            r.shuffle(&mut rng(val.seed, 0));
            r
        };
        match &strata {
            Some(s) => s.validation(&order, val.recordings, &e_slots)?,
            None => order.into_iter().take(val.recordings).collect(),
        }
    };
    let (v_units, validation_absent) = resolve(&v_slots, &slots, "validation", allowed)?;
    let validation_recordings = sorted(v_units.iter().map(|&u| units[u].members[0]));
    let v_pool = pool_of(&validation_recordings, recordings);
    if v_pool.len() < val.windows {
        return Err(SplitError::TooFewWindows {
            what: format!("validation ({} recordings with data)", validation_recordings.len()),
            needed: val.windows,
            available: v_pool.len(),
        });
    }
    let validation = if coupled {
        coupled::draw(&v_pool, val.windows, val.seed, Purpose::ValidationWindows, &name)
    } else if numpy {
        draw_numpy(&v_pool, val.windows, &mut val_rs)
    } else {
        draw(&v_pool, val.windows, &mut rng(val.seed, 1))
    };

    // R \ E \ V: every member of the remaining units (with `duplicates keep`
    // each identical file is its own unit, as in the paper).
    let v_set: BTreeSet<usize> = v_slots.iter().copied().collect();
    let (fit_recordings, fit_absent, fit_leaked) = match &design.published {
        None => {
            let fit_units: Vec<usize> = rest
                .iter()
                .filter(|c| !v_set.contains(c))
                .filter_map(|&c| match slots[c].1 {
                    Slot::Unit(u) => Some(u),
                    Slot::Absent(_) => None,
                })
                .collect();
            (sorted(fit_units.iter().flat_map(|&u| units[u].members.clone())), Vec::new(), Vec::new())
        }
        Some(pin) => {
            let held: Vec<usize> = evaluation_side.iter().chain(&validation_recordings).copied().collect();
            // Validation drawn from the fit roles leaves them: every
            // member of a validation unit is out of the fit pool.
            let drawn: BTreeSet<&str> =
                v_units.iter().flat_map(|&u| units[u].members.iter().map(|&m| info[m].name.as_str())).collect();
            let mut pin = pin.clone();
            if pin.validation_roles.is_empty() {
                pin.fit.retain(|l| !drawn.contains(l.name.as_str()));
            }
            published_fit(&pin, &slots, &units, &info, &held, allowed)?
        }
    };
    let mut fits = draw_fit_arms(design, &fit_recordings, recordings, numpy, &name, (&info, &evaluation_side))?;
    let e_pool = pool_of(&evaluation, recordings);
    let mut contaminating = Vec::new();
    // Derived arms, a dose-response family at a time: its doses share one
    // draw, each replacing a prefix of it, so that they are nested.
    let mut done: BTreeSet<String> = BTreeSet::new();
    for arm in &design.arms {
        let ArmKind::Derived { from, starts: policy, seed, family, .. } = &arm.kind else { continue };
        let group = family.clone().unwrap_or_else(|| arm.name.clone());
        if !done.insert(group) {
            continue;
        }
        let members: Vec<(String, f64)> = design
            .arms
            .iter()
            .filter_map(|a| match &a.kind {
                ArmKind::Derived { percent, family: f, .. }
                    if a.name == arm.name || (family.is_some() && f == family) =>
                {
                    Some((a.name.clone(), *percent))
                }
                _ => None,
            })
            .collect();
        let Some(base) = fits.iter().find(|(n, _)| n == from).map(|(_, w)| w.clone()) else { continue };
        let pool: Vec<Window> = match policy {
            StartsPolicy::Exclude => {
                let start_set: BTreeSet<Window> = starts.iter().copied().collect();
                e_pool.iter().copied().filter(|w| !start_set.contains(w)).collect()
            }
            StartsPolicy::Allow => e_pool.clone(),
        };
        let how = if coupled {
            Draw::Coupled(&name)
        } else if numpy {
            Draw::Numpy
        } else {
            Draw::Chacha
        };
        for (arm_name, fit, incoming) in contaminate(&base, &members, &pool, *seed, how)? {
            fits.push((arm_name.clone(), fit));
            contaminating.push((arm_name, incoming));
        }
    }
    Ok(Split {
        recordings: info,
        units,
        evaluation,
        evaluation_side,
        starts,
        validation_recordings,
        validation,
        fits,
        contaminating,
        horizon: rf.horizon,
        rate_hz: design.data.rate_hz,
        evaluation_absent,
        validation_absent,
        fit_absent,
        fit_leaked,
    })
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
