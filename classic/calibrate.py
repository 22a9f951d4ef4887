"""The front: ``calibrate(T_base_ee, T_cam_target, setup, method)`` for both setups.

The outlier policy of :func:`calibrate`: every pose is tested against a fit without it
(:mod:`classic.outlier_screen`: a clean set has a pose named with probability at most
:data:`classic.outlier_screen.OUTLIER_ALPHA`, 0.1 %, whatever its size). When the named poses move a
non-robust fit by more than :data:`classic.outlier_screen.ACCEPT_SHIFT_SIGMA` (2) of its sigma, the set is
refused (:class:`handeye.core.errors.ContaminatedPosesError`, naming them) if one is gross
(:data:`classic.outlier_screen.GROSS_FACTOR`, 6, times its bound), else the fit without them is returned; within
2 sigma the fit with them is returned, its covariance widened to reach the fit without them. They are always
named (a :class:`handeye.core.errors.SuspectPosesWarning` and ``diagnostics["suspect_poses"]``). With
``robust=True`` the candidates come from least-median sampling and a Cauchy fit, each is confirmed by an F test
against a least-squares fit without it, and least squares on the rest is returned.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass
from functools import cached_property

import numpy as np

# each solver module registers its closed form in classic.registry at import
import classic.andreff  # noqa: F401
import classic.daniilidis  # noqa: F401
import classic.horaud  # noqa: F401
import classic.li  # noqa: F401
import classic.park  # noqa: F401
import classic.shah  # noqa: F401
import classic.tsai  # noqa: F401
from classic.contamination import (
    MAX_SHIFT_SIGMA,
    check_contamination,
    pair_consensus_suspects,
    refuse_shift,
    x_shift_sigma,
)
from classic.diagnostics import check_consistency, diagnose_motion
from classic.motions import Motions, accumulate, iter_motions, motions_from_poses
from classic.noise_model import NoiseModel, as_noise_model
from classic.outlier_screen import (
    ACCEPT_SHIFT_SIGMA,
    GROSS_FACTOR,
    Screening,
    fit_shift_sigma,
    screen_poses,
    shift_vector,
)
from classic.pairs import PAIRINGS, describe_pairs, pair_indices
from classic.ransac import lmeds_inliers
from classic.refine import LOSSES, RefineOptions, refine_xy
from classic.registry import solver, solvers
from classic.residuals import estimate_target_pose, pose_residuals
from classic.result import CalibrationResult, PoseResiduals
from classic.starts import START_CANDIDATES, best_start, scaled_start
from handeye.core.errors import (
    ContaminatedPosesError,
    DegenerateMotionError,
    HandEyeInputError,
    InconsistentPosesError,
    SuspectPosesWarning,
    TooFewPosesError,
)
from handeye.core.setups import normalize_setup, robot_side_poses
from handeye.core.validation import (
    MIN_POSES,
    check_no_duplicates,
    check_paired,
    check_target_distance,
    check_transforms,
    check_units_metres,
)

__all__ = [
    "AXXB_METHODS",
    "AXYB_METHODS",
    "METHODS",
    "DEFAULT_METHOD",
    "calibrate",
    "CalibrateOptions",
    "initial_estimate",
    "solve",
]

#: AX=XB methods as (statistics of a chunk of motions, solve from the summed statistics), from
#: :mod:`classic.registry`.
AXXB_METHODS = {s.name: (s.stats, s.finish) for s in solvers("AX=XB")}
#: AX=YB methods: ``(A, B) -> (X, Y)`` on validated poses, from :mod:`classic.registry`.
AXYB_METHODS = {s.name: s.solve for s in solvers("AX=YB")}
#: ``auto``: the best of :data:`classic.starts.START_CANDIDATES` (Park and Shah) by pose residual.
METHODS = ("auto",) + tuple(AXXB_METHODS) + tuple(AXYB_METHODS)
#: Closed form used to start the refinement by default (see the benchmark in the README).
DEFAULT_METHOD = "auto"


def initial_estimate(
    A: np.ndarray, B: np.ndarray, method: str, pairs: str = "all", motions=None
) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form ``(X, Y)`` of ``A_i Y = X B_i`` by a named method.

    Parameters
    ----------
    A : array, shape (N, 4, 4)
        Robot-side poses (:func:`handeye.core.setups.robot_side_poses`).
    B : array, shape (N, 4, 4)
        ``T_cam_target``.
    method : str
        One of :data:`METHODS`; ``auto`` picks the candidate with the lowest pose residual.
    pairs : {"all", "consecutive"}
        Motion pairs for the AX=XB methods.
    motions : classic.motions.Motions, optional
        Those pairs' motions when already computed.

    Returns
    -------
    X, Y : array, shape (4, 4)
        Camera pose and target pose.
    """
    if method == "auto":
        _, X, Y = best_start(A, B, lambda a, b, m: initial_estimate(a, b, m, pairs, motions), START_CANDIDATES)
        return X, Y
    if method not in METHODS:
        raise HandEyeInputError(f"unknown method {method!r}: use one of {', '.join(METHODS)}")
    entry = solver(method)
    if entry.kind == "AX=XB":
        chunks = [motions] if motions is not None else iter_motions(A, B, *pair_indices(len(A), pairs))
        X = entry.finish(accumulate(entry.stats, chunks))
        return X, estimate_target_pose(A, B, X)
    Y_target, X_cam = entry.solve(A, B)
    return X_cam, Y_target


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
    T_base_ee: np.ndarray,
    T_cam_target: np.ndarray,
    setup: str = "eye_to_hand",
    method: str = DEFAULT_METHOD,
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
    check_target_distance(T_cam_target)
    return initial_estimate(robot_side_poses(T_base_ee, setup), T_cam_target, method, pairs)


