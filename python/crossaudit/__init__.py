"""crossaudit from Python: preregistered, leakage-aware evaluation of learned
dynamics models.

A study is a ``.design`` file. This package loads and checks designs, runs
the built-in models, exports what your own model (any framework) needs to
be fitted under the design's locked split, scores its rollouts with the
same failure-aware metrics and crossed statistics as the built-in models,
reanalyses per-cell data and audits published splits.

The usual loop for a model of your own (``model NAME = external inputs
world`` in the design)::

    import crossaudit
    ex = crossaudit.export("study.design", "out/study")
    for job in ex.jobs.itertuples():
        fit = ex.fit(job.arm, model=job.model)        # dict of NumPy arrays
        ...                                           # train with job.seed
        ex.write_predictions(job.model, job.arm, job.seed, trajectories)
    result = crossaudit.score("out/study")
    result.estimates                                  # pandas DataFrame

Every error crossaudit reports is raised as :class:`CrossauditError`
with the command line's message (a design error names its file, line and
column).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import pandas as pd

from . import _native
from ._native import CrossauditError

__all__ = [
    "CrossauditError",
    "Design",
    "Export",
    "Result",
    "analyze",
    "audit_split",
    "simsum",
    "build",
    "export",
    "load_design",
    "open_export",
    "read_cells",
    "run",
    "score",
]

PathLike = Union[str, "os.PathLike[str]"]

#: NanoBench's 14 state columns, in order (a ``data csv`` design names its
#: own: ``Export.index["state_columns"]``).
STATE_COLUMNS = ["x", "y", "z", "vx", "vy", "vz", "qw", "qx", "qy", "qz", "ref_x", "ref_y", "ref_z", "battery"]


def build() -> str:
    """The crossaudit build (version and commit) behind this package."""
    return _native.build()


@dataclass
class Design:
    """A validated design: its path, SHA-256, lock state and compiled plan."""

    path: str
    sha256: str
    lock: str
    plan: dict
    plan_text: str
    validated: dict = field(repr=False)

    @property
    def jobs(self) -> pd.DataFrame:
        """One row per job (model x arm x seed): model, kind, arm, seed, horizons."""
        rows = [
            {
                "model": j["model"],
                "kind": j["kind"]["kind"],
                "arm": j["arm"],
                "seed": j["seed"],
                "horizons_s": j["horizons_s"],
            }
            for j in self.plan["training_cells"]
        ]
        return pd.DataFrame(rows, columns=["model", "kind", "arm", "seed", "horizons_s"])

    @property
    def external_models(self) -> List[str]:
        """Names of the models fitted outside crossaudit."""
        return [m["name"] for m in self.plan["models"] if m["kind"]["kind"] == "external"]

    def __str__(self) -> str:
        return self.plan_text


def load_design(path: PathLike) -> Design:
    """Loads and validates a design; raises CrossauditError with the located
    message (``file:line:column``) if it is invalid."""
    d = json.loads(_native.load_design(os.fspath(path)))
    return Design(d["path"], d["sha256"], d["lock"], d["plan"], d["plan_text"], d["validated"])


def _load(path: Path) -> np.ndarray:
    return np.load(path, allow_pickle=False)


class Export:
    """An export written by :func:`export` (``DIR/export/``): the windows,
    standardizers and rollout starts of every external job, and where its
    predictions go."""

    def __init__(self, directory: PathLike):
        self.directory = Path(directory)
        path = self.directory / "export" / "export.json"
        try:
            raw = path.read_bytes()
        except OSError as e:
            raise CrossauditError(f"{path}: {e}; run crossaudit.export(design, dir) first") from None
        #: SHA-256 of export.json, which every predictions description quotes.
        self.sha256 = hashlib.sha256(raw).hexdigest()
        #: The index, as written.
        self.index = json.loads(raw)

    def _array(self, name: str) -> np.ndarray:
        return _load(self.directory / "export" / name)

    @property
    def jobs(self) -> pd.DataFrame:
        """One row per external job: model, arm, seed, inputs, actions,
        history, steps, predictions (the file to write)."""
        cols = ["model", "arm", "seed", "inputs", "actions", "history", "steps", "predictions"]
        return pd.DataFrame([{c: j[c] for c in cols} for j in self.index["jobs"]], columns=cols)

    def job(self, model: str, arm: str, seed: int) -> dict:
        """The index entry of one job."""
        for j in self.index["jobs"]:
            if (j["model"], j["arm"], j["seed"]) == (model, arm, int(seed)):
                return j
        raise CrossauditError(f"no external job {model}/{arm}/{seed} in {self.directory}/export/export.json")

    def _model_job(self, arm: str, model: Optional[str]) -> dict:
        for j in self.index["jobs"]:
            if j["arm"] == arm and (model is None or j["model"] == model):
                return j
        raise CrossauditError(f"no external job of arm {arm!r}" + (f" and model {model!r}" if model else ""))

    def fit(self, arm: str, model: Optional[str] = None) -> Dict[str, np.ndarray]:
        """The arm's fit windows: ``states`` (N x D), ``actions`` (N x A),
        ``next_states`` (N x D), ``history`` (N x H x (D + A)) when declared,
        and for ``model`` its standardized ``inputs`` (N x (D + A)) and
        ``targets`` (N x D). D and A are the data's state and action
        dimensions (NanoBench: 14 and 4; ``index["state_columns"]``)."""
        files = self.index["fit"].get(arm)
        if files is None:
            raise CrossauditError(f"no arm {arm!r}; arms: {', '.join(self.index['fit'])}")
        out = {k: self._array(v) for k, v in files.items()}
        if model is not None:
            j = self._model_job(arm, model)
            out["inputs"] = self._array(j["files"]["fit_inputs"])
            out["targets"] = self._array(j["files"]["fit_targets"])
        return out

    def validation(self, arm: Optional[str] = None, model: Optional[str] = None) -> Dict[str, np.ndarray]:
        """The shared validation windows (as :meth:`fit`); with ``arm`` and
        ``model``, their inputs and targets through that arm's standardizers."""
        out = {k: self._array(v) for k, v in self.index["validation"].items()}
        if arm is not None and model is not None:
            j = self._model_job(arm, model)
            out["inputs"] = self._array(j["files"]["validation_inputs"])
            out["targets"] = self._array(j["files"]["validation_targets"])
        return out

    def starts(self) -> Dict[str, Union[np.ndarray, pd.DataFrame]]:
        """The registered rollout starts: ``states`` (S x D), ``actions``
        (S x K x A: u at steps 0..K-1), ``exogenous`` (S x K x E: the
        measured exogenous state at steps 1..K, which the rollout
        overwrites; NanoBench: reference and battery, columns
        ``index["exogenous_columns"]``), ``history`` (S x H x (D + A)) when
        declared, and ``table`` (recording, sample index, trajectory, speed)."""
        out: Dict[str, Union[np.ndarray, pd.DataFrame]] = {}
        for k, v in self.index["start_files"].items():
            out[k] = pd.read_csv(self.directory / "export" / v) if k == "table" else self._array(v)
        return out

    def standardizers(self, model: str, arm: str) -> dict:
        """The standardizers of ``model``'s inputs and targets on ``arm``
        (``input``/``target`` mean and std), as a built-in MLP would fit them."""
        return self._model_job(arm, model)["standardizers"]

    def write_predictions(self, model: str, arm: str, seed: int, trajectories: np.ndarray) -> Path:
        """Writes one job's predicted trajectories (starts x steps x D states
        at steps 1..K, float64) with its description; checks the shape first."""
        j = self.job(model, arm, seed)
        p = np.ascontiguousarray(np.asarray(trajectories, dtype="<f8"))
        if list(p.shape) != list(j["shape"]):
            raise CrossauditError(
                f"predictions for {model}/{arm}/{seed} have shape {list(p.shape)}, expected {j['shape']} "
                "(starts x steps x state columns)"
            )
        path = self.directory / j["predictions"]
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".npy.tmp")
        with open(tmp, "wb") as f:
            np.save(f, p, allow_pickle=False)
        os.replace(tmp, path)
        desc = {"export_sha256": self.sha256, "model": model, "arm": arm, "seed": int(seed)}
        (self.directory / j["description"]).write_text(json.dumps(desc))
        return path


