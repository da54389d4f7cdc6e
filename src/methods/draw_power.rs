//! The planner for the draws (issue 45): from a pilot with `factor draw`,
//! whose d was pooled over draws by REML with components for recording,
//! seed, draw, recording:draw, seed:draw and the residual, the SE, df,
//! interval width and probability that the rule holds for other numbers of
//! recordings I, seeds J and draws K, and for the same study with per-seed
//! draws (`draws per seed`: seed j trains on and is evaluated with its own
//! draw, so J seeds cost what J seeds of one draw cost).

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use super::power::{check_counts, rule_power, PowerError};
use crate::analysis::multiverse::{DrawReplication, MultiverseAnalysis};
use crate::io::{create_dir_all, write_atomic};
use crate::plan::Plan;
use crate::report::charts::{draw_err, DrawError};
use crate::report::MdTable;
use crossaudit_stats::critical_value;

/// The REML variance components of d over recording x seed x draw, m^2.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct DrawComponents {
    /// Between recordings.
    pub recording: f64,
    /// Between seeds (the same seed in every draw).
    pub seed: f64,
    /// Between draws.
    pub draw: f64,
    /// Recording by draw.
    pub recording_draw: f64,
    /// Seed by draw.
    pub seed_draw: f64,
    /// The rest (recording by seed within a draw).
    pub residual: f64,
}

impl DrawComponents {
    /// The components of a pooled fit, by their names in
    /// [`DrawReplication::components`].
    pub fn of(d: &DrawReplication) -> Option<DrawComponents> {
        let get = |name: &str| d.components.iter().find(|c| c.0 == name).map(|c| c.1);
        Some(DrawComponents {
            recording: get("recording")?,
            seed: get("seed")?,
            draw: get("draw")?,
            recording_draw: get("recording:draw")?,
            seed_draw: get("seed:draw")?,
            residual: get("residual")?,
        })
    }

    /// The expected mean squares of the balanced I x J x K array with one
    /// cell per (recording, seed, draw), each with its coefficient in
    /// IJK Var(mean) and its df:
    ///
    /// ```text
    /// E MS_R  = JK s_r + J s_rd + s_e             (+1, I - 1)
    /// E MS_S  = IK s_s + I s_sd + s_e             (+1, J - 1)
    /// E MS_D  = IJ s_d + J s_rd + I s_sd + s_e    (+1, K - 1)
    /// E MS_RD = J s_rd + s_e                      (-1, (I - 1)(K - 1))
    /// E MS_SD = I s_sd + s_e                      (-1, (J - 1)(K - 1))
    /// ```
    ///
    /// whose signed sum is JK s_r + IK s_s + IJ s_d + J s_rd + I s_sd + s_e.
    fn mean_squares(&self, i: f64, j: f64, k: f64) -> [(f64, f64, f64); 5] {
        let c = self;
        [
            (j * k * c.recording + j * c.recording_draw + c.residual, 1.0, i - 1.0),
            (i * k * c.seed + i * c.seed_draw + c.residual, 1.0, j - 1.0),
            (i * j * c.draw + j * c.recording_draw + i * c.seed_draw + c.residual, 1.0, k - 1.0),
            (j * c.recording_draw + c.residual, -1.0, (i - 1.0) * (k - 1.0)),
            (i * c.seed_draw + c.residual, -1.0, (j - 1.0) * (k - 1.0)),
        ]
    }

    /// Var(pooled mean) on a complete I x J x K array:
    /// s_r/I + s_s/J + s_d/K + s_rd/(IK) + s_sd/(JK) + s_e/(IJK).
    pub fn pooled_variance(&self, i: usize, j: usize, k: usize) -> f64 {
        let (i, j, k) = (i as f64, j as f64, k as f64);
        self.recording / i
            + self.seed / j
            + self.draw / k
            + self.recording_draw / (i * k)
            + self.seed_draw / (j * k)
            + self.residual / (i * j * k)
    }

