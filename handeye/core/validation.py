"""Input checks for users' data: each raises a named :class:`ValueError` subclass.

These are checks for users, not asserts for developers: they run on every
public entry point and say what is wrong and where.
"""

from __future__ import annotations

import numpy as np

from handeye.core.errors import (
    DuplicatePoseError,
    LengthMismatchError,
    NonFiniteError,
    NotARotationError,
    ShapeError,
    TooFewPosesError,
    UnitsError,
)
from handeye.core.limits import ABSURD_TRANSLATION_M

__all__ = [
    "ROTATION_TOLERANCE",
    "MAX_TRANSLATION_M",
    "MIN_TARGET_DISTANCE_M",
    "check_target_distance",
    "MIN_POSES",
    "check_transforms",
    "check_paired",
    "check_no_duplicates",
    "check_units_metres",
]

#: Largest accepted ``|R^T R - I|`` entry and ``|det R - 1|`` of a rotation block.
ROTATION_TOLERANCE = 1e-6
#: Translations beyond this (metres) are taken as a units mistake (millimetres?).
MAX_TRANSLATION_M = 20.0
#: A target nearer the camera than this (metres) in most poses is a units mistake (metres read as millimetres):
#: no camera focuses on a calibration board a centimetre from its lens, and a board that near fills no view.
MIN_TARGET_DISTANCE_M = 0.01
#: The fewest poses any hand-eye problem accepts.
MIN_POSES = 3


def check_transforms(T: np.ndarray, name: str, tol: float = ROTATION_TOLERANCE) -> np.ndarray:
    """Check a batch of rigid transforms and return it as float64 ``(N, 4, 4)``.

    Parameters
    ----------
    T : array_like, shape (N, 4, 4) or (4, 4)
        Homogeneous transforms ``T_a_b``.
    name : str
        Name used in messages, e.g. ``"T_base_ee"``.
    tol : float
        Tolerance of the orthonormality and determinant checks.

    Returns
    -------
    T : array, shape (N, 4, 4)

    Raises
    ------
    ShapeError, NonFiniteError, NotARotationError
    """
    try:
        T = np.asarray(T, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"{name} is not a numeric array: {exc}") from exc
    if T.ndim == 2:
        T = T[None]
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise ShapeError(f"{name} must have shape (N, 4, 4), got {T.shape}")
    bad = ~np.isfinite(T).all(axis=(1, 2))
    if bad.any():
        idx = np.flatnonzero(bad)
        raise NonFiniteError(f"{name} holds NaN or infinity at pose index {_list(idx)}")
    bottom = np.abs(T[:, 3, :] - np.array([0.0, 0.0, 0.0, 1.0])).max(axis=1)
    if (bottom > tol).any():
        idx = np.flatnonzero(bottom > tol)
        raise ShapeError(f"{name} is not homogeneous at pose index {_list(idx)}: the last row must be [0, 0, 0, 1]")
    R = T[:, :3, :3]
    ortho = np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)).max(axis=(1, 2))
    det = np.einsum("ki,ki->k", R[:, 0], np.cross(R[:, 1], R[:, 2]))
    bad = (ortho > tol) | (np.abs(det - 1.0) > tol)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        what = "a reflection (det = -1)" if det[i] < 0 else f"not orthonormal (|R^T R - I| = {ortho[i]:.2e})"
        raise NotARotationError(
            f"{name}[{i}] has a rotation block that is {what}"
            f"; {int(bad.sum())} pose(s) fail in all (indices {_list(np.flatnonzero(bad))}). "
            "Pass proper rotations (re-orthonormalise with handeye.core.se3.project_to_so3 if they are "
            "rounded)."
        )
    return T


def check_paired(T_1: np.ndarray, T_2: np.ndarray, names: tuple[str, str], min_poses: int = MIN_POSES) -> None:
    """Check that two pose batches pair up one to one and are long enough.

    Parameters
    ----------
    T_1, T_2 : array, shape (N, 4, 4)
    names : (str, str)
        Their names, for messages.
    min_poses : int
        The fewest poses accepted.

    Raises
    ------
    LengthMismatchError, TooFewPosesError
    """
    if len(T_1) != len(T_2):
        raise LengthMismatchError(
            f"{names[0]} has {len(T_1)} poses but {names[1]} has {len(T_2)}: "
            "they must be paired one to one (pose i of each recorded at the same time)"
        )
    if len(T_1) < min_poses:
        raise TooFewPosesError(
            f"hand-eye calibration needs at least {min_poses} poses, got {len(T_1)}; "
            "record more robot poses (10 to 20 well spread ones is typical)"
        )


