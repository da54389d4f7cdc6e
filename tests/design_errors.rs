//! Every semantic and syntax error a design can have gets a located, plain
//! text message; each case is a file under tests/designs/errors/ and its
//! exact message is a snapshot.

use std::collections::BTreeSet;

use crate::common::root;
use crate::snapshots;

fn render(path: &std::path::Path) -> (String, crossaudit::design::DesignError) {
    let src = std::fs::read_to_string(path).unwrap();
    let name = format!("errors/{}", path.file_name().unwrap().to_string_lossy());
    let err = crossaudit::design::from_str(&name, &src).expect_err("an error case must not validate");
    (err.render(false), err)
}

#[test]
fn every_error_case_is_rejected_with_a_located_message() {
    snapshots!({
        insta::glob!("designs/errors/*.design", |path| {
            let (text, err) = render(path);
            let name = format!("errors/{}", path.file_name().unwrap().to_string_lossy());
            // file:line:column header, the source line and a caret.
            assert!(text.contains(&format!("--> {name}:")), "no file:line:col in\n{text}");
            assert!(text.contains('^'), "no caret in\n{text}");
            assert!(!text.contains('\u{1b}'), "plain text must carry no ANSI escapes");
            assert!(!err.diagnostics.is_empty());
            insta::assert_snapshot!(text);
        });
    });
}

#[test]
fn error_cases_cover_at_least_fifteen_distinct_problems() {
    let mut titles = BTreeSet::new();
    for entry in std::fs::read_dir(root().join("tests/designs/errors")).unwrap() {
        let (_, err) = render(&entry.unwrap().path());
        titles.insert(err.diagnostics[0].title.clone());
    }
    assert!(titles.len() >= 15, "only {} distinct errors: {titles:?}", titles.len());
}

#[test]
fn the_base_of_the_error_cases_is_valid() {
    let d = crate::common::minimal_design();
    assert_eq!(d.seeds.len(), 3);
    assert_eq!(d.recording.evaluation, 4);
}

#[test]
fn colour_is_only_added_when_asked() {
    let (_, err) = render(&root().join("tests/designs/errors/unknown_arm_in_contrast.design"));
    assert!(err.render(true).contains('\u{1b}'));
    assert!(!err.render(false).contains('\u{1b}'));
}

#[test]
fn all_problems_are_reported_not_only_the_first() {
    let src = std::fs::read_to_string(crate::common::minimal_design_path()).unwrap();
    let src = src
        .replace("contrast contaminated - disjoint", "contrast contaminated - nope")
        .replace("replace 25%", "replace 0%");
    let err = crossaudit::design::from_str("two.design", &src).unwrap_err();
    let titles: Vec<&str> = err.diagnostics.iter().map(|d| d.title.as_str()).collect();
    assert!(titles.contains(&"unknown arm") && titles.contains(&"percentage out of range"), "{titles:?}");
}

#[test]
fn inputs_found_by_fuzzing_do_not_panic() {
    // Regression corpus for the parser fuzz target (fuzz/): each must give
    // a diagnostic, not a panic.
    for src in [
        "",
        "study",
        "factor seed = 99999999999999999999..1",
        "data x {",
        "decide x when a >= 1e999",
        "\u{0}",
        // fuzz/artifacts crash-8be4e0ee: a 44-billion-seed range ran out of memory.
        "#\nfactor seed = 1..44444444444# A 1m\u{0}k 5 motns tor4444444444444444444444444\u{4}44444440\n",
    ] {
        let _ = crossaudit::design::from_str("fuzz.design", src).map(|_| ()).map_err(|e| e.render(false));
    }
    let big = "factor seed = 1..44444444444";
    let e = crossaudit::design::from_str("big.design", big).unwrap_err();
    assert!(e.diagnostics.iter().any(|d| d.title == "seed range too large"), "{}", e.render(false));
}

