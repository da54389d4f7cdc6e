//! The multiverse: choices in the language, specifications sharing draws
//! and jobs, the specification curve and the paired choice effects, draw
//! replication.

use std::path::Path;
use std::process::Command;

use crossaudit::analysis::multiverse::{analyze_multiverse, LevelInput};
use crossaudit::cells::Cell;
use crossaudit::design;

use crate::common::root;

fn bin() -> Command {
    let mut c = crate::common::bin();
    c.current_dir(root());
    c
}

/// The small simulated study of the trust tests, trained for two epochs.
fn small(extra: &str) -> String {
    let base = std::fs::read_to_string(root().join("tests/designs/sim_small.design")).unwrap();
    base.replace("epochs 15 cosine patience 15", "epochs 2 cosine patience 2")
        .replace("estimate crossed_mom level 0.95 df seed - 1\n", "")
        + extra
}

fn errors(text: &str) -> String {
    match design::from_str("m.design", text) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.render(false),
    }
}

#[test]
fn choices_expand_into_every_combination_with_a_primary() {
    let text = small(
        "choices {\n  tails keep | truncate\n  level 0.95 | 0.99\n}\nprimary specification tails keep, level 0.99\n",
    );
    let d = design::from_str("m.design", &text).unwrap();
    let m = d.multiverse.as_ref().unwrap();
    assert_eq!(m.specs.len(), 4);
    let labels: Vec<String> = (0..4).map(|k| m.label(k)).collect();
    assert_eq!(
        labels,
        [
            "tails=keep, level=0.95",
            "tails=keep, level=0.99",
            "tails=truncate, level=0.95",
            "tails=truncate, level=0.99"
        ]
    );
    assert_eq!(m.primary, 1);
    // The design is the primary specification's.
    assert_eq!(d.estimator.level, 0.99);
    assert_eq!(m.specs[2].design.data.tails, design::TailPolicy::Truncate);
    // Level is an analysis choice: specifications 1 and 2 share the run of 0, 3 that of 2.
    assert_eq!(m.run_of(), [0, 0, 2, 2]);
    // A design without choices is unchanged by the new fields.
    let plain = design::from_str("p.design", &small("estimate crossed_mom level 0.95 df seed - 1\n")).unwrap();
    assert!(plain.multiverse.is_none() && !plain.coupled && plain.draws.is_empty());
}

#[test]
fn bad_choices_are_refused_where_they_are_written() {
    let e = errors(&small("choices { colour red | blue }\nprimary specification colour red\n"));
    assert!(e.contains("unknown choice") && e.contains("`colour` is not a setting a choice can take"), "{e}");
    let e = errors(&small("choices { tails keep | sideways }\nprimary specification tails keep\n"));
    assert!(e.contains("wrong alternative") && e.contains("`sideways` is not keep, exclude or truncate"), "{e}");
    let e = errors(&small("choices { tails keep | truncate }\n"));
    assert!(e.contains("no primary specification"), "{e}");
    let e = errors(&small("choices { tails keep | truncate }\nprimary specification tails cut\n"));
    assert!(e.contains("`cut` is not an alternative of `tails`"), "{e}");
    let e = errors(&small(
        "choices { level 0.95 | 0.99 }\nprimary specification level 0.95\nestimate crossed_mom level 0.9\n",
    ));
    assert!(e.contains("setting is a choice"), "{e}");
    let e = errors(&small("primary specification tails keep\n"));
    assert!(e.contains("a primary specification needs a `choices { ... }` block"), "{e}");
    let e = errors(&small("factor draw = 1\n"));
    assert!(e.contains("draw replication needs at least two draws"), "{e}");
    // An alternative that makes its specification invalid names the specification.
    let e = errors(&small("choices { level 0.95 | 1.5 }\nprimary specification level 0.95\n"));
    assert!(e.contains("in the specification level 1.5"), "{e}");
    assert!(e.contains("m.design:"), "errors name the file, line and column: {e}");
}

