//! Issue 77, the round after the hostile corpus: each class a hostile
//! tester found short in the newest surface, tested through the real
//! binary. Every test here failed on the code before its fix (the outputs
//! it checks against are quoted in each test's comment).

use std::path::Path;

use crate::common::{assert_ok, assert_refused, crossaudit, root, said, stderr};

/// The quickstart's committed cells with every metric multiplied by
/// `factor` (empty fields kept empty), written to `dir/cells.csv`.
fn scaled_cells(dir: &Path, factor: f64) -> String {
    let text = std::fs::read_to_string(root().join("results/quickstart/cells.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let metric = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let cols =
        ["fa_position_rmse_m", "conditional_position_rmse_m", "velocity_rmse_mps", "attitude_rmse_deg"].map(metric);
    let mut out = vec![header.join(",")];
    for l in lines {
        let mut f: Vec<String> = l.split(',').map(String::from).collect();
        for &k in &cols {
            if !f[k].is_empty() {
                f[k] = format!("{:e}", f[k].parse::<f64>().unwrap() * factor);
            }
        }
        out.push(f.join(","));
    }
    let path = dir.join("cells.csv");
    std::fs::write(&path, out.join("\n") + "\n").unwrap();
    path.display().to_string()
}

/// The simulated lab's Parquet folder (`simulate-lab`) in `dir/lab_logs`
/// and its design, designs/logs/lab.design, copied beside it.
fn lab_folder(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let logs = dir.join("lab_logs");
    assert_ok(&crossaudit(&["simulate-lab", "--out", logs.to_str().unwrap()]));
    let design = dir.join("lab.design");
    std::fs::copy(root().join("designs/logs/lab.design"), &design).unwrap();
    (logs, design)
}

/// Class 1 (wrong answers at extreme scales). The quickstart's cells times
/// 1e-160 gave CONFIRMED under `upper < 0` (the variances underflowed to 0,
/// the interval to a point) where the same cells unscaled give NOT
/// CONFIRMED; `mixed` on a response of 1e-160 reported p < 2e-16 and a
/// certified optimum; `simsum --true NaN` scored coverage 0 with MCSE 0;
/// `plan --components` of 1e308 said "there is no variance to plan from".
/// Each reader now refuses a nonzero value below 1e-60 (or a declared
/// value outside the range its squares stay in) at its place, with the
/// advice to rescale.
#[test]
fn values_whose_squares_leave_double_precision_are_refused_where_they_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let cells = scaled_cells(dir.path(), 1e-160);
    let out = dir.path().join("out");
    let o = crossaudit(&["analyze", "designs/quickstart.design", "--cells", &cells, "--out", out.to_str().unwrap()]);
    assert_refused(&o, "line 2, field `fa_position_rmse_m`: is below 1e-60 but not 0");
    assert!(!out.join("report.md").exists());
    // The same cells at 1e-20 are analysed as the unscaled ones are.
    let cells = scaled_cells(dir.path(), 1e-20);
    let o = crossaudit(&["analyze", "designs/quickstart.design", "--cells", &cells, "--out", out.to_str().unwrap()]);
    assert_ok(&o);

    let table = dir.path().join("mixed.csv");
    let rows: Vec<String> = (0..60).map(|i| format!("{},{i},g{},h{}", 1e-160 * (i % 7) as f64, i % 6, i % 5)).collect();
    std::fs::write(&table, format!("y,x,g,h\n{}\n", rows.join("\n"))).unwrap();
    let o = crossaudit(&["mixed", table.to_str().unwrap(), "--formula", "y ~ x + (1|g) + (1|h)"]);
    assert_refused(&o, "column y: its values are too small for double precision");

    let reps = dir.path().join("reps.csv");
    let mut text = String::from("rep,method,estimate,se\n");
    for r in 1..=20 {
        for (m, e) in [("A", 0.5 + 0.01 * r as f64), ("B", 0.45 + 0.012 * r as f64)] {
            text.push_str(&format!("{r},{m},{e},0.1\n"));
        }
    }
    std::fs::write(&reps, &text).unwrap();
    let simsum_out = dir.path().join("simsum");
    let s = simsum_out.to_str().unwrap();
    for truth in ["NaN", "inf", "-inf", "1e-200"] {
        let o = crossaudit(&["simsum", reps.to_str().unwrap(), "--rep", "rep", &format!("--true={truth}"), "--out", s]);
        assert_refused(&o, "is not a finite number between 1e-60 and 1e75");
    }
    let tiny = text.replace(",0.1\n", ",1e-70\n");
    std::fs::write(&reps, tiny).unwrap();
    let o = crossaudit(&["simsum", reps.to_str().unwrap(), "--rep", "rep", "--true", "0.5", "--out", s]);
    assert_refused(&o, "SE 1e-70 is below 1e-60 in magnitude");

    let o = crossaudit(&[
        "plan",
        "designs/quickstart.design",
        "--components",
        "recording=1e308,seed=1e308,residual=1e308",
        "--effect",
        "-0.02",
        "--reference-mean",
        "0.3",
        "--out",
        dir.path().join("plan").to_str().unwrap(),
    ]);
    assert_refused(&o, "a variance must be 0 or between 1e-120 and 1e150");
}

/// Class 8: a negative value with a decimal point or an exponent, given
/// as its own argument, was taken for an option by the argument parser
/// ("unexpected argument '-1' found; tip: ... use '-- -1'", which does not
/// work); `audit split --gap -1` said "unexpected argument".
#[test]
fn negative_numbers_are_values_as_users_type_them() {
    let dir = tempfile::tempdir().unwrap();
    let reps = dir.path().join("reps.csv");
    let mut text = String::from("rep,method,estimate,se\n");
    for r in 1..=10 {
        text.push_str(&format!("{r},A,{},0.1\n", -0.001 + 0.0001 * r as f64));
    }
    std::fs::write(&reps, &text).unwrap();
    let out = dir.path().join("simsum");
    for truth in ["-1e-3", "-.5", "-1E-3"] {
        let o = crossaudit(&[
            "simsum",
            reps.to_str().unwrap(),
            "--rep",
            "rep",
            "--true",
            truth,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_ok(&o);
    }
    let o = crossaudit(&[
        "audit",
        "split",
        "../shared/nanobench/upstream_task2_split_metadata.json",
        "--data",
        "../shared/nanobench/recordings",
        "--gap",
        "-1",
        "--out",
        dir.path().join("audit").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("\"-1\" is not a number of seconds above 0"), "{}", stderr(&o));
}

/// Class 4 / `check` first: a primary endpoint on a parameter-free model
/// (persistence) passed `check` and `run` trained every job before the
/// analysis refused the contrast as 0 by construction, blaming cells.csv.
#[test]
fn a_parameter_free_primary_model_is_refused_by_check_at_its_name() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("designs/quickstart.design")).unwrap();
    let edited = text.replace("model world    = mlp(64, 64, 64) inputs world", "model world = persistence");
    assert_ne!(edited, text);
    let path = dir.path().join("q.design");
    std::fs::write(&path, edited).unwrap();
    let o = crossaudit(&["check", path.to_str().unwrap()]);
    assert_refused(&o, "parameter-free primary model");
    assert!(stderr(&o).contains("`world` is persistence: it fits nothing"), "{}", stderr(&o));
    assert!(stderr(&o).contains("q.design:"), "located: {}", stderr(&o));
}

/// Class 6: a control character in a design (an escape sequence in the
/// study's name) was accepted and written raw into report.html and
/// results.tex. Refused at its line and column.
#[test]
fn a_control_character_in_a_design_is_refused_where_it_stands() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("designs/quickstart.design")).unwrap();
    let edited = text.replacen("study \"", "study \"\u{1b}[2J\u{7}", 1);
    assert_ne!(edited, text);
    let path = dir.path().join("q.design");
    std::fs::write(&path, edited).unwrap();
    let o = crossaudit(&["check", path.to_str().unwrap()]);
    assert_refused(&o, "control character in the design");
    assert!(stderr(&o).contains("U+001B is a control character"), "{}", stderr(&o));
    assert!(!stderr(&o).contains('\u{1b}'), "the escape itself is not sent to the terminal");
}

