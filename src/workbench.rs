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
        .x_label_formatter(&|x| {
            let k = x.round();
            if (x - k).abs() < 1e-6 && k >= 0.0 && (k as usize) < n {
                format!("setting {}", k as usize + 1)
            } else {
                String::new()
            }
        })
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
