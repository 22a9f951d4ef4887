"""Li-Wang-Wu AX=YB solver (Kronecker product, rotation and translation jointly)."""

from __future__ import annotations

import numpy as np

from classic._linear import check_motions, normalize_rotation
from classic.registry import Solver, register
from handeye.core.se3 import make_transform

__all__ = ["li", "li_solve"]


def li(A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Solve ``A_i X = Y B_i`` on absolute poses by Li, Wang and Wu (2010).

    One linear least-squares system in ``(vec R_X, vec R_Y, t_X, t_Y)``
    (row-major ``vec``):

    .. math::
        \begin{bmatrix} R_A \otimes I_3 & -I_3 \otimes R_B^T & 0 & 0 \\
                        0 & I_3 \otimes t_B^T & -R_A & I_3 \end{bmatrix}
        \begin{bmatrix} \mathrm{vec} R_X \\ \mathrm{vec} R_Y \\ t_X \\ t_Y \end{bmatrix}
        = \begin{bmatrix} 0 \\ t_A \end{bmatrix},

    then both rotations are projected on SO(3) and the translations are those
    of the joint solve, as in OpenCV's ``CALIB_ROBOT_WORLD_HAND_EYE_LI``.
    Frame mapping for both setups: see :func:`classic.shah`.

    Parameters and return: those of every AX=YB solver (:mod:`classic.registry`): poses ``A``, ``B`` of shape
    ``(N, 4, 4)``, ``X, Y`` of shape ``(4, 4)``.

    References
    ----------
    A. Li, L. Wang, D. Wu, "Simultaneous robot-world and hand-eye calibration
    using dual-quaternions and Kronecker product", Int. J. Physical Sciences 5,
    2010.
    """
    A, B = check_motions(A, B, 3, "li")
    return li_solve(A, B)


def li_solve(A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`li` on poses already validated (:mod:`classic.registry`)."""
    n = len(A)
    R_A, R_B, t_A, t_B = A[:, :3, :3], B[:, :3, :3], A[:, :3, 3], B[:, :3, 3]
    I3 = np.eye(3)
    M = np.zeros((n, 12, 24))
    M[:, :9, :9] = np.einsum("kab,cd->kacbd", R_A, I3).reshape(n, 9, 9)
    M[:, :9, 9:18] = -np.einsum("ab,kdc->kacbd", I3, R_B).reshape(n, 9, 9)
    for r in range(3):
        M[:, 9 + r, 9 + 3 * r : 12 + 3 * r] = t_B
    M[:, 9:, 18:21] = -R_A
    M[:, 9:, 21:24] = I3
    rhs = np.zeros((n, 12))
    rhs[:, 9:] = t_A
    x = np.linalg.lstsq(M.reshape(-1, 24), rhs.reshape(-1), rcond=None)[0]
    R_X = normalize_rotation(x[:9].reshape(3, 3))
    R_Y = normalize_rotation(x[9:18].reshape(3, 3))
    return make_transform(R_X, x[18:21]), make_transform(R_Y, x[21:24])


register(Solver("li", "AX=YB", "Li-Wang-Wu 2010: Kronecker product, joint linear solve", 70, solve=li_solve))
