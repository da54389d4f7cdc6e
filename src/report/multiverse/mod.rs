//! A multiverse's report: the decision by the declared combination on
//! line 1, one row per specification, each choice's paired effect, the
//! joint bootstrap, the draws the specifications share, draw replication,
//! and the specification curve (`spec_curve.svg`): every specification's
//! estimate with its interval, in order, and under it which alternative
//! each takes. `specs.csv` and `choice_effects.csv` are the tidy tables.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

mod markdown;

pub use markdown::render_markdown;

use super::{f, level_pct, ReportError};
use crate::analysis::multiverse::MultiverseAnalysis;
use crate::io::{create_dir_all, pretty_json, write_atomic};

/// Writes report.md, multiverse.json, specs.csv, choice_effects.csv,
/// spec_curve.svg and report.html (the report as one page, the curve
/// inline) into `dir`.
pub fn write_multiverse(a: &MultiverseAnalysis, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    create_dir_all(dir)?;
    let mut out = Vec::new();
    let (markdown, curve) = (render_markdown(a), spec_curve_svg(a));
    let html =
        super::html::render_page(&a.study, &banner(a), &markdown, &[("spec_curve.svg".to_string(), curve.clone())]);
    let files = [
        // multiverse.json first: a folder holding a report.md without it
        // is someone's own to the next `analyze`.
        ("multiverse.json", pretty_json(a)),
        ("report.md", markdown),
        ("specs.csv", specs_csv(a)),
        ("choice_effects.csv", effects_csv(a)),
        ("spec_curve.svg", curve),
        ("report.html", html),
    ];
    for (name, text) in files {
        let path = dir.join(name);
        write_atomic(&path, text.as_bytes())?;
        out.push(path);
    }
    Ok(out)
}

/// The decision by the declared combination, as line 1 of the report
/// (the verdict in bold) and as the line `run` and `analyze` print.
fn sentence(a: &MultiverseAnalysis, bold: bool) -> String {
    let d = &a.decision;
    let v = super::format::verdict_word(&d.name, d.holds);
    let v = if bold { format!("**{v}**") } else { v };
    if a.choices.is_empty() {
        let (holding, draws) = d.draws_holding.unwrap_or((0, 0));
        return match a.draws.first().and_then(|x| x.pooled.as_ref()) {
            Some(p) => format!(
                "{v} on d pooled over {draws} draws: d = {} {} [{}, {}], optimism {}% (the rule holds in {holding} of the {draws} draws alone).",
                f(p.mean, 4),
                label(a),
                f(p.lower, 4),
                f(p.upper, 4),
                f(p.optimism_pct, 1)
            ),
            None => format!("{v} on the design's own draw (no pooled fit): the rule holds in {holding} of {draws} draws."),
        };
    }
    format!(
        "{v} {}: the rule holds in {} of {} specifications (primary: {}).",
        a.combine.describe(),
        d.specs_holding,
        d.specs,
        if d.primary_holds { "met" } else { "not met" }
    )
}

pub(super) fn verdict(a: &MultiverseAnalysis) -> String {
    sentence(a, true)
}

/// The banner of report.html: the verdict by the declared combination.
fn banner(a: &MultiverseAnalysis) -> super::html::Banner {
    let d = &a.decision;
    super::html::Banner::new(&d.name, d.holds, decision_line(a), &a.header.standing)
        .with_guards(a.guards.iter().map(|g| g.text.clone()).collect())
}

/// The decision line `run` and `analyze` print for a multiverse or a
/// draw-replicated study.
pub fn decision_line(a: &MultiverseAnalysis) -> String {
    super::format::labelled(sentence(a, false), &a.header.standing)
}

/// The primary metric's unit as estimates.csv writes it (`m`; empty for
/// a rate), from the levels' analyses.
fn metric_unit(a: &MultiverseAnalysis) -> &'static str {
    a.levels.iter().find_map(|(_, l)| l.units.first()).map_or("", |u| u.metric.unit())
}

