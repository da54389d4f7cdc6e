//! A multiverse's report: the decision by the declared combination on
//! line 1, one row per specification, each choice's paired effect, the
//! joint bootstrap, the draws the specifications share, draw replication,
//! and the specification curve (`spec_curve.svg`): every specification's
//! estimate with its interval, in order, and under it which alternative
//! each takes. `specs.csv` and `choice_effects.csv` are the tidy tables.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

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
        ("report.md", markdown),
        ("multiverse.json", pretty_json(a)),
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
                "{v} on d pooled over {draws} draws: d = {} m [{}, {}], optimism {}% (the rule holds in {holding} of the {draws} draws alone).",
                f(p.mean, 4),
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

fn verdict(a: &MultiverseAnalysis) -> String {
    sentence(a, true)
}

/// The banner of report.html: the verdict by the declared combination.
fn banner(a: &MultiverseAnalysis) -> super::html::Banner {
    let d = &a.decision;
    super::html::Banner::new(&d.name, d.holds, decision_line(a), a.exploratory, a.preregistered)
}

/// The decision line `run` and `analyze` print for a multiverse or a
/// draw-replicated study.
pub fn decision_line(a: &MultiverseAnalysis) -> String {
    super::format::labelled(sentence(a, false), a.exploratory, a.preregistered)
}

