"""Refuse a least-squares fit that outlier poses have pulled off, naming them.

After a non-robust fit, each pose's whitened residual ``d_i^2 = |W_i r_i|^2`` is chi-square with 6
degrees of freedom when the noise model holds (up to one common factor, estimated robustly from the
median so that the outliers cannot set it). A pose beyond the ``1 - alpha / N`` quantile (Bonferroni
over the N poses: a clean pose set is flagged with probability about ``alpha``) is suspect. Real
camera poses have heavier tails than any Gaussian model (a PnP pose of a grazing board), and a mildly
wrong pose barely moves the fit, so a suspect pose only refuses the fit when leaving it out would move
``X`` by more than :data:`MAX_SHIFT_SIGMA` of its own sigma (the linearised leave-one-out shift, Cook's
distance restricted to ``X``): then the answer would be several sigma off, and it is refused with the
poses named rather than returned as if it were fine.

A set so contaminated that the fit itself is wrecked leaves no pose looking odd against it. The
pair-consensus test (:func:`pair_consensus_suspects`) needs no fit: every motion pair must keep its
rotation angle and its screw displacement (``t . axis``) from robot to camera, whatever X is; a
grossly wrong pose breaks nearly every pair it is in, a good pose only the few it shares with bad
ones. The front refits without the suspects and refuses when the two answers differ by more than
:data:`MAX_SHIFT_SIGMA` (:func:`x_shift_sigma`).
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

from classic.motions import Motions, iter_motions, near_half_turn
from classic.pairs import pair_indices, unique_sorted
from handeye.core.errors import ContaminatedPosesError
from handeye.core.se3 import so3_log

__all__ = [
    "CONTAMINATION_ALPHA",
    "RESIDUAL_FLOOR",
    "MAX_SHIFT_SIGMA",
    "PAIR_SUSPECT_FACTOR",
    "leave_one_out_shift",
    "suspect_poses",
    "check_contamination",
    "pair_consensus_suspects",
    "x_shift_sigma",
    "refuse_shift",
]

#: Probability of refusing a clean pose set.
CONTAMINATION_ALPHA = 1e-3
#: Residuals below 1 micrometre and 1 microradian are rounding, not outliers (exact data).
RESIDUAL_FLOOR = 1e-6
#: A suspect pose refuses the fit when leaving it out moves X by more than this many of its sigmas.
MAX_SHIFT_SIGMA = 5.0
_DOF = 6


def suspect_poses(whitened: np.ndarray, alpha: float = CONTAMINATION_ALPHA) -> tuple[np.ndarray, np.ndarray]:
    """Poses whose whitened residual is beyond the chi-square quantile, and every pose's sigma.

    Parameters
    ----------
    whitened : array, shape (N, 6)
    alpha : float

    Returns
    -------
    suspects : array of int
        Indices, largest residual first.
    n_sigma : array, shape (N,)
        ``sqrt(d_i^2 / s^2)`` with the robust common factor ``s^2``.
    """
    d2 = np.sum(np.asarray(whitened, dtype=float) ** 2, axis=1)
    n = len(d2)
    s2 = max(float(np.median(d2)) / chi2.median(_DOF), 1e-300)
    z = d2 / s2
    limit = chi2.ppf(1.0 - alpha / max(n, 1), _DOF)
    bad = np.flatnonzero(z > limit)
    return bad[np.argsort(-z[bad])], np.sqrt(z)


def leave_one_out_shift(
    jacobian: np.ndarray, whitened: np.ndarray, pose: int, variance: float = 1.0, normal: np.ndarray | None = None
) -> float:
    """How far, in sigmas of ``X``, the fit moves when one pose is left out (first order).

    Parameters
    ----------
    jacobian : array, shape (6N, P)
        Whitened Jacobian at the fit (X's six parameters first).
    whitened : array, shape (N, 6)
    pose : int
    variance : float
        Common variance factor of the whitened residuals.
    normal : array, shape (P, P), optional
        ``J^T J`` when the caller has it (one product for every pose it tests, not one each).

    Returns
    -------
    float
        ``sqrt(d^T C_X^-1 d)`` with ``d`` the shift of ``[w_X, v_X]`` and ``C_X`` its covariance.
    """
    J = np.asarray(jacobian, dtype=float)
    rows = slice(6 * pose, 6 * pose + 6)
    H = J.T @ J if normal is None else normal
    Ji = J[rows]
    shift = np.linalg.lstsq(H - Ji.T @ Ji, Ji.T @ np.asarray(whitened, dtype=float)[pose], rcond=None)[0][:6]
    C_X = variance * np.linalg.pinv(H)[:6, :6]
    return float(np.sqrt(max(shift @ np.linalg.lstsq(C_X, shift, rcond=None)[0], 0.0)))


#: A pose is a pair-consensus suspect when its median pair mismatch exceeds this multiple of the typical one.
PAIR_SUSPECT_FACTOR = 4.0
#: Partners per pose in the pair-consensus test of a large set (all pairs up to 2x this + 1 poses).
PAIR_PARTNERS = 24
#: Motion angle below which a pair's screw axis is too ill-defined for its displacement to count.
_SCREW_MIN_ANGLE_RAD = np.radians(5.0)
#: Motion pairs built at once by :func:`pair_consensus_suspects`.
_CHUNK = 4096


def pair_consensus_suspects(A: np.ndarray, B: np.ndarray, pairs: str = "all", motions_all=None) -> np.ndarray:
    """Poses that break the invariants of most motion pairs they are in.

    Per pair, the mismatch of rotation angles and of screw displacements between the robot's and
    the camera's motion, each over its median over all pairs; per pose, the median over its pairs.

    Parameters
    ----------
    A, B : array, shape (N, 4, 4)
        Robot-side poses and ``T_cam_target``.
    pairs : {"all", "consecutive"}
        "consecutive" pairs give each pose at most two pairs: too few for a median, so all are used.
    motions_all : classic.motions.Motions, optional
        The motions of all pairs, in ``pair_indices(n, "all")`` order, when already computed.

    Returns
    -------
    array of int
        Suspect poses (may be empty).
    """
    n = len(A)
    i, j = _consensus_pairs(n)
    score = _pair_scores(A, B, i, j, motions_all)
    per_pose = _median_per_pose(n, i, j, score)
    return np.flatnonzero(per_pose > PAIR_SUSPECT_FACTOR * np.median(per_pose))


def _consensus_pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The pairs of the consensus test: all up to ``2 PAIR_PARTNERS + 1`` poses, else each pose with
    :data:`PAIR_PARTNERS` others spread over the set (enough for a median, linear in N); (K,) each."""
    if n <= 2 * PAIR_PARTNERS + 1:
        return pair_indices(n, "all")
    offsets = np.unique(np.linspace(1, n - 1, PAIR_PARTNERS).astype(int))
    k = np.repeat(np.arange(n), len(offsets))
    other = (k + np.tile(offsets, n)) % n
    code = unique_sorted(np.minimum(k, other) * n + np.maximum(k, other))  # each pair once, in (i, j) order
    return code // n, code % n


def _pair_scores(A, B, i, j, motions_all) -> np.ndarray:
    """Per pair, the angle and screw-displacement mismatches, each over its median over the pairs; (K,)."""
    n = len(A)
    if motions_all is not None and len(motions_all) == n * (n - 1) // 2:
        idx = i * n - i * (i + 1) // 2 + (j - i - 1)  # position of (i, j) in numpy's triu order
        m = Motions(motions_all.q_A[idx], motions_all.t_A[idx], motions_all.q_B[idx], motions_all.t_B[idx])
        ang, disp, flip = _pair_invariants(m)
    else:  # chunk by chunk: a large set's pairs' motions are never all held at once
        ang = [np.empty(len(i)), np.empty(len(i))]
        disp = [np.empty(len(i)), np.empty(len(i))]
        flip = np.empty(len(i), dtype=bool)
        for start, m in zip(range(0, len(i), _CHUNK), iter_motions(A, B, i, j, _CHUNK)):
            part = slice(start, start + _CHUNK)
            a, d, flip[part] = _pair_invariants(m)
            for side in (0, 1):
                ang[side][part], disp[side][part] = a[side], d[side]
    d_ang = np.abs(ang[0] - ang[1])
    screw = (ang[0] > _SCREW_MIN_ANGLE_RAD) & (ang[1] > _SCREW_MIN_ANGLE_RAD)
    d_disp = np.where(flip, np.abs(np.abs(disp[0]) - np.abs(disp[1])), np.abs(disp[0] - disp[1]))
    del ang, disp, flip
    d_disp = np.where(screw, d_disp, 0.0)
    score = d_ang / max(float(np.median(d_ang)), 1e-12)
    if screw.any():
        score = score + d_disp / max(float(np.median(d_disp[screw])), 1e-12)
    return score


def _median_per_pose(n: int, i: np.ndarray, j: np.ndarray, score: np.ndarray) -> np.ndarray:
    """Per pose, the median score of the pairs it is in: the scores listed under both their poses, sorted; (N,)."""
    pose = np.concatenate([i, j])
    order = np.argsort(pose, kind="stable")  # runs: i is sorted already
    pose = pose[order]
    sc = np.concatenate([score, score])[order]
    del order
    start = np.searchsorted(pose, np.arange(n))
    count = np.bincount(pose, minlength=n)
    # one row per pose, its scores sorted (padded with inf): the per-row sort of a (N, 2 PAIR_PARTNERS)
    # table is several times faster than sorting all scores by pose and score
    table = np.full((n, int(count.max(initial=1))), np.inf)
    table[pose, np.arange(len(pose)) - start[pose]] = sc
    table.sort(axis=1)
    rows = np.arange(n)
    return 0.5 * (table[rows, (count - 1) // 2] + table[rows, count // 2])


def _pair_invariants(m: Motions) -> tuple[list, list, np.ndarray]:
    """Per pair, the rotation angles ``[robot, camera]`` (K,), the screw displacements ``t . axis``
    ``[robot, camera]`` (K,), and whether the pair is near a half turn (K,) of bool."""
    ang = []
    disp = []
    for q, t, angle in ((m.q_A, m.t_A, m.angles_A), (m.q_B, m.t_B, m.angles_B)):
        s = np.sqrt(np.einsum("ij,ij->i", q[:, :3], q[:, :3]))
        ang.append(angle)
        axis = q[:, :3] * np.sign(q[:, 3:4] + (q[:, 3:4] == 0)) / np.maximum(s, 1e-300)[:, None]
        disp.append(np.sum(axis * t, axis=1))
    # near a half turn noise sets each side's axis sign (w >= 0) on its own, and t . axis with it:
    # compare magnitudes there (classic.motions.near_half_turn)
    return ang, disp, near_half_turn(m)


def x_shift_sigma(X: np.ndarray, X_ref: np.ndarray, covariance_ref: np.ndarray) -> float:
    """How many sigmas of ``X_ref`` lie between ``X`` and ``X_ref``: Mahalanobis distance of ``[w, v]``.

    Parameters
    ----------
    X, X_ref : array, shape (4, 4)
    covariance_ref : array, shape (>= 6, >= 6)
        ``X_ref``'s covariance, ``[w_X, v_X]`` first.

    Returns
    -------
    float
    """
    d = np.concatenate([so3_log(X[:3, :3] @ X_ref[:3, :3].T), X[:3, 3] - X_ref[:3, 3]])
    return float(np.sqrt(max(d @ np.linalg.lstsq(covariance_ref[:6, :6], d, rcond=None)[0], 0.0)))


def refuse_shift(suspects: np.ndarray, shift_sigma: float, n: int) -> None:
    """Raise :class:`ContaminatedPosesError` for poses whose removal moves X by ``shift_sigma``."""
    shown = ", ".join(str(int(k)) for k in suspects[:12]) + (
        f" and {len(suspects) - 12} more" if len(suspects) > 12 else ""
    )
    raise ContaminatedPosesError(
        f"{len(suspects)} of {n} poses break the robot-camera consistency of most motion pairs they are in "
        f"(poses {shown}), and leaving them out moves the answer by {shift_sigma:.1f} sigma. A least-squares fit is "
        "pulled off by them, so none is returned. Check those poses (a bad board detection, a mis-paired row), "
        "remove them, or calibrate with robust=True (CLI: --robust) to fit without them."
    )


def check_contamination(
    whitened: np.ndarray,
    raw: np.ndarray | None = None,
    jacobian: np.ndarray | None = None,
    alpha: float = CONTAMINATION_ALPHA,
    numbers: np.ndarray | None = None,
) -> None:
    """Raise :class:`ContaminatedPosesError` when a pose is a gross outlier (see the module).

    Parameters
    ----------
    whitened : array, shape (N, 6)
        Whitened residuals of a non-robust fit (:attr:`classic.refine.Refinement.whitened`).
    raw : array, shape (N, 6), optional
        The same residuals in rad and m: a pose is only refused when its residual exceeds
        :data:`RESIDUAL_FLOOR` (on exact data the whitened residuals are rounding noise).
    jacobian : array, shape (6N, P), optional
        Whitened Jacobian at the fit: a suspect pose then only refuses the fit when leaving it out
        moves X by more than :data:`MAX_SHIFT_SIGMA` (without it every suspect refuses).
    alpha : float
    numbers : array of int, shape (N,), optional
        Each pose's number as the caller's poses number it (the fit may hold a subset); default ``0 .. N-1``.
    """
    bad, n_sigma = suspect_poses(whitened, alpha)
    if raw is not None and len(bad):
        r = np.asarray(raw, dtype=float)[bad]
        big = (np.linalg.norm(r[:, :3], axis=1) > RESIDUAL_FLOOR) | (np.linalg.norm(r[:, 3:], axis=1) > RESIDUAL_FLOOR)
        bad = bad[big]
    if len(bad) == 0:
        return
    shifts = np.full(len(n_sigma), np.inf)
    if jacobian is not None:
        d2 = np.sum(np.asarray(whitened, dtype=float) ** 2, axis=1)
        variance = max(float(np.median(d2)) / chi2.median(_DOF), 1e-300)
        J = np.asarray(jacobian, dtype=float)
        normal = J.T @ J
        for i in bad:
            shifts[i] = leave_one_out_shift(J, whitened, int(i), variance, normal)
        bad = bad[shifts[bad] > MAX_SHIFT_SIGMA]
        if len(bad) == 0:
            return
    every = np.arange(len(n_sigma))
    numbers = every if numbers is None else np.asarray(numbers)
    fitted = "" if np.array_equal(numbers, every) else " fitted"
    shown = ", ".join(
        f"{int(numbers[i])} ({n_sigma[i]:.1f} sigma"
        + (f", moves X by {shifts[i]:.1f} sigma)" if np.isfinite(shifts[i]) else ")")
        for i in bad[:8]
    )
    more = f" and {len(bad) - 8} more" if len(bad) > 8 else ""
    typical = float(np.median(n_sigma))
    raise ContaminatedPosesError(
        f"{len(bad)} of {len(n_sigma)} poses{fitted} disagree with the rest far beyond the noise (typical residual "
        f"{typical:.1f} sigma): pose {shown}{more}. A least-squares fit is pulled off by them, so none is "
        "returned. Check those poses (a bad board detection, a robot pose recorded before the arm settled), "
        "remove them, or calibrate with robust=True (CLI: --robust) to fit without them."
    )
