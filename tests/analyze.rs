//! `analyze` on per-cell data: snapshot-locked outputs of the committed
//! example, and a clear error for every kind of bad per-cell input.

use std::fmt::Write as _;

use crate::common::{
    confirmatory_design, example_cells, minimal_cells, minimal_design, minimal_design_path, write_temp_cells,
};
use crate::snapshots;
use crossaudit::analysis::{analyze, Analysis, AnalysisError};
use crossaudit::cells::{read_cells, read_cells_from, Cell, CellsError, Origin};
use crossaudit::stats::CrossedEstimate;

fn est(e: &CrossedEstimate) -> String {
    format!(
        "mean {:.6} se {:.6} df {:.1} ci [{:.6}, {:.6}] s2 rec {:.6e} seed {:.6e} res {:.6e} shares {:.4}/{:.4}/{:.4}",
        e.mean,
        e.se,
        e.df,
        e.lower,
        e.upper,
        e.components.recording,
        e.components.seed,
        e.components.residual,
        e.share_recording,
        e.share_seed,
        e.share_residual
    )
}

fn example() -> Analysis {
    crossaudit::analyze_files(&confirmatory_design(), &example_cells(), Default::default()).unwrap()
}

#[test]
fn primary_output_of_the_example_is_locked() {
    let a = example();
    let u = &a.units[0];
    let mut s = String::new();
    let _ = writeln!(s, "{}", crossaudit::report::decision_summary(&a.decision));
    let _ = writeln!(s, "unit: {} {} at {} s ({:?})", u.model, u.metric.name(), u.horizon_s, u.role);
    let _ = writeln!(
        s,
        "means: contaminated {:.6} disjoint {:.6} optimism {:.4}%",
        u.mean_treated, u.mean_reference, u.optimism_pct
    );
    let _ = writeln!(s, "crossed: {}", est(&u.estimate));
    let b = u.bootstrap.unwrap();
    let _ = writeln!(
        s,
        "bootstrap: B {} seed {} stream {} se {:.6} ci [{:.6}, {:.6}]",
        b.replicates, b.seed, b.stream, b.se, b.lower, b.upper
    );
    for l in &u.leave_one_out {
        let _ = writeln!(
            s,
            "leave one {:?} out: mean [{:.6}, {:.6}] upper [{:.6}, {:.6}] optimism [{:.3}, {:.3}] holds {}/{}",
            l.factor,
            l.mean_min,
            l.mean_max,
            l.upper_min,
            l.upper_max,
            l.optimism_min,
            l.optimism_max,
            l.rule_holds,
            l.fits
        );
    }
    for t in &u.per_trajectory {
        let _ =
            writeln!(s, "trajectory {}: {} recordings, mean d {:.6}", t.trajectory, t.recordings, t.mean_difference);
    }
    let c = &u.conditional;
    let _ = writeln!(
        s,
        "divergent: contaminated {}/{} disjoint {}/{}",
        c.divergent_treated, c.starts_treated, c.divergent_reference, c.starts_reference
    );
    snapshots!({ insta::assert_snapshot!(s) });
}

#[test]
fn interaction_output_of_the_example_is_locked() {
    let a = example();
    let mut s = String::new();
    for ix in &a.interactions {
        let b = ix.bootstrap.unwrap();
        let _ =
            writeln!(s, "{} - {} {} at {} s: {}", ix.left, ix.right, ix.metric.name(), ix.horizon_s, est(&ix.estimate));
        let _ = writeln!(s, "  bootstrap ci [{:.6}, {:.6}]", b.lower, b.upper);
    }
    snapshots!({ insta::assert_snapshot!(s) });
}

#[test]
fn grouped_sensitivity_output_of_the_example_is_locked() {
    let a = example();
    let mut s = String::new();
    for u in &a.units {
        let g = u.grouped.as_ref().unwrap();
        let _ = writeln!(s, "{} at {} s: {} groups: {}", u.model, u.horizon_s, g.groups.len(), est(&g.estimate));
    }
    let g = a.units[0].grouped.as_ref().unwrap();
    for (name, n) in g.groups.iter().zip(&g.recordings_per_group) {
        let _ = writeln!(s, "  group {name}: {n} recordings");
    }
    snapshots!({ insta::assert_snapshot!(s) });
}

#[test]
fn compare_intervals_lists_every_estimator() {
    let a = crossaudit::analyze_files(
        &confirmatory_design(),
        &example_cells(),
        crossaudit::AnalyzeOptions { compare_intervals: true },
    )
    .unwrap();
    let iv = a.units[0].intervals.as_ref().unwrap();
    // Nine of the analysis, then the coverage study's nine further ones.
    assert_eq!(iv.len(), 18);
    // The further intervals on the same array, computed directly.
    let e = &a.units[0].estimate;
    for x in &iv[9..] {
        assert!((x.estimate - e.mean).abs() < 1e-12, "{:?}", x.method);
        assert!(x.lower < x.estimate && x.estimate < x.upper, "{:?}", x.method);
    }
    // The MoM t(J-1) row is the primary estimate itself.
    assert_eq!(iv[0].lower, a.units[0].estimate.lower);
    assert_eq!(iv[0].upper, a.units[0].estimate.upper);
    // The REML rows: the seed component is truncated at zero here (MS seed <
    // MS residual), so REML re-pools it and its SE differs from the MoM's;
    // Kenward-Roger's SE is never below the model-based one (here, with the
    // seed component at zero, its adjustment is zero up to rounding: 1e-12).
    use crossaudit::stats::IntervalMethod::*;
    let row = |m| iv.iter().find(|e| e.method == m).unwrap();
    assert!(row(RemlKenwardRoger).se >= row(RemlSatterthwaite).se * (1.0 - 1e-12));
    assert!(row(RemlKenwardRoger).df.is_finite() && row(RemlSatterthwaite).df.is_finite());
}