/// Two specifications that differ only in the analysis train once: the
/// second is analysed on the first's cells, and the run says so.
#[test]
fn an_analysis_only_choice_trains_no_extra_job() {
    let out = tempfile::tempdir().unwrap();
    let path = out.path().join("m.design");
    std::fs::write(
        &path,
        small("choices { level 0.95 | 0.99 }\nprimary specification level 0.95\nestimate crossed_mom df seed - 1\n"),
    )
    .unwrap();
    let check = bin().arg("check").arg(&path).output().unwrap();
    let said = String::from_utf8_lossy(&check.stdout);
    assert!(said.contains("multiverse: 2 specifications over level (0.95 | 0.99)"), "{said}");
    assert!(said.contains("runs: 2 levels, 1 trained (1 share another level's cells"), "{said}");
    assert!(said.contains("jobs: 8 in all"), "{said}");
    let run =
        bin().arg("run").arg(&path).arg("--out").arg(out.path().join("run")).args(["--workers", "2"]).output().unwrap();
    let said = format!("{}{}", String::from_utf8_lossy(&run.stdout), String::from_utf8_lossy(&run.stderr));
    assert!(run.status.success(), "{said}");
    assert!(said.contains("8 cells trained, 0 resumed"), "{said}");
    let dir = out.path().join("run");
    assert!(dir.join("spec-s1/run.json").exists());
    assert!(!dir.join("spec-s2/run.json").exists() && dir.join("spec-s2/report/report.md").exists());
    let report = std::fs::read_to_string(dir.join("report/report.md")).unwrap();
    assert!(report.contains("no (cells of spec-s1)"), "{report}");
    let specs = std::fs::read_to_string(dir.join("report/specs.csv")).unwrap();
    let rows: Vec<&str> = specs.lines().collect();
    assert_eq!(rows.len(), 3);
    // Same cells, same estimate; the 99% interval is wider.
    let col = |name: &str| rows[0].split(',').position(|h| h == name).unwrap();
    let field = |row: &str, name: &str| row.split(',').nth(col(name)).unwrap().parse::<f64>().unwrap();
    assert_eq!(field(rows[1], "estimate"), field(rows[2], "estimate"));
    assert!(field(rows[2], "lower") - field(rows[2], "upper") < field(rows[1], "lower") - field(rows[1], "upper"));
    let cells = std::fs::read_to_string(dir.join("multiverse_cells.csv")).unwrap();
    assert!(cells.starts_with("spec,draw,model,arm,seed,"));
    assert!(dir.join("report/spec_curve.svg").exists() && dir.join("report/choice_effects.csv").exists());
    // report.html: the verdict in the banner, the specification curve inline.
    let html = std::fs::read_to_string(dir.join("report/report.html")).unwrap();
    let verdict = report.lines().next().unwrap();
    let verdict = if verdict.contains("**NOT ") { "NOT CONFIRMED" } else { "CONFIRMED" };
    assert!(html.contains(&format!(": {verdict}</h1>")) && html.contains("<h1 class=\"verdict\">"), "{html}");
    let curve = std::fs::read_to_string(dir.join("report/spec_curve.svg")).unwrap();
    let body = curve.trim_start().strip_prefix("<?xml").map_or(curve.as_str(), |r| r.split_once("?>").unwrap().1);
    assert!(html.contains("<figure data-figure=\"spec_curve.svg\"") && html.contains(body.trim()), "{html}");
    // The same study as one Slurm array (the tasks run here as the array
    // script runs them): one task per job of the levels that train, and the
    // gather step writes what the local run wrote.
    let cluster = out.path().join("cluster");
    let prep = bin().arg("run").arg(&path).arg("--out").arg(&cluster).arg("--slurm").output().unwrap();
    let said = format!("{}{}", String::from_utf8_lossy(&prep.stdout), String::from_utf8_lossy(&prep.stderr));
    assert!(prep.status.success() && said.contains("8 of 8 jobs pending"), "{said}");
    let array = std::fs::read_to_string(cluster.join("slurm/array.json")).unwrap();
    assert!(array.contains("\"spec-s1/world__disjoint__1\"") && !array.contains("spec-s2/"), "{array}");
    for index in 0..8 {
        let o = bin().arg("job").arg(&cluster).args(["--index", &index.to_string()]).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let g = bin().arg("gather").arg(&cluster).output().unwrap();
    assert!(g.status.success(), "{}", String::from_utf8_lossy(&g.stderr));
    for f in ["report/specs.csv", "report/choice_effects.csv", "multiverse_cells.csv", "spec-s1/cells.csv"] {
        assert_eq!(std::fs::read(cluster.join(f)).unwrap(), std::fs::read(dir.join(f)).unwrap(), "{f}");
    }
    assert!(cluster.join("spec-s2/report/report.md").exists());
    // A rerun resumes everything.
    let again = bin().arg("run").arg(&path).arg("--out").arg(&dir).args(["--workers", "2"]).output().unwrap();
    let said = format!("{}{}", String::from_utf8_lossy(&again.stdout), String::from_utf8_lossy(&again.stderr));
    assert!(again.status.success() && said.contains("0 cells trained, 8 resumed"), "{said}");
    assert_eq!(std::fs::read_to_string(dir.join("report/specs.csv")).unwrap(), specs);
}

/// Removing one fit recording moves almost nothing of a coupled draw: the
/// evaluation recordings, their starts and the validation set stay, and
/// at least 98% of the fit windows; an independent draw keeps far less.
#[test]
fn coupled_draws_survive_removing_a_fit_recording() {
    let text = |coupled: bool| {
        let d = small(&format!(
            "estimate crossed_mom level 0.95 df seed - 1\n{}",
            if coupled { "draws coupled\n" } else { "" }
        ));
        d.replace("recordings 16 seed 5 strength 1.0 duration 15 s", "recordings 120 seed 5 strength 1.0 duration 12 s")
    };
    let out = tempfile::tempdir().unwrap();
    let full = out.path().join("full");
    let coupled = design::from_str("c.design", &text(true)).unwrap();
    crossaudit::sim::simulate(coupled.data.simulated.as_ref().unwrap(), &full).unwrap();
    let prepare = |d: &design::Design, data: &Path, name: &str| {
        let file = design::DesignFile {
            path: out.path().join("c.design"),
            source: String::new(),
            design: d.clone(),
            sha256: String::new(),
        };
        let plan = crossaudit::compile(d);
        crossaudit::split::prepare(&file, &plan, data, &out.path().join(name)).unwrap().split
    };
    let a = prepare(&coupled, &full, "a");
    // A fit recording (in no evaluation or validation set), removed from a copy of the data.
    let held: Vec<usize> = a.evaluation.iter().chain(&a.validation_recordings).copied().collect();
    let victim = a.fit("disjoint").unwrap().iter().map(|w| w.recording).find(|r| !held.contains(r)).unwrap();
    let victim = a.recordings[victim].name.clone();
    let fewer = out.path().join("fewer");
    std::fs::create_dir_all(&fewer).unwrap();
    for e in std::fs::read_dir(&full).unwrap() {
        let e = e.unwrap();
        let name = e.file_name().to_string_lossy().into_owned();
        if !name.starts_with(&format!("{victim}.")) && !name.starts_with('.') && name != "simulation.json" {
            std::fs::copy(e.path(), fewer.join(&name)).unwrap();
        }
    }
    let named = |s: &crossaudit::split::Split,
                 w: &[crossaudit::split::Window]|
     -> std::collections::BTreeSet<(String, usize)> {
        w.iter().map(|w| (s.recordings[w.recording].name.clone(), w.t)).collect()
    };
    let kept = |x: &crossaudit::split::Split,
                y: &crossaudit::split::Split,
                w: fn(&crossaudit::split::Split) -> Vec<crossaudit::split::Window>| {
        let (p, q) = (named(x, &w(x)), named(y, &w(y)));
        p.intersection(&q).count() as f64 / p.len() as f64
    };
    let b = prepare(&coupled, &fewer, "b");
    let starts = |s: &crossaudit::split::Split| s.starts.clone();
    let fit = |s: &crossaudit::split::Split| s.fit("disjoint").unwrap().to_vec();
    let contaminated = |s: &crossaudit::split::Split| s.fit("contaminated").unwrap().to_vec();
    let validation = |s: &crossaudit::split::Split| s.validation.clone();
    assert_eq!(kept(&a, &b, starts), 1.0);
    assert_eq!(kept(&a, &b, validation), 1.0);
    assert!(kept(&a, &b, fit) >= 0.98, "coupled fit windows kept: {}", kept(&a, &b, fit));
    assert!(kept(&a, &b, contaminated) >= 0.98, "coupled contaminated windows kept: {}", kept(&a, &b, contaminated));
    // The same removal under independent draws.
    let independent = design::from_str("i.design", &text(false)).unwrap();
    let (c, d) = (prepare(&independent, &full, "c"), prepare(&independent, &fewer, "d"));
    assert!(kept(&c, &d, fit) < 0.9, "independent fit windows kept: {}", kept(&c, &d, fit));
}

/// Synthetic cells with a known effect of one choice and none of the
/// other: d = -0.02 - 0.05 [state = onboard] + a_i + b_j + e_ijs.
fn planted_cells(d: &design::Design, values: &[String], spec: usize) -> Vec<Cell> {
    // A fixed linear congruential sequence: reproducible noise without a dependency.
    let mut state = 12345u64 + 7919 * spec as u64;
    let mut noise = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.02
    };
    let effect = if values[0] == "onboard" { -0.05 } else { 0.0 };
    let mut out = Vec::new();
    for i in 0..30 {
        for (j, s) in d.seeds.iter().enumerate() {
            let a = 0.01 * ((i * 7 % 11) as f64 - 5.0) / 5.0;
            let b = 0.005 * ((j * 3 % 5) as f64 - 2.0) / 2.0;
            let reference = 0.4 + 0.01 * i as f64;
            let diff = -0.02 + effect + a + b + noise();
            for h in [0.5, 1.0] {
                for (arm, v) in [("disjoint", reference), ("contaminated", reference + diff)] {
                    for model in ["world", "relative"] {
                        out.push(Cell {
                            split: None,
                            dose: None,
                            model: model.into(),
                            arm: arm.into(),
                            seed: s.0,
                            recording: format!("R{i:02}_circle_slow_rep1").into(),
                            trajectory: "circle".into(),
                            speed: "slow".into(),
                            horizon_s: h,
                            n_starts: 10,
                            n_divergent: 0,
                            fa_position_rmse_m: v * h,
                            conditional_position_rmse_m: Some(v * h),
                            divergence_rate: 0.0,
                            velocity_rmse_mps: Some(0.1),
                            attitude_rmse_deg: Some(1.0),
                            origin: Default::default(),
                        });
                    }
                }
            }
        }
    }
    out
}

