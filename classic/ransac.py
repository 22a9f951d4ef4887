"""Least-median-of-squares sampling over pose triples: find gross outliers.

Each hypothesis solves ``A_i X = Y B_i`` on three poses (Shah's closed form,
two motions with distinct axes) and scores all poses by their residual
``d_i = sqrt(|r_trans|^2 + (L r_angle)^2)``, with ``L`` the median
camera-to-target distance turning an angle into the displacement it causes
at the target. The hypothesis with the least median ``d`` wins (no threshold
to tune, valid below 50 % outliers); the set is refit on its inliers and
poses with ``d > INLIER_FACTOR * median(d)`` are flagged as outliers.

The sampling stops once an all-inlier triple has been drawn with probability
:data:`CONFIDENCE` at the inlier fraction the best hypothesis so far shows
(the usual adaptive count ``log(1 - p) / log(1 - w^3)``), after at least
:data:`MIN_ITERATIONS` triples: a clean set needs a few dozen triples, not the
full budget. The flags are a generous first cut (three times the median
residual trims a few good poses of a small set); :mod:`classic.outlier_screen`
tests each pose against a stated bound before anything is excluded.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from classic.residuals import pose_residuals
from classic.shah import shah_solve
from handeye.core.errors import DegenerateMotionError

__all__ = ["INLIER_FACTOR", "CONFIDENCE", "MIN_ITERATIONS", "RansacResult", "lmeds_inliers", "pose_error_m"]

#: Poses with a residual above this multiple of the median residual are outliers.
INLIER_FACTOR = 3.0
#: Probability of having drawn at least one all-inlier triple when the sampling stops.
CONFIDENCE = 0.99999
#: Triples drawn at least, whatever the inlier fraction seems to be.
MIN_ITERATIONS = 30


@dataclass
class RansacResult:
    """Inliers found by :func:`lmeds_inliers`.

    Attributes
    ----------
    inliers : array of bool, shape (N,)
    residual_m : array, shape (N,)
        ``d_i`` of every pose against the refit, metres.
    median_residual_m : float
    iterations : int
    """

    inliers: np.ndarray
    residual_m: np.ndarray
    median_residual_m: float
    iterations: int


def pose_error_m(A: np.ndarray, B: np.ndarray, X: np.ndarray, Y: np.ndarray, L: float | None = None) -> np.ndarray:
    """Per-pose residual ``d_i = sqrt(|r_trans|^2 + (L r_angle)^2)`` in metres.

    Parameters
    ----------
    A, B : array, shape (N, 4, 4)
        Robot-side poses and ``T_cam_target``.
    X, Y : array, shape (4, 4)
        Camera and target poses.
    L : float, optional
        Lever arm turning radians into metres; default the median camera-to-target distance.

    Returns
    -------
    d : array, shape (N,)
    """
    if L is None:
        L = float(np.median(np.linalg.norm(B[:, :3, 3], axis=1)))
    r_rot, r_trans = pose_residuals(A, B, X, Y)
    return np.sqrt(np.sum(r_trans**2, axis=1) + (L * np.linalg.norm(r_rot, axis=1)) ** 2)


def _solve(A, B):
    # Shah solves A_i X' = Y' B_i with X' the target pose and Y' the camera pose
    Y_target, X_cam = shah_solve(A, B)
    return X_cam, Y_target


def lmeds_inliers(
    A: np.ndarray, B: np.ndarray, rng: np.random.Generator | None = None, iterations: int = 150
) -> RansacResult:
    """Flag gross outliers among poses of ``A_i Y = X B_i`` by least median of squares.

    Parameters
    ----------
    A : array, shape (N, 4, 4)
        Robot-side poses (``T_base_ee`` or ``T_ee_base``).
    B : array, shape (N, 4, 4)
        ``T_cam_target``.
    rng : numpy.random.Generator, optional
        Default ``np.random.default_rng(0)``: results are reproducible.
    iterations : int
        Most pose triples tried; 150 finds an all-inlier triple with
        probability above 0.99999 at 30 % outliers and 0.9999 at 45 %. Fewer are
        drawn when the best hypothesis's inlier fraction says :data:`CONFIDENCE`
        is reached (at least :data:`MIN_ITERATIONS`).

    Returns
    -------
    RansacResult
    """
    rng = np.random.default_rng(0) if rng is None else rng
    n = len(A)
    L = float(np.median(np.linalg.norm(B[:, :3, 3], axis=1)))
    best, best_med = None, np.inf
    needed = iterations
    tried = 0
    while tried < min(iterations, max(needed, MIN_ITERATIONS)):
        tried += 1
        idx = rng.choice(n, 3, replace=False)
        try:
            X, Y = _solve(A[idx], B[idx])
        except np.linalg.LinAlgError:
            continue
        d = pose_error_m(A, B, X, Y, L)
        med = float(np.median(d))
        if med < best_med:
            best, best_med = (X, Y), med
            needed = _needed_iterations(float(np.mean(d <= INLIER_FACTOR * med)))
    if best is None:
        raise DegenerateMotionError("no triple of poses gave a solution: the motions are degenerate")
    d = pose_error_m(A, B, *best, L)
    inliers = d <= INLIER_FACTOR * np.median(d)
    # refit on the inliers, then re-flag against the better fit
    X, Y = _solve(A[inliers], B[inliers])
    d = pose_error_m(A, B, X, Y, L)
    med = float(np.median(d))
    inliers = d <= INLIER_FACTOR * med
    return RansacResult(inliers=inliers, residual_m=d, median_residual_m=med, iterations=tried)


def _needed_iterations(inlier_fraction: float) -> int:
    """Triples to draw for one all-inlier triple with probability :data:`CONFIDENCE`."""
    miss = 1.0 - inlier_fraction**3
    if miss <= 0.0:
        return 0
    return int(np.ceil(np.log(1.0 - CONFIDENCE) / np.log(miss)))
