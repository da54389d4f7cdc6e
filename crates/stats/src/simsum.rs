//! rsimsum's performance measures on anyone's replications: a simulation
//! study's estimates (with SEs, and optionally interval limits and df)
//! per method, replication and group of by-factors, scored as R's rsimsum
//! 0.13 (`simsum`, White 2010; Morris, White & Crowther 2019, Table 6)
//! scores them, with two differences, both said in the output:
//!
//! - methods are paired **by replication id**, not by row order, for the
//!   relative precision's correlation and for the paired differences; a
//!   file without ids is paired by order within each group, as rsimsum
//!   does, and [`Group::paired_by`] says so;
//! - each method is also compared with the reference method replication
//!   by replication: the difference in coverage, bias, mean interval
//!   width and interval score with its **paired** Monte Carlo SE (the SD of
//!   the per-replication differences over sqrt(n)), which two separate
//!   MCSEs overstate when the methods are correlated.
//!
//! Two measures rsimsum lacks: the interval score (Gneiting & Raftery
//! 2007, eq. 43: width plus 2 / alpha times the distance by which the
//! interval misses the truth, alpha = 1 - level; lower is better, and it
//! rewards narrow intervals only while they cover), and a coverage MCSE
//! that is not 0 at coverage 0 or 1: Agresti and Coull's, the SE of
//! (x + 2) / (n + 4) for x covering intervals out of n. rsimsum's
//! sqrt(p (1 - p) / n) says a coverage of 100 out of 100 is known exactly;
//! the adjusted one says how far it could be from 1, and +/- 1.96 of it
//! about the adjusted share is Agresti and Coull's 95% interval.
//!
//! Where no interval limits are given, the interval is estimate +/- c SE,
//! c the t quantile at the row's df where given, else the normal's
//! (rsimsum's rule); power is always |estimate| >= z SE (rsimsum's
//! default). A replication with a missing estimate, SE or limit is left
//! out of its method's measures and counted in `undefined`.
//!
//! ```
//! use crossaudit_stats::simsum::{simsum, Replication};
//! let reps: Vec<Replication> = (0..4)
//!     .flat_map(|r| {
//!         ["A", "B"].into_iter().map(move |m| Replication {
//!             by: vec![],
//!             method: m.to_string(),
//!             rep: Some(r.to_string()),
//!             estimate: 1.0 + 0.1 * r as f64 + if m == "B" { 0.05 } else { 0.0 },
//!             se: 0.2,
//!             limits: None,
//!             df: None,
//!             truth: 1.0,
//!             level: 0.95,
//!         })
//!     })
//!     .collect();
//! let groups = simsum(&reps, Some("A")).unwrap();
//! let b = &groups[0].methods[1];
//! assert_eq!(b.method, "B");
//! // B is A shifted by 0.05 in every replication: the paired bias
//! // difference is exact, its paired MCSE 0.
//! let d = b.versus_reference.as_ref().unwrap();
//! assert!((d.bias_diff - 0.05).abs() < 1e-12 && d.bias_diff_mcse.abs() < 1e-12);
//! ```

use std::collections::BTreeMap;

use crate::coverage::{performance_each, Estimate, Performance, Truth};
use crate::IntervalMethod;

/// One method's result in one replication.
#[derive(Debug, Clone, PartialEq)]
pub struct Replication {
    /// The values of the by-factors (the same order in every replication).
    pub by: Vec<String>,
    /// The method.
    pub method: String,
    /// The replication id; `None` where the file has none.
    pub rep: Option<String>,
    /// The estimate (NaN: missing).
    pub estimate: f64,
    /// Its standard error (NaN: missing).
    pub se: f64,
    /// Interval limits, where the file gives them.
    pub limits: Option<(f64, f64)>,
    /// Degrees of freedom, where given (NaN: infinite).
    pub df: Option<f64>,
    /// The true value (it may differ between replications: rsimsum's
    /// `true` as a column).
    pub truth: f64,
    /// The intervals' nominal level.
    pub level: f64,
}

/// How a group's methods were paired.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Pairing {
    /// By replication id.
    Id,
    /// By order within the group (no ids): rsimsum's rule.
    Order,
}