/// The multiverse analysis of design `text` on each specification's
/// [`planted_cells`], each cell changed by `edit` first.
fn planted_multiverse(text: &str, edit: impl Fn(&mut Cell)) -> crossaudit::analysis::multiverse::MultiverseAnalysis {
    let d = design::from_str("m.design", text).unwrap();
    let m = d.multiverse.as_ref().unwrap();
    let plans: Vec<crossaudit::Plan> = m.specs.iter().map(|s| crossaudit::compile(&s.design)).collect();
    let cells: Vec<Vec<Cell>> = m
        .specs
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let mut cells = planted_cells(&s.design, &s.values, k);
            cells.iter_mut().for_each(&edit);
            cells
        })
        .collect();
    let levels: Vec<LevelInput> = (0..m.specs.len())
        .map(|k| LevelInput {
            id: format!("spec-{}", m.specs[k].id),
            spec: Some(k),
            draw: None,
            shares: None,
            plan: &plans[k],
            cells: &cells[k],
        })
        .collect();
    analyze_multiverse(&d, &levels).unwrap()
}

/// A multiverse on a metric that is not in metres names its own unit
/// everywhere: specs.csv's and choice_effects.csv's `unit` column, every
/// heading and value of report.md and the curve's axis (velocity RMSE:
/// m/s).
#[test]
fn a_multiverse_on_another_metric_names_its_unit() {
    let text = small(
        "choices {\n  state motion_capture | onboard\n}\nprimary specification state motion_capture\nestimate crossed_mom level 0.95 df seed - 1\n",
    )
    .replace("endpoint primary   fa_position_rmse at 1.0 s cap 2 m", "endpoint primary   velocity_rmse at 1.0 s cap 2 m")
    .replace("factor seed = 1..2", "factor seed = 1..10")
    .replace("evaluation 4 split_seed 42", "evaluation 30 split_seed 42");
    let a = planted_multiverse(&text, |c| c.velocity_rmse_mps = Some(c.fa_position_rmse_m));
    let specs = crossaudit::report::multiverse::specs_csv(&a);
    let header: Vec<&str> = specs.lines().next().unwrap().split(',').collect();
    let unit = header.iter().position(|h| *h == "unit").unwrap();
    assert!(specs.lines().skip(1).all(|r| r.split(',').nth(unit) == Some("m/s")), "{specs}");
    let effects = crossaudit::report::multiverse::effects_csv(&a);
    assert!(effects.lines().nth(1).unwrap().contains(",m/s,"), "{effects}");
    let md = crossaudit::report::multiverse::render_markdown(&a);
    assert!(md.contains("| d (m/s) | interval (m/s) |") && md.contains("effect on d (m/s)"), "{md}");
    assert!(!md.contains("(m)") && !md.contains(" m,") && !md.contains(" m ") && !md.contains("metres"), "{md}");
    assert!(md.contains("difference in m/s"), "{md}");
    let svg = crossaudit::report::multiverse::spec_curve_svg(&a);
    assert!(svg.contains("d (m/s)") && !svg.contains("(m)"), "{svg}");
}

