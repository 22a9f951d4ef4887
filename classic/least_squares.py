"""The one nonlinear least-squares core of the classic solvers: scipy's trust region, one covariance.

Every refinement (pose residuals in :mod:`classic.refine`, corner reprojection in
:mod:`classic.vision.reprojection`) hands this module a residual function of a parameter
increment, its Jacobian and a loss; it gets back the increment, the residuals, the Jacobian at the
optimum, the loss's weights and one covariance computed one way (:func:`covariance_from_jacobian`).
The optimiser is :func:`scipy.optimize.least_squares` (MINPACK's Levenberg-Marquardt for least
squares, trust-region reflective with a robust loss); poses are
parametrised by increments about the start (``R <- so3_exp(w) R0``, ``t <- t0 + v``), so the
parameter vector stays a plain vector and the covariance's blocks read as rotation (rad) and
translation (m) errors.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.optimize import least_squares

__all__ = [
    "LOSSES",
    "LeastSquaresFit",
    "fit_least_squares",
    "covariance_from_jacobian",
    "loss_weights",
    "sigma_of_blocks",
]

#: Losses on the (whitened) residuals, as scipy names them.
LOSSES = ("linear", "huber", "cauchy", "soft_l1")


@dataclass
class LeastSquaresFit:
    """Outcome of :func:`fit_least_squares`.

    Attributes
    ----------
    x : array, shape (P,)
        Parameter increment at the optimum.
    residuals : array, shape (M,)
        Unweighted residuals at ``x``.
    jacobian : array, shape (M, P)
        Of the residuals at ``x``.
    weights : array, shape (M,)
        The loss's weight on each residual at ``x`` (``rho'(r^2 / s^2)``; all 1 for ``linear``).
    cost_initial, cost_final : float
        Sum of squared residuals (no loss) at the start and at ``x``.
    evaluations : int
        Residual evaluations.
    converged : bool
        scipy's status > 0 (a tolerance met), or nothing to do.
    """

    x: np.ndarray
    residuals: np.ndarray
    jacobian: np.ndarray
    weights: np.ndarray
    cost_initial: float
    cost_final: float
    evaluations: int
    converged: bool


def loss_weights(r: np.ndarray, loss: str, scale: float = 1.0) -> np.ndarray:
    """``rho'(z)`` at ``z = (r / scale)^2`` for scipy's losses: the IRLS weight of each residual.

    Parameters
    ----------
    r : array, shape (M,)
    loss : {"linear", "huber", "cauchy", "soft_l1"}
    scale : float
        scipy's ``f_scale``.

    Returns
    -------
    array, shape (M,)
    """
    z = (np.asarray(r, dtype=float) / scale) ** 2
    if loss == "linear":
        return np.ones_like(z)
    if loss == "huber":
        return np.where(z <= 1.0, 1.0, 1.0 / np.sqrt(np.maximum(z, 1e-300)))
    if loss == "cauchy":
        return 1.0 / (1.0 + z)
    if loss == "soft_l1":
        return 1.0 / np.sqrt(1.0 + z)
    raise ValueError(f"unknown loss {loss!r}: use one of {LOSSES}")


def fit_least_squares(
    fun: Callable[[np.ndarray], np.ndarray],
    jac: Callable[[np.ndarray], np.ndarray] | str,
    n_params: int,
    loss: str = "linear",
    loss_scale: float = 1.0,
    max_evaluations: int = 100,
    tol: float = 1e-12,
) -> LeastSquaresFit:
    """Minimise ``sum rho(fun(x)^2)`` from ``x = 0``.

    Parameters
    ----------
    fun : callable
        ``x (P,) -> residuals (M,)``.
    jac : callable or "2-point"
        ``x -> (M, P)`` Jacobian (analytic), or scipy's finite differences by name.
    n_params : int
    loss : {"linear", "huber", "cauchy", "soft_l1"}
    loss_scale : float
        Where a robust loss starts to bend, in the residuals' units.
    max_evaluations : int
        0 evaluates at the start and returns it.
    tol : float
        scipy's ``xtol``, ``ftol`` and ``gtol``.

    Returns
    -------
    LeastSquaresFit
    """
    if loss not in LOSSES:
        raise ValueError(f"unknown loss {loss!r}: use one of {LOSSES}")
    x0 = np.zeros(n_params)
    r0 = np.asarray(fun(x0), dtype=float)
    if max_evaluations <= 0:
        J = np.asarray(jac(x0)) if callable(jac) else _numeric_jacobian(fun, x0, r0)
        c0 = float(r0 @ r0)
        return LeastSquaresFit(x0, r0, J, loss_weights(r0, loss, loss_scale), c0, c0, 1, True)
    # MINPACK's Levenberg-Marquardt (QR) for least squares, several times faster than the trust-region
    # reflective method on these small dense problems; the latter where a robust loss needs it
    method = "lm" if loss == "linear" and r0.size >= n_params else "trf"
    sol = least_squares(
        fun,
        x0,
        jac=jac,
        method=method,
        loss=loss,
        f_scale=loss_scale,
        x_scale="jac",
        xtol=tol,
        ftol=tol,
        gtol=tol,
        max_nfev=max(max_evaluations, n_params + 1),
    )
    r = np.asarray(fun(sol.x), dtype=float)
    J = np.asarray(jac(sol.x)) if callable(jac) else np.asarray(sol.jac)
    return LeastSquaresFit(
        sol.x,
        r,
        J,
        loss_weights(r, loss, loss_scale),
        float(r0 @ r0),
        float(r @ r),
        int(sol.nfev),
        bool(sol.status > 0),
    )


def _numeric_jacobian(fun, x, r, h=1e-7):
    cols = []
    for k in range(x.size):
        e = np.zeros_like(x)
        e[k] = h
        cols.append((np.asarray(fun(x + e)) - r) / h)
    return np.stack(cols, axis=1)


def covariance_from_jacobian(J: np.ndarray, weights: np.ndarray | None = None, variance: float = 1.0) -> np.ndarray:
    """Covariance of the parameters, ``variance * (J^T W J)^-1`` (pseudo-inverse when singular).

    With whitened residuals (unit variance under the noise model) ``variance`` is 1, or the
    a-posteriori variance factor when the noise level was estimated. The loss's weights down-weight
    the residuals a robust fit discounted.

    Parameters
    ----------
    J : array, shape (M, P)
    weights : array, shape (M,), optional
    variance : float

    Returns
    -------
    array, shape (P, P)
    """
    Jw = J if weights is None else J * np.sqrt(np.asarray(weights, dtype=float))[:, None]
    return float(variance) * np.linalg.pinv(Jw.T @ Jw)


def sigma_of_blocks(covariance: np.ndarray) -> dict:
    """1-sigma magnitudes (``sqrt`` of the trace) of the ``[w_X, v_X, w_Y, v_Y]`` blocks, deg and mm.

    Parameters
    ----------
    covariance : array, shape (P, P), P >= 12

    Returns
    -------
    dict
        ``X_rotation_deg``, ``X_translation_mm``, ``Y_rotation_deg``, ``Y_translation_mm``.
    """
    tr = [float(np.trace(covariance[k : k + 3, k : k + 3])) for k in (0, 3, 6, 9)]
    return {
        "X_rotation_deg": float(np.degrees(np.sqrt(tr[0]))),
        "X_translation_mm": 1000 * float(np.sqrt(tr[1])),
        "Y_rotation_deg": float(np.degrees(np.sqrt(tr[2]))),
        "Y_translation_mm": 1000 * float(np.sqrt(tr[3])),
    }
