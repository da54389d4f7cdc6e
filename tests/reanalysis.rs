//! A reanalysis is the run: for every committed run folder (of a study of
//! one run, or the top folder of a study of several level folders),
//! `crossaudit analyze DESIGN --cells RUN_DIR` (the real binary)
//! reads the folder back as a record and writes its report again, and
//! every file of the committed `report/` must come out byte for byte (the
//! build line aside). A per-cell file alone gives the same numbers and
//! names the sections it cannot give.

use std::path::{Path, PathBuf};

use crate::common::crossaudit;
use crate::common::root;

/// The design a committed run folder ran: the first `run X.design` its
/// own COMMAND names, or else the line of a parent folder's COMMAND whose
/// `--out` is the folder.
fn design_of(folder: &Path) -> Option<String> {
    if let Some((_, d)) = DESIGNS.iter().find(|(f, _)| Path::new(f) == folder) {
        return Some(d.to_string());
    }
    let runs = |command: &Path| -> Vec<(String, Option<String>)> {
        let text = std::fs::read_to_string(root().join(command)).unwrap_or_default();
        text.lines()
            .filter_map(|line| {
                let words: Vec<&str> = line.split_whitespace().collect();
                let r =
                    words.windows(2).position(|w| (w[0] == "run" || w[0] == "combine") && w[1].ends_with(".design"))?;
                let design = words[r + 1].to_string();
                let out =
                    words.iter().position(|x| *x == "--out").and_then(|o| words.get(o + 1)).map(|o| o.to_string());
                Some((design, out))
            })
            .collect()
    };
    if let Some((design, _)) = runs(&folder.join("COMMAND")).into_iter().next() {
        return Some(design);
    }
    let parent = folder.parent()?;
    let shown = folder.display().to_string();
    runs(&parent.join("COMMAND")).into_iter().find(|(_, out)| out.as_deref() == Some(shown.as_str())).map(|(d, _)| d)
}

fn find(dir: &Path, name: &str, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            find(&p, name, out);
        } else if p.file_name().is_some_and(|n| n == name) {
            out.push(p);
        }
    }
}

/// The committed folders a run of one study wrote: a `run.json` of no
/// outer level, beside a `report/`; the tops of studies of several level
/// folders; the folders `crossaudit combine` wrote.
fn committed_run_folders() -> Vec<PathBuf> {
    let mut records = Vec::new();
    find(&root().join("results"), "run.json", &mut records);
    let level = |d: &Path| {
        let name = d.file_name().unwrap().to_string_lossy().into_owned();
        ["split-", "draw-", "spec-"].iter().any(|p| name.starts_with(p))
    };
    let mut out: Vec<PathBuf> = records
        .into_iter()
        .filter(|r| !std::fs::read_to_string(r).unwrap().contains("\"level\""))
        .map(|r| r.parent().unwrap().to_path_buf())
        .filter(|d| d.join("report").is_dir())
        // The level folders of an outer study (older ones record no level).
        .filter(|d| !level(d))
        .collect();
    // And the folders of studies of several levels: their level folders'
    // parent, beside a report/ (a multiverse of per-seed draws: the top).
    let mut parents: Vec<PathBuf> = Vec::new();
    find(&root().join("results"), "run.json", &mut parents);
    for r in parents {
        let mut d = r.parent().unwrap().to_path_buf();
        while level(&d) {
            d = d.parent().unwrap().to_path_buf();
        }
        let top = d.join("report").is_dir() && !d.join("run.json").exists() && !level(&d);
        if top && !out.contains(&d) {
            out.push(d);
        }
    }
    // And the folders `crossaudit combine` wrote.
    let mut combined = Vec::new();
    find(&root().join("results"), "combined.json", &mut combined);
    out.extend(combined.into_iter().map(|c| c.parent().unwrap().to_path_buf()).filter(|d| d.join("report").is_dir()));
    let mut out: Vec<PathBuf> = out.into_iter().map(|d| d.strip_prefix(root()).unwrap().to_path_buf()).collect();
    out.sort();
    out
}