/// report.md.
pub fn render_markdown(a: &MultiverseAnalysis) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{}\n", verdict(a));
    let _ = writeln!(
        s,
        "# {}: {}\n",
        if a.choices.is_empty() { "Draw replication" } else { "Multiverse" },
        super::md_text(&a.study)
    );
    let status = match (a.preregistered, a.exploratory) {
        (_, true) => "EXPLORATORY: the design changed after it was locked, or the run was labelled so.",
        (Some(true), _) => "Preregistered: the design was locked before the run and is unchanged.",
        _ => "NOT PREREGISTERED: the design was never locked.",
    };
    let amended = a.warnings.iter().any(|w| w.starts_with("the design was amended"));
    let _ = writeln!(
        s,
        "{status}{}\n",
        if amended { " The design was amended after it was first locked (the warnings say how and why)." } else { "" }
    );
    // Beside the verdict: a reference arm that is not disjoint (the
    // primary specification's; under draw replication, over the draws).
    let primary = a.specs.iter().find(|r| r.primary).map(|r| format!("spec-{}", r.id));
    let decided: Vec<&crate::analysis::multiverse::ReferenceCopies> = a
        .notes
        .iter()
        .filter(|n| a.choices.is_empty() || Some(&n.id) == primary.as_ref())
        .filter_map(|n| n.reference_copies.as_ref())
        .collect();
    if !decided.is_empty() {
        let all = crate::analysis::multiverse::ReferenceCopies {
            fewest: decided.iter().map(|c| c.fewest).min().unwrap_or(0),
            most: decided.iter().map(|c| c.most).max().unwrap_or(0),
            levels_with: decided.iter().map(|c| c.levels_with).sum(),
            levels: if a.choices.is_empty() { a.notes.len() } else { decided[0].levels },
        };
        let _ = writeln!(
            s,
            "**The reference arm is not disjoint** ({}): {}; allowed only because the design declares `duplicates keep` (table: the reference arm and the training).\n",
            primary.as_deref().filter(|_| !a.choices.is_empty()).unwrap_or("every draw"),
            copies_text(&all)
        );
    }
    // Beside the verdict: the reference arm's condition coverage (the
    // primary specification's, or every unit's).
    for n in a.notes.iter().filter(|n| a.choices.is_empty() || Some(&n.id) == primary.as_ref()) {
        if let Some(c) = &n.coverage {
            let who = if a.notes.len() > 1 && a.choices.is_empty() { format!("{}: ", n.id) } else { String::new() };
            let _ = writeln!(s, "{who}{}\n", super::coverage::note_sentence(c));
        }
    }
    if let Some(h) = &a.design_sha256 {
        let _ = writeln!(s, "Design SHA-256: `{h}`. Build: crossaudit {}.\n", crate::io::BUILD);
    }
    let _ = writeln!(
        s,
        "Rule: `{}`, decided {}. d is the primary endpoint's treated - reference difference in metres (negative: the treated arm looks better); optimism is 100 (reference - treated) / reference, in percent.\n",
        a.rule,
        if a.choices.is_empty() && a.draws.iter().any(|d| d.pooled.is_some()) {
            "on d pooled over the draws".to_string()
        } else {
            a.combine.describe()
        }
    );
    if !a.choices.is_empty() {
        let _ = writeln!(s, "## Specifications\n");
        let mut header = vec!["spec".to_string()];
        header.extend(a.choices.iter().map(|c| c.setting.clone()));
        header.extend(["d (m)", "interval (m)", "optimism", "rule", "trained"].map(String::from));
        let _ = writeln!(s, "| {} |", header.join(" | "));
        let _ = writeln!(s, "|{}", "---|".repeat(header.len()));
        for r in &a.specs {
            let mut row = vec![if r.primary { format!("{} (primary)", r.id) } else { r.id.clone() }];
            row.extend(r.values.iter().cloned());
            row.push(f(r.estimate.mean, 4));
            row.push(format!("[{}, {}]", f(r.estimate.lower, 4), f(r.estimate.upper, 4)));
            row.push(format!("{}%", f(r.optimism_pct, 1)));
            row.push(if r.rule_holds { "met" } else { "not met" }.to_string());
            row.push(match &r.shares_run_of {
                Some(o) => format!("no (cells of {o})"),
                None => "yes".to_string(),
            });
            let _ = writeln!(s, "| {} |", row.join(" | "));
        }
        let level = a.specs.first().map(|r| r.estimate.level).unwrap_or(0.95);
        let _ = writeln!(
            s,
            "\nIntervals: the design's estimator at {} per specification. A point's colour says whether the specification's preregistered rule holds (blue) or not (red); it is not whether its interval excludes zero: an interval wholly below zero is red where the optimism threshold is not met. Table: specs.csv.\n\n![spec_curve.svg](spec_curve.svg)\n",
            level_pct(level)
        );
        let _ = writeln!(s, "## Paired effect of each choice on d\n");
        let pooled = a.choice_effects.iter().map(|e| e.pooled_draws).max().unwrap_or(0);
        let _ = writeln!(
            s,
            "Per recording and seed: mean d over the specifications taking the alternative minus mean d over those taking the primary's; {}\n",
            if pooled > 0 {
                format!("that matrix in each of the {pooled} draws, pooled by REML over recording, seed, draw and their interactions with Kenward-Roger df, as each specification's d is.")
            } else {
                "the design's crossed estimator on that matrix.".to_string()
            }
        );
        let _ = writeln!(s, "| choice | from (primary) | to | specs per side | effect on d (m) | interval (m) | df |");
        let _ = writeln!(s, "|---|---|---|---:|---:|---|---:|");
        for e in &a.choice_effects {
            let (est, int, df) = match &e.estimate {
                Some(x) => (f(x.mean, 4), format!("[{}, {}]", f(x.lower, 4), f(x.upper, 4)), f(x.df, 1)),
                None => ("-".into(), e.error.clone().unwrap_or_default(), "-".into()),
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {est} | {int} | {df} |",
                e.setting, e.reference, e.alternative, e.specs_per_side
            );
        }
        if let Some(j) = &a.joint {
            let _ = writeln!(s, "\n## Joint inference over the curve\n");
            let _ = writeln!(
                s,
                "{} pigeonhole replicates (seed {}), each resampling the {} shared recordings and the seeds once for every specification; simultaneous {} bands are d +/- {} x the bootstrap SE (the max-|t| quantile).\n",
                j.replicates,
                j.seed,
                j.recordings,
                level_pct(j.level),
                f(j.critical, 3)
            );
            let _ = writeln!(s, "| spec | bootstrap SE (m) | simultaneous band (m) |");
            let _ = writeln!(s, "|---|---:|---|");
            for (id, se, lo, hi) in &j.bands {
                let _ = writeln!(s, "| {id} | {} | [{}, {}] |", f(*se, 4), f(*lo, 4), f(*hi, 4));
            }
            let (obs, lo, hi) = j.share_negative;
            let _ = writeln!(
                s,
                "\n{} of {} simultaneous bands exclude zero. Share of specifications with d < 0: {}% (bootstrap {}: [{}%, {}%]; descriptive: this bootstrap is centred at the observed estimates, so it is no test of a null).",
                j.bands_excluding_zero,
                j.bands.len(),
                f(100.0 * obs, 1),
                level_pct(j.level),
                f(100.0 * lo, 1),
                f(100.0 * hi, 1)
            );
            let n = &j.null;
            let _ = writeln!(
                s,
                "\nThe curve under the null (Simonsohn, Simmons and Nelson 2020, step 3; specr's `boot_null`): each specification's d matrix centred at zero, the same {} resamples for every specification; one-sided p-values in the rule's direction, (1 + replicates at least as extreme) / (1 + replicates).\n",
                j.replicates
            );
            let _ = writeln!(s, "| statistic | observed | p under the null |");
            let _ = writeln!(s, "|---|---:|---:|");
            let _ = writeln!(s, "| median d over specifications (m) | {} | {} |", f(n.median.0, 4), f(n.median.1, 4));
            let _ = writeln!(
                s,
                "| specifications meeting the rule (on the shared recordings) | {} | {} |",
                n.holding.0,
                f(n.holding.1, 4)
            );
            let _ = writeln!(s, "| Stouffer's combined t | {} | {} |", f(n.stouffer.0, 3), f(n.stouffer.1, 4));
        }
    }
    s.push_str(&notes_section(a));
    if !a.shared.is_empty() {
        let _ = writeln!(s, "\n## Draws the specifications share\n");
        let _ = writeln!(s, "| left | right | evaluation recordings | starts | reference-arm fit windows |");
        let _ = writeln!(s, "|---|---|---:|---:|---:|");
        let pct = |(n, of): (usize, usize)| format!("{n} / {of} ({}%)", f(100.0 * n as f64 / of.max(1) as f64, 1));
        for p in &a.shared {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} |",
                p.left,
                p.right,
                pct(p.recordings),
                pct(p.starts),
                pct(p.fit_windows)
            );
        }
    }
    if !a.draws.is_empty() {
        let _ = writeln!(s, "\n## Draw replication\n");
        let _ = writeln!(
            s,
            "Each draw redraws the validation recordings and windows, the fit and contamination windows and the starts, with the evaluation recordings fixed.\n"
        );
        for d in &a.draws {
            if d.spec != "-" {
                let _ = writeln!(s, "### Specification {}\n", d.spec);
            }
            let _ = writeln!(s, "| draw | d (m) | interval (m) | optimism | rule |");
            let _ = writeln!(s, "|---:|---:|---|---:|---|");
            for (k, m, lo, hi, opt, holds) in &d.per_draw {
                let rule = if *holds { "met" } else { "not met" };
                let _ =
                    writeln!(s, "| {k} | {} | [{}, {}] | {}% | {rule} |", f(*m, 4), f(*lo, 4), f(*hi, 4), f(*opt, 1));
            }
            match (&d.pooled, &d.error) {
                (Some(p), _) => {
                    let _ = writeln!(
                        s,
                        "\nREML over recording x seed x draw (d ~ 1 + (1|recording) + (1|seed) + (1|draw) + (1|recording:draw) + (1|seed:draw)): pooled d = {} m, SE {} m, {} df {}, {} interval [{}, {}] m, optimism {}%: the rule is {} on the pooled estimate.\n",
                        f(p.mean, 4),
                        f(p.se, 4),
                        if p.df_rule == "kenward_roger" { "Kenward-Roger" } else { "Satterthwaite" },
                        f(p.df, 1),
                        level_pct(p.level),
                        f(p.lower, 4),
                        f(p.upper, 4),
                        f(p.optimism_pct, 1),
                        if p.rule_holds { "met" } else { "not met" }
                    );
                    let levels: std::collections::BTreeMap<&str, usize> =
                        p.levels.iter().map(|(n, k)| (n.as_str(), *k)).collect();
                    let _ = writeln!(s, "| source | levels | variance (m^2) | share of Var(pooled d) |");
                    let _ = writeln!(s, "|---|---:|---:|---:|");
                    for (n, v, sh) in &d.components {
                        let k = levels.get(n.as_str()).map(|k| k.to_string()).unwrap_or_else(|| "-".into());
                        let _ = writeln!(s, "| {n} | {k} | {:.3e} | {}% |", v, f(100.0 * sh, 1));
                    }
                    for note in &p.notes {
                        let _ = writeln!(s, "\nNote: {note}.");
                    }
                    let _ = writeln!(s);
                }
                (None, Some(e)) => {
                    let _ = writeln!(s, "\nNo pooled fit: {e}\n");
                }
                _ => {}
            }
        }
    }
    if !a.warnings.is_empty() {
        let _ = writeln!(s, "\n## Warnings\n");
        for w in &a.warnings {
            let _ = writeln!(s, "- {}", crate::io::md_line(w));
        }
    }
    let _ = writeln!(s, "\nEach level's full report (audit, treatment audit, invariants, secondary endpoints) is in its directory's report/.");
    s
}

