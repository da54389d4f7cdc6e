//! Models, rollouts and metrics: invariances, known rotations, hand-built
//! failure-aware cases, own-arm standardizers and thread-count determinism.

use crate::common::{root, run_job};
use crossaudit::design::{ActionScaling, InputMap, TargetKind};
use crossaudit::model::features::{raw_input, Action, State};
use crossaudit::model::{Dynamics, FeatureMap, Learned, Slots};
use crossaudit::rollout::{attitude_error_deg, failure_aware, StartOutcome, Trace};
use crossaudit::split::Window;

fn state(p: [f64; 3], r: [f64; 3]) -> State {
    let mut x = vec![0.0; 14];
    x[..3].copy_from_slice(&p);
    x[3..6].copy_from_slice(&[0.3, -0.1, 0.05]);
    x[6..10].copy_from_slice(&[0.99, 0.05, -0.08, 0.1]);
    x[10..13].copy_from_slice(&r);
    x[13] = 3.9;
    x
}

/// Windows with some spread, enough to fit standardizers and a tiny net.
pub(crate) fn windows(offset: f64, n: usize) -> Vec<(State, Action, State)> {
    (0..n)
        .map(|k| {
            let a = k as f64 * 0.05 + offset;
            let x = state([a.cos(), a.sin(), 1.0 + 0.1 * a.sin()], [a.cos() + 0.1, a.sin(), 1.0]);
            let mut next = x.clone();
            next[0] += 0.01 * x[3];
            next[1] += 0.01 * x[4];
            let u = vec![0.5 + 0.1 * a.sin(), 0.5, 0.52, 0.49];
            (x, u, next)
        })
        .collect()
}

fn tiny_training() -> crossaudit::design::Training {
    crossaudit::design::load(&root().join("tests/designs/tiny_train.design")).unwrap().design.training.unwrap()
}

#[test]
fn relative_inputs_ignore_a_joint_translation_and_predictions_translate_with_it() {
    // Binary fractions, so that the shifted differences are exact.
    let x = state([0.25, -0.5, 1.125], [0.5, -0.25, 1.0]);
    let shift = [3.0, -7.5, 0.25];
    let mut y = x.clone();
    for k in 0..3 {
        y[k] += shift[k];
        y[10 + k] += shift[k];
    }
    let u = vec![0.5, 0.6, 0.55, 0.5];
    let nb = &Slots::NANOBENCH;
    assert_eq!(raw_input(nb, InputMap::Relative, &x, &u), raw_input(nb, InputMap::Relative, &y, &u));
    assert_ne!(raw_input(nb, InputMap::World, &x, &u), raw_input(nb, InputMap::World, &y, &u));
    // Any weights will do: train a tiny relative net for one epoch.
    let w = windows(0.0, 300);
    let features = FeatureMap::fit(
        Slots::NANOBENCH,
        InputMap::Relative,
        ActionScaling::Raw,
        TargetKind::StateScaled,
        &w,
        "manifest",
    );
    let mut t = tiny_training();
    t.epochs = 1;
    let (net, _) = crossaudit::model::train(&[32, 32, 32], &features, &w, &w[..50], &t, 3, &mut |_| {}).unwrap();
    let mut model = Learned::new(&net, &features);
    let next = model.step(&[x, y], &[u.clone(), u]);
    for k in 0..3 {
        let moved = next[1][k] - next[0][k];
        assert!((moved - shift[k]).abs() < 1e-9, "predicted position moved by {moved}, origin by {}", shift[k]);
    }
    for (k, (a, b)) in next[0].iter().zip(&next[1]).enumerate().take(10).skip(3) {
        assert!((b - a).abs() < 1e-12, "component {k} changed under translation");
    }
}

#[test]
fn shortest_rotation_angle_on_known_rotations() {
    let id = [1.0, 0.0, 0.0, 0.0];
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let close = |a: f64, b: f64| assert!((a - b).abs() < 1e-6, "{a} vs {b}");
    close(attitude_error_deg(&id, &id), 0.0);
    close(attitude_error_deg(&id, &[h, 0.0, 0.0, h]), 90.0); // 90 degrees about z
    close(attitude_error_deg(&id, &[0.0, 1.0, 0.0, 0.0]), 180.0); // 180 degrees about x
    close(attitude_error_deg(&[h, 0.0, h, 0.0], &[-h, 0.0, -h, 0.0]), 0.0); // q and -q
    close(attitude_error_deg(&[h, h, 0.0, 0.0], &[h, -h, 0.0, 0.0]), 180.0); // +90 vs -90 about x
}

