"""Classic hand-eye solvers: AX=XB, AX=YB, refinement, robust fitting, diagnostics.

Needs only numpy and scipy: ``import classic`` works without torch, pinocchio
or pyrender. Conventions (frames ``T_a_b``, metres, quaternions x, y, z, w):
see :mod:`handeye`.

Plain solvers
    AX=XB on motion pairs ``A, B`` of shape ``(K, 4, 4)`` (build them with
    :func:`motion_pairs`): :func:`tsai`, :func:`park`, :func:`horaud`,
    :func:`andreff`, :func:`daniilidis` return ``X``.
    AX=YB on absolute poses ``A_i X = Y B_i``: :func:`shah`, :func:`li` return
    ``(X, Y)``. Each registers itself by name in :mod:`classic.registry`, which
    describes the parameters they share; :func:`calibrate`'s ``method`` reads it.

Front
    :func:`calibrate` takes ``T_base_ee`` and ``T_cam_target`` for either
    setup and returns a :class:`CalibrationResult` with the estimate by frame
    name, residuals, covariance and diagnostics. The refinement is maximum
    likelihood under a :class:`NoiseModel` (camera and robot noise, anisotropic,
    joint noise through :func:`joint_noise_covariance`); the settings few calls
    change are a :class:`CalibrateOptions` (``estimate_scale=True`` adds a metric
    scale of the camera translations). :func:`calibrate_stream`
    takes a robot pose stream and camera poses at other times and also
    estimates the time offset between them.

Example
-------
>>> import classic
>>> from handeye.core.synthetic import make_problem
>>> p = make_problem(12, "eye_in_hand")
>>> res = classic.calibrate(p.T_base_ee, p.T_cam_target, setup="eye_in_hand", method="tsai")
>>> res.T_ee_cam.shape
(4, 4)
"""

from classic.andreff import andreff
from classic.calibrate import (
    AXXB_METHODS,
    AXYB_METHODS,
    DEFAULT_METHOD,
    METHODS,
    CalibrateOptions,
    calibrate,
    initial_estimate,
    solve,
)
from classic.daniilidis import daniilidis
from classic.diagnostics import MotionDiagnostics, check_consistency, diagnose_motion
from classic.horaud import horaud
from classic.li import li
from classic.noise_model import NoiseModel, joint_noise_covariance
from classic.pairs import motion_pairs, pair_indices
from classic.park import park
from classic.planning import PlanOptions, PosePlan, plan_poses
from classic.ransac import lmeds_inliers
from classic.refine import RefineOptions, cramer_rao_bound, refine_xy
from classic.result import CalibrationResult, PoseResiduals
from classic.robot_stream import RobotStream
from classic.shah import shah
from classic.time_offset import StreamOptions, calibrate_stream
from classic.tsai import tsai

__all__ = [
    "tsai",
    "park",
    "horaud",
    "andreff",
    "daniilidis",
    "shah",
    "li",
    "calibrate",
    "CalibrateOptions",
    "calibrate_stream",
    "StreamOptions",
    "solve",
    "NoiseModel",
    "joint_noise_covariance",
    "RobotStream",
    "initial_estimate",
    "motion_pairs",
    "pair_indices",
    "refine_xy",
    "RefineOptions",
    "cramer_rao_bound",
    "plan_poses",
    "PlanOptions",
    "PosePlan",
    "lmeds_inliers",
    "diagnose_motion",
    "check_consistency",
    "CalibrationResult",
    "PoseResiduals",
    "MotionDiagnostics",
    "METHODS",
    "AXXB_METHODS",
    "AXYB_METHODS",
    "DEFAULT_METHOD",
]
