//! `crossaudit combine`: finished runs analysed as one study with every
//! run's evidence, read back and verified by `analyze`. The runs are the
//! committed per-seed sets of the paper's protocol
//! (results/multiverse/per_seed and per_seed_uncoupled); the expected
//! counts come from each run's own committed report.

use std::path::Path;

use crate::common::{crossaudit, root, said};

const DESIGN: &str = "designs/multiverse/paper_per_seed_combined.design";
const COUPLED: (&str, &str) = ("designs/multiverse/paper_per_seed.design", "results/multiverse/per_seed");
const UNCOUPLED: (&str, &str) =
    ("designs/multiverse/paper_per_seed_uncoupled.design", "results/multiverse/per_seed_uncoupled");

fn combine(out: &Path, runs: &[(&str, &str, &str)]) -> std::process::Output {
    let mut args = vec!["combine", DESIGN, "--out", out.to_str().unwrap()];
    for (design, run, shift) in runs {
        args.extend(["--from", design, run, shift]);
    }
    crossaudit(&args)
}

/// N in "invariant `id` (...) is not met in full, which the design allows
/// (a warning), in N of M draws" of a report.
fn draws_warned(report: &str, id: u32) -> (usize, usize) {
    let line = report
        .lines()
        .find(|l| l.starts_with(&format!("- invariant {id} (")))
        .unwrap_or_else(|| panic!("no invariant {id} warning in the report"));
    let after = line.split("which the design allows (a warning), in ").nth(1).unwrap();
    let words: Vec<&str> = after.split_whitespace().collect();
    (words[0].parse().unwrap(), words[2].parse().unwrap())
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn combined_runs_carry_every_runs_evidence_and_read_back_the_same() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("combined");
    let o = combine(&out, &[(COUPLED.0, COUPLED.1, "0"), (UNCOUPLED.0, UNCOUPLED.1, "20")]);
    assert!(o.status.success(), "{}", said(&o));
    // The cells: the two runs' rows, the second's seeds shifted by 20.
    let cells = read(&out.join("cells.csv"));
    let coupled = read(&root().join(COUPLED.1).join("cells.csv"));
    let uncoupled = read(&root().join(UNCOUPLED.1).join("cells.csv"));
    assert_eq!(cells.lines().count(), coupled.lines().count() + uncoupled.lines().count() - 1);
    assert!(cells.starts_with(&coupled), "the first run's rows come first, unchanged");
    let seeds: std::collections::BTreeSet<u64> =
        cells.lines().skip(1).map(|l| l.split(',').nth(2).unwrap().parse().unwrap()).collect();
    assert_eq!(seeds, (100..140).collect());
    // Each guard counts the draws of both runs, as each run's own report
    // counts its own.
    let report = read(&out.join("report/report.md"));
    for id in [3, 5] {
        let (a, n) = draws_warned(&read(&root().join(COUPLED.1).join("report/report.md")), id);
        let (b, m) = draws_warned(&read(&root().join(UNCOUPLED.1).join("report/report.md")), id);
        assert_eq!(draws_warned(&report, id), (a + b, n + m), "invariant {id}");
    }
    assert!(report.contains("**The reference arm is not disjoint**"), "{report}");
    assert!(report.contains("**Validation holds copies of evaluation flights**"), "{report}");
    assert!(report.contains("**Early stopping**"), "{report}");
    assert!(report.contains("combined from 2 finished runs"), "{report}");
    // The console says the guards beside the verdict too.
    let console = said(&o);
    assert!(console.contains("The reference arm is not disjoint: invariant 5"), "{console}");
    // Read back from the folder, the analysis is the same.
    let again = tmp.path().join("again");
    let o = crossaudit(&["analyze", DESIGN, "--cells", out.to_str().unwrap(), "--out", again.to_str().unwrap()]);
    assert!(o.status.success(), "{}", said(&o));
    for f in ["report.md", "results.json", "estimates.csv"] {
        assert_eq!(read(&again.join(f)), read(&out.join("report").join(f)), "{f}");
    }
}