#[test]
fn analysis_is_deterministic() {
    let a = crossaudit::report::render_json(&example());
    let b = crossaudit::report::render_json(&example());
    assert_eq!(a, b);
}

#[test]
fn hand_built_cells_give_the_hand_computed_mean() {
    // minimal_cells: d_ij = -0.06 + 0.005 * ((3i + 7j) mod 5) for every
    // model and horizon, so mean d = -0.06 + 0.005 * mean((3i+7j) mod 5)
    // over i < 4, j < 3: residues (j = 0) 0,3,1,4 | (j = 1) 2,0,3,1 |
    // (j = 2) 4,2,0,3 sum to 23.
    let d = minimal_design();
    let a = analyze(&crossaudit::compile(&d), &minimal_cells(&d), Default::default()).unwrap();
    let expected = -0.06 + 0.005 * 23.0 / 12.0;
    assert!((a.units[0].estimate.mean - expected).abs() < 1e-12, "{}", a.units[0].estimate.mean);
}

/// Issue 72: the recordings whose leaving-out moves the verdict are named
/// beside it. Here every recording but R1 shows the treated arm 0.06 m
/// better; R1 shows it 0.2 m worse. Over all four the rule fails (mean d
/// is +0.005 m); leaving out R1 (and no other recording, and no seed)
/// makes it hold, and the guard says so by name.
#[test]
fn the_recording_whose_leaving_out_moves_the_verdict_is_named() {
    let d = minimal_design();
    let mut cells = minimal_cells(&d);
    let primary = |c: &Cell| c.model == "world" && c.horizon_s == 1.0;
    let reference: std::collections::BTreeMap<(u64, String), f64> = cells
        .iter()
        .filter(|c| primary(c) && c.arm == "disjoint")
        .map(|c| ((c.seed, c.recording.to_string()), c.fa_position_rmse_m))
        .collect();
    for c in cells.iter_mut().filter(|c| primary(c) && c.arm == "contaminated") {
        let r1 = c.recording.as_str() == "R1_circle_fast_rep1";
        // A little seed-to-seed noise, so that no variance is exactly zero.
        let shift = if r1 { 0.2 } else { -0.06 - 0.001 * ((c.seed * 7) % 3) as f64 };
        c.fa_position_rmse_m = reference[&(c.seed, c.recording.to_string())] + shift;
        c.conditional_position_rmse_m = Some(c.fa_position_rmse_m);
    }
    let a = analyze(&crossaudit::compile(&d), &cells, Default::default()).unwrap();
    assert!(!a.decision.holds);
    let u = &a.units[0];
    let by = |f: crossaudit::design::Factor| u.leave_one_out.iter().find(|l| l.factor == f).unwrap();
    assert_eq!(by(crossaudit::design::Factor::Recording).moves_verdict, vec!["R1_circle_fast_rep1".to_string()]);
    assert!(by(crossaudit::design::Factor::Seed).moves_verdict.is_empty());
    let fragile: Vec<_> = a.guards.iter().filter(|g| g.kind == crossaudit::analysis::GuardKind::Fragile).collect();
    assert_eq!(fragile.len(), 1, "{:?}", a.guards);
    assert!(fragile[0].text.contains("holds in 1 of the 4 fits that leave out one recording"), "{}", fragile[0].text);
    assert!(fragile[0].text.contains("when recording R1_circle_fast_rep1 is left out"), "{}", fragile[0].text);
}

fn err_of(cells: &[Cell]) -> String {
    let d = minimal_design();
    match analyze(&crossaudit::compile(&d), cells, Default::default()) {
        Ok(_) => panic!("bad cells were accepted"),
        Err(e) => e.to_string(),
    }
}

fn lined(mut cells: Vec<Cell>) -> Vec<Cell> {
    for (k, c) in cells.iter_mut().enumerate() {
        c.origin = Origin::line(k as u64 + 2);
    }
    cells
}

#[test]
fn a_missing_cell_is_named() {
    let d = minimal_design();
    let mut cells = lined(minimal_cells(&d));
    let gone = cells.remove(5);
    let e = err_of(&cells);
    assert!(e.contains("1 missing cell"), "{e}");
    assert!(
        e.contains(&format!(
            "model={} arm={} seed={} recording={} horizon={} s",
            gone.model, gone.arm, gone.seed, gone.recording, gone.horizon_s
        )),
        "{e}"
    );
}

#[test]
fn a_duplicate_cell_names_both_lines() {
    let d = minimal_design();
    let mut cells = lined(minimal_cells(&d));
    let mut dup = cells[3].clone();
    dup.origin = Origin::line(999);
    cells.push(dup);
    let e = err_of(&cells);
    assert!(e.contains("line 999: duplicate cell") && e.contains("first seen on line 5"), "{e}");
}

#[test]
fn models_arms_seeds_and_horizons_outside_the_design_are_rejected() {
    let d = minimal_design();
    for (field, edit) in [
        ("model", Box::new(|c: &mut Cell| c.model = "transformer".into()) as Box<dyn Fn(&mut Cell)>),
        ("arm", Box::new(|c: &mut Cell| c.arm = "leaky".into())),
        ("seed", Box::new(|c: &mut Cell| c.seed = 77)),
        ("horizon_s", Box::new(|c: &mut Cell| c.horizon_s = 3.0)),
    ] {
        let mut cells = lined(minimal_cells(&d));
        edit(&mut cells[7]);
        let e = err_of(&cells);
        assert!(
            e.starts_with(&format!("line 9, field `{field}`")) && e.contains("is not in the design"),
            "{field}: {e}"
        );
    }
}