/// A method against the reference method, replication by replication.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Paired {
    /// Replications where both are usable.
    pub pairs: usize,
    /// Coverage of this method minus the reference's.
    pub coverage_diff: f64,
    /// Its paired Monte Carlo SE; where no pair disagrees, Agresti & Min's
    /// (2005) 1 / (pairs + 2) instead of 0.
    pub coverage_diff_mcse: f64,
    /// Bias (equally: mean estimate) of this method minus the reference's.
    pub bias_diff: f64,
    /// Its paired Monte Carlo SE.
    pub bias_diff_mcse: f64,
    /// Mean interval width of this method minus the reference's.
    pub width_diff: f64,
    /// Its paired Monte Carlo SE.
    pub width_diff_mcse: f64,
    /// Mean interval score of this method minus the reference's.
    pub score_diff: f64,
    /// Its paired Monte Carlo SE.
    pub score_diff_mcse: f64,
}

/// One method's measures in one group.
#[derive(Debug, Clone)]
pub struct MethodPerformance {
    /// The method.
    pub method: String,
    /// rsimsum's measures (and crossaudit's further ones: widths, misses,
    /// rejection, type S) with their MCSEs; `setting` holds the group's
    /// by-values, `method` is a placeholder (the name is [`Self::method`]).
    pub performance: Performance,
    /// Mean interval score (Gneiting & Raftery 2007) and its MCSE.
    pub interval_score: (f64, f64),
    /// Agresti and Coull's MCSE of the coverage: the SE of (x + 2) / (n + 4).
    pub coverage_mcse_adjusted: f64,
    /// Against the reference method (None for the reference itself).
    pub versus_reference: Option<Paired>,
}

/// One group: one combination of by-values and level (the true value may
/// differ between its replications, as rsimsum allows).
#[derive(Debug, Clone)]
pub struct Group {
    /// The by-values.
    pub by: Vec<String>,
    /// The true value, where every replication of the group has the same;
    /// `None` where each has its own (each measure then uses each
    /// replication's, as rsimsum does).
    pub truth: Option<f64>,
    /// The nominal level.
    pub level: f64,
    /// The reference method (relative precision and paired differences).
    pub reference: String,
    /// How methods were paired.
    pub paired_by: Pairing,
    /// Every method, in the order first seen.
    pub methods: Vec<MethodPerformance>,
}

/// Why replications cannot be summarised.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimsumError {
    /// No replications.
    #[error("no replications")]
    Empty,
    /// The reference method does not occur in a group.
    #[error("the reference method `{reference}` has no replications in group {group}")]
    NoReference {
        /// The method asked for.
        reference: String,
        /// The group, as by-values.
        group: String,
    },
    /// A replication id occurs twice for one method in one group.
    #[error("replication {rep} of method `{method}` occurs twice in group {group}{}", if *.truths_differ { " (with different true values: where each true value is a data-generating mechanism of its own, add the true value's column to the by-factors, as rsimsum's `by`)" } else { "" })]
    DuplicateRep {
        /// The id.
        rep: String,
        /// The method.
        method: String,
        /// The group.
        group: String,
        /// Whether the two rows have different true values.
        truths_differ: bool,
    },
}

type Key = (Vec<String>, u64);

/// The measures of every method in every group (by-values and level; a
/// true value that varies between replications is each replication's, as
/// in rsimsum, not a group of its own), groups in the order first seen. `reference` names the method
/// others are compared with; by default each group's first.
pub fn simsum(reps: &[Replication], reference: Option<&str>) -> Result<Vec<Group>, SimsumError> {
    if reps.is_empty() {
        return Err(SimsumError::Empty);
    }
    let mut order: Vec<Key> = Vec::new();
    let mut groups: BTreeMap<Key, Vec<&Replication>> = BTreeMap::new();
    for r in reps {
        let key = (r.by.clone(), r.level.to_bits());
        let g = groups.entry(key.clone()).or_default();
        if g.is_empty() {
            order.push(key);
        }
        g.push(r);
    }
    order.iter().map(|key| group(&groups[key], reference)).collect()
}

