"""The run checkpoint of :func:`learned.experiment.run_experiment`: one file, rewritten after every time step.

``<out>/checkpoint.pt`` (tensors and JSON through :mod:`learned.safe_io`, no pickle) holds where
the run is (the next strategy x network x repeat unit and its next time step), the finished units'
records, and, mid-unit, the strategy's state (:meth:`learned.strategies.Strategy.state_dict`:
weights, replay buffer, numpy generator, counters) and its partial record; always torch's global
random state. A rerun with the same ``--out`` and the same run (the :func:`fingerprint`) resumes
from it; the networks of finished units are read back from ``<out>/<strategy>/<network>.pt``.
"""

from __future__ import annotations

import json
from pathlib import Path

import torch

from handeye.core.errors import HandEyeInputError
from learned.safe_io import load_document, save_document

__all__ = ["CHECKPOINT_NAME", "fingerprint", "save_checkpoint", "load_checkpoint", "remove_checkpoint"]

CHECKPOINT_NAME = "checkpoint.pt"
CHECKPOINT_VERSION = 1


def fingerprint(**what) -> dict:
    """The run's identity as JSON values (preset, strategies, labels, seed, family, data's time steps...)."""
    return json.loads(json.dumps(what))


def save_checkpoint(
    out: Path, run: dict, unit: int, step: int, records: list, partial: dict | None = None, strategy: dict | None = None
) -> None:
    """Write ``<out>/checkpoint.pt`` atomically.

    Parameters
    ----------
    out : Path
    run : dict
        :func:`fingerprint` of the run.
    unit, step : int
        The next unit (index into the run's strategy x network x repeat order) and its next time step.
    records : list of dict
        Finished units' records.
    partial : dict, optional
        The current unit's record so far (mid-unit only).
    strategy : dict, optional
        :meth:`learned.strategies.Strategy.state_dict` (mid-unit only).
    """
    doc = {
        "run": run,
        "unit": int(unit),
        "step": int(step),
        "records": records,
        "partial": partial,
        "torch_rng": torch.get_rng_state(),
    }
    if strategy is not None:
        doc["strategy"] = {k: v for k, v in strategy.items() if k not in ("weights", "buffer_tensors")}
        doc["strategy.weights"] = {k: v.detach().cpu() for k, v in strategy["weights"].items()}
        doc["strategy.buffer_tensors"] = strategy["buffer_tensors"]
    save_document(Path(out) / CHECKPOINT_NAME, "checkpoint", CHECKPOINT_VERSION, doc)


def load_checkpoint(out: Path, run: dict) -> dict | None:
    """The checkpoint under ``out`` (None if there is none); one of another run is refused.

    Returns
    -------
    dict or None
        ``unit``, ``step``, ``records``, ``partial``, ``torch_rng`` and, mid-unit, ``strategy`` (a state
        for :meth:`learned.strategies.Strategy.load_state_dict`).

    Raises
    ------
    HandEyeInputError
        The checkpoint belongs to a run with other settings (the differing ones named).
    """
    path = Path(out) / CHECKPOINT_NAME
    if not path.is_file():
        return None
    doc = load_document(path, "checkpoint", CHECKPOINT_VERSION)
    if doc["run"] != run:
        diff = sorted(k for k in set(run) | set(doc["run"]) if run.get(k) != doc["run"].get(k))
        raise HandEyeInputError(
            f"{path}: a checkpoint of another run (differs in {', '.join(diff)}); use another "
            "--out, or --fresh to discard it"
        )
    if "strategy" in doc:
        doc["strategy"] = dict(
            doc["strategy"],
            weights=doc.pop("strategy.weights"),
            buffer_tensors=doc.pop("strategy.buffer_tensors", None) or {},
        )
    return doc


def remove_checkpoint(out: Path) -> None:
    """Delete ``<out>/checkpoint.pt`` (the run is complete)."""
    (Path(out) / CHECKPOINT_NAME).unlink(missing_ok=True)
