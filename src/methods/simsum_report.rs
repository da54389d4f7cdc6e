//! What `crossaudit simsum` writes from the groups [`super::simsum`]
//! scored: `simsum.csv` (tidy, one row per group, method and measure, as
//! rsimsum's `tidy()`), `simsum.md`, `simsum.svg` and the console summary,
//! each saying where a group's true value differs between replications.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::simsum::{reps_needed, stat, Columns, SimsumFileError, STATS};
use crossaudit_stats::simsum::{Group, Pairing};

/// What a group whose true value differs between replications is told.
pub const TRUTH_VARIES: &str = "the true value differs between this group's replications: each measure uses each replication's own (bias, relative bias, MSE, coverage), as rsimsum does with `true` as a column; the empirical SE is the SD of the estimates. If the true values mark different data-generating mechanisms, add their column to `--by` to summarise each on its own.";

/// The groups whose true value differs between replications, named, each
/// with [`TRUTH_VARIES`] (what the console says).
pub fn truth_notes(groups: &[Group], by: &[String]) -> Vec<String> {
    groups
        .iter()
        .filter(|g| g.truth.is_none())
        .map(|g| {
            let label: Vec<String> = by.iter().zip(&g.by).map(|(n, v)| format!("{n} = {v}")).collect();
            let name = if label.is_empty() { "the study".to_string() } else { format!("group {}", label.join(", ")) };
            format!("{}: {TRUTH_VARIES}", crate::io::one_line(&name))
        })
        .collect()
}

/// A group's true value in words: `true 0.5`, or each replication's own.
fn truth_label(g: &Group) -> String {
    match g.truth {
        Some(t) => format!("true {}", num(t)),
        None => "true value each replication's own".to_string(),
    }
}

fn num(x: f64) -> String {
    if x.is_nan() {
        "NA".into()
    } else {
        format!("{x}")
    }
}

/// simsum.csv: by-columns, true, level, method, stat, est, mcse: rsimsum's
/// measures, then `cover_ac` (the coverage with Agresti and Coull's MCSE),
/// `interval_score`, and the paired differences against the reference as
/// `cover_diff`, `bias_diff`, `width_diff`, `interval_score_diff`; for each
/// target MCSE, `reps_for_MEASURE_mcse_TARGET` (the replications needed).
pub fn to_csv(groups: &[Group], by: &[String], targets: &[(String, f64)]) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    // The file's own text (by-column names and values, methods) as a
    // spreadsheet shows text: never a formula.
    let text = |s: &str| crate::io::spreadsheet_text(s).into_owned();
    let mut head: Vec<String> = by.iter().map(|b| text(b)).collect();
    head.extend(["true", "level", "method", "stat", "est", "mcse"].map(String::from));
    let _ = w.write_record(&head);
    for g in groups {
        for m in &g.methods {
            let mut rows: Vec<(&str, f64, f64)> =
                STATS.iter().map(|s| (*s, stat(&m.performance, s))).map(|(s, (e, c))| (s, e, c)).collect();
            rows.push(("cover_ac", m.performance.coverage, m.coverage_mcse_adjusted));
            rows.push(("interval_score", m.interval_score.0, m.interval_score.1));
            let planned: Vec<(String, f64)> = targets
                .iter()
                .map(|(name, t)| {
                    (format!("reps_for_{name}_mcse_{t}"), reps_needed(m, name, *t).map_or(f64::NAN, |n| n as f64))
                })
                .collect();
            if let Some(d) = &m.versus_reference {
                rows.push(("cover_diff", d.coverage_diff, d.coverage_diff_mcse));
                rows.push(("bias_diff", d.bias_diff, d.bias_diff_mcse));
                rows.push(("width_diff", d.width_diff, d.width_diff_mcse));
                rows.push(("interval_score_diff", d.score_diff, d.score_diff_mcse));
            }
            let rows = rows.into_iter().map(|(s, e, c)| (s.to_string(), e, c));
            for (s, e, c) in rows.chain(planned.into_iter().map(|(s, n)| (s, n, f64::NAN))) {
                let mut rec: Vec<String> = g.by.iter().map(|b| text(b)).collect();
                // A truth that varies by replication has no one value: NA.
                rec.extend([num(g.truth.unwrap_or(f64::NAN)), num(g.level), text(&m.method), s, num(e), num(c)]);
                let _ = w.write_record(&rec);
            }
        }
    }
    String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
}

