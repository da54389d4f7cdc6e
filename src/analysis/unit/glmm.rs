//! The crossed binomial GLMM of a divergence endpoint (`glmm binomial`):
//! each cell's diverged starts as failures out of its starts, the arm as a
//! fixed effect, recording, seed and recording x seed as random
//! intercepts, fitted as lme4's `glmer` fits it
//! ([`crossaudit_stats::mixed::glmm`]).

use super::Ctx;
use crate::analysis::types::{GlmmContrast, GlmmEndpoint};
use crate::plan::AnalysisUnit;
use crossaudit_stats::mixed::glmm::{fit_glmm, GlmmData, GlmmFit};
use crossaudit_stats::mixed::slopes::Term;

/// The model, in lme4's formula language.
pub(crate) const FORMULA: &str =
    "cbind(n_divergent, n_starts - n_divergent) ~ arm + (1 | recording) + (1 | seed) + (1 | recording:seed)";

impl Ctx<'_> {
    /// The unit's GLMM, or why it has none.
    /// The fewest recordings that hold at least nine tenths of the diverged
    /// starts (both arms), most first, when they are at most a fifth of the
    /// recordings: the events that decide the odds ratio are theirs.
    fn concentrated(&self, by_recording: &[u64]) -> Vec<(String, u64)> {
        let total: u64 = by_recording.iter().sum();
        let mut order: Vec<usize> = (0..by_recording.len()).collect();
        order.sort_by(|&a, &b| by_recording[b].cmp(&by_recording[a]).then(a.cmp(&b)));
        let (mut held, mut out) = (0u64, Vec::new());
        for i in order {
            if total == 0 || 10 * held >= 9 * total {
                break;
            }
            held += by_recording[i];
            out.push((self.recordings[i].recording.clone(), by_recording[i]));
        }
        if out.len() * 5 > by_recording.len() {
            out.clear();
        }
        out
    }

    pub(super) fn glmm(&self, u: &AnalysisUnit) -> GlmmEndpoint {
        let arms = [&self.plan.contrast.treated, &self.plan.contrast.reference];
        let cols = self.plan.seeds.len();
        let (mut k, mut m, mut arm, mut rec, mut seed, mut pair) = (vec![], vec![], vec![], vec![], vec![], vec![]);
        let mut totals = [(0u64, 0u64); 2];
        let mut by_recording = vec![0u64; self.recordings.len()];
        for (a, name) in arms.iter().enumerate() {
            for (i, r) in self.recordings.iter().enumerate() {
                let Some(row) = self.data.row(&u.model, name, &r.recording, u.horizon_s) else { continue };
                for (j, c) in row.iter().enumerate() {
                    let Some(c) = c else { continue };
                    by_recording[i] += u64::from(c.n_divergent);
                    totals[a].0 += u64::from(c.n_divergent);
                    totals[a].1 += u64::from(c.n_starts);
                    k.push(c.n_divergent as f64);
                    m.push(c.n_starts as f64);
                    arm.push(if a == 0 { 1.0 } else { 0.0 });
                    rec.push(i);
                    seed.push(j);
                    pair.push(i * cols + j);
                }
            }
        }
        let [(dt, st), (dr, sr)] = totals;
        let mut out = GlmmEndpoint {
            model: FORMULA.to_string(),
            diverged_treated: dt,
            starts_treated: st,
            diverged_reference: dr,
            starts_reference: sr,
            estimate: None,
            not_estimable: None,
            concentrated: self.concentrated(&by_recording),
        };
        let separated = |d: u64, s: u64, name: &str| -> Option<String> {
            (d == 0 || d == s).then(|| {
                format!(
                    "{} of the {name} arm's {s} starts diverged, so the log odds ratio's maximum-likelihood estimate is infinite and no interval exists",
                    if d == 0 { "none" } else { "every one" }
                )
            })
        };
        out.not_estimable = separated(dt, st, arms[0]).or_else(|| separated(dr, sr, arms[1]));
        if out.not_estimable.is_some() {
            return out;
        }
        let n = k.len();
        let intercept = |group: &str, codes: Vec<usize>| {
            let levels = codes.iter().max().map_or(0, |v| v + 1);
            let names = vec!["(Intercept)".to_string()];
            let columns = vec![vec![1.0; n]];
            Term { group: group.to_string(), factor: group.to_string(), codes: dense(codes), levels, names, columns }
        };
        let terms = vec![intercept("recording", rec), intercept("seed", seed), intercept("recording:seed", pair)];
        let column = format!("arm{}", arms[0]);
        let fitted = GlmmData::binomial(k, m, vec![(column, arm)], terms).and_then(|d| fit_glmm(&d));
        match fitted {
            Ok(f) => out.estimate = Some(contrast(&f, self.plan.estimator.level)),
            Err(e) => out.not_estimable = Some(e.to_string()),
        }
        out
    }
}

/// The arm's effect (the second fixed effect) of a fitted GLMM, with its
/// Wald interval at `level`, and the three standard deviations.
fn contrast(f: &GlmmFit, level: f64) -> GlmmContrast {
    let b = &f.fixed[1];
    let normal = statrs::distribution::Normal::standard();
    let z = statrs::distribution::ContinuousCDF::inverse_cdf(&normal, 0.5 + level / 2.0);
    let (lower, upper) = (b.estimate - z * b.se, b.estimate + z * b.se);
    let sd = |group: &str| f.terms.iter().find(|t| t.factor == group).map_or(f64::NAN, |t| t.sd[0]);
    GlmmContrast {
        log_odds_ratio: b.estimate,
        se: b.se,
        z: b.z,
        p: b.p,
        lower,
        upper,
        odds_ratio: b.estimate.exp(),
        odds_ratio_lower: lower.exp(),
        odds_ratio_upper: upper.exp(),
        sd_recording: sd("recording"),
        sd_seed: sd("seed"),
        sd_recording_seed: sd("recording:seed"),
        deviance: f.deviance,
        certified: f.certificate.certified,
        singular: f.singular,
    }
}

/// Codes renumbered from 0 in order of first appearance.
fn dense(codes: Vec<usize>) -> Vec<usize> {
    let mut seen = std::collections::HashMap::new();
    codes
        .into_iter()
        .map(|c| {
            let next = seen.len();
            *seen.entry(c).or_insert(next)
        })
        .collect()
}