def _check_pair_consensus(poses, X, model) -> None:
    """Refuse when poses that break the motion pairs' invariants move the least-squares X by several sigma."""
    A, B = poses.A_in, poses.B_in
    suspects = pair_consensus_suspects(A, B, poses.pairs, poses.built_motions() if poses.pairs == "all" else None)
    keep = np.ones(len(A), dtype=bool)
    keep[suspects] = False
    if len(suspects) == 0 or keep.sum() < MIN_POSES:
        return
    numbers = np.flatnonzero(poses.inliers)[suspects]  # as the caller numbers them: the screen may have left some out
    X0, Y0 = best_start(A[keep], B[keep], initial_estimate, START_CANDIDATES)[1:]
    try:
        clean = refine_xy(A[keep], B[keep], X0, Y0, RefineOptions(noise=_subset_model(model, keep), setup=poses.setup))
    except DegenerateMotionError as err:
        why = "suspected by the pair consensus check (breaking the motion pairs' invariants)"
        raise _resting_on(err, numbers, why) from None
    shift = x_shift_sigma(X, clean.X, clean.covariance)
    if shift > MAX_SHIFT_SIGMA:
        refuse_shift(numbers, shift, len(A))


def _consensus_model(model, ref) -> NoiseModel:
    """The noise model of the consensus check's refit: the caller's, or the fit's own estimate up to one factor.

    With the noise estimated, a refit on fewer poses could settle on another shape (isotropic against
    across and along the line of sight) and the shift between the two fits would then measure the
    difference of their weightings, not of their poses; the estimated shape, rescaled to the refit's
    residuals, keeps the two comparable.
    """
    if model is not None:
        return model
    return dataclasses.replace(ref.model, name=f"{ref.model.name}, shape of the full fit", scale_to_residuals=True)


def _subset_model(model, keep):
    return None if model is None else model.subset(keep)


@dataclass(frozen=True, kw_only=True)
class CalibrateOptions:
    """The settings of :func:`calibrate` that few calls change (the defaults are its own).

    Attributes
    ----------
    pairs : {"all", "consecutive"}
        Motion pairs for the AX=XB methods.
    refine : bool
        Refine (default). Without it the closed form is returned and the covariance is evaluated at it.
    loss : {"linear", "huber", "cauchy"}, optional
        Loss of the refinement; default ``linear``, or ``cauchy`` when robust.
    check : bool
        Run the consistency, motion and contamination checks (default). Turn off only for data you have checked
        otherwise.
    rng : numpy.random.Generator, optional
        For the robust sampling; default seeded, so results are reproducible.
    estimate_scale : bool
        Also estimate a metric scale ``s`` of the camera translations (monocular SLAM), ``t_cam_target <- s
        t_cam_target``, from :func:`classic.starts.scaled_start`; ``s`` and its sigma are in ``diagnostics["scale"]``.
    """

    pairs: str = "all"
    refine: bool = True
    loss: str | None = None
    check: bool = True
    rng: np.random.Generator | None = None
    estimate_scale: bool = False


