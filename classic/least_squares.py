"""The one nonlinear least-squares core of the classic solvers: scipy's trust region, one covariance.

Every refinement (pose residuals in :mod:`classic.refine`, corner reprojection in
:mod:`classic.vision.reprojection`) hands this module a residual function of a parameter
increment, its Jacobian and a loss; it gets back the increment, the residuals, the Jacobian at the
optimum, the loss's weights and one covariance computed one way (:func:`covariance_from_jacobian`), which
refuses a direction of the parameters the residuals do not determine (:func:`undetermined_directions`) instead
of giving it the pseudo-inverse's zero variance.
The optimiser is :func:`scipy.optimize.least_squares` (MINPACK's Levenberg-Marquardt for least
squares, trust-region reflective with a robust loss); poses are
parametrised by increments about the start (``R <- so3_exp(w) R0``, ``t <- t0 + v``), so the
parameter vector stays a plain vector and the covariance's blocks read as rotation (rad) and
translation (m) errors.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from scipy.optimize import least_squares

from handeye.core.errors import DegenerateMotionError

__all__ = [
    "LOSSES",
    "LeastSquaresFit",
    "fit_least_squares",
    "covariance_from_jacobian",
    "undetermined_directions",
    "require_determined",
    "RANK_TOLERANCE",
    "POSE_NAMES",
    "loss_weights",
    "sigma_of_blocks",
]

#: Losses on the (whitened) residuals, as scipy names them.
LOSSES = ("linear", "huber", "cauchy", "soft_l1")
#: A direction of the parameters is undetermined where the singular value of the weighted Jacobian, its columns
#: scaled to unit norm (so that radians, metres and pixels weigh alike), is below this share of the largest:
#: ``sqrt(eps)`` = 1.5e-8. An exact degeneracy leaves rounding there (a few ``eps``: 1e-16 to 1e-15 on the
#: motions about one axis); a direction above it is determined, if weakly, and keeps its (large) sigma.
RANK_TOLERANCE = float(np.sqrt(np.finfo(float).eps))
#: The pose parameters ``[w_X, v_X, w_Y, v_Y]`` (:func:`sigma_of_blocks`' order), as a refusal names them.
POSE_NAMES = ("X rotation",) * 3 + ("X translation",) * 3 + ("Y rotation",) * 3 + ("Y translation",) * 3
#: A block of parameters is named in a refusal when its share of the undetermined directions (the norm of their
#: unit-free components on it) is at least this.
_NAMED_SHARE = 0.1


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


def covariance_from_jacobian(
    J: np.ndarray,
    weights: np.ndarray | None = None,
    variance: float = 1.0,
    names: Sequence[str] | None = None,
    remedy: str = "",
    undetermined: str = "refuse",
) -> np.ndarray:
    """Covariance of the parameters, ``variance * (J^T W J)^-1``; refused where ``J`` does not determine them.

    With whitened residuals (unit variance under the noise model) ``variance`` is 1, or the
    a-posteriori variance factor when the noise level was estimated. The loss's weights down-weight
    the residuals a robust fit discounted. A direction the residuals do not see
    (:func:`undetermined_directions`) would get zero variance from the pseudo-inverse, the smallest sigma
    exactly where the answer is unknown: it is refused (:func:`require_determined`), or, where the caller
    asked for no refusal, the parameters it moves get an infinite variance. A caller whose parametrisation
    has a genuine gauge freedom fixes it (a prior's rows, a held parameter) before calling.

    Parameters
    ----------
    J : array, shape (M, P)
    weights : array, shape (M,), optional
    variance : float
    names : sequence of P str, optional
        What each parameter is, e.g. ``"X rotation"`` three times: consecutive equal names form a block,
        named in a refusal. Default ``"parameter k"``.
    remedy : str
        Appended to a refusal's message: what data would determine the estimate.
    undetermined : {"refuse", "infinite"}
        ``infinite``: no refusal; each parameter an undetermined direction moves (its unit-free component
        above :data:`RANK_TOLERANCE`) gets variance ``inf`` and covariances ``nan`` with the others.

    Returns
    -------
    array, shape (P, P)

    Raises
    ------
    DegenerateMotionError
        A direction of the parameters is undetermined; the message names the blocks it moves.
    """
    Jw = _weighted(J, weights)
    if undetermined == "refuse":
        require_determined(Jw, names=names, remedy=remedy)
        return float(variance) * np.linalg.pinv(Jw.T @ Jw)
    if undetermined != "infinite":
        raise ValueError(f"undetermined must be 'refuse' or 'infinite', got {undetermined!r}")
    C = float(variance) * np.linalg.pinv(Jw.T @ Jw)
    V, _ = _null_space(np.asarray(Jw, dtype=float))
    free = np.flatnonzero(np.linalg.norm(V, axis=1) > RANK_TOLERANCE)
    C[free, :] = np.nan
    C[:, free] = np.nan
    C[free, free] = np.inf
    return C


def _weighted(J: np.ndarray, weights: np.ndarray | None) -> np.ndarray:
    return J if weights is None else J * np.sqrt(np.asarray(weights, dtype=float))[:, None]


def undetermined_directions(J: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Unit directions ``d`` of the parameters with ``J d = 0`` to working precision (:data:`RANK_TOLERANCE`).

    Judged on ``J sqrt(W)`` with its columns scaled to unit norm, so the parameters' units do not matter; a
    parameter the residuals do not depend on (a zero column) is one such direction.

    Parameters
    ----------
    J : array, shape (M, P)
    weights : array, shape (M,), optional

    Returns
    -------
    array, shape (P, k)
        Orthonormal in the column-scaled parameters; each column scaled back to the parameters' units and
        normalised. ``k = 0`` when every direction is determined.
    """
    V, norms = _null_space(_weighted(np.asarray(J, dtype=float), weights))
    D = V / norms[:, None]
    return D / np.linalg.norm(D, axis=0, keepdims=True) if D.size else D


def _null_space(Jw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The undetermined directions in the column-scaled parameters, shape (P, k), and the column scales (P,)."""
    P = Jw.shape[1]
    norms = np.linalg.norm(Jw, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    R = np.linalg.qr(Jw / norms, mode="r")  # the singular values and right vectors of the tall Jacobian, cheaply
    _, s, Vt = np.linalg.svd(R)
    sv = np.zeros(P)
    sv[: len(s)] = s
    null = sv <= RANK_TOLERANCE * sv.max() if sv.max() > 0 else np.ones(P, dtype=bool)
    return Vt[null].T, norms


def require_determined(
    J: np.ndarray,
    weights: np.ndarray | None = None,
    names: Sequence[str] | None = None,
    remedy: str = "",
) -> None:
    """Raise when ``J sqrt(W)`` leaves a direction of the parameters undetermined, naming what it moves.

    Parameters
    ----------
    J : array, shape (M, P)
    weights : array, shape (M,), optional
    names : sequence of P str, optional
        As :func:`covariance_from_jacobian` takes them.
    remedy : str
        Appended to the message.

    Raises
    ------
    DegenerateMotionError
        With the number of undetermined directions and the blocks of parameters they move (for a single
        direction, its unit vector on each block of several parameters, in that block's units).
    ValueError
        ``names`` does not name every parameter.
    """
    V, norms = _null_space(_weighted(np.asarray(J, dtype=float), weights))
    labels = list(names) if names is not None else [f"parameter {i}" for i in range(len(norms))]
    if len(labels) != len(norms):
        raise ValueError(f"{len(labels)} names for {len(norms)} parameters")
    k = V.shape[1]
    if k == 0:
        return
    parts = []
    for label, idx in _blocks(labels):
        if np.linalg.norm(V[idx]) / np.sqrt(k) < _NAMED_SHARE:
            continue
        if k == 1 and len(idx) > 1:
            d = V[idx, 0] / norms[idx]
            d = d / np.linalg.norm(d)
            label += " along [" + ", ".join(f"{c:+.3f}" for c in d) + "]"
        parts.append(label)
    raise DegenerateMotionError(
        f"the data do not determine {k} direction{'s' if k > 1 else ''} of the estimate: {', '.join(parts)} "
        "(its sigma would read as 0 where the answer is unknown)" + (f"; {remedy}" if remedy else "")
    )


def _blocks(labels: list[str]) -> list[tuple[str, list[int]]]:
    """Runs of equal consecutive labels: ``(label, indices)``."""
    out: list[tuple[str, list[int]]] = []
    for i, label in enumerate(labels):
        if out and out[-1][0] == label and out[-1][1][-1] == i - 1:
            out[-1][1].append(i)
        else:
            out.append((label, [i]))
    return out


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
