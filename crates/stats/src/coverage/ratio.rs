//! Monte Carlo coverage of the optimism's intervals: Fieller's set and the
//! delta method's interval of rho = (mean_R - mean_T) / mean_R
//! ([`crate::ratio_interval`]), from the paper's estimator (the crossed
//! method of moments with t(J - 1)).
//!
//! Each replication draws a reference array R and a contrast array
//! D = T - R per recording r and seed s,
//!
//! R_rs = m_R + a_r + b_s + e_rs,   D_rs = m_D + a'_r + b'_s + e'_rs,
//!
//! each term's pair (a_r, a'_r), (b_s, b'_s), (e_rs, e'_rs) bivariate
//! normal with its declared variances and correlation, and T = R + D. The
//! true optimism is -m_D / m_R. Replications run in parallel, each on its
//! own ChaCha8 stream of the setting's seed, so the result does not depend
//! on the thread count.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::{crossed_mom, ratio_interval, standard_normal, CrossedMatrix, DfRule, FiellerSet, StatsError};

/// One value per term of a crossed array: recording, seed, residual.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Terms {
    /// The recording term.
    pub recording: f64,
    /// The seed term.
    pub seed: f64,
    /// The residual term.
    pub residual: f64,
}

impl Terms {
    fn all(&self) -> [f64; 3] {
        [self.recording, self.seed, self.residual]
    }
}

/// One setting of the ratio study.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RatioSetting {
    /// Its name in the tables.
    pub label: String,
    /// Recordings I.
    pub rows: usize,
    /// Seeds J.
    pub cols: usize,
    /// The reference arm's true mean m_R.
    pub mean_reference: f64,
    /// The contrast's true mean m_D (treated minus reference).
    pub mean_d: f64,
    /// The reference arm's variance components.
    pub reference: Terms,
    /// The contrast's variance components.
    pub d: Terms,
    /// The correlation of each term of D with the same term of R.
    pub correlation: Terms,
}

impl RatioSetting {
    /// The true optimism, -m_D / m_R (a share; 100 times it in percent).
    pub fn optimism(&self) -> f64 {
        -self.mean_d / self.mean_reference
    }

    /// Why the setting cannot be simulated, if it cannot.
    pub fn check(&self) -> Result<(), String> {
        if self.rows < 2 || self.cols < 2 || self.rows as f64 * self.cols as f64 > 1e6 {
            return Err(format!(
                "`rows` and `cols` must be at least 2 with at most 1e6 cells, found {} x {}",
                self.rows, self.cols
            ));
        }
        if !(self.mean_reference.is_finite() && self.mean_reference != 0.0 && self.mean_d.is_finite()) {
            return Err(format!(
                "`mean_reference` must be finite and not 0 and `mean_d` finite, found {} and {}",
                self.mean_reference, self.mean_d
            ));
        }
        let variances = self.reference.all().into_iter().chain(self.d.all());
        if variances.into_iter().any(|v| !(v.is_finite() && v >= 0.0)) || self.d.residual <= 0.0 {
            return Err("every variance must be finite and at least 0, the contrast's residual above 0".into());
        }
        if self.correlation.all().iter().any(|c| c.is_nan() || c.abs() > 1.0) {
            return Err(format!("every correlation must be in [-1, 1], found {:?}", self.correlation.all()));
        }
        Ok(())
    }
}

/// How one interval of the optimism performed in one setting, in percent.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RatioPerformance {
    /// The setting's label.
    pub setting: String,
    /// `fieller` or `delta`.
    pub method: String,
    /// The true optimism, %.
    pub true_optimism_pct: f64,
    /// Replications with an interval.
    pub reps: usize,
    /// Replications without one (the reference mean's estimate was 0).
    pub failed: usize,
    /// Share of intervals (sets) holding the true optimism; an unbounded
    /// Fieller set holds it.
    pub coverage: f64,
    /// Its Monte Carlo SE, sqrt(p (1 - p) / n).
    pub coverage_mcse: f64,
    /// Share wholly below the truth (the optimism understated).
    pub miss_below: f64,
    /// Share wholly above the truth (the optimism overstated).
    pub miss_above: f64,
    /// Share of Fieller sets that are unbounded (0 for the delta method).
    pub unbounded: f64,
    /// Mean width of the bounded intervals, percentage points.
    pub mean_width: f64,
    /// Its Monte Carlo SE.
    pub width_mcse: f64,
    /// Mean estimate minus the truth, percentage points.
    pub bias: f64,
    /// SD of the estimates.
    pub empirical_se: f64,
    /// Mean of the delta method's SE.
    pub model_se: f64,
}