fn trace(errors: &[f64]) -> Trace {
    Trace {
        start: Window { recording: 0, t: 0 },
        position_error: errors.to_vec(),
        at: vec![(errors.len(), vec![0.0; 14], vec![0.0; 14])],
        slots: Slots::NANOBENCH,
    }
}

#[test]
fn failure_aware_metric_on_hand_built_rollouts() {
    let cap = 2.0;
    let cases = [
        trace(&[0.05, 0.1]),          // fine: 0.1 at the horizon
        trace(&[0.1, 0.2]),           // fine: 0.2
        trace(&[2.5, 1.0]),           // above the cap before the horizon: divergent
        trace(&[0.1, f64::INFINITY]), // non-finite at the horizon: divergent
    ];
    let outcomes: Vec<StartOutcome> = cases.iter().map(|t| StartOutcome::of(t, 2, cap)).collect();
    assert_eq!(outcomes.iter().map(|o| o.divergent).collect::<Vec<_>>(), [false, false, true, true]);
    let m = failure_aware(&outcomes, cap);
    // sqrt((0.1^2 + 0.2^2 + 2^2 + 2^2) / 4) and sqrt((0.1^2 + 0.2^2) / 2).
    assert!((m.fa_position_rmse - (8.05f64 / 4.0).sqrt()).abs() < 1e-12, "{}", m.fa_position_rmse);
    assert!((m.conditional_position_rmse.unwrap() - (0.05f64 / 2.0).sqrt()).abs() < 1e-12);
    assert_eq!(m.n_divergent, 2);
    // At the first step nothing has diverged yet.
    let early: Vec<StartOutcome> = cases.iter().map(|t| StartOutcome::of(t, 1, cap)).collect();
    assert_eq!(early.iter().filter(|o| o.divergent).count(), 1);
    // Everything divergent: the conditional RMSE is empty, not zero.
    let all = failure_aware(&outcomes[2..], cap);
    assert_eq!((all.fa_position_rmse, all.conditional_position_rmse), (2.0, None));
}

#[test]
fn standardizers_use_their_own_arm_only() {
    let a = windows(0.0, 400);
    let b = windows(10.0, 400);
    let fa =
        FeatureMap::fit(Slots::NANOBENCH, InputMap::World, ActionScaling::Raw, TargetKind::StateScaled, &a, "fit_a");
    let fb =
        FeatureMap::fit(Slots::NANOBENCH, InputMap::World, ActionScaling::Raw, TargetKind::StateScaled, &b, "fit_b");
    let joint: Vec<_> = a.iter().chain(&b).cloned().collect();
    let fj = FeatureMap::fit(
        Slots::NANOBENCH,
        InputMap::World,
        ActionScaling::Raw,
        TargetKind::StateScaled,
        &joint,
        "joint",
    );
    assert_ne!(fa.input.mean, fb.input.mean);
    assert_ne!(fa.input.mean, fj.input.mean, "fitting on both arms would change arm A's standardizer");
    assert_eq!(
        fa,
        FeatureMap::fit(Slots::NANOBENCH, InputMap::World, ActionScaling::Raw, TargetKind::StateScaled, &a, "fit_a")
    );
    // Constant dimensions (quaternion components here) get SD 1, not 0.
    assert!(fa.input.std.iter().all(|s| *s > 0.0 && s.is_finite()));
}

/// Runs the same training cell inside rayon pools of 1 and 2 threads.
#[test]
#[ignore = "needs ../shared/nanobench"]
fn same_seed_gives_bit_identical_weights_and_cells_with_1_and_2_threads() {
    let _logs = crate::needs_shared_logs!();
    let out = tempfile::tempdir().unwrap();
    let (file, plan, split) = crate::common::tiny_split(out.path());
    let mut results = Vec::new();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let o = out.path().join(format!("t{threads}"));
        let cell = pool.install(|| run_job(&file, &plan, &split, ("world", "contaminated", 1), &o));
        let weights = std::fs::read(o.join("models/world__contaminated__1.safetensors")).unwrap();
        let cells = std::fs::read(o.join("cells/world__contaminated__1.csv")).unwrap();
        results.push((weights, cells, cell.epochs.iter().map(|e| e.val_loss).collect::<Vec<_>>()));
    }
    assert_eq!(results[0].0, results[1].0, "weights differ between 1 and 2 threads");
    assert_eq!(results[0].1, results[1].1, "per-cell rows differ between 1 and 2 threads");
    assert_eq!(results[0].2, results[1].2);
}

