"""The covariance of each board pose from its corners: what a PnP pose is worth, per direction.

A board pose from PnP is good across the optical axis and several times worse along it, and its
tilts trade against its lateral position. The hand-eye refinement weighs each pose by that
covariance (:class:`classic.noise_model.NoiseModel` ``camera_covariance``), so it needs it in the
camera-noise convention of :mod:`classic.noise_model`: ``R <- R exp(w)`` (target frame),
``t <- t + n`` (camera frame). It is ``s^2 (J^T J)^-1`` with ``J`` the corners' pixel Jacobian with
respect to ``[w, n]`` (central differences of :func:`classic.vision.reprojection.project`) and
``s`` the pixel noise, pooled over all views (one detector, one camera).
"""

from __future__ import annotations

import numpy as np

from classic.least_squares import require_determined
from classic.vision.board import BoardSpec
from classic.vision.camera import CameraIntrinsics
from classic.vision.reprojection import project
from handeye.core.errors import DegenerateMotionError, HandEyeInputError
from handeye.core.se3 import so3_exp

__all__ = ["pose_covariances"]


def _pixels(T: np.ndarray, p_target: np.ndarray, K: np.ndarray, dist: np.ndarray, delta: np.ndarray) -> np.ndarray:
    R = T[:3, :3] @ so3_exp(delta[:3])
    t = T[:3, 3] + delta[3:]
    return project(p_target @ R.T + t, K[0, 0], K[1, 1], K[0, 2], K[1, 2], dist)


def pose_covariances(
    T_cam_target: np.ndarray,
    corner_ids: list,
    corners_px: list,
    spec: BoardSpec,
    intrinsics: CameraIntrinsics,
    pixel_sigma: float | None = None,
) -> tuple[np.ndarray, float]:
    """Covariance of each view's board pose from its corners.

    Parameters
    ----------
    T_cam_target : array, shape (V, 4, 4)
        Board poses (PnP).
    corner_ids : list of V arrays of int
    corners_px : list of V arrays, shape (M_i, 2)
    spec : BoardSpec
    intrinsics : CameraIntrinsics
        Any of OpenCV's distortion models (4, 5, 8, 12 or 14 coefficients).
    pixel_sigma : float, optional
        Corner noise per axis, pixels; pooled from the views' reprojection residuals when omitted.

    Returns
    -------
    covariances : array, shape (V, 6, 6)
        ``[w (target frame, rad), n (camera frame, m)]``.
    pixel_sigma : float
        The pixel noise used.
    """
    T = np.asarray(T_cam_target, dtype=float).reshape(-1, 4, 4)
    if not (len(T) == len(corner_ids) == len(corners_px)):
        raise HandEyeInputError(f"{len(T)} poses, {len(corner_ids)} id lists and {len(corners_px)} corner lists")
    d = np.asarray(intrinsics.dist, dtype=float).ravel()
    dist = d if np.any(d[5:]) else np.pad(d[:5], (0, max(0, 5 - d.size)))  # full models go to cv2.projectPoints
    K = intrinsics.K
    corners = spec.corners_target()
    h = 1e-6
    infos, sq, dof = [], 0.0, 0
    for view, (Tv, ids, uv) in enumerate(zip(T, corner_ids, corners_px)):
        p = corners[np.asarray(ids, dtype=int)]
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        if len(p) < 4:
            raise HandEyeInputError(f"a view with {len(p)} corners has no pose covariance (at least 4 needed)")
        zero = np.zeros(6)
        r = _pixels(Tv, p, K, dist, zero) - uv
        sq += float(np.sum(r**2))
        dof += 2 * len(p) - 6
        J = np.empty((2 * len(p), 6))
        for k in range(6):
            e = np.zeros(6)
            e[k] = h
            J[:, k] = (_pixels(Tv, p, K, dist, e) - _pixels(Tv, p, K, dist, -e)).ravel() / (2 * h)
        try:  # corners on one line leave the turn about it free: the pseudo-inverse would give it sigma 0
            require_determined(J, names=["rotation"] * 3 + ["translation"] * 3)
        except DegenerateMotionError as exc:
            raise HandEyeInputError(
                f"view {view}: its {len(p)} corners do not determine the board's pose ({exc}); leave the view out"
            ) from None
        infos.append(J.T @ J)
    s = float(pixel_sigma) if pixel_sigma is not None else float(np.sqrt(sq / max(dof, 1)))
    s = max(s, 1e-6)
    return np.stack([s**2 * np.linalg.pinv(info) for info in infos]), s
