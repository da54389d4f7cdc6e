//! Per-seed draws (`draws per seed`, issue 45): each seed trains and is
//! evaluated on its own draw of everything after the evaluation
//! recordings, so the crossed recording x seed estimator's seed component
//! carries the draw variance. Seed j's cells are byte for byte those of
//! seed j in the level `factor draw` numbers j - j0 + 1, whatever the
//! number of workers.

use std::path::Path;
use std::process::{Command, Output};

use crate::common::root;

fn crossaudit(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_crossaudit")).current_dir(root()).env("NO_COLOR", "1").args(args).output().unwrap()
}

fn said(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

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
    let per_seed = write(tmp.path(), "p.design", &small("draws per seed\n"));
    let out = tmp.path().join("slurm");
    let o = crossaudit(&["run", &per_seed, "--slurm", "--out", out.to_str().unwrap()]);
    assert!(!o.status.success() && said(&o).contains("not supported on Slurm yet"), "{}", said(&o));
    assert!(!out.exists(), "nothing is written");
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