/// simsum.md: per group, each method's main measures as `est (MCSE)`, and
/// each method against the reference with paired MCSEs.
pub fn to_markdown(groups: &[Group], by: &[String], source: &str, targets: &[(String, f64)]) -> String {
    let mut s = format!("# Simulation study: {}\n\n", crate::io::md_text(source));
    let by_id = groups.iter().all(|g| g.paired_by == Pairing::Id);
    let _ = writeln!(
        s,
        "Measures as R's rsimsum 0.13 computes them (Monte Carlo SEs in brackets). Methods are paired {} for the relative precision and the paired differences{}.\n",
        if by_id { "by replication id" } else { "by order within each group" },
        if by_id { "" } else { " (the file has no replication ids, or some rows lack one: rsimsum's rule, which pairs wrongly if rows are not in the same order for every method)" }
    );
    let f = |e: f64, c: f64| if c.is_nan() { num(e) } else { format!("{} ({})", fmt4(e), fmt4(c)) };
    for g in groups {
        let label: Vec<String> = by
            .iter()
            .zip(&g.by)
            .map(|(n, v)| format!("{} = {}", crate::io::md_text(n), crate::io::md_text(v)))
            .collect();
        let _ = writeln!(
            s,
            "## {}{}, level {}\n",
            if label.is_empty() { String::new() } else { format!("{}, ", label.join(", ")) },
            truth_label(g),
            num(g.level)
        );
        if g.truth.is_none() {
            let _ = writeln!(s, "The {}\n", TRUTH_VARIES.trim_start_matches("the "));
        }
        let _ = writeln!(s, "| method | n | bias | empirical SE | model SE | relative error (%) | coverage | coverage MCSE (Agresti-Coull) | bias-eliminated coverage | power | relative precision vs {} (%) | interval score |", crate::io::md_text(&g.reference));
        let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
        for m in &g.methods {
            let p = &m.performance;
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                crate::io::md_text(&m.method),
                p.reps,
                f(p.bias, p.bias_mcse),
                f(p.emp_se, p.emp_se_mcse),
                f(p.mod_se, p.mod_se_mcse),
                f(p.rel_error_mod_se, p.rel_error_mod_se_mcse),
                f(p.coverage, p.coverage_mcse),
                fmt4(m.coverage_mcse_adjusted),
                f(p.be_coverage, p.be_coverage_mcse),
                f(p.power, p.power_mcse),
                f(p.rel_precision, p.rel_precision_mcse),
                f(m.interval_score.0, m.interval_score.1),
            );
        }
        let _ =
            writeln!(s, "\nAgainst {}, replication by replication (paired MCSEs; where no pair disagrees on covering, the coverage difference's is Agresti and Min's 1 / (pairs + 2), not 0):\n", crate::io::md_text(&g.reference));
        let _ = writeln!(
            s,
            "| method | pairs | coverage difference | bias difference | width difference | interval score difference |"
        );
        let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|");
        for m in &g.methods {
            if let Some(d) = &m.versus_reference {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {} |",
                    crate::io::md_text(&m.method),
                    d.pairs,
                    f(d.coverage_diff, d.coverage_diff_mcse),
                    f(d.bias_diff, d.bias_diff_mcse),
                    f(d.width_diff, d.width_diff_mcse),
                    f(d.score_diff, d.score_diff_mcse)
                );
            }
        }
        if !targets.is_empty() {
            plan_table(&mut s, g, targets);
        }
        s.push('\n');
    }
    s
}

/// Replications each method needs for each target MCSE.
fn plan_table(s: &mut String, g: &Group, targets: &[(String, f64)]) {
    let names: Vec<String> = targets.iter().map(|(m, t)| format!("{m} to {t}")).collect();
    let _ = writeln!(
        s,
        "\nReplications for the target MCSEs (n (MCSE / target)^2, from these {} replications):\n",
        g.methods.first().map_or(0, |m| m.performance.reps)
    );
    let _ = writeln!(s, "| method | {} |", names.join(" | "));
    let _ = writeln!(s, "|---|{}", "---:|".repeat(names.len()));
    for m in &g.methods {
        let cells: Vec<String> =
            targets.iter().map(|(n, t)| reps_needed(m, n, *t).map_or("NA".into(), |k| k.to_string())).collect();
        let _ = writeln!(s, "| {} | {} |", crate::io::md_text(&m.method), cells.join(" | "));
    }
}

