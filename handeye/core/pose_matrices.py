"""4x4 pose matrices as other tools print them: checked one by one, rotations re-orthonormalised, units.

Shared by the readers of matrix files (:mod:`handeye.core.matrix_poses`) and of OpenCV FileStorage pose
pairs (:mod:`handeye.core.opencv_pose_pairs`): each names the matrix (file and line, or file and key) in
``where``, and gets one line per cause.
"""

from __future__ import annotations

import numpy as np

from handeye.core.errors import PoseFileError
from handeye.core.limits import ABSURD_TRANSLATION_M
from handeye.core.poseset import UNIT_SCALE
from handeye.core.se3 import invert_transform, project_to_so3
from handeye.core.validation import MAX_TRANSLATION_M

__all__ = ["PRINTED_ROTATION_TOL", "checked_pose_matrix", "scaled_to_metres"]

#: A rotation block printed by another tool is taken when ``max |R^T R - I|`` and ``|det R - 1|`` are within
#: this, then re-orthonormalised (nearest rotation, SVD). Six printed decimals (Tabb's datasets) leave
#: about 3e-6, four decimals about 3e-4; a shear or scale of 0.1 % (or a matrix that is not a pose) is
#: beyond it and refused.
PRINTED_ROTATION_TOL = 1e-3


def checked_pose_matrix(
    M: np.ndarray, where: str, error: type[Exception] = PoseFileError, tol: float = PRINTED_ROTATION_TOL
) -> np.ndarray:
    """One pose matrix checked: finite, last row ``[0, 0, 0, 1]``, a rotation within rounding.

    Parameters
    ----------
    M : array, shape (4, 4)
        A homogeneous transform ``T_a_b`` as a file gives it (translation in the file's unit).
    where : str
        The file and line (or key), for messages.
    error : exception class
    tol : float
        Largest ``|R^T R - I|`` entry and ``|det R - 1|`` (and last-row deviation) taken; a truth passes a tighter one.

    Returns
    -------
    T : array, shape (4, 4)
        The rotation block replaced by its nearest rotation (SVD); the translation as given.

    Raises
    ------
    error
        Naming ``where`` and the cause: NaN or infinity, a last row other than ``[0, 0, 0, 1]``, a rotation
        block that is a reflection or not orthonormal within :data:`PRINTED_ROTATION_TOL`.
    """
    M = np.asarray(M, dtype=float)
    if M.shape != (4, 4):
        raise error(f"{where}: a pose matrix is 4 x 4, this one is {' x '.join(map(str, M.shape))}")
    if not np.isfinite(M).all():
        raise error(f"{where}: the matrix holds NaN or infinity")
    if np.abs(M[3] - [0.0, 0.0, 0.0, 1.0]).max() > tol:
        raise error(f"{where}: the last row is {np.round(M[3], 6).tolist()}, not [0, 0, 0, 1]: not a pose matrix")
    R = M[:3, :3]
    ortho = float(np.abs(R.T @ R - np.eye(3)).max())
    det = float(np.linalg.det(R))
    if det < 0:
        raise error(f"{where}: the rotation block is a reflection (det = {det:.4f}), not a rotation")
    if ortho > tol or abs(det - 1.0) > tol:
        raise error(
            f"{where}: the rotation block is not a rotation (|R^T R - I| = {ortho:.2e}, det = {det:.6f}; "
            f"rounding allows {tol:g})"
        )
    T = np.eye(4)
    T[:3, :3] = project_to_so3(R)
    T[:3, 3] = M[:3, 3]
    return T


def scaled_to_metres(
    T: np.ndarray,
    units: str | None,
    where_of: list[str],
    what: str,
    invert: bool = False,
    error: type[Exception] = PoseFileError,
) -> np.ndarray:
    """Poses in metres (optionally inverted), refusing translations that look like millimetres read as metres.

    Parameters
    ----------
    T : array, shape (N, 4, 4)
        Checked pose matrices in the file's unit.
    units : {"m", "mm"} or None
        The file's unit; ``None``: metres, checked.
    where_of : list of str
        The place (file and line or key) of each pose, for messages.
    what : str
        What the poses are (``"T_base_ee"``), for messages.
    invert : bool
        Return the inverses (after scaling).
    error : exception class

    Returns
    -------
    T : array, shape (N, 4, 4)
        Metres.

    Raises
    ------
    error
        Units not understood; a translation beyond :data:`~handeye.core.limits.ABSURD_TRANSLATION_M` in any
        unit; with ``units=None``, one beyond :data:`~handeye.core.validation.MAX_TRANSLATION_M` (millimetres
        read as metres), with the fix.
    """
    if units is not None and units not in UNIT_SCALE:
        raise error(f"units {units!r} not understood; use 'm' or 'mm'")
    T = np.array(T, dtype=float).reshape(-1, 4, 4)
    norms = np.linalg.norm(T[:, :3, 3], axis=1)
    if norms.size and norms.max() > ABSURD_TRANSLATION_M * 1e3:
        i = int(np.argmax(norms))
        raise error(f"{where_of[i]}: a translation of {norms[i]:.3g} is absurd in metres or millimetres")
    if units is None and norms.size and norms.max() > MAX_TRANSLATION_M:
        i = int(np.argmax(norms))
        raise error(
            f"{where_of[i]}: {what} has a translation of {norms[i]:.1f}; as metres that is beyond "
            f"{MAX_TRANSLATION_M:g} m, so these look like millimetres: give units='mm' (CLI: --units mm)"
        )
    T[:, :3, 3] *= UNIT_SCALE[units or "m"]
    return invert_transform(T) if invert else T