/// A file's text with the lines naming the build (`... (commit abc)`) blanked.
fn without_build(text: &str) -> String {
    text.lines().map(|l| if l.contains("(commit ") { "<build>" } else { l }).collect::<Vec<_>>().join("\n")
}

/// The files of `want` that `got` does not reproduce, the build line aside.
fn differing(want: &Path, got: &Path) -> Vec<String> {
    // Every file of either: a file only one of them has differs too.
    let mut names: Vec<String> = [want, got]
        .iter()
        .flat_map(|d| std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()))
        .collect();
    names.sort();
    names.dedup();
    names
        .into_iter()
        .filter(|n| {
            // Text without its build line; any other file (estimates.parquet)
            // byte for byte.
            let read = |d: &Path| {
                std::fs::read(d.join(n)).ok().map(|b| match String::from_utf8(b) {
                    Ok(t) => without_build(&t).into_bytes(),
                    Err(e) => e.into_bytes(),
                })
            };
            read(want) != read(got)
        })
        .collect()
}

/// Run folders whose design reads a data folder that is not committed
/// (`crossaudit simulate-lab` writes it, as tests/lab_logs.rs does):
/// checked when it is there, else said SKIPPED.
const NEEDS_DATA: &[(&str, &str)] = &[("results/lab", "designs/logs/lab_logs")];

/// Run folders whose COMMAND names no `run` (the design they ran).
const DESIGNS: &[(&str, &str)] = &[
    ("results/external_models", "designs/external/paper_external.design"),
    ("results/multiverse/per_seed_uncoupled", "designs/multiverse/paper_per_seed_uncoupled.design"),
];