/// A replication's estimate and bounds (`None`: an unbounded set).
type Scored = (f64, Option<(f64, f64)>);

/// One replication: the optimism's estimate and intervals, or `None`
/// where the reference mean's estimate is 0.
type Draw = Option<(f64, FiellerSet, f64, f64, f64)>;

/// The seed of a setting: the first 8 bytes of the SHA-256 of the base
/// seed and every value of the setting (their bits), so that adding or
/// reordering settings changes no other setting.
pub fn ratio_seed(base: u64, s: &RatioSetting) -> u64 {
    use sha2::{Digest, Sha256};
    let bits: Vec<String> = [s.mean_reference, s.mean_d]
        .into_iter()
        .chain(s.reference.all())
        .chain(s.d.all())
        .chain(s.correlation.all())
        .map(|v| format!("{:016x}", v.to_bits()))
        .collect();
    let text = format!("crossaudit ratio coverage seed 1|{base}|{}|{}|{}", s.rows, s.cols, bits.join(" "));
    let digest = Sha256::digest(text.as_bytes());
    let mut first = [0u8; 8];
    first.copy_from_slice(&digest[..8]);
    u64::from_le_bytes(first)
}

/// The arrays R and D of one replication.
fn draw_arrays(s: &RatioSetting, rng: &mut ChaCha8Rng) -> (Vec<f64>, Vec<f64>) {
    // One term's pair: (sqrt(vR) z1, sqrt(vD) (c z1 + sqrt(1 - c^2) z2)).
    let mut pair = |vr: f64, vd: f64, c: f64| {
        let (z1, z2) = (standard_normal(rng), standard_normal(rng));
        (vr.sqrt() * z1, vd.sqrt() * (c * z1 + (1.0 - c * c).max(0.0).sqrt() * z2))
    };
    let (r, d, c) = (&s.reference, &s.d, &s.correlation);
    let a: Vec<(f64, f64)> = (0..s.rows).map(|_| pair(r.recording, d.recording, c.recording)).collect();
    let b: Vec<(f64, f64)> = (0..s.cols).map(|_| pair(r.seed, d.seed, c.seed)).collect();
    let mut reference = Vec::with_capacity(s.rows * s.cols);
    let mut contrast = Vec::with_capacity(s.rows * s.cols);
    for ai in &a {
        for bj in &b {
            let e = pair(r.residual, d.residual, c.residual);
            reference.push(s.mean_reference + ai.0 + bj.0 + e.0);
            contrast.push(s.mean_d + ai.1 + bj.1 + e.1);
        }
    }
    (reference, contrast)
}

/// One replication's estimate (a share), Fieller's set, and the delta
/// method's SE and interval.
fn replicate(s: &RatioSetting, level: f64, rng: &mut ChaCha8Rng) -> Result<Draw, StatsError> {
    let (reference, contrast) = draw_arrays(s, rng);
    let n = reference.len() as f64;
    let (mr, md) = (reference.iter().sum::<f64>() / n, contrast.iter().sum::<f64>() / n);
    if mr == 0.0 {
        return Ok(None);
    }
    let rule = DfRule::SeedsMinusOne;
    let r_est = crossed_mom(&CrossedMatrix::new(s.rows, s.cols, reference.clone())?, level, rule)?;
    // L(rho) = T - (1 - rho) R = D + rho R.
    let at = |rho: f64| {
        let l = contrast.iter().zip(&reference).map(|(d, r)| d + rho * r).collect();
        crossed_mom(&CrossedMatrix::new(s.rows, s.cols, l)?, level, rule)
    };
    let iv = ratio_interval(-md / mr, &r_est, at)?;
    Ok(Some((iv.estimate, iv.fieller, iv.delta_se, iv.delta_lower, iv.delta_upper)))
}

/// Runs `reps` replications of one setting at `level` and scores Fieller's
/// set and the delta method's interval against the true optimism.
pub fn simulate_ratio(
    s: &RatioSetting,
    reps: usize,
    level: f64,
    base_seed: u64,
) -> Result<[RatioPerformance; 2], StatsError> {
    s.check().map_err(StatsError::Invalid)?;
    let seed = ratio_seed(base_seed, s);
    let draws: Vec<Draw> = (0..reps)
        .into_par_iter()
        .map(|r| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(r as u64);
            replicate(s, level, &mut rng)
        })
        .collect::<Result<_, _>>()?;
    let got: Vec<_> = draws.iter().flatten().copied().collect();
    let truth = s.optimism();
    let fieller: Vec<Scored> = got.iter().map(|g| (g.0, g.1.bounds())).collect();
    let delta: Vec<Scored> = got.iter().map(|g| (g.0, Some((g.3, g.4)))).collect();
    let model_se = got.iter().map(|g| g.2).sum::<f64>() / got.len().max(1) as f64;
    let failed = reps - got.len();
    Ok([score(s, "fieller", &fieller, truth, failed, model_se), score(s, "delta", &delta, truth, failed, model_se)])
}

