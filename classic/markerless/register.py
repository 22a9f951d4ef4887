"""Camera pose from the robot's own surface: register the posed robot model to the depth of many frames.

For one static camera and N frames of a moving robot, the robot's surface is
known in the base frame at every frame (forward kinematics of the recorded
joints, sampled as points ``m`` with outward normals ``n`` by the caller). The
camera pose is the one under which that surface lands on the observed depth in
all frames at once:

.. math:: \\hat T_{base,cam} = \\arg\\min_T \\sum_f \\sum_{i \\in f} \\rho\\big(n_i^T (T\\, q_i - m_i) / s\\big)

with ``q_i`` the observed point (camera frame) matched to model point ``i`` of
frame ``f``, ``rho`` a Cauchy loss and ``s`` a few depth-noise sigmas
(:mod:`classic.markerless.point_to_plane`).

Stages:

1. **The arm's pixels from motion** (:mod:`classic.markerless.depth`): what is
   nearer than the static depth moved there; no start needed.
2. **Start from centroids**: per frame, the centroid of the moving pixels'
   points (camera frame) and of the moving links' surface (base frame) form N
   point pairs; their rigid alignment (Kabsch) is a start within centimetres,
   refined a few times with the visible part of the model only. Any start the
   caller gives (the learned prediction, a tape-measure guess) is tried first.
3. **Coarse ICP**: each moving pixel matched to the nearest front-facing model
   point of its frame in 3-D, over a window shrinking from 30 cm to 1 cm.
4. **Fine registration**: the model's visible surface from the estimate
   (:mod:`classic.markerless.visibility`), each visible point matched to the
   observed point in its pixel (projective association), over all frames, the
   gate shrinking to a few noise sigmas.

The fine stage estimates with the pose, each under a Gaussian prior that keeps it where the frames say little and
puts its uncertainty into the pose's sigma:

- the sensor's depth scale and offset, ``d_obs = s d + o`` (``MarkerlessOptions.depth_model``), and for an
  active-stereo sensor (``stereo_fb_px_m``) its matcher's pull toward whole disparities,
  ``e(d) = a sin(2 pi d) + b cos(2 pi d)`` pixels of disparity;
- the depth camera's intrinsics ``(f_x, f_y, c_x, c_y)`` (``intrinsics_model``,
  :mod:`classic.markerless.intrinsics`), the camera matrix given the prior's mean;
- the robot's joint zero offsets ``delta``, true joint = recorded + ``delta`` (``joint_offsets_model``,
  :mod:`classic.markerless.kinematics`), where the surface carries its parts' twists per joint; the model is
  associated and fitted moved by them. A joint that moves every fitted part rigidly (the base rotation) is not
  estimated: its offset is a rotation of the camera about the base's axis, so the answer is the camera in the
  base frame the robot's own kinematics define.

The sigma counts frames, not pixels, as independent, and clusters the residuals by depth bin as well
(:func:`classic.clustered_covariance.clustered_covariance`); added to it in quadrature: the model's sampling bias
``F^2 / (8 r) / sqrt(3)`` for a pixel footprint ``F`` on a link of radius ``r``, the depth-to-colour extrinsic's
bound, and the scatter of groups of frames solved again by depth and by image column
(:mod:`classic.markerless.consistency`). The depth noise is measured on the static background
(:func:`classic.markerless.depth.depth_noise_curve`) unless the caller gives it.

The intrinsics are also reported with the depth noise's own bias taken out (``intrinsics["noise_debiased"]``,
:mod:`classic.markerless.noise_debias`), the estimate the placements pool.

A result is accepted only when most of the visible model is matched, the
residual is of the depth noise's size, the frames calibrate the depth and the last step has converged;
otherwise it is refused with the reason (:attr:`MarkerlessResult.refused`),
never returned as a calibration. What it achieves: ``docs/benchmarks/markerless.md``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from classic.markerless.depth_analysis import FALLBACK_SIGMA_M_AT_1M, DepthAnalysis
from classic.markerless.noise_debias import noise_debiased
from classic.markerless.options import MarkerlessOptions
from classic.markerless.point_to_plane import MatchedModel, PlaneFitOptions, solve_point_to_plane
from classic.markerless.problem import Outcome, Problem
from classic.markerless.result import MarkerlessResult, RefusedError, build_result, refused_result
from classic.markerless.surface_frames import RobotSurfaceFrames
from handeye.core.errors import NonFiniteError, ShapeError
from handeye.core.metrics import pose_error
from handeye.core.rigid import rigid_transform
from handeye.core.validation import check_transforms

__all__ = [
    "RobotSurfaceFrames",
    "MarkerlessOptions",
    "MarkerlessResult",
    "register_robot",
    "RefusedError",
    "FALLBACK_SIGMA_M_AT_1M",
]


def _check_inputs(depth_m, K, surface):
    depth_m = np.asarray(depth_m, dtype=float)
    if depth_m.ndim != 3:
        raise ShapeError(f"depth must be (N frames, H, W), got shape {depth_m.shape}")
    n_frames = len(depth_m)
    bad = ~np.isfinite(depth_m).reshape(len(depth_m), -1).all(axis=1)
    if bad.any():
        raise NonFiniteError(f"depth of frame {int(np.flatnonzero(bad)[0])} has NaN or inf (use 0 for no depth)")
    K = np.asarray(K, dtype=float)
    if K.shape != (3, 3) or not np.all(np.isfinite(K)) or K[0, 0] <= 0 or K[1, 1] <= 0:
        raise ShapeError(f"K must be a finite 3x3 camera matrix with positive focal lengths, got {K.tolist()}")
    if len(surface.frame) == 0 or surface.frame.min() < 0 or surface.frame.max() >= n_frames:
        raise ShapeError(f"surface frames must index the {n_frames} depth frames")
    return depth_m, K


def register_robot(
    depth_m: np.ndarray,
    K: np.ndarray,
    surface: RobotSurfaceFrames,
    starts: dict | None = None,
    options: MarkerlessOptions | None = None,
    centroid_start: bool = True,
    depth_analysis: DepthAnalysis | None = None,
) -> MarkerlessResult:
    """Register the posed robot surface to the depth of all frames: ``T_base_cam`` or a refusal.

    Parameters
    ----------
    depth_m : array, shape (N, H, W)
        Depth of N frames from one static camera, metres, 0 where missing (NaN is an error).
    K : array, shape (3, 3)
        Camera matrix of the depth images (undistorted, OpenCV convention).
    surface : RobotSurfaceFrames
        The robot's surface at each frame's joint angles, base frame.
    starts : dict of str -> array (4, 4), optional
        Starting ``T_base_cam`` by name (``"learned"``, ``"user"``), tried in order.
    options : MarkerlessOptions, optional
    centroid_start : bool
        Also try the start from the moving pixels' centroids (no prior needed).
    depth_analysis : DepthAnalysis, optional
        An earlier registration's of the same frames (:attr:`MarkerlessResult.depth_analysis`): the noise, the
        mixed and the moving pixels are taken from it instead of found again; ignored unless it holds for these
        frames and ``options.depth_sigma_m_at_1m`` (:func:`classic.markerless.depth_analysis.depth_key`).

    Returns
    -------
    MarkerlessResult
        Accepted, or refused with the reason; each start's outcome in ``diagnostics["starts"]``, the frames' own
        findings in ``depth_analysis``.

    Raises
    ------
    ShapeError, NonFiniteError
        Depth not (N, H, W), NaN in a frame (named), a bad K, surface frames out of range.
    """
    opts = options or MarkerlessOptions()
    depth_m, K = _check_inputs(depth_m, K, surface)
    starts = dict(starts or {})
    for name, T in starts.items():
        check_transforms(T, f"start {name!r}")
    problem = Problem(depth_m, K, surface, opts, depth_analysis)
    return replace(_registered(problem, starts, centroid_start), depth_analysis=problem.analysis)


def _registered(problem: Problem, starts: dict, centroid_start: bool) -> MarkerlessResult:
    """:func:`register_robot`'s stages on its problem: the starts, the best one's fit, the result."""
    opts, n = problem.opts, problem.n
    diag = {"frames": n, "moving_pixels": int(problem.n_moving), "mixed_pixels": problem.n_mixed, "starts": {}}
    if problem.n_moving < opts.min_moving_pixels:
        return refused_result(
            f"too few robot pixels: {problem.n_moving} pixels moved between the {n} frames "
            f"(at least {opts.min_moving_pixels} needed); is the arm in view and moving?",
            diag,
        )
    if centroid_start:
        T0 = _centroid_start(problem)
        if T0 is not None:
            starts["centroids"] = T0
    if not starts:
        return refused_result(
            "no start: the moving pixels of too few frames to align centroids, and none was given", diag
        )
    best = _best_of_starts(problem, starts, diag)
    if isinstance(best, str):
        return refused_result(best, diag)
    return noise_debiased(problem, build_result(problem, best, diag), _fine)


def _best_of_starts(problem: Problem, starts: dict, diag: dict) -> Outcome | str:
    """Stages 3 and 4 from each start in turn, until one clearly succeeds; the best kept, the problem left in its
    state. Returns its outcome, or the reason none would do."""
    opts, best = problem.opts, None
    for name, T_start in starts.items():
        problem.restart()
        outcome = _fine(problem, _coarse(problem, np.asarray(T_start, dtype=float)), name)
        diag["starts"][name] = {"matched_fraction": round(outcome.matched, 4), "converged_step": float(outcome.step)}
        if outcome.fit is not None and (best is None or outcome.matched > best.matched):
            best = outcome
        if outcome.fit is not None and outcome.matched >= opts.min_matched_fraction + 0.15:
            break  # a clear success: the other starts cannot do better than the noise
    if best is None:
        return "did not converge: no start kept enough matched points"
    # the best start's depth, intrinsics and joint offsets: a later start may have run since, and the split check
    # and the reported offsets read the problem's
    problem.adopt(best.fit)
    if problem.hold_undetermined(best.fit):  # static parts fitted, the base rotation not determined: absorbed
        best = _fine(problem, best.T, best.name)
        if best.fit is None:
            return "did not converge: the fit with the base rotation's offset absorbed kept too few points"
    return best


def _centroids(frame, points, n):
    """Per frame (``n`` of them), the centroid of ``points`` and how many there are (NaN centroids where none)."""
    count = np.bincount(frame, minlength=n).astype(float)
    sums = np.stack([np.bincount(frame, points[:, k], minlength=n) for k in range(3)], axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return sums / count[:, None], count


def _centroid_start(problem: Problem, iterations=4):
    """Stage 2: the rigid alignment of the moving pixels' centroids (camera frame) with the moving parts', per frame
    (base frame), refined ``iterations`` times with the visible part of the model; None with too few frames."""
    c_obs, counts = _centroids(problem.moving_frame, problem.moving_p_cam, problem.n)
    use = counts >= 20
    if use.sum() < 3:
        return None
    T = None
    for _ in range(iterations + 1):
        idx = problem.coarse_subset if T is None else problem.visible(T, subset=problem.coarse_subset)[0]
        idx = idx[problem.moving_part[idx]]
        c_mod, n_mod = _centroids(problem.s.frame[idx], problem.s.points_base[idx], problem.n)
        ok = use & (n_mod >= 10)
        if ok.sum() < 3:
            return T
        T = rigid_transform(c_obs[ok], c_mod[ok], counts[ok])
    return T


def _coarse(problem: Problem, T):
    """3-D ICP of the moving pixels to the model, window shrinking; up to 3 matchings per window,
    fewer once a matching moves the pose by less than a tenth of the window (the rotation taken at 1 m)."""
    moving_p_cam = problem.corrected(problem.moving_p_cam)
    for window in problem.opts.coarse_windows_m:
        for _ in range(3):
            p_base = moving_p_cam @ T[:3, :3].T + T[:3, 3]
            ok, jj = problem.nearest(p_base, problem.moving_frame, window)
            if ok.sum() < 50:
                break
            n = problem.s.normals_base[jj]
            # front-facing matches only: the normal must point towards the camera
            towards = np.einsum("ij,ij->i", n, T[:3, 3] - problem.s.points_base[jj]) > 0
            sel = np.flatnonzero(ok)[towards]
            jj = jj[towards]
            if len(sel) < 50:
                break
            fit = solve_point_to_plane(
                moving_p_cam[sel],
                MatchedModel(problem.s.points_base[jj], problem.s.normals_base[jj]),
                T,
                PlaneFitOptions(scale_m=window / 3, loss="cauchy", iterations=2, covariance=False),
            )
            moved = pose_error(T, fit.T_base_cam)
            T = fit.T_base_cam
            if np.radians(moved[0]) + moved[1] / 1e3 < 0.1 * window:
                break
    return T


def _fine(problem: Problem, T, name):
    """Projective point-to-plane from ``T``, gate shrinking to 4 robust sigmas; returns the start ``name``'s
    outcome.

    The z-buffer is rebuilt on the first and fourth association and every fifth after; in between the
    visible points are only projected again. The last association always has a fresh z-buffer, and the
    matched fraction (visible model points with depth within 1 cm) is taken from it.
    """
    opts = problem.opts
    gates = opts.fine_gates_m
    fit, step, scale, visible_idx = None, np.inf, None, None
    for it in range(opts.fine_iterations):
        gate = gates[it] if it < len(gates) else max(4 * scale, 0.004)
        full = _fresh_zbuffer(it)
        idx, f, q_obs, q, has_depth, close = problem.associate(T, gate, None if full else visible_idx)
        if full:
            visible_idx = idx
        fitted = problem.fitted_matches(idx, close)
        if fitted.sum() < 50:
            return Outcome(name, T, None, np.inf, 0.0)
        fit, expected, _ = problem.fit_matches(T, idx, f, q_obs, fitted, covariance=False)  # the matches change next
        T, step = fit.T_base_cam, fit.step_norm
        inl = fit.weights > 0.5
        scale = max(1.4826 * float(np.median(np.abs(fit.residuals_m[inl]))) if inl.any() else gate, expected)
        if it >= len(gates) and step < 1e-7:
            break
    return _final_outcome(problem, T, name, step, max(4 * scale, 0.004))


def _fresh_zbuffer(it: int) -> bool:
    """Whether the fine stage's association ``it`` (from 0) rebuilds the z-buffer: the first, the fourth and every
    fifth after."""
    return it in (0, 3) or (it > 3 and (it - 3) % 5 == 0)


def _final_outcome(problem: Problem, T, name, step, gate_m):
    """The fine stage's last association, fresh z-buffer, within ``gate_m``: one more fit on it, and the matched
    fraction; the start ``name``'s outcome, its last step the larger of ``step`` and this fit's."""
    idx, f, q_obs, q, has_depth, close = problem.associate(T, gate_m)
    fitted = problem.fitted_matches(idx, close)
    if fitted.sum() < 50:
        return Outcome(name, T, None, np.inf, 0.0)
    fit, _, matches = problem.fit_matches(T, idx, f, q_obs, fitted)
    q = problem.corrected(q_obs)
    step = max(step, fit.step_norm)
    matched_q = q[fitted]  # what calibrated the depth
    geometry = (
        float(np.median(matched_q[:, 2])),
        float(np.sqrt(np.mean(np.sum((matched_q - matched_q.mean(0)) ** 2, axis=1)))),
    )
    depth_range = tuple(np.percentile(matched_q[:, 2], [10, 90]))
    within_1cm = has_depth & (
        np.abs(q[:, 2] - (problem.model_points(idx) - fit.T_base_cam[:3, 3]) @ fit.T_base_cam[:3, 2]) < 0.01
    )
    matched = float(within_1cm.sum()) / max(int(has_depth.sum()), 1)
    return Outcome(name, fit.T_base_cam, fit, step, matched, geometry, depth_range, matches)
