//! The methodologists' workbench: `crossaudit coverage SPEC`, a grid of
//! simulation settings from a small JSON spec, every interval estimator,
//! performance measures with Monte Carlo SEs, as CSV, Markdown and SVG.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::stats::coverage::{simulate, Distribution, Performance, Setting};
use crate::Error;

/// A coverage study: the grid is rows x cols x shares x distributions.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoverageSpec {
    pub seed: u64,
    pub reps: usize,
    #[serde(default = "default_level")]
    pub level: f64,
    #[serde(default = "default_b")]
    pub bootstrap: usize,
    pub rows: Vec<usize>,
    pub cols: Vec<usize>,
    /// Shares of the true SE^2 (recording, seed, residual).
    pub shares: Vec<[f64; 3]>,
    pub distributions: Vec<Distribution>,
}

fn default_level() -> f64 {
    0.95
}

fn default_b() -> usize {
    999
}

impl CoverageSpec {
    pub fn load(path: &Path) -> Result<CoverageSpec, Error> {
        let text =
            std::fs::read_to_string(path).map_err(|e| Error::Usage(format!("cannot read {}: {e}", path.display())))?;
        let spec: CoverageSpec = serde_json::from_str(&text)
            .map_err(|e| Error::Usage(format!("{}: line {}, column {}: {e}", path.display(), e.line(), e.column())))?;
        spec.validate(path)?;
        Ok(spec)
    }

    fn validate(&self, path: &Path) -> Result<(), Error> {
        let bad = |m: String| Err(Error::Usage(format!("{}: {m}", path.display())));
        if self.reps < 2 {
            return bad(format!("`reps` must be at least 2, found {}", self.reps));
        }
        if !(self.level > 0.0 && self.level < 1.0) {
            return bad(format!("`level` must be in (0, 1), found {}", self.level));
        }
        if self.bootstrap == 0 {
            return bad("`bootstrap` must be at least 1".into());
        }
        if let Some(r) = self.rows.iter().chain(&self.cols).find(|n| **n < 2) {
            return bad(format!("`rows` and `cols` must be at least 2, found {r}"));
        }
        for s in &self.shares {
            if s.iter().any(|x| *x < 0.0 || !x.is_finite()) || (s.iter().sum::<f64>() - 1.0).abs() > 1e-6 {
                return bad(format!("each `shares` entry is three non-negative shares summing to 1, found {s:?}"));
            }
        }
        if self.rows.is_empty() || self.cols.is_empty() || self.shares.is_empty() || self.distributions.is_empty() {
            return bad("`rows`, `cols`, `shares` and `distributions` each need at least one entry".into());
        }
        Ok(())
    }

    pub fn settings(&self) -> Vec<Setting> {
        let mut out = Vec::new();
        for &rows in &self.rows {
            for &cols in &self.cols {
                for &shares in &self.shares {
                    for &distribution in &self.distributions {
                        out.push(Setting { rows, cols, shares, distribution });
                    }
                }
            }
        }
        out
    }
}

/// Runs every setting; `on_setting` sees each as it finishes.
pub fn run_coverage(
    spec: &CoverageSpec,
    on_setting: &mut dyn FnMut(usize, usize, &Setting),
) -> Result<Vec<Performance>, Error> {
    let settings = spec.settings();
    let mut out = Vec::new();
    for (k, s) in settings.iter().enumerate() {
        // Each setting gets its own seed so adding settings leaves the others unchanged.
        let seed = spec.seed.wrapping_add(k as u64);
        out.extend(
            simulate(s, spec.reps, spec.level, spec.bootstrap, seed)
                .map_err(|e| Error::Usage(format!("{}: {e}", s.label())))?,
        );
        on_setting(k + 1, settings.len(), s);
    }
    Ok(out)
}

pub fn to_csv(rows: &[Performance]) -> String {
    let mut s = String::from("setting,method,reps,coverage,coverage_mcse,mean_width,mean_width_mcse,median_width,bias,bias_mcse,emp_se,emp_se_mcse,mod_se,mod_se_mcse,rel_error_mod_se_pct,rel_error_mod_se_mcse\n");
    for r in rows {
        let _ = writeln!(
            s,
            "\"{}\",{:?},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.setting,
            r.method,
            r.reps,
            r.coverage,
            r.coverage_mcse,
            r.mean_width,
            r.mean_width_mcse,
            r.median_width,
            r.bias,
            r.bias_mcse,
            r.emp_se,
            r.emp_se_mcse,
            r.mod_se,
            r.mod_se_mcse,
            r.rel_error_mod_se,
            r.rel_error_mod_se_mcse
        );
    }
    s
}