/// The measures of one method's (estimate, bounds) over the replications,
/// `None` bounds an unbounded set; in percent.
fn score(s: &RatioSetting, method: &str, got: &[Scored], truth: f64, failed: usize, model_se: f64) -> RatioPerformance {
    let n = got.len().max(1) as f64;
    let share = |f: &dyn Fn(&Scored) -> bool| got.iter().filter(|g| f(g)).count() as f64 / n;
    let coverage = share(&|g| g.1.is_none_or(|(lo, hi)| lo <= truth && truth <= hi));
    let widths: Vec<f64> = got.iter().filter_map(|g| g.1.map(|(lo, hi)| 100.0 * (hi - lo))).collect();
    let mean_width = widths.iter().sum::<f64>() / widths.len().max(1) as f64;
    let estimates: Vec<f64> = got.iter().map(|g| 100.0 * g.0).collect();
    let mean = estimates.iter().sum::<f64>() / n;
    RatioPerformance {
        setting: s.label.clone(),
        method: method.to_string(),
        true_optimism_pct: 100.0 * truth,
        reps: got.len(),
        failed,
        coverage,
        coverage_mcse: (coverage * (1.0 - coverage) / n).sqrt(),
        miss_below: share(&|g| g.1.is_some_and(|(_, hi)| hi < truth)),
        miss_above: share(&|g| g.1.is_some_and(|(lo, _)| lo > truth)),
        unbounded: share(&|g| g.1.is_none()),
        mean_width,
        width_mcse: (crate::sample_variance(&widths) / widths.len().max(1) as f64).sqrt(),
        bias: mean - 100.0 * truth,
        empirical_se: crate::sample_variance(&estimates).sqrt(),
        model_se: 100.0 * model_se,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn setting(correlation: f64) -> RatioSetting {
        RatioSetting {
            label: "t".into(),
            rows: 200,
            cols: 200,
            mean_reference: 3.0,
            mean_d: -0.3,
            reference: Terms { recording: 0.0, seed: 0.0, residual: 1.0 },
            d: Terms { recording: 0.0, seed: 0.0, residual: 4.0 },
            correlation: Terms { recording: 0.0, seed: 0.0, residual: correlation },
        }
    }

    /// 40,000 residual pairs: their means, variances and correlation are
    /// the declared ones within 4 of their standard errors (var 1 and 4:
    /// SE sqrt(2/n) relative; the correlation's SE (1 - c^2)/sqrt(n)).
    #[test]
    fn the_arrays_have_the_declared_moments() {
        let s = setting(0.5);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (r, d) = draw_arrays(&s, &mut rng);
        let n = r.len() as f64;
        let (mr, md) = (r.iter().sum::<f64>() / n, d.iter().sum::<f64>() / n);
        assert!((mr - 3.0).abs() < 4.0 / n.sqrt() && (md + 0.3).abs() < 4.0 * 2.0 / n.sqrt(), "{mr} {md}");
        let vr = r.iter().map(|x| (x - mr).powi(2)).sum::<f64>() / (n - 1.0);
        let vd = d.iter().map(|x| (x - md).powi(2)).sum::<f64>() / (n - 1.0);
        let c = r.iter().zip(&d).map(|(x, y)| (x - mr) * (y - md)).sum::<f64>() / (n - 1.0) / (vr * vd).sqrt();
        let rel = 4.0 * (2.0 / n).sqrt();
        assert!((vr - 1.0).abs() < rel && (vd / 4.0 - 1.0).abs() < rel, "{vr} {vd}");
        assert!((c - 0.5).abs() < 4.0 * 0.75 / n.sqrt(), "{c}");
    }

    /// The true optimism is -m_D / m_R, and a bad setting is refused.
    #[test]
    fn settings_are_checked() {
        let s = setting(0.0);
        assert!((s.optimism() - 0.1).abs() < 1e-15);
        assert!(s.check().is_ok());
        assert!(setting(1.5).check().unwrap_err().contains("correlation"));
        let zero = RatioSetting { mean_reference: 0.0, ..setting(0.0) };
        assert!(zero.check().unwrap_err().contains("`mean_reference` must be finite and not 0"));
    }
}