fn group(rows: &[&Replication], reference: Option<&str>) -> Result<Group, SimsumError> {
    let first = rows[0];
    let label = if first.by.is_empty() { "(all)".to_string() } else { first.by.join(" / ") };
    let paired_by = if rows.iter().all(|r| r.rep.is_some()) { Pairing::Id } else { Pairing::Order };
    // Per method, in the order first seen: replications keyed by id (or
    // position), in file order. One pass over the rows, each method found
    // by its name's index: linear however many methods there are.
    let mut index: BTreeMap<&str, usize> = BTreeMap::new();
    let mut by_method: Vec<(&str, Vec<(String, Estimate)>)> = Vec::new();
    let mut truths: Vec<Vec<f64>> = Vec::new();
    let mut seen: Vec<std::collections::BTreeSet<String>> = Vec::new();
    for r in rows {
        let m = r.method.as_str();
        let k = *index.entry(m).or_insert_with(|| {
            by_method.push((m, Vec::new()));
            truths.push(Vec::new());
            seen.push(Default::default());
            by_method.len() - 1
        });
        let id = match (&r.rep, paired_by) {
            (Some(id), Pairing::Id) => id.clone(),
            _ => by_method[k].1.len().to_string(),
        };
        if !seen[k].insert(id.clone()) {
            let earlier = rows.iter().find(|o| o.method == r.method && o.rep.as_deref() == Some(id.as_str()));
            let truths_differ = earlier.is_some_and(|o| o.truth.to_bits() != r.truth.to_bits());
            return Err(SimsumError::DuplicateRep { rep: id, method: m.to_string(), group: label, truths_differ });
        }
        by_method[k].1.push((id, interval(r)));
        truths[k].push(r.truth);
    }
    let reference = reference.unwrap_or(by_method[0].0).to_string();
    let Some(&at) = index.get(reference.as_str()) else {
        return Err(SimsumError::NoReference { reference, group: label });
    };
    let reference_reps: &[(String, Estimate)] = &by_method[at].1;
    let reference_by_id: BTreeMap<&str, (&Estimate, f64)> =
        reference_reps.iter().zip(&truths[at]).map(|((id, e), t)| (id.as_str(), (e, *t))).collect();
    // One truth for the group, or each replication's own.
    let one = rows.iter().all(|r| r.truth.to_bits() == first.truth.to_bits()).then_some(first.truth);
    let usable_theta = |l: &[(String, Estimate)]| -> Vec<f64> {
        l.iter().filter(|(_, e)| crate::coverage::usable(e)).map(|(_, e)| e.0).collect()
    };
    let empse_ref = crate::sample_variance(&usable_theta(reference_reps)).sqrt();
    let mut out = Vec::new();
    for ((m, list), own) in by_method.iter().zip(&truths) {
        let est: Vec<Estimate> = list.iter().map(|(_, e)| *e).collect();
        let truth = match one {
            Some(t) => Truth::One(t),
            None => Truth::Each(own),
        };
        let mut p = performance_each(&label, IntervalMethod::MomT, &est, &[], truth, first.level);
        let pairs = paired(&reference_by_id, list, own);
        let ratio2 = (empse_ref / p.emp_se).powi(2);
        p.rel_precision = 100.0 * (ratio2 - 1.0);
        let rho = crate::coverage::correlation(&pairs.iter().map(|((a, _), (b, _))| (a.0, b.0)).collect::<Vec<_>>());
        p.rel_precision_mcse = 200.0 * ratio2 * ((1.0 - rho * rho).max(0.0) / (p.reps as f64 - 1.0)).sqrt();
        let versus_reference = (*m != reference).then(|| differences(&pairs, first.level));
        let scores: Vec<f64> = est
            .iter()
            .zip(own)
            .filter(|(e, _)| crate::coverage::usable(e))
            .map(|(e, t)| score(e, *t, first.level))
            .collect();
        let interval_score = mean_and_mcse(&scores);
        let (n, x) = (p.reps as f64, p.coverage * p.reps as f64);
        let adjusted = (x.round() + 2.0) / (n + 4.0);
        let coverage_mcse_adjusted = (adjusted * (1.0 - adjusted) / (n + 4.0)).sqrt();
        out.push(MethodPerformance {
            method: m.to_string(),
            performance: p,
            interval_score,
            coverage_mcse_adjusted,
            versus_reference,
        });
    }
    Ok(Group { by: first.by.clone(), truth: one, level: first.level, reference, paired_by, methods: out })
}

