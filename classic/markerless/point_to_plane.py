"""Robust point-to-plane least squares for a camera pose, with a covariance that trusts frames, not pixels.

Observed points ``p`` (camera frame) are matched to model points ``m`` with
outward normals ``n`` (base frame). The camera pose minimises

.. math:: \\sum_i \\rho\\big(n_i^T (T_{base,cam}\\, p_i - m_i) / s\\big)

with ``rho`` a robust loss and ``s`` the residual scale. The pose is
perturbed on the right, ``T = T_0 \\exp(\\xi)``, ``\\xi = (\\omega, v)`` in the
camera frame, so ``\\omega`` is the camera's rotation error and ``R_0 v`` its
position error in the base frame.

Written by hand (iteratively reweighted Gauss-Newton, one 6x6 solve per
step) rather than with ``scipy.optimize.least_squares``: the matches change
after every step (ICP), so each problem is a handful of linear solves, and
the exact Jacobian at the current pose is the closed form below.

The covariance is the sandwich (cluster-robust) estimate with one cluster per
frame: neighbouring pixels of one frame share the model's discretisation and
the sensor's systematic error, so counting them as independent would make
the sigma far too small. The plain ``s^2 H^{-1}`` is kept as a floor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from classic.clustered_covariance import clustered_covariance
from classic.least_squares import loss_weights
from classic.markerless.curvature import second_order_residual
from handeye.core.se3 import make_transform, so3_exp

__all__ = ["PlaneFit", "solve_point_to_plane", "apply_right"]


@dataclass
class PlaneFit:
    """Result of :func:`solve_point_to_plane`.

    Attributes
    ----------
    T_base_cam : array, shape (4, 4)
    covariance : array, shape (6, 6)
        Of ``(omega, v)``, the right perturbation in the camera frame (radians, metres).
    residuals_m : array, shape (N,)
        Signed point-to-plane residuals at the solution.
    weights : array, shape (N,)
        Robust weights at the solution (1 inlier, 0 outlier).
    group : array of int, shape (N,)
        Frame of each residual (all 0 when no groups were given).
    steps : int
    step_norm : float
        Size of the last update: rotation (rad) plus translation (m).
    """

    T_base_cam: np.ndarray
    covariance: np.ndarray
    residuals_m: np.ndarray
    weights: np.ndarray
    group: np.ndarray
    steps: int
    step_norm: float


def apply_right(T: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """``T @ [exp(omega) | v]``: the right perturbation of the parametrisation above, ``xi = (omega, v)``."""
    return T @ make_transform(so3_exp(xi[:3]), xi[3:])


def _linearise(p_cam, m_base, n_base, T, shape=None):
    R, t = T[:3, :3], T[:3, 3]
    x_base = p_cam @ R.T + t
    if shape is None:
        r, grad = np.einsum("ij,ij->i", n_base, x_base - m_base), n_base
    else:
        r, grad = second_order_residual(x_base, m_base, n_base, *shape)
    n_cam = grad @ R  # R^T grad, row-wise
    J = np.hstack([np.cross(p_cam, n_cam), n_cam])
    return r, J


def solve_point_to_plane(
    p_cam: np.ndarray,
    m_base: np.ndarray,
    n_base: np.ndarray,
    T_base_cam: np.ndarray,
    scale_m: float,
    loss: str = "cauchy",
    group: np.ndarray | None = None,
    iterations: int = 5,
    tol: float = 1e-7,
    curvatures: np.ndarray | None = None,
    direction_base: np.ndarray | None = None,
) -> PlaneFit:
    """Camera pose from fixed point-to-plane matches (IRLS Gauss-Newton).

    Parameters
    ----------
    p_cam : array, shape (N, 3)
        Observed points, camera frame, metres.
    m_base, n_base : array, shape (N, 3)
        Matched model points and their unit normals, base frame.
    T_base_cam : array, shape (4, 4)
        Start.
    scale_m : float
        Residual scale of the robust loss (a few depth-noise sigmas).
    loss : {"cauchy", "huber", "linear"}
    group : array of int, shape (N,), optional
        Frame of each match, for the covariance; all one group when omitted.
    iterations : int
    tol : float
        Stop when the update (rad + m) is below this.
    curvatures : array, shape (N, 2), optional
        Principal curvatures of the model at each match (1/m); with ``direction_base`` the residual
        is taken to second order (:func:`classic.markerless.curvature.second_order_residual`), which
        removes the bias of matching a sample anywhere in a pixel on a curved surface.
    direction_base : array, shape (N, 3), optional
        First principal direction of each match, base frame.

    Returns
    -------
    PlaneFit
    """
    T = np.array(T_base_cam, dtype=float)
    shape = None if curvatures is None else (curvatures, direction_base)
    step_norm, steps = np.inf, 0
    for steps in range(1, iterations + 1):
        r, J = _linearise(p_cam, m_base, n_base, T, shape)
        w = loss_weights(r / scale_m, loss, 1.0)
        H = (J * w[:, None]).T @ J
        g = (J * w[:, None]).T @ r
        xi = -np.linalg.solve(H + 1e-12 * np.trace(H) * np.eye(6), g)
        T = apply_right(T, xi)
        step_norm = float(np.linalg.norm(xi[:3]) + np.linalg.norm(xi[3:]))
        if step_norm < tol:
            break
    r, J = _linearise(p_cam, m_base, n_base, T, shape)
    w = loss_weights(r / scale_m, loss, 1.0)
    groups = np.zeros(len(r), dtype=np.int64) if group is None else np.asarray(group)
    return PlaneFit(T, clustered_covariance(J, r, w, group), r, w, groups, steps, step_norm)
