//! The bad-input corpus (`tests/bad_inputs/`, written by its
//! `make_cases.py`): designs, per-cell CSVs, flight logs, metadata,
//! coverage specs and command-line arguments, each run with the real
//! binary. Every case must exit non-zero with a message and never panic,
//! abort or hang; its exact exit code and message are snapshotted.

use std::path::Path;
use std::process::Command;

use crate::common::root;

/// Runs one case: its `args` with `{dir}` and `{out}` filled in; returns
/// the exit code and stderr with the paths put back as placeholders.
fn run_case(dir: &Path, out: &Path) -> (Option<i32>, String) {
    let args = std::fs::read_to_string(dir.join("args")).unwrap();
    let (d, o) = (dir.display().to_string(), out.display().to_string());
    let args: Vec<String> = args.split_whitespace().map(|a| a.replace("{dir}", &d).replace("{out}", &o)).collect();
    // A case with a `stdout` file reading `closed` runs with standard
    // output closed (`>&-`), through the shell: the one way to start a
    // program without a descriptor 1.
    let closed = std::fs::read_to_string(dir.join("stdout")).is_ok_and(|s| s.trim() == "closed");
    let mut command = if closed {
        let mut c = Command::new("sh");
        c.arg("-c").arg("exec \"$0\" \"$@\" >&-").arg(env!("CARGO_BIN_EXE_crossaudit"));
        c
    } else {
        crate::common::bin()
    };
    let child = command
        .current_dir(root())
        .args(&args)
        .env("NO_COLOR", "1")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // A case that runs for a minute is a hang.
    let (code, stderr) = crate::common::finish_within(child, 60, &dir.display().to_string());
    (code, stderr.replace(&d, "{dir}").replace(&o, "{out}"))
}

#[test]
fn every_bad_input_is_refused_with_a_located_message() {
    let corpus = root().join("tests/bad_inputs");
    let mut cases: Vec<_> = std::fs::read_dir(&corpus)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.join("args").exists())
        .collect();
    cases.sort();
    assert!(cases.len() >= 40, "the corpus holds {} cases", cases.len());
    let tmp = tempfile::tempdir().unwrap();
    // Each case runs twice: from the checkout, and from a copy whose path
    // is longer by a folder name. With the paths put back as placeholders
    // both must say the same: a message cut to a length must not cut
    // where the checkout lies (CI's checkout is not this machine's).
    let elsewhere = tmp.path().join("a-folder-that-makes-the-path-longer");
    for case in &cases {
        let name = case.file_name().unwrap().to_string_lossy().into_owned();
        let copy = elsewhere.join(&name);
        crate::common::copy_dir(case, &copy);
        let (code, stderr) = run_case(case, &tmp.path().join(&name));
        let moved = run_case(&copy, &tmp.path().join(format!("{name}-moved")));
        assert_eq!((code, &stderr), (moved.0, &moved.1), "{name}: the message depends on where the case lies");
        assert!(!stderr.contains("panicked"), "{name} panicked:\n{stderr}");
        assert!(matches!(code, Some(1) | Some(2)), "{name}: exit {code:?} (an abort or a success):\n{stderr}");
        assert!(!stderr.trim().is_empty(), "{name}: no message");
        crate::snapshots!({
            insta::assert_snapshot!(format!("bad_input_{name}"), format!("exit {}\n{stderr}", code.unwrap_or(-1)));
        });
    }
}

/// `run` cases of the corpus refused for a command-line choice (a flag's
/// value, the output folder), not for the design or what it names: `check`
/// sees no flags and no output folder. Each with why.
const RUN_ONLY: &[(&str, &str)] = &[
    ("cli_data_on_simulated", "the --data flag on a simulated design"),
    ("cli_workers_zero", "the --workers flag"),
    ("r3a_cli_slurm_cpus_huge", "the --cpus flag"),
    ("r3a_cli_slurm_throttle_huge", "the --throttle flag"),
    ("r3a_cli_workers_huge", "the --workers flag"),
    ("r3a_run_out_is_data_folder", "the --out folder"),
    ("r3b_run_into_other_designs_run", "the --out folder"),
    ("r3b_slurm_into_other_designs_run", "the --out folder"),
];

