"""Which kind of classic label a dataset holds, and the check that a protocol mode trains on its own kind.

``handeye label`` writes one of two labels per camera pose (:func:`handeye.labelling.label_camera`):

- this project's (``--repeats 0``, the default): closed form, maximum likelihood and corner reprojection, with
  its reprojection RMS and a sigma in ``label_sigma_trans_mm`` / ``label_sigma_rot_deg``;
- the seed paper's (``--method tsai --repeats 5``): the closed form alone, repeated on subsets of the views and
  averaged, with no sigma (the repeats share most of their views, so their spread says little of the error).

``cameras.csv`` does not name the method, so the kind is read from what each writes: a labelled pose with
none of the reprojection RMS and the two sigmas carries the paper's kind of label, one with any of them this
project's (its RMS is always written; a sigma can be NaN where the covariance is singular). The closed form
itself (Tsai or another) is not recorded and cannot be checked.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from handeye.core.dataset import Dataset
from handeye.core.errors import HandEyeInputError

__all__ = ["PAPER", "HANDEYE", "label_kind", "check_labels"]

PAPER = "the paper's (a closed form repeated, no sigma)"
HANDEYE = "this project's (with a sigma)"

_WRITTEN_BY_HANDEYE = ("label_rms_px", "label_sigma_trans_mm", "label_sigma_rot_deg")


def label_kind(root: str | Path) -> str | None:
    """:data:`PAPER`, :data:`HANDEYE`, ``"mixed"`` (some poses of each) or None (no labelled pose).

    Parameters
    ----------
    root : str or Path
        A dataset directory (:class:`handeye.core.dataset.Dataset`).
    """
    cams = Dataset.open(root).cameras()
    if "label_status" not in cams:
        return None
    ok = np.array([s == "ok" for s in cams["label_status"]])
    if not ok.any():
        return None
    ours = np.any([np.isfinite(np.asarray(cams[c], dtype=float)) for c in _WRITTEN_BY_HANDEYE], axis=0)[ok]
    if ours.all():
        return HANDEYE
    return PAPER if not ours.any() else "mixed"


def check_labels(preset, root: str | Path, labels: str) -> None:
    """Refuse to train a protocol mode on classic labels of the other kind.

    Parameters
    ----------
    preset : learned.presets.Preset
        Its ``label_repeats``: 0, this project's labels; at least 1, the paper's (``label_method`` repeated).
    root : str or Path
        The dataset.
    labels : str
        The run's label source; only ``"classic"`` is checked (the truth and the markerless labels are the
        user's explicit choice).

    Raises
    ------
    HandEyeInputError
        The dataset's labels are not of the kind the preset's protocol trains on, naming the command that
        writes them.
    """
    if labels != "classic":
        return
    kind = label_kind(root)
    want = PAPER if preset.label_repeats else HANDEYE
    if kind is None or kind == want:
        return
    command = f"handeye label {root}" + (
        f" --method {preset.label_method} --repeats {preset.label_repeats}" if preset.label_repeats else ""
    )
    other = "handeye" if preset.protocol == "paper" else "paper"
    raise HandEyeInputError(
        f"labels of {kind}; the {preset.protocol} protocol trains on {want}: run '{command}' on a copy, "
        f"or use --protocol {other}"
    )
