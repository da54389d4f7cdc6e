//! An interval for a relative difference, the optimism
//! rho = (mean_R - mean_T) / mean_R of two paired crossed arrays T (treated)
//! and R (reference), from the same crossed estimator that gives the
//! interval of the difference.
//!
//! Fieller's interval inverts the estimator's own test. Optimism rho is the
//! null E[T] = (1 - rho) E[R], that is E[L(rho)] = 0 for the array
//! L(rho) = T - (1 - rho) R. The Fieller set is every rho whose array
//! L(rho) has an interval containing 0: |mean L(rho)| <= t(df) SE(L(rho)),
//! with the SE and df that the estimator gives L(rho). A threshold lies
//! outside the set exactly when the estimator's test rejects "optimism equals
//! the threshold" at the interval's level, which is what a margin asks.
//!
//! The delta method's interval is rho +- t(df) SE(L(rho_hat)) / |mean_R|:
//! Var(rho_hat) ~ Var(mean_d + rho mean_R) / mean_R^2 with d = T - R, the
//! first-order expansion of -mean_d / mean_R, and d + rho R = L(rho).
//!
//! Both are found numerically, so that any estimator (the method of moments
//! with its truncated components, REML with missing cells, any df rule)
//! can be used; `scripts/reference/optimism_interval.py` checks them
//! against Fieller's closed form (untruncated moments, a quadratic in rho)
//! and against a pigeonhole bootstrap of the ratio.

use serde::Serialize;

use super::{CrossedEstimate, StatsError};

/// The set Fieller's method gives: an interval, or, when the reference
/// mean's own interval contains 0, an unbounded set (the whole line or
/// two rays): the data then bound the ratio on neither side.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum FiellerSet {
    /// [lower, upper].
    Bounded {
        /// Lower bound.
        lower: f64,
        /// Upper bound.
        upper: f64,
    },
    /// Not bounded: the reference arm's mean is not distinguishable from 0.
    Unbounded,
}

impl FiellerSet {
    /// The bounds, when the set is bounded.
    pub fn bounds(&self) -> Option<(f64, f64)> {
        match *self {
            FiellerSet::Bounded { lower, upper } => Some((lower, upper)),
            FiellerSet::Unbounded => None,
        }
    }

    /// Whether `x` lies in the set (an unbounded set holds every value
    /// that matters for a threshold: its side is not determined).
    pub fn contains(&self, x: f64) -> bool {
        match *self {
            FiellerSet::Bounded { lower, upper } => lower <= x && x <= upper,
            FiellerSet::Unbounded => true,
        }
    }
}

/// Intervals for the ratio rho = (mean_R - mean_T) / mean_R.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RatioInterval {
    /// The point estimate (mean_R - mean_T) / mean_R.
    pub estimate: f64,
    /// Confidence level.
    pub level: f64,
    /// Fieller's set: the inverted test of the estimator.
    pub fieller: FiellerSet,
    /// The delta method's SE of rho_hat.
    pub delta_se: f64,
    /// The delta method's df (those of L(rho_hat)).
    #[serde(serialize_with = "crate::df_json")]
    pub delta_df: f64,
    /// Lower delta-method bound.
    pub delta_lower: f64,
    /// Upper delta-method bound.
    pub delta_upper: f64,
}

impl RatioInterval {
    /// The same intervals for k rho (for example k = 100: in percent).
    pub fn scaled(self, k: f64) -> RatioInterval {
        let (a, b) = (self.delta_lower * k, self.delta_upper * k);
        RatioInterval {
            estimate: self.estimate * k,
            level: self.level,
            fieller: match self.fieller {
                FiellerSet::Bounded { lower, upper } => {
                    FiellerSet::Bounded { lower: (lower * k).min(upper * k), upper: (lower * k).max(upper * k) }
                }
                FiellerSet::Unbounded => FiellerSet::Unbounded,
            },
            delta_se: self.delta_se * k.abs(),
            delta_df: self.delta_df,
            delta_lower: a.min(b),
            delta_upper: a.max(b),
        }
    }
}