fn fmt4(x: f64) -> String {
    if x.is_nan() {
        "NA".into()
    } else if x != 0.0 && x.abs() < 1e-3 {
        format!("{x:.2e}")
    } else {
        format!("{x:.4}")
    }
}

/// The most groups simsum.svg draws: more do not fit one figure's key.
pub const MAX_FIGURE_GROUPS: usize = 60;

/// The most methods simsum.svg draws: more do not fit one figure's key
/// (and drawing 100,000 of them would take minutes).
pub const MAX_FIGURE_METHODS: usize = 60;

/// Writes simsum.csv, simsum.md (with `notes`, the file's columns that no
/// flag reads) and (with at most [`MAX_FIGURE_GROUPS`] groups) simsum.svg
/// into `out`.
pub fn write(
    groups: &[Group],
    cols: &Columns,
    source: &str,
    notes: &[String],
    out: &Path,
) -> Result<Vec<PathBuf>, SimsumFileError> {
    crate::io::create_dir_all(out)?;
    let mut written = Vec::new();
    let (by, targets) = (&cols.by, &cols.targets);
    let mut md = to_markdown(groups, by, source, targets);
    for n in notes {
        let _ = writeln!(md, "\nNote: {}", crate::io::md_line(n));
    }
    let methods = groups.iter().map(|g| g.methods.len()).max().unwrap_or(0);
    let drawn = groups.len() <= MAX_FIGURE_GROUPS && methods <= MAX_FIGURE_METHODS;
    if groups.len() > MAX_FIGURE_GROUPS {
        let _ = writeln!(
            md,
            "\nsimsum.svg is not drawn: {} groups, more than the {MAX_FIGURE_GROUPS} one figure's key holds; simsum.csv has every coverage.",
            groups.len()
        );
    } else if methods > MAX_FIGURE_METHODS {
        let _ = writeln!(
            md,
            "\nsimsum.svg is not drawn: {methods} methods in a group, more than the {MAX_FIGURE_METHODS} one figure's key holds; simsum.csv has every coverage."
        );
    }
    for (name, text) in [("simsum.csv", to_csv(groups, by, targets)), ("simsum.md", md)] {
        let p = out.join(name);
        crate::io::write_atomic(&p, text.as_bytes())?;
        written.push(p);
    }
    if drawn {
        let p = out.join("simsum.svg");
        draw(groups, by, &p)?;
        written.push(p);
    }
    Ok(written)
}

/// simsum.svg: each group's coverage per method with 2-MCSE bars and the
/// group's nominal level, as coverage.svg draws a coverage study.
fn draw(groups: &[Group], by: &[String], path: &Path) -> Result<(), crate::report::charts::DrawError> {
    use super::coverage_svg::{draw_points, Point};
    let mut points = Vec::new();
    for g in groups {
        let mut label: Vec<String> = by.iter().zip(&g.by).map(|(n, v)| format!("{n} = {v}")).collect();
        label.push(format!("{}, level {}", truth_label(g), num(g.level)));
        // Whole, not cut: two groups (or methods) cut to the same text would
        // be drawn as one.
        let group = crate::io::one_line(&label.join(", ")).into_owned();
        for m in &g.methods {
            points.push(Point {
                group: group.clone(),
                method: crate::io::one_line(&m.method).into_owned(),
                coverage: m.performance.coverage,
                mcse: m.performance.coverage_mcse,
                level: g.level,
            });
        }
    }
    let mut levels: Vec<f64> = groups.iter().map(|g| g.level).collect();
    levels.sort_by(f64::total_cmp);
    levels.dedup();
    draw_points(path, "Coverage, 2-MCSE bars (rsimsum's MCSE)", &levels, &points)
}

/// The groups' count per pairing, for the console.
pub fn summary(groups: &[Group]) -> String {
    let methods: BTreeMap<&str, ()> =
        groups.iter().flat_map(|g| g.methods.iter().map(|m| (m.method.as_str(), ()))).collect();
    let by_order = groups.iter().filter(|g| g.paired_by == Pairing::Order).count();
    format!(
        "{} group(s), {} method(s){}\n",
        groups.len(),
        methods.len(),
        if by_order > 0 {
            format!("; {by_order} group(s) paired by row order (no replication ids)")
        } else {
            String::new()
        }
    )
}