/// How many reference-arm fit windows come from evaluation recordings or
/// their copies.
fn copies_text(c: &crate::analysis::multiverse::ReferenceCopies) -> String {
    let n = if c.fewest == c.most { c.most.to_string() } else { format!("{} to {}", c.fewest, c.most) };
    let draws = if c.levels > 1 { format!(" (in {} of its {} draws)", c.levels_with, c.levels) } else { String::new() };
    format!("{n} of its fit windows come from byte-identical copies of evaluation recordings{draws}")
}

/// Per unit: whether the reference arm is disjoint, and how many models
/// reached their best epoch early, with the primary d of the seeds with
/// and without such a model.
fn notes_section(a: &MultiverseAnalysis) -> String {
    if a.notes.is_empty() {
        return String::new();
    }
    let mut s = String::new();
    let _ = writeln!(s, "\n## The reference arm and the training\n");
    let _ = writeln!(
        s,
        "Reference arm: windows of its fit set from evaluation recordings or their byte-identical copies (invariant 5; 0: disjoint). Early: fitted models whose best validation epoch (the weights the rollouts use) lies in the first tenth of training, per arm. Mean d: the primary d averaged over the seeds with such a model of the primary endpoint, and over the others.\n"
    );
    let _ = writeln!(s, "| unit | rule | reference-arm windows from evaluation copies | early best epochs | mean d, seeds with (m) | mean d, seeds without (m) |");
    let _ = writeln!(s, "|---|---|---:|---|---:|---:|");
    for n in &a.notes {
        let rule = a
            .specs
            .iter()
            .find(|r| format!("spec-{}", r.id) == n.id)
            .map(|r| if r.rule_holds { "met" } else { "not met" })
            .unwrap_or("-");
        let copies = match &n.reference_copies {
            Some(c) if c.fewest == c.most => c.most.to_string(),
            Some(c) => format!("{} to {}", c.fewest, c.most),
            None => "0".to_string(),
        };
        let (early, with, without) = match &n.early {
            Some(e) => {
                let arms: Vec<String> = e.per_arm.iter().map(|(arm, k, of)| format!("{arm} {k}/{of}")).collect();
                let d = |x: Option<f64>, seeds: usize| {
                    x.map(|v| format!("{} ({seeds})", f(v, 4))).unwrap_or_else(|| "-".into())
                };
                (arms.join(", "), d(e.mean_d_with, e.seeds_with.len()), d(e.mean_d_without, e.seeds_without))
            }
            None => ("-".to_string(), "-".to_string(), "-".to_string()),
        };
        let _ = writeln!(s, "| {} | {rule} | {copies} | {early} | {with} | {without} |", n.id);
    }
    s
}