#[test]
fn planted_choice_effects_are_recovered_by_the_paired_analysis() {
    let text = small(
        "choices {\n  state motion_capture | onboard\n  tails keep | truncate\n}\nprimary specification state motion_capture, tails keep\ndraws coupled\nestimate crossed_mom level 0.95 df seed - 1\n",
    )
    .replace("factor seed = 1..2", "factor seed = 1..10")
    .replace("evaluation 4 split_seed 42", "evaluation 30 split_seed 42");
    let a = planted_multiverse(&text, |_| {});
    let effect = |setting: &str| a.choice_effects.iter().find(|e| e.setting == setting).unwrap().estimate.unwrap();
    let state = effect("state");
    assert!(state.lower < -0.05 && state.upper > -0.05 && state.upper < 0.0, "state: {state:?}");
    let tails = effect("tails");
    assert!(tails.lower < 0.0 && tails.upper > 0.0, "tails: {tails:?}");
    // The curve: both onboard specifications below both motion-capture ones.
    let mut order: Vec<&str> = a.specs.iter().map(|s| s.id.as_str()).collect();
    order.sort_by(|x, y| {
        let e = |id: &str| a.specs.iter().find(|s| s.id == id).unwrap().estimate.mean;
        e(x).total_cmp(&e(y))
    });
    let onboard: Vec<&str> = a.specs.iter().filter(|s| s.values[0] == "onboard").map(|s| s.id.as_str()).collect();
    assert!(onboard.contains(&order[0]) && onboard.contains(&order[1]), "{order:?}");
    // Joint bands are wider than each specification's own interval, and cover its estimate.
    let joint = a.joint.as_ref().unwrap();
    assert!(joint.critical > 1.96);
    for (s, band) in a.specs.iter().zip(&joint.bands) {
        assert!(band.2 < s.estimate.mean && band.3 > s.estimate.mean);
    }
    assert_eq!(joint.share_negative.0, 1.0);
    // The primary decides: its d is -0.02 with optimism about 5%, under the 10% of the rule.
    assert!(!a.decision.primary_holds && !a.decision.holds);
}

/// The analysis of a committed multiverse run, recomputed from its cells:
/// every level's plan from the design, its cells from its directory.
fn committed(design: &str, run: &str) -> crossaudit::analysis::multiverse::MultiverseAnalysis {
    let file = design::load(&root().join(design)).unwrap();
    let study = crossaudit::compile_study(&file.design);
    crossaudit::run::outer::analyze_dir(&file, &study, &root().join(run)).unwrap()
}

/// The committed runs' tables, recomputed from their cells, are the
/// committed ones byte for byte, and locked by a snapshot.
#[test]
fn committed_multiverse_and_draw_analyses_are_locked() {
    for (design, run, name) in [
        ("designs/multiverse/paper_multiverse.design", "results/multiverse/paper", "paper_multiverse"),
        ("designs/multiverse/paper_draws.design", "results/multiverse/draws", "paper_draws"),
        ("designs/multiverse/holdout_trajectory.design", "results/multiverse/holdout", "holdout_trajectory"),
        ("designs/multiverse/paper_multiverse_per_seed.design", "results/multiverse/paper_per_seed", "paper_per_seed"),
    ] {
        let a = committed(design, run);
        let specs = crossaudit::report::multiverse::specs_csv(&a);
        let effects = crossaudit::report::multiverse::effects_csv(&a);
        let report = root().join(run).join("report");
        assert_eq!(specs, std::fs::read_to_string(report.join("specs.csv")).unwrap(), "{run}");
        assert_eq!(effects, std::fs::read_to_string(report.join("choice_effects.csv")).unwrap(), "{run}");
        // The REML fit's numbers to 6 significant digits: its optimizer's
        // last bits may differ between CPUs (SIMD dispatch in faer).
        let draws: String = a
            .draws
            .iter()
            .map(|d| {
                let per: Vec<String> = d
                    .per_draw
                    .iter()
                    .map(|x| format!("draw {}: d {:.6e} optimism {:.4} rule {}", x.0, x.1, x.4, x.5))
                    .collect();
                let comp: Vec<String> =
                    d.components.iter().map(|c| format!("{} {:.5e} ({:.4})", c.0, c.1, c.2)).collect();
                format!(
                    "{}\n{}\npooled {:?}",
                    per.join("\n"),
                    comp.join("\n"),
                    d.pooled.as_ref().map(|p| format!(
                        "{:.5e} se {:.5e} df {:.4} ({}) [{:.5e}, {:.5e}] optimism {:.4} rule {}",
                        p.mean, p.se, p.df, p.df_rule, p.lower, p.upper, p.optimism_pct, p.rule_holds
                    ))
                )
            })
            .collect();
        // The CLI gives the committed decision line from the run directory.
        let out = tempfile::tempdir().unwrap();
        let o = bin().args(["analyze", design, "--cells", run, "--out"]).arg(out.path()).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        // The decision line, then each guard beside the verdict on an
        // indented line of its own.
        let stdout = String::from_utf8_lossy(&o.stdout).to_string();
        let mut lines = stdout.lines();
        assert_eq!(lines.next().unwrap_or(""), crossaudit::report::multiverse::decision_line(&a));
        let guards =
            crossaudit::report::study_guards(&crossaudit::analysis::StudyAnalysis::Multiverse(Box::new(a.clone())));
        let printed: Vec<String> = lines.map(|l| l.trim().to_string()).filter(|l| !l.is_empty()).collect();
        assert_eq!(printed, guards);
        // multiverse.json carries the same guards, each with its kind.
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.path().join("multiverse.json")).unwrap()).unwrap();
        let written: Vec<String> = json["guards"]
            .as_array()
            .expect("multiverse.json's guards")
            .iter()
            .map(|g| {
                assert!(g["kind"].is_string(), "{g}");
                g["text"].as_str().unwrap().replace("**", "")
            })
            .collect();
        assert_eq!(written, guards, "{run}");
        assert_eq!(std::fs::read_to_string(out.path().join("specs.csv")).unwrap(), specs);
        crate::snapshots!({ insta::assert_snapshot!(name, format!("{specs}\n{effects}\n{draws}")) });
    }
    // Draw 1 of the draw replication is the multiverse's primary
    // specification: two runs of the same inputs, the same cells byte for byte.
    let cells = |p: &str| std::fs::read(root().join(p)).unwrap();
    assert_eq!(cells("results/multiverse/draws/draw-1/cells.csv"), cells("results/multiverse/paper/spec-s1/cells.csv"));
    // The paper design with per-seed draws is the per-seed multiverse's s1,
    // trained separately: the same cells byte for byte.
    assert_eq!(
        cells("results/multiverse/per_seed/cells.csv"),
        cells("results/multiverse/paper_per_seed/spec-s1/cells.csv")
    );
}

