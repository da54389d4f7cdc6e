//! `crossaudit coverage SPEC` with `"kind": "draws"`: how well intervals
//! cover the protocol-level mean when a study has a draw component (the
//! randomness of everything after the evaluation recordings: validation,
//! fit and contamination windows, rollout starts), which one run samples
//! once. The model is
//!
//! d_rsk = mu + a_r + b_s + c_k + (ac)_rk + (bc)_sk + e_rsk,
//!
//! recordings r, seeds s, draws k, every term normal with its declared
//! variance; the estimand is mu. Four intervals are compared on the same
//! replications:
//!
//! - `single_draw_t`: one draw's recordings x seeds array, crossed method
//!   of moments with t(J - 1) (the paper's interval);
//! - `per_seed_draws_t`: each seed its own draw (seed s in draw s), the same
//!   estimator on the resulting array (`draws per seed`);
//! - `pooled_reml_kr` and `pooled_reml_satterthwaite`: K whole draws,
//!   REML over recording, seed, draw, recording:draw and seed:draw
//!   (`factor draw`), with Kenward-Roger's or Satterthwaite's df.
//!
//! Each setting's replications are seeded by a hash of its label and
//! values, so adding or reordering settings changes no other setting.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::coverage::CoverageError;
use crate::io::{create_dir_all, write_atomic};
use crossaudit_stats::mixed::{self, Criterion, MixedData};
use crossaudit_stats::{crossed_mom, standard_normal, CrossedMatrix, DfRule};

/// Variances of the model's terms (in squared units of d).
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DrawVariances {
    /// a_r.
    pub recording: f64,
    /// b_s.
    pub seed: f64,
    /// c_k.
    pub draw: f64,
    /// (ac)_rk.
    pub recording_draw: f64,
    /// (bc)_sk.
    pub seed_draw: f64,
    /// e_rsk.
    pub residual: f64,
}

impl DrawVariances {
    fn all(&self) -> [f64; 6] {
        [self.recording, self.seed, self.draw, self.recording_draw, self.seed_draw, self.residual]
    }
}

/// One setting: sizes and variances.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DrawSetting {
    /// Its name in the tables.
    pub label: String,
    /// Recordings I.
    pub rows: usize,
    /// Seeds J.
    pub cols: usize,
    /// Whole draws K of the pooled design.
    pub draws: usize,
    /// The true variances.
    pub variances: DrawVariances,
}

/// A draw-coverage study.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DrawCoverageSpec {
    /// Must be `"draws"`.
    pub kind: String,
    /// Mixed into every setting's seed.
    pub seed: u64,
    /// Replications per setting.
    pub reps: usize,
    /// Nominal level.
    pub level: f64,
    /// Where the variances come from (free text, shown in the report).
    #[serde(default)]
    pub source: String,
    /// The settings.
    pub settings: Vec<DrawSetting>,
}

/// The most settings one spec may list.
const MAX_DRAW_SETTINGS: usize = 100;
/// The most cells fitted in all (reps x rows x cols x draws, summed over
/// the settings): the committed study (`specs/coverage_draws.json`, 3.8e6)
/// took 15 minutes on two cores, so this bounds a study to about 6 hours.
const MAX_DRAW_WORK: f64 = 1e8;

/// The interval methods compared.
pub const METHODS: [&str; 4] = ["single_draw_t", "per_seed_draws_t", "pooled_reml_kr", "pooled_reml_satterthwaite"];

/// One method's performance in one setting.
#[derive(Debug, Clone, Serialize)]
pub struct DrawPerformance {
    /// The setting's label.
    pub setting: String,
    /// The method.
    pub method: String,
    /// Replications with an interval.
    pub reps: usize,
    /// Replications without one (a fit that failed or was not certified).
    pub failed: usize,
    /// Share of intervals containing mu.
    pub coverage: f64,
    /// Its Monte Carlo SE, sqrt(p (1 - p) / reps).
    pub coverage_mcse: f64,
    /// Misses with the whole interval below mu, and above.
    pub below: f64,
    /// Misses above.
    pub above: f64,
    /// Mean interval width.
    pub mean_width: f64,
    /// Its Monte Carlo SE.
    pub width_mcse: f64,
    /// Mean estimate minus mu.
    pub bias: f64,
    /// SD of the estimates over replications.
    pub empirical_se: f64,
    /// Mean of the reported SEs.
    pub model_se: f64,
    /// Mean df.
    pub mean_df: f64,
    /// The true SE of the estimator's mean under the model (closed form),
    /// where one exists.
    pub true_se: Option<f64>,
}

