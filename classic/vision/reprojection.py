"""Hand-eye refinement on board-corner reprojection error (the paper's third formulation, section 2.1).

X and Y (and optionally the intrinsics) minimise the pixel residuals of every
detected corner over all views,

.. math:: \\sum_{i,k} \\rho\\big(|\\pi(K, d, X^{-1} A_i Y\\, p_k) - u_{ik}|^2\\big),

with ``A_i`` the robot-side poses of :mod:`handeye.core.setups`, ``p_k`` the
corners in the target frame and ``u_ik`` their detections. This is the
maximum-likelihood estimate under pixel noise: the per-view PnP poses that the
pose-based solvers take are not needed, and views with few corners count for
what they hold.

Parametrisation as in :mod:`classic.refine`: ``R <- so3_exp(w) R``,
``t <- t + v`` for X then Y, then ``(fx, fy, cx, cy, k1, k2, p1, p2, k3)``
when the intrinsics are refined.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from classic.vision.board import BoardSpec
from classic.vision.camera import CameraIntrinsics
from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import invert_transform, make_transform, so3_exp
from handeye.core.setups import normalize_setup, robot_side_poses

__all__ = ["ReprojectionResult", "OUTLIER_VIEW_FACTOR", "project", "refine_reprojection"]

#: A view whose RMS exceeds this multiple of the median view RMS (and 1 px) is flagged as an outlier.
OUTLIER_VIEW_FACTOR = 3.0


@dataclass
class ReprojectionResult:
    """Outcome of :func:`refine_reprojection`.

    Attributes
    ----------
    X, Y : array, shape (4, 4)
        Camera pose and target pose (:mod:`handeye.core.setups`).
    intrinsics : CameraIntrinsics
        Refined when asked for, else equal to the input.
    rms_px : float
        Over all corners.
    per_view_rms_px : array, shape (V,)
    outlier_views : list of int
        Views whose RMS exceeds ``OUTLIER_VIEW_FACTOR`` times the median (and 1 px).
    covariance : array, shape (P, P)
        Of the parameters (X, Y, [intrinsics]), from the Jacobian at the optimum. With fixed
        intrinsics it leaves out their own uncertainty: intrinsics calibrated from few views bias X
        by more than this predicts; refine them (``refine_intrinsics=True``) to include it.
    sigma : dict
        ``X_rotation_deg``, ``X_translation_mm``, ``Y_rotation_deg``, ``Y_translation_mm``.
    """

    X: np.ndarray
    Y: np.ndarray
    intrinsics: CameraIntrinsics
    rms_px: float
    per_view_rms_px: np.ndarray
    outlier_views: list
    covariance: np.ndarray
    sigma: dict = field(default_factory=dict)


def project(p_cam: np.ndarray, fx: float, fy: float, cx: float, cy: float, dist: np.ndarray) -> np.ndarray:
    """OpenCV's pinhole projection with ``(k1, k2, p1, p2, k3)`` distortion.

    Parameters
    ----------
    p_cam : array, shape (M, 3)
        Points in the camera frame, metres.
    fx, fy, cx, cy : float
    dist : array, shape (5,)

    Returns
    -------
    uv : array, shape (M, 2)
        Pixels, centres at integers.
    """
    k1, k2, p1, p2, k3 = dist
    x = p_cam[:, 0] / p_cam[:, 2]
    y = p_cam[:, 1] / p_cam[:, 2]
    r2 = x * x + y * y
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.column_stack([fx * xd + cx, fy * yd + cy])


def _pose(T0: np.ndarray, w: np.ndarray, v: np.ndarray) -> np.ndarray:
    return make_transform(so3_exp(w) @ T0[:3, :3], T0[:3, 3] + v)


def refine_reprojection(
    T_base_ee: np.ndarray,
    corner_ids: list[np.ndarray],
    corners_px: list[np.ndarray],
    spec: BoardSpec,
    intrinsics: CameraIntrinsics,
    X0: np.ndarray,
    Y0: np.ndarray,
    setup: str = "eye_to_hand",
    refine_intrinsics: bool = False,
    loss: str = "linear",
    loss_scale_px: float = 1.0,
) -> ReprojectionResult:
    """Refine X and Y (and optionally the intrinsics) on corner reprojection error.

    Parameters
    ----------
    T_base_ee : array, shape (V, 4, 4)
        Robot pose of each view.
    corner_ids : list of V arrays of int
        Corner ids detected in each view.
    corners_px : list of V arrays, shape (M_i, 2)
        Their pixel positions.
    spec : BoardSpec
    intrinsics : CameraIntrinsics
    X0, Y0 : array, shape (4, 4)
        Initial camera and target poses, e.g. from :func:`classic.calibrate` on the PnP poses.
    setup : {"eye_to_hand", "eye_in_hand"}
    refine_intrinsics : bool
        Also refine ``fx, fy, cx, cy`` and the five distortion coefficients.
    loss : {"linear", "huber", "cauchy", "soft_l1"}
        scipy's loss on each pixel residual.
    loss_scale_px : float
        Where the robust loss starts to bend, pixels.

    Returns
    -------
    ReprojectionResult

    Raises
    ------
    HandEyeInputError
        Mismatched counts, or fewer than 3 views with corners.
    """
    setup = normalize_setup(setup)
    n_views = len(T_base_ee)
    if not (len(corner_ids) == len(corners_px) == n_views):
        raise HandEyeInputError(
            f"{n_views} robot poses but {len(corner_ids)} corner-id lists and {len(corners_px)} corner lists: "
            "one entry per view is needed"
        )
    view = np.concatenate([np.full(len(ids), k) for k, ids in enumerate(corner_ids)] + [np.zeros(0)]).astype(int)
    if len(np.unique(view)) < 3:
        raise HandEyeInputError("the reprojection refinement needs corners in at least 3 views")
    p_target = spec.corners_target()[np.concatenate(corner_ids).astype(int)]
    uv = np.concatenate([np.asarray(c, dtype=float).reshape(-1, 2) for c in corners_px])
    A = robot_side_poses(np.asarray(T_base_ee, dtype=float), setup)
    K0 = intrinsics.K
    if np.any(intrinsics.dist[5:]):
        raise HandEyeInputError("the reprojection refinement models (k1, k2, p1, p2, k3) distortion only; "
                                f"got {intrinsics.dist.size} nonzero-tailed coefficients")
    d0 = np.zeros(5)
    d0[: min(5, intrinsics.dist.size)] = intrinsics.dist[:5]
    intr0 = np.array([K0[0, 0], K0[1, 1], K0[0, 2], K0[1, 2], *d0[:5]])

    def unpack(params):
        X = _pose(X0, params[0:3], params[3:6])
        Y = _pose(Y0, params[6:9], params[9:12])
        intr = intr0 + params[12:] if refine_intrinsics else intr0
        return X, Y, intr

    def residuals(params):
        X, Y, intr = unpack(params)
        T_cam_target = invert_transform(X) @ A @ Y  # (V, 4, 4)
        R, t = T_cam_target[view, :3, :3], T_cam_target[view, :3, 3]
        p_cam = np.einsum("mab,mb->ma", R, p_target) + t
        return (project(p_cam, *intr[:4], intr[4:9]) - uv).ravel()

    n_params = 12 + (9 if refine_intrinsics else 0)
    sol = least_squares(residuals, np.zeros(n_params), method="trf", loss=loss, f_scale=loss_scale_px,
                        x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=200)
    X, Y, intr = unpack(sol.x)
    r = residuals(sol.x).reshape(-1, 2)
    sq = np.sum(r**2, axis=1)
    counts = np.bincount(view, minlength=n_views)
    per_view = np.sqrt(np.bincount(view, weights=sq, minlength=n_views) / np.maximum(counts, 1))
    has = np.bincount(view, minlength=n_views) > 0
    med = float(np.median(per_view[has]))
    outliers = [int(k) for k in np.flatnonzero(has & (per_view > max(OUTLIER_VIEW_FACTOR * med, 1.0)))]
    if loss == "linear":
        s2 = float(np.sum(sq)) / max(2 * len(uv) - n_params, 1)  # per-axis variance, dof-corrected
    else:
        # a robust fit's outliers must not set the scale: |r|^2 / s^2 is chi2 with 2 dof, median 1.386
        s2 = float(np.median(sq)) / 1.3863
    J = sol.jac
    cov = s2 * np.linalg.pinv(J.T @ J)
    tr = [np.trace(cov[k : k + 3, k : k + 3]) for k in (0, 3, 6, 9)]
    sigma = {
        "X_rotation_deg": float(np.degrees(np.sqrt(tr[0]))), "X_translation_mm": float(1000 * np.sqrt(tr[1])),
        "Y_rotation_deg": float(np.degrees(np.sqrt(tr[2]))), "Y_translation_mm": float(1000 * np.sqrt(tr[3])),
    }
    K = np.array([[intr[0], K0[0, 1], intr[2]], [0, intr[1], intr[3]], [0, 0, 1]])
    return ReprojectionResult(
        X, Y, CameraIntrinsics(K, intr[4:9], intrinsics.width, intrinsics.height),
        float(np.sqrt(np.mean(sq))), per_view, outliers, cov, sigma,
    )
