use std::fmt::Write as _;

use super::f;
use crate::analysis::{Analysis, UnitResult};
use crate::design::{Factor, Role};
use crate::stats::CrossedEstimate;

fn ci(e: &CrossedEstimate) -> String {
    format!("[{}, {}]", f(e.lower, 4), f(e.upper, 4))
}

fn df(e: &CrossedEstimate) -> String {
    if e.df.is_infinite() {
        "z".into()
    } else {
        f(e.df, 1)
    }
}

fn unit_name(u: &UnitResult) -> String {
    format!("{} | {} | {} s", u.model, u.metric.name(), u.horizon_s)
}

pub fn render_markdown(a: &Analysis) -> String {
    let mut s = String::new();
    let level = format!("{}%", f(a.level * 100.0, 0));
    let verdict = if a.decision.holds {
        a.decision.name.to_uppercase()
    } else {
        format!("NOT {}", a.decision.name.to_uppercase())
    };
    let _ = writeln!(s, "# {}: {}{}", a.study, verdict, if a.exploratory { " (EXPLORATORY)" } else { "" });
    let _ = writeln!(s);
    let _ = writeln!(s, "{}", a.decision.summary());
    let _ = writeln!(s);
    let _ = writeln!(s, "Rule: `{}`, evaluated on {}.", a.decision.rule, a.decision.unit);
    let _ = writeln!(
        s,
        "Contrast `{} - {}` over {} recordings x {} seeds; crossed method-of-moments estimator, {level} intervals.",
        a.treated,
        a.reference,
        a.recordings.len(),
        a.seeds.len()
    );
    if let Some(h) = &a.design_sha256 {
        let _ = writeln!(s, "Design SHA-256: `{h}`.");
    }
    let _ = writeln!(s);

    if !a.figures.is_empty() {
        let _ = writeln!(s, "## Figures");
        let _ = writeln!(s);
        for f in &a.figures {
            let _ = writeln!(s, "![{f}]({f})");
            let _ = writeln!(s);
        }
    }

    let _ = writeln!(s, "## Endpoints");
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "| role | model | metric | horizon | {} mean | {} mean | optimism % | d mean | SE | df | {level} CI | bootstrap {level} CI | rule |",
        a.treated, a.reference
    );
    let _ = writeln!(s, "|---|---|---|---|---:|---:|---:|---:|---:|---:|---|---|---|");
    for u in &a.units {
        let e = &u.estimate;
        let boot = u.bootstrap.map(|b| format!("[{}, {}]", f(b.lower, 4), f(b.upper, 4))).unwrap_or_else(|| "-".into());
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            if u.role == Role::Primary { "primary" } else { "secondary" },
            unit_name(u),
            f(u.mean_treated, 4),
            f(u.mean_reference, 4),
            f(u.optimism_pct, 1),
            f(e.mean, 4),
            f(e.se, 4),
            df(e),
            ci(e),
            boot,
            if u.rule_holds { "holds" } else { "fails" }
        );
    }
    let _ = writeln!(s);

    let _ = writeln!(s, "## Variance components of d");
    let _ = writeln!(s);
    let _ = writeln!(s, "Shares are of SE^2 = s2_rec/I + s2_seed/J + s2_res/(IJ).");
    let _ = writeln!(s);
    let _ = writeln!(s, "| model | metric | horizon | MS rec | MS seed | MS res | s2 rec | s2 seed | s2 res | share rec % | share seed % | share res % |");
    let _ = writeln!(s, "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for u in &a.units {
        let e = &u.estimate;
        let (m, c) = (&e.mean_squares, &e.components);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            unit_name(u),
            sci(m.ms_rows),
            sci(m.ms_cols),
            sci(m.ms_error),
            sci(c.recording),
            sci(c.seed),
            sci(c.residual),
            f(100.0 * e.share_recording, 1),
            f(100.0 * e.share_seed, 1),
            f(100.0 * e.share_residual, 1)
        );
    }
    let _ = writeln!(s);

    if !a.interactions.is_empty() {
        let _ = writeln!(s, "## Interaction");
        let _ = writeln!(s);
        let _ = writeln!(s, "delta_ij = d_left,ij - d_right,ij, same estimator.");
        let _ = writeln!(s);
        let _ =
            writeln!(s, "| contrast | metric | horizon | delta mean | SE | df | {level} CI | bootstrap {level} CI |");
        let _ = writeln!(s, "|---|---|---|---:|---:|---:|---|---|");
        for ix in &a.interactions {
            let e = &ix.estimate;
            let boot =
                ix.bootstrap.map(|b| format!("[{}, {}]", f(b.lower, 4), f(b.upper, 4))).unwrap_or_else(|| "-".into());
            let _ = writeln!(
                s,
                "| {} - {} | {} | {} s | {} | {} | {} | {} | {} |",
                ix.left,
                ix.right,
                ix.metric.name(),
                ix.horizon_s,
                f(e.mean, 4),
                f(e.se, 4),
                df(e),
                ci(e),
                boot
            );
        }
        let _ = writeln!(s);
    }

    if a.units.iter().any(|u| u.grouped.is_some()) {
        let _ = writeln!(s, "## Grouped sensitivity");
        let _ = writeln!(s);
        let _ = writeln!(s, "d averaged within condition groups, then the same estimator on groups x seeds.");
        let _ = writeln!(s);
        let _ = writeln!(s, "| model | metric | horizon | groups | d mean | SE | df | {level} CI |");
        let _ = writeln!(s, "|---|---|---|---:|---:|---:|---:|---|");
        for u in &a.units {
            if let Some(g) = &u.grouped {
                let e = &g.estimate;
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {} |",
                    unit_name(u),
                    g.groups.len(),
                    f(e.mean, 4),
                    f(e.se, 4),
                    df(e),
                    ci(e)
                );
            }
        }
        let _ = writeln!(s);
    }

    if a.units.iter().any(|u| !u.leave_one_out.is_empty()) {
        let _ = writeln!(s, "## Leave-one-out");
        let _ = writeln!(s);
        let _ = writeln!(s, "| model | metric | horizon | left out | fits | d mean range | upper range | optimism % range | rule holds |");
        let _ = writeln!(s, "|---|---|---|---|---:|---|---|---|---:|");
        for u in &a.units {
            for l in &u.leave_one_out {
                let _ = writeln!(
                    s,
                    "| {} | one {} | {} | [{}, {}] | [{}, {}] | [{}, {}] | {}/{} |",
                    unit_name(u),
                    match l.factor {
                        Factor::Seed => "seed",
                        Factor::Recording => "recording",
                    },
                    l.fits,
                    f(l.mean_min, 4),
                    f(l.mean_max, 4),
                    f(l.upper_min, 4),
                    f(l.upper_max, 4),
                    f(l.optimism_min, 1),
                    f(l.optimism_max, 1),
                    l.rule_holds,
                    l.fits
                );
            }
        }
        let _ = writeln!(s);
    }

    let _ = writeln!(s, "## Per-seed optimism");
    let _ = writeln!(s);
    let _ = writeln!(s, "| model | metric | horizon | min % | max % | seeds below 0 |");
    let _ = writeln!(s, "|---|---|---|---:|---:|---:|");
    for u in &a.units {
        let v: Vec<f64> = u.per_seed_optimism.iter().map(|p| p.optimism_pct).collect();
        let min = v.iter().cloned().fold(f64::INFINITY, f64::min);
        let max = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} |",
            unit_name(u),
            f(min, 1),
            f(max, 1),
            v.iter().filter(|x| **x < 0.0).count()
        );
    }
    let _ = writeln!(s);

    let _ = writeln!(s, "## Mean difference by trajectory");
    let _ = writeln!(s);
    let _ = writeln!(s, "| model | metric | horizon | trajectory | recordings | mean d |");
    let _ = writeln!(s, "|---|---|---|---|---:|---:|");
    for u in &a.units {
        for t in &u.per_trajectory {
            let _ =
                writeln!(s, "| {} | {} | {} | {} |", unit_name(u), t.trajectory, t.recordings, f(t.mean_difference, 4));
        }
    }
    let _ = writeln!(s);

    let _ = writeln!(s, "## Conditional RMSE and divergence");
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "| model | metric | horizon | cond. RMSE {t} | cond. RMSE {r} | divergent {t} | divergent {r} | cond. d mean | cond. {level} CI |",
        t = a.treated,
        r = a.reference
    );
    let _ = writeln!(s, "|---|---|---|---:|---:|---:|---:|---:|---|");
    for u in &a.units {
        let c = &u.conditional;
        let opt = |v: Option<f64>| v.map(|x| f(x, 4)).unwrap_or_else(|| "NA".into());
        let (dm, dci) = match &c.difference {
            Some(e) => (f(e.mean, 4), ci(e)),
            None => ("NA".into(), format!("({} cells without a finite rollout)", c.cells_without_finite_rollout)),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {}/{} | {}/{} | {} | {} |",
            unit_name(u),
            opt(c.mean_conditional_treated),
            opt(c.mean_conditional_reference),
            c.divergent_treated,
            c.starts_treated,
            c.divergent_reference,
            c.starts_reference,
            dm,
            dci
        );
    }
    let _ = writeln!(s);

    if a.units.iter().any(|u| u.intervals.is_some()) {
        let _ = writeln!(s, "## Interval estimators compared");
        let _ = writeln!(s);
        let _ = writeln!(s, "| model | metric | horizon | method | estimate | SE | df | {level} CI | excludes 0 |");
        let _ = writeln!(s, "|---|---|---|---|---:|---:|---:|---|---|");
        for u in &a.units {
            for iv in u.intervals.iter().flatten() {
                let dfs = if iv.df.is_nan() {
                    "-".into()
                } else if iv.df.is_infinite() {
                    "z".into()
                } else {
                    f(iv.df, 1)
                };
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | [{}, {}] | {} |",
                    unit_name(u),
                    iv.method.label(),
                    f(iv.estimate, 4),
                    f(iv.se, 4),
                    dfs,
                    f(iv.lower, 4),
                    f(iv.upper, 4),
                    if iv.lower > 0.0 || iv.upper < 0.0 { "yes" } else { "no" }
                );
            }
        }
        let _ = writeln!(s);
    }

    if !a.warnings.is_empty() {
        let _ = writeln!(s, "## Warnings");
        let _ = writeln!(s);
        for w in &a.warnings {
            let _ = writeln!(s, "- {w}");
        }
        let _ = writeln!(s);
    }
    s
}

/// Variance-scale numbers span many orders of magnitude.
fn sci(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else {
        format!("{v:.3e}")
    }
}
