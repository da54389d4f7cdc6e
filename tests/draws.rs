//! Per-seed draws (`draws per seed`, issue 45): each seed trains and is
//! evaluated on its own draw of everything after the evaluation
//! recordings, so the crossed recording x seed estimator's seed component
//! carries the draw variance. Seed j's cells are byte for byte those of
//! seed j in the level `factor draw` numbers j - j0 + 1, whatever the
//! number of workers.

use std::path::Path;

use crate::common::root;
use crate::common::{crossaudit, said};

/// The small simulated study with three seeds.
fn small(extra: &str) -> String {
    let base = std::fs::read_to_string(root().join("tests/designs/sim_small.design")).unwrap();
    base.replace("factor seed = 1..2", "factor seed = 4..6") + extra
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

fn run(design: &str, out: &Path, workers: &str) -> String {
    let o = crossaudit(&["run", design, "--out", out.to_str().unwrap(), "--workers", workers]);
    let s = said(&o);
    assert!(o.status.success(), "{s}");
    s
}

#[test]
fn each_seed_uses_its_own_draw_byte_for_byte_as_draw_replication_numbers_it() {
    let tmp = tempfile::tempdir().unwrap();
    let per_seed = write(tmp.path(), "per_seed.design", &small("draws per seed\n"));
    let replicated = write(tmp.path(), "replicated.design", &small("factor draw = 1..3\n"));

    let check = crossaudit(&["check", &per_seed]);
    let s = said(&check);
    assert!(check.status.success(), "{s}");
    assert!(s.contains("draws per seed") && s.contains("seed 4: draw 1, seed 5: draw 2, seed 6: draw 3"), "{s}");

    let (a, b, c) = (tmp.path().join("a"), tmp.path().join("b"), tmp.path().join("c"));
    run(&per_seed, &a, "2");
    run(&per_seed, &b, "1");
    run(&replicated, &c, "2");
    // Seed j's per-cell files are those of seed j in draw j - 4 + 1.
    for (seed, draw) in [(4, 1), (5, 2), (6, 3)] {
        for model in ["world", "relative"] {
            for arm in ["disjoint", "contaminated"] {
                let file = format!("draw-{draw}/cells/{model}__{arm}__{seed}.csv");
                let mine = std::fs::read(a.join(&file)).unwrap();
                assert_eq!(mine, std::fs::read(c.join(&file)).unwrap(), "{file} differs from draw replication's");
                assert_eq!(mine, std::fs::read(b.join(&file)).unwrap(), "{file} differs with one worker");
            }
        }
        // Only that seed trained in that draw's folder.
        let others = std::fs::read_dir(a.join(format!("draw-{draw}/cells"))).unwrap().count();
        assert_eq!(others, 4, "draw-{draw} holds one seed's 4 jobs");
    }
    // One crossed study of every seed, identical with 1 and 2 workers.
    let cells = std::fs::read(a.join("cells.csv")).unwrap();
    assert_eq!(cells, std::fs::read(b.join("cells.csv")).unwrap());
    let text = String::from_utf8(cells).unwrap();
    for seed in [",4,", ",5,", ",6,"] {
        assert!(text.contains(seed), "seed {seed} missing from cells.csv");
    }
    let report = std::fs::read_to_string(a.join("report/report.md")).unwrap();
    assert!(report.contains("over 4 recordings x 3 seeds"), "{report}");
    assert!(report.contains("draws per seed: each seed trained and was evaluated on its own draw"), "{report}");
    assert!(report.contains("seed 4 draw 1, seed 5 draw 2, seed 6 draw 3"), "{report}");
    assert!(a.join("report/report.html").exists());
    // The per-cell file reanalyses to the same decision line.
    let again = crossaudit(&[
        "analyze",
        &per_seed,
        "--cells",
        a.join("cells.csv").to_str().unwrap(),
        "--out",
        tmp.path().join("again").to_str().unwrap(),
    ]);
    assert!(again.status.success(), "{}", said(&again));
    // A resumed run trains nothing and writes the same cells.
    let s = run(&per_seed, &a, "2");
    assert!(s.contains("0 cells trained, 12 resumed"), "{s}");
    assert_eq!(std::fs::read(a.join("cells.csv")).unwrap(), std::fs::read(b.join("cells.csv")).unwrap());
}

#[test]
fn per_seed_draws_are_refused_where_they_cannot_apply() {
    let tmp = tempfile::tempdir().unwrap();
    let with_draws = write(tmp.path(), "d.design", &small("draws per seed\nfactor draw = 1..2\n"));
    let o = crossaudit(&["check", &with_draws]);
    assert!(!o.status.success() && said(&o).contains("per-seed draws and a draw factor"), "{}", said(&o));
    // Per-seed draws run on Slurm (tests/slurm.rs); `train` of one job is refused.
    let per_seed = write(tmp.path(), "p.design", &small("draws per seed\n"));
    let o = crossaudit(&[
        "train",
        &per_seed,
        "--model",
        "world",
        "--arm",
        "disjoint",
        "--seed",
        "5",
        "--out",
        tmp.path().join("t").to_str().unwrap(),
    ]);
    assert!(!o.status.success() && said(&o).contains("per-seed draws is several runs"), "{}", said(&o));
}

/// The small study as a multiverse of two training lengths (trained) and two
/// levels (analysis only), its draws coupled and given per seed.
fn multiverse() -> String {
    small("").replace("epochs 15 ", "").replace("crossed_mom level 0.95 ", "crossed_mom ")
        + "draws per seed\ndraws coupled\nchoices {\n  epochs 15 | 12\n  level 0.95 | 0.99\n}\nprimary specification epochs 15, level 0.95\n"
}

#[test]
fn a_multiverse_with_per_seed_draws_gives_each_seed_one_draw_in_every_specification() {
    let tmp = tempfile::tempdir().unwrap();
    let m = write(tmp.path(), "m.design", &multiverse());
    let check = crossaudit(&["check", &m]);
    let s = said(&check);
    assert!(check.status.success(), "{s}");
    // 2 trained specifications x 3 seeds, each seed's level 4 jobs.
    assert!(s.contains("jobs: 24 in all"), "{s}");
    assert!(s.contains("seed 4: draw 1, seed 5: draw 2, seed 6: draw 3"), "{s}");

    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    run(&m, &a, "2");
    run(&m, &b, "1");
    let cells = std::fs::read(a.join("multiverse_cells.csv")).unwrap();
    assert_eq!(cells, std::fs::read(b.join("multiverse_cells.csv")).unwrap(), "1 and 2 workers differ");
    for (seed, draw) in [(4, 1), (5, 2), (6, 3)] {
        // The same draw in both trained specifications (they differ in the
        // number of epochs only): the same manifests, other models.
        let manifests =
            |spec: &str| std::fs::read(a.join(format!("{spec}/draw-{draw}/manifests/manifests.json"))).unwrap();
        assert_eq!(manifests("spec-s1"), manifests("spec-s3"), "seed {seed}: s1 and s3 drew differently");
        let file = format!("draw-{draw}/cells/world__disjoint__{seed}.csv");
        let (s1, s3) = (a.join("spec-s1").join(&file), a.join("spec-s3").join(&file));
        assert_ne!(std::fs::read(&s1).unwrap(), std::fs::read(&s3).unwrap(), "the training length changed nothing");
        let others = std::fs::read_dir(a.join(format!("spec-s1/draw-{draw}/cells"))).unwrap().count();
        assert_eq!(others, 4, "spec-s1/draw-{draw} holds one seed's 4 jobs");
    }
    // Each specification is one crossed study of every seed, with its report.
    for spec in ["s1", "s2", "s3", "s4"] {
        let report = std::fs::read_to_string(a.join(format!("spec-{spec}/report/report.md"))).unwrap();
        assert!(report.contains("over 4 recordings x 3 seeds"), "{spec}: {report}");
        assert!(report.contains("seed 4 draw 1, seed 5 draw 2, seed 6 draw 3"), "{spec}: {report}");
    }
    // An analysis-only choice trains nothing of its own.
    assert!(!a.join("spec-s2/draw-1").exists(), "spec-s2 shares spec-s1's seeds");
    assert_eq!(
        std::fs::read(a.join("spec-s1/cells.csv")).unwrap(),
        std::fs::read(a.join("spec-s2/cells.csv")).unwrap()
    );
    let text = String::from_utf8(cells).unwrap();
    assert!(text.starts_with("spec,draw,"), "{text}");
    assert!(text.lines().any(|l| l.starts_with("s3,2,")), "s3's seed 5 rows carry draw 2");
    let combined = std::fs::read_to_string(a.join("report/report.md")).unwrap();
    for spec in ["s1", "s2", "s3", "s4"] {
        assert!(combined.contains(&format!("| {spec} ")), "{spec} missing from the multiverse report: {combined}");
    }
    // The run reanalyses to the same decision, and an edited design cannot
    // overwrite its combined report.
    let again =
        crossaudit(&["analyze", &m, "--cells", a.to_str().unwrap(), "--out", tmp.path().join("r").to_str().unwrap()]);
    assert!(again.status.success(), "{}", said(&again));
    let edited = write(tmp.path(), "e.design", &multiverse().replace("level 0.95 | 0.99", "level 0.95 | 0.9"));
    let o =
        crossaudit(&["analyze", &edited, "--cells", a.to_str().unwrap(), "--out", a.join("report").to_str().unwrap()]);
    assert!(!o.status.success(), "an edited design replaced the run's report: {}", said(&o));
    let resumed = run(&m, &a, "2");
    assert!(resumed.contains("0 cells trained"), "{resumed}");
    assert_eq!(
        std::fs::read(a.join("multiverse_cells.csv")).unwrap(),
        std::fs::read(b.join("multiverse_cells.csv")).unwrap()
    );
}

/// The draw planner's variance and df are the balanced design's closed
/// forms: on a complete I x J x K array whose REML components are all
/// inside the parameter space, REML equals the ANOVA estimates, so the
/// GLS SE of the intercept is sqrt(s_r/I + s_s/J + s_d/K + s_rd/(IK) +
/// s_sd/(JK) + s_e/(IJK)) exactly, and the Satterthwaite df of the
/// expected mean squares is the df that the REML fit's own Hessian gives
/// (lmerTest's method, tests/stats_mixed_df.rs).
#[test]
fn the_draw_planner_s_closed_forms_are_those_of_a_reml_fit() {
    use crossaudit::stats::mixed::{fit, Criterion, MixedData};
    use rand::SeedableRng;
    let (ni, nj, nk) = (9usize, 7usize, 4usize);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(45);
    let mut z = |sd: f64| -> f64 { sd * crossaudit::stats::standard_normal(&mut rng) };
    let r: Vec<f64> = (0..ni).map(|_| z(1.0)).collect();
    let s: Vec<f64> = (0..nj).map(|_| z(0.7)).collect();
    let d: Vec<f64> = (0..nk).map(|_| z(1.5)).collect();
    let rd: Vec<f64> = (0..ni * nk).map(|_| z(0.6)).collect();
    let sd: Vec<f64> = (0..nj * nk).map(|_| z(0.8)).collect();
    let (mut y, mut fr, mut fs, mut fd, mut frd, mut fsd) = (vec![], vec![], vec![], vec![], vec![], vec![]);
    for k in 0..nk {
        for i in 0..ni {
            for j in 0..nj {
                y.push(r[i] + s[j] + d[k] + rd[i * nk + k] + sd[j * nk + k] + z(1.0));
                fr.push(i);
                fs.push(j);
                fd.push(k);
                frd.push(i * nk + k);
                fsd.push(j * nk + k);
            }
        }
    }
    let data = MixedData::new(
        y,
        vec![
            ("recording".into(), fr),
            ("seed".into(), fs),
            ("draw".into(), fd),
            ("recording:draw".into(), frd),
            ("seed:draw".into(), fsd),
        ],
    )
    .unwrap();
    let f = fit(&data, Criterion::Reml).unwrap();
    assert!(f.theta.iter().all(|t| *t > 0.05), "a component at the boundary: {:?}", f.theta);
    let c = crossaudit::methods::DrawComponents {
        recording: f.variances[0],
        seed: f.variances[1],
        draw: f.variances[2],
        recording_draw: f.variances[3],
        seed_draw: f.variances[4],
        residual: f.residual,
    };
    crate::common::assert_rel(c.pooled_variance(ni, nj, nk).sqrt(), f.se, 1e-8, "pooled SE = the GLS SE");
    let sat = f.df_satterthwaite.unwrap();
    crate::common::assert_rel(c.pooled_df(ni, nj, nk), sat, 1e-5, "pooled df = REML Satterthwaite df");
    // Per-seed draws on the same components: the crossed closed form with
    // the draw and seed:draw variances in the seed's.
    let per_seed = c.per_seed_variance(ni, nj * nk);
    let (a, b, e) = (c.recording, c.seed + c.draw + c.seed_draw, c.recording_draw + c.residual);
    let n = (nj * nk) as f64;
    crate::common::assert_rel(per_seed, a / ni as f64 + b / n + e / (ni as f64 * n), 1e-15, "per-seed variance");
}

/// `crossaudit plan` on the committed draw-replicated run plans d pooled
/// over draws and with per-seed draws; at the pilot's own sizes its pooled
/// SE is the closed form of the pilot's components.
#[test]
fn plan_on_a_draw_replicated_pilot_predicts_pooled_and_per_seed_designs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plan");
    let o = crossaudit(&[
        "plan",
        "designs/multiverse/paper_draws.design",
        "--cells",
        "results/multiverse/draws",
        "--recordings",
        "12,24",
        "--seeds",
        "10,20",
        "--draws",
        "3,6",
        "--out",
        out.to_str().unwrap(),
    ]);
    let s = said(&o);
    assert!(o.status.success(), "{s}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("plan.json")).unwrap()).unwrap();
    let (i0, j0, k0) =
        (json["pilot"][0].as_u64().unwrap(), json["pilot"][1].as_u64().unwrap(), json["pilot"][2].as_u64().unwrap());
    assert_eq!((i0, j0, k0), (24, 20, 3), "{s}");
    let rows = json["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2 * 2 * 2 + 2 * 2);
    let c = &json["components"];
    let v = |k: &str| c[k].as_f64().unwrap();
    let want = (v("recording") / 24.0
        + v("seed") / 20.0
        + v("draw") / 3.0
        + v("recording_draw") / 72.0
        + v("seed_draw") / 60.0
        + v("residual") / 1440.0)
        .sqrt();
    let at_pilot = rows.iter().find(|r| r["recordings"] == 24 && r["seeds"] == 20 && r["draws"] == 3).unwrap();
    crate::common::assert_rel(at_pilot["se"].as_f64().unwrap(), want, 1e-12, "pooled SE at the pilot");
    // More draws never widen the pooled interval; per-seed rows train J models.
    let per_seed = rows.iter().filter(|r| r["draws"].is_null()).count();
    assert_eq!(per_seed, 4);
    for r in rows.iter().filter(|r| r["draws"].is_null()) {
        assert_eq!(r["models_per_arm"], r["seeds"]);
    }
    let md = std::fs::read_to_string(out.join("plan.md")).unwrap();
    // A 3-draw pilot: its draw components rest on 2 df, and the plan says so.
    assert!(json["warning"].as_str().unwrap().starts_with("the pilot has 3 draws: its draw components rest on 2 df"));
    for needle in [
        "## Pooled over K draws",
        "## Per-seed draws",
        "## Assumptions",
        "A single draw (K = 1) is not planned",
        "**Warning**: the pilot has 3 draws",
        "or from a per-seed pilot",
    ] {
        assert!(md.contains(needle), "{needle} not in plan.md:\n{md}");
    }
    assert!(out.join("plan.svg").is_file());
    // K = 1 is refused with the flag named.
    let o = crossaudit(&[
        "plan",
        "designs/multiverse/paper_draws.design",
        "--cells",
        "results/multiverse/draws",
        "--draws",
        "1",
        "--out",
        dir.path().join("p1").to_str().unwrap(),
    ]);
    assert!(!o.status.success() && said(&o).contains("--draws need values of at least 2, found 1"), "{}", said(&o));
}
