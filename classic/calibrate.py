"""The front: ``calibrate(T_base_ee, T_cam_target, setup, method)`` for both setups."""

from __future__ import annotations

import numpy as np

from classic.andreff import _andreff_finish, _andreff_stats
from classic.daniilidis import _daniilidis_finish, _daniilidis_stats
from classic.diagnostics import check_consistency, diagnose_motion
from classic.horaud import _horaud_finish, _horaud_stats
from classic.li import _li
from classic.motions import accumulate, iter_motions
from classic.pairs import PAIRINGS, pair_indices
from classic.park import _park_finish, _park_stats
from classic.ransac import lmeds_inliers
from classic.refine import LOSSES, refine_xy
from classic.residuals import estimate_target_pose, pose_residuals
from classic.result import CalibrationResult, PoseResiduals
from classic.shah import _shah
from classic.tsai import _tsai_finish, _tsai_stats
from handeye.core.errors import HandEyeInputError, TooFewPosesError
from handeye.core.setups import normalize_setup, robot_side_poses
from handeye.core.validation import MIN_POSES, check_no_duplicates, check_paired, check_transforms, check_units_metres

__all__ = ["AXXB_METHODS", "AXYB_METHODS", "METHODS", "DEFAULT_METHOD", "calibrate", "initial_estimate", "solve"]

#: AX=XB methods as (statistics of a chunk of motions, solve from the summed statistics).
AXXB_METHODS = {
    "tsai": (_tsai_stats, _tsai_finish),
    "park": (_park_stats, _park_finish),
    "horaud": (_horaud_stats, _horaud_finish),
    "andreff": (_andreff_stats, _andreff_finish),
    "daniilidis": (_daniilidis_stats, _daniilidis_finish),
}
AXYB_METHODS = {"shah": _shah, "li": _li}
METHODS = tuple(AXXB_METHODS) + tuple(AXYB_METHODS)
#: Closed form used to start the refinement by default (see the benchmark in the README).
DEFAULT_METHOD = "park"


def initial_estimate(A: np.ndarray, B: np.ndarray, method: str, pairs: str = "all") -> tuple[np.ndarray, np.ndarray]:
    """Closed-form ``(X, Y)`` of ``A_i Y = X B_i`` by a named method.

    Parameters
    ----------
    A : array, shape (N, 4, 4)
        Robot-side poses (:func:`handeye.core.setups.robot_side_poses`).
    B : array, shape (N, 4, 4)
        ``T_cam_target``.
    method : str
        One of :data:`METHODS`.
    pairs : {"all", "consecutive"}
        Motion pairs for the AX=XB methods.

    Returns
    -------
    X, Y : array, shape (4, 4)
        Camera pose and target pose.
    """
    if method in AXXB_METHODS:
        stats, finish = AXXB_METHODS[method]
        X = finish(accumulate(stats, iter_motions(A, B, *pair_indices(len(A), pairs))))
        return X, estimate_target_pose(A, B, X)
    if method in AXYB_METHODS:
        Y_target, X_cam = AXYB_METHODS[method](A, B)
        return X_cam, Y_target
    raise HandEyeInputError(f"unknown method {method!r}: use one of {', '.join(METHODS)}")


def _validated(T_base_ee, T_cam_target):
    names = ("T_base_ee", "T_cam_target")
    T_base_ee = check_transforms(T_base_ee, names[0])
    T_cam_target = check_transforms(T_cam_target, names[1])
    check_paired(T_base_ee, T_cam_target, names)
    check_units_metres(T_base_ee, names[0])
    check_units_metres(T_cam_target, names[1])
    check_no_duplicates(T_base_ee, T_cam_target, names)
    return T_base_ee, T_cam_target