/// specs.csv: one row per specification.
pub fn specs_csv(a: &MultiverseAnalysis) -> String {
    let mut s = String::from("spec");
    for c in &a.choices {
        let _ = write!(s, ",{}", c.setting);
    }
    s.push_str(",primary,d_m,se_m,df,lower_m,upper_m,mean_treated_m,mean_reference_m,optimism_pct,rule_holds,joint_lower_m,joint_upper_m,trained\n");
    for r in &a.specs {
        let _ = write!(s, "{}", r.id);
        for v in &r.values {
            let _ = write!(s, ",{v}");
        }
        let band = a.joint.as_ref().and_then(|j| j.bands.iter().find(|b| b.0 == r.id));
        let e = &r.estimate;
        let _ = writeln!(
            s,
            ",{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.primary,
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
            r.shares_run_of.is_none()
        );
    }
    s
}

/// choice_effects.csv.
pub fn effects_csv(a: &MultiverseAnalysis) -> String {
    let mut s =
        String::from("choice,reference,alternative,specs_per_side,recordings,effect_m,se_m,df,lower_m,upper_m\n");
    for e in &a.choice_effects {
        let x = e.estimate.as_ref();
        let v = |g: fn(&crate::stats::CrossedEstimate) -> f64| x.map(|x| g(x).to_string()).unwrap_or_default();
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{}",
            e.setting,
            e.reference,
            e.alternative,
            e.specs_per_side,
            e.recordings,
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
    let band = |id: &str| a.joint.as_ref().and_then(|j| j.bands.iter().find(|b| b.0 == id)).map(|b| (b.2, b.3));
    let mut lo = 0.0f64;
    let mut hi = 0.0f64;
    for r in &a.specs {
        lo = lo.min(r.estimate.lower);
        hi = hi.max(r.estimate.upper);
        if let Some((l, h)) = band(&r.id) {
            lo = lo.min(l);
            hi = hi.max(h);
        }
    }
    let pad = 0.05 * (hi - lo).max(1e-9);
    let (lo, hi) = (lo - pad, hi + pad);
    let y = |v: f64| top + plot_h * (hi - v) / (hi - lo);
    let x = |k: usize| left + col_w * (k as f64 + 0.5);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="13">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="10" y="20" font-size="16">d = treated - reference (m) by specification: {} intervals; grey: joint bands</text>"#,
        level_pct(a.specs.first().map(|r| r.estimate.level).unwrap_or(0.95))
    );
    let _ = writeln!(
        s,
        r##"<text x="10" y="40" font-size="13"><tspan fill="#1f77b4">blue: the rule holds</tspan>; <tspan fill="#d62728">red: it does not</tspan> (the colour is the rule, not whether the interval excludes 0)</text>"##
    );
    // Axis with ticks.
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
            y(v) + 4.0,
            if v.abs() < step * 1e-6 { 0.0 } else { v },
            left - 4.0,
            y(v),
            y(v)
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="20" y="{:.1}" transform="rotate(-90 20 {:.1})" text-anchor="middle">d (m)</text>"#,
        top + plot_h / 2.0,
        top + plot_h / 2.0
    );
    if lo < 0.0 && hi > 0.0 {
        let _ = writeln!(
            s,
            r#"<line x1="{left}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="grey" stroke-dasharray="4 3"/>"#,
            y(0.0),
            width - 30.0,
            y(0.0)
        );
    }
    for (k, &i) in order.iter().enumerate() {
        let r = &a.specs[i];
        if let Some((l, h)) = band(&r.id) {
            let _ = writeln!(
                s,
                r##"<line x1="{0:.1}" y1="{1:.1}" x2="{0:.1}" y2="{2:.1}" stroke="#bbbbbb" stroke-width="7"/>"##,
                x(k),
                y(l),
                y(h)
            );
        }
        let colour = if r.rule_holds { "#1f77b4" } else { "#d62728" };
        let _ = writeln!(
            s,
            r##"<line x1="{0:.1}" y1="{1:.1}" x2="{0:.1}" y2="{2:.1}" stroke="{colour}" stroke-width="2"/>"##,
            x(k),
            y(r.estimate.lower),
            y(r.estimate.upper)
        );
        let shape = if r.primary {
            format!(
                r#"<rect x="{:.1}" y="{:.1}" width="9" height="9" fill="{colour}"/>"#,
                x(k) - 4.5,
                y(r.estimate.mean) - 4.5
            )
        } else {
            format!(r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="{colour}"/>"#, x(k), y(r.estimate.mean))
        };
        let _ = writeln!(s, "{shape}");
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            x(k),
            top + plot_h + 16.0,
            esc(&r.id)
        );
    }
    let base = top + plot_h + 34.0;
    for (row, (setting, value)) in rows.iter().enumerate() {
        let yy = base + row_h * row as f64;
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#,
            left - 8.0,
            yy + 4.0,
            esc(&format!("{setting} = {value}"))
        );
        let c = a.choices.iter().position(|c| &c.setting == setting).unwrap_or(0);
        for (k, &i) in order.iter().enumerate() {
            let takes = a.specs[i].values.get(c) == Some(value);
            let fill = if takes { "black" } else { "white" };
            let _ = writeln!(s, r#"<circle cx="{:.1}" cy="{yy:.1}" r="4" fill="{fill}" stroke="black"/>"#, x(k));
        }
    }
    let key_y = height - 24.0;
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