def calibrate(
    T_base_ee: np.ndarray,
    T_cam_target: np.ndarray,
    setup: str = "eye_to_hand",
    method: str = DEFAULT_METHOD,
    *,
    robust: bool = False,
    noise: tuple[float, float] | NoiseModel | None = None,
    options: CalibrateOptions | None = None,
) -> CalibrationResult:
    """Hand-eye calibration from paired robot and target poses.

    Eye-to-hand (static camera, target on the flange) estimates ``X = T_base_cam`` and ``Y = T_ee_target``;
    eye-in-hand (camera on the flange, static target) ``X = T_ee_cam`` and ``Y = T_base_target``. Both satisfy
    ``A_i Y = X B_i`` (:mod:`handeye.core.setups`).

    Steps: validate the input (raises a :class:`ValueError` subclass naming the pose); check that robot and
    camera motions are consistent and that the rotations determine X (raises on degenerate motion, warns on weak
    motion); optionally flag gross outliers by least-median sampling; solve in closed form by ``method`` (by
    default the better of Park and Shah); refine X and Y jointly by maximum likelihood under the noise model
    (:mod:`classic.refine`); test every pose against a fit without it and name, leave out or refuse the poses
    beyond the bound (the outlier policy: this module's docstring); report per-pose residuals and the covariance.

    Parameters
    ----------
    T_base_ee : array, shape (N, 4, 4)
        Robot flange poses in the base frame, metres.
    T_cam_target : array, shape (N, 4, 4)
        Target (board) poses in the camera's optical frame, metres.
    setup : {"eye_to_hand", "eye_in_hand"}
    method : str
        Closed form: ``auto`` (default: the better of ``park`` and ``shah``), ``tsai``, ``park``, ``horaud``,
        ``andreff``, ``daniilidis`` (AX=XB on motion pairs) or ``shah``, ``li`` (AX=YB on poses).
    robust : bool
        Leave out the poses the outlier test names (a clean set loses one with probability at most 0.1 % whatever
        its size) and return least squares on the rest. Without it (and with a linear ``options.loss``), a set
        whose named poses move the answer by more than 2 sigma is refused (:class:`ContaminatedPosesError`,
        naming them) when one of them is gross, and fitted without them otherwise.
    noise : (float, float) or NoiseModel, optional
        Per-axis camera noise ``(rad, m)``, or a :class:`classic.noise_model.NoiseModel` with camera and robot
        noise (anisotropic, per pose, joint noise through the robot's Jacobian); default: camera-only, the scales
        estimated from the residuals (rotation; translation, split across and along the line of sight when the
        residuals say they differ).
    options : CalibrateOptions, optional
        The motion pairs, the refinement on or off, its loss, the checks, the robust sampling's generator and a
        metric scale of the camera translations; None: :class:`CalibrateOptions`' defaults.

    Returns
    -------
    CalibrationResult

    Raises
    ------
    ShapeError, NonFiniteError, NotARotationError, LengthMismatchError,
    TooFewPosesError, DuplicatePoseError, UnitsError, InconsistentPosesError,
    DegenerateMotionError, ContaminatedPosesError
        All subclasses of :class:`ValueError`.

    Warns
    -----
    WeakMotionWarning, SuspectPosesWarning

    Examples
    --------
    >>> from handeye.core.synthetic import make_problem
    >>> p = make_problem(15, "eye_to_hand")
    >>> res = calibrate(p.T_base_ee, p.T_cam_target, setup="eye_to_hand")
    >>> bool(abs(res.T_base_cam - p.X_true).max() < 1e-9)
    True
    """
    options = options or CalibrateOptions()
    pairs, refine, check, estimate_scale = options.pairs, options.refine, options.check, options.estimate_scale
    setup, loss = _checked_arguments(setup, method, pairs, options.loss, robust)
    how = _How(method, loss, as_noise_model(noise), refine, robust, check, options.rng, estimate_scale)
    poses = _Poses.validated(T_base_ee, T_cam_target, setup, pairs)
    diagnostics: dict = {}
    poses, held = _checked_poses(poses, how, diagnostics)
    sampled = poses.inliers
    diagnostics["pairs"] = describe_pairs(len(poses.A_in), pairs)
    fit, poses = _refine(poses, _start(poses, how), how, diagnostics)
    if robust:
        _motion_of_final_inliers(poses, sampled, held, diagnostics)
    if check and not robust:
        fit, poses = _screened(poses, fit, how, diagnostics)
    if refine and check and loss == "linear":
        _check_fit(poses, fit.ref, how.model, estimate_scale)
    return _result(poses, fit, how, diagnostics)


