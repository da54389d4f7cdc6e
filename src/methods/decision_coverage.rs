//! `crossaudit coverage SPEC` with `"kind": "decision"`: coverage of what
//! the decision reads besides the primary d, at declared components (the
//! paper's, `specs/coverage_decision.json`):
//!
//! - the interaction of two models' contrasts, an I x J array of its own
//!   (d of one model minus d of the other, cell by cell), scored with
//!   every interval estimator of the coverage grid
//!   ([`crossaudit_stats::coverage::simulate_reps`]) at the shares of SE^2 its
//!   components give. Every estimator is location- and scale-equivariant,
//!   so only I, J and the shares matter; widths are given in the
//!   components' unit;
//! - the optimism's intervals, Fieller's set and the delta method's, from
//!   the paper's estimator ([`crossaudit_stats::coverage::ratio`]), on a
//!   reference array and a contrast drawn jointly.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::coverage::CoverageError;
use crate::io::{create_dir_all, write_atomic};
use crossaudit_stats::coverage::ratio::{simulate_ratio, RatioPerformance, RatioSetting, Terms};
use crossaudit_stats::coverage::{measures, setting_seed, simulate_reps, Distribution, Missing, Setting};

/// One interaction setting: sizes and the components of the interaction's
/// array.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InteractionSetting {
    /// Its name in the tables.
    pub label: String,
    /// Recordings I.
    pub rows: usize,
    /// Seeds J.
    pub cols: usize,
    /// The interaction array's variance components.
    pub components: Terms,
}

impl InteractionSetting {
    /// The true SE of the complete array's mean, sqrt(s_rec / I + s_seed /
    /// J + s_res / (I J)).
    pub fn true_se(&self) -> f64 {
        let (i, j, c) = (self.rows as f64, self.cols as f64, self.components);
        (c.recording / i + c.seed / j + c.residual / (i * j)).sqrt()
    }

    /// The coverage grid's setting with the same I, J and shares of SE^2.
    fn as_setting(&self) -> Setting {
        let (i, j, c) = (self.rows as f64, self.cols as f64, self.components);
        let se2 = self.true_se().powi(2);
        Setting {
            rows: self.rows,
            cols: self.cols,
            shares: [c.recording / i / se2, c.seed / j / se2, c.residual / (i * j) / se2],
            distribution: Distribution::Normal,
            missing: Missing::Complete,
        }
    }
}

/// A decision-coverage study.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DecisionCoverageSpec {
    /// Must be `"decision"`.
    pub kind: String,
    /// Mixed into every setting's seed.
    pub seed: u64,
    /// Replications per setting.
    pub reps: usize,
    /// Nominal level.
    pub level: f64,
    /// Bootstrap replicates of the interaction's resampling intervals.
    #[serde(default = "default_bootstrap")]
    pub bootstrap: usize,
    /// Where the components come from (free text, shown in the report).
    #[serde(default)]
    pub source: String,
    /// Interaction settings.
    #[serde(default)]
    pub interaction: Vec<InteractionSetting>,
    /// Optimism settings.
    #[serde(default)]
    pub ratio: Vec<RatioSetting>,
}

fn default_bootstrap() -> usize {
    999
}

/// One interval estimator's coverage of the interaction in one setting,
/// widths and bias in the components' unit.
#[derive(Debug, Clone, Serialize)]
pub struct InteractionPerformance {
    /// The setting's label.
    pub setting: String,
    /// The estimator.
    pub method: crossaudit_stats::IntervalMethod,
    /// The true SE of the array's mean.
    pub true_se: f64,
    /// Replications with an interval.
    pub reps: usize,
    /// Replications without one.
    pub undefined: usize,
    /// Share of intervals holding the true interaction.
    pub coverage: f64,
    /// Its Monte Carlo SE.
    pub coverage_mcse: f64,
    /// Share wholly below the truth.
    pub miss_below: f64,
    /// Share wholly above the truth.
    pub miss_above: f64,
    /// Mean width.
    pub mean_width: f64,
    /// Its Monte Carlo SE.
    pub mean_width_mcse: f64,
    /// 100 (ModSE / EmpSE - 1).
    pub rel_error_mod_se: f64,
    /// Median df.
    pub df_median: f64,
}

impl DecisionCoverageSpec {
    /// Reads and checks a spec (`kind` must be `decision`).
    pub fn from_text(path: &Path, text: &str) -> Result<DecisionCoverageSpec, CoverageError> {
        let spec: DecisionCoverageSpec = super::coverage::parse_spec(path, text)?;
        spec.validate(path)?;
        Ok(spec)
    }

