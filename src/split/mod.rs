//! Stage: the experiment both arms share, as immutable manifests.
//!
//! From the included recordings and the design: evaluation recordings E
//! (split seed; a duplicate group is one unit), rollout starts in E,
//! validation recordings V from R\E (validation seed) and their windows,
//! the disjoint fit set from R\E\V, and the contaminated fit set (the
//! disjoint set with a declared fraction replaced by E windows that are not
//! registered starts). Every draw is a ChaCha8 stream seeded from the design.

mod invariants;
mod manifest;
mod numpy_legacy;
mod prepare;
mod treatment;

use std::collections::BTreeSet;

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::data::{Audit, Recording};
use crate::design::{ArmKind, Design, DuplicatePolicy, RecordingFactor, StartsPolicy};

pub use invariants::{check_invariants, Invariant, InvariantReport, InvariantStatus, JobManifests};
pub use manifest::{write_split, ManifestSummary, Manifests};
pub use numpy_legacy::RandomState;
pub use prepare::{prepare, Prepared};
pub use treatment::{treatment_audit, Composition, TreatmentAudit};

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

/// Why the data cannot support the design.
#[derive(Debug, thiserror::Error)]
pub enum SplitError {
    /// Not enough deployment units for evaluation, validation and fitting.
    #[error("the design needs {needed} recordings ({evaluation} evaluation + {validation} validation + at least 1 for fitting), but only {available} usable deployment units remain")]
    TooFewRecordings {
        /// How many the design needs.
        needed: usize,
        /// Evaluation recordings declared.
        evaluation: usize,
        /// Validation recordings declared.
        validation: usize,
        /// How many are available.
        available: usize,
    },
    /// An evaluation recording has too few valid rollout starts.
    #[error("evaluation recording {recording} has {valid} valid rollout starts (>= {horizon} active samples after the start), the design needs {needed}")]
    TooFewStarts {
        /// Recording name.
        recording: String,
        /// Valid rollout starts it has.
        valid: usize,
        /// How many the design needs.
        needed: usize,
        /// Rollout horizon, samples.
        horizon: usize,
    },
    /// A window set cannot be drawn at the declared size.
    #[error("{what}: the design needs {needed} windows, only {available} are available")]
    TooFewWindows {
        /// Which set.
        what: String,
        /// How many the design needs.
        needed: usize,
        /// How many are available.
        available: usize,
    },
    /// A derived arm's percentage replaces no window.
    #[error("arm {arm}: {percent}% of {windows} windows replaces {replaced} windows; nothing would be replaced")]
    NothingToReplace {
        /// Arm name.
        arm: String,
        /// Percentage of windows replaced.
        percent: f64,
        /// Number of windows.
        windows: usize,
        /// Windows that would be replaced.
        replaced: usize,
    },
    /// The data directory could not be audited.
    #[error(transparent)]
    Audit(#[from] crate::data::AuditError),
    /// A manifest or audit file could not be written.
    #[error(transparent)]
    Write(#[from] crate::io::WriteError),
    /// An invariant failed; nothing may train.
    #[error("invariant check failed, nothing will train (see {path}):\n{list}")]
    Invariants {
        /// `audit/invariants.json`, which holds the details.
        path: String,
        /// The failed invariants, one per line.
        list: String,
    },
}

/// A window at row t needs rows t and t + 1 both active.
fn windows_of(rec: &Recording, index: usize) -> Vec<Window> {
    (0..rec.rows.saturating_sub(1))
        .filter(|&t| rec.active[t] && rec.active[t + 1])
        .map(|t| Window { recording: index, t })
        .collect()
}

/// A start at row t needs t and the `horizon` rows after it all active.
fn valid_starts(rec: &Recording, horizon: usize) -> Vec<usize> {
    let n = rec.rows;
    let mut run_after = vec![0usize; n + 1];
    // run_after[t] = consecutive active rows from t onward.
    for t in (0..n).rev() {
        run_after[t] = if rec.active[t] { run_after[t + 1] + 1 } else { 0 };
    }
    (0..n).filter(|&t| run_after[t] > horizon).collect()
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

/// Builds the split. `recordings` are the audit's included recordings.
pub fn build(design: &Design, audit: &Audit, recordings: &[Recording]) -> Result<Split, SplitError> {
    let info = recording_info(audit, recordings);
    let units = units(&info, design.data.duplicates);
    let rf = &design.recording;
    let val = &design.validation;
    let needed = rf.evaluation + val.recordings + 1;
    if units.len() < needed {
        return Err(SplitError::TooFewRecordings {
            needed,
            evaluation: rf.evaluation,
            validation: val.recordings,
            available: units.len(),
        });
    }
    // E: shuffle units with the split seed, take the first I.
    let mut order: Vec<usize> = (0..units.len()).collect();
    order.shuffle(&mut rng(rf.split_seed, 0));
    let (e_units, rest) = order.split_at(rf.evaluation);
    let evaluation = sorted(e_units.iter().map(|&u| units[u].members[0]));
    let evaluation_side = sorted(e_units.iter().flat_map(|&u| units[u].members.clone()));
    let starts = draw_starts(rf, &info, recordings, &evaluation)?;

    // V: from the remaining units, with the validation seed.
    let mut rest: Vec<usize> = rest.to_vec();
    rest.sort();
    rest.shuffle(&mut rng(val.seed, 0));
    let (v_units, fit_units) = rest.split_at(val.recordings);
    let validation_recordings = sorted(v_units.iter().map(|&u| units[u].members[0]));
    let v_pool = pool_of(&validation_recordings, recordings);
    if v_pool.len() < val.windows {
        return Err(SplitError::TooFewWindows {
            what: format!("validation ({} recordings)", val.recordings),
            needed: val.windows,
            available: v_pool.len(),
        });
    }
    let validation = draw(&v_pool, val.windows, &mut rng(val.seed, 1));

    // R \ E \ V: every member of the remaining units (with `duplicates keep`
    // each identical file is its own unit, as in the paper).
    let fit_recordings = sorted(fit_units.iter().flat_map(|&u| units[u].members.clone()));
    let mut fits = draw_fit_arms(design, &fit_recordings, recordings)?;
    let e_pool = pool_of(&evaluation, recordings);
    let mut contaminating = Vec::new();
    for arm in &design.arms {
        let ArmKind::Derived { from, percent, starts: policy, seed } = &arm.kind else { continue };
        let Some(base) = fits.iter().find(|(n, _)| n == from).map(|(_, w)| w.clone()) else { continue };
        let pool: Vec<Window> = match policy {
            StartsPolicy::Exclude => {
                let start_set: BTreeSet<Window> = starts.iter().copied().collect();
                e_pool.iter().copied().filter(|w| !start_set.contains(w)).collect()
            }
            StartsPolicy::Allow => e_pool.clone(),
        };
        let (fit, incoming) = contaminate(&arm.name, &base, *percent, &pool, *seed)?;
        fits.push((arm.name.clone(), fit));
        contaminating.push((arm.name.clone(), incoming));
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
    })
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

/// The registered rollout starts: `starts` valid starts per evaluation
/// recording, each recording on its own stream of the split seed.
fn draw_starts(
    rf: &RecordingFactor,
    info: &[RecordingInfo],
    recordings: &[Recording],
    evaluation: &[usize],
) -> Result<Vec<Window>, SplitError> {
    let mut starts = Vec::new();
    for (k, &r) in evaluation.iter().enumerate() {
        let valid = valid_starts(&recordings[r], rf.horizon);
        if valid.len() < rf.starts {
            return Err(SplitError::TooFewStarts {
                recording: info[r].name.clone(),
                valid: valid.len(),
                needed: rf.starts,
                horizon: rf.horizon,
            });
        }
        let pool: Vec<Window> = valid.into_iter().map(|t| Window { recording: r, t }).collect();
        starts.extend(draw(&pool, rf.starts, &mut rng(rf.split_seed, 1 + k as u64)));
    }
    Ok(starts)
}

/// The fit sets of the `fit` arms, drawn from the fitting recordings.
fn draw_fit_arms(
    design: &Design,
    fit_recordings: &[usize],
    recordings: &[Recording],
) -> Result<Vec<(String, Vec<Window>)>, SplitError> {
    let fit_pool = pool_of(fit_recordings, recordings);
    let mut fits = Vec::new();
    for arm in &design.arms {
        let ArmKind::Fit { windows, seed } = arm.kind else { continue };
        if fit_pool.len() < windows {
            return Err(SplitError::TooFewWindows {
                what: format!("arm {} (from {} fit recordings)", arm.name, fit_recordings.len()),
                needed: windows,
                available: fit_pool.len(),
            });
        }
        fits.push((arm.name.clone(), draw(&fit_pool, windows, &mut rng(seed, 0))));
    }
    Ok(fits)
}

/// A derived arm: `percent`% of `base`'s positions (stream 0 of `seed`)
/// replaced by windows drawn from `pool` (stream 1). Returns the sorted fit
/// set and the incoming evaluation windows.
fn contaminate(
    arm: &str,
    base: &[Window],
    percent: f64,
    pool: &[Window],
    seed: u64,
) -> Result<(Vec<Window>, Vec<Window>), SplitError> {
    let replaced = (percent / 100.0 * base.len() as f64).round() as usize;
    if replaced == 0 {
        return Err(SplitError::NothingToReplace { arm: arm.to_string(), percent, windows: base.len(), replaced });
    }
    if pool.len() < replaced {
        return Err(SplitError::TooFewWindows {
            what: format!("arm {arm} (evaluation windows that are not registered starts)"),
            needed: replaced,
            available: pool.len(),
        });
    }
    let positions = rand::seq::index::sample(&mut rng(seed, 0), base.len(), replaced).into_vec();
    let incoming = draw(pool, replaced, &mut rng(seed, 1));
    let mut fit = base.to_vec();
    for (&p, w) in positions.iter().zip(&incoming) {
        fit[p] = *w;
    }
    fit.sort();
    Ok((fit, incoming))
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