/// `g(rho) = |mean L(rho)| - t SE(L(rho))`: negative inside Fieller's set.
fn excess(e: &CrossedEstimate) -> f64 {
    e.mean.abs() - e.critical * e.se
}

/// Intervals for the optimism rho = (mean_R - mean_T) / mean_R. `estimate`
/// gives the crossed estimate of the array L(rho) = T - (1 - rho) R for any
/// rho (the caller builds the array, so any estimator works); `reference`
/// is the estimate of R alone, whose interval says whether Fieller's set is
/// bounded; `point` is rho_hat.
///
/// ```
/// use crossaudit_stats::{crossed_mom, ratio_interval, CrossedMatrix, DfRule};
/// // 3 recordings x 2 seeds: T is R shrunk by a third plus noise.
/// let r = [3.0, 3.2, 2.9, 3.4, 3.1, 2.8];
/// let t = [2.1, 2.0, 2.0, 2.3, 2.1, 1.9];
/// let arr = |rho: f64| CrossedMatrix::new(3, 2, (0..6).map(|k| t[k] - (1.0 - rho) * r[k]).collect());
/// let at = |rho: f64| crossed_mom(&arr(rho)?, 0.95, DfRule::Normal);
/// let reference = crossed_mom(&CrossedMatrix::new(3, 2, r.to_vec()).unwrap(), 0.95, DfRule::Normal).unwrap();
/// let rho = (r.iter().sum::<f64>() - t.iter().sum::<f64>()) / r.iter().sum::<f64>();
/// let iv = ratio_interval(rho, &reference, at).unwrap();
/// assert!(iv.fieller.contains(rho) && !iv.fieller.contains(0.0));
/// assert!(iv.delta_lower < rho && rho < iv.delta_upper);
/// ```
pub fn ratio_interval(
    point: f64,
    reference: &CrossedEstimate,
    estimate: impl Fn(f64) -> Result<CrossedEstimate, StatsError> + Sync,
) -> Result<RatioInterval, StatsError> {
    // The two edges' evaluations of a round run at once, each its own
    // sequence: the same numbers at any thread count.
    ratio_interval_batched(point, reference, 1, |rhos: &[f64]| match *rhos {
        [a, b] => {
            let (a, b) = rayon::join(|| estimate(a), || estimate(b));
            vec![a, b]
        }
        _ => rhos.iter().map(|&x| estimate(x)).collect(),
    })
}

