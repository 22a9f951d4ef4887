"""Levenberg-Marquardt refinement of X and Y on SE(3) over pose residuals.

Minimises, over the camera pose X and the target pose Y of ``A_i Y = X B_i``,

.. math:: \\sum_i \\rho\\Big(\\Big|\\frac{\\log(\\hat R_i^T R_{B_i})}{\\sigma_r}\\Big|^2
          + \\Big|\\frac{t_{B_i} - \\hat t_i}{\\sigma_t}\\Big|^2\\Big),
          \\qquad \\hat B_i = X^{-1} A_i Y,

the maximum-likelihood estimate under the camera-noise model of
:mod:`handeye.core.synthetic` (``rho`` the identity, or Huber / Cauchy for robust
fits). ``sigma_r`` (rad) and ``sigma_t`` (m) are given, or estimated from the
residuals and re-estimated once after convergence.

Parametrisation: ``R_X <- so3_exp(w_X) R_X`` and ``t_X <- t_X + v_X`` (same
for Y), so the covariance's blocks read directly as rotation error (rad, in
the frame X is expressed in) and translation error (m). Parameter order:
``[w_X, v_X, w_Y, v_Y]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from classic.residuals import pose_residuals
from handeye.core.se3 import hat, make_transform, so3_exp, so3_log

__all__ = ["LOSSES", "Refinement", "refine_xy", "robust_weights"]

LOSSES = ("linear", "huber", "cauchy")
#: Scale of the robust losses on the normalised 6-D pose residual (about the 95 % point of chi with 6 dof).
ROBUST_SCALE = 3.5
_CHI2_3_MEDIAN = 2.3660


@dataclass
class Refinement:
    """Outcome of :func:`refine_xy`.

    Attributes
    ----------
    X, Y : array, shape (4, 4)
    covariance : array, shape (12, 12)
        Of ``[w_X, v_X, w_Y, v_Y]`` (rad, m).
    sigma_rot_rad, sigma_trans_m : float
        The noise scales used (given or estimated).
    weights : array, shape (N,)
        Final robust weights per pose (all 1 for the linear loss).
    iterations : int
    cost_initial, cost_final : float
        Sum of squared normalised residuals at the start and the end (with the final scales).
    converged : bool
    """

    X: np.ndarray
    Y: np.ndarray
    covariance: np.ndarray
    sigma_rot_rad: float
    sigma_trans_m: float
    weights: np.ndarray
    iterations: int
    cost_initial: float
    cost_final: float
    converged: bool


def robust_weights(d: np.ndarray, loss: str, scale: float = ROBUST_SCALE) -> np.ndarray:
    """IRLS weights of normalised residual norms ``d`` for a loss.

    Parameters
    ----------
    d : array, shape (N,)
    loss : {"linear", "huber", "cauchy"}
    scale : float

    Returns
    -------
    w : array, shape (N,)
    """
    if loss == "linear":
        return np.ones_like(d)
    if loss == "huber":
        return np.where(d <= scale, 1.0, scale / np.maximum(d, 1e-300))
    if loss == "cauchy":
        return 1.0 / (1.0 + (d / scale) ** 2)
    raise ValueError(f"unknown loss {loss!r}: use one of {LOSSES}")


def _apply(T: np.ndarray, w: np.ndarray, v: np.ndarray) -> np.ndarray:
    return make_transform(so3_exp(w) @ T[:3, :3], T[:3, 3] + v)


def _update(X, Y, delta):
    return _apply(X, delta[0:3], delta[3:6]), _apply(Y, delta[6:9], delta[9:12])


def _scales(r_rot, r_trans, w, robust: bool, n_params: int = 12) -> tuple[float, float]:
    """Noise scales per axis from residuals: robust (median) or weighted RMS with dof correction."""
    if robust:
        s_r = np.sqrt(np.median(np.sum(r_rot**2, axis=1)) / _CHI2_3_MEDIAN)
        s_t = np.sqrt(np.median(np.sum(r_trans**2, axis=1)) / _CHI2_3_MEDIAN)
    else:
        n = w.sum()
        dof = max(6.0 * n - n_params, 1.0) / (6.0 * n)
        s_r = np.sqrt(np.sum(w * np.sum(r_rot**2, axis=1)) / (3.0 * n) / dof)
        s_t = np.sqrt(np.sum(w * np.sum(r_trans**2, axis=1)) / (3.0 * n) / dof)
    return max(float(s_r), 1e-12), max(float(s_t), 1e-12)


def _normalised(A, B, X, Y, s_r, s_t):
    r_rot, r_trans = pose_residuals(A, B, X, Y)
    return np.concatenate([r_rot / s_r, r_trans / s_t], axis=1)  # (N, 6)


def _left_jacobian_inverse(r: np.ndarray) -> np.ndarray:
    """``J_l(r)^-1`` of SO(3): ``log(exp(-d) exp(r)) = r - J_l(r)^-1 d`` to first order. Shape (N, 3, 3)."""
    theta = np.linalg.norm(r, axis=1)[:, None, None]
    K = hat(r)
    small = theta < 1e-6
    th = np.where(small, 1.0, theta)
    c = np.where(small, 1.0 / 12.0, 1.0 / th**2 - (1.0 + np.cos(th)) / (2.0 * th * np.sin(th)))
    return np.eye(3) - 0.5 * K + c * (K @ K)


def _jacobian(A, B, X, Y, s_r, s_t):
    """Analytic Jacobian of the normalised residuals w.r.t. ``[w_X, v_X, w_Y, v_Y]``, shape (6N, 12).

    With ``P_i = X^-1 A_i Y`` and ``w_i = R_A t_Y + t_A - t_X`` (so ``t_P = R_X^T w_i``):
    ``d r_rot / d w_X = Jl^-1 R_P^T R_X^T``, ``d r_rot / d w_Y = -Jl^-1 R_Y^T``,
    ``d r_t / d w_X = -R_X^T [w_i]x``, ``d r_t / d v_X = R_X^T``, ``d r_t / d v_Y = -R_X^T R_A``.
    """
    R_X, t_X, R_Y, t_Y = X[:3, :3], X[:3, 3], Y[:3, :3], Y[:3, 3]
    R_A, t_A = A[:, :3, :3], A[:, :3, 3]
    R_P = R_X.T @ R_A @ R_Y
    r_rot = so3_log(np.swapaxes(R_P, 1, 2) @ B[:, :3, :3])
    Jinv = _left_jacobian_inverse(r_rot)
    w = R_A @ t_Y + t_A - t_X
    n = len(A)
    J = np.zeros((n, 6, 12))
    J[:, :3, 0:3] = Jinv @ np.swapaxes(R_P, 1, 2) @ R_X.T / s_r
    J[:, :3, 6:9] = -(Jinv @ R_Y.T) / s_r
    J[:, 3:, 0:3] = -(R_X.T @ hat(w)) / s_t
    J[:, 3:, 3:6] = R_X.T / s_t
    J[:, 3:, 9:12] = -(R_X.T @ R_A) / s_t
    return J.reshape(6 * n, 12)


def _jacobian_numeric(A, B, X, Y, s_r, s_t, h=1e-7):
    """Central-difference Jacobian, the reference the analytic one is tested against."""
    cols = []
    for k in range(12):
        e = np.zeros(12)
        e[k] = h
        rp = _normalised(A, B, *_update(X, Y, e), s_r, s_t)
        rm = _normalised(A, B, *_update(X, Y, -e), s_r, s_t)
        cols.append((rp - rm).reshape(-1) / (2 * h))
    return np.stack(cols, axis=1)  # (6N, 12)


def _lm(A, B, X, Y, s_r, s_t, loss, max_iterations, tol):
    lam = 1e-3
    r = _normalised(A, B, X, Y, s_r, s_t)
    w = robust_weights(np.linalg.norm(r, axis=1), loss)
    cost = float(np.sum(w * np.sum(r**2, axis=1)))
    converged = False
    it = 0
    for it in range(1, max_iterations + 1):
        J = _jacobian(A, B, X, Y, s_r, s_t)
        sw = np.repeat(np.sqrt(w), 6)
        Jw = J * sw[:, None]
        rw = r.reshape(-1) * sw
        H = Jw.T @ Jw
        g = Jw.T @ rw
        improved = False
        while lam < 1e12:
            delta = np.linalg.solve(H + lam * np.diag(np.diag(H) + 1e-12), -g)
            X_new, Y_new = _update(X, Y, delta)
            r_new = _normalised(A, B, X_new, Y_new, s_r, s_t)
            cost_new = float(np.sum(w * np.sum(r_new**2, axis=1)))
            if cost_new <= cost:
                improved = True
                break
            lam *= 10.0
        if not improved:
            converged = True
            break
        rel = (cost - cost_new) / max(cost, 1e-300)
        X, Y, r = X_new, Y_new, r_new
        lam = max(lam / 10.0, 1e-12)
        w = robust_weights(np.linalg.norm(r, axis=1), loss)
        cost = float(np.sum(w * np.sum(r**2, axis=1)))
        if rel < tol or np.abs(delta).max() < 1e-14:
            converged = True
            break
    return X, Y, w, it, converged


def refine_xy(
    A: np.ndarray,
    B: np.ndarray,
    X0: np.ndarray,
    Y0: np.ndarray,
    loss: str = "linear",
    noise: tuple[float, float] | None = None,
    max_iterations: int = 50,
    tol: float = 1e-12,
) -> Refinement:
    """Refine ``A_i Y = X B_i`` by Levenberg-Marquardt from ``(X0, Y0)``.

    Parameters
    ----------
    A : array, shape (N, 4, 4)
        Robot-side poses (``T_base_ee`` eye-to-hand, ``T_ee_base`` eye-in-hand).
    B : array, shape (N, 4, 4)
        ``T_cam_target``.
    X0, Y0 : array, shape (4, 4)
        Initial camera and target poses.
    loss : {"linear", "huber", "cauchy"}
    noise : (float, float), optional
        Per-axis camera noise ``(sigma_rot_rad, sigma_trans_m)``; estimated
        from the residuals when omitted.
    max_iterations : int
    tol : float
        Relative cost decrease below which iterations stop.

    Returns
    -------
    Refinement
    """
    if loss not in LOSSES:
        raise ValueError(f"unknown loss {loss!r}: use one of {LOSSES}")
    robust = loss != "linear"
    r_rot, r_trans = pose_residuals(A, B, X0, Y0)
    if noise is None:
        s_r, s_t = _scales(r_rot, r_trans, np.ones(len(A)), robust=True)
    else:
        s_r, s_t = float(noise[0]), float(noise[1])
    X, Y, w, it1, conv = _lm(A, B, X0, Y0, s_r, s_t, loss, max_iterations, tol)
    it2 = 0
    if noise is None:
        # the scales fix the weighting of rotation against translation: re-estimate once at the optimum
        r_rot, r_trans = pose_residuals(A, B, X, Y)
        s_r, s_t = _scales(r_rot, r_trans, w, robust=robust)
        X, Y, w, it2, conv = _lm(A, B, X, Y, s_r, s_t, loss, max_iterations, tol)
        if not robust:
            r_rot, r_trans = pose_residuals(A, B, X, Y)
            s_r, s_t = _scales(r_rot, r_trans, w, robust=False)
    r0 = _normalised(A, B, X0, Y0, s_r, s_t)
    r1 = _normalised(A, B, X, Y, s_r, s_t)
    J = _jacobian(A, B, X, Y, s_r, s_t)
    sw = np.repeat(np.sqrt(w), 6)
    Jw = J * sw[:, None]
    covariance = np.linalg.pinv(Jw.T @ Jw)
    return Refinement(
        X=X,
        Y=Y,
        covariance=covariance,
        sigma_rot_rad=s_r,
        sigma_trans_m=s_t,
        weights=w,
        iterations=it1 + it2,
        cost_initial=float(np.sum(r0**2)),
        cost_final=float(np.sum(r1**2)),
        converged=conv,
    )
