"""The rigid transform between two matched point sets (Kabsch / Umeyama, weighted), batched.

.. math:: \\min_{R, t} \\sum_i w_i \\| R p_i + t - q_i \\|^2

solved in closed form from the weighted cross-covariance (Arun et al. 1987, with Umeyama's
reflection fix). Written here rather than with ``scipy.spatial.transform.Rotation.align_vectors``
because it is batched (one fit per frame in one call) and takes NaN rows as missing. Used by the
markerless start (centroids), the keypoint model's per-frame poses and, robustly
(:func:`robust_rigid_transform`), by the cross-frame keypoint solves of ``learned`` and ``classic``.
"""

from __future__ import annotations

import numpy as np

from handeye.core.errors import ShapeError

__all__ = ["rigid_transform", "robust_rigid_transform", "rigid_residuals"]


def rigid_transform(p_from: np.ndarray, p_to: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """``T`` with ``p_to ~ T p_from`` in the weighted least-squares sense.

    Parameters
    ----------
    p_from, p_to : array, shape (..., M, 3)
        Matched points (M >= 3, not all on a line).
    weights : array, shape (..., M), optional
        Non-negative; points with weight 0, or with NaN coordinates, are ignored.

    Returns
    -------
    T : array, shape (..., 4, 4)
        NaN for a batch entry with fewer than 3 weighted points.
    """
    p_from = np.asarray(p_from, dtype=float)
    p_to = np.asarray(p_to, dtype=float)
    if p_from.shape != p_to.shape or p_from.shape[-1] != 3 or p_from.ndim < 2:
        raise ShapeError(f"point sets must both be (..., M, 3), got {p_from.shape} and {p_to.shape}")
    w = np.ones(p_from.shape[:-1]) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != p_from.shape[:-1]:
        raise ShapeError(f"weights must be {p_from.shape[:-1]}, got {w.shape}")
    finite = np.isfinite(p_from).all(-1) & np.isfinite(p_to).all(-1) & np.isfinite(w)
    if not finite.all():  # a point with NaN (a missed detection) takes no part
        w = np.where(finite, w, 0.0)
        p_from = np.where(finite[..., None], p_from, 0.0)
        p_to = np.where(finite[..., None], p_to, 0.0)
    ws = w.sum(-1, keepdims=True)
    safe = np.where(ws > 0, ws, 1.0)
    c_from = (w[..., None] * p_from).sum(-2) / safe
    c_to = (w[..., None] * p_to).sum(-2) / safe
    H = np.einsum("...m,...mi,...mj->...ij", w, p_from - c_from[..., None, :], p_to - c_to[..., None, :])
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(np.swapaxes(Vt, -1, -2) @ np.swapaxes(U, -1, -2)))
    D = np.zeros(H.shape)
    D[..., 0, 0] = 1.0
    D[..., 1, 1] = 1.0
    D[..., 2, 2] = np.where(d == 0, 1.0, d)
    R = np.swapaxes(Vt, -1, -2) @ D @ np.swapaxes(U, -1, -2)
    T = np.zeros(p_from.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = c_to - np.einsum("...ij,...j->...i", R, c_from)
    T[..., 3, 3] = 1.0
    too_few = (w > 0).sum(-1) < 3
    T[too_few] = np.nan
    return T


def rigid_residuals(T: np.ndarray, p_from: np.ndarray, p_to: np.ndarray) -> np.ndarray:
    """``T p_from - p_to`` of matched points, shape (M, 3); NaN points give NaN rows.

    Parameters
    ----------
    T : array, shape (4, 4)
        Maps ``p_from``'s frame to ``p_to``'s (:func:`rigid_transform`'s result).
    p_from, p_to : array, shape (M, 3)
    """
    return np.asarray(p_from, dtype=float) @ T[:3, :3].T + T[:3, 3] - np.asarray(p_to, dtype=float)


def robust_rigid_transform(
    p_from: np.ndarray,
    p_to: np.ndarray,
    weights: np.ndarray | None = None,
    iterations: int = 10,
    floor_m: float = 0.005,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`rigid_transform` with iteratively reweighted Cauchy weights on the residual distances.

    The scale is 1.4826 times the median residual of the points in play (at least ``floor_m``), the
    weight ``1 / (1 + (r / 2s)^2)``.

    Parameters
    ----------
    p_from, p_to : array, shape (M, 3)
    weights : array, shape (M,), optional
        Start weights (0 leaves a point out throughout); all ones by default.
    iterations : int
    floor_m : float

    Returns
    -------
    T : array, shape (4, 4)
    weights : array, shape (M,)
        The final weights.
    """
    p_from = np.asarray(p_from, dtype=float)
    p_to = np.asarray(p_to, dtype=float)
    ok = np.isfinite(p_from).all(-1) & np.isfinite(p_to).all(-1)
    w0 = ok.astype(float) if weights is None else np.where(ok, np.asarray(weights, dtype=float), 0.0)
    w = w0
    T = rigid_transform(p_from, p_to, w)
    for _ in range(iterations):
        if not np.isfinite(T).all():
            break
        r = np.linalg.norm(rigid_residuals(T, np.nan_to_num(p_from), np.nan_to_num(p_to)), axis=-1)
        s = max(1.4826 * float(np.median(r[w0 > 0])), floor_m)
        w = w0 / (1.0 + (r / (2.0 * s)) ** 2)
        T = rigid_transform(p_from, p_to, w)
    return T, w