/// Class 6: names that a spreadsheet reads as formulas. A log file named
/// `=cmd-...` became a recording written raw into every CSV that names it
/// (cells.csv, the manifests, the audit), which the tool also reads back:
/// refused at its source, with the file named. Text the tool only writes
/// (a published split's role names, simsum's methods) gets a leading `'`,
/// with control characters shown as escapes, `-inf` included.
#[test]
fn names_a_spreadsheet_would_run_are_refused_at_their_source_or_neutralised() {
    let dir = tempfile::tempdir().unwrap();
    let (logs, design) = lab_folder(dir.path());
    std::fs::rename(logs.join("train/lab-circle-take1.parquet"), logs.join("train/=cmd-circle-take1.parquet")).unwrap();
    let o = crossaudit(&["check", design.to_str().unwrap()]);
    assert_refused(&o, "the file name \"=cmd-circle-take1.parquet\" begins with `=`");

    let reps = dir.path().join("reps.csv");
    let mut text = String::from("rep,method,estimate,se\n");
    for r in 1..=10 {
        text.push_str(&format!(
            "{r},=HYPERLINK(\"x\"),{},0.1\n{r},\u{1b}[31mred,{},0.1\n{r},-inf,{},0.1\n",
            0.5, 0.4, 0.45
        ));
    }
    std::fs::write(&reps, &text).unwrap();
    let out = dir.path().join("simsum");
    assert_ok(&crossaudit(&[
        "simsum",
        reps.to_str().unwrap(),
        "--rep",
        "rep",
        "--true",
        "0.5",
        "--out",
        out.to_str().unwrap(),
    ]));
    let csv = std::fs::read_to_string(out.join("simsum.csv")).unwrap();
    assert!(!csv.contains('\u{1b}'), "raw escape in simsum.csv");
    for line in csv.lines().skip(1) {
        for cell in line.split(',') {
            let cell = cell.trim_matches('"');
            assert!(!crossaudit::io::formula_like(cell), "a formula cell {cell:?} in: {line}");
        }
    }
    assert!(csv.contains("'-inf") && csv.contains("\\u{1b}[31mred"), "{csv}");
}