#[test]
#[ignore = "needs ../shared/nanobench"]
fn a_trained_cell_records_its_own_arm_and_baselines_do_not_depend_on_the_arm() {
    let _logs = crate::needs_shared_logs!();
    let out = tempfile::tempdir().unwrap();
    let (file, plan, split) = crate::common::tiny_split(out.path());
    let mut baseline_fa = Vec::new();
    for arm in ["disjoint", "contaminated"] {
        let cell = run_job(&file, &plan, &split, ("relative", arm, 2), out.path());
        let meta: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.path().join(format!("models/relative__{arm}__2.json"))).unwrap(),
        )
        .unwrap();
        assert_eq!(meta["fit_manifest_sha256"], split.manifests.sha256(&format!("fit_{arm}.csv")), "invariant 6");
        assert_eq!(meta["design_sha256"], file.sha256);
        assert_eq!(cell.cells.len(), 4, "4 evaluation recordings x 1 horizon (0.5 s) for the relative model");
        baseline_fa.push(cell.mean_fa_rmse.iter().filter(|(who, _, _)| who != "relative").cloned().collect::<Vec<_>>());
    }
    assert_eq!(baseline_fa[0], baseline_fa[1], "parameter-free baselines must score the same on both arms");
}

#[test]
#[ignore = "needs ../shared/nanobench"]
fn a_saved_cell_is_re_evaluated_without_retraining() {
    let _logs = crate::needs_shared_logs!();
    let out = tempfile::tempdir().unwrap();
    let (file, plan, split) = crate::common::tiny_split(out.path());
    let cell = run_job(&file, &plan, &split, ("world", "disjoint", 1), out.path());
    // Reload weights and standardizers from disk and roll out again.
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("models/world__disjoint__1.json")).unwrap())
            .unwrap();
    let features: FeatureMap = serde_json::from_value(meta["features"].clone()).unwrap();
    let widths: Vec<usize> = serde_json::from_value(meta["widths"].clone()).unwrap();
    let net = crossaudit::model::Net::load(&widths, &out.path().join("models/world__disjoint__1.safetensors")).unwrap();
    let horizons = plan.jobs.iter().find(|j| j.model == "world").unwrap().horizons_s.clone();
    let steps = crossaudit::rollout::horizon_steps(&horizons, file.design.data.rate_hz);
    let mut model = Learned::new(&net, &features);
    let traces = crossaudit::rollout::rollout(
        &mut model,
        &split.recordings,
        &split.split.starts,
        *steps.iter().max().unwrap(),
        &steps,
    );
    let again = crossaudit::rollout::cells(
        "world",
        "disjoint",
        1,
        &split.split,
        &traces,
        &horizons,
        file.design.data.rate_hz,
        2.0,
    );
    assert_eq!(again, cell.cells, "re-evaluating the saved model must reproduce the cell's rows");
}

/// Population mean and SD of dimension `k` over `rows`, recomputed here
/// from the definition (divisor n).
fn mean_sd(rows: &[Vec<f64>], k: usize) -> (f64, f64) {
    let n = rows.len() as f64;
    let m = rows.iter().map(|r| r[k]).sum::<f64>() / n;
    (m, (rows.iter().map(|r| (r[k] - m).powi(2)).sum::<f64>() / n).sqrt())
}