/// One replication's interval: (estimate, SE, df, lower, upper).
type Interval = (f64, f64, f64, f64, f64);

impl DrawCoverageSpec {
    /// Reads and checks a spec (`kind` must be `draws`).
    pub fn from_text(path: &Path, text: &str) -> Result<DrawCoverageSpec, CoverageError> {
        let spec: DrawCoverageSpec = super::coverage::parse_spec(path, text)?;
        spec.validate(path)?;
        Ok(spec)
    }

    /// Checks the spec (also after a command-line override of `reps`).
    pub fn validate(&self, path: &Path) -> Result<(), CoverageError> {
        let spec = self;
        let bad = |message: String| Err(CoverageError::Invalid { path: path.display().to_string(), message });
        if spec.kind != "draws" {
            return bad(format!("`kind` must be \"draws\", found {:?}", spec.kind));
        }
        if spec.reps < 2 || spec.reps > 100_000 {
            return bad(format!("`reps` must be from 2 to 100000, found {}", spec.reps));
        }
        if !(spec.level > 0.0 && spec.level < 1.0) {
            return bad(format!("`level` must be in (0, 1), found {}", spec.level));
        }
        if spec.settings.is_empty() || spec.settings.len() > MAX_DRAW_SETTINGS {
            return bad(format!("`settings` needs 1 to {MAX_DRAW_SETTINGS} settings, found {}", spec.settings.len()));
        }
        let mut work = 0.0;
        for s in &spec.settings {
            // In f64: sizes near 2^64 overflow any integer product.
            let cells = s.rows as f64 * s.cols as f64 * s.draws as f64;
            if s.rows < 2 || s.cols < 2 || s.draws < 2 || cells > 200_000.0 {
                return bad(format!(
                    "setting {:?}: `rows`, `cols` and `draws` must each be at least 2, with at most 200000 cells, found {} x {} x {}",
                    s.label, s.rows, s.cols, s.draws
                ));
            }
            if s.variances.all().iter().any(|v| !(v.is_finite() && *v >= 0.0)) || s.variances.residual <= 0.0 {
                return bad(format!(
                    "setting {:?}: every variance must be finite and non-negative, the residual's positive",
                    s.label
                ));
            }
            work += cells * spec.reps as f64;
        }
        if work > MAX_DRAW_WORK {
            return bad(format!(
                "reps x cells over the settings is {work:.3e}, more than the {MAX_DRAW_WORK:.0e} allowed (each replication fits two REML models; about 4,000 cells a second on two cores, so this would take {:.0} hours); lower `reps` or the sizes",
                work / 4000.0 / 3600.0
            ));
        }
        Ok(())
    }
}

/// The study a coverage spec's text asks for: its `kind` (`"draws"`,
/// `"decision"`), or `None` for the grid, which has none. Text that is not
/// JSON is refused here with the syntax error's line and column, whichever
/// study it meant (a NaN or a missing comma was reported as the other
/// study's "unknown field `kind`"); a `kind` that names no study is
/// refused with the kinds there are.
pub fn spec_kind(path: &Path, text: &str) -> Result<Option<String>, CoverageError> {
    let value: serde_json::Value = super::coverage::parse_spec(path, text)?;
    match value.get("kind") {
        None => Ok(None),
        Some(serde_json::Value::String(k)) if k == "draws" || k == "decision" => Ok(Some(k.clone())),
        Some(other) => Err(CoverageError::Invalid {
            path: path.display().to_string(),
            message: format!(
                "`kind` must be \"draws\" (coverage with a draw component) or \"decision\" (the interaction and the optimism), or absent (the grid of settings), found {other}"
            ),
        }),
    }
}

/// The seed of a setting: FNV-1a of its JSON, mixed with the spec's seed.
fn setting_seed(spec_seed: u64, s: &DrawSetting) -> u64 {
    let text = serde_json::to_string(s).unwrap_or_default();
    let mut h: u64 = 0xcbf29ce484222325 ^ spec_seed;
    for b in text.bytes() {
        h ^= b as u64;
        h = h.wrapping_mul(0x100000001b3);
    }
    h
}

/// The closed-form SE of the single-draw and per-seed means. One draw:
/// Var = sa/I + sb/J + sc + sac/I + sbc/J + se/(IJ). Per-seed draws (seed
/// s in draw s): the draw terms average over J draws:
/// sa/I + (sb + sc + sbc)/J + (sac + se)/(IJ).
fn true_ses(s: &DrawSetting) -> (f64, f64) {
    let v = s.variances;
    let (i, j) = (s.rows as f64, s.cols as f64);
    let single = v.recording / i + v.seed / j + v.draw + v.recording_draw / i + v.seed_draw / j + v.residual / (i * j);
    let per_seed = v.recording / i + (v.seed + v.draw + v.seed_draw) / j + (v.recording_draw + v.residual) / (i * j);
    (single.sqrt(), per_seed.sqrt())
}