def check_no_duplicates(T_1: np.ndarray, T_2: np.ndarray, names: tuple[str, str], tol: float = 1e-12) -> None:
    """Refuse pose pairs that appear twice (both poses identical).

    A repeated row is almost always a bookkeeping error (an image paired twice)
    and adds nothing but a zero motion.

    Parameters
    ----------
    T_1, T_2 : array, shape (N, 4, 4)
    names : (str, str)
    tol : float
        Largest entry difference still called identical.

    Raises
    ------
    DuplicatePoseError
    """
    key = np.concatenate([T_1[:, :3, :].reshape(len(T_1), -1), T_2[:, :3, :].reshape(len(T_2), -1)], axis=1)
    order = np.lexsort(key.T[::-1])
    sorted_key = key[order]
    same = np.abs(np.diff(sorted_key, axis=0)).max(axis=1) <= tol
    if same.any():
        k = int(np.flatnonzero(same)[0])
        i, j = sorted(int(v) for v in order[k : k + 2])
        raise DuplicatePoseError(
            f"poses {i} and {j} are identical in both {names[0]} and {names[1]}: "
            "a duplicated row adds no information; remove it"
        )


def check_units_metres(T: np.ndarray, name: str, max_translation_m: float = MAX_TRANSLATION_M) -> None:
    """Refuse translations too large to be metres.

    Parameters
    ----------
    T : array, shape (N, 4, 4)
    name : str
    max_translation_m : float
        Largest plausible translation norm in metres.

    Raises
    ------
    UnitsError
    """
    with np.errstate(over="ignore", invalid="ignore"):  # 1e308 squared: inf, which is absurd below
        norms = np.linalg.norm(T[:, :3, 3], axis=1)
    if norms.size and norms.max() > ABSURD_TRANSLATION_M:
        i = int(np.argmax(norms))
        largest = float(np.abs(T[i, :3, 3]).max())
        raise UnitsError(
            f"{name}[{i}] has a translation coordinate of {largest:.3g} m: absurd in any unit (no robot cell is "
            f"{ABSURD_TRANSLATION_M:g} m wide, in metres or millimetres); the value is corrupt or not a pose"
        )
    if norms.size and norms.max() > max_translation_m:
        i = int(np.argmax(norms))
        raise UnitsError(
            f"{name}[{i}] has a translation of {norms[i]:.1f} m; handeye works in metres and this "
            "looks like millimetres. Convert the translations to metres (divide by 1000); pose files "
            "read with units='mm' (CLI: --units mm) are converted for you."
        )


def check_target_distance(T_cam_target: np.ndarray, name: str = "T_cam_target") -> None:
    """Refuse camera poses whose target lies nearer the lens than any camera can see it: a units mistake.

    Metres read as millimetres (``--units mm`` on a file in metres) divide every translation by 1000: a
    board 0.6 m away becomes 0.6 mm away, and a calibration on it is silently wrong. The median distance
    is judged, so one bad pose is left to the outlier test.

    Parameters
    ----------
    T_cam_target : array, shape (N, 4, 4)
    name : str

    Raises
    ------
    UnitsError
        When the median target distance is below :data:`MIN_TARGET_DISTANCE_M`.
    """
    norms = np.linalg.norm(np.asarray(T_cam_target, dtype=float)[:, :3, 3], axis=1)
    if norms.size == 0:
        return
    median = float(np.median(norms))
    if median < MIN_TARGET_DISTANCE_M:
        raise UnitsError(
            f"{name}: the target is {1000 * median:.3g} mm from the camera (median over {norms.size} poses); no "
            f"camera sees a board nearer than {1000 * MIN_TARGET_DISTANCE_M:g} mm. The translations look 1000 times "
            "too small: metres read as millimetres? Read the file without --units mm (units='m')."
        )


def _list(idx: np.ndarray, limit: int = 10) -> str:
    shown = ", ".join(str(int(i)) for i in idx[:limit])
    return shown + (", ..." if len(idx) > limit else "")