def solve(
    T_base_ee: np.ndarray, T_cam_target: np.ndarray, setup: str = "eye_to_hand", method: str = DEFAULT_METHOD,
    pairs: str = "all",
) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form hand-eye solution from absolute poses: the analogue of ``cv2.calibrateHandEye``.

    Validates the input like :func:`calibrate`, then runs one closed form;
    no consistency or motion checks, no refinement, no covariance. Use
    :func:`calibrate` unless you need the bare speed.

    Parameters
    ----------
    T_base_ee : array, shape (N, 4, 4)
    T_cam_target : array, shape (N, 4, 4)
    setup : {"eye_to_hand", "eye_in_hand"}
    method : str
        One of :data:`METHODS`.
    pairs : {"all", "consecutive"}

    Returns
    -------
    X, Y : array, shape (4, 4)
        ``(T_base_cam, T_ee_target)`` eye-to-hand, ``(T_ee_cam, T_base_target)`` eye-in-hand.
    """
    setup = normalize_setup(setup)
    if pairs not in PAIRINGS:
        raise HandEyeInputError(f"unknown pairs {pairs!r}: use one of {PAIRINGS}")
    T_base_ee, T_cam_target = _validated(T_base_ee, T_cam_target)
    return initial_estimate(robot_side_poses(T_base_ee, setup), T_cam_target, method, pairs)


def calibrate(
    T_base_ee: np.ndarray,
    T_cam_target: np.ndarray,
    setup: str = "eye_to_hand",
    method: str = DEFAULT_METHOD,
    pairs: str = "all",
    refine: bool = True,
    robust: bool = False,
    loss: str | None = None,
    noise: tuple[float, float] | None = None,
    check: bool = True,
    rng: np.random.Generator | None = None,
) -> CalibrationResult:
    """Hand-eye calibration from paired robot and target poses.

    Eye-to-hand (static camera, target on the flange) estimates
    ``X = T_base_cam`` and ``Y = T_ee_target``; eye-in-hand (camera on the
    flange, static target) ``X = T_ee_cam`` and ``Y = T_base_target``. Both
    satisfy ``A_i Y = X B_i`` (:mod:`handeye.core.setups`).

    Steps: validate the input (raises a :class:`ValueError` subclass naming the
    pose); check that robot and camera motions are consistent and that the
    rotations determine X (raises on degenerate motion, warns on weak motion);
    optionally flag gross outliers by least-median sampling; solve in closed
    form by ``method``; refine X and Y jointly by Levenberg-Marquardt on the
    pose residuals; report per-pose residuals and the covariance.

    Parameters
    ----------
    T_base_ee : array, shape (N, 4, 4)
        Robot flange poses in the base frame, metres.
    T_cam_target : array, shape (N, 4, 4)
        Target (board) poses in the camera's optical frame, metres.
    setup : {"eye_to_hand", "eye_in_hand"}
    method : str
        Closed form: ``tsai``, ``park`` (default), ``horaud``, ``andreff``,
        ``daniilidis`` (AX=XB on motion pairs) or ``shah``, ``li`` (AX=YB on poses).
    pairs : {"all", "consecutive"}
        Motion pairs for the AX=XB methods.
    refine : bool
        Refine by Levenberg-Marquardt (default). Without it the closed form is
        returned and the covariance is evaluated at it.
    robust : bool
        Flag gross outliers by least-median sampling, fit on the inliers, and
        refine with a Cauchy loss (unless ``loss`` says otherwise).
    loss : {"linear", "huber", "cauchy"}, optional
        Loss of the refinement; default ``linear``, or ``cauchy`` when robust.
    noise : (float, float), optional
        Per-axis camera noise ``(rad, m)``; estimated from the residuals when omitted.
    check : bool
        Run the consistency and motion checks (default). Turn off only for
        data you have checked otherwise.
    rng : numpy.random.Generator, optional
        For the robust sampling; default seeded, so results are reproducible.

    Returns
    -------
    CalibrationResult

    Raises
    ------
    ShapeError, NonFiniteError, NotARotationError, LengthMismatchError,
    TooFewPosesError, DuplicatePoseError, UnitsError, InconsistentPosesError,
    DegenerateMotionError
        All subclasses of :class:`ValueError`.

    Examples
    --------
    >>> from handeye.core.synthetic import make_problem
    >>> p = make_problem(15, "eye_to_hand")
    >>> res = calibrate(p.T_base_ee, p.T_cam_target, setup="eye_to_hand")
    >>> bool(abs(res.T_base_cam - p.X_true).max() < 1e-9)
    True
    """
    setup = normalize_setup(setup)
    if pairs not in PAIRINGS:
        raise HandEyeInputError(f"unknown pairs {pairs!r}: use one of {PAIRINGS}")
    if method not in METHODS:
        raise HandEyeInputError(f"unknown method {method!r}: use one of {', '.join(METHODS)}")
    loss = loss or ("cauchy" if robust else "linear")
    if loss not in LOSSES:
        raise HandEyeInputError(f"unknown loss {loss!r}: use one of {LOSSES}")
    T_base_ee, T_cam_target = _validated(T_base_ee, T_cam_target)
    diagnostics: dict = {}
    A = robot_side_poses(T_base_ee, setup)
    B = T_cam_target
    inliers = np.ones(len(A), dtype=bool)
    if robust:
        found = lmeds_inliers(A, B, rng)
        inliers = found.inliers
        if inliers.sum() < MIN_POSES:
            raise TooFewPosesError(
                f"only {int(inliers.sum())} of {len(A)} poses agree with each other after outlier rejection; "
                f"at least {MIN_POSES} are needed. Check the pairing of robot and camera poses."
            )
        diagnostics["outliers"] = [int(i) for i in np.flatnonzero(~inliers)]
        diagnostics["lmeds_median_residual_mm"] = 1000 * found.median_residual_m
    # motion first: on degenerate motion a closed-form fit is ill-posed, and the fit-based consistency test
    # would blame the pairing for what is a lack of rotation
    motion = diagnose_motion(T_base_ee[inliers], T_cam_target[inliers], setup, pairs, raise_on_degenerate=check)
    if check:
        diagnostics["consistency"] = check_consistency(T_base_ee[inliers], T_cam_target[inliers], setup, pairs)
    diagnostics["motion"] = motion.to_dict()

    X, Y = initial_estimate(A[inliers], B[inliers], method, pairs)
    name = ("ransac+" if robust else "") + method
    ref = refine_xy(A[inliers], B[inliers], X, Y, loss=loss, noise=noise, max_iterations=50 if refine else 0)
    if refine:
        X, Y = ref.X, ref.Y
        name += "+lm"
    diagnostics["noise_estimate"] = {
        "rotation_deg": float(np.degrees(ref.sigma_rot_rad)),
        "translation_mm": 1000 * ref.sigma_trans_m,
        "given": noise is not None,
    }
    diagnostics["refinement"] = {
        "loss": loss,
        "iterations": ref.iterations,
        "converged": bool(ref.converged),
        "cost_initial": ref.cost_initial,
        "cost_final": ref.cost_final,
    }
    r_rot, r_trans = pose_residuals(A, B, X, Y)
    residuals = PoseResiduals(
        rotation_deg=np.degrees(np.linalg.norm(r_rot, axis=1)),
        translation_mm=1000 * np.linalg.norm(r_trans, axis=1),
        inliers=inliers,
    )
    return CalibrationResult(setup, name, X, Y, residuals, ref.covariance, diagnostics)