fn r_table(path: &str) -> Vec<std::collections::BTreeMap<String, String>> {
    let text = std::fs::read_to_string(root().join(path)).unwrap();
    let mut rdr = csv::Reader::from_reader(text.as_bytes());
    let header: Vec<String> = rdr.headers().unwrap().iter().map(String::from).collect();
    rdr.records().map(|r| header.iter().cloned().zip(r.unwrap().iter().map(String::from)).collect()).collect()
}

/// crossaudit's per-specification estimates, paired choice effects and
/// draw-replication REML against base R and lme4
/// (scripts/reference/multiverse_check.R, run on the committed cells).
#[test]
fn committed_multiverse_matches_r_and_lme4() {
    let num = |row: &std::collections::BTreeMap<String, String>, k: &str| row[k].parse::<f64>().unwrap();
    for (design, run) in [
        ("designs/multiverse/holdout_trajectory.design", "results/multiverse/holdout"),
        ("designs/multiverse/paper_multiverse.design", "results/multiverse/paper"),
        ("designs/multiverse/paper_multiverse_per_seed.design", "results/multiverse/paper_per_seed"),
    ] {
        let a = committed(design, run);
        let rows = r_table(&format!("{run}/reference/specs_r.csv"));
        assert_eq!(rows.len(), a.specs.len());
        for (s, r) in a.specs.iter().zip(&rows) {
            assert_eq!(s.id, r["spec"]);
            crate::common::assert_rel(s.estimate.mean, num(r, "d_m"), 1e-9, &format!("{run} {} d", s.id));
            crate::common::assert_rel(s.estimate.se, num(r, "se_m"), 1e-9, &format!("{run} {} se", s.id));
            crate::common::assert_rel(s.estimate.lower, num(r, "lower_m"), 1e-9, &format!("{run} {} lower", s.id));
            crate::common::assert_rel(
                s.optimism_pct,
                num(r, "optimism_pct"),
                1e-9,
                &format!("{run} {} optimism", s.id),
            );
        }
    }
    let a = committed("designs/multiverse/paper_multiverse.design", "results/multiverse/paper");
    let rows = r_table("results/multiverse/paper/reference/choice_effects_r.csv");
    assert_eq!(rows.len(), a.choice_effects.len());
    for (e, r) in a.choice_effects.iter().zip(&rows) {
        assert_eq!((e.setting.as_str(), e.alternative.as_str()), (r["choice"].as_str(), r["alternative"].as_str()));
        let x = e.estimate.unwrap();
        crate::common::assert_rel(x.mean, num(r, "effect_m"), 1e-9, &format!("{} effect", e.setting));
        crate::common::assert_rel(x.se, num(r, "se_m"), 1e-9, &format!("{} se", e.setting));
        crate::common::assert_rel(x.upper, num(r, "upper_m"), 1e-9, &format!("{} upper", e.setting));
    }
    let a = committed("designs/multiverse/paper_draws.design", "results/multiverse/draws");
    let rows = r_table("results/multiverse/draws/reference/draws_r.csv");
    let d = &a.draws[0];
    let p = d.pooled.as_ref().unwrap();
    // lme4 (bobyqa) and crossaudit's optimizer meet to about 1e-6 in the
    // variances; variances at zero are compared absolutely. The decision's
    // SE and df are Kenward-Roger's (pbkrtest's vcovAdj and Lb_ddf).
    crate::common::assert_rel(p.mean, num(&rows[0], "pooled_m"), 1e-6, "pooled d");
    assert_eq!(p.df_rule, "kenward_roger");
    crate::common::assert_rel(p.se, num(&rows[0], "kr_se_m"), 1e-4, "pooled Kenward-Roger SE");
    crate::common::assert_rel(p.df, num(&rows[0], "kr_df"), 1e-3, "pooled Kenward-Roger df");
    for (name, column) in [
        ("recording", "var_recording"),
        ("seed", "var_seed"),
        ("draw", "var_draw"),
        ("recording:draw", "var_recording_draw"),
        ("seed:draw", "var_seed_draw"),
        ("residual", "var_residual"),
    ] {
        let ours = d.components.iter().find(|c| c.0 == name).unwrap().1;
        let theirs = num(&rows[0], column);
        assert!((ours - theirs).abs() <= 1e-4 * theirs.abs() + 1e-9, "{name}: {ours} vs lme4 {theirs}");
    }
}