def export(design: PathLike, out: PathLike, data: Optional[PathLike] = None, exploratory: bool = False) -> Export:
    """``crossaudit export``: opens ``out`` as a run does (lock, audit, split,
    manifests, invariants) and writes every external job's windows,
    standardizers and starts to ``out/export``."""
    _native.export(os.fspath(design), os.fspath(out), None if data is None else os.fspath(data), exploratory)
    return Export(out)


def open_export(directory: PathLike) -> Export:
    """An export already written into ``directory``."""
    return Export(directory)


@dataclass
class Result:
    """What :func:`score`, :func:`run` or :func:`analyze` produced."""

    decision: str
    holds: bool
    estimates: pd.DataFrame
    results: dict = field(repr=False)
    #: What the report gives beside the verdict (condition coverage, early
    #: stopping, a reference arm that is not disjoint, a fragile decision),
    #: one paragraph each, as the console prints them under the decision.
    guards: list = field(default_factory=list)
    cells: Optional[pd.DataFrame] = None
    report_dir: Optional[Path] = None
    details: dict = field(default_factory=dict, repr=False)


def _tidy(text: str) -> pd.DataFrame:
    """The report's tidy table (``estimates.csv``, or a multiverse's
    ``specs.csv``) as a DataFrame: the same columns and rows the command
    line writes, so one set of names serves R, pandas and this package."""
    return pd.read_csv(io.StringIO(text))


