"""Saved files without pickle: tensors and JSON text only, read back with ``torch.load(weights_only=True)``.

A pickled file can run code when it is opened, so a model or calibrator state from someone
else would be a program. Here every file is a dict of str keys whose values are tensors, nested
dicts of tensors, or JSON text; numpy arrays travel as tensors (string arrays as JSON lists).
``torch.load(..., weights_only=True)`` refuses anything else, and a file that is not ours,
or one written by an older handeye with pickle, is refused with a named error.
"""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import numpy as np
import torch

from handeye.core.errors import HandEyeInputError

__all__ = ["SavedFileError", "save_document", "load_document", "arrays_to_tensors", "tensors_to_arrays"]

MAGIC = "handeye"


class SavedFileError(HandEyeInputError):
    """A saved model or state that is not handeye's, is damaged, or was written by an older handeye."""


def save_document(path: str | Path, kind: str, version: int, doc: dict) -> None:
    """Write ``doc`` (tensors, dicts of tensors, JSON-serialisable values) atomically.

    Parameters
    ----------
    path : str or Path
    kind : str
        What the file holds (``"model"``, ``"calibrator"``); checked when read.
    version : int
    doc : dict
        Values that are tensors (or dicts of tensors) are stored as such; the rest as one JSON text.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tensors = {
        k: v
        for k, v in doc.items()
        if isinstance(v, torch.Tensor)
        or (isinstance(v, dict) and v and all(isinstance(x, torch.Tensor) for x in v.values()))
    }
    rest = {k: v for k, v in doc.items() if k not in tensors}
    out = {"format": MAGIC, "kind": kind, "version": int(version), "json": json.dumps(rest), "tensors": tensors}
    tmp = path.with_name(path.name + ".tmp")
    torch.save(out, tmp)
    tmp.replace(path)


def load_document(path: str | Path, kind: str, version: int) -> dict:
    """Read a file written by :func:`save_document`, refusing anything else with :class:`SavedFileError`."""
    path = Path(path)
    if not path.is_file():
        raise SavedFileError(f"{path}: no saved {kind}")
    try:
        raw = torch.load(path, map_location="cpu", weights_only=True)
    except (pickle.UnpicklingError, RuntimeError, EOFError, ValueError, OSError, AttributeError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SavedFileError(
            f"{path}: not a handeye {kind} file, or one written by an older handeye with pickle "
            f"(refused: it could run code when opened); retrain it ({first[:120]})"
        ) from None
    if not isinstance(raw, dict) or raw.get("format") != MAGIC or raw.get("kind") != kind:
        raise SavedFileError(f"{path}: not a handeye {kind} file")
    if raw.get("version") != version:
        raise SavedFileError(f"{path}: {kind} file version {raw.get('version')!r}, this handeye reads {version}")
    try:
        doc = json.loads(raw["json"])
    except (KeyError, TypeError, json.JSONDecodeError):
        raise SavedFileError(f"{path}: damaged {kind} file (no readable JSON part)") from None
    doc.update(raw.get("tensors", {}))
    return doc


def arrays_to_tensors(arrays: dict) -> tuple[dict, dict]:
    """Split a dict of numpy arrays into tensors and JSON-able lists (string and object arrays)."""
    tensors, other = {}, {}
    for k, v in arrays.items():
        a = np.asarray(v)
        if a.dtype.kind in "biuf":
            tensors[k] = torch.from_numpy(np.ascontiguousarray(a))
        else:
            other[k] = a.astype(str).tolist()
    return tensors, other


def tensors_to_arrays(tensors: dict, other: dict) -> dict:
    """Inverse of :func:`arrays_to_tensors`."""
    out = {k: v.numpy() for k, v in tensors.items()}
    out.update({k: np.array(v, dtype=str) for k, v in other.items()})
    return out
