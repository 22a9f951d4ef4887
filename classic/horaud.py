"""Horaud-Dornaika AX=XB solver (unit quaternions)."""

from __future__ import annotations

import numpy as np

from classic._linear import (
    check_motions,
    resolve_near_half_turns,
    split_near_half_turns,
    translation_from_stats,
    translation_stats,
)
from classic.motions import Motions, motions_from_transforms
from classic.registry import Solver, register
from handeye.core.se3 import make_transform, matrix_from_quat_xyzw, quat_wxyz_to_xyzw, quat_xyzw_to_wxyz

__all__ = ["horaud", "horaud_stats", "horaud_finish"]


def horaud(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    r"""Solve ``A_k X = X B_k`` by Horaud and Dornaika (1995).

    The rotation's unit quaternion ``q`` minimises

    .. math:: \sum_k |a_k q - q b_k|^2 = q^T \Big[\sum_k (L(a_k) - W(b_k))^T (L(a_k) - W(b_k))\Big] q,

    the eigenvector of the smallest eigenvalue (``L``, ``W``: left and right
    quaternion-multiplication matrices); ``a_k``, ``b_k`` are the
    motions' quaternions, of the same sign (near a half turn: :mod:`classic.registry`). Then
    ``(R_A - I) t_X = R_X t_B - t_A``. Same algebra as OpenCV's
    ``CALIB_HAND_EYE_HORAUD`` (agreement to 1e-3 of the noise on motions below 120 degrees,
    tests/classic/test_opencv_agreement.py).

    Parameters and return: those of every AX=XB solver (:mod:`classic.registry`): motions ``A``, ``B`` of
    shape ``(K, 4, 4)``, ``X`` of shape ``(4, 4)``.

    References
    ----------
    R. Horaud, F. Dornaika, "Hand-eye calibration", Int. J. Robotics Research
    14(3), 1995.
    """
    A, B = check_motions(A, B, 2, "horaud")
    return horaud_finish(horaud_stats(motions_from_transforms(A, B)))


def _horaud_core(m: Motions) -> dict:
    """A chunk's statistics for :func:`horaud_finish` (:mod:`classic.registry`)."""
    # L(a) - W(b) written out with d = a - b and s = a + b ((w, x, y, z) indices 0..3)
    d = quat_xyzw_to_wxyz(m.q_A) - quat_xyzw_to_wxyz(m.q_B)
    s = m.q_A[:, :3] + m.q_B[:, :3]  # s1, s2, s3
    D = np.empty((len(m), 4, 4))
    D[:, :, 0] = d
    D[:, 0, 1:] = -d[:, 1:]
    D[:, 1, 1], D[:, 1, 2], D[:, 1, 3] = d[:, 0], -s[:, 2], s[:, 1]
    D[:, 2, 1], D[:, 2, 2], D[:, 2, 3] = s[:, 2], d[:, 0], -s[:, 0]
    D[:, 3, 1], D[:, 3, 2], D[:, 3, 3] = -s[:, 1], s[:, 0], d[:, 0]
    D = D.reshape(-1, 4)
    return {"M": D.T @ D, **translation_stats(m)}


horaud_stats = split_near_half_turns(_horaud_core)


def horaud_finish(st: dict) -> np.ndarray:
    """``X`` from the summed :func:`horaud_stats` (:mod:`classic.registry`)."""
    st = resolve_near_half_turns(_horaud_core, st)
    _, vecs = np.linalg.eigh(st["M"])
    R_X = matrix_from_quat_xyzw(quat_wxyz_to_xyzw(vecs[:, 0]))
    return make_transform(R_X, translation_from_stats(st, R_X))


register(Solver("horaud", "AX=XB", "Horaud-Dornaika 1995: unit quaternions", 30, horaud_stats, horaud_finish))
