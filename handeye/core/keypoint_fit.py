"""Maximum-likelihood camera pose from points seen as normalised image positions and depths.

A point ``p_base`` (base frame, metres) seen by a camera at ``T_base_cam`` is measured as its normalised
image position and its depth, ``(x_n, y_n, z) = (fx x / z + cx, fy y / z + cy, z)`` with
``(x, y, z) = T_cam_base p_base`` and ``intrinsics_norm = (fx, fy, cx, cy)`` (the learned keypoint
model's convention, :mod:`learned.keypoints`). Each component has its own sigma: a detector's pixel and
depth errors differ by keypoint and are not of one kind, so a millimetre of depth is not a millimetre
across the line of sight. :func:`likelihood_fit` minimises the Cauchy-robust whitened residuals of many
independent point sets at once; :func:`whitened_residuals` gives one set's residuals and Jacobian at a
pose, for its covariance. The learned placement fit (:func:`learned.keypoints.camera_pose`) and the
classic cross-frame keypoint solve (:func:`classic.keypoint_pose.solve_keypoint_pose`) both fit with it.

The pose update is ``p_cam <- exp(dw) p_cam + dv``, a left perturbation of ``T_cam_base``, which is the
right perturbation ``(-dw, -dv)`` of ``T_base_cam`` to first order: a covariance of ``(dw, dv)`` is that of
``T_base_cam``'s camera-frame right perturbation (:func:`classic.clustered_covariance.pose_sigma`).
"""

from __future__ import annotations

import numpy as np

from handeye.core.se3 import hat, so3_exp

__all__ = ["CAUCHY_SCALE", "cauchy_weights", "project", "backproject", "likelihood_fit", "whitened_residuals"]

#: Cauchy scale of the maximum-likelihood fit, in sigmas.
CAUCHY_SCALE = 2.0


def cauchy_weights(r: np.ndarray) -> np.ndarray:
    """IRLS weights ``1 / (1 + (r / c)^2)`` of whitened residuals ``r`` under the Cauchy loss of scale
    :data:`CAUCHY_SCALE` (``scipy``'s ``loss="cauchy"``), elementwise."""
    return 1.0 / (1.0 + np.square(r) / CAUCHY_SCALE**2)


def project(p_cam: np.ndarray, intrinsics_norm: np.ndarray) -> np.ndarray:
    """Camera-frame points as measured: ``(x_n, y_n, z) = (fx x / z + cx, fy y / z + cy, z)``.

    Parameters
    ----------
    p_cam : array, shape (..., 3)
        Metres.
    intrinsics_norm : array, shape (..., 4)
        ``(fx, fy, cx, cy)`` normalised, broadcast against ``p_cam``'s leading axes.

    Returns
    -------
    array, shape (..., 3)
    """
    p_cam = np.asarray(p_cam, dtype=float)
    fx, fy, cx, cy = (np.asarray(intrinsics_norm, dtype=float)[..., i] for i in range(4))
    z = p_cam[..., 2]
    return np.stack([fx * p_cam[..., 0] / z + cx, fy * p_cam[..., 1] / z + cy, z], axis=-1)


def backproject(meas: np.ndarray, intrinsics_norm: np.ndarray) -> np.ndarray:
    """Inverse of :func:`project`: camera-frame points (metres) of measured ``(x_n, y_n, z)``, shape (..., 3)."""
    meas = np.asarray(meas, dtype=float)
    fx, fy, cx, cy = (np.asarray(intrinsics_norm, dtype=float)[..., i] for i in range(4))
    z = meas[..., 2]
    return np.stack([(meas[..., 0] - cx) / fx * z, (meas[..., 1] - cy) / fy * z, z], axis=-1)


def _model_and_jacobian(p: np.ndarray, fx, fy, cx, cy, ok: np.ndarray):
    """Predicted ``(x_n, y_n, z)`` of camera-frame points ``p`` (..., M, 3), and its derivative by ``(dw, dv)``.

    The derivative has shape (..., M, 3, 6); ``ok`` (..., M) marks the points whose depth divides.
    """
    z = np.where(ok, p[..., 2], 1.0)
    model = project(np.concatenate([p[..., :2], z[..., None]], axis=-1), np.stack([fx, fy, cx, cy], axis=-1))
    D = np.zeros(p.shape + (3,))  # d model / d p_cam
    D[..., 0, 0], D[..., 0, 2] = fx / z, -fx * p[..., 0] / z**2
    D[..., 1, 1], D[..., 1, 2] = fy / z, -fy * p[..., 1] / z**2
    D[..., 2, 2] = 1.0
    eye3 = np.broadcast_to(np.eye(3), p.shape + (3,))
    return model, D @ np.concatenate([-hat(p), eye3], axis=-1)