/// `hold out trajectory` on the real logs: the family arm has no recording
/// of an evaluation recording's trajectory, and under coupled draws it
/// keeps every window of the recording-disjoint draw outside that family.
#[test]
#[ignore = "needs ../shared/nanobench"]
fn a_trajectory_holdout_keeps_the_family_out_and_the_rest_of_the_draw() {
    let _logs = crate::needs_shared_logs!();
    let logs = crate::common::shared_logs();
    let out = tempfile::tempdir().unwrap();
    let file = design::load(&root().join("designs/multiverse/holdout_trajectory.design")).unwrap();
    let plan = crossaudit::compile(&file.design);
    let s = crossaudit::split::prepare(&file, &plan, &logs, out.path()).unwrap().split;
    let families: std::collections::BTreeSet<&str> =
        s.evaluation_side.iter().map(|&r| s.recordings[r].trajectory.as_str()).collect();
    assert_eq!(families.iter().copied().collect::<Vec<_>>(), ["trefoil"]);
    let family = s.fit("family").unwrap();
    assert_eq!(family.len(), 16000);
    assert!(family.iter().all(|w| s.recordings[w.recording].trajectory != "trefoil"));
    let disjoint = s.fit("disjoint").unwrap();
    assert!(disjoint.iter().any(|w| s.recordings[w.recording].trajectory == "trefoil"));
    let outside: Vec<_> = disjoint.iter().filter(|w| s.recordings[w.recording].trajectory != "trefoil").collect();
    assert!(outside.iter().all(|w| family.binary_search(w).is_ok()), "coupled draws keep the shared windows");
}

#[test]
fn a_holdout_names_a_recording_label() {
    let e = errors(&small("estimate crossed_mom level 0.95 df seed - 1\n").replace(
        "arm disjoint     { fit 3000 windows seed 42 }",
        "arm disjoint     { fit 3000 windows seed 42 hold out colour }",
    ));
    assert!(e.contains("unknown holdout") && e.contains("`colour` is not a recording label"), "{e}");
    let e = errors(&small("choices { contrast contaminated - disjoint | world }\nprimary specification contrast contaminated - disjoint\n"));
    assert!(e.contains("wrong alternative"), "{e}");
}

#[test]
fn multiverse_limits_and_misuse_are_refused_clearly() {
    // 2^9 = 512 specifications: more than a multiverse may have.
    let many: String = [
        "tails keep | truncate",
        "duplicates keep | group",
        "implausible pooled | per_column",
        "target state_scaled | standardized",
        "actions raw | standardized",
        "action_noise 0 | 0.02",
        "generator chacha8 | numpy_legacy",
        "draws coupled | independent",
        "level 0.9 | 0.95",
    ]
    .join("\n");
    let text = small(&format!("choices {{\n{many}\n}}\nprimary specification tails keep\n"))
        .replace("exclude    implausible\n", "")
        .replace("duplicates group\n", "");
    let e = errors(&text);
    assert!(e.contains("too many specifications") && e.contains("these choices span 512 specifications"), "{e}");
    // An alternative that is not a finite number, as any number of the language.
    let e = errors(&small("choices { level 0.95 | 1e999 }\nprimary specification level 0.95\n"));
    assert!(e.contains("number out of range") && e.contains("is not a finite number"), "{e}");
    // Two choices blocks, two primary specifications.
    let e = errors(&small(
        "choices { level 0.95 | 0.99 }\nchoices { level 0.9 | 0.99 }\nprimary specification level 0.95\n",
    ));
    assert!(e.contains("a second `choices` statement"), "{e}");
    let e = errors(&small(
        "choices { level 0.95 | 0.99 }\nprimary specification level 0.95\nprimary specification level 0.99\n",
    ));
    assert!(e.contains("a second `primary specification` statement"), "{e}");
    // A draw factor too large, and a shift out of numpy's range.
    let e = errors(&small("estimate crossed_mom level 0.95 df seed - 1\nfactor draw = 1..5000\n"));
    assert!(e.contains("the number of draws must be at most 1000"), "{e}");
    let e = errors(
        &small("estimate crossed_mom level 0.95 df seed - 1\ngenerator numpy_legacy\nfactor draw = 1..3\n")
            .replace("seed 143", "seed 4294967295"),
    );
    assert!(e.contains("draw shifts a seed out of range"), "{e}");
    // `analyze` of a multiverse reads a run directory, and says so.
    let out = tempfile::tempdir().unwrap();
    let path = out.path().join("m.design");
    std::fs::write(&path, small("choices { level 0.95 | 0.99 }\nprimary specification level 0.95\n")).unwrap();
    let cells = out.path().join("cells.csv");
    std::fs::write(&cells, "model,arm\n").unwrap();
    let o = bin().arg("analyze").arg(&path).arg("--cells").arg(&cells).output().unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("is analysed from its run directory"), "{e}");
    // `split` and `train` do one run: refused before anything is written.
    for args in [vec!["split"], vec!["train", "--model", "world", "--arm", "disjoint", "--seed", "1"]] {
        let target = out.path().join(format!("one-{}", args[0]));
        let o = bin().arg(args[0]).arg(&path).args(&args[1..]).arg("--out").arg(&target).output().unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && e.contains("is several runs; `crossaudit run` prepares"), "{e}");
        assert!(!target.exists(), "{}", target.display());
    }
    // A missing level's cells are named with their path.
    std::fs::create_dir_all(out.path().join("run")).unwrap();
    let o = bin().arg("analyze").arg(&path).arg("--cells").arg(out.path().join("run")).output().unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("spec-s1") && e.contains("cells.csv"), "{e}");
}