/// Cells built in memory skip the reader's checks: a metric that is NaN
/// or infinite is refused by line and field, never read as a missing cell
/// (the analysis's grids mark a missing cell with NaN).
#[test]
fn a_non_finite_metric_built_in_memory_is_refused_by_line_and_field() {
    let d = minimal_design();
    for (field, edit) in [
        ("fa_position_rmse_m", Box::new(|c: &mut Cell| c.fa_position_rmse_m = f64::NAN) as Box<dyn Fn(&mut Cell)>),
        ("conditional_position_rmse_m", Box::new(|c: &mut Cell| c.conditional_position_rmse_m = Some(f64::NAN))),
        ("divergence_rate", Box::new(|c: &mut Cell| c.divergence_rate = f64::INFINITY)),
        ("velocity_rmse_mps", Box::new(|c: &mut Cell| c.velocity_rmse_mps = Some(f64::NEG_INFINITY))),
    ] {
        let mut cells = lined(minimal_cells(&d));
        edit(&mut cells[4]);
        let e = err_of(&cells);
        assert!(
            e.starts_with(&format!("line 6, field `{field}`")) && e.contains("a metric is a finite number"),
            "{field}: {e}"
        );
    }
}

/// The analysis checks every row in one parallel pass, and its errors keep
/// their order: a `split` column the design lacks is named even where an
/// earlier row has a refused value, and of two refused values the first.
#[test]
fn the_rows_checks_name_what_the_checks_in_order_name() {
    let d = minimal_design();
    let mut cells = lined(minimal_cells(&d));
    cells[2].fa_position_rmse_m = 99.0;
    cells[6].split = Some(42);
    let e = err_of(&cells);
    assert!(e.contains("line 8: the file has a `split` column, but the design has no split factor"), "{e}");
    cells[6].split = None;
    cells[9].fa_position_rmse_m = 99.0;
    let e = err_of(&cells);
    assert!(e.starts_with("line 4, field `fa_position_rmse_m`") && e.contains("divergence cap"), "{e}");
}

#[test]
fn a_zero_reference_mean_is_an_error_not_an_infinite_optimism() {
    let d = minimal_design();
    let mut cells = lined(minimal_cells(&d));
    for c in cells.iter_mut().filter(|c| c.arm == "disjoint" && c.model == "world" && c.horizon_s == 1.0) {
        // Zero error everywhere (consistent: FA = conditional when nothing diverged).
        c.fa_position_rmse_m = 0.0;
        c.conditional_position_rmse_m = Some(0.0);
    }
    let e = err_of(&cells);
    assert!(e.contains("disjoint arm's mean is zero"), "{e}");
}

#[test]
fn too_few_recordings_for_the_design_is_an_error() {
    let d = minimal_design();
    let cells: Vec<Cell> = lined(minimal_cells(&d)).into_iter().filter(|c| c.recording.starts_with("R1")).collect();
    let e = err_of(&cells);
    assert!(e.contains("1 recording(s); the design declares `evaluation 4`"), "{e}");
}

/// A recording beyond the declared number (a name misspelt in one row,
/// here 5,000 characters long) is named, cut short, with its first line.
#[test]
fn too_many_recordings_names_the_one_in_the_fewest_rows() {
    let d = minimal_design();
    let mut cells = lined(minimal_cells(&d));
    let long = "y".repeat(5000);
    cells[10].recording = long.as_str().into();
    let e = err_of(&cells);
    let want = format!("5 recording(s); the design declares `evaluation 4`; the one in the fewest rows is `{}`... (5000 characters): 1 row(s), first at line 12", &long[..60]);
    assert!(e.contains(&want), "{e}");
}

#[test]
fn inconsistent_condition_labels_are_an_error() {
    let d = minimal_design();
    let mut cells = lined(minimal_cells(&d));
    cells[10].trajectory = "oval".into();
    let e = err_of(&cells);
    assert!(e.contains("line 12, field `trajectory`") && e.contains("oval"), "{e}");
}

#[test]
fn grouped_sensitivity_with_one_group_is_skipped_with_a_warning() {
    let d = minimal_design();
    let mut cells = minimal_cells(&d);
    for c in cells.iter_mut() {
        c.trajectory = "circle".into();
    }
    let a = analyze(&crossaudit::compile(&d), &cells, Default::default()).unwrap();
    assert!(a.units.iter().all(|u| u.grouped.is_none()));
    assert!(a.warnings.iter().any(|w| w.contains("grouped sensitivity skipped")), "{:?}", a.warnings);
}