pub fn to_markdown(spec: &CoverageSpec, rows: &[Performance]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Coverage of interval estimators for crossed designs\n");
    let _ = writeln!(
        s,
        "{} replications per setting, nominal level {}, pigeonhole bootstrap B = {}, seed {}. True SE = 1 in every setting; MCSE in parentheses (Morris, White & Crowther 2019).\n",
        spec.reps, spec.level, spec.bootstrap, spec.seed
    );
    let mut setting = "";
    for r in rows {
        if r.setting != setting {
            setting = &r.setting;
            let _ = writeln!(s, "\n## {setting}\n");
            let _ = writeln!(
                s,
                "| estimator | coverage | mean width | median width | bias | EmpSE | ModSE | rel. error ModSE % |"
            );
            let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|");
        }
        let _ = writeln!(
            s,
            "| {} | {:.3} ({:.3}) | {:.3} ({:.3}) | {:.3} | {:.3} ({:.3}) | {:.3} ({:.3}) | {:.3} ({:.3}) | {:.1} ({:.1}) |",
            r.method.label(),
            r.coverage,
            r.coverage_mcse,
            r.mean_width,
            r.mean_width_mcse,
            r.median_width,
            r.bias,
            r.bias_mcse,
            r.emp_se,
            r.emp_se_mcse,
            r.mod_se,
            r.mod_se_mcse,
            r.rel_error_mod_se,
            r.rel_error_mod_se_mcse
        );
    }
    s
}

/// Coverage per setting and estimator with 2-MCSE bars and the nominal line.
pub fn draw(path: &Path, spec: &CoverageSpec, rows: &[Performance]) -> Result<(), Error> {
    use plotters::prelude::*;
    let e = |x: String| Error::Usage(format!("cannot draw {}: {x}", path.display()));
    let mut settings: Vec<&str> = Vec::new();
    for r in rows {
        if !settings.contains(&r.setting.as_str()) {
            settings.push(&r.setting);
        }
    }
    let mut methods: Vec<_> = Vec::new();
    for r in rows {
        if !methods.contains(&r.method) {
            methods.push(r.method);
        }
    }
    let labels: Vec<String> = (1..=settings.len()).map(|k| format!("setting {k}")).collect();
    let root = SVGBackend::new(path, (1000, 520)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(format!("{x:?}")))?;
    let lo = rows.iter().map(|r| r.coverage - 2.0 * r.coverage_mcse).fold(spec.level, f64::min).max(0.0);
    let n = settings.len();
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("Coverage (nominal {}), 2-MCSE bars, {} reps", spec.level, spec.reps), ("sans-serif", 18))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .right_y_label_area_size(10)
        .build_cartesian_2d(-0.5f64..(n as f64 - 0.5), (lo - 0.02)..1.0)
        .map_err(|x| e(format!("{x:?}")))?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(n)
        .x_label_formatter(&|x| crate::report::figures::category_label(*x, &labels))
        .y_desc("coverage")
        .draw()
        .map_err(|x| e(format!("{x:?}")))?;
    chart
        .draw_series(LineSeries::new(vec![(-0.5, spec.level), (n as f64 - 0.5, spec.level)], BLACK))
        .map_err(|x| e(format!("{x:?}")))?;
    let palette = [BLUE, RED, GREEN, MAGENTA, CYAN, RGBColor(230, 120, 20), RGBColor(90, 90, 90)];
    for (k, m) in methods.iter().enumerate() {
        let color = palette[k % palette.len()];
        let dx = (k as f64 - (methods.len() as f64 - 1.0) / 2.0) * 0.08;
        let pts: Vec<(f64, f64, f64)> = rows
            .iter()
            .filter(|r| r.method == *m)
            .map(|r| {
                let x = settings.iter().position(|s| *s == r.setting).unwrap_or(0) as f64 + dx;
                (x, r.coverage, r.coverage_mcse)
            })
            .collect();
        chart
            .draw_series(
                pts.iter().map(|(x, c, m)| PathElement::new(vec![(*x, c - 2.0 * m), (*x, c + 2.0 * m)], color)),
            )
            .map_err(|x| e(format!("{x:?}")))?;
        chart
            .draw_series(pts.iter().map(|(x, c, _)| Circle::new((*x, *c), 4, color.filled())))
            .map_err(|x| e(format!("{x:?}")))?
            .label(m.label())
            .legend(move |(x, y)| Circle::new((x, y), 4, color.filled()));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerRight)
        .draw()
        .map_err(|x| e(format!("{x:?}")))?;
    root.present().map_err(|x| e(format!("{x:?}")))
}