/// Class 6: a published split whose entry holds a control character (a NUL
/// in a JSON string) was counted "unknown" and the NUL written into
/// split_recordings.csv; refused at the entry.
#[test]
fn a_split_entry_with_a_control_character_is_refused_at_its_place() {
    let dir = tempfile::tempdir().unwrap();
    let split = dir.path().join("split.csv");
    std::fs::write(&split, "recording,role\nF1_circle_slow_rep1,train\nF2_star\u{0}_rep1,test\n").unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir(&data).unwrap();
    let o = crossaudit(&[
        "audit",
        "split",
        split.to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
        "--out",
        dir.path().join("audit").to_str().unwrap(),
    ]);
    assert_refused(&o, "holds a control character, which no name may");
    assert!(stderr(&o).contains("split.csv:3:"), "located: {}", stderr(&o));
}

/// Class 4: a lock whose time was edited by hand ("not a time", or a date
/// in the future) stood as "locked before this run" and the run was
/// labelled preregistered.
#[test]
fn a_lock_whose_time_was_edited_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let design = dir.path().join("q.design");
    std::fs::copy(root().join("designs/quickstart.design"), &design).unwrap();
    let lock = dir.path().join("q.design.lock");
    let committed = std::fs::read_to_string(root().join("designs/quickstart.design.lock")).unwrap();
    let value: serde_json::Value = serde_json::from_str(&committed).unwrap();
    let at = value["locked_at_utc"].as_str().unwrap().to_string();
    std::fs::write(&lock, &committed).unwrap();
    assert_ok(&crossaudit(&["check", design.to_str().unwrap()]));
    for (edited, why) in [("not a time", "is not a UTC time"), ("2099-12-05T09:57:33Z", "lies in the future")] {
        std::fs::write(&lock, committed.replace(&at, edited)).unwrap();
        let o = crossaudit(&["check", design.to_str().unwrap()]);
        assert_refused(&o, why);
        assert!(stderr(&o).contains("`locked_at_utc`"), "{}", stderr(&o));
    }
}