    /// Satterthwaite's df of that variance written as the signed sum of
    /// the expected mean squares (`Self::mean_squares`):
    /// (sum c M)^2 / sum M^2 / df, at least 1.
    pub fn pooled_df(&self, i: usize, j: usize, k: usize) -> f64 {
        let ms = self.mean_squares(i as f64, j as f64, k as f64);
        let total: f64 = ms.iter().map(|(m, c, _)| c * m).sum();
        let denominator: f64 = ms.iter().filter(|(_, _, df)| *df > 0.0).map(|(m, _, df)| m * m / df).sum();
        if denominator > 0.0 {
            (total * total / denominator).max(1.0)
        } else {
            f64::INFINITY
        }
    }

    /// The crossed components of the same study with per-seed draws: a
    /// seed's own draw moves all its cells together, so the draw and
    /// seed-by-draw variances join the seed's, and the recording-by-draw
    /// variance joins the residual's. (recording, seed, residual).
    pub fn per_seed(&self) -> (f64, f64, f64) {
        (self.recording, self.seed + self.draw + self.seed_draw, self.recording_draw + self.residual)
    }

    /// Var(mean) with per-seed draws on a complete I x J array.
    pub fn per_seed_variance(&self, i: usize, j: usize) -> f64 {
        let (r, s, e) = self.per_seed();
        let (i, j) = (i as f64, j as f64);
        r / i + s / j + e / (i * j)
    }
}

/// One row of the draw planner.
#[derive(Debug, Clone, Serialize)]
pub struct DrawPowerRow {
    /// Recordings I.
    pub recordings: usize,
    /// Seeds J.
    pub seeds: usize,
    /// Draws K, pooled; None for per-seed draws (J draws, one per seed).
    pub draws: Option<usize>,
    /// Models trained per arm: J K pooled, J per seed.
    pub models_per_arm: usize,
    /// Predicted SE.
    pub se: f64,
    /// The df of the interval.
    pub df: f64,
    /// Predicted interval width, 2 t SE.
    pub width: f64,
    /// P(the decision rule holds), normal approximation.
    pub power: f64,
}

/// The draw planner's answer.
#[derive(Debug, Clone, Serialize)]
pub struct DrawPowerPlan {
    /// The primary unit's label.
    pub unit: String,
    /// The specification planned (`-` without choices).
    pub spec: String,
    /// The pilot's recordings, seeds and draws.
    pub pilot: (usize, usize, usize),
    /// The pilot's pooled mean d, m.
    pub mean_d: f64,
    /// The pilot's reference-arm mean over every draw, m.
    pub mean_reference: f64,
    /// The pilot's components, m^2.
    pub components: DrawComponents,
    /// Rows pooled over K draws, then rows with per-seed draws.
    pub rows: Vec<DrawPowerRow>,
    /// What the pilot's own sizes and their doublings give.
    pub advice: String,
    /// Why the pilot's draw variance is uncertain, when it is (fewer than
    /// [`MIN_PILOT_DRAWS`] draws).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
}

/// Fewer draws than this give a draw variance on so few df that a plan
/// resting on it is a guess: the planner warns.
pub const MIN_PILOT_DRAWS: usize = 5;

