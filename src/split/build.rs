//! [`build`]: the split drawn step by step, in the order the generators'
//! streams are consumed (evaluation recordings, rollout starts, validation
//! recordings and windows, fit sets, contaminating windows), each step a
//! method of [`Universe`], the recordings a split is drawn from.

use std::collections::{BTreeMap, BTreeSet};

use rand::seq::SliceRandom;

use super::arms::{contaminate, contaminate_at_distances, draw_fit_arms, replaced, Draw};
use super::coupled::{self, Purpose};
use super::pinned::{pinned, published_fit, resolve};
use super::starts::draw_starts;
use super::{
    draw, draw_numpy, np_seed, pool_of, recording_info, rng, sorted, stratify, units, universe, universe_order,
    DeploymentUnit, RandomState, RecordingInfo, Slot, Split, SplitError, Window,
};
use crate::data::{Audit, Recording, Status};
use crate::design::{ArmKind, Condition, Design, Generator, StartsPolicy, WindowDistance};

/// Builds the split. `recordings` are the audit's included recordings.
pub fn build(design: &Design, audit: &Audit, recordings: &[Recording]) -> Result<Split, SplitError> {
    let u = Universe::new(design, audit, recordings);
    // A stratification the logs cannot give is said first.
    let strata = u.strata()?;
    u.check_enough()?;
    let (rf, allowed) = (&design.recording, design.data.missing_csv_allowed);
    // E: pinned, or the first I of a shuffle of the universe (split seed).
    let mut split_rs = RandomState::new(np_seed(rf.split_seed));
    let e_slots = u.evaluation_slots(strata.as_ref(), &mut split_rs)?;
    let (e_units, evaluation_absent) = resolve(&e_slots, &u.slots, "evaluation", allowed)?;
    let evaluation = sorted(e_units.iter().map(|&k| u.units[k].members[0]));
    let evaluation_side = sorted(e_units.iter().flat_map(|&k| u.units[k].members.clone()));
    let starts = u.starts(&e_slots, &evaluation, &mut split_rs)?;
    // V: pinned, or from the rest of the universe with the validation seed.
    let rest = u.rest(&e_slots);
    let mut val_rs = RandomState::new(np_seed(design.validation.seed));
    let v_slots = u.validation_slots(&rest, &e_slots, strata.as_ref(), &mut val_rs)?;
    let (v_units, validation_absent) = resolve(&v_slots, &u.slots, "validation", allowed)?;
    let validation_recordings = sorted(v_units.iter().map(|&k| u.units[k].members[0]));
    let validation = u.validation_windows(&validation_recordings, &mut val_rs)?;
    // R \ E \ V, then each arm's fit set and the contaminating windows.
    let held: Vec<usize> = evaluation_side.iter().chain(&validation_recordings).copied().collect();
    let (fit_recordings, fit_absent, fit_leaked) = u.fit_recordings(&rest, &v_slots, &v_units, &held)?;
    let numpy = u.numpy();
    let mut fits =
        draw_fit_arms(design, &fit_recordings, recordings, numpy, &|r| u.name(r), (&u.info, &evaluation_side))?;
    let contaminating = u.derive_arms(&mut fits, &starts, &pool_of(&evaluation, recordings))?;
    Ok(Split {
        recordings: u.info,
        units: u.units,
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

/// The recordings a split is drawn from: the included ones, their units,
/// and the universe's slots (the drawable units first, then names the
/// design may list that have no usable data).
struct Universe<'a> {
    design: &'a Design,
    recordings: &'a [Recording],
    info: Vec<RecordingInfo>,
    units: Vec<DeploymentUnit>,
    slots: Vec<(String, Slot)>,
    /// How many of `slots` may be drawn (the rest are absent names).
    drawable: usize,
}

impl<'a> Universe<'a> {
    fn new(design: &'a Design, audit: &Audit, recordings: &'a [Recording]) -> Self {
        let info = recording_info(audit, recordings);
        let units = units(&info, design.data.duplicates);
        let mut slots = universe(design, audit, &info, &units);
        let drawable = slots.len();
        if !design.recording.listed.is_empty() || !design.validation.listed.is_empty() {
            let excluded = audit.files.iter().filter(|f| f.status == Status::Excluded);
            slots.extend(excluded.map(|f| (f.name.clone(), Slot::Absent(f.name.clone()))));
        }
        // A published split may list names that have only a metadata file.
        if design.published.is_some() && !design.data.universe.metadata {
            let missing = audit.files.iter().filter(|f| f.status == Status::Missing);
            slots.extend(missing.map(|f| (f.name.clone(), Slot::Absent(f.name.clone()))));
        }
        Universe { design, recordings, info, units, slots, drawable }
    }

    fn numpy(&self) -> bool {
        self.design.generator == Generator::NumpyLegacy
    }

    fn name(&self, r: usize) -> String {
        self.info[r].name.clone()
    }

    fn members(&self, unit: usize) -> Vec<String> {
        self.units[unit].members.iter().map(|&m| self.info[m].name.clone()).collect()
    }

    /// Enough drawable recordings for the draws (pinned names are checked
    /// one by one instead: absent ones listed, unknown ones refused).
    fn check_enough(&self) -> Result<(), SplitError> {
        let (rf, val) = (&self.design.recording, &self.design.validation);
        let needed = rf.evaluation + val.recordings + 1;
        let drawn = rf.listed.is_empty() || val.listed.is_empty();
        if drawn && self.drawable < needed {
            return Err(SplitError::TooFewRecordings {
                needed,
                evaluation: rf.evaluation,
                validation: val.recordings,
                available: self.drawable,
            });
        }
        Ok(())
    }

    /// `stratify`: each drawable slot's condition, for the walks below;
    /// refused, at the clause, where a condition it names is `unknown` for
    /// every recording (it would draw an unstratified set without a word).
    fn strata(&self) -> Result<Option<stratify::Strata<'_>>, SplitError> {
        let Some(s) = self.design.recording.stratify.as_ref() else { return Ok(None) };
        for c in &s.conditions {
            let value = |r: usize| match c {
                Condition::Trajectory => self.info[r].trajectory.as_str(),
                Condition::Speed => self.info[r].speed.as_str(),
            };
            let members: Vec<usize> = (0..self.drawable)
                .filter_map(|k| match self.slots[k].1 {
                    Slot::Unit(u) => Some(self.units[u].members[0]),
                    Slot::Absent(_) => None,
                })
                .collect();
            // No recording to draw is the draw's own refusal (too few units
            // remain), not the stratification's.
            if !members.is_empty() && members.iter().all(|&r| value(r) == "unknown") {
                return Err(SplitError::Stratify {
                    detail: format!(
                        "`stratify` names {}, but every recording's {} is unknown, so the draw could not be stratified by it; say how the logs give it (a name pattern, a conditions table, `speed from metadata`) or stratify by the conditions they have",
                        c.name(),
                        c.name()
                    ),
                    offset: s.offset,
                });
            }
        }
        Ok(Some({
            let label = |r: usize| {
                let parts: Vec<&str> = s
                    .conditions
                    .iter()
                    .map(|c| match c {
                        Condition::Trajectory => self.info[r].trajectory.as_str(),
                        Condition::Speed => self.info[r].speed.as_str(),
                    })
                    .collect();
                parts.join(" / ")
            };
            let of = |c: usize| match self.slots[c].1 {
                Slot::Unit(u) => Some(label(self.units[u].members[0])),
                Slot::Absent(_) => None,
            };
            stratify::Strata::new(s, (0..self.drawable).map(of).collect())
        }))
    }

    /// The evaluation slots: pinned, or the first I of the generator's
    /// shuffle of the universe (numpy: `choice(n, I)` is the first I of
    /// `permutation(n)`, the same draws).
    fn evaluation_slots(
        &self,
        strata: Option<&stratify::Strata>,
        split_rs: &mut RandomState,
    ) -> Result<Vec<usize>, SplitError> {
        let rf = &self.design.recording;
        if !rf.listed.is_empty() {
            let members = |u: usize| self.members(u);
            return pinned(&rf.listed, &self.slots, &members, "evaluation", self.design.data.universe.metadata);
        }
        let order = if self.numpy() {
            split_rs.permutation(self.drawable)
        } else if self.design.coupled {
            coupled::order(self.drawable, rf.split_seed, Purpose::Evaluation, &|c| self.slots[c].0.clone(), &|_| 0)
        } else {
            let mut order: Vec<usize> = (0..self.drawable).collect();
            order.shuffle(&mut rng(rf.split_seed, 0));
            order
        };
        Ok(match strata {
            Some(s) => s.evaluation(&order, rf.evaluation)?,
            None => order.into_iter().take(rf.evaluation).collect(),
        })
    }

    /// The registered rollout starts. Draw k of a draw-replicated design
    /// redraws them with the evaluation set fixed: seed split_seed + k - 1
    /// (numpy: a fresh RandomState of it; chacha8: streams 2^32 + position).
    fn starts(
        &self,
        e_slots: &[usize],
        evaluation: &[usize],
        split_rs: &mut RandomState,
    ) -> Result<Vec<Window>, SplitError> {
        let (rf, recordings) = (&self.design.recording, self.recordings);
        let redraw = self.design.draw.filter(|&k| k > 1).map(|k| rf.split_seed.saturating_add(k - 1));
        let name = |r: usize| self.name(r);
        if self.design.coupled {
            let seed = redraw.unwrap_or(rf.split_seed);
            return draw_starts(rf, &self.info, recordings, evaluation, &mut |pool, k, _| {
                coupled::draw(pool, k, seed, Purpose::Starts, &name)
            });
        }
        let in_order = || universe_order(e_slots, &self.slots, &self.units);
        match (redraw, self.numpy()) {
            (Some(seed), true) => {
                let mut rs = RandomState::new(np_seed(seed));
                draw_starts(rf, &self.info, recordings, &in_order(), &mut |pool, k, _| draw_numpy(pool, k, &mut rs))
            }
            (Some(seed), false) => draw_starts(rf, &self.info, recordings, evaluation, &mut |pool, k, idx| {
                draw(pool, k, &mut rng(seed, (1 << 32) + idx as u64))
            }),
            // In universe order, continuing the split seed's RandomState.
            (None, true) => {
                draw_starts(rf, &self.info, recordings, &in_order(), &mut |pool, k, _| draw_numpy(pool, k, split_rs))
            }
            (None, false) => draw_starts(rf, &self.info, recordings, evaluation, &mut |pool, k, idx| {
                draw(pool, k, &mut rng(rf.split_seed, 1 + idx as u64))
            }),
        }
    }

    /// The drawable slots outside the evaluation set; under a published
    /// split of train and test alone (no validation role), only its fit
    /// roles' recordings.
    fn rest(&self, e_slots: &[usize]) -> Vec<usize> {
        let e_set: BTreeSet<usize> = e_slots.iter().copied().collect();
        let from_fit_roles: Option<BTreeSet<&str>> = self
            .design
            .published
            .as_ref()
            .filter(|p| p.validation_roles.is_empty())
            .map(|p| p.fit.iter().map(|l| l.name.as_str()).collect());
        (0..self.drawable)
            .filter(|c| !e_set.contains(c))
            .filter(|&c| from_fit_roles.as_ref().is_none_or(|fit| fit.contains(self.slots[c].0.as_str())))
            .collect()
    }

    /// The validation slots: pinned, or drawn from `rest` with the
    /// validation seed.
    fn validation_slots(
        &self,
        rest: &[usize],
        e_slots: &[usize],
        strata: Option<&stratify::Strata>,
        val_rs: &mut RandomState,
    ) -> Result<Vec<usize>, SplitError> {
        let val = &self.design.validation;
        if !val.listed.is_empty() {
            let members = |u: usize| self.members(u);
            let v = pinned(&val.listed, &self.slots, &members, "validation", self.design.data.universe.metadata)?;
            if let Some(k) = v.iter().position(|c| e_slots.contains(c)) {
                return Err(SplitError::ListedTwice { name: val.listed[k].name.clone() });
            }
            return Ok(v);
        }
        let order: Vec<usize> = if self.design.coupled {
            let name = |i: usize| self.slots[rest[i]].0.clone();
            let order = coupled::order(rest.len(), val.seed, Purpose::ValidationRecordings, &name, &|_| 0);
            order.into_iter().map(|i| rest[i]).collect()
        } else if self.numpy() {
            val_rs.permutation(rest.len()).into_iter().map(|k| rest[k]).collect()
        } else {
            let mut r = rest.to_vec();
            r.shuffle(&mut rng(val.seed, 0));
            r
        };
        Ok(match strata {
            Some(s) => s.validation(&order, val.recordings, e_slots)?,
            None => order.into_iter().take(val.recordings).collect(),
        })
    }

    /// The shared validation windows, from the validation recordings.
    fn validation_windows(&self, from: &[usize], val_rs: &mut RandomState) -> Result<Vec<Window>, SplitError> {
        let val = &self.design.validation;
        let v_pool = pool_of(from, self.recordings);
        if v_pool.len() < val.windows {
            return Err(SplitError::TooFewWindows {
                what: format!("validation ({} recordings with data)", from.len()),
                needed: val.windows,
                available: v_pool.len(),
            });
        }
        Ok(if self.design.coupled {
            coupled::draw(&v_pool, val.windows, val.seed, Purpose::ValidationWindows, &|r| self.name(r))
        } else if self.numpy() {
            draw_numpy(&v_pool, val.windows, val_rs)
        } else {
            draw(&v_pool, val.windows, &mut rng(val.seed, 1))
        })
    }

    /// R \ E \ V: every member of the remaining units (with `duplicates
    /// keep` each identical file is its own unit, as in the paper), or the
    /// published split's fit roles; with the fit names that have no data
    /// and those dropped as copies of `held` recordings.
    #[allow(clippy::type_complexity)]
    fn fit_recordings(
        &self,
        rest: &[usize],
        v_slots: &[usize],
        v_units: &[usize],
        held: &[usize],
    ) -> Result<(Vec<usize>, Vec<String>, Vec<(String, String)>), SplitError> {
        let Some(pin) = &self.design.published else {
            let v_set: BTreeSet<usize> = v_slots.iter().copied().collect();
            let fit_units: Vec<usize> = rest
                .iter()
                .filter(|c| !v_set.contains(c))
                .filter_map(|&c| match self.slots[c].1 {
                    Slot::Unit(u) => Some(u),
                    Slot::Absent(_) => None,
                })
                .collect();
            return Ok((sorted(fit_units.iter().flat_map(|&u| self.units[u].members.clone())), Vec::new(), Vec::new()));
        };
        // Validation drawn from the fit roles leaves them: every member of
        // a validation unit is out of the fit pool.
        let drawn: BTreeSet<&str> =
            v_units.iter().flat_map(|&u| self.units[u].members.iter().map(|&m| self.info[m].name.as_str())).collect();
        let mut pin = pin.clone();
        if pin.validation_roles.is_empty() {
            pin.fit.retain(|l| !drawn.contains(l.name.as_str()));
        }
        // The recordings the design excludes by name: left out of the fit
        // roles as the design says, with or without `missing csv allow`.
        let named: Vec<&str> = self
            .design
            .data
            .rules
            .iter()
            .filter_map(|r| match r {
                crate::design::InclusionRule::Named { names } => Some(names.iter().map(String::as_str)),
                _ => None,
            })
            .flatten()
            .collect();
        published_fit(
            &pin,
            (&self.slots, &self.units, &self.info),
            held,
            (self.design.data.missing_csv_allowed, &named),
        )
    }

    /// Derived arms, a dose-response family at a time: its doses share one
    /// draw from the evaluation windows `e_pool` (without the registered
    /// `starts` under `exclude starts`), each replacing a prefix of it, so
    /// that they are nested. Their fit sets join `fits`; returns the
    /// contaminating windows each received.
    fn derive_arms(
        &self,
        fits: &mut Vec<(String, Vec<Window>)>,
        starts: &[Window],
        e_pool: &[Window],
    ) -> Result<Vec<(String, Vec<Window>)>, SplitError> {
        let design = self.design;
        let mut contaminating = Vec::new();
        let mut done: BTreeSet<String> = BTreeSet::new();
        for arm in &design.arms {
            let ArmKind::Derived { from, starts: policy, seed, family, distance, .. } = &arm.kind else { continue };
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
                StartsPolicy::Allow => e_pool.to_vec(),
            };
            let name = |r: usize| self.name(r);
            let how = if design.coupled {
                Draw::Coupled(&name)
            } else if self.numpy() {
                Draw::Numpy
            } else {
                Draw::Chacha
            };
            let gaps = family.as_deref().map(|f| design.distance_doses(f)).unwrap_or_default();
            let drawn = if gaps.len() > 1 {
                let percent = members[0].1;
                let mut pools = Vec::new();
                for (arm_name, d) in &gaps {
                    let member = [(arm_name.clone(), percent)];
                    pools.push(self.at_distance(d, (arm_name, &member, base.len()), &pool, starts, *policy)?);
                }
                let members: Vec<(String, &[Window])> =
                    gaps.iter().zip(&pools).map(|((a, _), p)| (a.clone(), p.as_slice())).collect();
                contaminate_at_distances(&base, percent, &members, &pool, *seed, how)?
            } else {
                let pool = match distance {
                    Some(d) => self.at_distance(d, (&arm.name, &members, base.len()), &pool, starts, *policy)?,
                    None => pool,
                };
                contaminate(&base, &members, &pool, *seed, how)?
            };
            for (arm_name, fit, incoming) in drawn {
                fits.push((arm_name.clone(), fit));
                contaminating.push((arm_name, incoming));
            }
        }
        Ok(contaminating)
    }

    /// The windows of `pool` at distance `d` from every evaluated segment
    /// of their recording; refused, at the clause, when fewer than the
    /// family's largest dose replaces.
    fn at_distance(
        &self,
        d: &WindowDistance,
        (arm, members, base): (&str, &[(String, f64)], usize),
        pool: &[Window],
        starts: &[Window],
        policy: StartsPolicy,
    ) -> Result<Vec<Window>, SplitError> {
        let horizon = self.design.recording.horizon;
        let rate = self.design.data.rate_hz;
        let by_recording = starts_by_recording(starts);
        let kept: Vec<Window> = pool
            .iter()
            .copied()
            .filter(|w| {
                let of = by_recording.get(&w.recording).map_or(&[][..], Vec::as_slice);
                if d.after_segments {
                    // Sharing no row with any segment, and after the last.
                    !of.is_empty() && of.iter().all(|&s| w.t > s + horizon)
                } else {
                    segment_distance(w.t, of, horizon).is_some_and(|n| d.admits(n, rate))
                }
            })
            .collect();
        let needed = members.iter().map(|(_, p)| replaced(*p, base)).max().unwrap_or(0);
        if kept.len() < needed {
            return Err(SplitError::TooFewAtDistance {
                arm: arm.to_string(),
                clause: d.describe(),
                offset: d.offset,
                needed,
                available: kept.len(),
                starts: if policy == StartsPolicy::Exclude { " that are not registered starts" } else { "" },
                pool: pool.len(),
            });
        }
        Ok(kept)
    }
}

/// The rows of the registered starts, by recording.
pub(super) fn starts_by_recording(starts: &[Window]) -> BTreeMap<usize, Vec<usize>> {
    let mut out: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for s in starts {
        out.entry(s.recording).or_default().push(s.t);
    }
    out
}

/// Samples between the one-step window at row `t` (rows t and t + 1) and
/// the nearest evaluated segment (a start s to s + horizon) among `starts`,
/// the start rows of the window's recording: 0 when they share a row;
/// None for a recording without starts.
pub fn segment_distance(t: usize, starts: &[usize], horizon: usize) -> Option<usize> {
    starts
        .iter()
        .map(|&s| {
            if t + 1 < s {
                s - (t + 1)
            } else {
                // 0 when the window shares a row with the segment.
                t.saturating_sub(s + horizon)
            }
        })
        .min()
}
