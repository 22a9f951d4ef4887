"""Motion pairs in the form the AX=XB solvers use: quaternions and translations.

Building all ``n (n - 1) / 2`` relative motions as 4x4 matrix products is the
slow part of a naive solver; here each relative rotation is one quaternion
product ``q_j * conj(q_i)`` of per-pose quaternions, translations are rotated
by quaternion, and rotation matrices are evaluated (from the quaternions) only
when a solver asks for them, all vectorised.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from handeye.core.se3 import matrix_from_quat_xyzw, quat_xyzw_from_matrix, rotvec_from_quat_xyzw

__all__ = ["Motions", "motions_from_transforms", "motions_from_poses", "iter_motions", "accumulate"]


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
        return matrix_from_quat_xyzw(self.q_A, normalize=False)

    @cached_property
    def R_B(self) -> np.ndarray:
        """Rotation matrices of B, shape (K, 3, 3)."""
        return matrix_from_quat_xyzw(self.q_B, normalize=False)

    @cached_property
    def rotvec_A(self) -> np.ndarray:
        """Rotation vectors of A (axis times angle, radians), shape (K, 3); computed once, as the
        checks and Park's method read them."""
        return rotvec_from_quat_xyzw(self.q_A)

    @cached_property
    def rotvec_B(self) -> np.ndarray:
        """Rotation vectors of B, shape (K, 3)."""
        return rotvec_from_quat_xyzw(self.q_B)

    @cached_property
    def angles_A(self) -> np.ndarray:
        """Rotation angles of A, radians in [0, pi], shape (K,)."""
        return np.sqrt(np.einsum("ij,ij->i", self.rotvec_A, self.rotvec_A))

    @cached_property
    def angles_B(self) -> np.ndarray:
        """Rotation angles of B, radians in [0, pi], shape (K,)."""
        return np.sqrt(np.einsum("ij,ij->i", self.rotvec_B, self.rotvec_B))

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


def _relative(q: np.ndarray, t: np.ndarray, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Quaternion (``w >= 0``) and translation of ``T_j T_i^-1`` for all pairs.

    ``q_ij = q_j * conj(q_i)`` and ``t_ij = t_j - R(q_ij) t_i``, the rotation
    applied as ``t + 2 w (v x t) + 2 v x (v x t)``; no matrix is formed.
    """
    qT, tT = q.T, t.T
    x1, y1, z1, w1 = qT[:, j]
    x2, y2, z2, w2 = qT[:, i]
    w = w1 * w2 + x1 * x2 + y1 * y2 + z1 * z2
    sign = np.where(w < 0, -1.0, 1.0)
    x = (x1 * w2 - w1 * x2 - y1 * z2 + z1 * y2) * sign
    y = (y1 * w2 - w1 * y2 + x1 * z2 - z1 * x2) * sign
    z = (z1 * w2 - w1 * z2 - x1 * y2 + y1 * x2) * sign
    w *= sign
    a, b, c = tT[:, i]
    # u = v x t_i, then v x u
    ux, uy, uz = y * c - z * b, z * a - x * c, x * b - y * a
    vx, vy, vz = y * uz - z * uy, z * ux - x * uz, x * uy - y * ux
    tj = tT[:, j]
    t_ij = np.stack(
        [tj[0] - a - 2 * (w * ux + vx), tj[1] - b - 2 * (w * uy + vy), tj[2] - c - 2 * (w * uz + vz)], axis=1
    )
    return np.stack([x, y, z, w], axis=1), t_ij


def iter_motions(A: np.ndarray, B: np.ndarray, i: np.ndarray, j: np.ndarray, chunk: int = 4096):
    """Motions ``A_j A_i^-1`` and ``B_j B_i^-1`` of absolute poses, in chunks of pairs.

    Chunks keep every temporary small (in cache, below the allocator's mmap
    threshold), which makes all-pairs solves about twice as fast as one pass
    over all pairs.

    Parameters
    ----------
    A, B : array, shape (N, 4, 4)
        Robot-side poses and ``T_cam_target`` (:mod:`handeye.core.setups`).
    i, j : array of int, shape (K,)
    chunk : int

    Yields
    ------
    Motions
    """
    per_pose = [(quat_xyzw_from_matrix(T[:, :3, :3]), T[:, :3, 3]) for T in (A, B)]
    for start in range(0, len(i), chunk):
        sl = slice(start, start + chunk)
        (q_A, t_A), (q_B, t_B) = (_relative(q, t, i[sl], j[sl]) for q, t in per_pose)
        yield Motions(q_A, t_A, q_B, t_B)


def motions_from_poses(A: np.ndarray, B: np.ndarray, i: np.ndarray, j: np.ndarray) -> Motions:
    """Motions ``A_j A_i^-1`` and ``B_j B_i^-1`` of absolute poses for index pairs, in one batch.

    Parameters
    ----------
    A, B : array, shape (N, 4, 4)
        Robot-side poses and ``T_cam_target`` (:mod:`handeye.core.setups`).
    i, j : array of int, shape (K,)

    Returns
    -------
    Motions
    """
    parts = list(iter_motions(A, B, i, j))
    return Motions(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("q_A", "t_A", "q_B", "t_B")))


def accumulate(stats_fn, motions) -> dict:
    """Sum the statistics ``stats_fn(m)`` (a dict of arrays) over an iterable of :class:`Motions`."""
    total = None
    for m in motions:
        st = stats_fn(m)
        total = st if total is None else {k: total[k] + v for k, v in st.items()}
    return total
