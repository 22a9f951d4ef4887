"""Camera pose from 3-D keypoints seen in many frames: robust closed form, then least squares with a sigma.

Given camera-frame points ``p_cam`` (a detector's keypoints back-projected with depth) and their
base-frame positions ``p_base`` (forward kinematics), find ``T_base_cam`` with
``p_base ~ T_base_cam p_cam`` over all frames at once:

1. RANSAC over minimal samples (three points, rigid closed form, :func:`handeye.core.rigid.rigid_transform`),
   scored by the number of points within ``inlier_m``;
2. IRLS with a Cauchy weight from that consensus (:func:`handeye.core.rigid.robust_rigid_transform`);
3. given what was measured (normalised image positions and depths) and each component's sigma: the
   maximum-likelihood fit of the consensus's projections and depths
   (:func:`handeye.core.keypoint_fit.likelihood_fit`, the learned placement fit's), so that a pixel error
   is not read as a depth error and each keypoint counts as much as its sigma allows;
4. the covariance of ``(omega, v)`` (camera-frame right perturbation, as in
   :mod:`classic.markerless.point_to_plane`), :func:`classic.clustered_covariance.clustered_covariance`
   with one cluster per frame, of the 3-D residuals or, after step 3, of the whitened ones.

Refuses (``refused`` names the reason) when fewer than ``min_inlier_fraction`` of the points, or
fewer than six, agree: most keypoints wrong is not an answer.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from classic.clustered_covariance import clustered_covariance, pose_sigma
from handeye.core.errors import HandEyeInputError, ShapeError
from handeye.core.keypoint_fit import cauchy_weights, likelihood_fit, whitened_residuals
from handeye.core.rigid import rigid_residuals, rigid_transform, robust_rigid_transform
from handeye.core.se3 import hat

__all__ = ["KeypointPoseOptions", "KeypointPoseResult", "solve_keypoint_pose"]


@dataclass
class KeypointPoseResult:
    """``T_base_cam`` from keypoints, or a refusal.

    Attributes
    ----------
    T_base_cam : array, shape (4, 4) or None
    refused : str or None
    sigma : dict
        ``rotation_deg`` and ``translation_mm`` (RMS of the error norm).
    covariance : array, shape (6, 6)
    inliers : array of bool, shape (M,)
    rms_mm : float
        RMS 3-D residual of the inliers.
    """

    T_base_cam: np.ndarray | None
    refused: str | None
    sigma: dict
    covariance: np.ndarray
    inliers: np.ndarray
    rms_mm: float

    @property
    def ok(self) -> bool:
        return self.refused is None


@dataclass(frozen=True, kw_only=True)
class KeypointPoseOptions:
    """The consensus of :func:`solve_keypoint_pose` and its refusal, checked on construction.

    Attributes
    ----------
    inlier_m : float
        RANSAC's consensus distance, metres.
    min_inlier_fraction : float
        Refused when fewer of the valid points agree (in [0, 1]).
    iterations : int
        RANSAC samples.
    rng : numpy.random.Generator, optional
        Default ``default_rng(0)`` (deterministic).

    Raises
    ------
    HandEyeInputError
        ``inlier_m`` not a positive number, ``min_inlier_fraction`` not in [0, 1] (a NaN would never refuse),
        ``iterations`` below 1.
    """

    inlier_m: float = 0.03
    min_inlier_fraction: float = 0.5
    iterations: int = 200
    rng: np.random.Generator | None = None

    def __post_init__(self) -> None:
        """Refuse settings under which the consensus or its refusal cannot work (NaN compares False: never refused)."""
        inlier_m, min_inlier_fraction, iterations = self.inlier_m, self.min_inlier_fraction, self.iterations
        if not (np.isfinite(inlier_m) and inlier_m > 0):
            raise HandEyeInputError(f"inlier_m must be a positive number of metres, got {inlier_m!r}")
        if not (0.0 <= min_inlier_fraction <= 1.0):
            raise HandEyeInputError(f"min_inlier_fraction must be in [0, 1], got {min_inlier_fraction!r}")
        if int(iterations) != iterations or iterations < 1:
            raise HandEyeInputError(f"iterations must be a whole number >= 1, got {iterations!r}")


def solve_keypoint_pose(
    p_cam: np.ndarray,
    p_base: np.ndarray,
    frame: np.ndarray | None = None,
    *,
    meas: np.ndarray | None = None,
    intrinsics_norm: np.ndarray | None = None,
    sigma: np.ndarray | None = None,
    options: KeypointPoseOptions | None = None,
) -> KeypointPoseResult:
    """Robust ``T_base_cam`` from matched camera-frame and base-frame points.

    Parameters
    ----------
    p_cam, p_base : array, shape (M, 3)
        Metres. Rows with NaN are ignored.
    frame : array of int, shape (M,), optional
        Frame of each point (the covariance's clusters); one cluster per point when omitted.
    meas : array, shape (M, 3), optional
        What ``p_cam`` was back-projected from: normalised image position and depth ``(x_n, y_n, z_m)``
        (:mod:`handeye.core.keypoint_fit`). With ``intrinsics_norm`` and ``sigma``, the pose is the
        maximum-likelihood fit of the consensus's measurements (step 3).
    intrinsics_norm : array, shape (M, 4), optional
        ``(fx, fy, cx, cy)`` normalised, per point.
    sigma : array, shape (M, 3), optional
        Sigma of each measured component. ``meas``, ``intrinsics_norm`` and ``sigma`` come together.
    options : KeypointPoseOptions, optional
        RANSAC's consensus distance, samples and generator, and the share of agreeing points below which the
        answer is refused; None: :class:`KeypointPoseOptions`' defaults (3 cm, 200 samples, half).

    Returns
    -------
    KeypointPoseResult

    Raises
    ------
    ShapeError
        Points not both ``(M, 3)``; ``meas``, ``intrinsics_norm`` and ``sigma`` not all given or of other shapes.
        (Bad settings are refused where :class:`KeypointPoseOptions` is made.)
    """
    options = options or KeypointPoseOptions()
    inlier_m, min_inlier_fraction, iterations = options.inlier_m, options.min_inlier_fraction, options.iterations
    p_cam, p_base = _checked_points(p_cam, p_base)
    m = len(p_cam)
    measured = _checked_measurements(m, meas, intrinsics_norm, sigma)
    frame = np.arange(m) if frame is None else np.asarray(frame)
    rng = np.random.default_rng(0) if options.rng is None else options.rng
    valid = np.isfinite(p_cam).all(1) & np.isfinite(p_base).all(1)
    idx = np.flatnonzero(valid)
    if len(idx) < 6:
        return KeypointPoseResult(
            None,
            f"too few keypoints: {len(idx)} valid (at least 6 needed)",
            {"rotation_deg": np.nan, "translation_mm": np.nan},
            np.full((6, 6), np.nan),
            np.zeros(m, bool),
            np.nan,
        )
    w0 = np.zeros(m)
    w0[idx] = _consensus(p_cam, p_base, idx, inlier_m, iterations, rng)
    T, w = robust_rigid_transform(p_cam, p_base, w0, floor_m=1e-6)
    r3 = rigid_residuals(T, np.nan_to_num(p_cam), np.nan_to_num(p_base))
    inl = valid & (np.linalg.norm(r3, axis=1) < inlier_m)
    sel = np.flatnonzero(inl)
    if measured is not None and len(sel) >= 3:
        T, cov = _likelihood_fit(T, measured, p_base, sel, frame)
        r3 = rigid_residuals(T, np.nan_to_num(p_cam), np.nan_to_num(p_base))
    else:
        cov = _rigid_covariance(T, p_cam, r3, w, sel, frame)
    rms_mm = float(np.sqrt(np.mean(np.sum(r3[inl] ** 2, axis=1))) * 1e3) if inl.any() else np.nan
    refused = _too_few_agree(inl, valid, inlier_m, min_inlier_fraction)
    return KeypointPoseResult(None if refused else T, refused, pose_sigma(cov, T[:3, :3]), cov, inl, rms_mm)


# -- the stages of solve_keypoint_pose(), in its order


def _checked_points(p_cam, p_base) -> tuple[np.ndarray, np.ndarray]:
    """The points as float arrays, both ``(M, 3)`` (else :class:`ShapeError`)."""
    p_cam = np.asarray(p_cam, dtype=float)
    p_base = np.asarray(p_base, dtype=float)
    if p_cam.shape != p_base.shape or p_cam.ndim != 2 or p_cam.shape[1] != 3:
        raise ShapeError(f"keypoints must both be (M, 3), got {p_cam.shape} and {p_base.shape}")
    return p_cam, p_base


def _checked_measurements(m: int, meas, intrinsics_norm, sigma):
    """``(meas, intrinsics_norm, sigma)`` as float arrays for ``m`` points, or None when not given; some
    without the others, or shapes that do not match, raise :class:`ShapeError`."""
    given = [a is not None for a in (meas, intrinsics_norm, sigma)]
    if any(given) and not all(given):
        raise ShapeError("meas, intrinsics_norm and sigma go together: give all three or none")
    if not all(given):
        return None
    meas, intrinsics_norm = np.asarray(meas, dtype=float), np.asarray(intrinsics_norm, dtype=float)
    sigma = np.asarray(sigma, dtype=float)
    if meas.shape != (m, 3) or intrinsics_norm.shape != (m, 4) or sigma.shape != (m, 3):
        raise ShapeError(
            f"meas and sigma must be (M, 3) and intrinsics_norm (M, 4) for M = {m}, got {meas.shape}, "
            f"{sigma.shape} and {intrinsics_norm.shape}"
        )
    return meas, intrinsics_norm, sigma


def _consensus(p_cam, p_base, idx, inlier_m: float, iterations: int, rng) -> np.ndarray:
    """Step 1: which of the valid points ``idx`` lie within ``inlier_m`` of the RANSAC sample with the most."""
    best, best_count = None, -1
    for _ in range(iterations):
        s = rng.choice(idx, 3, replace=False)
        T = rigid_transform(p_cam[s], p_base[s])
        if not np.isfinite(T).all():
            continue
        count = int((np.linalg.norm(rigid_residuals(T, p_cam[idx], p_base[idx]), axis=1) < inlier_m).sum())
        if count > best_count:
            best, best_count = T, count
    return np.linalg.norm(rigid_residuals(best, p_cam[idx], p_base[idx]), axis=1) < inlier_m


def _likelihood_fit(T, measured, p_base, sel, frame):
    """Steps 3 and 4 with measurements: the maximum-likelihood fit of the consensus ``sel`` from ``T``, and the
    covariance of its whitened residuals. Returns ``(T, covariance)``."""
    meas, intrinsics_norm, sigma = measured
    args = (meas[sel], p_base[sel], intrinsics_norm[sel], sigma[sel])
    T = likelihood_fit(*(a[None] for a in args), T[None])[0][0]
    r, J, ok = whitened_residuals(*args, T)
    # the Cauchy loss's weights per component, as in the fit; J is d r / d (dw, dv), whose covariance is
    # that of T_base_cam's camera-frame right perturbation (handeye.core.keypoint_fit)
    wr = np.where(ok[:, None], cauchy_weights(r), 0.0)
    return T, clustered_covariance(J.reshape(-1, 6), r.reshape(-1), wr.reshape(-1), np.repeat(frame[sel], 3))


def _rigid_covariance(T, p_cam, r3, w, sel, frame) -> np.ndarray:
    """Step 4 without measurements: the covariance of the consensus's 3-D residuals ``r3``, IRLS weights ``w``."""
    # r = R (p + omega x p + v) + t - q  ->  dr/domega = -R [p]x, dr/dv = R; three residual rows per point
    R = T[:3, :3]
    J = np.concatenate([-R @ hat(p_cam[sel]), np.broadcast_to(R, (len(sel), 3, 3))], axis=2).reshape(-1, 6)
    return clustered_covariance(J, r3[sel].reshape(-1), np.repeat(w[sel], 3), np.repeat(frame[sel], 3))


def _too_few_agree(inl, valid, inlier_m: float, min_inlier_fraction: float) -> str | None:
    """The refusal when fewer than six points, or than ``min_inlier_fraction`` of the valid ones, agree."""
    frac = inl.sum() / max(valid.sum(), 1)
    if not (inl.sum() < 6 or frac < min_inlier_fraction):
        return None
    return (
        f"too few keypoints agree: {int(inl.sum())} of {int(valid.sum())} ({frac:.0%}) within "
        f"{inlier_m * 1e3:.0f} mm (at least {min_inlier_fraction:.0%} and 6 needed)"
    )