/// Class 2: logs in a subfolder were left out without a word whenever the
/// data folder's top level held any log. The audit names them, with the
/// clause that reads them.
#[test]
fn logs_in_subfolders_that_are_not_read_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let (logs, _) = lab_folder(dir.path());
    // The lab's design reads its folder's top level only once `folders
    // nested` and the split published as folders are gone (the split then
    // drawn by the recording factor), with one log moved to the top.
    let design = dir.path().join("flat.design");
    let text = std::fs::read_to_string(root().join("designs/logs/lab.design")).unwrap();
    let flat = text
        .replace("  folders nested\n", "")
        .replace("split published folders { evaluation test; fit train }\n", "")
        .replace("  require at least 18 recordings\n", "")
        .replace("factor recording { split_seed 1;", "factor recording { evaluation 3; split_seed 1;");
    assert!(!flat.contains("folders"), "{flat}");
    std::fs::write(&design, flat).unwrap();
    std::fs::rename(logs.join("train/lab-circle-take1.parquet"), logs.join("lab-circle-take1.parquet")).unwrap();
    let o = crossaudit(&["data", "audit", design.to_str().unwrap(), "--out", dir.path().join("a").to_str().unwrap()]);
    let all = said(&o);
    assert!(all.contains("flight log(s) in subfolders are not read"), "{all}");
    assert!(all.contains("declare `folders nested` in the data block"), "{all}");
}

