//! The fit sets of the arms: each `fit` arm drawn from its pool (the
//! fitting recordings, less any held-out family), and each derived arm's
//! replaced positions and incoming evaluation windows, nested over a
//! dose-response family's doses.

use super::coupled::{self, Purpose};
use super::*;

/// How a derived arm's draws are made.
#[derive(Clone, Copy)]
pub(super) enum Draw<'a> {
    Chacha,
    Numpy,
    /// Priority sampling, recordings named by the function.
    Coupled(&'a dyn Fn(usize) -> String),
}

/// The fit sets of the `fit` arms, drawn from the fitting recordings.
pub(super) fn draw_fit_arms(
    design: &Design,
    fit_recordings: &[usize],
    recordings: &[Recording],
    numpy: bool,
    name: &dyn Fn(usize) -> String,
    (info, evaluation): (&[RecordingInfo], &[usize]),
) -> Result<Vec<(String, Vec<Window>)>, SplitError> {
    let fit_pool = pool_of(fit_recordings, recordings);
    let mut fits = Vec::new();
    for arm in &design.arms {
        let ArmKind::Fit { windows, seed, ref hold_out } = arm.kind else { continue };
        // A stricter holdout: every recording sharing a held-out label
        // with an evaluation recording leaves this arm's pool.
        let held = |r: usize| {
            hold_out.iter().any(|c| {
                let label = |k: usize| match c {
                    Condition::Trajectory => &info[k].trajectory,
                    Condition::Speed => &info[k].speed,
                };
                evaluation.iter().any(|&e| label(e) == label(r))
            })
        };
        let own_pool;
        let fit_pool: &[Window] = if hold_out.is_empty() {
            &fit_pool
        } else {
            let kept: Vec<usize> = fit_recordings.iter().copied().filter(|&r| !held(r)).collect();
            own_pool = pool_of(&kept, recordings);
            &own_pool
        };
        let fit_recordings: Vec<usize> = if hold_out.is_empty() {
            fit_recordings.to_vec()
        } else {
            fit_recordings.iter().copied().filter(|&r| !held(r)).collect()
        };
        if fit_pool.len() < windows {
            return Err(SplitError::TooFewWindows {
                what: format!("arm {} (from {} fit recordings)", arm.name, fit_recordings.len()),
                needed: windows,
                available: fit_pool.len(),
            });
        }
        let drawn = if design.coupled {
            coupled::draw(fit_pool, windows, seed, Purpose::Fit, name)
        } else if numpy {
            draw_numpy(fit_pool, windows, &mut RandomState::new(np_seed(seed)))
        } else {
            draw(fit_pool, windows, &mut rng(seed, 0))
        };
        fits.push((arm.name.clone(), drawn));
    }
    Ok(fits)
}

/// A derived arm's name, sorted fit set and sorted incoming evaluation windows.
pub(super) type DerivedArm = (String, Vec<Window>, Vec<Window>);

/// The windows a derived arm replaces: `percent`% of its base's `base`
/// windows, rounded.
pub(super) fn replaced(percent: f64, base: usize) -> usize {
    (percent / 100.0 * base as f64).round() as usize
}