/// A replication as (estimate, SE, lower, upper): its limits, or estimate
/// +/- c SE with c the t quantile at its df (the normal's without one).
fn interval(r: &Replication) -> Estimate {
    let (lower, upper) = match r.limits {
        Some(l) => l,
        None => {
            let df = r.df.unwrap_or(f64::INFINITY);
            let df = if df.is_nan() { f64::INFINITY } else { df };
            let c = crate::critical_value(r.level, df).unwrap_or(f64::NAN);
            (r.estimate - c * r.se, r.estimate + c * r.se)
        }
    };
    (r.estimate, r.se, lower, upper)
}

/// An estimate and the true value of its replication.
type AtTruth = (Estimate, f64);

/// The replications both methods estimated, matched by id, each with its
/// own replication's truth (`mine_truths` parallel to `mine`).
fn paired(
    theirs: &BTreeMap<&str, (&Estimate, f64)>,
    mine: &[(String, Estimate)],
    mine_truths: &[f64],
) -> Vec<(AtTruth, AtTruth)> {
    mine.iter()
        .zip(mine_truths)
        .filter_map(|((id, e), t)| theirs.get(id.as_str()).map(|(r, rt)| ((**r, *rt), (*e, *t))))
        .filter(|((a, _), (b, _))| crate::coverage::usable(a) && crate::coverage::usable(b))
        .collect()
}

/// The interval score of `[lower, upper]` at `truth`, alpha = 1 - level
/// (Gneiting & Raftery 2007, eq. 43).
fn score(e: &Estimate, truth: f64, level: f64) -> f64 {
    let alpha = 1.0 - level;
    (e.3 - e.2) + 2.0 / alpha * ((e.2 - truth).max(0.0) + (truth - e.3).max(0.0))
}

/// The mean and its MCSE, SD / sqrt(n) (NaN from fewer than 2).
fn mean_and_mcse(d: &[f64]) -> (f64, f64) {
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let mcse = if d.len() >= 2 { (crate::sample_variance(d) / n).sqrt() } else { f64::NAN };
    (mean, mcse)
}

fn differences(pairs: &[(AtTruth, AtTruth)], level: f64) -> Paired {
    let of = |f: &dyn Fn(&AtTruth, &AtTruth) -> f64| -> (f64, f64) {
        mean_and_mcse(&pairs.iter().map(|(a, b)| f(a, b)).collect::<Vec<_>>())
    };
    let covers = |(e, t): &AtTruth| f64::from(u8::from(e.2 <= *t && *t <= e.3));
    let (coverage_diff, mut coverage_diff_mcse) = of(&|a, b| covers(b) - covers(a));
    // No pair disagrees: the SD of the differences is 0, and an MCSE of 0
    // would claim the two coverages equal without error. Agresti & Min's
    // (2005) half a pair added to each cell of the 2 x 2 table gives the
    // paired difference's SE at b = c = 1/2 of n + 2 pairs:
    // sqrt((b + c) - (b - c)^2 / n) / n = 1 / (n + 2).
    if !pairs.is_empty() && pairs.iter().all(|(a, b)| covers(a) == covers(b)) {
        coverage_diff_mcse = 1.0 / (pairs.len() as f64 + 2.0);
    }
    // Bias difference: (b - tb) - (a - ta); with one truth, b - a.
    let (bias_diff, bias_diff_mcse) =
        of(&|(a, ta), (b, tb)| if ta.to_bits() == tb.to_bits() { b.0 - a.0 } else { (b.0 - tb) - (a.0 - ta) });
    let (width_diff, width_diff_mcse) = of(&|(a, _), (b, _)| (b.3 - b.2) - (a.3 - a.2));
    let (score_diff, score_diff_mcse) = of(&|(a, ta), (b, tb)| score(b, *tb, level) - score(a, *ta, level));
    Paired {
        pairs: pairs.len(),
        coverage_diff,
        coverage_diff_mcse,
        bias_diff,
        bias_diff_mcse,
        width_diff,
        width_diff_mcse,
        score_diff,
        score_diff_mcse,
    }
}