fn csv_err(body: &str) -> String {
    let header = crossaudit::cells::HEADER.join(",");
    match read_cells_from("cells.csv", format!("{header}\n{body}").as_bytes()) {
        Ok(_) => panic!("bad row accepted: {body}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_rows_name_the_line_and_field() {
    let good = "world,disjoint,1,R1,circle,fast,1,5,0,0.3,0.3,0,0.1,2";
    assert!(read_cells_from("cells.csv", format!("{}\n{good}", crossaudit::cells::HEADER.join(",")).as_bytes()).is_ok());
    for (row, field, problem) in [
        ("world,disjoint,one,R1,circle,fast,1,5,0,0.3,0.3,0,0.1,2", "seed", "not a non-negative integer"),
        ("world,disjoint,1,R1,circle,fast,1,5,0,abc,0.3,0,0.1,2", "fa_position_rmse_m", "not a number"),
        ("world,disjoint,1,R1,circle,fast,1,5,0,NaN,0.3,0,0.1,2", "fa_position_rmse_m", "not finite"),
        ("world,disjoint,1,R1,circle,fast,1,5,0,inf,0.3,0,0.1,2", "fa_position_rmse_m", "not finite"),
        (
            "world,disjoint,1,R1,circle,fast,1,5,0,0.3,,0,0.1,2",
            "conditional_position_rmse_m",
            "not every start diverged",
        ),
        ("world,disjoint,1,R1,circle,fast,1,5,6,0.3,0.3,1.2,0.1,2", "n_divergent", "exceeds n_starts"),
        ("world,disjoint,1,R1,circle,fast,1,5,1,0.3,0.3,0.5,0.1,2", "divergence_rate", "disagrees"),
        ("world,disjoint,1,R1,circle,fast,0,5,0,0.3,0.3,0,0.1,2", "horizon_s", "must be > 0"),
        (",disjoint,1,R1,circle,fast,1,5,0,0.3,0.3,0,0.1,2", "model", "is empty"),
    ] {
        let e = csv_err(&format!("{good}\n{row}"));
        assert!(e.starts_with(&format!("cells.csv: line 3, field `{field}`")) && e.contains(problem), "{row}: {e}");
    }
    let e = csv_err(&format!("{good}\nworld,disjoint,1"));
    assert!(e.contains("line 3") && e.contains("3 fields, the header has 14"), "{e}");
}

#[test]
fn all_diverged_cells_may_leave_finite_only_metrics_empty() {
    let header = crossaudit::cells::HEADER.join(",");
    let row = "world,disjoint,1,R1,circle,fast,1,5,5,2,,1,,";
    let cells = read_cells_from("cells.csv", format!("{header}\n{row}").as_bytes()).unwrap();
    assert_eq!(cells[0].conditional_position_rmse_m, None);
}

#[test]
fn a_wrong_header_is_reported() {
    let e = read_cells_from("cells.csv", "model,arm\nworld,disjoint\n".as_bytes()).unwrap_err();
    assert!(matches!(e, CellsError::Header { .. }));
    assert!(e.to_string().contains("line 1: wrong header"));
}

#[test]
fn cells_round_trip_through_csv() {
    let d = minimal_design();
    let dir = tempfile::tempdir().unwrap();
    let cells = minimal_cells(&d);
    let p = write_temp_cells(dir.path(), &cells);
    let back = read_cells(&p).unwrap();
    assert_eq!(back.len(), cells.len());
    for (a, b) in back.iter().zip(&cells) {
        assert_eq!((a.fa_position_rmse_m, &a.recording, a.seed), (b.fa_position_rmse_m, &b.recording, b.seed));
    }
    let _ = minimal_design_path();
    let _: Option<AnalysisError> = None;
}

/// The analysis of a committed real run's cells.csv, locked: primary,
/// interaction and grouped-sensitivity outputs.
fn locked_real_run(design: &str, cells: &str) -> String {
    let root = crate::common::root();
    let a = crossaudit::analyze_files(&root.join(design), &root.join(cells), Default::default()).unwrap();
    let mut s = String::new();
    let _ = writeln!(s, "{}", crossaudit::report::decision_summary(&a.decision));
    for u in &a.units {
        let _ = writeln!(
            s,
            "{} {} at {} s: contaminated {:.6} disjoint {:.6} optimism {:.3}%",
            u.model,
            u.metric.name(),
            u.horizon_s,
            u.mean_treated,
            u.mean_reference,
            u.optimism_pct
        );
        let _ = writeln!(s, "  crossed: {}", est(&u.estimate));
        if let Some(b) = u.bootstrap {
            let _ = writeln!(s, "  bootstrap ci [{:.6}, {:.6}]", b.lower, b.upper);
        }
        if let Some(g) = &u.grouped {
            let _ = writeln!(s, "  grouped ({} groups): {}", g.groups.len(), est(&g.estimate));
        }
    }
    for ix in &a.interactions {
        let _ = writeln!(s, "interaction {} - {} at {} s: {}", ix.left, ix.right, ix.horizon_s, est(&ix.estimate));
    }
    s
}

#[test]
fn the_committed_confirmatory_run_analysis_is_locked() {
    let s = locked_real_run("designs/nanobench_confirmatory.design", "results/nanobench_confirmatory/cells.csv");
    snapshots!({ insta::assert_snapshot!(s) });
}

#[test]
fn the_committed_audited_run_analysis_is_locked() {
    let s = locked_real_run("designs/nanobench_audited.design", "results/nanobench_audited/cells.csv");
    snapshots!({ insta::assert_snapshot!(s) });
}

/// Issue 30: a single-contrast report never said when its REML fit was
/// singular. The minimal design's hand-built cells, analysed by REML with
/// Satterthwaite df: d_ij = -0.06 + 0.005 ((3i + 7j) mod 5) has no
/// recording or seed main effect to speak of, so the fits are singular;
/// the report's header names each singular unit and says why its
/// Satterthwaite and Kenward-Roger df differ.
#[test]
fn a_singular_reml_fit_is_named_in_the_report() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(minimal_design_path()).unwrap();
    let design = dir.path().join("reml.design");
    std::fs::write(
        &design,
        // Both models have the same cells, so their interaction is zero
        // everywhere: it is left out.
        text.replace("estimate crossed_mom level 0.95 df seed - 1", "estimate reml level 0.95 df satterthwaite")
            .replace("interaction world - relative\n", ""),
    )
    .unwrap();
    let cells = write_temp_cells(dir.path(), &minimal_cells(&minimal_design()));
    let a = crossaudit::analyze_files(&design, &cells, Default::default()).unwrap();
    let singular: Vec<_> = a.units.iter().filter(|u| u.estimate.reml.unwrap().singular).collect();
    assert!(!singular.is_empty(), "the hand-built cells give singular fits");
    let report = crossaudit::report::render_markdown(&a);
    assert!(report.contains("Singular REML fit"), "{report}");
    for u in singular {
        assert!(report.contains(&format!("{} {} at {} s", u.model, u.metric.name(), u.horizon_s)), "{report}");
    }
}

/// `--compare-intervals` on an array with no recording or seed effect
/// (the hand-built cells): the two-way cluster-robust variance V_row +
/// V_col - V_cell is then not positive, so that interval is undefined,
/// and the report names it and why rather than printing NaN.
#[test]
fn an_interval_undefined_on_the_array_is_named_with_its_reason() {
    let d = minimal_design();
    let a =
        analyze(&crossaudit::compile(&d), &minimal_cells(&d), crossaudit::AnalyzeOptions { compare_intervals: true })
            .unwrap();
    let iv = a.units[0].intervals.as_ref().unwrap();
    let cgm = iv.iter().find(|e| e.method == crossaudit::stats::IntervalMethod::TwoWayCluster).unwrap();
    // By hand: d_ij = -0.06 + 0.005 ((3i + 7j) mod 5), i < 4, j < 3; CGM's
    // variance (Cameron, Gelbach & Miller 2011) with e = d - mean summed per
    // row and per column, I / (I-1) sum_i (row sum)^2 / n^2 + J / (J-1)
    // sum_j (column sum)^2 / n^2 - n / (n-1) sum e^2 / n^2, is below zero.
    let d_ij = |i: usize, j: usize| -0.06 + 0.005 * ((3 * i + 7 * j) % 5) as f64;
    let n = 12.0;
    let mean = (0..4).flat_map(|i| (0..3).map(move |j| d_ij(i, j))).sum::<f64>() / n;
    let rows: f64 = (0..4).map(|i| (0..3).map(|j| d_ij(i, j) - mean).sum::<f64>().powi(2)).sum();
    let cols: f64 = (0..3).map(|j| (0..4).map(|i| d_ij(i, j) - mean).sum::<f64>().powi(2)).sum();
    let cells: f64 = (0..4).flat_map(|i| (0..3).map(move |j| (d_ij(i, j) - mean).powi(2))).sum();
    let v = (4.0 / 3.0 * rows + 3.0 / 2.0 * cols - n / (n - 1.0) * cells) / (n * n);
    assert!(v <= 0.0, "{v}");
    assert!(cgm.lower.is_nan(), "{cgm:?}");
    let report = crossaudit::report::render_markdown(&a);
    assert!(
        report.contains("two-way cluster-robust (CGM), t(min(I,J)-1) | - | - | - | undefined: its variance V_row + V_col - V_cell is not positive on this array"),
        "{report}"
    );
    assert!(!report.contains("NaN"), "{report}");
}

/// A secondary endpoint whose arms cannot differ (here the relative model's
/// contaminated cells equal its disjoint ones, as a baseline model's would)
/// is left out with a warning, and the primary endpoint is still decided;
/// the same on the primary endpoint is an error (issue 30: no decision on
/// differences without variance).
#[test]
fn a_degenerate_secondary_endpoint_is_left_out_and_the_primary_still_decides() {
    let dir = tempfile::tempdir().unwrap();
    let design = minimal_design();
    let mut cells = minimal_cells(&design);
    let same_as_disjoint = |cells: &mut Vec<Cell>, model: &str| {
        let reference: Vec<Cell> = cells.iter().filter(|c| c.model == model && c.arm == "disjoint").cloned().collect();
        for c in cells.iter_mut().filter(|c| c.model == model && c.arm == "contaminated") {
            let r = reference
                .iter()
                .find(|r| (r.seed, &r.recording, r.horizon_s) == (c.seed, &c.recording, c.horizon_s))
                .unwrap();
            (c.fa_position_rmse_m, c.conditional_position_rmse_m) =
                (r.fa_position_rmse_m, r.conditional_position_rmse_m);
        }
    };
    same_as_disjoint(&mut cells, "relative");
    // Without the interaction (world - relative), which would no longer be
    // a contrast of two trained models.
    let text = std::fs::read_to_string(minimal_design_path()).unwrap().replace("interaction world - relative\n", "");
    let path = dir.path().join("study.design");
    std::fs::write(&path, text).unwrap();
    let file = write_temp_cells(dir.path(), &cells);
    let a = crossaudit::analyze_files(&path, &file, Default::default()).unwrap();
    assert!(a.units.iter().all(|u| u.model != "relative"));
    assert!(a.units.iter().any(|u| u.model == "world"));
    assert!(
        a.warnings.iter().any(|w| w.contains("relative fa_position_rmse at 0.5 s") && w.contains("left out")),
        "{:?}",
        a.warnings
    );
    same_as_disjoint(&mut cells, "world");
    let file = write_temp_cells(dir.path(), &cells);
    let e = crossaudit::analyze_files(&path, &file, Default::default()).unwrap_err().to_string();
    assert!(e.contains("world fa_position_rmse at 1 s"), "{e}");
}

/// The example cells with one cell of the relative model at 0.5 s whose
/// every start diverged (its divergence rate 1, the failure-aware RMSE at
/// the cap, the conditional, velocity and attitude errors empty), and, with
/// `never`, a reference arm that never diverges at 2 s. Returns the lines
/// and the blanked cell's (arm, recording, seed).
fn with_a_diverged_cell(never: bool) -> (Vec<String>, (String, String, String)) {
    let text = std::fs::read_to_string(example_cells()).unwrap();
    let mut blanked = None;
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(k, l)| {
            let mut f: Vec<String> = l.split(',').map(String::from).collect();
            if k > 0 && f[0] == "relative" && f[6] == "0.5" && blanked.is_none() {
                f[8] = f[7].clone();
                f[11] = "1".into();
                f[9] = "2".into();
                for k in [10, 12, 13] {
                    f[k].clear();
                }
                blanked = Some((f[1].clone(), f[3].clone(), f[2].clone()));
            }
            if never && k > 0 && f[0] == "relative" && f[1] == "disjoint" && f[6] == "2" {
                // No diverged start: the failure-aware RMSE is the conditional one.
                f[8] = "0".into();
                f[11] = "0".into();
                f[9] = f[10].clone();
            }
            f.join(",")
        })
        .collect();
    assert!(text.lines().nth(1).unwrap().split(',').count() == 14);
    (lines, blanked.unwrap())
}

