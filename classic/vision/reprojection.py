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

Distortion models: with OpenCV's ``(k1, k2, p1, p2, k3)`` (or fewer) the projection is
:func:`project`'s own and the Jacobian analytic. With OpenCV's full models (rational: 8 coefficients,
thin prism: 12, tilted: 14; any nonzero beyond the fifth) the projection is ``cv2.projectPoints``'s and
the Jacobian finite differences (scipy's "2-point"); the coefficients beyond the fifth are then held
fixed, also with ``refine_intrinsics=True``, which refines ``fx, fy, cx, cy, k1, k2, p1, p2, k3`` only.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from classic.least_squares import covariance_from_jacobian, fit_least_squares, sigma_of_blocks
from classic.vision.board import BoardSpec
from classic.vision.camera import CameraIntrinsics
from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import hat, invert_transform, make_transform, so3_exp
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
    """OpenCV's pinhole projection with its distortion.

    ``(k1, k2, p1, p2, k3)`` (or fewer coefficients, or more with a zero tail) are projected here, in
    closed form; a nonzero coefficient beyond the fifth (rational, thin prism, tilted models) hands the
    projection to ``cv2.projectPoints``.

    Parameters
    ----------
    p_cam : array, shape (M, 3)
        Points in the camera frame, metres.
    fx, fy, cx, cy : float
    dist : array, shape (4,), (5,), (8,), (12,) or (14,)

    Returns
    -------
    uv : array, shape (M, 2)
        Pixels, centres at integers.
    """
    dist = np.asarray(dist, dtype=float).ravel()
    if np.any(dist[5:]):
        import cv2

        K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
        uv, _ = cv2.projectPoints(np.asarray(p_cam, dtype=float).reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, dist)
        return uv.reshape(-1, 2)
    k1, k2, p1, p2, k3 = np.pad(dist[:5], (0, max(0, 5 - dist.size)))
    x = p_cam[:, 0] / p_cam[:, 2]
    y = p_cam[:, 1] / p_cam[:, 2]
    r2 = x * x + y * y
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.column_stack([fx * xd + cx, fy * yd + cy])


def _reprojection_jacobian(
    A: np.ndarray, X: np.ndarray, Y: np.ndarray, p_target: np.ndarray, intr: np.ndarray, with_intrinsics: bool
) -> np.ndarray:
    """Analytic Jacobian of the corners' pixels w.r.t. ``[w_X, v_X, w_Y, v_Y, (fx, fy, cx, cy, k1, k2, p1, p2, k3)]``.

    ``p_cam = R_X^T (q - t_X)`` with ``q = R_A (R_Y p + t_Y) + t_A``; increments ``R <- exp(w) R``,
    ``t <- t + v``: ``dp/dw_X = R_X^T [q - t_X]x``, ``dp/dv_X = -R_X^T``, ``dp/dw_Y = -R_X^T R_A [R_Y p]x``,
    ``dp/dv_Y = R_X^T R_A``; then the pinhole and OpenCV's ``(k1, k2, p1, p2, k3)`` distortion.

    Parameters
    ----------
    A : array, shape (M, 4, 4)
        Robot-side pose of each corner's view.
    X, Y : array, shape (4, 4)
    p_target : array, shape (M, 3)
    intr : array, shape (9,)
    with_intrinsics : bool

    Returns
    -------
    array, shape (2M, 12 or 21)
        Rows ``u_0, v_0, u_1, ...``.
    """
    R_X, t_X, R_Y, t_Y = X[:3, :3], X[:3, 3], Y[:3, :3], Y[:3, 3]
    R_A, t_A = A[:, :3, :3], A[:, :3, 3]
    Ryp = p_target @ R_Y.T
    q = np.einsum("mab,mb->ma", R_A, Ryp + t_Y) + t_A
    p = (q - t_X) @ R_X  # R_X^T (q - t_X), row-wise
    m = len(p)
    dp = np.zeros((m, 3, 12))
    dp[:, :, 0:3] = R_X.T @ hat(q - t_X)
    dp[:, :, 3:6] = -R_X.T
    RxRa = R_X.T @ R_A
    dp[:, :, 6:9] = -(RxRa @ hat(Ryp))
    dp[:, :, 9:12] = RxRa
    fx, fy, cx, cy, k1, k2, p1, p2, k3 = intr
    Z = p[:, 2]
    x, y = p[:, 0] / Z, p[:, 1] / Z
    dxy = np.zeros((m, 2, 3))
    dxy[:, 0, 0] = dxy[:, 1, 1] = 1.0 / Z
    dxy[:, 0, 2] = -x / Z
    dxy[:, 1, 2] = -y / Z
    r2 = x * x + y * y
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    dradial = k1 + 2 * k2 * r2 + 3 * k3 * r2 * r2
    dd = np.empty((m, 2, 2))  # d(xd, yd) / d(x, y)
    dd[:, 0, 0] = radial + 2 * x * x * dradial + 2 * p1 * y + 6 * p2 * x
    dd[:, 0, 1] = 2 * x * y * dradial + 2 * p1 * x + 2 * p2 * y
    dd[:, 1, 0] = 2 * x * y * dradial + 2 * p1 * x + 2 * p2 * y
    dd[:, 1, 1] = radial + 2 * y * y * dradial + 6 * p1 * y + 2 * p2 * x
    duv = np.array([fx, fy])[None, :, None] * dd  # (m, 2, 2)
    J = (duv @ dxy @ dp).reshape(2 * m, 12)
    if not with_intrinsics:
        return J
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    Ji = np.zeros((m, 2, 9))
    Ji[:, 0, 0], Ji[:, 1, 1], Ji[:, 0, 2], Ji[:, 1, 3] = xd, yd, 1.0, 1.0
    for col, r_pow in ((4, r2), (5, r2 * r2), (8, r2**3)):  # k1, k2, k3
        Ji[:, 0, col], Ji[:, 1, col] = fx * x * r_pow, fy * y * r_pow
    Ji[:, 0, 6], Ji[:, 1, 6] = fx * 2 * x * y, fy * (r2 + 2 * y * y)  # p1
    Ji[:, 0, 7], Ji[:, 1, 7] = fx * (r2 + 2 * x * x), fy * 2 * x * y  # p2
    return np.concatenate([J, Ji.reshape(2 * m, 9)], axis=1)


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
        Also refine ``fx, fy, cx, cy`` and the first five distortion coefficients (further ones stay fixed).
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
    full_model = bool(np.any(intrinsics.dist[5:]))  # rational / thin prism / tilted: cv2.projectPoints, 2-point
    tail = intrinsics.dist[5:] if full_model else np.zeros(0)
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
        return (project(p_cam, *intr[:4], np.concatenate([intr[4:9], tail])) - uv).ravel()

    def jacobian(params):
        X, Y, intr = unpack(params)
        return _reprojection_jacobian(A[view], X, Y, p_target, intr, refine_intrinsics)

    n_params = 12 + (9 if refine_intrinsics else 0)
    fit = fit_least_squares(
        residuals,
        "2-point" if full_model else jacobian,
        n_params,
        loss=loss,
        loss_scale=loss_scale_px,
        max_evaluations=200,
        tol=1e-12,
    )
    X, Y, intr = unpack(fit.x)
    r = fit.residuals.reshape(-1, 2)
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
    cov = covariance_from_jacobian(fit.jacobian, fit.weights, s2)
    sigma = sigma_of_blocks(cov)
    K = np.array([[intr[0], K0[0, 1], intr[2]], [0, intr[1], intr[3]], [0, 0, 1]])
    return ReprojectionResult(
        X,
        Y,
        CameraIntrinsics(K, np.concatenate([intr[4:9], tail]), intrinsics.width, intrinsics.height),
        float(np.sqrt(np.mean(sq))),
        per_view,
        outliers,
        cov,
        sigma,
    )