/// Class 3: columns whose names say what they hold (`rep`, `level`) but
/// that no flag names were ignored without a word, and simsum.md then said
/// "the file has no replication ids" of a file with a `rep` column. Each
/// is named, on the console and in simsum.md, with the flag that reads it.
#[test]
fn simsum_names_the_columns_it_does_not_read() {
    let dir = tempfile::tempdir().unwrap();
    let reps = dir.path().join("reps.csv");
    let mut text = String::from("rep,method,estimate,se,level,true\n");
    for r in 1..=12 {
        for (m, e) in [("A", 0.5 + 0.01 * r as f64), ("B", 0.47 + 0.02 * r as f64)] {
            text.push_str(&format!("{r},{m},{e},0.1,0.9,0.55\n"));
        }
    }
    std::fs::write(&reps, &text).unwrap();
    let out = dir.path().join("simsum");
    let o = crossaudit(&["simsum", reps.to_str().unwrap(), "--true", "0.5", "--out", out.to_str().unwrap()]);
    assert_ok(&o);
    let md = std::fs::read_to_string(out.join("simsum.md")).unwrap();
    for (column, flag) in [("rep", "--rep rep"), ("level", "--level level"), ("true", "--true true")] {
        assert!(said(&o).contains(&format!("column `{column}` is not read")), "{}", said(&o));
        assert!(md.contains(&format!("column `{column}` is not read")) && md.contains(flag), "{md}");
    }
    // Declared, nothing is said.
    let o = crossaudit(&[
        "simsum",
        reps.to_str().unwrap(),
        "--rep",
        "rep",
        "--level",
        "level",
        "--true",
        "true",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_ok(&o);
    assert!(!said(&o).contains("is not read"), "{}", said(&o));
}

/// Class 2: a hidden file named like a log (`._x.parquet`, which macOS
/// leaves beside copied files) was read as a recording; two files of one
/// recording in a published folder split were reported as a split file's
/// error "at line 1, column 1" of a file that does not exist. The hidden
/// file is named and not read; the two files are named with both paths.
#[test]
fn hidden_logs_and_one_recording_in_two_folders_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let (logs, design) = lab_folder(dir.path());
    let take1 = logs.join("train/lab-circle-take1.parquet");
    std::fs::copy(&take1, logs.join("train/._lab-circle-take1.parquet")).unwrap();
    let o = crossaudit(&["data", "audit", design.to_str().unwrap(), "--out", dir.path().join("a").to_str().unwrap()]);
    assert_ok(&o);
    assert!(
        said(&o).contains("1 hidden file(s) named like logs or metadata (the first: train/._lab-circle-take1.parquet)"),
        "{}",
        said(&o)
    );
    let csv = std::fs::read_to_string(dir.path().join("a/recordings.csv")).unwrap();
    assert!(!csv.contains("._lab"), "{csv}");

    std::fs::copy(&take1, logs.join("test/lab-circle-take1.parquet")).unwrap();
    let o = crossaudit(&["check", design.to_str().unwrap()]);
    assert_refused(&o, "`test/lab-circle-take1.parquet` and `train/lab-circle-take1.parquet` are one recording");
    assert!(!stderr(&o).contains("line 1, column 1"), "{}", stderr(&o));
}

/// The second replay's shortest cases. An output never replaces its own
/// input: `simsum DIR/simsum.csv --out DIR` rewrote the file it read (and
/// `analyze --cells DIR/estimates.csv --out DIR` likewise).
#[test]
fn an_output_never_replaces_the_input_it_was_made_from() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let input = out.join("simsum.csv");
    let mut text = String::from("rep,method,estimate,se\n");
    for r in 1..=10 {
        text.push_str(&format!("{r},A,{},0.1\n", 0.5 + 0.01 * r as f64));
    }
    std::fs::write(&input, &text).unwrap();
    let o = crossaudit(&[
        "simsum",
        input.to_str().unwrap(),
        "--rep",
        "rep",
        "--true",
        "0.5",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_refused(&o, "it is an input of this command, which writing here would replace");
    assert_eq!(std::fs::read_to_string(&input).unwrap(), text, "the input is as it was");
}

/// A `df` column of 1e8 ran without end (statrs's inverse searching); of
/// 1e-60 it scored every interval a miss (a quantile of no width). The
/// first is the normal quantile with its Cornish-Fisher terms; the second
/// cannot be computed, so no interval is scored (undefined, counted).
#[test]
fn extreme_degrees_of_freedom_end_and_are_not_scored_as_misses() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("reps.csv");
    let out = dir.path().join("out");
    for (df, cover) in [("1e8", "1"), ("1e300", "1"), ("1e-60", "NA")] {
        let rows: Vec<String> = (1..=10).map(|r| format!("{r},A,{},0.1,{df}", 0.5 + 0.001 * r as f64)).collect();
        std::fs::write(&file, format!("rep,method,estimate,se,df\n{}\n", rows.join("\n"))).unwrap();
        let o = crossaudit(&[
            "simsum",
            file.to_str().unwrap(),
            "--rep",
            "rep",
            "--true",
            "0.5",
            "--df",
            "df",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_ok(&o);
        let csv = std::fs::read_to_string(out.join("simsum.csv")).unwrap();
        let row = csv.lines().find(|l| l.contains(",A,cover,")).unwrap();
        assert_eq!(row.split(',').nth_back(1), Some(cover), "df {df}: {row}");
    }
    // The t quantile at 1e8 df: the normal's z = 1.959963984540054 plus
    // Abramowitz and Stegun 26.7.5's first term (z^3 + z) / (4 df); the
    // next is below 1e-15.
    let z = 1.959_963_984_540_054_f64;
    let want = z + (z * z * z + z) / 4e8;
    let c = crossaudit::stats::critical_value(0.95, 1e8).unwrap();
    assert!((c - want).abs() < 1e-14, "{c} against {want}");
}

/// A value whose fourth power overflows (an estimate of 1e100) gave an MSE
/// MCSE of inf, written as a number.
#[test]
fn simsum_refuses_values_whose_fourth_power_overflows() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("reps.csv");
    let rows: Vec<String> = (1..=10).map(|r| format!("{r},A,{:e},1e99", 1e100 * (1.0 + 0.01 * r as f64))).collect();
    std::fs::write(&file, format!("rep,method,estimate,se\n{}\n", rows.join("\n"))).unwrap();
    let o = crossaudit(&[
        "simsum",
        file.to_str().unwrap(),
        "--rep",
        "rep",
        "--true",
        "0",
        "--out",
        dir.path().join("o").to_str().unwrap(),
    ]);
    assert_refused(&o, "is beyond +-1e75: its fourth power");
}

/// `check` says what it found beside the design: the files it does not
/// read (`check --data` was silent where `data audit` named them), and a
/// lock's post hoc mark ("locked/unchanged" alone hid it).
#[test]
fn check_names_unread_logs_and_a_post_hoc_mark() {
    let dir = tempfile::tempdir().unwrap();
    let (logs, design) = lab_folder(dir.path());
    std::fs::copy(logs.join("train/lab-circle-take1.parquet"), logs.join("train/._lab-circle-take1.parquet")).unwrap();
    let o = crossaudit(&["check", design.to_str().unwrap()]);
    assert_ok(&o);
    assert!(said(&o).contains("not read: 1 hidden file(s)"), "{}", said(&o));
    assert_ok(&crossaudit(&["lock", design.to_str().unwrap(), "--posthoc", "written after the pilot's results"]));
    let o = crossaudit(&["check", design.to_str().unwrap()]);
    assert!(said(&o).contains("marked POST HOC: written after the pilot's results"), "{}", said(&o));
}

/// A design's text shows what it says: a bidirectional override (U+202E)
/// in the study's name reached every report; a threshold written 1e-400
/// was read as 0 (`upper < 1e-400` decided as `upper < 0`).
#[test]
fn a_design_that_would_read_other_than_it_shows_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("designs/quickstart.design")).unwrap();
    let path = dir.path().join("q.design");
    std::fs::write(&path, text.replacen("study \"", "study \"x\u{202E}", 1)).unwrap();
    let o = crossaudit(&["check", path.to_str().unwrap()]);
    assert_refused(&o, "U+202E is a bidirectional override");
    let edited = text.replace("upper < 0", "upper < 1e-400");
    assert_ne!(edited, text);
    std::fs::write(&path, edited).unwrap();
    let o = crossaudit(&["check", path.to_str().unwrap()]);
    assert_refused(&o, "is too small for double precision: it would be read as 0");
}

