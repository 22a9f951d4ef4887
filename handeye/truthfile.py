"""The ``--truth`` file of ``handeye calibrate``: true poses by frame name, checked before any error is printed.

A JSON object of 4x4 matrices (metres) by frame name, as ``handeye sim`` and the examples write it::

    {"T_base_cam": [[...], [...], [...], [0, 0, 0, 1]], "T_ee_target": [[...], ...]}

A truth is what an error is measured against, so it is held to more than a pose file's printed matrices:
its rotation block must be orthonormal within :data:`TRUTH_ROTATION_TOL`, its translation within
:data:`handeye.core.validation.MAX_TRANSLATION_M`, its numbers in the grammar of :mod:`handeye.core.numbers`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from handeye.core.errors import TruthFileError
from handeye.core.jsonfile import read_json_file
from handeye.core.numbers import float_array
from handeye.core.pose_matrices import checked_pose_matrix
from handeye.core.validation import MAX_TRANSLATION_M

__all__ = ["TRUTH_ROTATION_TOL", "read_truth"]

#: Largest ``|R^T R - I|`` entry and ``|det R - 1|`` of a truth's rotation block. handeye writes a truth with
#: 17 significant digits (orthonormal to about 1e-15); a matrix copied with six decimals is off by up to about
#: 3e-6 (``3 * 0.5e-6`` per entry of a column's dot product); four decimals (3e-4), a scale or a shear is
#: beyond it, and would bias the printed rotation error by more than the 0.0006 degrees this allows.
TRUTH_ROTATION_TOL = 1e-5


def read_truth(path: str | Path, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The true poses ``names`` of a truth file, each checked to be a rigid transform in metres.

    Parameters
    ----------
    path : str or Path
        JSON object: frame name -> 4x4 matrix ``T_a_b`` (metres).
    names : tuple of str
        The poses the calibration estimated (``("T_base_cam", "T_ee_target")``); those present are returned.

    Returns
    -------
    dict of str -> array, shape (4, 4)
        The poses of ``names`` the file holds (at least one).

    Raises
    ------
    TruthFileError
        One line naming the file and the pose: not a JSON object, none of ``names``, a value that is not a
        4x4 matrix of numbers, a rotation block that is not a rotation (within :data:`TRUTH_ROTATION_TOL`, or a
        reflection), a last row other than ``[0, 0, 0, 1]``, a translation over ``MAX_TRANSLATION_M``.
    """
    path = Path(path)
    truth = read_json_file(path, TruthFileError, "truth file (JSON of 4x4 poses by frame name)")
    if not isinstance(truth, dict):
        raise TruthFileError(f"{path}: not a truth file (a JSON object of 4x4 poses by frame name is needed)")
    found = [name for name in names if name in truth]
    if not found:
        raise TruthFileError(
            f"{path}: holds none of {', '.join(names)} (it has {', '.join(map(str, list(truth)[:6])) or 'no keys'}); "
            "give the truth of the poses this calibration estimates"
        )
    out = {}
    for name in found:
        where = f"{path}, {name}"
        M = float_array(truth[name], where, TruthFileError)  # numbers, finite
        checked_pose_matrix(M, where, TruthFileError, tol=TRUTH_ROTATION_TOL)  # 4x4, last row, a rotation
        norm = float(np.linalg.norm(M[:3, 3]))
        if norm > MAX_TRANSLATION_M:
            raise TruthFileError(
                f"{where}: translation {norm:.4g} m, over {MAX_TRANSLATION_M:g} m: a truth is in metres "
                "(millimetres? divide by 1000)"
            )
        out[name] = M  # as written: the error is measured against the file's own numbers
    return out
