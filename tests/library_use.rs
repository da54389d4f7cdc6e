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
    let study = crossaudit::compile_study(&file.design);
    assert!(study.levels().is_empty(), "one run: no outer levels");
    let plan = &study.plan;
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
    let study = crossaudit::compile_study(&file.design);
    let cells = Path::new("examples/cells/nanobench_synthetic.csv");
    let a = crossaudit::analyze_study(&file, &study, cells, Default::default()).unwrap();
    let crossaudit::analysis::StudyAnalysis::Single(single) = &a else { panic!("a single study") };
    let u = &single.units[0];
    let text = format!(
        "{}\nprimary: d = {:.6} (SE {:.6}, df {}), 95% CI [{:.6}, {:.6}]",
        crossaudit::report::study_decision_line(&a),
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

/// A study with outer factors compiles once into every level's plan: the
/// paper's multiverse with per-seed draws (3 binary choices, 20 seeds) is
/// 8 specifications x 20 seed levels, each level holding its seed alone,
/// and 8 analysis units, each a specification's 20 seeds together.
#[test]
fn a_study_plan_holds_every_level_compiled_once() {
    let file = crossaudit::design::load(Path::new("designs/multiverse/paper_multiverse_per_seed.design")).unwrap();
    let study = crossaudit::compile_study(&file.design);
    assert_eq!(study.role(), Some(crossaudit::plan::study::LevelRole::Specification));
    assert!(study.combines_levels());
    let levels = study.levels();
    assert_eq!(levels.len(), 8 * 20);
    for level in levels {
        assert_eq!(level.plan.seeds.len(), 1, "{}: one seed per level", level.id);
        assert!(level.id.starts_with("spec-") && level.id.contains("/draw-"), "{}", level.id);
        assert!(level.plan.jobs.iter().all(|j| j.seed == level.plan.seeds[0]));
    }
    let units = &study.outer.as_ref().unwrap().units;
    assert_eq!(units.len(), 8);
    for u in units {
        assert_eq!(u.members.len(), 20, "{}", u.id);
        assert_eq!(u.plan.seeds.len(), 20, "{}: the specification's seeds analysed together", u.id);
    }
    // The jobs it trains: those of every level that does not share an
    // earlier level's run.
    let shared = levels.iter().filter(|l| l.shares.is_some()).count();
    assert_eq!(study.job_count(), (levels.len() - shared) * levels[0].plan.jobs.len());
}