#[test]
fn combine_refuses_one_run_counted_twice_before_writing() {
    // A trust review found the same run given twice (seeds shifted apart)
    // combined into 40 "independent" seeds of 20 models, with a narrower
    // interval and another decision. Its models are the same: refused by
    // name, and nothing written.
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("twice");
    let o = combine(&out, &[(COUPLED.0, COUPLED.1, "0"), (COUPLED.0, COUPLED.1, "20")]);
    assert!(!o.status.success());
    let e = said(&o);
    assert!(
        e.contains("has the same cells, value for value, as seed 100 of") && e.contains("the same trained models"),
        "{e}"
    );
    assert!(!out.join("cells.csv").exists() && !out.join("combined.json").exists(), "nothing written");
    // A copy of the run's folder is the same run.
    let copy = tmp.path().join("copy");
    crate::common::copy_dir(&root().join(COUPLED.1), &copy);
    let o = combine(&out, &[(COUPLED.0, COUPLED.1, "0"), (COUPLED.0, copy.to_str().unwrap(), "20")]);
    assert!(said(&o).contains("the same trained models"), "{}", said(&o));
    // A folder holding someone's own cells.csv is not combined into.
    let mine = tmp.path().join("mine");
    std::fs::create_dir_all(&mine).unwrap();
    std::fs::write(mine.join("cells.csv"), "precious\n").unwrap();
    let o = combine(&mine, &[(COUPLED.0, COUPLED.1, "0"), (UNCOUPLED.0, UNCOUPLED.1, "20")]);
    assert!(said(&o).contains("that no `combine` wrote"), "{}", said(&o));
    assert_eq!(read(&mine.join("cells.csv")), "precious\n");
}

#[test]
fn combine_refuses_runs_whose_seeds_collide_or_are_not_the_designs() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("combined");
    let o = combine(&out, &[(COUPLED.0, COUPLED.1, "0"), (UNCOUPLED.0, UNCOUPLED.1, "0")]);
    assert!(!o.status.success());
    let e = said(&o);
    assert!(e.contains("seed 100, which an earlier run already has") && e.contains(UNCOUPLED.1), "{e}");
    assert!(!out.join("cells.csv").exists(), "nothing written");
    let o = combine(&out, &[(COUPLED.0, COUPLED.1, "0"), (UNCOUPLED.0, UNCOUPLED.1, "30")]);
    assert!(!o.status.success());
    let e = said(&o);
    assert!(e.contains("are not the combined design's seeds") && e.contains("factor seed"), "{e}");
    let o = combine(&out, &[(COUPLED.0, COUPLED.1, "0"), (UNCOUPLED.0, UNCOUPLED.1, "-20")]);
    assert!(!o.status.success());
    assert!(said(&o).contains("seed shift \"-20\" is not a whole number"), "{}", said(&o));
    // A run folder of another design.
    let o = combine(&out, &[(COUPLED.0, UNCOUPLED.1, "0"), (UNCOUPLED.0, UNCOUPLED.1, "20")]);
    assert!(!o.status.success());
    assert!(said(&o).contains("is a run of another design"), "{}", said(&o));
}

#[test]
fn a_combined_folder_whose_cells_or_runs_changed_is_not_reanalysed() {
    let tmp = tempfile::tempdir().unwrap();
    let source = tmp.path().join("uncoupled");
    crate::common::copy_dir(&root().join(UNCOUPLED.1), &source);
    let out = tmp.path().join("combined");
    let o = combine(&out, &[(COUPLED.0, COUPLED.1, "0"), (UNCOUPLED.0, source.to_str().unwrap(), "20")]);
    assert!(o.status.success(), "{}", said(&o));
    let analyze = || {
        crossaudit(&[
            "analyze",
            DESIGN,
            "--cells",
            out.to_str().unwrap(),
            "--out",
            tmp.path().join("r").to_str().unwrap(),
        ])
    };
    // The combined cells edited: refused.
    let cells = out.join("cells.csv");
    let text = read(&cells);
    std::fs::write(&cells, text.replacen(",100,", ",101,", 1)).unwrap();
    let o = analyze();
    assert!(!o.status.success());
    assert!(said(&o).contains("it was edited after combining"), "{}", said(&o));
    std::fs::write(&cells, &text).unwrap();
    assert!(analyze().status.success());
    // A source run's cells edited: refused, naming the file.
    let theirs = source.join("cells.csv");
    let t = read(&theirs);
    let (head, rest) = t.split_once('\n').unwrap();
    let mut rows: Vec<&str> = rest.lines().collect();
    rows.swap(0, 1);
    std::fs::write(&theirs, format!("{head}\n{}\n", rows.join("\n"))).unwrap();
    let o = analyze();
    assert!(!o.status.success());
    let e = said(&o);
    assert!(e.contains(&theirs.display().to_string()) && e.contains("changed since the runs were combined"), "{e}");
}
