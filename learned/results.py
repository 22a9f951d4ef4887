"""Reading a protocol run's ``results.json``: the document, a strategy's records, its matrices over repeats.

One place for what :mod:`learned.report`, :mod:`learned.paper_tables` and :mod:`learned.ablation` read.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.jsonfile import read_json_file

__all__ = ["NETS", "UNIT", "load_results", "runs_of", "mean_matrix", "has_rmse", "metric_key"]

#: The two rows of every table: the paper's two networks (or the keypoint model's two errors).
NETS = ("translation", "orientation")
UNIT = {"translation": "mm", "orientation": "deg"}


def load_results(run_dir: str | Path) -> dict:
    """``results.json`` of a run directory, with a clear error when it is missing or not a results file."""
    path = Path(run_dir) / "results.json"
    if not path.exists():
        raise HandEyeInputError(f"{path}: missing; run 'handeye learned run ... --out {run_dir}' first")
    doc = read_json_file(path, HandEyeInputError, "run results file", constants=True)  # NaN: a metric undefined
    if not isinstance(doc, dict) or "runs" not in doc:
        raise HandEyeInputError(f"{path}: not the results of 'handeye learned run' (no 'runs')")
    return doc


def runs_of(results: dict, strategy: str, network: str) -> list[dict]:
    """The records of one strategy and network, one per repeat."""
    return [r for r in results["runs"] if r["strategy"] == strategy and r["network"] == network]


def mean_matrix(results: dict, strategy: str, network: str, key: str = "matrix") -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation over repeats of the step x subset matrix (``key="rmse_matrix"``: of the RMS
    errors, the paper's metric)."""
    m = np.array([r[key] for r in runs_of(results, strategy, network)], dtype=float)
    return m.mean(axis=0), m.std(axis=0)


def has_rmse(results: dict) -> bool:
    """Every record carries the RMSE matrix (runs before it was recorded do not)."""
    return all(r.get("rmse_matrix") for r in results["runs"])


def metric_key(results: dict) -> str:
    """The matrix the tables lead with: ``rmse_matrix`` where the preset's metric is the RMSE and it was
    recorded, else ``matrix`` (the mean)."""
    return "rmse_matrix" if results["preset"].get("metric") == "rmse" and has_rmse(results) else "matrix"