/// Plans a design with `factor draw` from the pooled fit of its primary
/// specification (`a` is the pilot's analysis, as `analyze` makes it).
/// Pooled rows: SE^2 from [`DrawComponents::pooled_variance`], df from
/// [`DrawComponents::pooled_df`]. Per-seed rows: SE^2 from
/// [`DrawComponents::per_seed_variance`], df the design's rule at I and J
/// (the normal where that rule needs data). P(rule holds) as for the
/// crossed planner, the pilot's pooled mean taken as the true effect.
pub fn draw_power_plan(
    plan: &Plan,
    a: &MultiverseAnalysis,
    recordings: &[usize],
    seeds: &[usize],
    draws: &[usize],
) -> Result<DrawPowerPlan, PowerError> {
    check_counts(&[recordings, seeds, draws])?;
    let primary = a.specs.iter().position(|s| s.primary).unwrap_or(0);
    let spec_id = a.specs.get(primary).map(|s| s.id.clone());
    let d = a
        .draws
        .iter()
        .find(|d| spec_id.as_deref().is_none_or(|id| d.spec == id || d.spec == "-"))
        .ok_or(PowerError::NoPrimary)?;
    let pooled = d.pooled.as_ref().ok_or_else(|| PowerError::NoPooledFit {
        why: d.error.clone().unwrap_or_else(|| "the fit over draws was not certified".into()),
    })?;
    let c = DrawComponents::of(d).ok_or_else(|| PowerError::NoPooledFit {
        why: "the fit over draws has no recording, seed, draw, recording:draw and seed:draw components".into(),
    })?;
    let all = [c.recording, c.seed, c.draw, c.recording_draw, c.seed_draw, c.residual];
    super::power::refuse_degenerate("d pooled over draws", &all, pooled.mean, pooled.mean_reference)?;
    let level_of = |name: &str| pooled.levels.iter().find(|l| l.0 == name).map_or(0, |l| l.1);
    let pilot = (level_of("recording"), level_of("seed"), level_of("draw"));
    let level = plan.estimator.level;
    let row = |i: usize, j: usize, k: Option<usize>| -> Result<DrawPowerRow, PowerError> {
        let (var, df) = match k {
            Some(k) => (c.pooled_variance(i, j, k), c.pooled_df(i, j, k)),
            None => (c.per_seed_variance(i, j), plan.df(i, j).unwrap_or(f64::INFINITY)),
        };
        let se = var.sqrt();
        let t = critical_value(level, df)?;
        let power = rule_power(plan, pooled.mean, se, t, pooled.mean_reference)?;
        Ok(DrawPowerRow {
            recordings: i,
            seeds: j,
            draws: k,
            models_per_arm: j * k.unwrap_or(1),
            se,
            df,
            width: 2.0 * t * se,
            power,
        })
    };
    // Every (I, J) pooled over each K draws, then with per-seed draws.
    let grid = |k: Option<usize>| recordings.iter().flat_map(move |&i| seeds.iter().map(move |&j| (i, j, k)));
    let sizes = draws.iter().flat_map(|&k| grid(Some(k))).chain(grid(None));
    let rows = sizes.map(|(i, j, k)| row(i, j, k)).collect::<Result<Vec<_>, _>>()?;
    let advice = advice(plan, &c, (pooled.mean, pooled.mean_reference), pilot);
    let k0 = pilot.2;
    // A variance from K draws has K - 1 df for its draw component: with
    // K = 3 its 95% interval spans a factor of about 40 (chi-square, 2 df).
    let warning = (k0 < MIN_PILOT_DRAWS).then(|| {
        format!(
            "the pilot has {k0} draws: its draw components rest on {} df, so the planned SEs above may be far off. Plan from at least {MIN_PILOT_DRAWS} draws, or from a per-seed pilot (`draws per seed`, whose seed component carries the draw variance over J draws): `crossaudit plan DESIGN --cells RUN/cells.csv`",
            k0.saturating_sub(1)
        )
    });
    let u = a.levels.first().and_then(|l| l.1.units.first());
    let unit = u.map_or_else(|| "d".to_string(), |u| format!("{} {} at {} s", u.model, u.metric.name(), u.horizon_s));
    Ok(DrawPowerPlan {
        unit,
        spec: spec_id.unwrap_or_else(|| "-".into()),
        pilot,
        mean_d: pooled.mean,
        mean_reference: pooled.mean_reference,
        components: c,
        rows,
        advice,
        warning,
    })
}

