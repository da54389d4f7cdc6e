//! report.md of a multiverse or a draw-replicated study, one function
//! per section.

use std::fmt::Write as _;

use super::super::{f, level_pct};
use super::{label, verdict};
use crate::analysis::multiverse::MultiverseAnalysis;

/// report.md.
pub fn render_markdown(a: &MultiverseAnalysis) -> String {
    let mut s = header(a);
    if !a.choices.is_empty() {
        specifications(&mut s, a);
        choice_effects(&mut s, a);
        if let Some(j) = &a.joint {
            joint(&mut s, j, label(a));
        }
    }
    s.push_str(&notes_section(a));
    if !a.shared.is_empty() {
        shared_draws(&mut s, a);
    }
    if !a.draws.is_empty() {
        draw_replication(&mut s, a);
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

/// The verdict, the study, its status and what stands beside the verdict
/// (a reference arm that is not disjoint, its condition coverage), the
/// design's hash and the rule.
fn header(a: &MultiverseAnalysis) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{}\n", verdict(a));
    let _ = writeln!(
        s,
        "# {}: {}\n",
        if a.choices.is_empty() { "Draw replication" } else { "Multiverse" },
        super::super::md_text(&a.study)
    );
    let _ = writeln!(s, "{}.\n", a.header.standing.sentence());
    for g in a.guards.iter().map(|g| &g.text) {
        let _ = writeln!(s, "{g}\n");
    }
    if let Some(h) = &a.header.design_sha256 {
        let _ = writeln!(s, "Design SHA-256: `{h}`. Build: crossaudit {}.\n", crate::io::BUILD);
    }
    let _ = writeln!(
        s,
        "Rule: `{}`, decided {}. d is the primary endpoint's treated - reference difference in {} (negative: the treated arm looks better); optimism is 100 (reference - treated) / reference, in percent.\n",
        a.rule,
        if a.choices.is_empty() && a.draws.iter().any(|d| d.pooled.is_some()) {
            "on d pooled over the draws".to_string()
        } else {
            a.combine.describe()
        },
        // Metres spelled out, as before; any other unit as the tables write it.
        match label(a) {
            "m" => "metres",
            other => other,
        }
    );
    s
}

/// One row per specification, and the curve.
fn specifications(s: &mut String, a: &MultiverseAnalysis) {
    let _ = writeln!(s, "## Specifications\n");
    let mut header = vec!["spec".to_string()];
    header.extend(a.choices.iter().map(|c| c.setting.clone()));
    let u = label(a);
    let level = level_pct(a.specs.first().map(|r| r.estimate.level).unwrap_or(0.95));
    header.extend([
        format!("d ({u})"),
        format!("interval ({u})"),
        "optimism".into(),
        format!("optimism {level} CI"),
        "rule".into(),
        "trained".into(),
    ]);
    let _ = writeln!(s, "| {} |", header.join(" | "));
    let _ = writeln!(s, "|{}", "---|".repeat(header.len()));
    for r in &a.specs {
        let mut row = vec![if r.primary { format!("{} (primary)", r.id) } else { r.id.clone() }];
        row.extend(r.values.iter().cloned());
        row.push(f(r.estimate.mean, 4));
        row.push(format!("[{}, {}]", f(r.estimate.lower, 4), f(r.estimate.upper, 4)));
        row.push(format!("{}%", f(r.optimism_pct, 1)));
        row.push(match r.optimism_interval {
            None => "-".to_string(),
            iv => crate::report::format::fieller_text(iv, "%").unwrap_or_else(|| "unbounded".into()),
        });
        row.push(if r.rule_holds { "met" } else { "not met" }.to_string());
        row.push(match &r.shares_run_of {
            Some(o) => format!("no (cells of {o})"),
            None => "yes".to_string(),
        });
        let _ = writeln!(s, "| {} |", row.join(" | "));
    }
    let _ = writeln!(
        s,
        "\nIntervals: the design's estimator at {level} per specification; the optimism's is Fieller's, from the same estimator. A point's colour says whether the specification's preregistered rule holds (blue) or not (red); it is not whether its interval excludes zero: an interval wholly below zero is red where the optimism threshold is not met. Table: specs.csv.\n\n![spec_curve.svg](spec_curve.svg)\n",
    );
    spec_guards(s, a);
}

/// Each specification's own guards: its rule's margin, a fragile
/// decision, early stopping held fixed (the reference arm and early
/// training are in their own table).
fn spec_guards(s: &mut String, a: &MultiverseAnalysis) {
    if a.specs.iter().all(|r| r.guards.is_empty()) {
        return;
    }
    let _ = writeln!(
        s,
        "### Beside each specification's verdict
"
    );
    for r in a.specs.iter().filter(|r| !r.guards.is_empty()) {
        let _ = writeln!(s, "- **{}** ({}):", r.id, if r.rule_holds { "met" } else { "not met" });
        for g in &r.guards {
            let _ = writeln!(s, "  - {}", g.text);
        }
    }
    let _ = writeln!(s);
}

/// Each choice's paired effect on d.
fn choice_effects(s: &mut String, a: &MultiverseAnalysis) {
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
    let u = label(a);
    let _ = writeln!(s, "| choice | from (primary) | to | specs per side | effect on d ({u}) | interval ({u}) | df |");
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
}

/// The joint bootstrap over the curve and the curve under the null.
fn joint(s: &mut String, j: &crate::analysis::multiverse::JointBootstrap, u: &str) {
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
    let _ = writeln!(s, "| spec | bootstrap SE ({u}) | simultaneous band ({u}) |");
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
    let _ = writeln!(s, "| median d over specifications ({u}) | {} | {} |", f(n.median.0, 4), f(n.median.1, 4));
    let _ = writeln!(
        s,
        "| specifications meeting the rule (on the shared recordings) | {} | {} |",
        n.holding.0,
        f(n.holding.1, 4)
    );
    let _ = writeln!(s, "| Stouffer's combined t | {} | {} |", f(n.stouffer.0, 3), f(n.stouffer.1, 4));
}

/// The draws the specifications share.
fn shared_draws(s: &mut String, a: &MultiverseAnalysis) {
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

/// Each draw's d, and the pooled fit over the draws.
fn draw_replication(s: &mut String, a: &MultiverseAnalysis) {
    let _ = writeln!(s, "\n## Draw replication\n");
    let _ = writeln!(
        s,
        "Each draw redraws the validation recordings and windows, the fit and contamination windows and the starts, with the evaluation recordings fixed.\n"
    );
    for d in &a.draws {
        if d.spec != "-" {
            let _ = writeln!(s, "### Specification {}\n", d.spec);
        }
        let u = label(a);
        let _ = writeln!(s, "| draw | d ({u}) | interval ({u}) | optimism | rule |");
        let _ = writeln!(s, "|---:|---:|---|---:|---|");
        for (k, m, lo, hi, opt, holds) in &d.per_draw {
            let rule = if *holds { "met" } else { "not met" };
            let _ = writeln!(s, "| {k} | {} | [{}, {}] | {}% | {rule} |", f(*m, 4), f(*lo, 4), f(*hi, 4), f(*opt, 1));
        }
        match (&d.pooled, &d.error) {
            (Some(p), _) => {
                let _ = writeln!(
                    s,
                    "\nREML over recording x seed x draw (d ~ 1 + (1|recording) + (1|seed) + (1|draw) + (1|recording:draw) + (1|seed:draw)): pooled d = {} {u}, SE {} {u}, {} df {}, {} interval [{}, {}] {u}, optimism {}%: the rule is {} on the pooled estimate.\n",
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
                let _ = writeln!(s, "| source | levels | variance ({u}^2) | share of Var(pooled d) |");
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
        "Reference arm: windows of its fit set from evaluation recordings or their identical copies (invariant 5; 0: disjoint). Early: fitted models whose best validation epoch (the weights the rollouts use) lies in the first tenth of training, per arm. Mean d: the primary d averaged over the seeds with such a model of the primary endpoint, and over the others.\n"
    );
    let u = label(a);
    let _ = writeln!(s, "| unit | rule | reference-arm windows from evaluation copies | early best epochs | mean d, seeds with ({u}) | mean d, seeds without ({u}) |");
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
                let unknown = match e.seeds_unknown.len() {
                    0 => String::new(),
                    n => format!("; {n} seed(s) with curves missing, in neither"),
                };
                (arms.join(", ") + &unknown, d(e.mean_d_with, e.seeds_with.len()), d(e.mean_d_without, e.seeds_without))
            }
            None => ("-".to_string(), "-".to_string(), "-".to_string()),
        };
        let _ = writeln!(s, "| {} | {rule} | {copies} | {early} | {with} | {without} |", n.id);
    }
    s
}