/// `target state_scaled` (the paper): dz = (x_{t+1} - x_t) / sd_x, with
/// sd_x the SD of x_t over the fit windows: no centring, and per-dimension
/// weights 1 / sd_x. `target standardized`: the increment's own mean and SD.
#[test]
fn state_scaled_target_divides_the_increment_by_the_state_sd() {
    // Increments that vary, so that their own SD is not zero.
    let w: Vec<(State, Action, State)> = windows(0.0, 400)
        .into_iter()
        .enumerate()
        .map(|(k, (x, u, mut next))| {
            next[0] += 0.02 * (k as f64 * 0.3).sin();
            next[1] -= 0.01 * (k as f64 * 0.7).cos();
            (x, u, next)
        })
        .collect();
    let xs: Vec<Vec<f64>> = w.iter().map(|(x, _, _)| x.clone()).collect();
    let paper =
        FeatureMap::fit(Slots::NANOBENCH, InputMap::Relative, ActionScaling::Raw, TargetKind::StateScaled, &w, "m");
    let own =
        FeatureMap::fit(Slots::NANOBENCH, InputMap::Relative, ActionScaling::Raw, TargetKind::Standardized, &w, "m");
    let (x, u, next) = w[37].clone();
    let (mut z_paper, mut z_own) = ([0f32; 14], [0f32; 14]);
    paper.target(&x, &next, &mut z_paper);
    own.target(&x, &next, &mut z_own);
    for k in 0..2 {
        let (_, sd) = mean_sd(&xs, k);
        let want = (next[k] - x[k]) / sd;
        assert!(
            (f64::from(z_paper[k]) - want).abs() < 1e-6 * want.abs().max(1e-3),
            "dim {k}: {} vs {want}",
            z_paper[k]
        );
        assert_eq!(paper.target.mean[k], 0.0, "no centring");
        let dx: Vec<Vec<f64>> = w.iter().map(|(a, _, b)| (0..14).map(|j| b[j] - a[j]).collect()).collect();
        let (dm, dsd) = mean_sd(&dx, k);
        let standardized = ((next[k] - x[k]) - dm) / dsd;
        assert!((f64::from(z_own[k]) - standardized).abs() < 1e-5, "dim {k}: standardized increment");
        assert!((f64::from(z_paper[k]) - standardized).abs() > 1e-3, "the two targets differ in dim {k}");
    }
    // Exogenous components are zero under both; the rollout inverts dz exactly.
    assert!(z_paper[10..].iter().chain(&z_own[10..]).all(|v| *v == 0.0));
    let back = paper.next_state(&x, &z_paper);
    assert!((back[0] - next[0]).abs() < 1e-7 && (back[1] - next[1]).abs() < 1e-7);
    let _ = u;
}

/// `actions raw` (the paper): u reaches both networks unscaled;
/// `actions standardized`: through the input standardizer, in both maps.
#[test]
fn raw_actions_reach_both_networks_unscaled() {
    let w = windows(0.0, 400);
    let (x, u, _) = w[11].clone();
    for map in [InputMap::World, InputMap::Relative] {
        let raw = FeatureMap::fit(Slots::NANOBENCH, map, ActionScaling::Raw, TargetKind::StateScaled, &w, "m");
        let std = FeatureMap::fit(Slots::NANOBENCH, map, ActionScaling::Standardized, TargetKind::StateScaled, &w, "m");
        let (mut a, mut b) = ([0f32; 18], [0f32; 18]);
        raw.input(&x, &u, &mut a);
        std.input(&x, &u, &mut b);
        for k in 0..4 {
            assert_eq!(a[14 + k], u[k] as f32, "{map:?}: raw u_{k} enters unscaled");
        }
        assert_eq!(a[..14], b[..14], "{map:?}: the state part does not depend on the action scaling");
        let us: Vec<Vec<f64>> =
            w.iter().map(|(_, u, _)| (0..14).map(|j| if j < 4 { u[j] } else { 0.0 }).collect()).collect();
        let (m, sd) = mean_sd(&us, 0);
        assert!((f64::from(b[14]) - (u[0] - m) / sd).abs() < 1e-5, "{map:?}: standardized u_0");
    }
}

