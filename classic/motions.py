"""Motion pairs in the form the AX=XB solvers use: quaternions and translations.

Building all ``n (n - 1) / 2`` relative motions as 4x4 matrix products is the
slow part of a naive solver; here each relative rotation is one quaternion
product ``q_j * conj(q_i)`` of per-pose quaternions, translations are rotated
by quaternion, and rotation matrices are evaluated (from the quaternions) only
when a solver asks for them, all vectorised.

Signs near a half turn. ``A X = X B`` gives ``q_A = +-q_X q_B q_X^-1``: the two
quaternions of a motion have the same scalar part ``w`` and vector parts related
by ``R_X``, *with the same sign*, which is what the quaternion closed forms (Tsai,
Park, Horaud, Daniilidis) rely on. Taking each with ``w >= 0`` pairs the signs
right while ``w`` is well above its noise; near 180 degrees ``w`` is near zero,
noise sets its sign on each side independently, and a pair of opposite signs
breaks those solvers (degrees off from one such pair). :func:`near_half_turn`
marks the pairs beyond :data:`NEAR_HALF_TURN_DEG`; :func:`align_signs` flips
``q_B`` of each to the sign that a reference rotation says pairs it with
``q_A`` (see :mod:`classic._linear` for the reference).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from handeye.core.se3 import matrix_from_quat_xyzw, quat_xyzw_from_matrix

__all__ = [
    "Motions",
    "motions_from_transforms",
    "motions_from_poses",
    "iter_motions",
    "accumulate",
    "NEAR_HALF_TURN_DEG",
    "near_half_turn",
    "concatenate_motions",
    "align_signs",
]

#: Motions turning by more than this on either side have their quaternion signs aligned by a
#: reference rotation (:func:`align_signs`) instead of ``w >= 0``. At 150 degrees ``w = cos 75 deg
#: = 0.26``: noise would need to move the angle by 30 degrees to flip a sign below this, so the
#: ``w >= 0`` pairing of every other motion is right for any noise a calibration survives.
NEAR_HALF_TURN_DEG = 150.0
_NEAR_HALF_TURN_W = float(np.cos(np.radians(NEAR_HALF_TURN_DEG / 2.0)))


def _rotvec_keeping_sign(q: np.ndarray) -> np.ndarray:
    """Rotation vectors ``2 atan2(|v|, w) v / |v|`` of quaternions (x, y, z, w) *as signed*.

    For ``w >= 0`` the usual rotation vector (angle in ``[0, pi]``); for ``w < 0`` the same rotation
    as an angle in ``(pi, 2 pi]`` about the opposite axis: the branch that keeps
    ``log(q_A) = R_X log(q_B)`` for a pair whose signs were aligned.
    """
    v = q[..., :3]
    s = np.linalg.norm(v, axis=-1)  # as handeye.core.se3.rotvec_from_quat_xyzw, to the last bit for w >= 0
    theta = 2.0 * np.arctan2(s, q[..., 3])
    small = s < 1e-12
    scale = np.where(small, 2.0, theta / np.where(small, 1.0, s))
    return v * scale[..., None]


@dataclass
class Motions:
    """Paired motions ``A_k X = X B_k``.

    Attributes
    ----------
    q_A, q_B : array, shape (K, 4)
        Rotation quaternions (x, y, z, w), ``w >= 0``; after :func:`align_signs` a ``q_B`` may
        have ``w < 0`` (the sign that pairs it with ``q_A``).
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
        checks and Park's method read them. Angle in ``[0, pi]`` (``w >= 0``)."""
        return _rotvec_keeping_sign(self.q_A)

    @cached_property
    def rotvec_B(self) -> np.ndarray:
        """Rotation vectors of B, shape (K, 3): angle in ``[0, pi]``, or beyond pi where
        :func:`align_signs` gave ``q_B`` a negative ``w`` (the branch paired with ``rotvec_A``)."""
        return _rotvec_keeping_sign(self.q_B)

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

    def subset(self, keep: np.ndarray) -> "Motions":
        """The motions selected by a boolean mask or index array, shape (K,)."""
        return Motions(self.q_A[keep], self.t_A[keep], self.q_B[keep], self.t_B[keep])


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
    return concatenate_motions(iter_motions(A, B, i, j))


def concatenate_motions(parts) -> Motions:
    """One :class:`Motions` of a sequence of them, in order."""
    parts = list(parts)
    return Motions(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("q_A", "t_A", "q_B", "t_B")))


def accumulate(stats_fn, motions) -> dict:
    """Sum the statistics ``stats_fn(m)`` (a dict of arrays) over an iterable of :class:`Motions`.

    Entries that are :class:`Motions` (the pairs a solver keeps aside, :func:`near_half_turn`)
    are concatenated instead of summed.
    """
    total = None
    for m in motions:
        st = stats_fn(m)
        if total is None:
            total = st
            continue
        total = {
            k: concatenate_motions([total[k], v]) if isinstance(v, Motions) else total[k] + v for k, v in st.items()
        }
    return total


def near_half_turn(m: Motions) -> np.ndarray:
    """Motions turning by more than :data:`NEAR_HALF_TURN_DEG` on the robot side or the camera side.

    Parameters
    ----------
    m : Motions
        With ``w >= 0`` on both sides (as built here).

    Returns
    -------
    array of bool, shape (K,)
    """
    return np.minimum(m.q_A[:, 3], m.q_B[:, 3]) < _NEAR_HALF_TURN_W


def align_signs(m: Motions, R_ref: np.ndarray) -> Motions:
    """The motions with each ``q_B``'s sign set to pair it with ``q_A`` through a reference rotation.

    ``A X = X B`` gives ``q_A = s q_X q_B q_X^-1`` with ``s = +-1``; ``s`` is the sign of
    ``q_A . (q_X q_B q_X^-1) = w_A w_B + v_A . (R_X v_B)``, here with ``R_X`` replaced by ``R_ref``.
    Near a half turn ``|v_A| ~ |v_B| ~ 1``, so a reference tens of degrees off still gives the right
    sign; far from it ``w_A w_B`` decides, as ``w >= 0`` did.

    Parameters
    ----------
    m : Motions
    R_ref : array, shape (3, 3)
        A rotation close to ``R_X`` of ``A X = X B`` (``R_A = R_X R_B R_X^T``).

    Returns
    -------
    Motions
        ``q_A``, ``t_A``, ``t_B`` unchanged; ``q_B`` times ``s`` (``w_B`` may then be negative).
    """
    dot = m.q_A[:, 3] * m.q_B[:, 3] + np.einsum("ki,ki->k", m.q_A[:, :3], m.q_B[:, :3] @ R_ref.T)
    s = np.where(dot < 0.0, -1.0, 1.0)
    return Motions(m.q_A, m.t_A, m.q_B * s[:, None], m.t_B)