/// Writes coverage.csv, coverage.md (with the numbered settings) and
/// coverage.svg into `out`.
pub fn write(out: &Path, spec: &CoverageSpec, rows: &[Performance]) -> Result<Vec<PathBuf>, Error> {
    std::fs::create_dir_all(out).map_err(|e| Error::Usage(format!("cannot create {}: {e}", out.display())))?;
    let csv = out.join("coverage.csv");
    crate::report::write_atomic(&csv, to_csv(rows).as_bytes())?;
    let md = out.join("coverage.md");
    let mut text = to_markdown(spec, rows);
    text.push_str("\n## Settings in coverage.svg\n\n");
    for (k, s) in spec.settings().iter().enumerate() {
        let _ = writeln!(text, "{}. {}", k + 1, s.label());
    }
    crate::report::write_atomic(&md, text.as_bytes())?;
    let svg = out.join("coverage.svg");
    draw(&svg, spec, rows)?;
    Ok(vec![csv, md, svg])
}

/// One row of the design planner.
#[derive(Debug, Clone, Serialize)]
pub struct PlanRow {
    pub recordings: usize,
    pub seeds: usize,
    pub se: f64,
    pub width: f64,
    /// P(the decision rule holds), normal approximation.
    pub power: f64,
}

/// The planner's answer for one design and pilot.
#[derive(Debug, Clone, Serialize)]
pub struct PlanReport {
    pub unit: String,
    pub pilot_recordings: usize,
    pub pilot_seeds: usize,
    /// Pilot estimates: mean d, reference-arm mean, variance components.
    pub mean_d: f64,
    pub mean_reference: f64,
    pub sigma2_recording: f64,
    pub sigma2_seed: f64,
    pub sigma2_residual: f64,
    pub rows: Vec<PlanRow>,
    pub advice: String,
}