def read_cells(path: PathLike) -> pd.DataFrame:
    """A per-cell CSV (``cells.csv``) as a DataFrame, one row per model x arm
    x seed x recording x horizon."""
    return pd.read_csv(path)


def _finished(d: dict) -> Result:
    report = Path(d["report_dir"])
    # A multiverse's (or draw replication's) combined report is
    # multiverse.json where a single or family study's is results.json.
    results_json = report / "results.json" if (report / "results.json").is_file() else report / "multiverse.json"
    results = json.loads(results_json.read_text())
    # A multiverse's report has specs.csv where a single or family study's
    # has estimates.csv.
    table = report / "estimates.csv" if (report / "estimates.csv").is_file() else report / "specs.csv"
    return Result(
        decision=d["decision"],
        holds=d["holds"],
        estimates=_tidy(table.read_text()),
        results=results,
        guards=d.get("guards", []),
        cells=read_cells(d["cells_csv"]),
        report_dir=report,
        details=d,
    )


def score(directory: PathLike, workers: Optional[int] = None) -> Result:
    """``crossaudit score``: checks and scores the predictions in
    ``directory/predictions``, runs the design's built-in models, writes
    cells.csv and the report, and returns the estimates."""
    return _finished(json.loads(_native.score(os.fspath(directory), workers)))


def run(
    design: PathLike,
    out: PathLike,
    data: Optional[PathLike] = None,
    workers: Optional[int] = None,
    exploratory: bool = False,
    device: str = "cpu",
) -> Result:
    """``crossaudit run``: the whole study with the built-in models.
    ``device`` is ``run --device``'s: ``"cpu"`` (the default), ``"cuda"``
    (refused where no usable NVIDIA GPU is found) or ``"auto"`` (the GPU
    where one is found, else the CPU, said in a warning)."""
    d = _native.run(
        os.fspath(design), os.fspath(out), None if data is None else os.fspath(data), workers, exploratory, device
    )
    return _finished(json.loads(d))


