"""Daniilidis AX=XB solver (dual quaternions)."""

from __future__ import annotations

import numpy as np

from classic._linear import check_motions, resolve_near_half_turns, split_near_half_turns
from classic.motions import Motions, motions_from_transforms
from classic.registry import Solver, register
from handeye.core.se3 import (
    make_transform,
    matrix_from_quat_xyzw,
    quat_multiply_wxyz,
    quat_wxyz_to_xyzw,
    quat_xyzw_to_wxyz,
)

__all__ = ["daniilidis", "daniilidis_stats", "daniilidis_finish"]


def daniilidis(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    r"""Solve ``A_k X = X B_k`` by Daniilidis (1999), rotation and translation at once.

    With dual quaternions ``a + eps a'``, ``b + eps b'`` of the motions and
    ``x + eps x'`` of X, each motion gives six linear equations

    .. math::
        \begin{bmatrix} a - b & [a + b]_\times & 0 & 0 \\
                        a' - b' & [a' + b']_\times & a - b & [a + b]_\times \end{bmatrix}
        \begin{bmatrix} x \\ x' \end{bmatrix} = 0

    (vector parts only). The solution is the combination of the two smallest
    right singular vectors that satisfies ``|x| = 1`` and ``x . x' = 0``.

    Differs from OpenCV's ``CALIB_HAND_EYE_DANIILIDIS`` in one respect: ``a`` and
    ``b`` of each motion are taken with the same sign, as the derivation requires (equal
    scalar parts; near a half turn: :mod:`classic.registry`). OpenCV takes the signs
    its matrix-to-quaternion conversion happens to return, which for motions beyond 120
    degrees can pair opposite signs and break the solve. On motions below 120 degrees both
    agree.

    Parameters and return: those of every AX=XB solver (:mod:`classic.registry`): motions ``A``, ``B`` of
    shape ``(K, 4, 4)``, ``X`` of shape ``(4, 4)``.

    References
    ----------
    K. Daniilidis, "Hand-eye calibration using dual quaternions", Int. J.
    Robotics Research 18(3), 1999.
    """
    A, B = check_motions(A, B, 2, "daniilidis")
    return daniilidis_finish(daniilidis_stats(motions_from_transforms(A, B)))


def _dual(q_xyzw: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Real and dual parts (w, x, y, z) of ``q + eps (0, t) q / 2``, written out for speed."""
    x, y, z, w = np.moveaxis(q_xyzw, -1, 0)
    tx, ty, tz = np.moveaxis(t, -1, 0)
    # (0, t) * (w, v) = (-t.v, w t + t x v)
    dual = 0.5 * np.stack(
        [-(tx * x + ty * y + tz * z), w * tx + ty * z - tz * y, w * ty + tz * x - tx * z, w * tz + tx * y - ty * x],
        axis=-1,
    )
    return quat_xyzw_to_wxyz(q_xyzw), dual


def _block(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rows ``[u, [v]x]`` of shape (3K, 4) for vectors ``u, v`` of shape (K, 3)."""
    P = np.zeros((len(u), 3, 4))
    P[:, :, 0] = u
    P[:, 0, 2], P[:, 0, 3] = -v[:, 2], v[:, 1]
    P[:, 1, 1], P[:, 1, 3] = v[:, 2], -v[:, 0]
    P[:, 2, 1], P[:, 2, 2] = -v[:, 1], v[:, 0]
    return P.reshape(-1, 4)


def _daniilidis_core(m: Motions) -> dict:
    """A chunk's statistics for :func:`daniilidis_finish` (:mod:`classic.registry`)."""
    # S = [[P, 0], [Q, P]] per motion, so S^T S = [[P^T P + Q^T Q, Q^T P], [P^T Q, P^T P]] summed
    a, a_d = _dual(m.q_A, m.t_A)
    b, b_d = _dual(m.q_B, m.t_B)
    P = _block(a[:, 1:] - b[:, 1:], a[:, 1:] + b[:, 1:])
    Q = _block(a_d[:, 1:] - b_d[:, 1:], a_d[:, 1:] + b_d[:, 1:])
    PtP, QtP = P.T @ P, Q.T @ P
    M = np.empty((8, 8))
    M[:4, :4] = PtP + Q.T @ Q
    M[:4, 4:] = QtP
    M[4:, :4] = QtP.T
    M[4:, 4:] = PtP
    return {"M": M}


daniilidis_stats = split_near_half_turns(_daniilidis_core)


def daniilidis_finish(st: dict) -> np.ndarray:
    """``X`` from the summed :func:`daniilidis_stats` (:mod:`classic.registry`)."""
    st = resolve_near_half_turns(_daniilidis_core, st)
    _, V = np.linalg.eigh(st["M"])
    v1, v2 = V[:, 0], V[:, 1]
    u1, w1, u2, w2 = v1[:4], v1[4:], v2[:4], v2[4:]
    # lambda = (l1, l2): |l1 u1 + l2 u2| = 1 and (l1 u1 + l2 u2) . (l1 w1 + l2 w2) = 0
    Q_norm = np.array([[u1 @ u1, u1 @ u2], [u1 @ u2, u2 @ u2]])
    c = 0.5 * (u1 @ w2 + u2 @ w1)
    Q_orth = np.array([[u1 @ w1, c], [c, u2 @ w2]])
    e, E = np.linalg.eigh(Q_orth)
    if e[0] < 0 < e[1]:
        r = np.sqrt(-e[0] / e[1])
        candidates = [E @ np.array([1.0, r]), E @ np.array([1.0, -r])]
    else:  # noise removed the real roots: take the direction closest to orthogonality
        candidates = [E[:, int(np.argmin(np.abs(e)))]]
    lam = max(candidates, key=lambda v: (v @ Q_norm @ v) / (v @ v))
    lam = lam / np.sqrt(lam @ Q_norm @ lam)
    x = lam[0] * u1 + lam[1] * u2
    x_d = lam[0] * w1 + lam[1] * w2
    x_conj = x * np.array([1.0, -1.0, -1.0, -1.0])
    t = 2.0 * quat_multiply_wxyz(x_d, x_conj)[1:]
    return make_transform(matrix_from_quat_xyzw(quat_wxyz_to_xyzw(x)), t)


register(Solver("daniilidis", "AX=XB", "Daniilidis 1999: dual quaternions", 50, daniilidis_stats, daniilidis_finish))