# -- the stages of calibrate(), in its order


@dataclass
class _Poses:
    """The validated poses as every stage reads them: the robot side ``A`` and the camera's ``B`` of all poses,
    which of them are inliers, and the inliers' motion pairs, built once when a stage first asks for them."""

    setup: str
    pairs: str
    T_base_ee: np.ndarray
    B: np.ndarray
    A: np.ndarray
    inliers: np.ndarray

    @classmethod
    def validated(cls, T_base_ee, T_cam_target, setup, pairs) -> "_Poses":
        T_base_ee, T_cam_target = _validated(T_base_ee, T_cam_target)
        A = robot_side_poses(T_base_ee, setup)
        return cls(setup, pairs, T_base_ee, T_cam_target, A, np.ones(len(A), dtype=bool))

    def keeping(self, inliers: np.ndarray) -> "_Poses":
        """The same poses with other inliers (their motions built afresh when asked for)."""
        return _Poses(self.setup, self.pairs, self.T_base_ee, self.B, self.A, inliers)

    @cached_property
    def A_in(self) -> np.ndarray:
        return self.A[self.inliers]

    @cached_property
    def B_in(self) -> np.ndarray:
        return self.B[self.inliers]

    @cached_property
    def motions(self) -> Motions:
        """The inliers' motion pairs (``pairs``): for the motion and consistency checks, the start, the pair
        consensus."""
        return motions_from_poses(self.A_in, self.B_in, *pair_indices(len(self.A_in), self.pairs))

    def built_motions(self) -> Motions | None:
        """:attr:`motions` if a stage has built them, else None (the caller builds only what it needs)."""
        return self.__dict__.get("motions")


@dataclass(frozen=True)
class _How:
    """:func:`calibrate`'s choices as the stages read them (``setup`` and ``pairs`` travel with the poses)."""

    method: str
    loss: str
    model: NoiseModel | None
    refine: bool
    robust: bool
    check: bool
    rng: np.random.Generator | None
    estimate_scale: bool


@dataclass(frozen=True)
class _Fit:
    """The answer as the stages hand it on: ``X``, ``Y``, the method's name, the start's scale and the
    refinement (evaluated at the start without ``refine``; None before it)."""

    X: np.ndarray
    Y: np.ndarray
    name: str
    scale0: float = 1.0
    ref: object = None

    def refined(self, ref, how: _How) -> "_Fit":
        """This fit with the refinement ``ref``: its ``X`` and ``Y`` (and the refinement named) when ``refine``."""
        if not how.refine:
            return dataclasses.replace(self, ref=ref)
        suffix = "+ml" if how.model is not None and how.model.has_robot_noise else "+lm"
        return dataclasses.replace(self, X=ref.X, Y=ref.Y, name=self.name + suffix, ref=ref)


def _checked_arguments(setup, method, pairs, loss, robust) -> tuple[str, str]:
    """The setup's canonical name and the loss (``cauchy`` when robust unless given); unknown names raise."""
    setup = normalize_setup(setup)
    if pairs not in PAIRINGS:
        raise HandEyeInputError(f"unknown pairs {pairs!r}: use one of {PAIRINGS}")
    if method not in METHODS:
        raise HandEyeInputError(f"unknown method {method!r}: use one of {', '.join(METHODS)}")
    loss = loss or ("cauchy" if robust else "linear")
    if loss not in LOSSES:
        raise HandEyeInputError(f"unknown loss {loss!r}: use one of {LOSSES}")
    return setup, loss


def _checked_poses(poses: _Poses, how: _How, diagnostics: dict) -> tuple[_Poses, list]:
    """The checks before any fit: the target's distance; robust, the gross outliers left out and the motion
    checked, its warnings held; else the motion and consistency checks, an inconsistent set refused naming
    its outliers when they are what makes it so. Returns the poses and the held warnings."""
    if not how.estimate_scale:  # a scale-free camera (monocular SLAM) may have any distance
        check_target_distance(poses.B)
    if how.robust:
        poses = _reject_outliers(poses, how.rng, diagnostics)
        return poses, _check_motion_held(poses, how.check, how.estimate_scale, diagnostics)
    try:
        _check_motion(poses, how.check, how.estimate_scale, diagnostics)
    except InconsistentPosesError as err:
        _refuse_named_behind(err, poses, how.model, how.rng, how.estimate_scale)
    return poses, []