/// One replication: every method's interval (None where it failed).
fn replicate(s: &DrawSetting, level: f64, rng: &mut ChaCha8Rng) -> [Option<Interval>; 4] {
    let v = s.variances;
    let (i, j, k) = (s.rows, s.cols, s.draws);
    let mut z = |var: f64, n: usize| -> Vec<f64> { (0..n).map(|_| var.sqrt() * standard_normal(rng)).collect() };
    let a = z(v.recording, i);
    let b = z(v.seed, j);
    // Draws: the K pooled draws, then J per-seed draws (independent).
    let c = z(v.draw, k + j);
    let ac = z(v.recording_draw, i * (k + j));
    let bc = z(v.seed_draw, j * (k + j));
    let e = z(v.residual, i * j * (k + 1));
    let d = |r: usize, sd: usize, dk: usize, noise: f64| {
        a[r] + b[sd] + c[dk] + ac[r * (k + j) + dk] + bc[sd * (k + j) + dk] + noise
    };
    // Pooled: draws 0..k; the single draw is draw 0 of them.
    let mut y = Vec::with_capacity(i * j * k);
    let (mut fr, mut fs, mut fd, mut frd, mut fsd) = (vec![], vec![], vec![], vec![], vec![]);
    for dk in 0..k {
        for r in 0..i {
            for sd in 0..j {
                y.push(d(r, sd, dk, e[(dk * i + r) * j + sd]));
                fr.push(r);
                fs.push(sd);
                fd.push(dk);
                frd.push(r * k + dk);
                fsd.push(sd * k + dk);
            }
        }
    }
    let t_interval = |data: Vec<f64>| -> Option<Interval> {
        let m = CrossedMatrix::new(i, j, data).ok()?;
        let est = crossed_mom(&m, level, DfRule::SeedsMinusOne).ok()?;
        Some((est.mean, est.se, est.df, est.lower, est.upper))
    };
    let single = t_interval(y[..i * j].to_vec());
    // Per-seed: seed sd in draw k + sd, with its own residuals.
    let mut per = Vec::with_capacity(i * j);
    for r in 0..i {
        for sd in 0..j {
            per.push(d(r, sd, k + sd, e[(k * i + r) * j + sd]));
        }
    }
    let per_seed = t_interval(per);
    let factors = vec![
        ("recording".to_string(), fr),
        ("seed".to_string(), fs),
        ("draw".to_string(), fd),
        ("recording:draw".to_string(), frd),
        ("seed:draw".to_string(), fsd),
    ];
    let fit =
        MixedData::new(y, factors).and_then(|data| mixed::fit(&data, Criterion::Reml)).and_then(|f| f.certified());
    let pooled = |kr: bool| -> Option<Interval> {
        let f = fit.as_ref().ok()?;
        let (se, df, rule, lower, upper) = f.intercept_interval(kr, level).ok()?;
        // A Kenward-Roger interval that fell back to Satterthwaite's is no
        // Kenward-Roger interval: that replication failed.
        (!kr || rule == "kenward_roger").then_some((f.intercept, se, df, lower, upper))
    };
    [single, per_seed, pooled(true), pooled(false)]
}

/// Runs every setting (replications in parallel, results independent of
/// the thread count), calling `progress(k, n, label)` before setting k.
pub fn run_draw_coverage(
    spec: &DrawCoverageSpec,
    progress: &mut dyn FnMut(usize, usize, &str),
) -> Vec<DrawPerformance> {
    let mut out = Vec::new();
    for (n, s) in spec.settings.iter().enumerate() {
        progress(n + 1, spec.settings.len(), &s.label);
        let seed = setting_seed(spec.seed, s);
        let reps: Vec<[Option<Interval>; 4]> = (0..spec.reps)
            .into_par_iter()
            .map(|r| {
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                rng.set_stream(r as u64);
                replicate(s, spec.level, &mut rng)
            })
            .collect();
        let (single_se, per_seed_se) = true_ses(s);
        for (m, name) in METHODS.iter().enumerate() {
            let got: Vec<Interval> = reps.iter().filter_map(|r| r[m]).collect();
            let truth = match m {
                0 => Some(single_se),
                1 => Some(per_seed_se),
                _ => None,
            };
            out.push(measure(&s.label, name, &got, spec.reps - got.len(), truth));
        }
    }
    out
}