/// A raw control character in a design (ESC, which a terminal obeys) is
/// quoted in the error as its visible picture, never sent: the snippet of
/// `check` holds no ESC byte, colour on or off, and keeps its columns.
#[test]
fn control_characters_in_a_design_are_shown_not_sent() {
    let src = std::fs::read_to_string(crate::common::minimal_design_path()).unwrap();
    let src = format!("{src}\nbogus \u{1b}[2J\u{7}clause\n");
    let err = crossaudit::design::from_str("esc.design", &src).expect_err("a syntax error");
    for color in [false, true] {
        let text = err.render(color);
        let quoted = text.lines().find(|l| l.contains("bogus")).expect("the quoted line");
        // Colour adds crossaudit's own escapes; the design's ESC and BEL
        // never reach the terminal.
        assert!(!quoted.contains("\u{1b}[2J") && !quoted.contains('\u{7}'), "{quoted:?}");
        assert!(quoted.contains("bogus \u{241b}[2J\u{2407}clause"), "{quoted:?}");
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("esc.design");
    std::fs::write(&path, &src).unwrap();
    let o = crate::common::crossaudit(&["check", path.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!o.stderr.contains(&0x1b), "{}", String::from_utf8_lossy(&o.stderr));
}

/// A keyword one or two letters off (`relativ`, `cosin`) is named with
/// the one meant, after what was expected; a word far from every keyword
/// gets no guess.
#[test]
fn a_misspelt_keyword_is_told_the_one_meant() {
    let src = std::fs::read_to_string(root().join("designs/quickstart.design")).unwrap();
    for (from, to, meant) in [
        ("inputs relative", "inputs relativ", "did you mean `relative`?"),
        ("epochs 30 cosine", "epochs 30 cosin", "did you mean `cosine`?"),
    ] {
        let text = src.replace(from, to);
        let e = crossaudit::design::from_str("q.design", &text).unwrap_err().render(false);
        assert!(e.contains(meant), "{to}: {e}");
    }
    let e = crossaudit::design::from_str("q.design", &src.replace("inputs relative", "inputs zzzzzz"))
        .unwrap_err()
        .render(false);
    assert!(!e.contains("did you mean"), "{e}");
}

/// A character that is not ASCII where the language reads only ASCII (a
/// zero-width space inside a model's name, a no-break space after
/// `factor`, a Cyrillic `о` in an arm's name) was reported at column 1
/// under a valid keyword; now at the character itself, by code point. A
/// non-ASCII character in a comment or a quoted string is no error, and a
/// syntax error elsewhere on a line holding one keeps its own message.
#[test]
fn a_character_that_is_not_ascii_is_named_where_it_stands() {
    let src = std::fs::read_to_string(root().join("designs/quickstart.design")).unwrap();
    let line_of = |needle: &str| src.lines().position(|l| l.contains(needle)).unwrap() + 1;
    for (from, to, col, shown) in [
        ("model world    =", "model wo\u{200B}rld    =", 9, "U+200B ZERO WIDTH SPACE"),
        ("factor seed", "factor\u{00A0}seed", 7, "U+00A0 NO-BREAK SPACE"),
        ("arm disjoint", "arm disj\u{043E}int", 9, "`\u{043E}` (U+043E)"),
    ] {
        assert!(src.contains(from), "{from}");
        let text = src.replacen(from, to, 1);
        let e = crossaudit::design::from_str("q.design", &text).unwrap_err().render(false);
        let at = format!("--> q.design:{}:{col}", line_of(from));
        assert!(e.contains(&at) && e.contains(shown) && e.contains("only ASCII"), "{to}: wanted {at}, {shown}:\n{e}");
    }
    let fine = format!("# r\u{00E9}sum\u{00E9}: no-break\u{00A0}space\n{src}");
    assert!(crossaudit::design::from_str("q.design", &fine).is_ok());
    let other = format!("# caf\u{00E9}\n{}", src.replacen("epochs 30 cosine", "epochs 30 cosin", 1));
    let e = crossaudit::design::from_str("q.design", &other).unwrap_err().render(false);
    assert!(e.contains("did you mean `cosine`?") && !e.contains("only ASCII"), "{e}");
}

/// A decision's threshold is shown as a design writes it, however large
/// (it was printed as 301 digits); optimism, at most 100% of errors that
/// are never negative, may be asked to reach 100% (every treated error 0)
/// but no more (tests/designs/errors/optimism_above_100_percent.design).
#[test]
fn decision_thresholds_are_shown_as_written_and_optimism_stops_at_100_percent() {
    let src = std::fs::read_to_string(crate::common::minimal_design_path()).unwrap();
    let rule = "decide confirmed when optimism >= 10% and upper < 0";
    assert!(src.contains(rule));
    let with = |r: &str| crossaudit::design::from_str("t", &src.replace(rule, r));
    let d = with("decide confirmed when optimism >= 1e-9% and upper < -1e300").unwrap();
    assert_eq!(d.decision.to_string(), "confirmed when optimism >= 1e-9% and upper < -1e300");
    let d = with("decide confirmed when optimism >= 100% and upper < -0.025").unwrap();
    assert_eq!(d.decision.to_string(), "confirmed when optimism >= 100% and upper < -0.025");
    for never in ["optimism > 100%", "optimism >= 100.5%", "optimism >= 1e300%"] {
        let e = with(&format!("decide confirmed when {never} and upper < 0")).expect_err(never);
        assert_eq!(e.diagnostics[0].title, "a condition that can never hold", "{never}");
    }
}
