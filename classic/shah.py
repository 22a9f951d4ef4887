"""Shah AX=YB solver (Kronecker product, closed form)."""

from __future__ import annotations

import numpy as np

from classic._linear import check_motions, normalize_rotation
from classic.registry import Solver, register
from handeye.core.se3 import make_transform

__all__ = ["shah", "shah_solve", "translations_axyb"]


def shah(A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Solve ``A_i X = Y B_i`` on absolute poses by Shah (2013).

    Column-major ``vec``: ``(R_B \otimes R_A) vec(R_X) = vec(R_Y)`` for every
    pose, so ``vec(R_X)`` and ``vec(R_Y)`` are the leading right and left
    singular vectors of

    .. math:: T = \sum_i R_{B_i} \otimes R_{A_i},

    projected on SO(3); then ``R_A t_X - t_Y = R_Y t_B - t_A`` in least
    squares. Same algebra as OpenCV's ``CALIB_ROBOT_WORLD_HAND_EYE_SHAH``.

    For hand-eye data (see :mod:`handeye.core.setups`): eye-to-hand
    ``A = T_base_ee``, ``B = T_cam_target`` give ``X = T_ee_target``,
    ``Y = T_base_cam``; eye-in-hand ``A = T_ee_base``, ``B = T_cam_target``
    give ``X = T_base_target``, ``Y = T_ee_cam``.

    Parameters and return: those of every AX=YB solver (:mod:`classic.registry`): poses ``A``, ``B`` of shape
    ``(N, 4, 4)``, ``X, Y`` of shape ``(4, 4)``.

    References
    ----------
    M. Shah, "Solving the robot-world/hand-eye calibration problem using the
    Kronecker product", J. Mechanisms and Robotics 5(3), 2013.
    """
    A, B = check_motions(A, B, 3, "shah")
    return shah_solve(A, B)


def shah_solve(A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`shah` on poses already validated (:mod:`classic.registry`)."""
    T = np.einsum("kab,kcd->acbd", B[:, :3, :3], A[:, :3, :3]).reshape(9, 9)
    U, _, Vt = np.linalg.svd(T)
    R_X = normalize_rotation(Vt[0].reshape(3, 3).T)
    R_Y = normalize_rotation(U[:, 0].reshape(3, 3).T)
    t_X, t_Y = translations_axyb(A, B, R_Y)
    return make_transform(R_X, t_X), make_transform(R_Y, t_Y)


def translations_axyb(A: np.ndarray, B: np.ndarray, R_Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Translations of ``A_i X = Y B_i`` given ``R_Y``: ``R_A t_X - t_Y = R_Y t_B - t_A``.

    Parameters
    ----------
    A, B : array, shape (N, 4, 4)
    R_Y : array, shape (3, 3)

    Returns
    -------
    t_X, t_Y : array, shape (3,)
    """
    n = len(A)
    M = np.zeros((n, 3, 6))
    M[:, :, :3] = A[:, :3, :3]
    M[:, :, 3:] = -np.eye(3)
    rhs = B[:, :3, 3] @ R_Y.T - A[:, :3, 3]
    x = np.linalg.lstsq(M.reshape(-1, 6), rhs.reshape(-1), rcond=None)[0]
    return x[:3], x[3:]


register(Solver("shah", "AX=YB", "Shah 2013: Kronecker product, singular vectors", 60, solve=shah_solve))