/// Predicts SE, interval width and the probability that the decision rule
/// holds for other numbers of recordings I and seeds J, from the pilot's
/// primary-endpoint variance components:
/// SE^2 = sa/I + sb/J + se/(IJ) (closed form), width = 2 t(J-1) SE, and,
/// with d_hat ~ N(mu, SE^2), the rule "optimism >= c% and upper < 0" holds
/// when d_hat <= min(-t SE, -c m_ref / 100), so
/// P = Phi((min(-t SE, -c m_ref/100) - mu) / SE). The pilot's mean is taken
/// as the true effect.
pub fn plan(
    analysis: &crate::Analysis,
    design: &crate::Design,
    recordings: &[usize],
    seeds: &[usize],
) -> Result<PlanReport, Error> {
    use statrs::distribution::{ContinuousCDF, Normal};
    let u = analysis.units.first().ok_or_else(|| Error::Usage("the analysis has no primary endpoint".into()))?;
    let c = &u.estimate.components;
    let level = design.estimator.level;
    let threshold =
        design.decision.conditions.iter().find(|k| k.quantity == crate::design::Quantity::Optimism).map(|k| k.value);
    let normal = Normal::new(0.0, 1.0).map_err(|e| Error::Usage(e.to_string()))?;
    let mut rows = Vec::new();
    for &i in recordings {
        for &j in seeds {
            let (fi, fj) = (i as f64, j as f64);
            let se = (c.recording / fi + c.seed / fj + c.residual / (fi * fj)).sqrt();
            let df = match design.estimator.df {
                crate::stats::DfRule::SeedsMinusOne => fj - 1.0,
                crate::stats::DfRule::RecordingsMinusOne => fi - 1.0,
                _ => f64::INFINITY,
            };
            let t = crate::stats::critical_value(level, df).map_err(|e| Error::Usage(e.to_string()))?;
            let mut bound = -t * se;
            if let Some(thr) = threshold {
                bound = bound.min(-thr * u.mean_reference / 100.0);
            }
            let power = if se > 0.0 {
                normal.cdf((bound - u.estimate.mean) / se)
            } else {
                f64::from(u8::from(u.estimate.mean <= bound))
            };
            rows.push(PlanRow { recordings: i, seeds: j, se, width: 2.0 * t * se, power });
        }
    }
    let (i0, j0) = (analysis.recordings.len() as f64, analysis.seeds.len() as f64);
    let se_at = |i: f64, j: f64| (c.recording / i + c.seed / j + c.residual / (i * j)).sqrt();
    let (base, more_rec, more_seed) = (se_at(i0, j0), se_at(2.0 * i0, j0), se_at(i0, 2.0 * j0));
    let advice = format!(
        "From the pilot's {i0} recordings x {j0} seeds (SE {base:.4}): doubling the recordings gives SE {more_rec:.4}, doubling the seeds gives SE {more_seed:.4}; {} reduce the SE more.",
        if more_rec < more_seed { "more recordings" } else { "more seeds" }
    );
    Ok(PlanReport {
        unit: format!("{} {} at {} s", u.model, u.metric.name(), u.horizon_s),
        pilot_recordings: analysis.recordings.len(),
        pilot_seeds: analysis.seeds.len(),
        mean_d: u.estimate.mean,
        mean_reference: u.mean_reference,
        sigma2_recording: c.recording,
        sigma2_seed: c.seed,
        sigma2_residual: c.residual,
        rows,
        advice,
    })
}

impl PlanReport {
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# Design planner: {}\n", self.unit);
        let _ = writeln!(
            s,
            "Pilot: {} recordings x {} seeds; mean d {:.5}, reference mean {:.5}; sigma^2 recording {:.3e}, seed {:.3e}, residual {:.3e}.\n",
            self.pilot_recordings,
            self.pilot_seeds,
            self.mean_d,
            self.mean_reference,
            self.sigma2_recording,
            self.sigma2_seed,
            self.sigma2_residual
        );
        let _ = writeln!(s, "{}\n", self.advice);
        let _ = writeln!(s, "| recordings I | seeds J | predicted SE | interval width | P(decision rule holds) |");
        let _ = writeln!(s, "|---:|---:|---:|---:|---:|");
        for r in &self.rows {
            let _ = writeln!(s, "| {} | {} | {:.5} | {:.5} | {:.3} |", r.recordings, r.seeds, r.se, r.width, r.power);
        }
        s
    }

    /// Power against seeds, one line per number of recordings.
    pub fn draw(&self, path: &Path) -> Result<(), Error> {
        use plotters::prelude::*;
        let e = |x: String| Error::Usage(format!("cannot draw {}: {x}", path.display()));
        let root = SVGBackend::new(path, (900, 480)).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(format!("{x:?}")))?;
        let max_j = self.rows.iter().map(|r| r.seeds).max().unwrap_or(2) as f64;
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("P(decision rule holds) for {}", self.unit), ("sans-serif", 18))
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..max_j, 0.0..1.0)
            .map_err(|x| e(format!("{x:?}")))?;
        chart.configure_mesh().x_desc("seeds J").y_desc("probability").draw().map_err(|x| e(format!("{x:?}")))?;
        let mut recs: Vec<usize> = self.rows.iter().map(|r| r.recordings).collect();
        recs.dedup();
        let palette = [BLUE, RED, GREEN, MAGENTA, CYAN, BLACK];
        for (k, i) in recs.iter().enumerate() {
            let color = palette[k % palette.len()];
            let pts: Vec<(f64, f64)> =
                self.rows.iter().filter(|r| r.recordings == *i).map(|r| (r.seeds as f64, r.power)).collect();
            chart
                .draw_series(LineSeries::new(pts, color))
                .map_err(|x| e(format!("{x:?}")))?
                .label(format!("I = {i}"))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], color));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|x| e(format!("{x:?}")))?;
        root.present().map_err(|x| e(format!("{x:?}")))
    }
}