/// A choice of the training (`action_noise`) retrains every fitted model,
/// but a parameter-free baseline's jobs read the same inputs in both
/// specifications: the second takes them by content hash.
#[test]
fn jobs_with_identical_inputs_are_shared_by_content_hash() {
    let out = tempfile::tempdir().unwrap();
    let path = out.path().join("m.design");
    let text = small("choices { action_noise 0.02 | 0.05 }\nprimary specification action_noise 0.02\nestimate crossed_mom level 0.95 df seed - 1\n")
        .replace(" action_noise 0.02 }", " }")
        .replace("model relative = mlp(32, 32, 32) inputs relative", "model relative = mlp(32, 32, 32) inputs relative\nmodel still = persistence")
        .replace("endpoint secondary fa_position_rmse at 0.5 s models world, relative", "endpoint secondary fa_position_rmse at 0.5 s models world, relative, still");
    std::fs::write(&path, text).unwrap();
    let run =
        bin().arg("run").arg(&path).arg("--out").arg(out.path().join("run")).args(["--workers", "2"]).output().unwrap();
    let said = format!("{}{}", String::from_utf8_lossy(&run.stdout), String::from_utf8_lossy(&run.stderr));
    assert!(run.status.success(), "{said}");
    // 12 jobs per specification (3 models x 2 arms x 2 seeds); the second trains its 8 fitted ones.
    assert!(said.contains("20 cells trained, 4 resumed"), "{said}");
    let dir = out.path().join("run");
    for stem in ["still__disjoint__1", "still__contaminated__2"] {
        let a = std::fs::read(dir.join(format!("spec-s1/cells/{stem}.csv"))).unwrap();
        assert_eq!(a, std::fs::read(dir.join(format!("spec-s2/cells/{stem}.csv"))).unwrap());
    }
    let report = std::fs::read_to_string(dir.join("report/report.md")).unwrap();
    assert!(report.contains("spec-s2: 4 job(s) whose inputs"), "{report}");
    // Fitted models differ with the noise.
    let w = |s: &str| std::fs::read(dir.join(format!("{s}/cells/world__disjoint__1.csv"))).unwrap();
    assert_ne!(w("spec-s1"), w("spec-s2"));
}

#[test]
fn choices_with_splits_or_doses_are_refused() {
    let e = errors(
        &small("choices { level 0.95 | 0.99 }\nprimary specification level 0.95\nfactor split = 42..43\n")
            .replace("decide confirmed when", "decide confirmed on pooled when"),
    );
    assert!(e.contains("choices with splits or doses"), "{e}");
    let e = errors(
        &small("choices { level 0.95 | 0.99 }\nprimary specification level 0.95\n")
            .replace("replace 25% with", "replace 5%, 25% with")
            .replace("decide confirmed when", "decide confirmed on slope when"),
    );
    assert!(e.contains("choices with splits or doses"), "{e}");
}

/// Training and data settings as choices: each specification's design
/// carries its alternative; whole-number settings refuse fractions.
#[test]
fn training_and_data_settings_can_be_choices() {
    let text = small(
        "choices {\n  epochs 2 | 4\n  lr 0.001 | 0.0003\n  universe csv | metadata\n  cap 2 | 5\n}\nprimary specification epochs 2, lr 0.001, universe csv, cap 2\nestimate crossed_mom level 0.95 df seed - 1\n",
    )
    .replace("train { adam lr 1e-3 batch 256 epochs 2 cosine patience 2 action_noise 0.02 }", "train { batch 256 cosine patience 2 action_noise 0.02 }")
    .replace("cap 2 m ", "");
    let d = design::from_str("m.design", &text).unwrap();
    let m = d.multiverse.as_ref().unwrap();
    assert_eq!(m.specs.len(), 16);
    let last = &m.specs[15].design;
    let t = last.training.as_ref().unwrap();
    assert_eq!((t.epochs, t.lr), (4, 0.0003));
    assert!(last.data.universe.metadata);
    assert!(last.endpoints.iter().all(|e| e.cap.0 == 5.0));
    let e = errors(&text.replace("epochs 2 | 4", "epochs 2 | 4.5"));
    assert!(e.contains("`4.5` is not an epoch cap (a whole number)"), "{e}");
    let e = errors(&text.replace("train { batch 256", "train { adam lr 1e-3 batch 256"));
    assert!(e.contains("setting is a choice") && e.contains("`lr` is written here"), "{e}");
}