/// Windows whose increment is an exact affine function of (x, u): the
/// non-exogenous state moves by A x + B u + c (A, B, c fixed, small).
fn affine_windows(n: usize, salt: u64) -> Vec<(State, Action, State)> {
    let mut s = salt.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let mut r = || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((s >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    (0..n)
        .map(|_| {
            let x: State = (0..14).map(|_| r()).collect();
            let u: Action = (0..4).map(|_| r() + 0.5).collect();
            let mut next = x.clone();
            for (k, n) in next.iter_mut().enumerate().take(10) {
                let a: f64 = x.iter().enumerate().map(|(j, xj)| 0.01 * ((k * 14 + j) % 7) as f64 * xj).sum();
                let b: f64 = u.iter().enumerate().map(|(j, uj)| 0.02 * ((k + j) % 3) as f64 * uj).sum();
                *n += a + b + 0.001 * k as f64;
            }
            (x, u, next)
        })
        .collect()
}

#[test]
fn ridge_without_a_penalty_recovers_an_exact_linear_map() {
    // Closed form: with Y an exact affine function of X, least squares
    // (ridge 0) has zero residual, so every one-step prediction is exact
    // up to the f32 standardization of inputs and outputs.
    let (fit, val, test) = (affine_windows(400, 1), affine_windows(100, 2), affine_windows(50, 3));
    let features = FeatureMap::fit(
        Slots::NANOBENCH,
        InputMap::World,
        ActionScaling::Standardized,
        TargetKind::Standardized,
        &fit,
        "m",
    );
    let mut model = crossaudit::model::linear::fit(features, &fit, &val, Some(0.0)).unwrap();
    assert_eq!(model.validation.len(), 1);
    assert!(model.validation[0].1 < 1e-10, "validation loss {}", model.validation[0].1);
    let states: Vec<State> = test.iter().map(|w| w.0.clone()).collect();
    let actions: Vec<Action> = test.iter().map(|w| w.1.clone()).collect();
    let predicted = model.step(&states, &actions);
    for ((p, w), x) in predicted.iter().zip(&test).zip(&states) {
        for (k, (got, want)) in p.iter().zip(&w.2).take(10).enumerate() {
            assert!((got - want).abs() < 1e-6, "dim {k}: {got} vs {want}");
        }
        // The exogenous dimensions are left as they were (the rollout overwrites them).
        assert_eq!(p[10..], x[10..]);
    }
}

#[test]
fn ridge_auto_keeps_the_grid_penalty_with_the_lowest_validation_loss_and_a_huge_penalty_predicts_the_mean() {
    let (fit, val) = (affine_windows(300, 4), affine_windows(100, 5));
    let features =
        FeatureMap::fit(Slots::NANOBENCH, InputMap::Relative, ActionScaling::Raw, TargetKind::Standardized, &fit, "m");
    let auto = crossaudit::model::linear::fit(features.clone(), &fit, &val, None).unwrap();
    let grid: Vec<f64> = auto.validation.iter().map(|v| v.0).collect();
    assert_eq!(grid, crossaudit::model::linear::RIDGE_GRID.to_vec());
    let best = auto.validation.iter().map(|v| v.1).fold(f64::INFINITY, f64::min);
    assert_eq!(auto.validation.iter().find(|v| v.0 == auto.lambda).unwrap().1, best);
    // Closed form of the limit: as the penalty grows, every input weight
    // goes to 0 and the prediction to the unpenalized intercept, the mean
    // standardized target, which is 0 for a standardized target.
    let mut big = crossaudit::model::linear::fit(features, &fit, &val, Some(1e12)).unwrap();
    assert!(big.weights[..18 * 14].iter().all(|w| w.abs() < 1e-9));
    assert!(big.weights[18 * 14..].iter().all(|w| w.abs() < 1e-6), "{:?}", &big.weights[18 * 14..]);
    let (x, u) = (fit[0].0.clone(), fit[0].1.clone());
    let p = big.step(std::slice::from_ref(&x), &[u])[0].clone();
    let mean: Vec<f64> = (0..10).map(|k| fit.iter().map(|w| w.2[k] - w.0[k]).sum::<f64>() / fit.len() as f64).collect();
    for (k, m) in mean.iter().enumerate() {
        assert!((p[k] - x[k] - m).abs() < 1e-6, "dim {k}");
    }
}

#[test]
#[ignore = "needs ../shared/nanobench"]
fn the_linear_model_beside_the_paper_reproduces_its_committed_run_on_the_papers_split() {
    let data = crate::needs_shared_logs!();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("linear");
    let o = crate::common::bin()
        .current_dir(root())
        .args(["run", "designs/nanobench_paper_linear.design", "--data"])
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    crate::common::assert_ok(&o);
    let read = |p: std::path::PathBuf| std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let committed = root().join("results/nanobench_paper_linear");
    assert_eq!(
        read(out.join("cells.csv")),
        read(committed.join("cells.csv")),
        "cells.csv differs from the committed run"
    );
    // The paper's split: the same audit and the same evaluation recordings
    // as its MLP run, whose content hashes are of the earlier definition
    // (of the logs' text: results/INDEX.md), so that column is set aside.
    let paper = root().join("results/nanobench_paper");
    let without_hashes = |text: String| {
        let at = text.lines().next().unwrap().split(',').position(|c| c == "content_hash").unwrap();
        let mut rows = csv::ReaderBuilder::new().has_headers(false).from_reader(text.as_bytes());
        let rows: Vec<Vec<String>> = rows
            .records()
            .map(|r| r.unwrap().iter().enumerate().filter(|&(k, _)| k != at).map(|(_, f)| f.to_string()).collect())
            .collect();
        rows
    };
    let (ours, theirs) = (read(out.join("audit/recordings.csv")), read(paper.join("audit/recordings.csv")));
    assert_eq!(ours.lines().count(), theirs.lines().count());
    assert_eq!(without_hashes(ours), without_hashes(theirs));
    let recordings = |cells: String| {
        let mut r: Vec<String> = cells.lines().skip(1).map(|l| l.split(',').nth(3).unwrap().to_string()).collect();
        r.sort();
        r.dedup();
        r
    };
    let linear = recordings(read(out.join("cells.csv")));
    assert_eq!(linear.len(), 24, "the paper's 26 evaluation recordings less the 2 without a CSV");
    assert_eq!(linear, recordings(read(paper.join("cells.csv"))));
    // A closed-form fit: every seed gives the same cells.
    let cells = read(out.join("cells.csv"));
    let rows_of = |seed: &str| -> Vec<String> {
        cells
            .lines()
            .filter(|l| l.split(',').nth(2) == Some(seed))
            .map(|l| l.split(',').enumerate().filter(|(k, _)| *k != 2).map(|(_, f)| f).collect::<Vec<_>>().join(","))
            .collect()
    };
    assert_eq!(rows_of("100"), rows_of("119"));
}

/// `restore final` (early stopping held fixed): training runs the full
/// budget whatever the patience, its epochs up to where early stopping
/// would have stopped are those of the early-stopped run bit for bit, and
/// the weights kept are the last epoch's: they equal the best-epoch
/// weights exactly when the last epoch is the best one.
#[test]
fn restore_final_trains_the_full_budget_and_keeps_the_last_weights() {
    let (fit, val) = (windows(0.0, 300), windows(0.37, 80));
    let features =
        FeatureMap::fit(Slots::NANOBENCH, InputMap::World, ActionScaling::Raw, TargetKind::StateScaled, &fit, "fit");
    let mut t = tiny_training();
    t.epochs = 14;
    t.patience = 1;
    let train = |t: &crossaudit::design::Training| {
        crossaudit::model::train(&[32, 32, 32], &features, &fit, &val, t, 5, &mut |_| {}).unwrap()
    };
    let (_, early) = train(&t);
    let mut full_budget = t.clone();
    full_budget.restore_final = true;
    let (last, full) = train(&full_budget);
    assert_eq!(full.len(), 14);
    let loss = |e: &[crossaudit::model::EpochLog]| e.iter().map(|e| e.val_loss.to_bits()).collect::<Vec<_>>();
    assert_eq!(loss(&full[..early.len()]), loss(&early), "the early-stopped epochs are a prefix of the full budget");
    // The best of the same 14 epochs, restored: patience never reached.
    let mut best = t.clone();
    best.patience = 14;
    let (restored, same) = train(&best);
    assert_eq!(loss(&same), loss(&full));
    let argmin = full.iter().enumerate().min_by(|a, b| a.1.val_loss.total_cmp(&b.1.val_loss)).unwrap().0 + 1;
    assert_eq!(last == restored, argmin == 14, "best epoch {argmin}");
}

/// Any MLP shape, with the real binary: `check` accepts `mlp(64, 64)` and
/// an unequal three-layer net, `run` trains both on simulated data, and
/// each job's weights file has the declared layers.
#[test]
fn networks_of_any_shape_are_checked_trained_and_saved() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("tests/designs/sim_small.design"))
        .unwrap()
        .replace("model world    = mlp(32, 32, 32)", "model world    = mlp(64, 64)")
        .replace("model relative = mlp(32, 32, 32)", "model relative = mlp(24, 12, 6)")
        .replace("epochs 15 cosine patience 15", "epochs 2 cosine patience 2");
    let design = dir.path().join("shapes.design");
    std::fs::write(&design, text).unwrap();
    let bin = |args: &[&str]| crate::common::bin().args(args).output().unwrap();
    let check = bin(&["check", design.to_str().unwrap()]);
    crate::common::assert_ok(&check);
    assert!(crate::common::stdout(&check).contains("mlp(64, 64)"), "{}", crate::common::stdout(&check));
    let out = dir.path().join("run");
    crate::common::assert_ok(&bin(&[
        "run",
        design.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--exploratory",
        "--workers",
        "2",
    ]));
    for (model, widths) in [("world", vec![64, 64]), ("relative", vec![24, 12, 6])] {
        let net = crossaudit::model::Net::load(&widths, &out.join(format!("models/{model}__disjoint__1.safetensors")))
            .unwrap();
        assert_eq!(net.widths(), widths);
        assert_eq!((net.fused().inputs(), net.fused().outputs()), (18, 14));
    }
    assert!(out.join("cells.csv").is_file());
}

