"""Where to move next: greedy choice of the robot poses that shrink the predicted sigma of X most.

The predicted covariance of ``[w_X, v_X, w_Y, v_Y]`` after a pose set is the inverse of the Fisher
information :math:`F = \\sum_i G_i^T G_i`, with :math:`G_i = W_i J_i` pose ``i``'s residual Jacobian
whitened by its covariance under the noise model (:func:`classic.refine.cramer_rao_bound` is
:math:`F^{-1}`; the Jacobian, covariance and whitening are :mod:`classic.refine`'s and
:mod:`classic.noise_model`'s, evaluated at the current estimate or guess of X and Y, where the
residuals vanish).

**Criterion: the workspace sigma of X.** The error of X moves a point ``p`` seen by the camera by
:math:`\\delta p = w_X \\times (R_X p) + v_X = G_p\\,[w_X, v_X]` with :math:`G_p = [-[R_X p]_\\times,\\ I]`.
The planner minimises the mean squared displacement over the targets' positions in the candidate
workspace (the points X is used for),

.. math:: \\sigma_{ws}^2 = \\operatorname{tr}(M\\, C_{XX}), \\qquad M = \\frac{1}{K} \\sum_k G_{p_k}^T G_{p_k},

an A-optimal design weighted by the lever arm (L-optimality), reported in millimetres. It was chosen over
the D-optimal :math:`\\log\\det C_{XX}` because the rotation and translation of X have different units
and the determinant rewards shrinking an already small direction as much as the one that dominates the
error a user sees; :math:`\\sigma_{ws}` is that error, in mm, at the distance the camera works at, so a
5 % gain means 5 % less error where it matters. It is not the sum of the two reported sigmas (rotation in
degrees, translation in mm, ``sqrt`` of the traces as :func:`classic.least_squares.sigma_of_blocks` gives
them), but it shrinks whenever both do: adding a pose adds information, so every block's variance is
non-increasing (Loewner order) and no greedy step can raise a predicted sigma.

**Greedy steps.** Each step adds the candidate with the largest decrease of
:math:`\\operatorname{tr}(M C_{XX})`, evaluated for all candidates at once by the Woodbury identity
(``C' = C - C G^T (I + G C G^T)^{-1} G C``, one 6x6 solve per candidate). Greedy selection is the
standard way to this combinatorial design (the true optimum of a k-subset is NP-hard); a candidate is
used once. Until the poses determine X (too few poses, or motions about one axis), ``F`` is singular:
a weak prior (1 rad, 1 m per axis on every parameter, :data:`PRIOR_SIGMA_ROT_RAD`,
:data:`PRIOR_SIGMA_TRANS_M`) keeps the criterion finite, so the undetermined directions, carrying the
prior's huge variance, dominate it and the steps go first to the poses that determine them: with no
poses yet the greedy pass starts from the candidate nearest the workspace's middle (one pose alone tells
nothing about X) and the next ones rotate about new axes until X is determined (after three poses). The
prior is never in the reported sigmas (``inf`` while X is undetermined). Greedy is myopic while X is
undetermined, so Fedorov's exchange then swaps chosen poses for free candidates while that lowers the
criterion, and the final set is put in greedy order (:func:`plan_poses`).

**Stop advice.** After each step the best remaining candidate's predicted relative decrease of
:math:`\\sigma_{ws}` is known; when it falls below ``min_gain`` (default 5 %) with X determined, planning
stops and says more poses will no longer help. It also stops when no candidate adds information.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from classic.least_squares import sigma_of_blocks
from classic.noise_model import as_noise_model, residual_covariances, whitening
from classic.refine import pose_residual_jacobian
from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import hat
from handeye.core.setups import normalize_setup

__all__ = [
    "DEFAULT_MIN_GAIN",
    "PRIOR_SIGMA_ROT_RAD",
    "PRIOR_SIGMA_TRANS_M",
    "PlanOptions",
    "PosePlan",
    "pose_information",
    "workspace_weight",
    "predicted_sigmas",
    "plan_poses",
]

#: A pose that shrinks the predicted workspace sigma of X by less than this is not worth recording.
DEFAULT_MIN_GAIN = 0.05
#: The weak prior that keeps the criterion finite while X is undetermined (never in a reported sigma).
PRIOR_SIGMA_ROT_RAD = 1.0
PRIOR_SIGMA_TRANS_M = 1.0
#: Relative eigenvalue of the Jacobi-scaled information below which a direction counts as undetermined.
_RANK_TOL = 1e-10

STOP_REQUESTED, STOP_SMALL_GAIN, STOP_EXHAUSTED = "requested", "small_gain", "exhausted"


def pose_information(A: np.ndarray, X: np.ndarray, Y: np.ndarray, noise, setup: str = "eye_to_hand") -> np.ndarray:
    """Each pose's whitened residual Jacobian ``G_i = W_i J_i``: its information is ``G_i^T G_i``.

    Evaluated where the residuals vanish (``B_i = X^-1 A_i Y``), as :func:`classic.refine.cramer_rao_bound`
    does: ``inv(sum_i G_i^T G_i)`` is that bound.

    Parameters
    ----------
    A : array, shape (N, 4, 4)
        Robot-side poses: ``T_base_ee`` eye-to-hand, ``T_ee_base`` eye-in-hand
        (:func:`handeye.core.setups.robot_side_poses`).
    X, Y : array, shape (4, 4)
        Estimate or guess of the camera and target poses.
    noise : (float, float) or NoiseModel
        Per-axis camera noise ``(rad, m)`` or a :class:`classic.noise_model.NoiseModel` (camera and robot).
    setup : {"eye_to_hand", "eye_in_hand"}

    Returns
    -------
    G : array, shape (N, 6, 12)
        Rows: the residual ``[rotation, translation]`` whitened; columns ``[w_X, v_X, w_Y, v_Y]`` (rad, m).
    """
    model = as_noise_model(noise)
    if model is None:
        raise HandEyeInputError("planning needs a noise model: give the camera's (and the robot's) noise")
    A = np.asarray(A, dtype=float).reshape(-1, 4, 4)
    if len(A) == 0:
        return np.zeros((0, 6, 12))
    B = np.linalg.inv(X) @ A @ Y
    W = whitening(residual_covariances(model, A, B, X, Y, normalize_setup(setup)))
    return W @ pose_residual_jacobian(A, B, X, Y)


def workspace_weight(X: np.ndarray, p_cam: np.ndarray) -> np.ndarray:
    """``M = mean_k G_k^T G_k``, ``G_k = [-[R_X p_k]x, I]``: X's error felt at points seen by the camera.

    ``tr(M C_XX)`` is the mean squared displacement of the points ``p_k`` when mapped through an X with
    covariance ``C_XX`` (of ``[w_X, v_X]``, rad and m).

    Parameters
    ----------
    X : array, shape (4, 4)
        ``T_base_cam`` or ``T_ee_cam``.
    p_cam : array, shape (K, 3)
        Points in the camera frame, metres (the target's positions in the workspace).

    Returns
    -------
    M : array, shape (6, 6)
    """
    q = np.asarray(p_cam, dtype=float).reshape(-1, 3) @ X[:3, :3].T  # R_X p, the lever arm in X's frame
    G = np.concatenate([-hat(q), np.broadcast_to(np.eye(3), (len(q), 3, 3))], axis=2)
    return np.mean(np.swapaxes(G, 1, 2) @ G, axis=0)


def _prior() -> np.ndarray:
    d = np.tile(np.r_[np.full(3, PRIOR_SIGMA_ROT_RAD**-2), np.full(3, PRIOR_SIGMA_TRANS_M**-2)], 2)
    return np.diag(d)


def _determined(F: np.ndarray) -> bool:
    """Whether the information fixes all 12 parameters (Jacobi-scaled smallest eigenvalue not ~0)."""
    d = np.diag(F)
    if np.any(d <= 0):
        return False
    s = 1.0 / np.sqrt(d)
    ev = np.linalg.eigvalsh(F * s[:, None] * s[None, :])
    return bool(ev[0] > _RANK_TOL * ev[-1])


def predicted_sigmas(F: np.ndarray, M: np.ndarray) -> dict:
    """The predicted 1-sigma of X from an information matrix (``inf`` when X is undetermined).

    Parameters
    ----------
    F : array, shape (12, 12)
        Fisher information of ``[w_X, v_X, w_Y, v_Y]``.
    M : array, shape (6, 6)
        :func:`workspace_weight`.

    Returns
    -------
    dict
        ``X_rotation_deg``, ``X_translation_mm`` (:func:`classic.least_squares.sigma_of_blocks`),
        ``X_workspace_mm`` (``sqrt(tr(M C_XX))``).
    """
    if not _determined(F):
        return {"X_rotation_deg": np.inf, "X_translation_mm": np.inf, "X_workspace_mm": np.inf}
    C = np.linalg.inv(F)
    s = sigma_of_blocks(C)
    return {
        "X_rotation_deg": s["X_rotation_deg"],
        "X_translation_mm": s["X_translation_mm"],
        "X_workspace_mm": 1000.0 * float(np.sqrt(max(np.trace(M @ C[:6, :6]), 0.0))),
    }


@dataclass
class PosePlan:
    """Outcome of :func:`plan_poses`.

    Attributes
    ----------
    chosen : array of int, shape (k,)
        Candidate indices, in the order to record them.
    sigma_rotation_deg, sigma_translation_mm, sigma_workspace_mm : array, shape (k + 1,)
        Predicted 1-sigma of X with the recorded poses only (entry 0) and after each added pose; ``inf``
        while X is undetermined.
    gain : array, shape (k,)
        Predicted relative decrease of the workspace sigma at each step (with the weak prior while X is
        undetermined, so large there).
    next_gain : float
        What the best remaining candidate would give after the last step (``nan`` when none is left).
    stop_reason : {"requested", "small_gain", "exhausted"}
        The requested number was planned; the next pose would gain less than ``min_gain``; or no
        candidate adds information.
    min_gain : float
    advice : str
        One sentence for the user.
    """

    chosen: np.ndarray
    sigma_rotation_deg: np.ndarray
    sigma_translation_mm: np.ndarray
    sigma_workspace_mm: np.ndarray
    gain: np.ndarray
    next_gain: float
    stop_reason: str
    min_gain: float
    advice: str = field(default="")


def _reductions(G: np.ndarray, C: np.ndarray, M: np.ndarray) -> np.ndarray:
    """Decrease of ``tr(M C_XX)`` from adding each candidate (Woodbury), shape (K,)."""
    U = G @ C  # (K, 6, 12)
    S = np.eye(6) + U @ np.swapaxes(G, 1, 2)
    V = U[:, :, :6]
    Q = V @ M @ np.swapaxes(V, 1, 2)
    return np.trace(np.linalg.solve(S, Q), axis1=1, axis2=2)


def _advice(reason: str, next_gain: float, min_gain: float, determined: bool) -> str:
    if reason == STOP_EXHAUSTED:
        return (
            "stop: no candidate pose left adds information (candidates exhausted); sample more candidates "
            "or widen the workspace"
        )
    if reason == STOP_SMALL_GAIN:
        return (
            f"stop: one more pose would shrink the predicted sigma by only {100 * next_gain:.1f} % "
            f"(threshold {100 * min_gain:.0f} %): more poses will no longer help"
        )
    if not determined:
        return "keep going: these poses do not determine X yet"
    if next_gain < min_gain:
        return (
            f"enough: the next best pose would shrink the predicted sigma by only {100 * next_gain:.1f} % "
            f"(< {100 * min_gain:.0f} %): more poses will no longer help"
        )
    return f"more poses still help: the next best pose would shrink the predicted sigma by {100 * next_gain:.1f} %"


class _Design:
    """The information of the recorded poses, the candidates' factors and the criterion's weight."""

    def __init__(self, F_recorded: np.ndarray, G: np.ndarray, M: np.ndarray):
        self.F_recorded, self.G, self.M = F_recorded, G, M
        self.M12 = np.zeros((12, 12))
        self.M12[:6, :6] = M
        self.P0 = _prior()

    def information(self, chosen) -> np.ndarray:
        G = self.G[list(chosen)]
        return self.F_recorded + np.einsum("nji,njk->ik", G, G)

    def criterion(self, F: np.ndarray) -> tuple[float, np.ndarray]:
        """``tr(M C_XX)`` with the weak prior, and that ``C``."""
        C = np.linalg.inv(F + self.P0)
        return float(np.trace(self.M12 @ C)), C

    def best(self, F: np.ndarray, available: np.ndarray) -> tuple[int, float, float]:
        """The candidate that shrinks the criterion most: index, relative gain in sigma, new criterion."""
        crit, C = self.criterion(F)
        if not np.any(available):
            return -1, 0.0, crit
        red = np.where(available, _reductions(self.G, C, self.M), -np.inf)
        k = int(np.argmax(red))
        if not red[k] > 1e-12 * crit:
            return -1, 0.0, crit
        new = max(crit - float(red[k]), 0.0)
        return k, 1.0 - float(np.sqrt(new / crit)), new


def _greedy(design: _Design, available: np.ndarray, n: int, min_gain: float, first: int | None):
    """Add up to ``n`` candidates greedily; returns (chosen, gains, stop reason)."""
    available = available.copy()
    F = design.F_recorded
    chosen, gains = [], []
    while True:
        if not available.any():
            return chosen, gains, STOP_EXHAUSTED
        k, gain, _ = design.best(F, available)
        if k < 0:
            return chosen, gains, STOP_EXHAUSTED
        if len(chosen) >= n:
            return chosen, gains, STOP_REQUESTED
        if gain < min_gain and _determined(F):
            return chosen, gains, STOP_SMALL_GAIN
        if not chosen and first is not None:
            k = first  # nothing recorded: start in the middle (any single pose tells nothing about X alone)
            only = np.zeros_like(available)
            only[k] = True
            gain = design.best(F, only)[1]
        chosen.append(k)
        gains.append(gain)
        available[k] = False
        F = F + design.G[k].T @ design.G[k]


def _exchange(design: _Design, chosen: list, available: np.ndarray, max_sweeps: int = 10) -> list:
    """Fedorov's exchange: swap a chosen pose for a free candidate while that lowers the criterion."""
    chosen = list(chosen)
    free = available.copy()
    free[chosen] = False
    F = design.information(chosen)
    current, _ = design.criterion(F)
    for _ in range(max_sweeps):
        improved = False
        for i, c in enumerate(list(chosen)):
            F_minus = F - design.G[c].T @ design.G[c]
            k, _, new = design.best(F_minus, free)
            if k >= 0 and new < current * (1.0 - 1e-9):
                free[c], free[k] = True, False
                chosen[i] = k
                F, current = F_minus + design.G[k].T @ design.G[k], new
                improved = True
        if not improved:
            break
    return chosen


@dataclass(frozen=True, kw_only=True)
class PlanOptions:
    """When :func:`plan_poses` stops, where X's error counts and whether the exchange pass runs.

    Attributes
    ----------
    min_gain : float
        Stop when the best next pose shrinks the workspace sigma by less than this fraction (0 plans all
        ``n`` unless the candidates run out).
    workspace_cam : array, shape (P, 3), optional
        Points in the camera frame where X's error counts (:func:`workspace_weight`); default the
        candidates' target positions.
    exchange : bool
        Run the exchange pass (default).
    """

    min_gain: float = DEFAULT_MIN_GAIN
    workspace_cam: np.ndarray | None = None
    exchange: bool = True


def plan_poses(
    A_recorded: np.ndarray,
    A_candidates: np.ndarray,
    X: np.ndarray,
    Y: np.ndarray,
    noise,
    setup: str = "eye_to_hand",
    n: int = 8,
    *,
    options: PlanOptions | None = None,
) -> PosePlan:
    """Choose up to ``n`` candidate poses that shrink the predicted workspace sigma of X most.

    Three passes: greedy selection (which also decides when to stop, see the module docstring); Fedorov's
    exchange on the chosen set (each chosen pose swapped for the free candidate that lowers the criterion
    most, until no swap helps; the recorded poses stay), which lowers the criterion a further few per cent
    (greedy is myopic while X is undetermined); and a greedy ordering of the final set, so that every
    prefix of the plan is itself a good plan and the per-step sigmas are those of recording them in order.

    Parameters
    ----------
    A_recorded : array, shape (N, 4, 4)
        Robot-side poses recorded so far (``T_base_ee`` eye-to-hand, ``T_ee_base`` eye-in-hand); ``N``
        may be 0.
    A_candidates : array, shape (K, 4, 4)
        Robot-side poses the robot can reach with the target in view (:mod:`classic.target_views`).
    X, Y : array, shape (4, 4)
        Current estimate of ``X`` and ``Y`` (a calibration of the recorded poses) or a guess.
    noise : (float, float) or NoiseModel
        The noise the prediction assumes.
    setup : {"eye_to_hand", "eye_in_hand"}
    n : int
        Most poses to add.
    options : PlanOptions, optional
        The smallest gain worth a pose, the workspace's points and the exchange pass; None:
        :class:`PlanOptions`' defaults (stop below a 5 % gain).

    Returns
    -------
    PosePlan
    """
    options = options or PlanOptions()
    min_gain, workspace_cam = options.min_gain, options.workspace_cam
    setup = normalize_setup(setup)
    if n < 0:
        raise HandEyeInputError(f"number of poses to plan must be >= 0, got {n}")
    A_candidates = np.asarray(A_candidates, dtype=float).reshape(-1, 4, 4)
    G_rec = pose_information(A_recorded, X, Y, noise, setup)
    views = (np.linalg.inv(X) @ A_candidates @ Y)[:, :3, 3]
    if workspace_cam is None:
        workspace_cam = views if len(views) else np.zeros((1, 3))
    workspace_cam = np.asarray(workspace_cam, dtype=float).reshape(-1, 3)
    design = _Design(
        np.einsum("nji,njk->ik", G_rec, G_rec),
        pose_information(A_candidates, X, Y, noise, setup),
        workspace_weight(X, workspace_cam),
    )
    available = np.ones(len(A_candidates), dtype=bool)
    first = None
    if len(G_rec) == 0 and len(views):
        first = int(np.argmin(np.linalg.norm(views - workspace_cam.mean(axis=0), axis=1)))
    chosen, gains, reason = _greedy(design, available, n, min_gain, first)
    if options.exchange and chosen:
        chosen = _exchange(design, chosen, available)
        pool = np.zeros(len(A_candidates), dtype=bool)
        pool[chosen] = True
        ordered, gains, _ = _greedy(design, pool, len(chosen), 0.0, first if first in chosen else None)
        chosen = ordered + [c for c in chosen if c not in ordered]  # a pose that adds nothing goes last
        gains = gains + [0.0] * (len(chosen) - len(gains))
    F = design.information(chosen)
    left = available.copy()
    left[chosen] = False
    k, next_gain, _ = design.best(F, left)
    if k < 0:  # no candidate left adds information, whatever stopped the greedy pass
        next_gain, reason = float("nan"), STOP_EXHAUSTED
    sigmas = [predicted_sigmas(design.information(chosen[:j]), design.M) for j in range(len(chosen) + 1)]
    return PosePlan(
        chosen=np.array(chosen, dtype=int),
        sigma_rotation_deg=np.array([s["X_rotation_deg"] for s in sigmas]),
        sigma_translation_mm=np.array([s["X_translation_mm"] for s in sigmas]),
        sigma_workspace_mm=np.array([s["X_workspace_mm"] for s in sigmas]),
        gain=np.array(gains),
        next_gain=float(next_gain),
        stop_reason=reason,
        min_gain=float(min_gain),
        advice=_advice(reason, float(next_gain), min_gain, _determined(F)),
    )