/// Choices and draws together: one level per specification and draw, the
/// curve read at the first draw, draw replication per specification.
#[test]
fn choices_and_draws_together_run_every_level() {
    let out = tempfile::tempdir().unwrap();
    let path = out.path().join("m.design");
    std::fs::write(
        &path,
        small("choices { lr 0.001 | 0.002 }\nprimary specification lr 0.001\nfactor draw = 1..2\ndraws coupled\nestimate crossed_mom level 0.95 df seed - 1\n")
            .replace("factor seed = 1..2", "factor seed = 1..3")
            .replace("train { adam lr 1e-3 batch", "train { batch"),
    )
    .unwrap();
    let run =
        bin().arg("run").arg(&path).arg("--out").arg(out.path().join("run")).args(["--workers", "2"]).output().unwrap();
    let said = format!("{}{}", String::from_utf8_lossy(&run.stdout), String::from_utf8_lossy(&run.stderr));
    assert!(run.status.success(), "{said}");
    let dir = out.path().join("run");
    for level in ["spec-s1_draw-1", "spec-s1_draw-2", "spec-s2_draw-1", "spec-s2_draw-2"] {
        assert!(dir.join(level).join("report/report.md").exists(), "{level}");
    }
    let file = design::load(&path).unwrap();
    let a = crossaudit::run::outer::analyze_dir(&file, &crossaudit::compile_study(&file.design), &dir).unwrap();
    assert_eq!(a.specs.len(), 2);
    assert_eq!(a.draws.len(), 2);
    assert!(a.draws.iter().all(|d| d.per_draw.len() == 2));
    let report = std::fs::read_to_string(dir.join("report/report.md")).unwrap();
    assert!(report.contains("## Draw replication") && report.contains("### Specification s2"), "{report}");
    let cells = std::fs::read_to_string(dir.join("multiverse_cells.csv")).unwrap();
    assert!(cells.lines().any(|l| l.starts_with("s2,2,")), "spec and draw columns");
    // The choice effect is pooled over the draws as the specifications
    // are: recomputed here from the levels' cells.csv files, d(s2) - d(s1)
    // per recording, seed and draw, and one REML fit over recording, seed,
    // draw, recording:draw and seed:draw.
    let e = &a.choice_effects[0];
    assert_eq!(e.pooled_draws, 2, "{e:?}");
    let d = |level: &str| -> std::collections::BTreeMap<(String, u64), f64> {
        let cells = crossaudit::cells::read_cells(&dir.join(level).join("cells.csv")).unwrap();
        let at = |arm: &str| -> std::collections::BTreeMap<(String, u64), f64> {
            cells
                .iter()
                .filter(|c| c.arm == arm && (c.horizon_s - 1.0).abs() < 1e-9)
                .map(|c| ((c.recording.to_string(), c.seed), c.fa_position_rmse_m))
                .collect()
        };
        let (t, r) = (at("contaminated"), at("disjoint"));
        t.iter().map(|(k, v)| (k.clone(), v - r[k])).collect()
    };
    let (mut y, mut rec, mut seed, mut draw, mut rd, mut sd) = (vec![], vec![], vec![], vec![], vec![], vec![]);
    let mut names: Vec<String> = Vec::new();
    for k in 1..=2usize {
        let (s1, s2) = (d(&format!("spec-s1_draw-{k}")), d(&format!("spec-s2_draw-{k}")));
        for (key, v1) in &s1 {
            let r = names.iter().position(|n| *n == key.0).unwrap_or_else(|| {
                names.push(key.0.clone());
                names.len() - 1
            });
            y.push(s2[key] - v1);
            rec.push(r);
            seed.push(key.1 as usize);
            draw.push(k);
            rd.push(r * 10 + k);
            sd.push(key.1 as usize * 10 + k);
        }
    }
    use crossaudit::stats::mixed::{fit, Criterion, MixedData};
    let data = MixedData::new(
        y,
        vec![
            ("recording".into(), rec),
            ("seed".into(), seed),
            ("draw".into(), draw),
            ("recording:draw".into(), rd),
            ("seed:draw".into(), sd),
        ],
    )
    .unwrap();
    let f = fit(&data, Criterion::Reml).unwrap();
    let (se, df, _, lower, upper) = f.intercept_interval(true, 0.95).unwrap();
    let x = e.estimate.unwrap();
    crate::common::assert_rel(x.mean, f.intercept, 1e-9, "pooled choice effect");
    crate::common::assert_rel(x.se, se, 1e-6, "its SE");
    crate::common::assert_rel(x.df, df, 1e-6, "its df");
    crate::common::assert_rel(x.upper - x.lower, upper - lower, 1e-6, "its width");
    assert!(report.contains("pooled by REML over recording, seed, draw"), "{report}");
}

/// The curve under the null (issue 45): crossaudit's p-values for the
/// median d, the count of specifications meeting the rule and Stouffer's
/// t agree with an independent NumPy computation (its own random numbers,
/// B = 20,000; scripts/reference/null_test_check.py, output committed in
/// each run's reference/null_test.out) within Monte Carlo error, on a
/// simulated multiverse with no effect (moderate p-values) and on the
/// paper multiverse (p at its floor).
#[test]
fn the_curve_under_the_null_agrees_with_an_independent_script() {
    for (design, run) in [
        ("designs/multiverse/sim_null.design", "results/multiverse/sim_null"),
        ("designs/multiverse/paper_multiverse.design", "results/multiverse/paper"),
        ("designs/multiverse/paper_multiverse_per_seed.design", "results/multiverse/paper_per_seed"),
    ] {
        let a = committed(design, run);
        let j = a.joint.as_ref().unwrap();
        let text = std::fs::read_to_string(root().join(run).join("reference/null_test.out")).unwrap();
        let row = |name: &str| -> (f64, f64, f64) {
            let l = text.lines().find(|l| l.starts_with(&format!("{name},"))).unwrap();
            let f: Vec<f64> = l.split(',').skip(1).map(|x| x.parse().unwrap()).collect();
            (f[0], f[1], f[2])
        };
        let b = j.replicates as f64;
        let close = |ours: f64, (_, p, mcse): (f64, f64, f64), what: &str| {
            let tol = 4.0 * (mcse * mcse + ours * (1.0 - ours) / b).sqrt() + 1.0 / b;
            assert!((ours - p).abs() <= tol, "{run} {what}: p {ours} against the script's {p} (tolerance {tol})");
        };
        let n = &j.null;
        // The observed statistics are the same numbers (Stouffer's uses
        // each side's own bootstrap SE, so it agrees to Monte Carlo error).
        crate::common::assert_rel(n.median.0, row("median_d").0, 1e-9, "observed median");
        assert_eq!(n.holding.0 as f64, row("holding").0, "{run}: observed count");
        crate::common::assert_rel(n.stouffer.0, row("stouffer").0, 0.05, "observed Stouffer t");
        close(n.median.1, row("median_d"), "median");
        close(n.holding.1, row("holding"), "count meeting the rule");
        close(n.stouffer.1, row("stouffer"), "Stouffer");
    }
}