/// [`ratio_interval`] with its evaluations asked for together, `lanes` at a
/// time (shared by the edges of Fieller's set still being searched, at
/// least one each): `estimates` is given the rho of a round (the point
/// estimate alone first) and returns their estimates in that order. With
/// more lanes than edges a round also holds the steps after an edge's
/// next one, for either answer the next one may get (the search's tree of
/// outcomes, level by level), and the edge then takes as many steps as the
/// round answered. Each edge follows the very sequence of rho of
/// [`ratio_interval`] whatever `lanes` is, so the intervals are the same,
/// bit for bit. It pays where several estimates cost about what one does
/// ([`crate::mean_squares_along`] sums [`crate::ALONG_LANES`] arrays in one
/// pass): four lanes per edge take two steps per round, eight take three;
/// [`ratio_interval`] is this with one lane, each edge one step a round.
///
/// ```
/// use crossaudit_stats::{crossed_mom, mean_squares_along, mom_from_squares, ratio_interval};
/// use crossaudit_stats::{ratio_interval_batched, CrossedMatrix, DfRule};
/// let r = [3.0, 3.2, 2.9, 3.4, 3.1, 2.8];
/// let t = [2.1, 2.0, 2.0, 2.3, 2.1, 1.9];
/// let rule = DfRule::SeedsMinusOne;
/// let reference = crossed_mom(&CrossedMatrix::new(3, 2, r.to_vec())?, 0.95, rule)?;
/// let rho = (r.iter().sum::<f64>() - t.iter().sum::<f64>()) / r.iter().sum::<f64>();
/// let alone = ratio_interval(rho, &reference, |rho: f64| {
///     let l = t.iter().zip(&r).map(|(t, r)| t - (1.0 - rho) * r).collect();
///     crossed_mom(&CrossedMatrix::new(3, 2, l)?, 0.95, rule)
/// });
/// let together = ratio_interval_batched(rho, &reference, 8, |rhos: &[f64]| {
///     let tables = mean_squares_along(&t, &r, 3, 2, rhos);
///     tables.into_iter().map(|m| mom_from_squares(m?.0, 3, 2, 0.95, rule)).collect()
/// });
/// assert_eq!(alone, together);
/// # Ok::<(), crossaudit_stats::StatsError>(())
/// ```
pub fn ratio_interval_batched(
    point: f64,
    reference: &CrossedEstimate,
    lanes: usize,
    estimates: impl Fn(&[f64]) -> Vec<Result<CrossedEstimate, StatsError>>,
) -> Result<RatioInterval, StatsError> {
    if !point.is_finite() || !reference.mean.is_finite() || reference.mean == 0.0 {
        return Err(StatsError::Invalid(format!(
            "the ratio needs a finite estimate and a finite, non-zero reference mean (estimate {point}, reference mean {})",
            reference.mean
        )));
    }
    let one = |x: f64| estimates(&[x]).into_iter().next().unwrap_or_else(|| Err(unanswered(1, 0)));
    let at = one(point)?;
    let delta_se = at.se / reference.mean.abs();
    let fieller = if reference.lower <= 0.0 && 0.0 <= reference.upper {
        FiellerSet::Unbounded
    } else {
        let step = if delta_se > 0.0 { delta_se } else { 1e-6 * point.abs().max(1e-6) };
        let [lower, upper] = roots(point, step, lanes, &estimates);
        match (lower?, upper?) {
            (Some(lower), Some(upper)) => FiellerSet::Bounded { lower, upper },
            _ => FiellerSet::Unbounded,
        }
    };
    Ok(RatioInterval {
        estimate: point,
        level: at.level,
        fieller,
        delta_se,
        delta_df: at.df,
        delta_lower: point - at.critical * delta_se,
        delta_upper: point + at.critical * delta_se,
    })
}

/// An estimator that answered `got` estimates where `asked` were asked for.
fn unanswered(asked: usize, got: usize) -> StatsError {
    StatsError::Invalid(format!("the estimator gave {got} estimates for {asked} values of rho"))
}

/// The search for one edge of Fieller's set: from the point estimate
/// outwards, doubling the step until the excess turns positive (at most 60
/// times), then bisecting until the two ends are adjacent doubles (at most
/// 200 halvings).
#[derive(Clone)]
enum Edge {
    Grow { inside: f64, width: f64, tries: u32 },
    Bisect { inside: f64, out: f64, halvings: u32 },
    Done(Result<Option<f64>, StatsError>),
}

impl Edge {
    /// The next rho to evaluate, or `None` once the edge is found (or
    /// known not to be within reach).
    fn next(&mut self) -> Option<f64> {
        match *self {
            Edge::Grow { tries: 60, .. } => *self = Edge::Done(Ok(None)),
            Edge::Grow { inside, width, .. } => return Some(inside + width),
            Edge::Bisect { inside, out, halvings } => {
                let mid = inside + (out - inside) / 2.0;
                if halvings < 200 && mid != inside && mid != out {
                    return Some(mid);
                }
                *self = Edge::Done(Ok(Some(inside)));
            }
            Edge::Done(_) => {}
        }
        None
    }

    /// The edge after the estimate `e` at `x`, the rho `next` gave.
    fn step(&mut self, x: f64, e: Result<CrossedEstimate, StatsError>) {
        match e {
            Ok(e) => self.answer(x, excess(&e)),
            Err(e) => *self = Edge::Done(Err(e)),
        }
    }

    /// Up to `lanes` rho this edge may ask for next: its next one, then
    /// the next one after each answer it may get, level by level.
    fn ahead(&self, lanes: usize) -> Vec<f64> {
        let mut out = Vec::with_capacity(lanes);
        let mut level = std::collections::VecDeque::from([self.clone()]);
        while out.len() < lanes {
            let Some(mut edge) = level.pop_front() else { break };
            let Some(x) = edge.next() else { continue };
            out.push(x);
            for excess in [1.0, -1.0] {
                let mut after = edge.clone();
                after.answer(x, excess);
                level.push_back(after);
            }
        }
        out
    }

