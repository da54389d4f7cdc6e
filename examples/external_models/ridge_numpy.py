"""Your own model through crossaudit in a minute: a ridge regression in
NumPy, fitted on each arm's exported windows, rolled out open loop from the
registered starts, written as predictions and scored.

    python3 -m pip install ./python          # compiles the crate (minutes, once)
    python3 examples/external_models/ridge_numpy.py out/ridge

The design is designs/external/simulated_ridge.design (the simulated
quickstart, its world model external, persistence beside it): no data to
download, nothing for crossaudit to train. The same code is checked by
python/tests/test_package.py."""

import sys

import numpy as np

import crossaudit

DESIGN = "designs/external/simulated_ridge.design"


def ridge_fit(inputs: np.ndarray, targets: np.ndarray, lam: float = 1e-3) -> np.ndarray:
    """Least squares with an intercept and a small ridge penalty."""
    x = np.hstack([inputs, np.ones((len(inputs), 1))])
    return np.linalg.solve(x.T @ x + lam * np.eye(x.shape[1]), x.T @ targets)


def rollout(weights: np.ndarray, std: dict, starts: dict, steps: int, exogenous: list) -> np.ndarray:
    """Open loop from every start: the standardized state and actions in,
    the exported target (an increment) out, added to the state."""
    mean_in, sd_in = np.array(std["input"]["mean"]), np.array(std["input"]["std"])
    mean_t, sd_t = np.array(std["target"]["mean"]), np.array(std["target"]["std"])
    x = starts["states"].copy()
    out = np.empty((x.shape[0], steps, x.shape[1]))
    for k in range(steps):
        raw = np.hstack([x, starts["actions"][:, k, :]])
        z = np.hstack([(raw - mean_in) / sd_in, np.ones((len(x), 1))]) @ weights
        x = x + z * sd_t + mean_t
        x[:, exogenous] = starts["exogenous"][:, k, :]  # measured (NanoBench: reference and battery)
        x[:, 6:10] /= np.linalg.norm(x[:, 6:10], axis=1, keepdims=True)  # unit quaternion
        out[:, k, :] = x
    return out


def main(out: str) -> None:
    ex = crossaudit.export(DESIGN, out)
    starts = ex.starts()
    exogenous = ex.index["exogenous_columns"]
    for job in ex.jobs.itertuples():
        fit = ex.fit(job.arm, model=job.model)
        w = ridge_fit(fit["inputs"], fit["targets"])
        ex.write_predictions(job.model, job.arm, job.seed, rollout(w, ex.standardizers(job.model, job.arm), starts, job.steps, exogenous))
        print(f"fitted and rolled out {job.model}/{job.arm}/{job.seed}")
    result = crossaudit.score(out)
    print(result.decision)
    print(f"report: {result.report_dir / 'report.html'}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "out/ridge")