def whitened_residuals(
    meas: np.ndarray, p_base: np.ndarray, intrinsics_norm: np.ndarray, sigma: np.ndarray, T_base_cam: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One point set's whitened residuals and their Jacobian at ``T_base_cam``.

    Parameters
    ----------
    meas, p_base : array, shape (M, 3)
        Measured ``(x_n, y_n, z_m)`` and the points in the base frame (metres).
    intrinsics_norm : array, shape (M, 4)
    sigma : array, shape (M, 3)
    T_base_cam : array, shape (4, 4)

    Returns
    -------
    r : array, shape (M, 3)
        ``(meas - predicted) / sigma``; 0 where a point is left out (not finite, or ``z <= 0``).
    J : array, shape (M, 3, 6)
        ``d r / d (dw, dv)`` (the update of :func:`likelihood_fit`); 0 where left out.
    ok : array of bool, shape (M,)
    """
    meas, p_base = np.asarray(meas, dtype=float), np.asarray(p_base, dtype=float)
    sigma = np.broadcast_to(np.asarray(sigma, dtype=float), meas.shape)
    T_cam_base = np.linalg.inv(T_base_cam)
    p = np.where(np.isfinite(p_base), p_base, 0.0) @ T_cam_base[:3, :3].T + T_cam_base[:3, 3]
    ok = np.isfinite(meas).all(-1) & (meas[..., 2] > 0) & np.isfinite(p_base).all(-1) & (p[..., 2] > 0)
    fx, fy, cx, cy = (np.asarray(intrinsics_norm, dtype=float)[..., i] for i in range(4))
    model, dmodel = _model_and_jacobian(p, fx, fy, cx, cy, ok)
    okf = ok.astype(float)[..., None]
    r = (np.where(ok[..., None], meas, 0.0) - model) / sigma * okf
    return r, -dmodel / sigma[..., None] * okf[..., None], ok


def likelihood_fit(
    meas: np.ndarray,
    p_base: np.ndarray,
    intrinsics_norm: np.ndarray,
    sigma: np.ndarray,
    T_base_cam0: np.ndarray,
    iterations: int = 50,
    ftol: float = 1e-10,
) -> tuple[np.ndarray, np.ndarray]:
    """Maximum-likelihood ``T_base_cam`` of G independent point sets, by one batched Levenberg–Marquardt.

    Minimises per set ``sum rho(((x_n, y_n, z) - project(T_cam_base p_base)) / sigma)`` over every
    point and component, ``rho`` the Cauchy loss of scale :data:`CAUCHY_SCALE` sigmas (``scipy``'s
    ``loss="cauchy"``), by iteratively reweighted Gauss–Newton steps with Levenberg damping, each set
    with its own damping and its own acceptance test. The update is ``p_cam <- exp(dw) p_cam + dv``.
    ``scipy.optimize.least_squares`` solves one problem at a time; the protocol's thousands of frames
    of six parameters each are solved here at once, in array operations, and the tests check that both
    reach the same minimum.

    Parameters
    ----------
    meas : array, shape (G, M, 3)
        Measured ``(x_n, y_n, z_m)``, offsets already removed; rows that are not finite or with
        ``z <= 0`` are left out.
    p_base : array, shape (G, M, 3)
        The points in the base frame, metres.
    intrinsics_norm : array, shape (G, M, 4)
    sigma : array, shape (M, 3) or (G, M, 3)
        Sigma of every component.
    T_base_cam0 : array, shape (G, 4, 4)
        Starts.
    iterations : int
    ftol : float
        Relative change of the cost that ends a set's iterations.

    Returns
    -------
    T_base_cam : array, shape (G, 4, 4)
    weights : array, shape (G, M)
        Cauchy weight of every point's whitened residual norm (0 where left out).
    """
    meas = np.asarray(meas, dtype=float)
    p_base = np.asarray(p_base, dtype=float)
    sigma = np.broadcast_to(np.asarray(sigma, dtype=float), meas.shape)
    ok = np.isfinite(meas).all(-1) & (meas[..., 2] > 0) & np.isfinite(p_base).all(-1)
    okf = ok.astype(float)[..., None]
    meas, pts = np.where(ok[..., None], meas, 0.0), np.where(ok[..., None], p_base, 0.0)
    fx, fy, cx, cy = (np.asarray(intrinsics_norm, dtype=float)[..., i] for i in range(4))
    c2 = CAUCHY_SCALE**2
    T_cam_base = np.linalg.inv(T_base_cam0)
    R, t = T_cam_base[:, :3, :3], T_cam_base[:, :3, 3]

    def state(R, t):
        p = np.einsum("gij,gmj->gmi", R, pts) + t[:, None, :]
        model, dmodel = _model_and_jacobian(p, fx, fy, cx, cy, ok)
        r = (meas - model) / sigma * okf
        return dmodel, r, (c2 * np.log1p(r**2 / c2)).sum(axis=(1, 2))

    dmodel, r, cost = state(R, t)
    damping = np.full(len(R), 1e-3)
    for _ in range(iterations):
        w = cauchy_weights(r)  # per component
        J = -dmodel / sigma[..., None] * okf[..., None]  # (G, M, 3, 6)
        Jw = J * w[..., None]
        H = np.einsum("gmki,gmkj->gij", Jw, J)
        g = np.einsum("gmki,gmk->gi", Jw, r)
        scale = np.trace(H, axis1=1, axis2=2) / 6.0 + 1e-300
        step = -np.linalg.solve(H + (damping * scale)[:, None, None] * np.eye(6), g[..., None])[..., 0]
        dR = so3_exp(step[:, :3])
        R_new, t_new = dR @ R, np.einsum("gij,gj->gi", dR, t) + step[:, 3:]
        dmodel_new, r_new, cost_new = state(R_new, t_new)
        better = cost_new <= cost
        done = better & (cost - cost_new <= ftol * cost)
        R, t = np.where(better[:, None, None], R_new, R), np.where(better[:, None], t_new, t)
        dmodel = np.where(better[:, None, None, None], dmodel_new, dmodel)
        r, cost = np.where(better[:, None, None], r_new, r), np.where(better, cost_new, cost)
        damping = np.where(better, damping / 3.0, damping * 10.0)
        if np.all(done | (damping > 1e12)):
            break
    T_cam_base = np.zeros((len(R), 4, 4))
    T_cam_base[:, :3, :3], T_cam_base[:, :3, 3], T_cam_base[:, 3, 3] = R, t, 1.0
    weights = np.where(ok, cauchy_weights(np.linalg.norm(r, axis=-1)), 0.0)
    return np.linalg.inv(T_cam_base), weights