/// Derived arms of one base: each member's `percent`% of `base`'s
/// positions replaced by windows of `pool`. The positions (stream 0 of
/// `seed`) and the incoming windows (stream 1) are drawn once, in random
/// order, for the largest dose; each dose takes their first k, so a smaller
/// dose's replaced positions and incoming windows are part of every larger
/// dose's. For one arm this is a plain draw of k. Returns (arm, sorted fit
/// set, sorted incoming evaluation windows) per member, in member order.
pub(super) fn contaminate(
    base: &[Window],
    members: &[(String, f64)],
    pool: &[Window],
    seed: u64,
    how: Draw<'_>,
) -> Result<Vec<DerivedArm>, SplitError> {
    let count = |percent: f64| replaced(percent, base.len());
    let mut most = 0;
    for (arm, percent) in members {
        let replaced = count(*percent);
        if replaced == 0 {
            let (arm, percent, windows) = (arm.clone(), *percent, base.len());
            return Err(SplitError::NothingToReplace { arm, percent, windows, replaced });
        }
        if pool.len() < replaced {
            return Err(SplitError::TooFewWindows {
                what: format!("arm {arm} (evaluation windows that are not registered starts)"),
                needed: replaced,
                available: pool.len(),
            });
        }
        most = most.max(replaced);
    }
    let (positions, incoming): (Vec<usize>, Vec<Window>) = match how {
        Draw::Numpy => {
            let mut rs = RandomState::new(np_seed(seed));
            let positions = rs.choice(base.len(), most);
            (positions, rs.choice(pool.len(), most).into_iter().map(|i| pool[i]).collect())
        }
        Draw::Chacha => {
            let positions = rand::seq::index::sample(&mut rng(seed, 0), base.len(), most).into_vec();
            let incoming = rand::seq::index::sample(&mut rng(seed, 1), pool.len(), most).into_iter().map(|i| pool[i]);
            (positions, incoming.collect())
        }
        Draw::Coupled(name) => {
            let replaced = coupled::order(base.len(), seed, Purpose::Replaced, &|i| name(base[i].recording), &|i| {
                base[i].t as u64
            });
            let incoming = coupled::order(pool.len(), seed, Purpose::Incoming, &|i| name(pool[i].recording), &|i| {
                pool[i].t as u64
            });
            (replaced.into_iter().take(most).collect(), incoming.into_iter().take(most).map(|i| pool[i]).collect())
        }
    };
    let mut out = Vec::new();
    for (arm, percent) in members {
        let k = count(*percent);
        let mut fit = base.to_vec();
        for (&p, w) in positions[..k].iter().zip(&incoming[..k]) {
            fit[p] = *w;
        }
        fit.sort();
        let mut taken = incoming[..k].to_vec();
        taken.sort();
        out.push((arm.clone(), fit, taken));
    }
    Ok(out)
}

/// A distance-dose family: every member replaces the same `percent` of
/// `base`'s positions, each with windows at its own distance, whose
/// admissible windows (a subset of `pool`) it names. The positions are
/// drawn once (stream 0 of `seed`), as for one arm; the incoming windows
/// come from one random order of the whole `pool` (stream 1), each member
/// taking the first windows of that order that lie at its distance. So the
/// members share their replaced positions, and a window that a nearer
/// member drew and that also lies at a farther member's distance is one
/// that member draws too: the distances differ, not the draws.
pub(super) fn contaminate_at_distances(
    base: &[Window],
    percent: f64,
    members: &[(String, &[Window])],
    pool: &[Window],
    seed: u64,
    how: Draw<'_>,
) -> Result<Vec<DerivedArm>, SplitError> {
    let k = replaced(percent, base.len());
    if let (0, Some((arm, _))) = (k, members.first()) {
        let (arm, windows) = (arm.clone(), base.len());
        return Err(SplitError::NothingToReplace { arm, percent, windows, replaced: k });
    }
    let (positions, order): (Vec<usize>, Vec<usize>) = match how {
        Draw::Numpy => {
            let mut rs = RandomState::new(np_seed(seed));
            let positions = rs.choice(base.len(), k);
            (positions, rs.choice(pool.len(), pool.len()))
        }
        Draw::Chacha => {
            let positions = rand::seq::index::sample(&mut rng(seed, 0), base.len(), k).into_vec();
            (positions, rand::seq::index::sample(&mut rng(seed, 1), pool.len(), pool.len()).into_vec())
        }
        Draw::Coupled(name) => {
            let replaced = coupled::order(base.len(), seed, Purpose::Replaced, &|i| name(base[i].recording), &|i| {
                base[i].t as u64
            });
            let incoming = coupled::order(pool.len(), seed, Purpose::Incoming, &|i| name(pool[i].recording), &|i| {
                pool[i].t as u64
            });
            (replaced.into_iter().take(k).collect(), incoming)
        }
    };
    let mut out = Vec::new();
    for (arm, admitted) in members {
        let admitted: std::collections::BTreeSet<&Window> = admitted.iter().collect();
        let incoming: Vec<Window> = order.iter().map(|&i| pool[i]).filter(|w| admitted.contains(w)).take(k).collect();
        let mut fit = base.to_vec();
        for (&p, w) in positions.iter().zip(&incoming) {
            fit[p] = *w;
        }
        fit.sort();
        let mut taken = incoming;
        taken.sort();
        out.push((arm.clone(), fit, taken));
    }
    Ok(out)
}