impl DrawPowerPlan {
    /// plan.md.
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# Design planner over draws: {}\n", self.unit);
        let c = &self.components;
        let (i0, j0, k0) = self.pilot;
        let _ = writeln!(
            s,
            "Pilot: {i0} recordings x {j0} seeds x {k0} draws{}; d pooled over draws {:.5} m, reference mean {:.5} m. REML components (m^2): recording {:.3e}, seed {:.3e}, draw {:.3e}, recording:draw {:.3e}, seed:draw {:.3e}, residual {:.3e}.\n",
            if self.spec == "-" { String::new() } else { format!(" (specification {})", self.spec) },
            self.mean_d,
            self.mean_reference,
            c.recording,
            c.seed,
            c.draw,
            c.recording_draw,
            c.seed_draw,
            c.residual
        );
        if let Some(w) = &self.warning {
            let _ = writeln!(s, "**Warning**: {w}.\n");
        }
        let _ = writeln!(s, "{}\n", self.advice);
        let cols = [
            "draws K",
            "recordings I",
            "seeds J",
            "models per arm",
            "predicted SE (m)",
            "df",
            "interval width (m)",
            "P(decision rule holds)",
        ];
        for (title, per_seed) in [("Pooled over K draws", false), ("Per-seed draws (seed j uses draw j)", true)] {
            let _ = writeln!(s, "## {title}\n");
            let mut table = MdTable::new(&cols, "lrrrrrrr");
            for r in self.rows.iter().filter(|r| r.draws.is_none() == per_seed) {
                table.row([
                    r.draws.map_or_else(|| "per seed".to_string(), |k| k.to_string()),
                    r.recordings.to_string(),
                    r.seeds.to_string(),
                    r.models_per_arm.to_string(),
                    format!("{:.5}", r.se),
                    if r.df.is_finite() { format!("{:.1}", r.df) } else { "inf".into() },
                    format!("{:.5}", r.width),
                    format!("{:.3}", r.power),
                ]);
            }
            s.push_str(&table.render());
            s.push('\n');
        }
        s.push_str(
            "## Assumptions\n\n\
- The pilot's REML components are the true ones, and recordings, seeds and draws added are like the pilot's; every array is complete. A component estimated from few levels (the draws, usually) is poorly determined, and so is every prediction that rests on it.\n\
- Pooled over K draws: Var(mean) = s_r/I + s_s/J + s_d/K + s_rd/(IK) + s_sd/(JK) + s_e/(IJK), the model the pooled fit uses (the recording-by-seed variance is in the residual). The df are Satterthwaite's for that variance written as a signed sum of the balanced design's expected mean squares; on a balanced array Kenward-Roger's are close to them, but the decision's own df come from the data.\n\
- Per-seed draws: each seed's draw moves all its cells, so the seed component becomes s_s + s_d + s_sd and the residual s_rd + s_e; Var(mean) = s_r/I + (s_s + s_d + s_sd)/J + (s_rd + s_e)/(IJ), with the design's df rule at I and J (the normal where that rule needs data). It trains J models per arm where K pooled draws train J K.\n\
- A single draw (K = 1) is not planned: its interval leaves the draw variance out and covers the mean over draws less often than its level says (docs/study-coverage.md).\n\
- The pilot's pooled mean d is the true effect, the reference mean stays at the pilot's, and the estimate is normal with the predicted SE taken as known; the rule (`optimism >= c%` and `upper < 0`, or whichever of them it has) holds when the estimate is at most min(-t SE, -c m_ref / 100).\n",
        );
        s
    }

    /// Writes plan.md, plan.json and plan.svg into `out`.
    pub fn write(&self, out: &Path) -> Result<(), PowerError> {
        create_dir_all(out)?;
        write_atomic(&out.join("plan.md"), self.to_markdown().as_bytes())?;
        let json = serde_json::to_string_pretty(self).unwrap_or_default();
        write_atomic(&out.join("plan.json"), json.as_bytes())?;
        self.draw(&out.join("plan.svg"))?;
        Ok(())
    }

    /// P(rule holds) against models trained per arm at the pilot's
    /// recordings (or the nearest planned): one line per K, one for
    /// per-seed draws.
    pub fn draw(&self, path: &Path) -> Result<(), DrawError> {
        use plotters::prelude::*;
        let e = draw_err(path);
        let i =
            self.rows.iter().map(|r| r.recordings).min_by_key(|&i| i.abs_diff(self.pilot.0)).unwrap_or(self.pilot.0);
        let mut lines: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
        let mut ks: Vec<Option<usize>> = self.rows.iter().map(|r| r.draws).collect();
        ks.dedup();
        for k in ks {
            let pts: Vec<(f64, f64)> = self
                .rows
                .iter()
                .filter(|r| r.draws == k && r.recordings == i)
                .map(|r| (r.models_per_arm as f64, r.power))
                .collect();
            let name = k.map_or_else(|| "per-seed draws".to_string(), |k| format!("K = {k} draws, pooled"));
            lines.push((name, pts));
        }
        let max_x = self.rows.iter().map(|r| r.models_per_arm).max().unwrap_or(2) as f64;
        crate::report::charts::svg_figure(path, (900, 480), |root| {
            use crate::report::charts::{chart, ticks, whole, AXIS_FONT, TICK_FONT};
            let mut chart = chart(root, &format!("P(decision rule holds), {i} recordings"))
                .build_cartesian_2d(0.0..max_x * 1.05, 0.0..1.0)
                .map_err(&e)?;
            chart
                .configure_mesh()
                .x_label_formatter(&whole)
                .y_label_formatter(&ticks(0.0, 1.0))
                .label_style(TICK_FONT)
                .axis_desc_style(AXIS_FONT)
                .x_desc("models trained per arm (seeds x draws)")
                .y_desc("P(decision rule holds)")
                .draw()
                .map_err(&e)?;
            for (n, (name, pts)) in lines.into_iter().enumerate() {
                let color = Palette99::pick(n).to_rgba();
                chart
                    .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                    .map_err(&e)?
                    .label(name)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
                chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 4, color.filled()))).map_err(&e)?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::LowerRight)
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(&e)?;
            Ok(())
        })?;
        Ok(())
    }
}

