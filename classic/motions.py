"""Motion pairs in the form the AX=XB solvers use: quaternions and translations.

Building all ``n (n - 1) / 2`` relative motions as 4x4 matrix products is the
slow part of a naive solver; here each relative rotation is one quaternion
product ``q_j * conj(q_i)`` of per-pose quaternions, and its matrix (needed by
the translation step) is evaluated from the quaternion, all vectorised.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from handeye.se3 import matrix_from_quat_xyzw, quat_xyzw_from_matrix

__all__ = ["Motions", "motions_from_transforms", "motions_from_poses"]


@dataclass
class Motions:
    """Paired motions ``A_k X = X B_k``.

    Attributes
    ----------
    q_A, q_B : array, shape (K, 4)
        Rotation quaternions (x, y, z, w), ``w >= 0``.
    t_A, t_B : array, shape (K, 3)
        Translations, metres.
    """

    q_A: np.ndarray
    t_A: np.ndarray
    q_B: np.ndarray
    t_B: np.ndarray

    @cached_property
    def R_A(self) -> np.ndarray:
        """Rotation matrices of A, shape (K, 3, 3)."""
        return matrix_from_quat_xyzw(self.q_A)

    @cached_property
    def R_B(self) -> np.ndarray:
        """Rotation matrices of B, shape (K, 3, 3)."""
        return matrix_from_quat_xyzw(self.q_B)

    def __len__(self) -> int:
        return len(self.q_A)


def motions_from_transforms(A: np.ndarray, B: np.ndarray) -> Motions:
    """Motions from 4x4 transforms.

    Parameters
    ----------
    A, B : array, shape (K, 4, 4)

    Returns
    -------
    Motions
    """
    m = Motions(quat_xyzw_from_matrix(A[:, :3, :3]), A[:, :3, 3], quat_xyzw_from_matrix(B[:, :3, :3]), B[:, :3, 3])
    m.__dict__["R_A"] = A[:, :3, :3]
    m.__dict__["R_B"] = B[:, :3, :3]
    return m


def _relative(q: np.ndarray, t: np.ndarray, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quaternion, matrix and translation of ``T_j T_i^-1`` for all pairs."""
    x1, y1, z1, w1 = (q[j, k] for k in range(4))
    x2, y2, z2, w2 = (-q[i, 0], -q[i, 1], -q[i, 2], q[i, 3])  # conjugate of q_i
    q_ij = np.stack(
        [
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        ],
        axis=1,
    )
    q_ij *= np.where(q_ij[:, 3:] < 0, -1.0, 1.0)
    R_ij = matrix_from_quat_xyzw(q_ij)
    ti = t[i]
    t_ij = t[j] - (R_ij[:, :, 0] * ti[:, :1] + R_ij[:, :, 1] * ti[:, 1:2] + R_ij[:, :, 2] * ti[:, 2:])
    return q_ij, R_ij, t_ij


def motions_from_poses(A: np.ndarray, B: np.ndarray, i: np.ndarray, j: np.ndarray) -> Motions:
    """Motions ``A_j A_i^-1`` and ``B_j B_i^-1`` of absolute poses for index pairs.

    Parameters
    ----------
    A, B : array, shape (N, 4, 4)
        Robot-side poses and ``T_cam_target`` (:mod:`handeye.setups`).
    i, j : array of int, shape (K,)

    Returns
    -------
    Motions
    """
    q_A, R_A, t_A = _relative(quat_xyzw_from_matrix(A[:, :3, :3]), A[:, :3, 3], i, j)
    q_B, R_B, t_B = _relative(quat_xyzw_from_matrix(B[:, :3, :3]), B[:, :3, 3], i, j)
    m = Motions(q_A, t_A, q_B, t_B)
    m.__dict__["R_A"] = R_A
    m.__dict__["R_B"] = R_B
    return m