/// A secondary endpoint the data cannot estimate is "not estimable", with
/// its reason, and the primary endpoint is decided as without it: a
/// divergence-rate endpoint whose reference arm never diverges (optimism,
/// a percentage of its mean 0, undefined). An attitude endpoint with a cell
/// whose starts all diverged (its field empty in cells.csv) is estimable:
/// paired over the other pairs, as the conditional RMSE is. Before, either
/// stopped the whole analysis and no report was written.
#[test]
fn a_secondary_endpoint_the_data_cannot_estimate_is_named_not_estimable() {
    let dir = tempfile::tempdir().unwrap();
    let design = std::fs::read_to_string(confirmatory_design()).unwrap().replace(
        "endpoint primary   fa_position_rmse at 1.0 s cap 2 m  model world",
        "endpoint primary   fa_position_rmse at 1.0 s cap 2 m  model world\nendpoint secondary attitude_rmse at 0.5 s model relative\nendpoint secondary divergence_rate at 2.0 s model relative",
    );
    let design_path = dir.path().join("d.design");
    std::fs::write(&design_path, design).unwrap();
    let (lines, _) = with_a_diverged_cell(true);
    let cells = dir.path().join("cells.csv");
    std::fs::write(&cells, lines.join("\n") + "\n").unwrap();
    let a = crossaudit::analyze_files(&design_path, &cells, Default::default()).unwrap();
    let said: Vec<&String> = a.warnings.iter().filter(|w| w.contains("not estimable")).collect();
    assert_eq!(said.len(), 1, "{:#?}", a.warnings);
    let rate = said[0];
    assert!(
        rate.starts_with("relative divergence_rate at 2 s: not estimable (the disjoint arm's mean is zero"),
        "{rate}"
    );
    assert!(rate.contains("optimism (a percentage of it) is undefined"), "{rate}");
    let attitude = a.units.iter().find(|u| u.metric == crossaudit::design::Metric::AttitudeRmse).unwrap();
    assert!(attitude.estimate.reml.is_some(), "paired and estimated by REML");
    // The primary endpoint's decision is the one without them.
    let plain = example();
    assert_eq!(a.decision.holds, plain.decision.holds);
    assert_eq!(a.units[0].estimate.mean, plain.units[0].estimate.mean);
}