/// The primary metric's unit as the report prints it after a value or in
/// a column's heading (`fraction` for a rate).
pub(super) fn label(a: &MultiverseAnalysis) -> &'static str {
    super::format::unit_label(metric_unit(a))
}

/// specs.csv: one row per specification, with estimates.csv's names for
/// the same quantities (`unit` the primary metric's).
pub fn specs_csv(a: &MultiverseAnalysis) -> String {
    let mut s = String::from("spec");
    for c in &a.choices {
        let _ = write!(s, ",{}", c.setting);
    }
    s.push_str(",primary,unit,estimate,se,df,lower,upper,treated_mean,reference_mean,optimism_pct,rule_holds,joint_lower,joint_upper,trained,optimism_lower,optimism_upper,guards\n");
    for r in &a.specs {
        let _ = write!(s, "{}", r.id);
        for v in &r.values {
            let _ = write!(s, ",{v}");
        }
        let band = a.joint.as_ref().and_then(|j| j.bands.iter().find(|b| b.0 == r.id));
        let e = &r.estimate;
        // Fieller's bounds of the optimism (empty where unbounded or absent),
        // and the kinds of the specification's guards.
        let (olo, ohi) = r
            .optimism_interval
            .and_then(|iv| iv.fieller.bounds())
            .map(|(lo, hi)| (lo.to_string(), hi.to_string()))
            .unwrap_or_default();
        // Each kind once, in the order the guards give them.
        let mut kinds: Vec<&str> = Vec::new();
        for g in &r.guards {
            if !kinds.contains(&g.kind.name()) {
                kinds.push(g.kind.name());
            }
        }
        let _ = writeln!(
            s,
            ",{},{},{},{},{},{},{},{},{},{},{},{},{},{},{olo},{ohi},{}",
            r.primary,
            metric_unit(a),
            e.mean,
            e.se,
            e.df,
            e.lower,
            e.upper,
            r.mean_treated,
            r.mean_reference,
            r.optimism_pct,
            r.rule_holds,
            band.map(|b| b.2.to_string()).unwrap_or_default(),
            band.map(|b| b.3.to_string()).unwrap_or_default(),
            r.shares_run_of.is_none(),
            kinds.join(";")
        );
    }
    s
}

/// choice_effects.csv, with estimates.csv's names (`estimate` the
/// effect on d, in `unit`).
pub fn effects_csv(a: &MultiverseAnalysis) -> String {
    let mut s =
        String::from("choice,reference,alternative,specs_per_side,recordings,unit,estimate,se,df,lower,upper\n");
    for e in &a.choice_effects {
        let x = e.estimate.as_ref();
        let v = |g: fn(&crossaudit_stats::CrossedEstimate) -> f64| x.map(|x| g(x).to_string()).unwrap_or_default();
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{}",
            e.setting,
            e.reference,
            e.alternative,
            e.specs_per_side,
            e.recordings,
            metric_unit(a),
            v(|x| x.mean),
            v(|x| x.se),
            v(|x| x.df),
            v(|x| x.lower),
            v(|x| x.upper)
        );
    }
    s
}