def analyze(
    design: PathLike,
    cells: Union[PathLike, pd.DataFrame],
    out: Optional[PathLike] = None,
    compare_intervals: bool = False,
) -> Result:
    """The design's preregistered analysis of any study: per-cell data (a
    CSV path or a DataFrame with the per-cell columns) of a single-contrast,
    dose-response or multi-split design, or the run directory of a
    multiverse or draw-replicated one; writes the report to ``out`` if
    given. ``estimates`` is the tidy table the report writes
    (``estimates.csv`` of a single study or a family, ``specs.csv`` of a
    multiverse), with the same columns and rows; ``details["kind"]`` says
    which kind of study it is. ``compare_intervals=True`` adds every interval
    estimator for each contrast, as ``--compare-intervals`` does (rows of
    ``estimates``; one the array does not allow has NaN limits)."""
    if isinstance(cells, pd.DataFrame):
        import tempfile

        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "cells.csv"
            cells.to_csv(path, index=False)
            return analyze(design, path, out, compare_intervals)
    text, line, holds, kind, table, guards = _native.analyze(
        os.fspath(design), os.fspath(cells), None if out is None else os.fspath(out), compare_intervals
    )
    results = json.loads(text)
    estimates = _tidy(table)
    # A multiverse is analysed from its run directory; its per-cell rows are
    # multiverse_cells.csv there. Any other run folder's are its cells.csv.
    if kind == "multiverse":
        cells_path = Path(cells) / "multiverse_cells.csv"
    elif Path(cells).is_dir():
        cells_path = Path(cells) / "cells.csv"
    else:
        cells_path = Path(cells)
    return Result(
        decision=line,
        holds=holds,
        estimates=estimates,
        results=results,
        guards=guards,
        cells=read_cells(cells_path) if cells_path.is_file() else None,
        report_dir=None if out is None else Path(out),
        details={"kind": kind},
    )


def audit_split(
    split: PathLike,
    data: PathLike,
    out: PathLike,
    design: Optional[PathLike] = None,
    min_run: int = 100,
    gap: float = 1.0,
) -> dict:
    """``crossaudit audit split``: audits a published split (whole recordings
    or windows) against the flight logs in ``data``; returns the audit
    (split_audit.json), its per-recording table as ``recordings`` and each
    window's nearest window of another role as ``windows`` (DataFrames),
    ``exact_leak`` (copies or overlapping windows across roles) and
    ``gap_violation`` (a window within ``gap`` seconds of another role's)."""
    paths, leak, close = _native.audit_split(
        os.fspath(split), os.fspath(data), os.fspath(out), None if design is None else os.fspath(design), min_run, gap
    )
    audit: dict = {}
    tables = {}
    for p in map(Path, paths):
        if p.suffix == ".json":
            audit = json.loads(p.read_text())
        elif p.name == "split_recordings.csv":
            tables["recordings"] = pd.read_csv(p)
        elif p.name == "split_windows.csv":
            tables["windows"] = pd.read_csv(p)
    audit.update(tables)
    audit["exact_leak"] = leak
    audit["gap_violation"] = close
    audit["files"] = [str(p) for p in paths]
    return audit


def simsum(
    file: PathLike,
    out: PathLike,
    true: Union[float, str],
    estimate: str = "estimate",
    se: str = "se",
    method: str = "method",
    rep: Optional[str] = None,
    by: Sequence[str] = (),
    level: Union[float, str] = 0.95,
    ci: Optional[Tuple[str, str]] = None,
    df: Optional[str] = None,
    ref: Optional[str] = None,
    target_mcse: Optional[dict] = None,
) -> pd.DataFrame:
    """``crossaudit simsum``: every rsimsum measure with its Monte Carlo SE
    from a replications CSV (one row per method and replication), methods
    paired by replication id (``rep``), paired MCSEs against the reference
    method, the interval score, an Agresti-Coull coverage MCSE and, with
    ``target_mcse={"cover": 0.005}``, the replications each measure needs.
    ``true`` and ``level`` are numbers or column names. Writes simsum.csv
    and simsum.md into ``out``; returns simsum.csv as a DataFrame (as
    rsimsum's ``tidy()``: by-columns, true, level, method, stat, est, mcse)."""
    targets = None if not target_mcse else ",".join(f"{k}={v}" for k, v in target_mcse.items())
    paths = _native.simsum(
        os.fspath(file), os.fspath(out), str(true), estimate, se, method, rep, list(by), str(level),
        None if ci is None else (ci[0], ci[1]), df, ref, targets,
    )
    return pd.read_csv(paths[0], keep_default_na=True)