def _reject_outliers(poses: _Poses, rng, diagnostics: dict) -> _Poses:
    """Gross outliers flagged by least-median sampling over pose triples (:func:`classic.ransac.lmeds_inliers`)."""
    found = lmeds_inliers(poses.A, poses.B, rng)
    inliers = found.inliers
    if inliers.sum() < MIN_POSES:
        raise TooFewPosesError(
            f"only {int(inliers.sum())} of {len(poses.A)} poses agree with each other after outlier rejection; "
            f"at least {MIN_POSES} are needed. Check the pairing of robot and camera poses."
        )
    diagnostics["outliers"] = [int(i) for i in np.flatnonzero(~inliers)]
    diagnostics["lmeds_median_residual_mm"] = 1000 * found.median_residual_m
    return poses.keeping(inliers)


def _check_motion(poses: _Poses, check: bool, estimate_scale: bool, diagnostics: dict) -> None:
    """Whether the rotations determine X (refused when degenerate and ``check``) and whether the robot's and
    the camera's motions agree (refused when not).

    Motion first: on degenerate motion a closed-form fit is ill-posed, and the fit-based consistency test
    would blame the pairing for what is a lack of rotation.
    """
    T_base_ee, T_cam_target = poses.T_base_ee[poses.inliers], poses.B_in
    # the warnings point at calibrate()'s caller: this stage, _checked_poses and calibrate() lie between
    motion = diagnose_motion(
        T_base_ee,
        T_cam_target,
        poses.setup,
        poses.pairs,
        raise_on_degenerate=check,
        motions=poses.motions,
        stacklevel=5,
    )
    if check and not estimate_scale:  # the consistency fit assumes metric camera poses
        diagnostics["consistency"] = check_consistency(
            T_base_ee, T_cam_target, poses.setup, poses.pairs, motions=poses.motions
        )
    diagnostics["motion"] = motion.to_dict()