/// Issue 57: a parameter-free model in a secondary endpoint is the same
/// model in both arms; the report says its contrast is 0 by construction
/// and where the model does enter (the interaction), instead of calling its
/// per-cell data "not the output of a run".
#[test]
fn a_baseline_in_an_endpoint_is_reported_as_zero_by_construction() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("tests/designs/sim_small.design"))
        .unwrap()
        .replace("model relative = mlp(32, 32, 32) inputs relative", "model cv = constant_velocity")
        .replace("models world, relative", "models world, cv")
        .replace("interaction world - relative", "interaction world - cv")
        .replace("epochs 15 cosine patience 15", "epochs 2 cosine patience 2");
    let design = dir.path().join("cv.design");
    std::fs::write(&design, text).unwrap();
    let out = dir.path().join("run");
    let o = crate::common::bin()
        .args(["run", design.to_str().unwrap(), "--out", out.to_str().unwrap(), "--exploratory", "--workers", "2"])
        .output()
        .unwrap();
    crate::common::assert_ok(&o);
    let md = std::fs::read_to_string(out.join("report/report.md")).unwrap();
    assert!(
        md.contains("`cv` is parameter-free (constant_velocity): it is the same model in every arm, so `contaminated - disjoint` is 0 by construction")
            && md.contains("the reference level of `world - cv`"),
        "{md}"
    );
    assert!(!md.contains("not the output of a run"), "{md}");
    assert!(md.contains("| world - cv |"), "the interaction is reported:\n{md}");
}

