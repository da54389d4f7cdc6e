"""The Python package on the simulated quickstart, end to end with a model
of our own: a ridge regression in NumPy, fitted on the exported windows of
each arm, rolled out open loop from the registered starts, written as
predictions, scored and analysed. No torch; seconds."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import crossaudit

# The quickstart with its world model external and persistence beside it
# (no built-in training: the package's debug-level build stays quick).
EXTERNAL = "tests/designs/quickstart_ridge.design"


def ridge_fit(inputs: np.ndarray, targets: np.ndarray, lam: float = 1e-3) -> np.ndarray:
    """Least squares with an intercept and a small ridge penalty."""
    x = np.hstack([inputs, np.ones((len(inputs), 1))])
    return np.linalg.solve(x.T @ x + lam * np.eye(x.shape[1]), x.T @ targets)


def rollout(weights: np.ndarray, std: dict, starts: dict, steps: int) -> np.ndarray:
    """Open-loop rollout of the world-frame ridge model: the standardized
    state and raw actions in, the state-scaled increment out."""
    mean_in, sd_in = np.array(std["input"]["mean"]), np.array(std["input"]["std"])
    mean_t, sd_t = np.array(std["target"]["mean"]), np.array(std["target"]["std"])
    x = starts["states"].copy()
    out = np.empty((x.shape[0], steps, 14))
    for k in range(steps):
        raw = np.hstack([x, starts["actions"][:, k, :]])
        z = np.hstack([(raw - mean_in) / sd_in, np.ones((len(x), 1))]) @ weights
        x = x + z * sd_t + mean_t
        x[:, 10:14] = starts["exogenous"][:, k, :]  # measured reference and battery
        x[:, 6:10] /= np.linalg.norm(x[:, 6:10], axis=1, keepdims=True)
        out[:, k, :] = x
    return out


def test_load_design_gives_the_plan_and_located_errors(tmp_path):
    d = crossaudit.load_design(EXTERNAL)
    assert d.external_models == ["world"]
    jobs = d.jobs
    assert len(jobs) == 20 and set(jobs["kind"]) == {"external", "persistence"}
    assert "external inputs world" in str(d)
    bad = tmp_path / "bad.design"
    bad.write_text(Path(EXTERNAL).read_text().replace("external inputs world", "external inputs sideways"))
    with pytest.raises(crossaudit.CrossauditError) as e:
        crossaudit.load_design(bad)
    assert f"{bad}:" in str(e.value) and "sideways" in str(e.value)


def test_a_numpy_ridge_model_through_export_score_and_analyze(tmp_path, workers):
    out = tmp_path / "study"
    ex = crossaudit.export(EXTERNAL, out)
    assert len(ex.sha256) == 64
    assert list(ex.jobs.columns[:3]) == ["model", "arm", "seed"] and len(ex.jobs) == 10
    starts = ex.starts()
    assert starts["states"].shape == (300, 14) and starts["actions"].shape == (300, 100, 4)
    assert list(starts["table"].columns) == ["index", "recording", "sample_index", "trajectory", "speed"]
    val = ex.validation("disjoint", "world")
    assert val["inputs"].shape[1] == 18 and val["targets"].shape[1] == 14
    for job in ex.jobs.itertuples():
        fit = ex.fit(job.arm, model=job.model)
        assert fit["inputs"].shape == (8000, 18) and fit["states"].shape == (8000, 14)
        w = ridge_fit(fit["inputs"], fit["targets"])
        traj = rollout(w, ex.standardizers(job.model, job.arm), starts, job.steps)
        ex.write_predictions(job.model, job.arm, job.seed, traj)
    result = crossaudit.score(out, workers=workers)
    assert result.details["scored"] == 10 and result.details["trained"] == 10  # persistence: 10 jobs
    assert "decision: " in result.decision
    est = result.estimates
    # The report's own estimates.csv, row for row and column for column.
    pd.testing.assert_frame_equal(est, pd.read_csv(result.report_dir / "estimates.csv"))
    # Each endpoint's preregistered estimator's row carries the arm means.
    endpoints = est[(est["kind"] == "endpoint") & est["treated_mean"].notna()]
    primary = endpoints[endpoints["role"] == "primary"].iloc[0]
    assert primary["model"] == "world" and primary["horizon_s"] == 1.0
    assert primary["lower"] <= primary["estimate"] <= primary["upper"]
    # The optimism's Fieller interval holds the optimism.
    fieller = est[(est["kind"] == "optimism") & (est["role"] == "primary") & (est["estimator"] == "fieller")].iloc[0]
    assert fieller["lower"] <= primary["optimism_pct"] <= fieller["upper"]
    # The rule decides on the primary endpoint alone: the other rows leave
    # rule_holds empty.
    assert endpoints[endpoints["role"] != "primary"]["rule_holds"].isna().all()
    assert primary["rule_holds"] == result.holds
    # The estimate is the mean of the per-cell differences (crossed design, balanced).
    cells = result.cells
    w1 = cells[(cells.model == "world") & (cells.horizon_s == 1.0)]
    piv = w1.pivot_table(index=["recording", "seed"], columns="arm", values="fa_position_rmse_m")
    assert primary["estimate"] == pytest.approx((piv["contaminated"] - piv["disjoint"]).mean(), rel=1e-12)
    assert (result.report_dir / "report.md").read_text().count("fitted outside crossaudit") >= 1

    # The same cells analysed again give the same estimates.
    again = crossaudit.analyze(EXTERNAL, out / "cells.csv")
    pd.testing.assert_frame_equal(again.estimates, result.estimates)
    assert again.decision == result.decision
    from_frame = crossaudit.analyze(EXTERNAL, crossaudit.read_cells(out / "cells.csv"))
    # Cells alone carry no run evidence: the coverage guard's rows (kind
    # `coverage`, from the run folder's split audit) are the run's only.
    run_rows = result.estimates[result.estimates["kind"] != "coverage"]
    assert from_frame.estimates["estimate"].tolist() == run_rows["estimate"].tolist()
    assert (from_frame.estimates["kind"] != "coverage").all()


def test_predictions_are_checked_before_they_are_written(tmp_path):
    ex = crossaudit.export(EXTERNAL, tmp_path / "study")
    job = ex.jobs.iloc[0]
    with pytest.raises(crossaudit.CrossauditError, match="expected \\[300, 100, 14\\]"):
        ex.write_predictions(job.model, job.arm, job.seed, np.zeros((300, 99, 14)))
    with pytest.raises(crossaudit.CrossauditError, match="no external job"):
        ex.write_predictions("relative", job.arm, job.seed, np.zeros((300, 100, 14)))
    # score names what is missing and keeps what is there.
    ex.write_predictions(job.model, job.arm, job.seed, np.repeat(ex.starts()["states"][:, None, :], 100, axis=1))
    with pytest.raises(crossaudit.CrossauditError, match="9 of 10 external jobs have no predictions"):
        crossaudit.score(tmp_path / "study")
    # A file edited after export is refused by name.
    f = tmp_path / "study" / "export" / "starts_states.npy"
    a = np.load(f)
    a[0, 0] += 1.0
    np.save(f, a)
    with pytest.raises(crossaudit.CrossauditError, match="starts_states.npy"):
        crossaudit.score(tmp_path / "study")


def test_run_device_is_checked_before_anything_is_written(root, tmp_path):
    with pytest.raises(crossaudit.CrossauditError, match="unknown device `gpu`"):
        crossaudit.run(root / "designs/quickstart.design", tmp_path / "x", device="gpu")
    try:
        import ctypes

        ctypes.CDLL("libcuda.so.1")
        return  # a GPU machine: scripts/gpu-check.sh checks the GPU side
    except OSError:
        pass
    with pytest.raises(crossaudit.CrossauditError, match="no usable NVIDIA GPU"):
        crossaudit.run(root / "designs/quickstart.design", tmp_path / "x", device="cuda")
    assert not (tmp_path / "x").exists()


def test_run_refuses_external_and_analyze_reads_example_cells(root, tmp_path):
    with pytest.raises(crossaudit.CrossauditError, match="crossaudit export"):
        crossaudit.run(EXTERNAL, tmp_path / "x")
    assert not (tmp_path / "x").exists()
    r = crossaudit.analyze("designs/nanobench_confirmatory.design", root / "examples/cells/nanobench_synthetic.csv")
    # The decision the README quotes for this example.
    assert r.decision.startswith("decision: NOT CONFIRMED") and not r.holds, r.decision
    committed = json.loads((root / "results/example/results.json").read_text())
    assert r.estimates["estimate"].iloc[0] == pytest.approx(committed["units"][0]["estimate"]["mean"], rel=1e-12)
    # The guard beside the verdict, as the console prints it under the decision.
    assert any(g.startswith("The data do not determine the side of the threshold") for g in r.guards), r.guards
    # From a run folder: the reference arm's condition coverage too (the
    # quickstart's stratified draw covers every evaluated condition).
    q = crossaudit.analyze(root / "designs/quickstart.design", root / "results/quickstart")
    assert any(g.startswith("Condition coverage: the reference arm") for g in q.guards), q.guards
    assert q.cells is not None and len(q.cells) > 0, "a run folder's cells.csv is read"
    # A folder `crossaudit combine` wrote: both runs' guards (issue 72).
    c = crossaudit.analyze(root / "designs/multiverse/paper_per_seed_combined.design",
                           root / "results/multiverse/per_seed_combined")
    assert any(g.startswith("The reference arm is not disjoint") for g in c.guards), c.guards
    assert any(g.startswith("Early stopping") for g in c.guards), c.guards


def test_audit_split_matches_the_command_line(root, tmp_path):
    import subprocess, os

    split, data = root / "tests/fixtures/splits/nanobench_small.json", root / "tests/fixtures/splits/data"
    a = crossaudit.audit_split(split, data, tmp_path / "py")
    assert isinstance(a["exact_leak"], bool) and isinstance(a["recordings"], pd.DataFrame)
    assert len(a["recordings"]) > 0
    binary = os.environ.get("CROSSAUDIT_BIN")
    if binary:
        subprocess.run([binary, "audit", "split", str(split), "--data", str(data), "--out", str(tmp_path / "cli")], check=False)
        assert (tmp_path / "cli/split_audit.json").read_bytes() == (tmp_path / "py/split_audit.json").read_bytes()


def test_audit_split_reads_a_per_window_split(root, tmp_path):
    """tests/fixtures/splits/windows.csv, whose distances tests/split_windows.rs
    works out by hand: of 5 test windows, 4 share a recording with train, 1
    overlaps a train window, 3 lie within 1 s (2 within 0.4 s)."""
    split, data = root / "tests/fixtures/splits/windows.csv", root / "tests/fixtures/splits/data"
    a = crossaudit.audit_split(split, data, tmp_path / "w", gap=0.4)
    assert a["windowed"] and a["exact_leak"] and a["gap_violation"]
    test = next(d for d in a["distances"] if d["role"] == "test")
    assert (test["windows"], test["in_shared_recording"], test["overlapping"], test["within_gap"]) == (5, 4, 1, 2)
    w = a["windows"]
    assert list(w[w.role == "test"].distance_s) == [0.0, 0.5, 0.0, 1.5]
    assert len(a["recordings"]) == 10 and "listed_as" in a["recordings"].columns
    with pytest.raises(crossaudit.CrossauditError, match="above 0"):
        crossaudit.audit_split(split, data, tmp_path / "w2", gap=0.0)


def test_analyze_takes_every_kind_of_study_and_matches_the_committed_reports(root, tmp_path):
    """A dose-response family's per-cell file, a multiverse's run folder and a
    per-seed-draw run's per-cell file, each analysed by the package as the
    command line analyses it: the same decision and the same estimates as
    the committed reports (results/dose_response, results/multiverse/paper,
    results/multiverse/per_seed)."""
    numeric = ["estimate", "se", "lower", "upper"]
    dose = crossaudit.analyze(
        root / "designs/nanobench_dose_response.design", root / "results/dose_response/cells.csv", tmp_path / "dose"
    )
    assert dose.details["kind"] == "family"
    committed = pd.read_csv(root / "results/dose_response/report/estimates.csv")
    assert list(dose.estimates.columns) == list(committed.columns)
    pd.testing.assert_frame_equal(dose.estimates[numeric], committed[numeric], rtol=1e-12)
    assert dose.decision in (root / "results/dose_response/report/report.md").read_text()

    multiverse = crossaudit.analyze(root / "designs/multiverse/paper_multiverse.design", root / "results/multiverse/paper")
    assert multiverse.details["kind"] == "multiverse" and multiverse.report_dir is None
    committed = pd.read_csv(root / "results/multiverse/paper/report/specs.csv")
    assert list(multiverse.estimates["spec"]) == list(committed["spec"])
    for column in ["estimate", "se", "lower", "upper"]:
        assert multiverse.estimates[column].tolist() == pytest.approx(committed[column].tolist(), rel=1e-12)
    assert len(multiverse.cells) > 0

    per_seed = crossaudit.analyze(
        root / "designs/multiverse/paper_per_seed.design", root / "results/multiverse/per_seed/cells.csv"
    )
    assert per_seed.details["kind"] == "single"
    committed = json.loads((root / "results/multiverse/per_seed/report/results.json").read_text())
    assert per_seed.estimates["estimate"].iloc[0] == pytest.approx(committed["units"][0]["estimate"]["mean"], rel=1e-12)
    assert per_seed.holds == committed["decision"]["holds"]


def test_simsum_matches_the_command_line_and_rsimsum(root, tmp_path):
    """crossaudit's own replications through the package: the same
    simsum.csv as the committed results/simsum_rsimsum (which
    tests/simsum.rs checks against rsimsum 0.13), and a bad column named."""
    reps = root / "results/coverage_rsimsum/replications.csv"
    t = crossaudit.simsum(reps, tmp_path / "s", true="true_mean", level="level", by=["setting", "true_mean"],
                          ci=("ci_lower", "ci_upper"), rep="rep", target_mcse={"cover": 0.005, "bias": 0.02})
    assert list(t.columns) == ["setting", "true_mean", "true", "level", "method", "stat", "est", "mcse"]
    committed = (root / "results/simsum_rsimsum/simsum.csv").read_bytes()
    assert (tmp_path / "s/simsum.csv").read_bytes() == committed
    cover = t[(t.method == "MomT") & (t.stat == "cover")]
    raw = pd.read_csv(reps)
    groups = raw[raw.method == "MomT"][["setting", "true_mean", "level"]].drop_duplicates()
    assert len(cover) == len(groups) > 0 and cover.est.between(0, 1).all()
    with pytest.raises(crossaudit.CrossauditError, match="no column `theta`"):
        crossaudit.simsum(reps, tmp_path / "bad", true="theta")


def test_analyze_compares_every_interval_as_the_command_line_does(root, tmp_path):
    """results/example was written by ``analyze --compare-intervals``: the
    package's estimates with ``compare_intervals=True`` are its
    estimates.csv, every further interval included."""
    r = crossaudit.analyze(root / "designs/nanobench_confirmatory.design",
                           root / "examples/cells/nanobench_synthetic.csv", compare_intervals=True)
    committed = pd.read_csv(root / "results/example/estimates.csv")
    assert len(r.estimates) == len(committed)
    assert list(r.estimates["estimator"]) == list(committed["estimator"])
    numeric = ["estimate", "se", "lower", "upper"]
    pd.testing.assert_frame_equal(r.estimates[numeric], committed[numeric], rtol=1e-12)
    assert (committed["estimator"] == "profile_ml").any() and (committed["estimator"] == "two_way_cluster").any()


def test_run_of_a_multiverse_returns_its_combined_report(root, tmp_path, workers):
    """Issue 73: ``run()`` of a multiverse trained everything and then
    raised FileNotFoundError on report/results.json; its combined report is
    multiverse.json and specs.csv, which the result now carries."""
    text = (root / "tests/designs/sim_small.design").read_text()
    text = text.replace("epochs 15 ", "").replace("crossed_mom level 0.95 ", "crossed_mom ")
    text += "choices {\n  epochs 15 | 12\n}\nprimary specification epochs 15\n"
    design = tmp_path / "m.design"
    design.write_text(text)
    r = crossaudit.run(design, tmp_path / "run", workers=workers)
    assert r.results["decision"]["name"] == "confirmed", r.results["decision"]
    assert list(r.estimates["spec"]) == ["s1", "s2"], r.estimates
    assert len(r.cells) > 0 and "spec" in r.cells.columns
    assert r.decision.startswith(("decision:", "NOT PREREGISTERED")), r.decision