def _check_motion_held(poses: _Poses, check: bool, estimate_scale: bool, diagnostics: dict) -> list:
    """Robust: :func:`_check_motion` of the sampling's inliers, its warnings held until the final inliers are
    known (the sampling's cut is generous: "only 5 poses" may not hold of the final fit)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _check_motion(poses, check, estimate_scale, diagnostics)
    return caught


def _motion_of_final_inliers(poses: _Poses, sampled: np.ndarray, held: list, diagnostics: dict) -> None:
    """The held motion warnings when the final inliers are the sampling's, else the final inliers' motion."""
    if np.array_equal(poses.inliers, sampled):
        for w in held:
            warnings.warn(w.message, w.category, stacklevel=3)
        return
    motion = diagnose_motion(
        poses.T_base_ee[poses.inliers], poses.B_in, poses.setup, poses.pairs, raise_on_degenerate=False, stacklevel=4
    )
    diagnostics["motion"] = motion.to_dict()


def _start(poses: _Poses, how: _How) -> _Fit:
    """The closed form the refinement starts from (named ``ransac+...`` when robust)."""
    A, B, pairs = poses.A_in, poses.B_in, poses.pairs
    sampled = "ransac+" if how.robust else ""
    if how.estimate_scale:
        X, Y, scale0 = scaled_start(A, B, pairs)
        return _Fit(X, Y, sampled + "park+scale", scale0)
    if how.method == "auto":
        solve = lambda a, b, m: initial_estimate(a, b, m, pairs, poses.motions)  # noqa: E731
        start, X, Y = best_start(A, B, solve, START_CANDIDATES)
        return _Fit(X, Y, f"{sampled}auto({start})")
    X, Y = initial_estimate(A, B, how.method, pairs, poses.motions)
    return _Fit(X, Y, sampled + how.method)


def _refine(poses: _Poses, start: _Fit, how: _How, diagnostics: dict) -> tuple[_Fit, _Poses]:
    """The maximum-likelihood refinement (:func:`classic.refine.refine_xy`; evaluated at the start only
    without ``refine``); robust, the robust loss's fit on the sampling's inliers starts the outlier test
    (:func:`classic.outlier_screen.screen_poses`) and the poses it does not name are refit by least
    squares. Returns the fit and the poses with their final inliers."""
    options = RefineOptions(
        loss=how.loss,
        noise=_subset_model(how.model, poses.inliers),
        max_iterations=50 if how.refine else 0,
        setup=poses.setup,
        estimate_scale=how.estimate_scale and how.refine,
        scale0=start.scale0,
        undetermined="refuse" if how.check else "infinite",  # checks off: an undetermined sigma reads inf
    )
    ref = refine_xy(poses.A_in, poses.B_in, start.X, start.Y, options)
    if not (how.refine and how.robust):
        return start.refined(ref, how), poses
    # the sampling's flags are a generous first cut (three times the median residual): each pose is tested
    # against a least-squares fit without it, and only the named ones stay out
    screening = screen_poses(poses.A, poses.B, ref, poses.setup, model=how.model, estimate_scale=how.estimate_scale)
    inliers = np.ones(len(poses.A), dtype=bool)
    inliers[screening.outliers] = False
    diagnostics["outliers"] = [int(i) for i in np.flatnonzero(~inliers)]
    _record_screening(screening, diagnostics)
    return start.refined(screening.reference, how), poses.keeping(inliers)


def _screened(poses: _Poses, fit: _Fit, how: _How, diagnostics: dict) -> tuple[_Fit, _Poses]:
    """A non-robust fit's outlier test: every pose judged against a fit without it (least squares must not
    hide an outlier; a robust loss is told which poses it had to discount), then :func:`_name_or_refuse`."""
    screening = _screen(poses, fit.ref if how.refine else None, how.model, how.rng, how.estimate_scale)
    ref, poses = _name_or_refuse(screening, fit, poses, diagnostics, act=how.refine and how.loss == "linear")
    if how.refine:
        return dataclasses.replace(fit, X=ref.X, Y=ref.Y, ref=ref), poses
    return dataclasses.replace(fit, ref=ref), poses


def _screen(poses: _Poses, fit_all, model, rng, estimate_scale: bool) -> Screening:
    """The outlier test of a non-robust fit: a fit no single pose pulls off (least-median sampling on all poses,
    then Shah's closed form and least squares on its inliers, which leave the gross outliers out) to find
    candidates, then :func:`classic.outlier_screen.screen_poses`. Least squares, not a Cauchy loss: scipy's
    robust losses take an SVD per step, 0.2 s a step at 200 poses here."""
    found = lmeds_inliers(poses.A, poses.B, rng)
    every = np.ones(len(poses.A), dtype=bool)
    keep = found.inliers if found.inliers.sum() >= MIN_POSES else every
    try:
        robust_fit = _screen_start(poses, keep, model, estimate_scale)
    except DegenerateMotionError:
        # the sampling fits triples of poses; one that turns about a single axis leaves the translation along it
        # free, and the poses that fix it then look like outliers: start from all poses, which the fit determined
        robust_fit = _screen_start(poses, every, model, estimate_scale)
    try:
        return screen_poses(
            poses.A, poses.B, robust_fit, poses.setup, model=model, fit_all=fit_all, estimate_scale=estimate_scale
        )
    except DegenerateMotionError as err:
        raise _resting_on(err, None, "set aside by the outlier test to test them") from None


def _screen_start(poses: _Poses, keep: np.ndarray, model, estimate_scale: bool):
    """Shah's closed form and least squares on the poses ``keep``: the fit :func:`_screen` starts from."""
    A, B = poses.A[keep], poses.B[keep]
    if estimate_scale:
        X0, Y0, scale0 = scaled_start(A, B, poses.pairs)
    else:
        (X0, Y0), scale0 = initial_estimate(A, B, "shah"), 1.0  # on poses: no motion pairs to build
    options = RefineOptions(
        loss="linear", noise=_subset_model(model, keep), setup=poses.setup, estimate_scale=estimate_scale, scale0=scale0
    )
    return refine_xy(A, B, X0, Y0, options)


def _resting_on(err: DegenerateMotionError, named, why: str) -> DegenerateMotionError:
    """A check's refit without some poses found the rest undetermined: the answer along that direction rests on
    poses nothing else checks, so it is refused. The message: which poses (``named``, or None when the check does
    not say), why they were set aside, then ``err``'s (the direction)."""
    which = "the poses " if named is None or len(named) == 0 else _list(named) + ", "
    them = "them" if named is None else _them(named)
    return DegenerateMotionError(
        f"Without {which}{why}, the other poses leave a direction of the answer free, so nothing checks {them}: "
        f"{err} Refused: check {them}, or add poses that turn about other axes."
    )


def _refuse_named_behind(err: InconsistentPosesError, poses: _Poses, model, rng, estimate_scale: bool) -> None:
    """A set refused as inconsistent: when at most a quarter of its poses are named by the outlier test and
    the rest is consistent, refuse naming them (:class:`ContaminatedPosesError`); else re-raise ``err``."""
    screening = _screen(poses, None, model, rng, estimate_scale)
    out = screening.outliers
    n = len(poses.A)
    if not 0 < len(out) <= n // 4:
        raise err
    keep = np.ones(n, dtype=bool)
    keep[out] = False
    try:
        check_consistency(poses.T_base_ee[keep], poses.B[keep], poses.setup, poses.pairs)
    except InconsistentPosesError:
        raise err from None
    raise _naming(
        ContaminatedPosesError(
            f"{'Pose' if len(out) == 1 else 'Poses'} beyond the outlier bound make the set inconsistent "
            f"(alpha {screening.alpha:g} for {n} poses): {_suspects_text(screening)}. Check or remove {_them(out)}, "
            "or use robust=True (CLI: --robust) to fit without."
        ),
        out,
    ) from err


def _naming(error: ContaminatedPosesError, poses) -> ContaminatedPosesError:
    """The error with the named poses' indices as ``error.poses`` (the CLI adds their file rows)."""
    error.poses = [int(k) for k in poses]
    return error


def _them(items, one: str = "it", many: str = "them") -> str:
    return one if len(items) == 1 else many


def _record_screening(screening: Screening, diagnostics: dict) -> None:
    diagnostics["suspect_poses"] = screening.describe()
    diagnostics["outlier_test"] = screening.summary()


def _suspects_text(screening: Screening, most: int = 3) -> str:
    """``pose 3: translation 1799.0 mm / 0.12 deg, 921 sigma (bound 7.1)`` for the first ``most`` named poses."""
    parts = []
    for d in screening.describe()[:most]:
        sigma = max(d["n_sigma_rotation"], d["n_sigma_translation"])
        size = (
            f"translation {d['translation_mm']:.1f} mm / {d['rotation_deg']:.2f} deg"
            if d["block"] == "translation"
            else f"rotation {d['rotation_deg']:.2f} deg / {d['translation_mm']:.1f} mm"
        )
        parts.append(f"pose {d['index']}: {size}, {sigma:.0f} sigma (bound {d['bound_n_sigma']:.1f})")
    more = len(screening.outliers) - len(parts)
    return "; ".join(parts) + (f"; and {more} more" if more > 0 else "")


def _name_or_refuse(screening: Screening, fit: _Fit, poses: _Poses, diagnostics: dict, act: bool):
    """Name the poses beyond the bound, and cover their influence (see :func:`calibrate`).

    With ``act`` (a least-squares fit), when leaving the named poses out moves the answer by more than
    :data:`classic.outlier_screen.ACCEPT_SHIFT_SIGMA` of the fit without them: refuse if one of them is gross
    (:data:`classic.outlier_screen.GROSS_FACTOR` times its bound), else return the fit without them. An answer
    returned with named poses has its covariance widened by ``d d^T``, ``d`` the offset of the fit without them,
    so its sigma covers their influence. Returns the refinement and the poses (their inliers) of the answer."""
    _record_screening(screening, diagnostics)
    ref = fit.ref
    if len(screening.outliers) == 0:
        return ref, poses
    shift = fit_shift_sigma(fit, screening.reference)
    test = diagnostics["outlier_test"]
    test["shift_sigma"] = shift
    out, gross = screening.outliers, screening.gross
    n = len(screening.residual_deg)
    head = (
        f"{'Pose' if len(out) == 1 else 'Poses'} beyond the outlier bound (alpha {screening.alpha:g} for {n} poses): "
        f"{_suspects_text(screening)}. Without {_them(out)} the answer moves by {shift:.1f} sigma"
    )
    big = shift > ACCEPT_SHIFT_SIGMA
    if act and big and len(gross):
        test["action"] = "refused"
        raise _naming(
            ContaminatedPosesError(
                f"{head}, and {_list(gross)} {'is' if len(gross) == 1 else 'are'} beyond {GROSS_FACTOR:g} times the "
                f"bound: refused. Check or remove {_them(out)}, or use robust=True (CLI: --robust) to fit without."
            ),
            out,
        )
    if act and big:
        # not gross: a heavy-tailed clean pose (a grazing PnP view) or a moderate outlier; the fit without them,
        # as robust=True returns it (its sigma covered the truth as often as a clean set's: benchmarks/outliers.py)
        keep = np.ones(len(poses.A), dtype=bool)
        keep[out] = False
        test["action"] = "left out"
        diagnostics["outliers"] = [int(k) for k in out]
        warnings.warn(
            f"{head}, none beyond {GROSS_FACTOR:g} times the bound: returned the fit without {_them(out)}; "
            f"check {_them(out)}.",
            SuspectPosesWarning,
            stacklevel=4,
        )
        return screening.reference, poses.keeping(keep)
    # returned with them: the sigma widened by the offset d of the fit without them (covariance + d d^T)
    test["action"] = "named"
    d = shift_vector(screening.reference, ref)
    widened = dataclasses.replace(ref, covariance=ref.covariance + np.outer(d, d))
    grow = float(np.sqrt(np.max(np.diag(widened.covariance) / np.maximum(np.diag(ref.covariance), 1e-300))))
    test["sigma_widened_by"] = grow
    warnings.warn(
        f"{head}{f' (at most {ACCEPT_SHIFT_SIGMA:g})' if not big else ' (not a least-squares fit: kept)'}: returned "
        f"with {_them(out)}, its sigma widened to cover the fit "
        f"without {_them(out)} (up to {grow:.2f}x); check {_them(out)}.",
        SuspectPosesWarning,
        stacklevel=4,
    )
    return widened, poses


def _list(poses) -> str:
    return ("pose " if len(poses) == 1 else "poses ") + ", ".join(str(int(k)) for k in poses)


def _check_fit(poses: _Poses, ref, model, estimate_scale: bool) -> None:
    """Refuse a least-squares fit that outlier poses pulled off (:mod:`classic.contamination`)."""
    B_fit = poses.B_in.copy()
    B_fit[:, :3, 3] *= ref.scale
    residuals = np.concatenate(pose_residuals(poses.A_in, B_fit, ref.X, ref.Y), axis=1)
    check_contamination(ref.whitened, residuals, ref.jacobian, numbers=np.flatnonzero(poses.inliers))
    if not estimate_scale:
        _check_pair_consensus(poses, ref.X, _consensus_model(_subset_model(model, poses.inliers), ref))


def _result(poses: _Poses, fit: _Fit, how: _How, diagnostics: dict) -> CalibrationResult:
    """The result: the noise estimate, the refinement's record, every pose's residual (outliers too)."""
    ref, X, Y, estimate_scale = fit.ref, fit.X, fit.Y, how.estimate_scale
    diagnostics["noise_estimate"] = {
        "rotation_deg": float(np.degrees(ref.sigma_rot_rad)),
        "translation_mm": 1000 * ref.sigma_trans_m,
        "given": how.model is not None,
    }
    diagnostics["noise_model"] = ref.noise_model
    diagnostics["refinement"] = {
        "loss": how.loss,
        "then": "least squares on the inliers" if how.refine and how.robust else None,
        "iterations": ref.iterations,
        "converged": bool(ref.converged),
        "cost_initial": ref.cost_initial,
        "cost_final": ref.cost_final,
        "variance_factor": ref.variance_factor,
    }
    scale = ref.scale if estimate_scale else 1.0
    if estimate_scale:
        diagnostics["scale"] = {"value": ref.scale, "sigma": ref.scale_sigma}
    B_eval = poses.B
    if scale != 1.0:
        B_eval = poses.B.copy()
        B_eval[:, :3, 3] *= scale
    r_rot, r_trans = pose_residuals(poses.A, B_eval, X, Y)
    residuals = PoseResiduals(
        rotation_deg=np.degrees(np.linalg.norm(r_rot, axis=1)),
        translation_mm=1000 * np.linalg.norm(r_trans, axis=1),
        inliers=poses.inliers,
    )
    return CalibrationResult(poses.setup, fit.name, X, Y, residuals, ref.covariance, diagnostics)
