"""Markerless calibration: the camera pose from the robot's own surface in depth images (numpy, scipy).

:func:`register_robot` takes one camera placement's depth frames, the
intrinsics and the robot's surface posed at every frame (points and normals
in the base frame, made by :mod:`handeye.robot.surface` from a URDF and the recorded
joints) and returns ``T_base_cam`` with its sigma, or a refusal with the
reason. The front (:mod:`handeye.markerless`, ``handeye markerless``)
composes it with the robot model and the learned start.
"""

from classic.markerless.depth import backproject, moving_mask, static_depth
from classic.markerless.point_to_plane import MatchedModel, PlaneFit, PlaneFitOptions, solve_point_to_plane
from classic.markerless.register import (
    MarkerlessOptions,
    MarkerlessResult,
    RefusedError,
    RobotSurfaceFrames,
    register_robot,
)
from classic.markerless.visibility import visible_points

__all__ = [
    "register_robot",
    "RobotSurfaceFrames",
    "MarkerlessOptions",
    "MarkerlessResult",
    "RefusedError",
    "solve_point_to_plane",
    "PlaneFitOptions",
    "MatchedModel",
    "PlaneFit",
    "backproject",
    "static_depth",
    "moving_mask",
    "visible_points",
]