fn esc(t: &str) -> String {
    t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// The specification curve: estimates with intervals (and joint bands) in
/// increasing order; under them, one row per alternative, a filled dot
/// where the specification takes it.
pub fn spec_curve_svg(a: &MultiverseAnalysis) -> String {
    let mut order: Vec<usize> = (0..a.specs.len()).collect();
    order.sort_by(|&i, &j| a.specs[i].estimate.mean.total_cmp(&a.specs[j].estimate.mean));
    let rows: Vec<(String, String)> =
        a.choices.iter().flat_map(|c| c.alternatives.iter().map(move |v| (c.setting.clone(), v.clone()))).collect();
    let l = Layout::new(a, &rows);
    let mut s = String::new();
    curve_header(&mut s, a, &l);
    curve_axis(&mut s, &l, label(a));
    curve_estimates(&mut s, a, &l, &order);
    curve_choices(&mut s, a, &l, &order, &rows);
    let key_y = l.height - 24.0;
    let _ = writeln!(
        s,
        r##"<text x="10" y="{key_y:.1}">Blue: the rule is met; red: not met. Square: the primary specification.</text>"##
    );
    let _ = writeln!(
        s,
        r##"<text x="10" y="{:.1}">Below: a filled dot marks the alternative each specification takes.</text>"##,
        key_y + 16.0
    );
    let _ = writeln!(s, "</svg>");
    s
}

/// Where the curve's parts lie: the left margin (fitting the longest
/// choice label), the plot's top and height, a choice row's height, a
/// specification's column width, the picture's size and the value range
/// of the axis.
struct Layout {
    left: f64,
    top: f64,
    plot_h: f64,
    row_h: f64,
    col_w: f64,
    width: f64,
    height: f64,
    lo: f64,
    hi: f64,
}

impl Layout {
    /// The layout for `a`'s specifications over its choice `rows`.
    fn new(a: &MultiverseAnalysis, rows: &[(String, String)]) -> Layout {
        // The left margin fits the longest "setting = value" label (about
        // 7.5 px a character at 13 px).
        let longest = rows.iter().map(|(c, v)| c.chars().count() + v.chars().count() + 3).max().unwrap_or(0);
        let (left, top, plot_h, row_h, col_w) = (
            (7.5 * longest as f64 + 30.0).max(230.0),
            58.0,
            260.0,
            19.0,
            34.0_f64.max(480.0 / a.specs.len().max(1) as f64),
        );
        let width = (left + col_w * a.specs.len() as f64 + 30.0).max(720.0);
        let height = top + plot_h + 40.0 + row_h * rows.len() as f64 + 40.0;
        let (lo, hi) = value_range(a);
        Layout { left, top, plot_h, row_h, col_w, width, height, lo, hi }
    }

    /// The height of value `v` on the axis.
    fn y(&self, v: f64) -> f64 {
        self.top + self.plot_h * (self.hi - v) / (self.hi - self.lo)
    }

    /// The middle of the `k`th specification's column.
    fn x(&self, k: usize) -> f64 {
        self.left + self.col_w * (k as f64 + 0.5)
    }
}

/// The joint band of specification `id`, if the analysis has one.
fn band(a: &MultiverseAnalysis, id: &str) -> Option<(f64, f64)> {
    a.joint.as_ref().and_then(|j| j.bands.iter().find(|b| b.0 == id)).map(|b| (b.2, b.3))
}

/// The axis's range: every interval and joint band, and 0, padded by 5%.
fn value_range(a: &MultiverseAnalysis) -> (f64, f64) {
    let mut lo = 0.0f64;
    let mut hi = 0.0f64;
    for r in &a.specs {
        lo = lo.min(r.estimate.lower);
        hi = hi.max(r.estimate.upper);
        if let Some((l, h)) = band(a, &r.id) {
            lo = lo.min(l);
            hi = hi.max(h);
        }
    }
    let pad = 0.05 * (hi - lo).max(1e-9);
    (lo - pad, hi + pad)
}

/// The picture's opening tag, its white ground and the two title lines.
fn curve_header(s: &mut String, a: &MultiverseAnalysis, l: &Layout) {
    let (width, height) = (l.width, l.height);
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="13">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="10" y="20" font-size="16">d = treated - reference ({}) by specification: {} intervals; grey: joint bands</text>"#,
        label(a),
        level_pct(a.specs.first().map(|r| r.estimate.level).unwrap_or(0.95))
    );
    let _ = writeln!(
        s,
        r##"<text x="10" y="40" font-size="13"><tspan fill="#1f77b4">blue: the rule holds</tspan>; <tspan fill="#d62728">red: it does not</tspan> (the colour is the rule, not whether the interval excludes 0)</text>"##
    );
}