/// A seed-invariant contrast (the paper's closed-form linear models: every
/// seed gives the same cells) takes its df from the recordings in every
/// sensitivity as in its primary fit: leaving one seed out changes nothing,
/// so each leave-one-seed-out fit is the primary fit itself (the closed
/// form: mean of the per-recording d, SE = sd / sqrt(I), df = I - 1), and a
/// leave-one-recording-out fit has df I - 2. Before, the closed form used
/// the design's `df seed - 1` there, with an upper bound that moved.
#[test]
fn a_seed_invariant_contrast_keeps_recording_df_when_a_seed_is_left_out() {
    let a = crossaudit::analyze_files(
        std::path::Path::new("designs/nanobench_paper_linear.design"),
        &root().join("results/nanobench_paper_linear/cells.csv"),
        Default::default(),
    )
    .unwrap();
    let mut checked = 0;
    for u in a.units.iter().filter(|u| u.seed_invariant) {
        let seed = u.leave_one_out.iter().find(|l| l.factor == crossaudit::design::Factor::Seed).unwrap();
        assert_eq!(u.estimate.df, (a.recordings.len() - 1) as f64, "{}", u.model);
        assert!(
            (seed.upper_min - u.estimate.upper).abs() < 1e-12,
            "{}: {} vs {}",
            u.model,
            seed.upper_min,
            u.estimate.upper
        );
        assert!(
            (seed.upper_max - u.estimate.upper).abs() < 1e-12,
            "{}: {} vs {}",
            u.model,
            seed.upper_max,
            u.estimate.upper
        );
        assert!((seed.mean_min - u.estimate.mean).abs() < 1e-12 && (seed.mean_max - u.estimate.mean).abs() < 1e-12);
        checked += 1;
    }
    assert!(checked >= 1, "no seed-invariant unit");
}