    /// Checks the spec (also after a command-line override of `reps`).
    pub fn validate(&self, path: &Path) -> Result<(), CoverageError> {
        let bad = |message: String| Err(CoverageError::Invalid { path: path.display().to_string(), message });
        if self.kind != "decision" {
            return bad(format!("`kind` must be \"decision\", found {:?}", self.kind));
        }
        if self.reps < 2 || self.reps > 100_000 {
            return bad(format!("`reps` must be from 2 to 100000, found {}", self.reps));
        }
        if !(self.level > 0.0 && self.level < 1.0) {
            return bad(format!("`level` must be in (0, 1), found {}", self.level));
        }
        if self.bootstrap < 19 || self.bootstrap > 99_999 {
            return bad(format!("`bootstrap` must be from 19 to 99999, found {}", self.bootstrap));
        }
        let n = self.interaction.len() + self.ratio.len();
        if n == 0 || n > 100 {
            return bad(format!("`interaction` and `ratio` need 1 to 100 settings together, found {n}"));
        }
        for s in &self.interaction {
            let c = s.components;
            let ok = [c.recording, c.seed, c.residual].iter().all(|v| v.is_finite() && *v >= 0.0) && c.residual > 0.0;
            // In f64: sizes near 2^64 overflow any integer product.
            if s.rows < 2 || s.cols < 2 || s.rows as f64 * s.cols as f64 > 100_000.0 || !ok {
                return bad(format!(
                    "interaction setting {:?}: `rows` and `cols` at least 2 with at most 100000 cells, every component finite and at least 0, the residual above 0",
                    s.label
                ));
            }
        }
        for s in &self.ratio {
            if let Err(why) = s.check() {
                return bad(format!("ratio setting {:?}: {why}", s.label));
            }
        }
        Ok(())
    }
}

/// Runs every setting, calling `progress(k, n, label)` before setting k.
pub fn run_decision_coverage(
    spec: &DecisionCoverageSpec,
    progress: &mut dyn FnMut(usize, usize, &str),
) -> Result<(Vec<InteractionPerformance>, Vec<RatioPerformance>), CoverageError> {
    let n = spec.interaction.len() + spec.ratio.len();
    let mut interaction = Vec::new();
    for (k, s) in spec.interaction.iter().enumerate() {
        progress(k + 1, n, &s.label);
        let setting = s.as_setting();
        let stats = |source| CoverageError::Stats { setting: s.label.clone(), source };
        let sim = simulate_reps(&setting, spec.reps, &[spec.level], spec.bootstrap, setting_seed(spec.seed, &setting))
            .map_err(stats)?;
        let se = s.true_se();
        // Drawn with SE 1 around 0: scale back to the components' unit.
        interaction.extend(measures(&sim, &[0.0]).into_iter().map(|p| InteractionPerformance {
            setting: s.label.clone(),
            method: p.method,
            true_se: se,
            reps: p.reps,
            undefined: p.undefined,
            coverage: p.coverage,
            coverage_mcse: p.coverage_mcse,
            miss_below: p.miss_below,
            miss_above: p.miss_above,
            mean_width: p.mean_width * se,
            mean_width_mcse: p.mean_width_mcse * se,
            rel_error_mod_se: p.rel_error_mod_se,
            df_median: p.df_median,
        }));
    }
    let mut ratio = Vec::new();
    for (k, s) in spec.ratio.iter().enumerate() {
        progress(spec.interaction.len() + k + 1, n, &s.label);
        let rows = simulate_ratio(s, spec.reps, spec.level, spec.seed)
            .map_err(|source| CoverageError::Stats { setting: s.label.clone(), source })?;
        ratio.extend(rows);
    }
    Ok((interaction, ratio))
}

fn csv_bytes<T: Serialize>(rows: &[T]) -> Result<Vec<u8>, CoverageError> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r)?;
    }
    w.into_inner().map_err(|e| CoverageError::Csv(e.into_error().into()))
}

/// Writes interaction.csv, ratio.csv and coverage.md into `out`.
pub fn write_decision_coverage(
    out: &Path,
    spec: &DecisionCoverageSpec,
    (interaction, ratio): (&[InteractionPerformance], &[RatioPerformance]),
) -> Result<Vec<PathBuf>, CoverageError> {
    create_dir_all(out)?;
    let mut written = Vec::new();
    for (name, bytes) in [("interaction.csv", csv_bytes(interaction)?), ("ratio.csv", csv_bytes(ratio)?)] {
        let path = out.join(name);
        write_atomic(&path, &bytes)?;
        written.push(path);
    }
    let md = out.join("coverage.md");
    write_atomic(&md, markdown(spec, interaction, ratio).as_bytes())?;
    written.push(md);
    Ok(written)
}

