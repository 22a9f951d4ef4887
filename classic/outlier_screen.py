"""Name the poses whose residual lies beyond a stated bound, each judged against a fit without it.

A gross outlier must not set the noise scale it is judged against. In a least-squares fit whose noise
scales are estimated from the residuals, one robot pose moved by 1.8 m inflates the translation scale
until its own residual looks ordinary: the answer moves by a quarter of a metre and its sigma with it.
So every pose is judged against a fit that does not contain it, with the scale set by the other poses:

1. **Candidates.** A fit on the inliers of least-median sampling (:func:`classic.ransac.lmeds_inliers`,
   which leaves the gross outliers out: the default) or a Cauchy-loss fit on them (``robust=True``) is a
   fit no single pose can pull off. The poses whose whitened residual
   against it lies beyond a loose bound (chi-square with 6 degrees of freedom at
   ``1 - CANDIDATE_ALPHA / N``, its common factor from the median) are candidates. The loose bound costs
   a refit at most; no pose is named on it.
2. **Reference fit.** Least squares under the caller's noise model (given, or its scales estimated from
   the residuals) on the poses that are not candidates.
3. **The test.** Each pose's residual against the reference fit, standardised by its covariance: a
   candidate, which the fit does not contain, by its prediction covariance ``S_i + J_i C J_i^T``; a pose
   the fit contains, by its deleted (leave-one-out, first order) residual ``(I - H_ii)^-1 w_i``, of
   covariance ``(I - H_ii)^-1`` in whitened units. Its six components (rotation in the target frame,
   translation in the camera frame, whitened by the noise model) are each divided by their own standard
   deviation: the model's, times a variance factor estimated from the reference poses' residuals, one
   per group of components (:data:`GROUPS`: the rotation's three; the translation across the line of
   sight; along it), each residual's leverage and the judged pose's own share taken out. So each
   component is Student's t under the model, whatever the set's size and whatever the noise's scale per
   group (a PnP pose's depth noise ten times its lateral noise, a model given with the wrong scale): the
   bound widens on a small set, whose spreads are themselves uncertain. A pose is named when a
   component's two-sided p-value is below ``alpha / (6 N)`` (Bonferroni over six components and N
   poses), so a clean set has some pose named with probability at most ``alpha``
   (:data:`OUTLIER_ALPHA`). The bound in sigmas (rotation / translation across / along the line of
   sight): 5.8 / 7.1 / 15.4 at 8 poses, 5.1 / 5.5 / 7.2 at 15, 4.8 / 5.0 / 5.4 at 40.
4. The named poses replace the candidates and 2-3 repeat until the named set settles; the last
   reference fit is the fit of the same poses without the named ones (:attr:`Screening.reference`).

The stated rate holds for Gaussian noise of one scale per group. PnP poses are heteroscedastic (a board seen
at 60 deg has several times a frontal view's rotation error): on clean PnP sets some pose is named in 7 %,
28 % and 45 % of them at 8, 15 and 40 poses (benchmarks/outliers.py, 200 sets each, none refused), and the
largest ratio of a component to its bound measured on 1,200 such sets was 4.0, against 10 to 300 for a gross
outlier's, 2 to 6 for a 0.05 m one at 8 poses (:data:`GROSS_FACTOR`).

What the caller does with the named poses is :mod:`classic.calibrate`'s choice: the default refuses a
fit that they move by more than :data:`ACCEPT_SHIFT_SIGMA` of the reference fit's sigma when one of them is
gross (:attr:`Screening.gross`), returns the fit without them when none is, and returns the fit with them,
its covariance widened to reach the fit without them, otherwise; ``robust=True`` leaves them out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2
from scipy.stats import t as student_t

from classic.contamination import RESIDUAL_FLOOR, x_shift_sigma
from classic.noise_model import NoiseModel, residual_covariances
from classic.refine import Refinement, RefineOptions, pose_residual_jacobian, refine_xy
from classic.residuals import pose_residuals
from handeye.core.se3 import so3_log

__all__ = [
    "OUTLIER_ALPHA",
    "CANDIDATE_ALPHA",
    "ACCEPT_SHIFT_SIGMA",
    "MIN_REFERENCE_POSES",
    "GROSS_FACTOR",
    "PoseTest",
    "Screening",
    "pose_tests",
    "screen_poses",
    "fit_shift_sigma",
    "shift_vector",
]

#: Probability that a clean pose set (the noise model holding) has any pose named, whatever its size.
OUTLIER_ALPHA = 1e-3
#: Per-set level of the loose bound that makes a pose a candidate (a refit without it, no naming).
CANDIDATE_ALPHA = 0.5
#: The default returns a fit with named poses only when leaving them out moves X and Y by at most this
#: many sigmas of the fit without them (Mahalanobis distance of each's six parameters); beyond, it refuses.
ACCEPT_SHIFT_SIGMA = 2.0
#: A named pose is *gross* when its most significant component lies beyond this many times its bound: beyond
#: the bound even if that pose's noise were this many times the set's (a scale mixture; a PnP pose seen at 60 deg
#: has several times a frontal one's rotation error). On clean PnP sets (0.1-0.3 px corners, tilts to 60 deg,
#: 8/15/40 poses) the largest ratio measured was 4.0 in 360 sets (benchmarks/outliers.py). Only a gross pose
#: that moves the answer by more than ACCEPT_SHIFT_SIGMA gets the fit refused (:mod:`classic.calibrate`).
GROSS_FACTOR = 6.0
#: Fewest poses a reference fit keeps (and at least half the set): below, fewer candidates are taken.
MIN_REFERENCE_POSES = 5
#: Rounds of naming and refitting at most.
MAX_ROUNDS = 4
_BLOCKS = ("rotation", "translation")


@dataclass
class PoseTest:
    """Per-pose tests of :func:`pose_tests`.

    Attributes
    ----------
    n_sigma : array, shape (N, 2)
        The rotation's and the translation's most significant component, in sigmas of its spread over
        the reference poses (Student's t statistic, absolute).
    bound_n_sigma : array, shape (N, 2)
        The bound of that component: where its p-value reaches ``alpha / (6 N)``.
    p_value : array, shape (N,)
        The smallest component p-value times six (Bonferroni over the components), at most 1.
    dof : array, shape (N, 2)
        Degrees of freedom of those components' t tests.
    """

    n_sigma: np.ndarray
    bound_n_sigma: np.ndarray
    p_value: np.ndarray
    dof: np.ndarray


def pose_tests(
    residuals: np.ndarray,
    covariance_sqrt: np.ndarray,
    jacobian: np.ndarray,
    reference: np.ndarray,
    alpha: float = OUTLIER_ALPHA,
) -> PoseTest:
    """Test each pose's residual against a least-squares fit on the ``reference`` poses (see the module).

    .. math:: t_{ik} = e_{ik} / \\sqrt{P_{i,kk} f_{g(k)}}, \\qquad
              f_g = \\sum_{j \\ne i} \\sum_{l \\in g} w_{jl}^2 \\Big/ \\sum_{j \\ne i} \\sum_{l \\in g} (1 - H_{jj,ll}),

    with ``e_i`` the pose's whitened prediction or deleted residual, ``P_i`` its covariance in model units,
    ``w_j`` the reference poses' whitened residuals, ``H`` the hat matrix and ``g(k)`` the group of component
    k (:data:`GROUPS`).

    Parameters
    ----------
    residuals : array, shape (N, 6)
        Every pose's raw residual ``[r_rot, r_trans]`` (rad, m) at the reference fit.
    covariance_sqrt : array, shape (N, 6, 6)
        Lower Cholesky factor ``L_i`` of each residual's covariance under the noise model (``S_i = L_i L_i^T``),
        up to the common factor the test estimates.
    jacobian : array, shape (N, 6, P)
        Each raw residual's Jacobian in the fit's P parameters.
    reference : array of bool, shape (N,)
        The poses the fit was made on.
    alpha : float
        Family-wise level over the N poses.

    Returns
    -------
    PoseTest
    """
    r = np.asarray(residuals, dtype=float)
    L = np.asarray(covariance_sqrt, dtype=float)
    reference = np.asarray(reference, dtype=bool)
    n, n_params = len(r), jacobian.shape[2]
    w = np.linalg.solve(L, r[:, :, None])[:, :, 0]  # whitened residuals
    Jw = np.linalg.solve(L, jacobian)
    Jr = Jw[reference].reshape(-1, n_params)
    C = np.linalg.pinv(Jr.T @ Jr)
    G = Jw @ C @ np.swapaxes(Jw, 1, 2)  # (N, 6, 6): the hat matrix's blocks (inside), the fit's share (outside)
    eye = np.eye(6)
    inside = reference[:, None]
    cov_w = np.where(inside[:, :, None], _inverse_psd(eye - G), eye + G)
    e_w = np.where(inside, np.einsum("nij,nj->ni", cov_w, w), w)  # deleted (inside) or prediction residual
    var = np.maximum(np.einsum("nii->ni", cov_w), 1e-300)  # its variance per component, in model units
    # each group's variance factor over the reference poses, E[w_jk^2] = f_g (1 - h_jk): rotation; translation
    # across the line of sight (x, y); along it (z)
    keep = 1.0 - np.clip(np.einsum("nii->ni", G), 0.0, 1.0)
    rss = _pooled(np.sum(w[reference] ** 2, axis=0))
    nu = _pooled(np.sum(keep[reference], axis=0))
    rss_i = np.where(inside, rss - _pooled(w**2), rss)
    dof = np.maximum(np.where(inside, nu - _pooled(keep), nu), 1.0)
    factor = np.maximum(rss_i / dof, 1e-300)
    t = np.abs(e_w) / np.sqrt(var * factor)  # Student t with dof degrees of freedom under the model
    p_comp = 2.0 * student_t.sf(t, dof)
    level = alpha / (6.0 * max(n, 1))
    bound = student_t.isf(level / 2.0, dof)
    ratio = t / bound
    worst = np.stack([np.argmax(ratio[:, :3], axis=1), 3 + np.argmax(ratio[:, 3:], axis=1)], axis=1)
    rows = np.arange(n)[:, None]
    p_value = np.minimum(1.0, 6.0 * p_comp.min(axis=1))
    return PoseTest(n_sigma=t[rows, worst], bound_n_sigma=bound[rows, worst], p_value=p_value, dof=dof[rows, worst])


#: The components that share a variance factor: the rotation's three (in the target frame, which turns with
#: every pose); the translation's across the line of sight (camera x and y); along it (z), where a PnP pose
#: is several times poorer.
GROUPS = (0, 0, 0, 1, 1, 2)


def _pooled(x: np.ndarray) -> np.ndarray:
    """Sums of ``x`` (..., 6) over each component's group, broadcast back to the components."""
    g = np.asarray(GROUPS)
    sums = np.stack([np.sum(x[..., g == k], axis=-1) for k in range(3)], axis=-1)
    return sums[..., g]


def _inverse_psd(M: np.ndarray) -> np.ndarray:
    """Inverse of symmetric positive semi-definite matrices, eigenvalues floored (a pose of leverage 1)."""
    lam, V = np.linalg.eigh(0.5 * (M + np.swapaxes(M, 1, 2)))
    return (V / np.maximum(lam, 1e-9)[:, None, :]) @ np.swapaxes(V, 1, 2)


def _cholesky_psd(M: np.ndarray) -> np.ndarray:
    M = 0.5 * (M + np.swapaxes(M, 1, 2))
    scale = np.maximum(np.einsum("nii->n", M) / 6.0, 1e-300)
    return np.linalg.cholesky(M + 1e-12 * scale[:, None, None] * np.eye(6))


@dataclass
class Screening:
    """Outcome of :func:`screen_poses`.

    Attributes
    ----------
    outliers : array of int
        The named poses, the most significant first.
    candidates : array of int
        The first round's candidates (step 1 of the module).
    test : PoseTest
        Every pose's test against :attr:`reference`.
    reference : classic.refine.Refinement
        Least squares on every pose but the named ones.
    residual_deg, residual_mm : array, shape (N,)
        Every pose's residual against :attr:`reference`.
    alpha : float
    rounds : int
    """

    outliers: np.ndarray
    candidates: np.ndarray
    test: PoseTest
    reference: Refinement
    residual_deg: np.ndarray
    residual_mm: np.ndarray
    alpha: float
    rounds: int

    @property
    def gross(self) -> np.ndarray:
        """The named poses beyond :data:`GROSS_FACTOR` times their bound (array of int)."""
        ratio = np.max(self.test.n_sigma / self.test.bound_n_sigma, axis=1)
        return np.asarray([k for k in self.outliers if ratio[k] >= GROSS_FACTOR], dtype=int)

    def describe(self) -> list[dict]:
        """One JSON-ready dict per named pose: index, residuals, n-sigma and bound per block, p-value."""
        out = []
        for k in self.outliers:
            k = int(k)
            ns, bound = self.test.n_sigma[k], self.test.bound_n_sigma[k]
            worst = int(np.argmax(ns / bound))
            out.append(
                {
                    "index": k,
                    "rotation_deg": float(self.residual_deg[k]),
                    "translation_mm": float(self.residual_mm[k]),
                    "n_sigma_rotation": float(ns[0]),
                    "n_sigma_translation": float(ns[1]),
                    "bound_n_sigma": float(bound[worst]),
                    "block": _BLOCKS[worst],
                    "p_value": float(self.test.p_value[k]),
                    "gross": bool(np.max(ns / bound) >= GROSS_FACTOR),
                }
            )
        return out

    def summary(self) -> dict:
        """The test as stated: level, reference poses, the bound of a reference pose."""
        keep = np.ones(len(self.residual_deg), dtype=bool)
        keep[self.outliers] = False
        return {
            "test": "each pose's six residual components against a least-squares fit without it, Student's t with "
            "the spread of the other poses (rotation; translation across, along the line of sight), "
            "Bonferroni over 6 x N",
            "alpha": self.alpha,
            "poses": len(keep),
            "reference_poses": int(keep.sum()),
            "bound_n_sigma": float(self.test.bound_n_sigma[keep].max(initial=0.0)),
            "named": [int(k) for k in self.outliers],
            "rounds": self.rounds,
        }


def _scaled(B: np.ndarray, scale: float) -> np.ndarray:
    if scale == 1.0:
        return B
    out = B.copy()
    out[:, :3, 3] *= scale
    return out


def _system(A, B, fit: Refinement, model: NoiseModel | None, setup: str, estimate_scale: bool):
    """Raw residuals (N, 6), covariance square roots (N, 6, 6) and Jacobians (N, 6, P) of every pose at ``fit``.

    The model is the caller's, or the one the fit estimated (camera-only, per axis: it applies to any pose).
    """
    Bs = _scaled(B, fit.scale)
    r = np.concatenate(pose_residuals(A, Bs, fit.X, fit.Y), axis=1)
    S = residual_covariances(model if model is not None else fit.model, A, Bs, fit.X, fit.Y, setup)
    J = pose_residual_jacobian(A, Bs, fit.X, fit.Y)
    if estimate_scale:
        c = np.zeros((len(A), 6, 1))
        c[:, 3:, 0] = B[:, :3, 3]
        J = np.concatenate([J, c], axis=2)
    return r, _cholesky_psd(S), J


def _candidates(A, B, robust_fit: Refinement, model, setup: str, estimate_scale: bool, most: int) -> np.ndarray:
    """Poses beyond the loose bound against the robust fit, the largest first, at most ``most``."""
    r, L, _ = _system(A, B, robust_fit, model, setup, estimate_scale)
    w = np.linalg.solve(L, r[:, :, None])[:, :, 0]
    d2 = np.sum(w**2, axis=1)
    z = d2 / max(float(np.median(d2)) / chi2.median(6), 1e-300)
    bad = np.flatnonzero(z > chi2.isf(CANDIDATE_ALPHA / len(A), 6))
    return bad[np.argsort(-z[bad])][: max(most, 0)]


def _named(test: PoseTest, r: np.ndarray, alpha: float, most: int) -> np.ndarray:
    """Poses whose p-value is below ``alpha / N`` and whose residual is above rounding, the most significant
    first, at most ``most``."""
    n = len(r)
    above = (np.linalg.norm(r[:, :3], axis=1) > RESIDUAL_FLOOR) | (np.linalg.norm(r[:, 3:], axis=1) > RESIDUAL_FLOOR)
    bad = np.flatnonzero((test.p_value < alpha / n) & above)
    order = np.lexsort((-np.max(test.n_sigma[bad] / test.bound_n_sigma[bad], axis=1), test.p_value[bad]))
    return bad[order][: max(most, 0)]


def screen_poses(
    A: np.ndarray,
    B: np.ndarray,
    robust_fit: Refinement,
    setup: str,
    model: NoiseModel | None = None,
    fit_all: Refinement | None = None,
    alpha: float | None = None,
    estimate_scale: bool = False,
) -> Screening:
    """Name the poses beyond the bound (see the module).

    Parameters
    ----------
    A : array, shape (N, 4, 4)
        Robot-side poses (:func:`handeye.core.setups.robot_side_poses`).
    B : array, shape (N, 4, 4)
        ``T_cam_target``.
    robust_fit : classic.refine.Refinement
        A fit no single pose can pull off (on the inliers of least-median sampling), on any subset.
    setup : {"eye_to_hand", "eye_in_hand"}
    model : NoiseModel, optional
        The caller's noise model for all N poses; None: estimated from the residuals by each fit.
    fit_all : classic.refine.Refinement, optional
        The least-squares fit on all N poses, when the caller has it (no refit when nothing is a candidate).
    alpha : float, optional
        Probability that a clean set has a pose named; default :data:`OUTLIER_ALPHA` (read at the call).
    estimate_scale : bool
        The fits also estimate a scale of the camera translations.

    Returns
    -------
    Screening
    """
    A, B = np.asarray(A, dtype=float), np.asarray(B, dtype=float)
    alpha = OUTLIER_ALPHA if alpha is None else float(alpha)
    n = len(A)
    most = n - max(MIN_REFERENCE_POSES, (n + 1) // 2)
    candidates = _candidates(A, B, robust_fit, model, setup, estimate_scale, most)
    excluded = candidates
    start = robust_fit
    for rounds in range(1, MAX_ROUNDS + 1):
        keep = np.ones(n, dtype=bool)
        keep[excluded] = False
        if keep.all() and fit_all is not None:
            ref = fit_all
        else:
            noise = None if model is None else model.subset(keep)
            options = RefineOptions(noise=noise, setup=setup, estimate_scale=estimate_scale, scale0=start.scale)
            ref = refine_xy(A[keep], B[keep], start.X, start.Y, options)
        r, L, J = _system(A, B, ref, model, setup, estimate_scale)
        test = pose_tests(r, L, J, keep, alpha)
        named = _named(test, r, alpha, most)
        if set(named.tolist()) == set(excluded.tolist()) or rounds == MAX_ROUNDS:
            break
        excluded, start = named, ref
    # the reference excludes exactly the poses reported (a last round that has not settled reports those)
    return Screening(
        outliers=np.asarray(excluded, dtype=int)[np.argsort(test.p_value[excluded], kind="stable")],
        candidates=np.asarray(candidates, dtype=int),
        test=test,
        reference=ref,
        residual_deg=np.degrees(np.linalg.norm(r[:, :3], axis=1)),
        residual_mm=1000 * np.linalg.norm(r[:, 3:], axis=1),
        alpha=alpha,
        rounds=rounds,
    )


def shift_vector(fit, reference) -> np.ndarray:
    """``fit`` relative to ``reference`` in the covariance's parameters ``[w_X, v_X, w_Y, v_Y]``.

    Parameters
    ----------
    fit, reference : objects with ``X``, ``Y`` (arrays, shape (4, 4))

    Returns
    -------
    array, shape (12,)
        ``w = log(R R_ref^T)`` (rad), ``v = t - t_ref`` (m), X's then Y's.
    """
    parts = []
    for T, T_ref in ((fit.X, reference.X), (fit.Y, reference.Y)):
        parts += [so3_log(T[:3, :3] @ T_ref[:3, :3].T), T[:3, 3] - T_ref[:3, 3]]
    return np.concatenate(parts)


def fit_shift_sigma(fit, reference: Refinement) -> float:
    """How far ``fit`` lies from ``reference`` in the reference's sigmas: the larger of X's and Y's
    Mahalanobis distance over their six parameters.

    Parameters
    ----------
    fit : object with ``X``, ``Y`` (arrays, shape (4, 4))
    reference : classic.refine.Refinement

    Returns
    -------
    float
    """
    C = reference.covariance
    return max(x_shift_sigma(fit.X, reference.X, C[:6, :6]), x_shift_sigma(fit.Y, reference.Y, C[6:12, 6:12]))