/// Declarations that cannot do what they say: an action noise of 1e308
/// passed `check` (and would make every loss NaN); `patience` at or above
/// `epochs` passed without a word, though early stopping can then never
/// stop a model.
#[test]
fn training_settings_that_cannot_act_are_refused_or_named() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("designs/quickstart.design")).unwrap();
    let path = dir.path().join("q.design");
    let noisy = text.replace("action_noise 0.02", "action_noise 1e308");
    assert_ne!(noisy, text);
    std::fs::write(&path, noisy).unwrap();
    assert_refused(&crossaudit(&["check", path.to_str().unwrap()]), "action noise sd 1e308 is above 1e6");
    let patient = regex_like_replace(&text, "patience ", "patience 500");
    std::fs::write(&path, patient).unwrap();
    let o = crossaudit(&["check", path.to_str().unwrap()]);
    assert_ok(&o);
    assert!(said(&o).contains("note: patience 500 is at least the"), "{}", said(&o));
}

/// `text` with the number after the first `word` replaced by `with`.
fn regex_like_replace(text: &str, word: &str, with: &str) -> String {
    let at = text.find(word).unwrap();
    let end = at + word.len() + text[at + word.len()..].find(|c: char| !c.is_ascii_digit()).unwrap();
    format!("{}{with}{}", &text[..at], &text[end..])
}