fn measure(setting: &str, method: &str, got: &[Interval], failed: usize, true_se: Option<f64>) -> DrawPerformance {
    let n = got.len().max(1) as f64;
    let mean = |f: &dyn Fn(&Interval) -> f64| got.iter().map(f).sum::<f64>() / n;
    let covered = mean(&|x| if x.3 <= 0.0 && 0.0 <= x.4 { 1.0 } else { 0.0 });
    let below = mean(&|x| if x.4 < 0.0 { 1.0 } else { 0.0 });
    let above = mean(&|x| if x.3 > 0.0 { 1.0 } else { 0.0 });
    let width = mean(&|x| x.4 - x.3);
    let width_sd = (got.iter().map(|x| (x.4 - x.3 - width).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
    let est = mean(&|x| x.0);
    let emp = (got.iter().map(|x| (x.0 - est).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
    DrawPerformance {
        setting: setting.to_string(),
        method: method.to_string(),
        reps: got.len(),
        failed,
        coverage: covered,
        coverage_mcse: (covered * (1.0 - covered) / n).sqrt(),
        below,
        above,
        mean_width: width,
        width_mcse: width_sd / n.sqrt(),
        bias: est,
        empirical_se: emp,
        model_se: mean(&|x| x.1),
        mean_df: mean(&|x| x.2),
        true_se,
    }
}

/// Writes coverage.csv and coverage.md into `out`.
pub fn write_draw_coverage(
    out: &Path,
    spec: &DrawCoverageSpec,
    rows: &[DrawPerformance],
) -> Result<Vec<PathBuf>, CoverageError> {
    create_dir_all(out)?;
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r)?;
    }
    let bytes = w.into_inner().map_err(|e| CoverageError::Csv(e.into_error().into()))?;
    let csv_path = out.join("coverage.csv");
    write_atomic(&csv_path, &bytes)?;
    let mut s = String::new();
    let _ = writeln!(s, "# Coverage with a draw component\n");
    let _ = writeln!(
        s,
        "Model: d_rsk = mu + a_r + b_s + c_k + (ac)_rk + (bc)_sk + e_rsk, every term normal; the estimand is mu = 0, the protocol-level mean over draws. {} replications per setting, nominal level {}%. Methods: `single_draw_t`, one draw's array with the crossed method of moments and t(J - 1); `per_seed_draws_t`, each seed its own draw, the same estimator; `pooled_reml_kr` and `pooled_reml_satterthwaite`, {} whole draws pooled by REML over recording, seed, draw, recording:draw and seed:draw. Below / above: misses with the interval wholly below / above mu. True SE: the closed form of the estimator's SD under the model. Failed: replications whose REML fit was not certified or had no df.\n",
        spec.reps,
        100.0 * spec.level,
        spec.settings.iter().map(|s| s.draws.to_string()).collect::<Vec<_>>().join(" / ")
    );
    if !spec.source.is_empty() {
        let _ = writeln!(s, "Variances: {}\n", spec.source);
    }
    for set in &spec.settings {
        let v = set.variances;
        let _ = writeln!(
            s,
            "## {}\n\n{} recordings x {} seeds x {} draws; variances: recording {:.3e}, seed {:.3e}, draw {:.3e}, recording:draw {:.3e}, seed:draw {:.3e}, residual {:.3e}.\n",
            set.label, set.rows, set.cols, set.draws, v.recording, v.seed, v.draw, v.recording_draw, v.seed_draw, v.residual
        );
        let _ = writeln!(s, "| method | coverage (MCSE) | below | above | mean width (MCSE) | bias | empirical SE | model SE | true SE | mean df | failed |");
        let _ = writeln!(s, "|---|---|---:|---:|---|---:|---:|---:|---:|---:|---:|");
        for r in rows.iter().filter(|r| r.setting == set.label) {
            let _ = writeln!(
                s,
                "| {} | {:.3} ({:.3}) | {:.3} | {:.3} | {:.4} ({:.4}) | {:.5} | {:.4} | {:.4} | {} | {:.1} | {} |",
                r.method,
                r.coverage,
                r.coverage_mcse,
                r.below,
                r.above,
                r.mean_width,
                r.width_mcse,
                r.bias,
                r.empirical_se,
                r.model_se,
                r.true_se.map(|x| format!("{x:.4}")).unwrap_or_else(|| "-".into()),
                r.mean_df,
                r.failed
            );
        }
        let _ = writeln!(s);
    }
    let md_path = out.join("coverage.md");
    write_atomic(&md_path, s.as_bytes())?;
    Ok(vec![csv_path, md_path])
}