/// The planner's advice: what doubling each factor gives from the pilot's
/// sizes, the per-seed design at the pilot's cost, and a pilot optimism
/// under the rule's threshold.
fn advice(plan: &Plan, c: &DrawComponents, (mean, mean_reference): (f64, f64), pilot: (usize, usize, usize)) -> String {
    let (i0, j0, k0) = pilot;
    let se = |i: usize, j: usize, k: usize| c.pooled_variance(i.max(1), j.max(1), k.max(1)).sqrt();
    let same_cost = c.per_seed_variance(i0.max(1), (j0 * k0).max(1)).sqrt();
    let advice = format!(
        "From the pilot's {i0} recordings x {j0} seeds x {k0} draws (SE {:.4} m pooled): doubling the recordings gives SE {:.4}, the seeds {:.4}, the draws {:.4}. At the pilot's cost ({} models per arm), {} seeds with per-seed draws give SE {:.4}.",
        se(i0, j0, k0),
        se(2 * i0, j0, k0),
        se(i0, 2 * j0, k0),
        se(i0, j0, 2 * k0),
        j0 * k0,
        j0 * k0,
        same_cost
    );
    match plan.decision.optimism_threshold() {
        Some(thr) if -100.0 * mean / mean_reference < thr => format!(
            "{advice} The pilot's optimism ({:.1}%) is below the rule's threshold ({thr}%): taken as the true effect, it makes the rule less likely to hold the more precise the estimate.",
            -100.0 * mean / mean_reference
        ),
        _ => advice,
    }
}
