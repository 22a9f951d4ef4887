"""Hand-eye calibration from unsynchronised streams: the camera's time offset against the robot's clock.

The robot's poses are interpolated at each camera time plus an unknown offset
(:class:`classic.robot_stream.RobotStream`). The offset is found by a grid search of the closed
form's pose residual (robust to a start far off: one evaluation per half robot sample over the
stated range), then estimated jointly with X and Y by the refinement (:func:`classic.refine.refine_xy`),
which reports its sigma.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from classic.calibrate import initial_estimate
from classic.contamination import check_contamination
from classic.ransac import pose_error_m
from classic.refine import LOSSES, RefineOptions, refine_xy
from classic.residuals import pose_residuals
from classic.result import CalibrationResult, PoseResiduals
from classic.robot_stream import RobotStream
from handeye.core.errors import DegenerateMotionError, HandEyeInputError, TooFewPosesError
from handeye.core.setups import normalize_setup, robot_side_poses
from handeye.core.validation import MIN_POSES, check_transforms, check_units_metres

__all__ = ["StreamOptions", "calibrate_stream", "MAX_GRID_POINTS", "GRID_POSES"]

#: The offset grid is capped at this many points (the step grows with the range).
MAX_GRID_POINTS = 801
#: Camera poses the grid search uses (evenly spread); the refinement uses all.
GRID_POSES = 30


@dataclass(frozen=True, kw_only=True)
class StreamOptions:
    """The settings of :func:`calibrate_stream` that few calls change (the defaults are its own).

    Attributes
    ----------
    method : str
        Closed form of the grid search and start.
    noise : None, (float, float) or classic.noise_model.NoiseModel
        As in :func:`classic.calibrate`.
    loss : {"linear", "huber", "cauchy"}
    check : bool
        Refuse a fit that outlier poses pulled off (linear loss).
    """

    method: str = "park"
    noise: object = None
    loss: str = "linear"
    check: bool = True


def calibrate_stream(
    robot_times_s: np.ndarray,
    T_base_ee: np.ndarray,
    camera_times_s: np.ndarray,
    T_cam_target: np.ndarray,
    setup: str = "eye_to_hand",
    max_offset_s: float = 0.5,
    *,
    options: StreamOptions | None = None,
) -> CalibrationResult:
    """Calibrate from a robot pose stream and camera poses at other times, with their time offset.

    Parameters
    ----------
    robot_times_s : array, shape (M,)
        Strictly increasing.
    T_base_ee : array, shape (M, 4, 4)
        Robot flange poses at those times, metres.
    camera_times_s : array, shape (N,)
        Times of the camera's target poses on the camera's clock.
    T_cam_target : array, shape (N, 4, 4)
    setup : {"eye_to_hand", "eye_in_hand"}
    max_offset_s : float
        The offset is searched in ``[-max_offset_s, max_offset_s]`` (robot time = camera time + offset);
        camera poses whose shifted time could leave the robot recording are left out.
    options : StreamOptions, optional
        The closed form, the noise model, the loss and the contamination check; None: :class:`StreamOptions`'
        defaults.

    Returns
    -------
    CalibrationResult
        ``diagnostics["time_offset"]``: ``value_s``, ``sigma_s``, ``grid_step_s``, ``poses_used``
        (indices into the camera poses).

    Raises
    ------
    HandEyeInputError
        Bad times or shapes; :class:`TooFewPosesError` when too few camera poses fall inside.
    """
    options = options or StreamOptions()
    method, noise, loss, check = options.method, options.noise, options.loss, options.check
    setup = normalize_setup(setup)
    if loss not in LOSSES:
        raise HandEyeInputError(f"unknown loss {loss!r}: use one of {LOSSES}")
    if not (np.isfinite(max_offset_s) and max_offset_s >= 0):
        raise HandEyeInputError(f"max_offset_s must be finite and >= 0, got {max_offset_s!r}")
    stream = RobotStream(robot_times_s, T_base_ee)
    check_units_metres(stream.T_base_ee, "T_base_ee")
    t_cam, B, used = _camera_poses_inside(stream, camera_times_s, T_cam_target, max_offset_s)
    grid = _offset_grid(stream, max_offset_s)
    dt0, X0, Y0 = _grid_search(stream, t_cam, B, grid, setup, method)
    options = RefineOptions(loss=loss, noise=noise, setup=setup, time_offset0_s=dt0)
    ref = refine_xy(None, B, X0, Y0, options, stream=stream, camera_times_s=t_cam)
    A = robot_side_poses(stream.at(t_cam + ref.time_offset_s)[0], setup)
    r_rot, r_trans = pose_residuals(A, B, ref.X, ref.Y)
    if check and loss == "linear":
        check_contamination(ref.whitened, np.concatenate([r_rot, r_trans], axis=1), ref.jacobian)
    residuals = PoseResiduals(
        np.degrees(np.linalg.norm(r_rot, axis=1)), 1000 * np.linalg.norm(r_trans, axis=1), np.ones(len(B), dtype=bool)
    )
    diagnostics = _diagnostics(ref, grid, used, loss)
    return CalibrationResult(setup, f"{method}+offset+lm", ref.X, ref.Y, residuals, ref.covariance, diagnostics)


# -- the stages of calibrate_stream(), in its order


def _camera_poses_inside(stream: RobotStream, camera_times_s, T_cam_target, max_offset_s: float):
    """The camera's validated times and poses that stay inside the robot recording at any searched offset:
    ``(t_cam, B, used)``, ``used`` their indices into the camera poses."""
    B_all = check_transforms(T_cam_target, "T_cam_target")
    check_units_metres(B_all, "T_cam_target")
    t_cam = np.asarray(camera_times_s, dtype=float)
    if t_cam.shape != (len(B_all),) or not np.all(np.isfinite(t_cam)):
        raise HandEyeInputError(f"{len(B_all)} camera poses need {len(B_all)} finite times, got shape {t_cam.shape}")
    t0, t1 = stream.times_s[0], stream.times_s[-1]
    used = np.flatnonzero((t_cam - max_offset_s >= t0) & (t_cam + max_offset_s <= t1))
    if len(used) < MIN_POSES:
        raise TooFewPosesError(
            f"only {len(used)} camera poses lie at least {max_offset_s} s inside the robot recording "
            f"[{t0:.3f}, {t1:.3f}] s; at least {MIN_POSES} are needed (check the clocks, or lower max_offset_s)"
        )
    return t_cam[used], B_all[used], used


def _offset_grid(stream: RobotStream, max_offset_s: float) -> np.ndarray:
    """The searched offsets: one per half robot sample over ``[-max_offset_s, max_offset_s]``, at most
    :data:`MAX_GRID_POINTS`."""
    spacing = float(np.median(np.diff(stream.times_s)))
    n_grid = int(min(MAX_GRID_POINTS, 2 * np.ceil(max_offset_s / (0.5 * spacing)) + 1)) if max_offset_s > 0 else 1
    return np.linspace(-max_offset_s, max_offset_s, n_grid)


def _grid_search(stream: RobotStream, t_cam, B, grid, setup: str, method: str):
    """The offset of the grid whose closed form has the least pose residual: ``(offset, X, Y)``."""
    # the search needs the offset, not precision: at most GRID_POSES poses spread over the recording
    few = np.unique(np.linspace(0, len(B) - 1, min(GRID_POSES, len(B))).round().astype(int))
    best = None
    for dt in grid:
        A = robot_side_poses(stream.at(t_cam[few] + dt)[0], setup)
        try:
            X, Y = initial_estimate(A, B[few], method)
        except (DegenerateMotionError, np.linalg.LinAlgError):
            continue
        cost = float(np.sum(pose_error_m(A, B[few], X, Y) ** 2))
        if best is None or cost < best[0]:
            best = (cost, dt, X, Y)
    if best is None:
        raise DegenerateMotionError(
            "no offset in the searched range gives a closed-form solution: more rotation "
            "between the camera poses is needed"
        )
    return best[1:]


def _diagnostics(ref, grid, used, loss: str) -> dict:
    """The offset found, its sigma and the search's step, and the refinement's record."""
    return {
        "time_offset": {
            "value_s": ref.time_offset_s,
            "sigma_s": ref.time_offset_sigma_s,
            "grid_step_s": float(grid[1] - grid[0]) if len(grid) > 1 else 0.0,
            "poses_used": [int(i) for i in used],
        },
        "noise_model": ref.noise_model,
        "refinement": {
            "loss": loss,
            "iterations": ref.iterations,
            "converged": ref.converged,
            "cost_initial": ref.cost_initial,
            "cost_final": ref.cost_final,
            "variance_factor": ref.variance_factor,
        },
    }