#[test]
fn every_committed_run_folder_is_reproduced_by_its_reanalysis() {
    let folders = committed_run_folders();
    assert!(folders.len() >= 15, "only {} committed run folders found: {folders:?}", folders.len());
    let tmp = tempfile::tempdir().unwrap();
    let mut failures = Vec::new();
    for (k, folder) in folders.iter().enumerate() {
        if let Some((_, data)) = NEEDS_DATA.iter().find(|(f, _)| Path::new(f) == folder) {
            if !root().join(data).is_dir() {
                crate::common::skip(
                    "lab data",
                    &format!("{}: its design's data folder {data} is absent", folder.display()),
                );
                continue;
            }
        }
        let design =
            design_of(folder).unwrap_or_else(|| panic!("no COMMAND names the design {} ran", folder.display()));
        let out = tmp.path().join(k.to_string());
        let o = crossaudit(&["analyze", &design, "--cells", folder.to_str().unwrap(), "--out", out.to_str().unwrap()]);
        if !o.status.success() {
            failures.push(format!("{}: analyze failed: {}", folder.display(), String::from_utf8_lossy(&o.stderr)));
            continue;
        }
        if std::env::var_os("CROSSAUDIT_REWRITE_REPORTS").is_some() {
            // scripts/regenerate.sh: the committed report becomes the
            // reanalysis's (the analysis is a pure function of the folder:
            // what a rerun of the same cells and evidence would write).
            let report = root().join(folder).join("report");
            std::fs::remove_dir_all(&report).unwrap();
            crate::common::copy_dir(&out, &report);
        }
        let differ = differing(&root().join(folder).join("report"), &out);
        if !differ.is_empty() {
            failures.push(format!("{}: {} differ", folder.display(), differ.join(", ")));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_quickstart_reanalysis_keeps_the_verdict_and_its_evidence() {
    let tmp = tempfile::tempdir().unwrap();
    let (folder, file) = (tmp.path().join("folder"), tmp.path().join("file"));
    let o = crossaudit(&[
        "analyze",
        "designs/quickstart.design",
        "--cells",
        "results/quickstart",
        "--out",
        folder.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(differing(&root().join("results/quickstart/report"), &folder), Vec::<String>::new());
    // The run's own cells.csv reads its folder's evidence too: the
    // coverage sentence beside the verdict stays.
    let o = crossaudit(&[
        "analyze",
        "designs/quickstart.design",
        "--cells",
        "results/quickstart/cells.csv",
        "--out",
        file.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(file.join("report.md")).unwrap();
    assert!(md.contains("Condition coverage: the reference arm (`disjoint`) fits on other recordings"), "{md}");
    assert!(md.contains("## Treatment strength"), "{md}");
}

#[test]
fn a_per_cell_file_alone_gives_the_same_numbers_and_names_what_it_lacks() {
    let tmp = tempfile::tempdir().unwrap();
    // A copy of the quickstart's cells, away from its run folder.
    let cells = tmp.path().join("cells.csv");
    std::fs::copy(root().join("results/quickstart/cells.csv"), &cells).unwrap();
    let out = tmp.path().join("report");
    let o = crossaudit(&[
        "analyze",
        "designs/quickstart.design",
        "--cells",
        cells.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let alone = std::fs::read_to_string(out.join("estimates.csv")).unwrap();
    let run = std::fs::read_to_string(root().join("results/quickstart/report/estimates.csv")).unwrap();
    // The same estimates; only the rows the run's evidence gives (the
    // covered-only contrast) are absent.
    for line in alone.lines() {
        assert!(run.lines().any(|l| l == line), "a row the run's report does not hold: {line}");
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("analysed from a per-cell file alone"), "{md}");
    assert!(md.contains("condition coverage") && md.contains("training curves"), "{md}");
    assert!(!md.contains("## Condition coverage"), "{md}");
}

#[test]
fn a_folder_that_is_not_a_run_or_of_another_design_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let o = crossaudit(&["analyze", "designs/quickstart.design", "--cells", tmp.path().to_str().unwrap()]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("run.json") && err.contains("not a run"), "{err}");
    let out = tmp.path().join("x");
    let o = crossaudit(&[
        "analyze",
        "designs/nanobench_confirmatory.design",
        "--cells",
        "results/quickstart",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("results/quickstart") && err.contains("961d4a76e4f5"), "{err}");
}

/// The small simulated study (tests/designs/sim_small.design) with `extra`.
fn small(extra: &str) -> String {
    std::fs::read_to_string(root().join("tests/designs/sim_small.design")).unwrap() + extra
}

/// A study of every kind whose run writes several level folders (per-seed
/// draws, whole splits, a multiverse with trained and analysis-only
/// choices, draw replication, a multiverse of per-seed draws) is run by
/// the real binary, then its folder is analysed again: the combined
/// report comes out byte for byte (the build line aside), its warnings
/// (levels, invariants, notes) included, because both read the same
/// record. The run's study.json records the combined cells' hash: an
/// edited cells.csv is refused.
#[test]
fn a_study_of_several_level_folders_is_reproduced_by_its_reanalysis() {
    let tmp = tempfile::tempdir().unwrap();
    let kinds: [(&str, String); 5] = [
        ("per_seed", small("draws per seed\n")),
        (
            "splits",
            small("factor split = 42..43\n").replace("decide confirmed when", "decide confirmed on pooled when"),
        ),
        (
            "multiverse",
            small("").replace("epochs 15 ", "").replace("crossed_mom level 0.95 ", "crossed_mom ")
                + "choices {\n  epochs 15 | 12\n  level 0.95 | 0.99\n}\nprimary specification epochs 15, level 0.95\n",
        ),
        ("draws", small("factor draw = 1..2\n")),
        (
            "per_seed_multiverse",
            small("").replace("epochs 15 ", "").replace("crossed_mom level 0.95 ", "crossed_mom ")
                + "draws per seed\ndraws coupled\nchoices {\n  epochs 15 | 12\n  level 0.95 | 0.99\n}\nprimary specification epochs 15, level 0.95\n",
        ),
    ];
    let mut failures = Vec::new();
    for (name, text) in &kinds {
        let design = tmp.path().join(format!("{name}.design"));
        std::fs::write(&design, text).unwrap();
        let (run, again) = (tmp.path().join(format!("{name}_run")), tmp.path().join(format!("{name}_again")));
        let d = design.to_str().unwrap();
        let o = crossaudit(&["run", d, "--out", run.to_str().unwrap(), "--workers", "2"]);
        assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
        assert!(run.join("study.json").is_file(), "{name}: the run wrote no study.json");
        let o = crossaudit(&["analyze", d, "--cells", run.to_str().unwrap(), "--out", again.to_str().unwrap()]);
        assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
        let differ = differing(&run.join("report"), &again);
        if !differ.is_empty() {
            failures.push(format!("{name}: {} differ", differ.join(", ")));
        }
        if *name == "per_seed" {
            // The run's own notes are the reanalysis's: the levels' note.
            let md = std::fs::read_to_string(again.join("report.md")).unwrap();
            assert!(md.contains("draws per seed: each seed trained"), "{md}");
            // The combined cells.csv is verified against study.json.
            let cells = run.join("cells.csv");
            let text = std::fs::read_to_string(&cells).unwrap();
            std::fs::write(&cells, text.replacen(",1,", ",2,", 1)).unwrap();
            let o = crossaudit(&["analyze", d, "--cells", run.to_str().unwrap(), "--out", again.to_str().unwrap()]);
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(!o.status.success() && err.contains("study.json") && err.contains("edited"), "{err}");
            // study.json itself edited (a note added): its seal no longer holds.
            std::fs::write(&cells, &text).unwrap();
            let study = run.join("study.json");
            let mut record: serde_json::Value = serde_json::from_slice(&std::fs::read(&study).unwrap()).unwrap();
            record["notes"] = serde_json::json!(["retrained on real logs"]);
            std::fs::write(&study, serde_json::to_string_pretty(&record).unwrap()).unwrap();
            let o = crossaudit(&["analyze", d, "--cells", run.to_str().unwrap(), "--out", again.to_str().unwrap()]);
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(!o.status.success() && err.contains("study.json was edited after crossaudit wrote it"), "{err}");
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Issue 72: a validation set that holds copies of evaluation flights
/// steers early stopping by them, and the verdict says so in every view.
/// The per-seed budget run's draws, counted from their own
/// `audit/invariants.json` (invariant 3 with status `warn`), against its
/// results.json guard and its report beside the verdict.
#[test]
fn validation_copies_of_evaluation_flights_are_a_guard_counted_per_draw() {
    let dir = root().join("results/multiverse/per_seed_budget");
    let mut warned = 0;
    let mut draws = 0;
    for k in 1..=20 {
        let text = std::fs::read_to_string(dir.join(format!("draw-{k}/audit/invariants.json"))).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        draws += 1;
        let three = v["invariants"].as_array().unwrap().iter().find(|i| i["id"] == 3).unwrap();
        if three["status"] == "warn" {
            warned += 1;
        }
    }
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report/results.json")).unwrap()).unwrap();
    let guard = results["guards"].as_array().unwrap().iter().find(|g| g["kind"] == "validation_copies").unwrap();
    let text = guard["text"].as_str().unwrap();
    assert!(text.contains(&format!("which the design allows (a warning), in {warned} of {draws} draws")), "{text}");
    let md = std::fs::read_to_string(dir.join("report/report.md")).unwrap();
    let head = md.split("\n## ").next().unwrap();
    assert!(head.contains("**Validation holds copies of evaluation flights**"), "{head}");
}

/// Two draw folders swapped: each run.json still names its own level, so
/// the reanalysis is refused (it credited one draw's evidence to another).
#[test]
fn swapped_draw_folders_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    crate::common::copy_dir(&root().join("results/multiverse/per_seed_budget"), &run);
    std::fs::rename(run.join("draw-1"), run.join("swap")).unwrap();
    std::fs::rename(run.join("draw-2"), run.join("draw-1")).unwrap();
    std::fs::rename(run.join("swap"), run.join("draw-2")).unwrap();
    let out = tmp.path().join("out");
    let o = crossaudit(&[
        "analyze",
        "designs/multiverse/paper_per_seed_budget.design",
        "--cells",
        run.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("draw-1") && e.contains("draw-2"), "{e}");
    assert!(!out.join("report.md").exists(), "nothing reported");
}

#[test]
fn a_training_curve_edited_after_the_run_is_left_out_and_named() -> Result<(), Box<dyn std::error::Error>> {
    // Before: a curve's epoch edited to `inf` hung the report (the
    // figure's axis ran to infinity, whose ticks plotters counts out
    // forever), and an epoch edited to -1 or 1.5 moved the early-stopping
    // check beside the verdict ("epochs -1 to 1") without a word. Every
    // job record holds its curve's SHA-256: a curve that differs is left
    // out, with why; where the folder keeps no job records (the committed
    // results), a curve whose epochs are not 1, 2, 3, ... is left out.
    let tmp = tempfile::tempdir()?;
    let run = tmp.path().join("run");
    let run_s = run.to_str().ok_or("path")?;
    let o = crossaudit(&["run", "designs/quickstart.design", "--out", run_s]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let curve = run.join("curves/relative__contaminated__1.csv");
    let text = std::fs::read_to_string(&curve)?;
    assert!(text.lines().nth(1).is_some_and(|l| l.starts_with("1,")), "{text}");
    // The run folder analysed into `out`, a hang failing the test.
    let analyze = |out: &Path| -> Result<(Option<i32>, String), Box<dyn std::error::Error>> {
        let out = out.to_str().ok_or("path")?;
        Ok(crate::common::crossaudit_within(
            60,
            &["analyze", "designs/quickstart.design", "--cells", run_s, "--out", out],
        ))
    };
    for (edit, why) in [("inf", "edited after the run"), ("-1", "edited after the run")] {
        std::fs::write(&curve, text.replacen("\n1,", &format!("\n{edit},"), 1))?;
        let out = tmp.path().join(format!("re{edit}"));
        let (code, said) = analyze(&out)?;
        assert_eq!(code, Some(0), "{said}");
        let line = said.lines().find(|l| l.contains("training curve(s)")).unwrap_or("");
        assert!(line.contains("relative__contaminated__1.csv") && line.contains(why), "{said}");
        assert!(line.contains("but jobs/relative__contaminated__1.json recorded"), "{said}");
        let md = std::fs::read_to_string(out.join("report.md"))?;
        assert!(!md.contains("epochs -1") && !md.contains("epochs inf"), "{md}");
    }
    // Without the job record, the curve's own epochs say it was edited.
    std::fs::remove_file(run.join("jobs/relative__contaminated__1.json"))?;
    std::fs::write(&curve, text.replacen("\n1,", "\ninf,", 1))?;
    let (code, said) = analyze(&tmp.path().join("bare"))?;
    assert_eq!(code, Some(0), "{said}");
    assert!(said.contains("relative__contaminated__1.csv (line 2: epoch inf where a run writes epoch 1)"), "{said}");
    Ok(())
}

#[test]
fn evidence_edited_after_the_run_is_left_out_and_named() -> Result<(), Box<dyn std::error::Error>> {
    // Before: one count in audit/treatment.json (the reference arm's fit
    // recordings of one evaluation condition, 1 edited to 0) made a
    // reanalysis print "The contrast mixes condition novelty with recording
    // leakage" beside the verdict, with nothing said about the edit. The
    // run records the SHA-256 of its evidence files in run.json
    // (`evidence_sha256`; audit/recordings.csv's in `audit_sha256`).
    let tmp = tempfile::tempdir()?;
    let run = tmp.path().join("run");
    let run_s = run.to_str().ok_or("path")?;
    let o = crossaudit(&["run", "designs/quickstart.design", "--out", run_s]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let record: serde_json::Value = serde_json::from_slice(&std::fs::read(run.join("run.json"))?)?;
    for name in ["audit/treatment.json", "audit/invariants.json"] {
        let sha = crossaudit::io::sha256_hex(&std::fs::read(run.join(name))?);
        assert_eq!(record["evidence_sha256"][name], sha.as_str(), "{record}");
    }
    let path = run.join("audit/treatment.json");
    let mut treatment: serde_json::Value = serde_json::from_slice(&std::fs::read(&path)?)?;
    treatment["coverage"]["recordings"][0]["fit_recordings"]["disjoint"] = 0.into();
    std::fs::write(&path, serde_json::to_string_pretty(&treatment)?)?;
    let recordings = run.join("audit/recordings.csv");
    let text = std::fs::read_to_string(&recordings)?;
    std::fs::write(&recordings, text.replacen(",included,", ",included ,", 1))?;
    let out = tmp.path().join("re");
    let o =
        crossaudit(&["analyze", "designs/quickstart.design", "--cells", run_s, "--out", out.to_str().ok_or("path")?]);
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{said}");
    for name in ["audit/treatment.json", "audit/recordings.csv"] {
        let line = said.lines().find(|l| l.contains(name)).unwrap_or("");
        assert!(line.contains("was edited after the run (sha256") && line.contains("but run.json recorded"), "{said}");
    }
    let md = std::fs::read_to_string(out.join("report.md"))?;
    assert!(!md.contains("mixes condition novelty"), "{md}");
    assert!(md.contains("treatment strength and condition coverage not reported"), "{md}");
    Ok(())
}

/// Before: a run folder whose audit/treatment.json was gone got no
/// coverage guard at all beside its verdict (the contrast's coverage of
/// the evaluated conditions unknown, said only in a warning far down), and
/// a per-cell file analysed into a folder that held the run's analysis
/// left its training_curves.svg there, beside a report that names none.
#[test]
fn unknown_coverage_is_a_guard_and_no_stale_figure_is_left() -> Result<(), Box<dyn std::error::Error>> {
    let tmp = tempfile::tempdir()?;
    let run = tmp.path().join("run");
    let run_s = run.to_str().ok_or("path")?;
    let o = crossaudit(&["run", "designs/quickstart.design", "--out", run_s]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = tmp.path().join("re");
    let out_s = out.to_str().ok_or("path")?;
    let o = crossaudit(&["analyze", "designs/quickstart.design", "--cells", run_s, "--out", out_s]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("training_curves.svg").is_file());
    // The run's cells alone, into the same folder.
    let cells = tmp.path().join("cells.csv");
    std::fs::copy(run.join("cells.csv"), &cells)?;
    let o =
        crossaudit(&["analyze", "designs/quickstart.design", "--cells", cells.to_str().ok_or("path")?, "--out", out_s]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!out.join("training_curves.svg").exists(), "a figure the report no longer names was left");
    assert!(out.join("optimism.svg").is_file());
    // The run folder without its treatment audit.
    std::fs::remove_file(run.join("audit/treatment.json"))?;
    let bare = tmp.path().join("bare");
    let o =
        crossaudit(&["analyze", "designs/quickstart.design", "--cells", run_s, "--out", bare.to_str().ok_or("path")?]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(said.contains("  Condition coverage unknown: the run folder records no condition coverage"), "{said}");
    let md = std::fs::read_to_string(bare.join("report.md"))?;
    let head = md.split("\n## ").next().unwrap_or("");
    assert!(head.contains("**Condition coverage unknown**: the run folder records no condition coverage"), "{head}");
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(bare.join("results.json"))?)?;
    let kinds: Vec<&str> =
        json["guards"].as_array().ok_or("guards")?.iter().filter_map(|g| g["kind"].as_str()).collect();
    assert!(kinds.contains(&"coverage"), "{kinds:?}");
    Ok(())
}

/// Before: `analyze --cells /dev/stdin` wrote its report into /dev/report
/// (beside the path given). Per-cell data that is no file in a folder
/// needs --out.
#[test]
fn per_cell_data_that_is_no_file_in_a_folder_needs_an_output_folder() {
    let o = crate::common::bin()
        .args(["analyze", "designs/quickstart.design", "--cells", "/dev/stdin"])
        .stdin(std::fs::File::open(root().join("results/quickstart/cells.csv")).unwrap())
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && e.contains("/dev/stdin is not a file in a folder") && e.contains("give --out DIR"),
        "{e}"
    );
    assert!(!Path::new("/dev/report").exists());
}