/// A log whose recording name ends in a space was read as a recording
/// that prints as another's name; refused, naming the file.
#[test]
fn a_recording_name_with_a_trailing_space_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (logs, design) = lab_folder(dir.path());
    std::fs::rename(logs.join("train/lab-circle-take1.parquet"), logs.join("train/lab-circle-take1 .parquet")).unwrap();
    let o = crossaudit(&["check", design.to_str().unwrap()]);
    assert_refused(&o, "begins or ends with a space");
}

/// `mixed` printed every variance, estimate and SE of a response near
/// 1e-7 as 0.000000 beside a t of 21 and p < 2e-16: a nonzero value the
/// six-decimal table would show as 0 is written in scientific notation.
#[test]
fn mixed_never_prints_a_nonzero_value_as_zero() {
    let dir = tempfile::tempdir().unwrap();
    let table = dir.path().join("small.csv");
    let rows: Vec<String> = (0..60)
        .map(|i| format!("{:e},{i},g{}", 1e-7 * (1.0 + 0.01 * i as f64 + 0.3 * ((i * 7) % 5) as f64), i % 6))
        .collect();
    std::fs::write(&table, format!("y,x,g\n{}\n", rows.join("\n"))).unwrap();
    let o = crossaudit(&["mixed", table.to_str().unwrap(), "--formula", "y ~ x + (1|g)"]);
    assert_ok(&o);
    let out = crate::common::stdout(&o);
    let x = out.lines().find(|l| l.starts_with("x ")).unwrap_or_else(|| panic!("{out}"));
    let estimate = x.split_whitespace().nth(1).unwrap();
    assert!(estimate.contains('e') && estimate.parse::<f64>().unwrap() > 0.0, "{x}");
    // Zero only where the fit's value is 0 (here g's variance, a singular fit).
    let residual = out.lines().find(|l| l.trim_start().starts_with("Residual")).unwrap();
    assert!(!residual.contains("0.000000"), "{residual}");
}

/// `plan --splits` (or `--draws`) on a design without that factor planned
/// its recordings and seeds and said nothing of the option.
#[test]
fn plan_options_for_factors_the_design_lacks_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let base = [
        "plan",
        "designs/quickstart.design",
        "--components",
        "recording=1e-3,seed=1e-4,residual=2e-4",
        "--effect=-0.02",
        "--reference-mean",
        "0.3",
        "--out",
    ];
    let out = dir.path().join("plan");
    for (flag, why) in [("--splits", "has none"), ("--draws", "`factor draw`")] {
        let mut args: Vec<&str> = base.to_vec();
        args.extend([out.to_str().unwrap(), flag, "7,9"]);
        let o = crossaudit(&args);
        assert_refused(&o, why);
    }
}

/// A lock edited by hand: a hash that is not one, and an amendment dated
/// after the lock that replaced it, stood as "locked/unchanged".
#[test]
fn a_lock_with_a_malformed_hash_or_amendments_out_of_order_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let design = dir.path().join("q.design");
    std::fs::copy(root().join("designs/quickstart.design"), &design).unwrap();
    let lock_path = dir.path().join("q.design.lock");
    let committed = std::fs::read_to_string(root().join("designs/quickstart.design.lock")).unwrap();
    let mut lock: serde_json::Value = serde_json::from_str(&committed).unwrap();
    let at = lock["locked_at_utc"].as_str().unwrap().to_string();
    let sha = lock["sha256"].as_str().unwrap().to_string();
    let amendment = |previous_sha: &str, previous_at: &str| serde_json::json!([{"previous_sha256": previous_sha, "previous_locked_at_utc": previous_at, "reason": "why"}]);
    for (amendments, field, why) in [
        (amendment("zz", "2026-01-01T00:00:00Z"), "previous_sha256", "is not a SHA-256"),
        (amendment(&sha, "2099-01-01T00:00:00Z"), "previous_locked_at_utc", "lies in the future"),
        (amendment(&sha, &at), "locked_at_utc", "unused"),
    ] {
        lock["amendments"] = amendments;
        if why == "unused" {
            // Amended after the lock it replaced: in order, accepted; then
            // the lock's own time moved before the amendment's.
            std::fs::write(&lock_path, serde_json::to_string_pretty(&lock).unwrap()).unwrap();
            assert_ok(&crossaudit(&["check", design.to_str().unwrap()]));
            lock["locked_at_utc"] = serde_json::json!("2020-01-01T00:00:00Z");
            std::fs::write(&lock_path, serde_json::to_string_pretty(&lock).unwrap()).unwrap();
            let o = crossaudit(&["check", design.to_str().unwrap()]);
            assert_refused(&o, "is earlier than a lock it replaced");
            assert!(stderr(&o).contains(&format!("`{field}`")), "{}", stderr(&o));
            continue;
        }
        std::fs::write(&lock_path, serde_json::to_string_pretty(&lock).unwrap()).unwrap();
        let o = crossaudit(&["check", design.to_str().unwrap()]);
        assert_refused(&o, why);
        assert!(stderr(&o).contains(&format!("`{field}`")), "{}", stderr(&o));
    }
}