fn markdown(spec: &DecisionCoverageSpec, interaction: &[InteractionPerformance], ratio: &[RatioPerformance]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Coverage of what the decision reads: the interaction and the optimism\n");
    let _ = writeln!(
        s,
        "{} replications per setting, nominal level {}%, every term normal. Below / above: intervals wholly below / above the truth.\n",
        spec.reps,
        100.0 * spec.level
    );
    if !spec.source.is_empty() {
        let _ = writeln!(s, "Components: {}\n", crate::io::md_line(&spec.source));
    }
    for set in &spec.interaction {
        interaction_section(&mut s, spec, set, interaction);
    }
    for set in &spec.ratio {
        ratio_section(&mut s, set, ratio);
    }
    s
}

/// coverage.md's table of one interaction setting.
fn interaction_section(
    s: &mut String,
    spec: &DecisionCoverageSpec,
    set: &InteractionSetting,
    interaction: &[InteractionPerformance],
) {
    let c = set.components;
    let _ = writeln!(
        s,
        "## Interaction: {}\n\n{} recordings x {} seeds; components of the interaction's array: recording {:.3e}, seed {:.3e}, residual {:.3e} (true SE {:.4}). Every estimator of the coverage grid ({} bootstrap replicates); the widths are in the components' unit.\n",
        crate::io::md_text(&set.label),
        set.rows,
        set.cols,
        c.recording,
        c.seed,
        c.residual,
        set.true_se(),
        spec.bootstrap
    );
    let _ = writeln!(
        s,
        "| estimator | coverage (MCSE) | below | above | mean width | rel. error of ModSE % | median df | undefined |"
    );
    let _ = writeln!(s, "|---|---|---:|---:|---:|---:|---:|---:|");
    for r in interaction.iter().filter(|r| r.setting == set.label) {
        let _ = writeln!(
            s,
            "| {} | {:.3} ({:.3}) | {:.3} | {:.3} | {:.4} | {:.1} | {} | {} |",
            r.method.label(),
            r.coverage,
            r.coverage_mcse,
            r.miss_below,
            r.miss_above,
            r.mean_width,
            r.rel_error_mod_se,
            if r.df_median.is_finite() { format!("{:.1}", r.df_median) } else { "-".into() },
            r.undefined
        );
    }
    let _ = writeln!(s);
}

/// coverage.md's table of one optimism setting.
fn ratio_section(s: &mut String, set: &RatioSetting, ratio: &[RatioPerformance]) {
    let (r, d, c) = (set.reference, set.d, set.correlation);
    let _ = writeln!(
        s,
        "## Optimism: {}\n\n{} recordings x {} seeds; reference mean {}, contrast mean {} (true optimism {:.2}%). Components (recording, seed, residual): reference {:.3e}, {:.3e}, {:.3e}; contrast {:.3e}, {:.3e}, {:.3e}; their correlations {:.3}, {:.3}, {:.3}. The crossed method of moments with t(J - 1), as the paper; widths and bias in percentage points; an unbounded Fieller set counts as covering.\n",
        crate::io::md_text(&set.label),
        set.rows,
        set.cols,
        set.mean_reference,
        set.mean_d,
        100.0 * set.optimism(),
        r.recording,
        r.seed,
        r.residual,
        d.recording,
        d.seed,
        d.residual,
        c.recording,
        c.seed,
        c.residual
    );
    let _ = writeln!(s, "| interval | coverage (MCSE) | below | above | unbounded | mean width (bounded) | bias | empirical SE | delta SE | failed |");
    let _ = writeln!(s, "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for p in ratio.iter().filter(|p| p.setting == set.label) {
        let _ = writeln!(
            s,
            "| {} | {:.3} ({:.3}) | {:.3} | {:.3} | {:.3} | {:.2} | {:.3} | {:.2} | {:.2} | {} |",
            p.method,
            p.coverage,
            p.coverage_mcse,
            p.miss_below,
            p.miss_above,
            p.unbounded,
            p.mean_width,
            p.bias,
            p.empirical_se,
            p.model_se,
            p.failed
        );
    }
    let _ = writeln!(s);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The grid setting has the interaction's I, J and shares: shares sum
    /// to 1 and give back the components, s_k = share_k SE^2 n_k.
    #[test]
    fn an_interaction_is_the_grid_setting_of_its_shares() {
        let s = InteractionSetting {
            label: "x".into(),
            rows: 24,
            cols: 20,
            components: Terms { recording: 4e-5, seed: 3e-4, residual: 5e-3 },
        };
        let g = s.as_setting();
        let se2 = s.true_se().powi(2);
        assert!((g.shares.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        let back = [g.shares[0] * se2 * 24.0, g.shares[1] * se2 * 20.0, g.shares[2] * se2 * 480.0];
        for (b, c) in back.iter().zip([4e-5, 3e-4, 5e-3]) {
            assert!((b / c - 1.0).abs() < 1e-14, "{b} {c}");
        }
        assert!((se2 - (4e-5 / 24.0 + 3e-4 / 20.0 + 5e-3 / 480.0)).abs() < 1e-18);
    }
}
