"""The camera pose from image observations of points known in the base frame (PnP refinement).

.. math:: \\min_{T} \\sum_i \\rho\\big(\\| \\pi(T_{cam,base}\\, p_i) - x_i \\|^2 / s^2\\big)

Gauss-Newton with iteratively reweighted Cauchy weights from a start (for example a 3-D to 3-D
fit). The points may come from many frames of a static camera: the camera pose is the same for
all, only the base-frame positions differ (forward kinematics). Image coordinates are
normalised, ``x_n = (u + 0.5) / W`` (see :mod:`learned.keypoints`), with
``intrinsics_norm = (fx / W, fy / H, (cx + 0.5) / W, (cy + 0.5) / H)``; plain pixels work the same
with ``(fx, fy, cx, cy)``.

Written here, numpy only, because the learned module (which may not import ``classic``) and the
classic keypoint solve both need it; a few lines of Gauss-Newton do the job.
"""

from __future__ import annotations

import numpy as np

from handeye.core.se3 import hat, invert_transform, make_transform, so3_exp

__all__ = ["refine_pnp"]


def refine_pnp(T_base_cam: np.ndarray, p_base: np.ndarray, x_obs: np.ndarray, intrinsics: np.ndarray,
               iterations: int = 15, scale: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Refine ``T_base_cam`` on reprojection residuals, robustly.

    Parameters
    ----------
    T_base_cam : array, shape (4, 4)
        Start.
    p_base : array, shape (M, 3)
        Points in the base frame, metres (NaN rows ignored).
    x_obs : array, shape (M, 2)
        Their observed image coordinates.
    intrinsics : array, shape (4,) or (M, 4)
        ``(fx, fy, cx, cy)`` in the units of ``x_obs``.
    iterations : int
    scale : float, optional
        Cauchy scale of the residual norm; by default 2x the median residual at each step.

    Returns
    -------
    T_base_cam : array, shape (4, 4)
    weights : array, shape (M,)
    """
    p_base = np.asarray(p_base, dtype=float)
    x_obs = np.asarray(x_obs, dtype=float)
    k = np.broadcast_to(np.asarray(intrinsics, dtype=float), (len(p_base), 4))
    ok = np.isfinite(p_base).all(1) & np.isfinite(x_obs).all(1) & np.isfinite(k).all(1)
    p, x, k = p_base[ok], x_obs[ok], k[ok]
    T_cb = invert_transform(np.asarray(T_base_cam, dtype=float))
    w_all = np.zeros(len(p_base))
    if len(p) < 3:
        return np.asarray(T_base_cam, dtype=float), w_all
    for _ in range(iterations):
        pc = p @ T_cb[:3, :3].T + T_cb[:3, 3]
        z = pc[:, 2]
        front = z > 1e-6
        zs = np.where(front, z, 1.0)
        proj = np.stack([k[:, 0] * pc[:, 0] / zs + k[:, 2], k[:, 1] * pc[:, 1] / zs + k[:, 3]], axis=1)
        r = (proj - x).reshape(-1)
        rn = np.linalg.norm((proj - x), axis=1)
        s = scale if scale is not None else max(2.0 * float(np.median(rn[front])) if front.any() else 1.0, 1e-12)
        w = np.where(front, 1.0 / (1.0 + (rn / s) ** 2), 0.0)
        # d proj / d p_cam, then d p_cam / d xi for the left perturbation exp(xi) T_cam_base
        Jp = np.zeros((len(p), 2, 3))
        Jp[:, 0, 0] = k[:, 0] / zs
        Jp[:, 0, 2] = -k[:, 0] * pc[:, 0] / zs**2
        Jp[:, 1, 1] = k[:, 1] / zs
        Jp[:, 1, 2] = -k[:, 1] * pc[:, 1] / zs**2
        Jxi = np.concatenate([-hat(pc), np.broadcast_to(np.eye(3), (len(p), 3, 3))], axis=2)
        J = (Jp @ Jxi).reshape(-1, 6)
        ww = np.repeat(w, 2)
        H = (J * ww[:, None]).T @ J
        g = (J * ww[:, None]).T @ r
        xi = -np.linalg.solve(H + 1e-12 * np.trace(H) * np.eye(6), g)
        T_cb = make_transform(so3_exp(xi[:3]), xi[3:]) @ T_cb
        if np.linalg.norm(xi) < 1e-12:
            break
    w_all[ok] = w
    return invert_transform(T_cb), w_all
