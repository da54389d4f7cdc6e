//! The whole crate as a Rust user uses it in their own tests
//! (docs/library.md, "From the whole crate"): a design parsed and compiled
//! to inspect its plan, and a reanalysis of per-cell data locked by an
//! insta snapshot, so that any change to a number it reports fails the
//! test and shows the difference.

use std::path::Path;

/// The paper's confirmatory design compiles to the plan its text declares.
#[test]
fn a_design_parsed_and_compiled_shows_its_plan() {
    let file = crossaudit::design::load(Path::new("designs/nanobench_confirmatory.design")).unwrap();
    let plan = crossaudit::compile(&file.design);
    // 2 models x 2 arms x 20 seeds, as `crossaudit check` prints.
    assert_eq!(plan.jobs.len(), 80);
    assert_eq!(plan.models.len(), 2);
    assert_eq!(plan.study, "nanobench-contamination-confirmatory");
}

/// A snapshot-tested reanalysis: the decision line and the primary unit's
/// estimate of the committed example cells, as text a reviewer reads.
#[test]
fn a_reanalysis_is_locked_by_a_snapshot() {
    let file = crossaudit::design::load(Path::new("designs/nanobench_confirmatory.design")).unwrap();
    let a = crossaudit::analyze_study(&file, Path::new("examples/cells/nanobench_synthetic.csv"), Default::default())
        .unwrap();
    let crossaudit::run::StudyAnalysis::Single(single) = &a else { panic!("a single study") };
    let u = &single.units[0];
    let text = format!(
        "{}\nprimary: d = {:.6} (SE {:.6}, df {}), 95% CI [{:.6}, {:.6}]",
        a.decision_line(),
        u.estimate.mean,
        u.estimate.se,
        u.estimate.df,
        u.estimate.lower,
        u.estimate.upper
    );
    crate::snapshots!({
        insta::assert_snapshot!(text);
    });
}