/// `check` is the run's validator: for every `run` case of the corpus that
/// `run` refuses for the design or the files it names (its lock state
/// included), `check` of the same design refuses it too or says that `run`
/// refuses it, before anyone runs; the cases refused for a flag or an output
/// folder are listed in [`RUN_ONLY`] with why.
#[test]
fn check_says_first_what_run_refuses_about_a_design() {
    let corpus = root().join("tests/bad_inputs");
    let mut checked = 0;
    let mut only_run = Vec::new();
    for e in std::fs::read_dir(&corpus).unwrap() {
        let dir = e.unwrap().path();
        let name = dir.file_name().unwrap().to_string_lossy().into_owned();
        let Ok(args) = std::fs::read_to_string(dir.join("args")) else { continue };
        let words: Vec<String> =
            args.split_whitespace().map(|a| a.replace("{dir}", &dir.display().to_string())).collect();
        if words.first().map(String::as_str) != Some("run") || RUN_ONLY.iter().any(|(n, _)| *n == name) {
            continue;
        }
        let o = crate::common::crossaudit(&["check", &words[1]]);
        let said = crate::common::said(&o);
        if o.status.success() && !said.contains("run refuses this design as it stands") {
            only_run.push(format!("{name}: check {} passes without a word:\n{said}", words[1]));
        }
        checked += 1;
    }
    assert!(checked >= 5, "only {checked} run cases");
    assert!(only_run.is_empty(), "refused only by run:\n{}", only_run.join("\n"));
}

/// `data audit` and `split` cases refused for the output folder, not for
/// the design or its data.
const OUT_FOLDER_ONLY: &[&str] = &[
    "r3a_data_inside_out_folder",
    "r3a_out_inside_data_folder",
    "r3a_out_is_data_folder",
    "r3a_out_is_data_folder_dotted",
    "r3a_split_out_is_data_folder",
    "r3b_data_audit_into_other_designs_run",
    "r3b_split_into_other_designs_run",
];

/// `check` reads the data too: for every `data audit` and `split` case of
/// the corpus (each refused for its logs, its conditions or its split),
/// `check` of the same design on the same data refuses, before anyone
/// locks, where it used to say "valid" (issue 73: an unmapped speed column
/// of a conditions table surfaced only at `run`).
#[test]
fn check_refuses_first_what_run_refuses_about_the_data() {
    let corpus = root().join("tests/bad_inputs");
    let mut checked = Vec::new();
    let mut passed = Vec::new();
    for e in std::fs::read_dir(&corpus).unwrap() {
        let dir = e.unwrap().path();
        let name = dir.file_name().unwrap().to_string_lossy().into_owned();
        let Ok(args) = std::fs::read_to_string(dir.join("args")) else { continue };
        let words: Vec<String> =
            args.split_whitespace().map(|a| a.replace("{dir}", &dir.display().to_string())).collect();
        let design = match words.iter().map(String::as_str).collect::<Vec<_>>().as_slice() {
            ["data", "audit", d, ..] | ["split", d, ..] => d.to_string(),
            _ => continue,
        };
        if OUT_FOLDER_ONLY.contains(&name.as_str()) {
            continue;
        }
        let mut check = vec!["check".to_string(), design];
        if let Some(k) = words.iter().position(|w| w == "--data") {
            check.extend(["--data".to_string(), words[k + 1].clone()]);
        }
        let check: Vec<&str> = check.iter().map(String::as_str).collect();
        let o = crate::common::crossaudit(&check);
        let said = crate::common::said(&o);
        assert!(!said.contains("panicked"), "{name}: {said}");
        if o.status.success() {
            passed.push(format!("{name}: {} passes:\n{said}", check.join(" ")));
        }
        checked.push(name);
    }
    assert!(checked.len() >= 40, "only {} data cases: {checked:?}", checked.len());
    assert!(passed.is_empty(), "check passes what run refuses about the data:\n{}", passed.join("\n"));
}