/// A primary endpoint over finite rollouts (attitude) with a cell whose
/// every start diverged, under the crossed MoM (which needs every cell):
/// the contrast stays paired, over the recording x seed pairs where both
/// arms have a value, and is decided on REML with Kenward-Roger df, which
/// the report says beside it. Before, the analysis stopped ("empty, but ...
/// needs a value here") after every job had trained, and no report was
/// written. The estimate is `stats::crossed_reml` on the pairs left, built
/// here from the per-cell file on its own (REML itself is checked against
/// lme4 in tests/stats_mixed.rs).
#[test]
fn a_primary_endpoint_with_a_diverged_cell_is_decided_on_the_pairs_left() {
    let dir = tempfile::tempdir().unwrap();
    let design = std::fs::read_to_string(confirmatory_design()).unwrap().replace(
        "endpoint primary   fa_position_rmse at 1.0 s cap 2 m  model world",
        "endpoint primary   attitude_rmse at 0.5 s cap 2 m  model relative",
    );
    assert!(design.contains("estimate crossed_mom"));
    let design_path = dir.path().join("d.design");
    std::fs::write(&design_path, design).unwrap();
    let (lines, (arm, recording, seed)) = with_a_diverged_cell(false);
    let cells = dir.path().join("cells.csv");
    std::fs::write(&cells, lines.join("\n") + "\n").unwrap();
    let a = crossaudit::analyze_files(&design_path, &cells, Default::default()).unwrap();
    let w =
        a.warnings.iter().find(|w| w.contains("recording x seed pairs lack a value")).expect("the dropped pair named");
    assert!(
        w.starts_with("relative attitude_rmse at 0.5 s: 1 of ") && w.contains("by REML with Kenward-Roger df"),
        "{w}"
    );
    // d per (recording, seed) from the file itself, the blanked pair left out.
    let mut value: std::collections::BTreeMap<(String, String, String), f64> = Default::default();
    for l in lines.iter().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        if f[0] == "relative" && f[6] == "0.5" && !f[13].is_empty() {
            value.insert((f[1].to_string(), f[3].to_string(), f[2].to_string()), f[13].parse().unwrap());
        }
    }
    assert!(!value.contains_key(&(arm, recording.clone(), seed.clone())));
    let recs: Vec<String> =
        value.keys().map(|k| k.1.clone()).collect::<std::collections::BTreeSet<_>>().into_iter().collect();
    let seeds: Vec<String> =
        value.keys().map(|k| k.2.clone()).collect::<std::collections::BTreeSet<_>>().into_iter().collect();
    let mut d = Vec::new();
    for (i, r) in recs.iter().enumerate() {
        for (j, s) in seeds.iter().enumerate() {
            let get = |arm: &str| value.get(&(arm.to_string(), r.clone(), s.clone())).copied();
            if let (Some(t), Some(u)) = (get("contaminated"), get("disjoint")) {
                d.push((i, j, t - u));
            }
        }
    }
    assert_eq!(d.len(), recs.len() * seeds.len() - 1);
    let want =
        crossaudit::stats::crossed_reml(&d, recs.len(), seeds.len(), 0.95, crossaudit::stats::DfRule::KenwardRoger)
            .unwrap();
    let got = &a.units[0].estimate;
    assert!(got.reml.is_some());
    for (g, w) in [(got.mean, want.mean), (got.se, want.se), (got.df, want.df), (got.upper, want.upper)] {
        assert!((g - w).abs() <= 1e-9 * w.abs().max(1e-12), "{g} against {w}");
    }
    // The design's rule: optimism >= 10% and upper < 0, read on that estimate.
    assert_eq!(a.decision.holds, a.units[0].optimism_pct >= 10.0 && got.upper < 0.0);
}