/// A parameter-free model read by secondary endpoints and an interaction
/// passed `check` without a word, while `analyze` later warned that its
/// contrasts are 0 by construction: `check` says so first.
#[test]
fn check_names_a_parameter_free_model_an_endpoint_reads() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("designs/quickstart.design")).unwrap();
    let edited = text.replace("model relative = mlp(64, 64, 64) inputs relative", "model relative = persistence");
    assert_ne!(edited, text);
    let path = dir.path().join("q.design");
    std::fs::write(&path, edited).unwrap();
    let o = crossaudit(&["check", path.to_str().unwrap()]);
    assert_ok(&o);
    assert!(said(&o).contains("note: `relative` is parameter-free"), "{}", said(&o));
}

/// Refusals that named the wrong cause: inclusion rules that keep no
/// recording were blamed on `stratify` ("every recording's trajectory is
/// unknown"); `--true 1e400` was echoed as `inf`.
#[test]
fn refusals_name_their_own_cause() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("designs/quickstart.design")).unwrap();
    let strict = text.replace(">= 200 samples", ">= 1000000 samples");
    assert_ne!(strict, text);
    assert!(strict.contains("stratify trajectory, speed"));
    let path = dir.path().join("q.design");
    std::fs::write(&path, strict).unwrap();
    let o = crossaudit(&["check", path.to_str().unwrap()]);
    assert_refused(&o, "only 0 usable deployment units remain");
    assert!(!stderr(&o).contains("stratify"), "{}", stderr(&o));

    let reps = dir.path().join("reps.csv");
    std::fs::write(&reps, "rep,method,estimate,se\n1,A,0.5,0.1\n2,A,0.4,0.1\n").unwrap();
    let out = dir.path().join("o");
    let o = crossaudit(&[
        "simsum",
        reps.to_str().unwrap(),
        "--rep",
        "rep",
        "--true",
        "1e400",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_refused(&o, "--true 1e400 is not a finite number");
    // A target MCSE no simulation could reach gave NA without a word, under
    // a column named by a 300-digit decimal.
    let o = crossaudit(&[
        "simsum",
        reps.to_str().unwrap(),
        "--rep",
        "rep",
        "--true",
        "0.5",
        "--target-mcse",
        "cover=1e-300",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_refused(&o, "a target below 1e-12 needs more replications than any simulation runs");
}

/// A declaration that could change nothing: `missing csv allow` under
/// `data simulated` (the simulator writes every log it lists) passed
/// `check` without a word.
#[test]
fn missing_csv_allow_on_simulated_data_is_refused_at_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("designs/quickstart.design")).unwrap();
    let edited = text.replacen("data simulated {", "data simulated {\n  missing csv allow", 1);
    assert_ne!(edited, text);
    let path = dir.path().join("q.design");
    std::fs::write(&path, edited).unwrap();
    let o = crossaudit(&["check", path.to_str().unwrap()]);
    assert_refused(&o, "declaration that cannot apply");
    assert!(stderr(&o).contains("q.design:40:3"), "{}", stderr(&o));
}
