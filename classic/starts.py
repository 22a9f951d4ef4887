"""Starts for the refinement: the cheap closed forms side by side, and one that also finds a metric scale.

The closed forms fail in different ways (AX=XB methods work on motion pairs and weigh large motions;
AX=YB methods work on absolute poses), and each costs well under a millisecond, so the refinement
starts from whichever explains the poses best (:func:`best_start`). A camera whose translations
have an unknown scale (monocular SLAM) needs a start for the scale as well: the rotation from Park
(angles carry no scale), then ``t_X`` and ``s`` from one linear system (:func:`scaled_start`).
"""

from __future__ import annotations

import numpy as np

from classic.motions import motions_from_transforms
from classic.pairs import pair_indices
from classic.park import park
from classic.ransac import pose_error_m
from classic.residuals import estimate_target_pose
from classic.rotation_ambiguity import commuting_half_turns, half_turn, solve_translations
from handeye.core.errors import DegenerateMotionError
from handeye.core.se3 import invert_transform, make_transform

__all__ = ["START_CANDIDATES", "AMBIGUOUS_COST_RATIO", "best_start", "resolve_half_turns", "scaled_start"]

#: The closed forms :func:`best_start` compares: one AX=XB and one AX=YB.
START_CANDIDATES = ("park", "shah")
#: Of two rotations the camera's motions cannot tell apart, the translations must fit one at least this many
#: times better (sum of squared pose errors), or the set is refused as ambiguous.
AMBIGUOUS_COST_RATIO = 4.0


def best_start(A: np.ndarray, B: np.ndarray, solve, candidates=START_CANDIDATES) -> tuple[str, np.ndarray, np.ndarray]:
    """The candidate closed form with the lowest sum of squared pose errors.

    Parameters
    ----------
    A, B : array, shape (N, 4, 4)
        Robot-side poses and ``T_cam_target``.
    solve : callable
        ``(A, B, method) -> (X, Y)`` (:func:`classic.calibrate.initial_estimate`).
    candidates : sequence of str

    Returns
    -------
    method : str
    X, Y : array, shape (4, 4)
    """
    best = None
    for method in candidates:
        try:
            X, Y = solve(A, B, method)
        except (DegenerateMotionError, np.linalg.LinAlgError):
            continue
        cost = float(np.sum(pose_error_m(A, B, X, Y) ** 2))
        if np.isfinite(cost) and (best is None or cost < best[0]):
            best = (cost, method, X, Y)
    if best is None:
        raise DegenerateMotionError(f"none of the closed forms {', '.join(candidates)} gives a solution")
    X, Y = resolve_half_turns(A, B, best[2], best[3], best[0])
    return best[1], X, Y


def resolve_half_turns(A: np.ndarray, B: np.ndarray, X: np.ndarray, Y: np.ndarray, cost: float | None = None):
    """``(X, Y)``, or the rotation of ``X`` by a half turn the camera's motions cannot see, if the
    translations fit that one better (:mod:`classic.rotation_ambiguity`).

    Parameters
    ----------
    A, B : array, shape (N, 4, 4)
        Robot-side poses and ``T_cam_target``.
    X, Y : array, shape (4, 4)
        A closed form's answer.
    cost : float, optional
        Its sum of squared pose errors, when already computed.

    Returns
    -------
    X, Y : array, shape (4, 4)

    Raises
    ------
    DegenerateMotionError
        When two such rotations fit the translations within :data:`AMBIGUOUS_COST_RATIO` of each other.
    """
    axes = commuting_half_turns(B[:, :3, :3])
    if len(axes) == 0:
        return X, Y
    found = [(float(np.sum(pose_error_m(A, B, X, Y) ** 2)) if cost is None else cost, X, Y)]
    for c in axes:
        Xc, Yc = solve_translations(A, B, X[:3, :3] @ half_turn(c))
        found.append((float(np.sum(pose_error_m(A, B, Xc, Yc) ** 2)), Xc, Yc))
    found.sort(key=lambda f: f[0])
    if found[1][0] < AMBIGUOUS_COST_RATIO * max(found[0][0], 1e-300):
        shown = "; ".join(f"[{c[0]:+.2f}, {c[1]:+.2f}, {c[2]:+.2f}]" for c in axes)
        raise DegenerateMotionError(
            f"the camera's motions are half turns about a few axes, so the camera's rotation is fixed only up to a "
            f"half turn about {shown} (camera frame), and the translations do not tell the candidates apart "
            f"(their pose errors within {AMBIGUOUS_COST_RATIO:g}x). Add poses turned by 20 to 120 degrees about "
            "other axes."
        )
    return found[0][1], found[0][2]


def scaled_start(A: np.ndarray, B: np.ndarray, pairs: str = "all") -> tuple[np.ndarray, np.ndarray, float]:
    """``(X, Y, s)`` of ``A_i Y = X B_i(s)``, ``B_i(s)`` with its translation times ``s``.

    Rotation by Park on the motion pairs; then, per motion, ``(R_A - I) t_X - s R_X t_B = -t_A``
    (least squares in ``t_X`` and ``s``); ``Y`` from the scaled poses.

    Parameters
    ----------
    A, B : array, shape (N, 4, 4)
    pairs : {"all", "consecutive"}

    Returns
    -------
    X, Y : array, shape (4, 4)
    s : float
    """
    i, j = pair_indices(len(A), pairs)
    A_ij = A[j] @ invert_transform(A[i])  # the motions of classic.motions: A_j A_i^-1, B_j B_i^-1
    B_ij = B[j] @ invert_transform(B[i])
    m = motions_from_transforms(A_ij, B_ij)
    R_X = park(A_ij, B_ij)[:3, :3]
    M = np.concatenate([m.R_A - np.eye(3), -(R_X @ m.t_B[:, :, None])], axis=2).reshape(-1, 4)
    sol = np.linalg.lstsq(M, -m.t_A.reshape(-1), rcond=None)[0]
    s = float(sol[3])
    if not np.isfinite(s) or s <= 0:
        raise DegenerateMotionError(
            f"the camera translations' scale came out {s:.3g}: the motions do not fix it "
            "(more translation of the camera between poses is needed)"
        )
    X = make_transform(R_X, sol[:3])
    Bs = B.copy()
    Bs[:, :3, 3] *= s
    return X, estimate_target_pose(A, Bs, X), s