/// The value axis with its ticks and its label in `unit`, and a dashed
/// line at 0 where the range spans it.
fn curve_axis(s: &mut String, l: &Layout, unit: &str) {
    let Layout { left, top, plot_h, lo, hi, width, .. } = *l;
    let _ = writeln!(s, r#"<line x1="{left}" y1="{top}" x2="{left}" y2="{}" stroke="black"/>"#, top + plot_h);
    // Round ticks: a step of 1, 2 or 5 x 10^k giving four to eight of them.
    let step = super::charts::nice_step((hi - lo) / 5.0);
    let decimals = super::charts::step_decimals(step);
    let ticks: Vec<f64> =
        (0..20).map(|k| (lo / step).ceil() * step + k as f64 * step).take_while(|v| *v <= hi + 1e-12).collect();
    for v in ticks {
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{:.1}" text-anchor="end">{:.decimals$}</text><line x1="{}" y1="{:.1}" x2="{left}" y2="{:.1}" stroke="black"/>"#,
            left - 8.0,
            l.y(v) + 4.0,
            if v.abs() < step * 1e-6 { 0.0 } else { v },
            left - 4.0,
            l.y(v),
            l.y(v)
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="20" y="{:.1}" transform="rotate(-90 20 {:.1})" text-anchor="middle">d ({})</text>"#,
        top + plot_h / 2.0,
        top + plot_h / 2.0,
        unit
    );
    if lo < 0.0 && hi > 0.0 {
        let _ = writeln!(
            s,
            r#"<line x1="{left}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="grey" stroke-dasharray="4 3"/>"#,
            l.y(0.0),
            width - 30.0,
            l.y(0.0)
        );
    }
}

/// Each specification in `order`: its joint band in grey, its interval
/// and estimate in the rule's colour (a square for the primary) and its
/// id under the plot.
fn curve_estimates(s: &mut String, a: &MultiverseAnalysis, l: &Layout, order: &[usize]) {
    for (k, &i) in order.iter().enumerate() {
        let r = &a.specs[i];
        if let Some((lo, hi)) = band(a, &r.id) {
            let _ = writeln!(
                s,
                r##"<line x1="{0:.1}" y1="{1:.1}" x2="{0:.1}" y2="{2:.1}" stroke="#bbbbbb" stroke-width="7"/>"##,
                l.x(k),
                l.y(lo),
                l.y(hi)
            );
        }
        let colour = if r.rule_holds { "#1f77b4" } else { "#d62728" };
        let _ = writeln!(
            s,
            r##"<line x1="{0:.1}" y1="{1:.1}" x2="{0:.1}" y2="{2:.1}" stroke="{colour}" stroke-width="2"/>"##,
            l.x(k),
            l.y(r.estimate.lower),
            l.y(r.estimate.upper)
        );
        let shape = if r.primary {
            format!(
                r#"<rect x="{:.1}" y="{:.1}" width="9" height="9" fill="{colour}"/>"#,
                l.x(k) - 4.5,
                l.y(r.estimate.mean) - 4.5
            )
        } else {
            format!(r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="{colour}"/>"#, l.x(k), l.y(r.estimate.mean))
        };
        let _ = writeln!(s, "{shape}");
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            l.x(k),
            l.top + l.plot_h + 16.0,
            esc(&r.id)
        );
    }
}

/// One row per alternative under the plot: its label, and for each
/// specification in `order` a dot, filled where it takes the alternative.
fn curve_choices(s: &mut String, a: &MultiverseAnalysis, l: &Layout, order: &[usize], rows: &[(String, String)]) {
    let base = l.top + l.plot_h + 34.0;
    for (row, (setting, value)) in rows.iter().enumerate() {
        let yy = base + l.row_h * row as f64;
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#,
            l.left - 8.0,
            yy + 4.0,
            esc(&format!("{setting} = {value}"))
        );
        let c = a.choices.iter().position(|c| &c.setting == setting).unwrap_or(0);
        for (k, &i) in order.iter().enumerate() {
            let takes = a.specs[i].values.get(c) == Some(value);
            let fill = if takes { "black" } else { "white" };
            let _ = writeln!(s, r#"<circle cx="{:.1}" cy="{yy:.1}" r="4" fill="{fill}" stroke="black"/>"#, l.x(k));
        }
    }
}
