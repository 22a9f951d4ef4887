"""The robot's own pose error in the corner reprojection fit: estimated from the residuals, carried to the sigma.

A view's corners are predicted through the robot pose of that view, so an error of that pose moves all of
the view's corners together: the corners of one view are not independent. Per view ``i``, with
``delta_i ~ N(0, D)`` the robot pose error (``[w, n]``: rotation in the flange frame, translation in the base
frame, as :mod:`classic.noise_model` has it) and ``J_i`` the corners' pixel Jacobian with respect to it,

.. math:: S_i = \\sigma_{px}^2 I + J_i D J_i^T, \\qquad
          D = \\mathrm{diag}(\\sigma_r^2 I_3, \\sigma_t^2 I_3).

The three scalars ``(sigma_px, sigma_r, sigma_t)`` are estimated by restricted maximum likelihood (REML,
Patterson & Thompson 1971; Harville, "Maximum likelihood approaches to variance component estimation",
JASA 72(358), 1977) from the residuals ``r_i`` and the parameters' Jacobian ``G_i``:

.. math:: -2 \\ell_R = \\sum_i \\log|S_i| + \\log|G^T S^{-1} G| + r^T S^{-1} r
          - r^T S^{-1} G (G^T S^{-1} G)^{-1} G^T S^{-1} r,

evaluated per view through the 6x6 Woodbury form (``S_i^{-1} = \\sigma^{-2}(I - J_i L M_i^{-1} L J_i^T)``,
``L = D^{1/2}``, ``M_i = \\sigma^2 I + L J_i^T J_i L``), so that a robot error of zero is an ordinary point
of the search. The refit is then generalised least squares with ``S_i`` (:mod:`classic.vision.reprojection`),
and the covariance of the parameters ``(G^T S^{-1} G)^{-1}``. REML rather than plain maximum likelihood: the
12 (or 21) fitted parameters take their share of the residuals, which plain ML would count as smaller noise.

With an exact robot the estimate of ``sigma_r, sigma_t`` is zero or of the order of its own sampling error,
and the sigma stays at the corners' level; with a robot error it is estimated from the spread of the views'
poses beyond what their corners explain.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

__all__ = [
    "RobotNoiseEstimate",
    "RobotPoseErrorWarning",
    "DOMINANCE_FLOOR_PX",
    "robot_dominates",
    "DOMINANCE_FACTOR",
    "estimate_robot_noise",
    "view_covariances",
]

#: The robot's pose error is said to dominate when the corners' RMS residual exceeds this multiple of the RMS
#: the corner detection alone would leave (``sqrt(2) sigma_px`` for 2-D residuals).
DOMINANCE_FACTOR = 3.0
#: ... and also exceeds this absolute RMS (px): below, the residual is rounding and the solver's tolerance (exact
#: synthetic corners leave about 1e-6 px), not a robot error worth a warning. A tenth of the 0.1 px that a good
#: sub-pixel corner detector reaches.
DOMINANCE_FLOOR_PX = 0.01

# the search's units: ratios of milliradians and millimetres to pixels
_UNITS = np.array([1.0, 1e-3, 1e-3])
# below this within-view pixel noise the corners are taken as exact (synthetic), and no robot error is fitted
_NOISE_FREE_PX = 1e-6
# the objective where a covariance is not positive definite (rounding only): finite, so that scipy's
# finite differences stay numbers
_UNUSABLE = 1e300
# the search's tolerances: 1e-3 in (mrad, mm per px) and 1e-3 in -2 log L, far below what the data can tell
# (a 1-sigma change of a variance component changes -2 log L by about 1)
_SEARCH = {"xatol": 1e-3, "fatol": 1e-3, "maxiter": 2000}


def robot_dominates(rms_px: float, detection_rms_px: float) -> bool:
    """Whether the corners' RMS residual says the robot's pose error dominates.

    Parameters
    ----------
    rms_px : float
        RMS residual per corner of the fit (px, 2-D).
    detection_rms_px : float
        RMS the corner detection alone would leave (``sqrt(2) sigma_px``).

    Returns
    -------
    bool
        ``rms_px`` above :data:`DOMINANCE_FACTOR` times ``detection_rms_px`` and above :data:`DOMINANCE_FLOOR_PX`.
    """
    return bool(rms_px > DOMINANCE_FACTOR * detection_rms_px and rms_px > DOMINANCE_FLOOR_PX)


class RobotPoseErrorWarning(UserWarning):
    """The reprojection residuals are far above the corner detection's noise: the robot's pose error dominates."""


@dataclass
class RobotNoiseEstimate:
    """The variance components of the corner residuals.

    Attributes
    ----------
    sigma_px : float
        Per-axis pixel noise of the corner detection.
    rotation_rad : float
        Per-axis standard deviation of the robot's rotation error (flange frame).
    translation_m : float
        Per-axis standard deviation of the robot's translation error (base frame).
    """

    sigma_px: float
    rotation_rad: float
    translation_m: float

    @property
    def robot_covariance(self) -> np.ndarray:
        """``D``, shape (6, 6), order ``[w, n]`` (rad, m)."""
        return np.diag(np.repeat([self.rotation_rad**2, self.translation_m**2], 3))

    @property
    def has_robot_error(self) -> bool:
        return bool(self.rotation_rad > 0 or self.translation_m > 0)

    def describe(self) -> dict:
        """JSON-ready (px, deg, mm per axis)."""
        return {
            "corner_sigma_px": float(self.sigma_px),
            "robot_rotation_deg": float(np.degrees(self.rotation_rad)),
            "robot_translation_mm": float(self.translation_m * 1e3),
        }


def view_covariances(J_robot: list[np.ndarray], estimate: RobotNoiseEstimate) -> list[np.ndarray]:
    """``S_i = sigma_px^2 I + J_i D J_i^T`` of each view's stacked corner residuals.

    Parameters
    ----------
    J_robot : list of V arrays, shape (2 M_i, 6)
        The corners' pixel Jacobian with respect to the robot pose error of their view.
    estimate : RobotNoiseEstimate

    Returns
    -------
    list of V arrays, shape (2 M_i, 2 M_i)
    """
    D = estimate.robot_covariance
    return [estimate.sigma_px**2 * np.eye(len(J)) + J @ D @ J.T for J in J_robot]


class _Blocks:
    """The per-view products REML needs, computed once per linearisation."""

    def __init__(self, J_robot, G, r):
        self.n = np.array([len(Ji) for Ji in J_robot], dtype=float)
        self.rr = np.array([ri @ ri for ri in r])
        self.Jr = np.stack([Ji.T @ ri for Ji, ri in zip(J_robot, r)])
        self.JJ = np.stack([Ji.T @ Ji for Ji in J_robot])
        self.JG = np.stack([Ji.T @ Gi for Ji, Gi in zip(J_robot, G)])
        self.GG = sum(Gi.T @ Gi for Gi in G)
        self.Gr = sum(Gi.T @ ri for Gi, ri in zip(G, r))
        self.dof = float(np.sum(self.n)) - self.GG.shape[0]

    def profile(self, ratio: np.ndarray) -> tuple[float, float]:
        """``-2 l_R`` (constants dropped) with ``sigma_px^2`` profiled out, and that ``sigma_px^2``.

        With ``S = sigma_px^2 (I + J L L J^T)``, ``L = diag(ratio)`` (robot sigma per pixel sigma, rotation then
        translation, in the search's units), ``-2 l_R = dof log sigma^2 + sum log|M_i| + log|H| + q / sigma^2``
        with ``M_i = I + L J_i^T J_i L``, ``H = G^T (S / sigma^2)^-1 G`` and ``q = r^T P r sigma^2``; its minimum
        over ``sigma^2`` is at ``q / dof``.
        """
        L = np.repeat(np.abs(ratio) * _UNITS[1:], 3)
        M = np.eye(6) + L[:, None] * self.JJ * L[None, :]
        a = L * self.Jr
        B = L[None, :, None] * self.JG
        C = np.linalg.cholesky(M)  # I + PSD: positive definite
        solved = np.linalg.solve(M, np.concatenate([a[..., None], B], axis=2))
        Ma, MB = solved[..., 0], solved[..., 1:]
        logdet_M = 2.0 * float(np.sum(np.log(np.diagonal(C, axis1=1, axis2=2))))
        g = self.Gr - np.einsum("vkp,vk->p", B, Ma)
        H = self.GG - np.einsum("vkp,vkq->pq", B, MB)
        sign_H, logdet_H = np.linalg.slogdet(H)
        q = float(np.sum(self.rr - np.einsum("vk,vk->v", a, Ma))) - float(g @ np.linalg.solve(H, g))
        if sign_H <= 0 or not q > 0:
            return _UNUSABLE, np.nan
        s2 = q / self.dof
        return self.dof * np.log(s2) + logdet_M + logdet_H, s2

    def start(self) -> tuple[float, np.ndarray]:
        """The within-view pixel variance, and the robot-to-pixel ratios from the spread of the views' own pose
        offsets beyond what their corners' noise explains.

        The residual outside a view's robot-error directions (``J_i``'s column space) is pixel noise alone (the
        fitted X and Y take a share that is small beside ``sum (2 M_i - 6)``).
        """
        pinv = np.linalg.pinv(self.JJ)
        offsets = np.einsum("vab,vb->va", pinv, self.Jr)
        dof = max(float(np.sum(self.n)) - 6 * len(self.n), 1.0)
        s2 = max(float(np.sum(self.rr - np.einsum("va,va->v", self.Jr, offsets))) / dof, 0.0)
        spread = np.mean(offsets**2, axis=0) - s2 * np.mean(np.diagonal(pinv, axis1=1, axis2=2), axis=0)
        robot = np.sqrt(np.maximum([np.mean(spread[:3]), np.mean(spread[3:])], 0.0)) / _UNITS[1:]
        return s2, robot / np.sqrt(max(s2, _NOISE_FREE_PX**2))


def estimate_robot_noise(J_robot: list[np.ndarray], G: list[np.ndarray], r: list[np.ndarray]) -> RobotNoiseEstimate:
    """REML estimate of the corner noise and the robot's pose error from a fit's residuals.

    Parameters
    ----------
    J_robot : list of V arrays, shape (2 M_i, 6)
        Per view: the corners' pixel Jacobian w.r.t. the robot pose error ``[w, n]`` of that view.
    G : list of V arrays, shape (2 M_i, P)
        Per view: the residuals' Jacobian w.r.t. the fitted parameters.
    r : list of V arrays, shape (2 M_i,)
        Per view: the residuals (pixels), rows ``u_0, v_0, u_1, ...``.

    Returns
    -------
    RobotNoiseEstimate
    """
    blocks = _Blocks(J_robot, G, r)
    s2, ratio = blocks.start()
    if s2 < _NOISE_FREE_PX**2:  # exact corners: nothing to weigh, and S would be singular
        return RobotNoiseEstimate(float(np.sqrt(s2)), 0.0, 0.0)
    # the scale profiled out, two ratios left; they enter as their absolute values, so that zero is an
    # interior point of an unconstrained search (Nelder-Mead), started at no robot error and at the spread
    best = None
    for start in (np.zeros(2), ratio):
        sol = minimize(lambda x: blocks.profile(x)[0], start, method="Nelder-Mead", options=_SEARCH)
        if best is None or sol.fun < best.fun:
            best = sol
    ratio = np.abs(best.x)
    s2 = blocks.profile(ratio)[1]
    sigma_px = float(np.sqrt(s2))
    return RobotNoiseEstimate(sigma_px, float(ratio[0] * _UNITS[1] * sigma_px), float(ratio[1] * _UNITS[2] * sigma_px))