/// The CSV tables' guard-kind names are the ones results.json serializes.
#[test]
fn a_guard_kind_is_named_as_serde_writes_it() {
    use crossaudit::analysis::GuardKind::*;
    for k in [
        Margin,
        NoInterval,
        Fragile,
        EarlyStopping,
        FixedBudget,
        NotDisjoint,
        ValidationCopies,
        Coverage,
        Concentrated,
        Distance,
        Harm,
    ] {
        assert_eq!(serde_json::to_value(k).unwrap(), serde_json::Value::String(k.name().into()));
    }
}

/// Issue 76, item 3 (the reading half): `--cells` accepts a Parquet file
/// with the per-cell CSV's columns. A twin of the committed quickstart
/// cells written here with typed columns (text, 64-bit integers, doubles,
/// as pandas' `to_parquet` writes them) is analysed to the same report as
/// the CSV, apart from the line naming the file and its hash.
#[test]
fn a_parquet_cells_file_is_analysed_as_its_csv_twin() {
    use parquet::basic::{LogicalType, Repetition, Type as Physical};
    use parquet::column::writer::ColumnWriter;
    use parquet::data_type::ByteArray;
    use parquet::file::properties::WriterProperties;
    use parquet::file::writer::SerializedFileWriter;
    use parquet::schema::types::Type;
    use std::sync::Arc;

    let root = crate::common::root();
    let csv_path = root.join("results/quickstart/cells.csv");
    let text = std::fs::read_to_string(&csv_path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // Each column as the narrowest type every value fits: integer, double,
    // else text.
    let kind = |c: usize| -> u8 {
        if rows.iter().all(|r| r[c].parse::<i64>().is_ok()) {
            0
        } else if rows.iter().all(|r| r[c].parse::<f64>().is_ok()) {
            1
        } else {
            2
        }
    };
    let kinds: Vec<u8> = (0..header.len()).map(kind).collect();
    assert_eq!(kinds.iter().filter(|k| **k == 2).count(), 5, "{header:?} {kinds:?}");
    let fields = header
        .iter()
        .zip(&kinds)
        .map(|(name, k)| {
            let builder = match k {
                0 => Type::primitive_type_builder(name, Physical::INT64),
                1 => Type::primitive_type_builder(name, Physical::DOUBLE),
                _ => Type::primitive_type_builder(name, Physical::BYTE_ARRAY)
                    .with_logical_type(Some(LogicalType::String)),
            };
            Arc::new(builder.with_repetition(Repetition::REQUIRED).build().unwrap())
        })
        .collect();
    let schema = Arc::new(Type::group_type_builder("cells").with_fields(fields).build().unwrap());
    let dir = tempfile::tempdir().unwrap();
    let parquet_path = dir.path().join("cells.parquet");
    let file = std::fs::File::create(&parquet_path).unwrap();
    let mut writer = SerializedFileWriter::new(file, schema, Arc::new(WriterProperties::builder().build())).unwrap();
    let mut group = writer.next_row_group().unwrap();
    let mut c = 0;
    while let Some(mut col) = group.next_column().unwrap() {
        match col.untyped() {
            ColumnWriter::Int64ColumnWriter(w) => {
                let v: Vec<i64> = rows.iter().map(|r| r[c].parse().unwrap()).collect();
                w.write_batch(&v, None, None).unwrap();
            }
            ColumnWriter::DoubleColumnWriter(w) => {
                let v: Vec<f64> = rows.iter().map(|r| r[c].parse().unwrap()).collect();
                w.write_batch(&v, None, None).unwrap();
            }
            ColumnWriter::ByteArrayColumnWriter(w) => {
                let v: Vec<ByteArray> = rows.iter().map(|r| ByteArray::from(r[c])).collect();
                w.write_batch(&v, None, None).unwrap();
            }
            _ => panic!("column {c}"),
        }
        col.close().unwrap();
        c += 1;
    }
    group.close().unwrap();
    writer.close().unwrap();
    let design = root.join("designs/quickstart.design");
    let report = |cells: &std::path::Path, out: &std::path::Path| -> String {
        let o = crate::common::bin()
            .args(["analyze", design.to_str().unwrap(), "--cells", cells.to_str().unwrap(), "--out"])
            .arg(out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let md = std::fs::read_to_string(out.join("report.md")).unwrap();
        md.lines().filter(|l| !l.starts_with("Per-cell data:")).collect::<Vec<_>>().join("\n")
    };
    // Both bare files (a run folder's cells.csv would bring its record's
    // evidence).
    let bare_csv = dir.path().join("cells.csv");
    std::fs::copy(&csv_path, &bare_csv).unwrap();
    let from_csv = report(&bare_csv, &dir.path().join("csv"));
    let from_parquet = report(&parquet_path, &dir.path().join("parquet"));
    assert!(from_csv.contains("## "), "{from_csv}");
    let differ: Vec<(&str, &str)> = from_csv.lines().zip(from_parquet.lines()).filter(|(a, b)| a != b).collect();
    assert!(differ.is_empty() && from_csv.lines().count() == from_parquet.lines().count(), "{differ:#?}");
    // A damaged Parquet file is named as such, at its path.
    let broken = dir.path().join("broken.parquet");
    std::fs::write(&broken, b"PAR1 not really").unwrap();
    let o = crate::common::bin()
        .args(["analyze", design.to_str().unwrap(), "--cells", broken.to_str().unwrap(), "--out"])
        .arg(dir.path().join("broken"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("broken.parquet") && stderr.contains("not a readable Parquet file"), "{stderr}");
}

/// The Parquet tables a run and a report write hold their CSV tables'
/// values with types: for the quickstart's cells and the example's
/// estimates, every column's Parquet type is the narrowest its values fit
/// (names text, seeds and counts INT64, metrics DOUBLE, `rule_holds`
/// BOOLEAN), an empty field is a null, and every value reads back as the
/// CSV's (the same number, or the same text).
#[test]
fn the_parquet_tables_hold_the_csv_tables_values_typed() {
    use crossaudit::io::parquet::{columns_to_csv_text, csv_to_parquet};
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let root = crate::common::root();
    let tmp = tempfile::tempdir().unwrap();
    let o = crate::common::crossaudit(&[
        "analyze",
        "designs/nanobench_confirmatory.design",
        "--cells",
        "examples/cells/nanobench_synthetic.csv",
        "--out",
        tmp.path().to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", crate::common::said(&o));
    let estimates = std::fs::read(tmp.path().join("estimates.csv")).unwrap();
    let written = std::fs::read(tmp.path().join("estimates.parquet")).unwrap();
    assert_eq!(written, csv_to_parquet(&estimates).unwrap(), "the report's estimates.parquet is its estimates.csv");
    let cells = std::fs::read(root.join("results/quickstart/cells.csv")).unwrap();
    let mut nulls = 0;
    for (csv, types) in [
        (
            &cells,
            vec![("model", "BYTE_ARRAY"), ("seed", "INT64"), ("n_starts", "INT64"), ("fa_position_rmse_m", "DOUBLE")],
        ),
        (&estimates, vec![("kind", "BYTE_ARRAY"), ("estimate", "DOUBLE"), ("rule_holds", "BOOLEAN")]),
    ] {
        let parquet = csv_to_parquet(csv).unwrap();
        let reader = SerializedFileReader::new(bytes::Bytes::from(parquet.clone())).unwrap();
        let schema = reader.metadata().file_metadata().schema_descr_ptr();
        for (name, physical) in types {
            let c = (0..schema.num_columns()).find(|&c| schema.column(c).name() == name).unwrap();
            assert_eq!(schema.column(c).physical_type().to_string(), physical, "{name}");
        }
        let back = columns_to_csv_text(bytes::Bytes::from(parquet), u64::MAX).unwrap();
        let records = |t: &[u8]| -> Vec<Vec<String>> {
            let mut r = csv::ReaderBuilder::new().has_headers(false).from_reader(t);
            r.records().map(|x| x.unwrap().iter().map(String::from).collect()).collect()
        };
        let (want, got) = (records(csv), records(&back));
        assert_eq!(want.len(), got.len());
        for (w, g) in want.iter().zip(&got) {
            for (a, b) in w.iter().zip(g) {
                nulls += usize::from(a.is_empty());
                let same = a == b || matches!((a.parse::<f64>(), b.parse::<f64>()), (Ok(x), Ok(y)) if x == y);
                assert!(same, "{a:?} read back as {b:?}");
            }
        }
    }
    assert!(nulls > 0, "the estimates have empty fields, read back as nulls");
}

/// A per-cell file read alone whose last line ends without a line break
/// (as a file cut short while it was written does) is analysed with a
/// warning that names its last line and the value it read there, in the
/// console, results.json and the report; the same file with its line
/// break gets none.
#[test]
fn a_per_cell_file_without_a_final_line_break_is_analysed_with_a_warning() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(crate::common::example_cells()).unwrap();
    assert!(text.ends_with('\n'));
    let lines = text.lines().count();
    let last_value = text.trim_end().rsplit(',').next().unwrap().to_string();
    for (name, body, warned) in [("whole.csv", text.clone(), false), ("open.csv", text.trim_end().to_string(), true)] {
        let cells = tmp.path().join(name);
        std::fs::write(&cells, &body).unwrap();
        let out = tmp.path().join(format!("out-{name}"));
        let o = crate::common::crossaudit(&[
            "analyze",
            "designs/nanobench_confirmatory.design",
            "--cells",
            cells.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", crate::common::said(&o));
        let said = crate::common::said(&o);
        let json = std::fs::read_to_string(out.join("results.json")).unwrap();
        let report = std::fs::read_to_string(out.join("report.md")).unwrap();
        let needle = format!("its last line ({lines}) ends without a line break");
        for (view, text) in [("console", &said), ("results.json", &json), ("report.md", &report)] {
            assert_eq!(text.contains(&needle), warned, "{name}, {view}: {text}");
        }
        if warned {
            let value: f64 = last_value.parse().unwrap();
            assert!(said.contains(&format!("`attitude_rmse_deg`, read as {value})")), "{said}");
        }
    }
}