    /// [`Edge::step`] on an excess alone (the sign is all a step reads).
    fn answer(&mut self, x: f64, excess: f64) {
        let outside = excess > 0.0;
        *self = match *self {
            Edge::Grow { inside, .. } if outside => Edge::Bisect { inside, out: x, halvings: 0 },
            Edge::Grow { width, tries, .. } => Edge::Grow { inside: x, width: width * 2.0, tries: tries + 1 },
            Edge::Bisect { inside, halvings, .. } if outside => Edge::Bisect { inside, out: x, halvings: halvings + 1 },
            Edge::Bisect { out, halvings, .. } => Edge::Bisect { inside: x, out, halvings: halvings + 1 },
            Edge::Done(_) => return,
        };
    }

    /// Takes the steps a round answered: while the next rho is among the
    /// round's (`answered`, by its bits), its estimate is the step's.
    fn take(&mut self, answered: &mut Vec<(f64, Result<CrossedEstimate, StatsError>)>) {
        while let Some(x) = self.next() {
            let Some(k) = answered.iter().position(|(y, _)| y.to_bits() == x.to_bits()) else { break };
            let (_, e) = answered.swap_remove(k);
            self.step(x, e);
        }
    }
}

/// Both edges of Fieller's set from `from`, searched side by side: the
/// lower (steps of -`step`) and the upper; `None` for an edge not found
/// within 2^60 steps. Each round asks for `lanes` rho, shared by the
/// edges still searching (at least one each). An error in the lower
/// edge ends the search (it is the one reported); one in the upper lets the
/// lower finish, whose own error would come first.
fn roots(
    from: f64,
    step: f64,
    lanes: usize,
    estimates: &impl Fn(&[f64]) -> Vec<Result<CrossedEstimate, StatsError>>,
) -> [Result<Option<f64>, StatsError>; 2] {
    let mut edges =
        [Edge::Grow { inside: from, width: -step, tries: 0 }, Edge::Grow { inside: from, width: step, tries: 0 }];
    let done = |e: &Edge| matches!(e, Edge::Done(_));
    while !matches!(edges[0], Edge::Done(Err(_))) && !edges.iter().all(done) {
        let searching = edges.iter().filter(|e| !done(e)).count();
        let share = (lanes / searching).max(1);
        // An edge not done has a next rho (`take` leaves it waiting on
        // one, or done), so a round is never empty.
        let asked: Vec<Vec<f64>> = edges.iter().map(|e| e.ahead(share)).collect();
        let rhos: Vec<f64> = asked.concat();
        let mut got = estimates(&rhos);
        if got.len() != rhos.len() {
            let e = unanswered(rhos.len(), got.len());
            return [Err(e.clone()), Err(e)];
        }
        for (edge, xs) in edges.iter_mut().zip(&asked) {
            let mut answered: Vec<_> = xs.iter().copied().zip(got.drain(..xs.len())).collect();
            edge.take(&mut answered);
        }
    }
    edges.map(|e| match e {
        Edge::Done(found) => found,
        // Only after the lower edge's error, which is reported first.
        _ => Ok(None),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{crossed_mom, CrossedMatrix, DfRule};

    /// Fieller's closed form on an array whose moment components stay
    /// positive: Var(L(rho)) is the quadratic a + 2 b rho + c rho^2 of the
    /// untruncated mean squares, and the set's edges are the roots of
    /// (mean_d + rho mean_R)^2 = t^2 Var(L(rho)).
    #[test]
    fn fieller_matches_the_quadratic_closed_form() {
        let (rows, cols) = (6usize, 5usize);
        // Pseudo-random effects (a 64-bit LCG, uniform on [-0.5, 0.5)):
        // recording and seed effects in both arms, and noise.
        let mut u = crate::lcg_uniform(0x2545_f491_4f6c_dd1du64);
        let (ra, rb): (Vec<f64>, Vec<f64>) = ((0..rows).map(|_| u()).collect(), (0..cols).map(|_| u()).collect());
        let (ta, tb): (Vec<f64>, Vec<f64>) = ((0..rows).map(|_| u()).collect(), (0..cols).map(|_| u()).collect());
        let mut t = Vec::new();
        let mut r = Vec::new();
        for i in 0..rows {
            for j in 0..cols {
                let base = 1.0 + 0.4 * ra[i] + 0.3 * rb[j] + 0.05 * u();
                r.push(base);
                t.push(0.85 * base + 0.2 * ta[i] + 0.2 * tb[j] + 0.05 * u());
            }
        }
        let arr =
            |rho: f64| CrossedMatrix::new(rows, cols, (0..rows * cols).map(|k| t[k] - (1.0 - rho) * r[k]).collect());
        let at = |rho: f64| crossed_mom(&arr(rho)?, 0.95, DfRule::SeedsMinusOne);
        let rm = CrossedMatrix::new(rows, cols, r.clone()).unwrap();
        let reference = crossed_mom(&rm, 0.95, DfRule::SeedsMinusOne).unwrap();
        let (st, sr): (f64, f64) = (t.iter().sum(), r.iter().sum());
        let rho = (sr - st) / sr;
        let iv = ratio_interval(rho, &reference, at).unwrap();
        // Var(L(rho)) from three evaluations: a quadratic through them (the
        // components stay positive here, so no truncation bends it).
        let v = |x: f64| {
            let e = at(x).unwrap();
            let c = e.components;
            assert!(c.recording > 0.0 && c.seed > 0.0);
            e.se * e.se
        };
        let (v0, v1, vm) = (v(0.0), v(1.0), v(-1.0));
        let cq = (v1 + vm) / 2.0 - v0;
        let bq = (v1 - vm) / 2.0;
        let q = reference.critical.powi(2);
        let md = (st - sr) / (rows * cols) as f64;
        let mr = sr / (rows * cols) as f64;
        // (md + rho mr)^2 - q (v0 + bq rho + cq rho^2) = 0
        let (qa, qb, qc) = (mr * mr - q * cq, 2.0 * md * mr - q * bq, md * md - q * v0);
        let disc = (qb * qb - 4.0 * qa * qc).sqrt();
        let (lo, hi) = ((-qb - disc) / (2.0 * qa), (-qb + disc) / (2.0 * qa));
        for x in [lo, hi, rho] {
            let c = at(x).unwrap().components;
            assert!(c.recording > 0.0 && c.seed > 0.0, "truncated at {x}: {c:?}");
        }
        match iv.fieller {
            FiellerSet::Bounded { lower, upper } => {
                assert!((lower - lo).abs() < 1e-9, "{lower} vs {lo}");
                assert!((upper - hi).abs() < 1e-9, "{upper} vs {hi}");
            }
            FiellerSet::Unbounded => panic!("bounded expected"),
        }
        // The delta method is symmetric about rho_hat and, for a precisely
        // known denominator, close to Fieller.
        assert!((iv.delta_upper - rho - (rho - iv.delta_lower)).abs() < 1e-12);
        assert!((iv.delta_lower - lo).abs() < 0.2 * (hi - lo));
    }

    /// The search with both edges' arrays summed side by side and the
    /// steps ahead asked for (`ratio_interval_batched` over
    /// `mean_squares_along`, 1 to 16 lanes) gives the very intervals of the
    /// search one array at a time, under each df rule and at two levels.
    #[test]
    fn both_edges_side_by_side_give_the_same_bits() -> Result<(), StatsError> {
        use crate::{mean_squares_along, mom_from_squares};
        let (rows, cols) = (41usize, 9usize);
        let mut u = crate::lcg_uniform(0x2545_f491_4f6c_dd1du64);
        let r: Vec<f64> = (0..rows * cols).map(|k| 2.0 + 0.3 * u() + 0.01 * (k % cols) as f64).collect();
        let t: Vec<f64> = r.iter().map(|x| 0.8 * x + 0.2 * u()).collect();
        for level in [0.95, 0.999_999] {
            let r = &r;
            for rule in [DfRule::SeedsMinusOne, DfRule::Satterthwaite, DfRule::Normal] {
                let reference = crossed_mom(&CrossedMatrix::new(rows, cols, r.clone())?, level, rule)?;
                let (st, sr): (f64, f64) = (t.iter().sum(), r.iter().sum());
                let point = (sr - st) / sr;
                let alone = ratio_interval(point, &reference, |rho: f64| {
                    let l = t.iter().zip(r).map(|(t, r)| t - (1.0 - rho) * r).collect();
                    crossed_mom(&CrossedMatrix::new(rows, cols, l)?, level, rule)
                });
                for lanes in [1, 2, 3, 8, 16] {
                    let together = ratio_interval_batched(point, &reference, lanes, |rhos: &[f64]| {
                        let tables = mean_squares_along(&t, r, rows, cols, rhos);
                        tables.into_iter().map(|m| mom_from_squares(m?.0, rows, cols, level, rule)).collect()
                    });
                    assert_eq!(format!("{alone:?}"), format!("{together:?}"), "{rule:?} at {level}, {lanes} lanes");
                }
                assert!(matches!(alone, Ok(RatioInterval { fieller: FiellerSet::Bounded { .. }, .. })));
            }
        }
        Ok(())
    }

    /// An estimator's error ends the search: the lower edge's error is the
    /// one reported when both edges meet one, as when each edge was its own
    /// search.
    #[test]
    fn the_lower_edges_error_comes_first() -> Result<(), StatsError> {
        let r = [3.0, 3.2, 2.9, 3.4, 3.1, 2.8];
        let t = [2.1, 2.0, 2.0, 2.3, 2.1, 1.9];
        let rule = DfRule::Normal;
        let reference = crossed_mom(&CrossedMatrix::new(3, 2, r.to_vec())?, 0.95, rule)?;
        let rho = (r.iter().sum::<f64>() - t.iter().sum::<f64>()) / r.iter().sum::<f64>();
        let refusing = |below: f64, above: f64| {
            move |x: f64| {
                if x < below || x > above {
                    return Err(StatsError::Invalid((if x < below { "below" } else { "above" }).to_string()));
                }
                let l = t.iter().zip(&r).map(|(t, r)| t - (1.0 - x) * r).collect();
                crossed_mom(&CrossedMatrix::new(3, 2, l)?, 0.95, rule)
            }
        };
        let at = |below, above| ratio_interval(rho, &reference, refusing(below, above)).map_err(|e| e.to_string());
        let found = ratio_interval(rho, &reference, refusing(f64::MIN, f64::MAX))?;
        let Some((lower, upper)) = found.fieller.bounds() else { panic!("bounded expected") };
        assert!(at(rho - 1e-3, rho + 1e-3).is_err_and(|e| e.contains("below")));
        assert!(at(lower - 1.0, rho + 1e-3).is_err_and(|e| e.contains("above")));
        assert!(at(rho - 1e-3, upper + 1.0).is_err_and(|e| e.contains("below")));
        assert_eq!(at(lower - 1.0, upper + 1.0), Ok(found));
        Ok(())
    }

    #[test]
    fn a_reference_mean_near_zero_gives_an_unbounded_set() {
        let r = [0.1, -0.2, 0.15, -0.05, 0.0, 0.02];
        let t = [0.0, -0.1, 0.1, -0.02, 0.01, 0.0];
        let arr = |rho: f64| CrossedMatrix::new(3, 2, (0..6).map(|k| t[k] - (1.0 - rho) * r[k]).collect());
        let at = |rho: f64| crossed_mom(&arr(rho)?, 0.95, DfRule::SeedsMinusOne);
        let reference = crossed_mom(&CrossedMatrix::new(3, 2, r.to_vec()).unwrap(), 0.95, DfRule::SeedsMinusOne);
        let reference = reference.unwrap();
        let sr: f64 = r.iter().sum();
        let st: f64 = t.iter().sum();
        let iv = ratio_interval((sr - st) / sr, &reference, at).unwrap();
        assert_eq!(iv.fieller, FiellerSet::Unbounded);
        assert!(iv.fieller.contains(1e9));
    }
}
