"""Hand-eye refinement on board-corner reprojection error (the paper's third formulation, section 2.1).

X and Y (and optionally the intrinsics) minimise the pixel residuals of every
detected corner over all views,

.. math:: \\sum_{i,k} \\rho\\big(|\\pi(K, d, X^{-1} A_i Y\\, p_k) - u_{ik}|^2\\big),

with ``A_i`` the robot-side poses of :mod:`handeye.core.setups`, ``p_k`` the
corners in the target frame and ``u_ik`` their detections. This is the
maximum-likelihood estimate under pixel noise: the per-view PnP poses that the
pose-based solvers take are not needed, and views with few corners count for
what they hold.

Parametrisation as in :mod:`classic.refine`: ``R <- so3_exp(w) R``,
``t <- t + v`` for X then Y, then ``(fx, fy, cx, cy, k1, k2, p1, p2, k3)``
when the intrinsics are refined.

Distortion models: with OpenCV's ``(k1, k2, p1, p2, k3)`` (or fewer) the projection is
:func:`project`'s own and the Jacobian analytic. With OpenCV's full models (rational: 8 coefficients,
thin prism: 12, tilted: 14; any nonzero beyond the fifth) the projection is ``cv2.projectPoints``'s and
the Jacobian finite differences (scipy's "2-point"); the coefficients beyond the fifth are then held
fixed, also with ``refine_intrinsics=True``, which refines ``fx, fy, cx, cy, k1, k2, p1, p2, k3`` only.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import solve_triangular

from classic.least_squares import (
    POSE_NAMES,
    covariance_from_jacobian,
    fit_least_squares,
    require_determined,
    sigma_of_blocks,
)
from classic.vision.board import BoardSpec
from classic.vision.camera import STD_NAMES, CameraIntrinsics
from classic.vision.robot_noise import (
    RobotNoiseEstimate,
    RobotPoseErrorWarning,
    estimate_robot_noise,
    robot_dominates,
    view_covariances,
)
from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import hat, invert_transform, make_transform, so3_exp
from handeye.core.setups import normalize_setup, robot_side_poses

__all__ = [
    "ReprojectionOptions",
    "ReprojectionResult",
    "OUTLIER_VIEW_FACTOR",
    "project",
    "refine_reprojection",
    "robot_pose_jacobian",
]

#: A view whose RMS exceeds this multiple of the median view RMS (and 1 px) is flagged as an outlier.
OUTLIER_VIEW_FACTOR = 3.0


@dataclass
class ReprojectionResult:
    """Outcome of :func:`refine_reprojection`.

    Attributes
    ----------
    X, Y : array, shape (4, 4)
        Camera pose and target pose (:mod:`handeye.core.setups`).
    intrinsics : CameraIntrinsics
        Refined when asked for (with their one-sigma from ``covariance`` as ``std``), else equal to the input.
    rms_px : float
        Over all corners.
    per_view_rms_px : array, shape (V,)
    outlier_views : list of int
        Views whose RMS exceeds ``OUTLIER_VIEW_FACTOR`` times the median (and 1 px).
    covariance : array, shape (P, P)
        Of the parameters (X, Y, [intrinsics]), from the Jacobian at the optimum: ``(G^T S^-1 G)^-1`` under
        the estimated corner noise and robot pose error (:mod:`classic.vision.robot_noise`), or
        ``s^2 (G^T G)^-1`` when no robot error is found or modelled. With fixed intrinsics it leaves
        out their own uncertainty: intrinsics calibrated from few views bias X by more than this
        predicts; refine them (``intrinsics_prior=True``, or ``refine_intrinsics=True``) to include it.
    sigma : dict
        ``X_rotation_deg``, ``X_translation_mm``, ``Y_rotation_deg``, ``Y_translation_mm``.
    robot_noise : RobotNoiseEstimate or None
        The estimated corner noise and robot pose error (None when not modelled).
    diagnostics : dict
        ``robot_noise`` (``corner_sigma_px``, ``robot_rotation_deg``, ``robot_translation_mm`` per axis, or
        None with ``robot_noise_reason``), ``detection_rms_px``, ``robot_dominates`` and its ``warning``.
    warnings : list of str
        The warnings the fit gave (also issued as :class:`~classic.vision.robot_noise.RobotPoseErrorWarning`).
    """

    X: np.ndarray
    Y: np.ndarray
    intrinsics: CameraIntrinsics
    rms_px: float
    per_view_rms_px: np.ndarray
    outlier_views: list
    covariance: np.ndarray
    sigma: dict = field(default_factory=dict)
    robot_noise: RobotNoiseEstimate | None = None
    diagnostics: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)


def project(p_cam: np.ndarray, fx: float, fy: float, cx: float, cy: float, dist: np.ndarray) -> np.ndarray:
    """OpenCV's pinhole projection with its distortion.

    ``(k1, k2, p1, p2, k3)`` (or fewer coefficients, or more with a zero tail) are projected here, in
    closed form; a nonzero coefficient beyond the fifth (rational, thin prism, tilted models) hands the
    projection to ``cv2.projectPoints``.

    Parameters
    ----------
    p_cam : array, shape (M, 3)
        Points in the camera frame, metres.
    fx, fy, cx, cy : float
    dist : array, shape (4,), (5,), (8,), (12,) or (14,)

    Returns
    -------
    uv : array, shape (M, 2)
        Pixels, centres at integers.
    """
    dist = np.asarray(dist, dtype=float).ravel()
    if np.any(dist[5:]):
        import cv2

        K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
        uv, _ = cv2.projectPoints(np.asarray(p_cam, dtype=float).reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, dist)
        return uv.reshape(-1, 2)
    k1, k2, p1, p2, k3 = np.pad(dist[:5], (0, max(0, 5 - dist.size)))
    x = p_cam[:, 0] / p_cam[:, 2]
    y = p_cam[:, 1] / p_cam[:, 2]
    r2 = x * x + y * y
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.column_stack([fx * xd + cx, fy * yd + cy])


def _reprojection_jacobian(
    A: np.ndarray, X: np.ndarray, Y: np.ndarray, p_target: np.ndarray, intr: np.ndarray, with_intrinsics: bool
) -> np.ndarray:
    """Analytic Jacobian of the corners' pixels w.r.t. ``[w_X, v_X, w_Y, v_Y, (fx, fy, cx, cy, k1, k2, p1, p2, k3)]``.

    ``p_cam = R_X^T (q - t_X)`` with ``q = R_A (R_Y p + t_Y) + t_A``; increments ``R <- exp(w) R``,
    ``t <- t + v``: ``dp/dw_X = R_X^T [q - t_X]x``, ``dp/dv_X = -R_X^T``, ``dp/dw_Y = -R_X^T R_A [R_Y p]x``,
    ``dp/dv_Y = R_X^T R_A``; then the pinhole and OpenCV's ``(k1, k2, p1, p2, k3)`` distortion.

    Parameters
    ----------
    A : array, shape (M, 4, 4)
        Robot-side pose of each corner's view.
    X, Y : array, shape (4, 4)
    p_target : array, shape (M, 3)
    intr : array, shape (9,)
    with_intrinsics : bool

    Returns
    -------
    array, shape (2M, 12 or 21)
        Rows ``u_0, v_0, u_1, ...``.
    """
    R_X, t_X, R_Y, t_Y = X[:3, :3], X[:3, 3], Y[:3, :3], Y[:3, 3]
    R_A, t_A = A[:, :3, :3], A[:, :3, 3]
    Ryp = p_target @ R_Y.T
    q = np.einsum("mab,mb->ma", R_A, Ryp + t_Y) + t_A
    p = (q - t_X) @ R_X  # R_X^T (q - t_X), row-wise
    m = len(p)
    dp = np.zeros((m, 3, 12))
    dp[:, :, 0:3] = R_X.T @ hat(q - t_X)
    dp[:, :, 3:6] = -R_X.T
    RxRa = R_X.T @ R_A
    dp[:, :, 6:9] = -(RxRa @ hat(Ryp))
    dp[:, :, 9:12] = RxRa
    J = (_pixel_jacobian(p, intr) @ dp).reshape(2 * m, 12)
    if not with_intrinsics:
        return J
    fx, fy, cx, cy, k1, k2, p1, p2, k3 = intr
    x, y = p[:, 0] / p[:, 2], p[:, 1] / p[:, 2]
    r2 = x * x + y * y
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    Ji = np.zeros((m, 2, 9))
    Ji[:, 0, 0], Ji[:, 1, 1], Ji[:, 0, 2], Ji[:, 1, 3] = xd, yd, 1.0, 1.0
    for col, r_pow in ((4, r2), (5, r2 * r2), (8, r2**3)):  # k1, k2, k3
        Ji[:, 0, col], Ji[:, 1, col] = fx * x * r_pow, fy * y * r_pow
    Ji[:, 0, 6], Ji[:, 1, 6] = fx * 2 * x * y, fy * (r2 + 2 * y * y)  # p1
    Ji[:, 0, 7], Ji[:, 1, 7] = fx * (r2 + 2 * x * x), fy * 2 * x * y  # p2
    return np.concatenate([J, Ji.reshape(2 * m, 9)], axis=1)


def _pixel_jacobian(p: np.ndarray, intr: np.ndarray) -> np.ndarray:
    """d(u, v) / d(point in the camera frame) of the pinhole with ``(k1, k2, p1, p2, k3)``, shape (M, 2, 3)."""
    fx, fy, cx, cy, k1, k2, p1, p2, k3 = intr
    m, Z = len(p), p[:, 2]
    x, y = p[:, 0] / Z, p[:, 1] / Z
    dxy = np.zeros((m, 2, 3))
    dxy[:, 0, 0] = dxy[:, 1, 1] = 1.0 / Z
    dxy[:, 0, 2] = -x / Z
    dxy[:, 1, 2] = -y / Z
    r2 = x * x + y * y
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    dradial = k1 + 2 * k2 * r2 + 3 * k3 * r2 * r2
    dd = np.empty((m, 2, 2))  # d(xd, yd) / d(x, y)
    dd[:, 0, 0] = radial + 2 * x * x * dradial + 2 * p1 * y + 6 * p2 * x
    dd[:, 0, 1] = 2 * x * y * dradial + 2 * p1 * x + 2 * p2 * y
    dd[:, 1, 0] = 2 * x * y * dradial + 2 * p1 * x + 2 * p2 * y
    dd[:, 1, 1] = radial + 2 * y * y * dradial + 6 * p1 * y + 2 * p2 * x
    return np.array([fx, fy])[None, :, None] * dd @ dxy


def robot_pose_jacobian(
    A: np.ndarray, X: np.ndarray, Y: np.ndarray, p_target: np.ndarray, intr: np.ndarray, setup: str
) -> np.ndarray:
    """The corners' pixel Jacobian w.r.t. an error ``[w, n]`` of their view's robot pose ``T_base_ee``.

    The error is :mod:`classic.noise_model`'s: ``R <- R exp(w)`` (flange frame), ``t <- t + n`` (base frame) on
    ``T_base_ee``. With ``q = R_A (R_Y p + t_Y) + t_A`` and ``p_cam = R_X^T (q - t_X)``: eye-to-hand
    (``A = T_base_ee``) ``dq/dw = -R_A [R_Y p + t_Y]x``, ``dq/dn = I``; eye-in-hand (``A = T_ee_base``, the
    error on its inverse) ``dq/dw = [q]x``, ``dq/dn = -R_A``. Distortion: the first five coefficients (a
    full model's further ones are left out of this Jacobian, which only weighs the views).

    Parameters
    ----------
    A : array, shape (M, 4, 4)
        Robot-side pose (:func:`handeye.core.setups.robot_side_poses`) of each corner's view.
    X, Y : array, shape (4, 4)
    p_target : array, shape (M, 3)
    intr : array, shape (9,)
        ``fx, fy, cx, cy, k1, k2, p1, p2, k3``.
    setup : {"eye_to_hand", "eye_in_hand"}

    Returns
    -------
    array, shape (2M, 6)
        Rows ``u_0, v_0, u_1, ...``; columns ``w`` (rad) then ``n`` (m).
    """
    R_X, t_X, R_Y, t_Y = X[:3, :3], X[:3, 3], Y[:3, :3], Y[:3, 3]
    R_A, t_A = A[:, :3, :3], A[:, :3, 3]
    y = p_target @ R_Y.T + t_Y
    q = np.einsum("mab,mb->ma", R_A, y) + t_A
    dq = np.zeros((len(q), 3, 6))
    if setup == "eye_to_hand":
        dq[:, :, :3] = -(R_A @ hat(y))
        dq[:, :, 3:] = np.eye(3)
    else:
        dq[:, :, :3] = hat(q)
        dq[:, :, 3:] = -R_A
    p = (q - t_X) @ R_X
    return (_pixel_jacobian(p, intr) @ (R_X.T @ dq)).reshape(-1, 6)


def _pose(T0: np.ndarray, w: np.ndarray, v: np.ndarray) -> np.ndarray:
    return make_transform(so3_exp(w) @ T0[:3, :3], T0[:3, 3] + v)


@dataclass(frozen=True, kw_only=True)
class ReprojectionOptions:
    """Settings of :func:`refine_reprojection`.

    Attributes
    ----------
    setup : {"eye_to_hand", "eye_in_hand"}
    refine_intrinsics : bool
        Also refine ``fx, fy, cx, cy`` and the first five distortion coefficients (further ones stay fixed),
        freely: the corners alone determine them.
    intrinsics_prior : bool
        Refine them as ``refine_intrinsics`` does, with the given intrinsics as a Gaussian prior of their
        one-sigma (:meth:`~classic.vision.camera.CameraIntrinsics.std_vector`: the file's own, or a stated
        default), so that their uncertainty is in the covariance and the views improve them where they
        determine them. False with ``refine_intrinsics`` False: the intrinsics are taken as exact, and the
        covariance leaves their error out.
    loss : {"linear", "huber", "cauchy", "soft_l1"}
        scipy's loss on each pixel residual.
    loss_scale_px : float
        Where the robust loss starts to bend, pixels.
    robot_noise : {"estimate", "none"}
        ``estimate``: the corners of a view share its robot pose error; the corner noise and the robot's
        rotation and translation error are estimated from the residuals (REML), X and Y refitted by
        generalised least squares and the covariance is that model's (:mod:`classic.vision.robot_noise`); a
        :class:`~classic.vision.robot_noise.RobotPoseErrorWarning` when the residuals are beyond
        ``DOMINANCE_FACTOR`` times the detection's own and above ``DOMINANCE_FLOOR_PX`` (0.01 px:
        exact corners leave rounding). With the linear loss only (a robust loss keeps the
        plain model). ``none``: every corner independent, the robot exact.
    """

    setup: str = "eye_to_hand"
    refine_intrinsics: bool = False
    intrinsics_prior: bool = False
    loss: str = "linear"
    loss_scale_px: float = 1.0
    robot_noise: str = "estimate"


#: A parameter whose stated one-sigma is zero (held fixed by its calibration) is held to this share of the default
#: rule's one-sigma (:data:`classic.vision.camera.DEFAULT_STD_RULE`): for a distortion coefficient a thousandth of a
#: pixel at the image corner.
HELD_STD_SHARE = 1e-3
#: What a refusal of an undetermined direction (:func:`classic.least_squares.require_determined`) asks for.
_REMEDY = (
    "record views whose robot motions turn about at least two different axes; refined intrinsics also need "
    "the board tilted and across the image, or their prior (intrinsics_prior)"
)


def refine_reprojection(
    T_base_ee: np.ndarray,
    corner_ids: list[np.ndarray],
    corners_px: list[np.ndarray],
    spec: BoardSpec,
    intrinsics: CameraIntrinsics,
    X0: np.ndarray,
    Y0: np.ndarray,
    options: ReprojectionOptions | None = None,
) -> ReprojectionResult:
    """Refine X and Y (and optionally the intrinsics) on corner reprojection error.

    Parameters
    ----------
    T_base_ee : array, shape (V, 4, 4)
        Robot pose of each view.
    corner_ids : list of V arrays of int
        Corner ids detected in each view.
    corners_px : list of V arrays, shape (M_i, 2)
        Their pixel positions.
    spec : BoardSpec
    intrinsics : CameraIntrinsics
    X0, Y0 : array, shape (4, 4)
        Initial camera and target poses, e.g. from :func:`classic.calibrate` on the PnP poses.
    options : ReprojectionOptions, optional
        Setup, intrinsics refined or not, loss, robot noise; None: :class:`ReprojectionOptions`' defaults.

    Returns
    -------
    ReprojectionResult

    Raises
    ------
    HandEyeInputError
        Mismatched counts, or fewer than 3 views with corners.
    DegenerateMotionError
        The views leave a direction of X, Y (or of the refined intrinsics) undetermined: its sigma would read
        as 0. The message names it.
    """
    opts = options or ReprojectionOptions()
    setup, loss, robot_noise = normalize_setup(opts.setup), opts.loss, opts.robot_noise
    _check_arguments(T_base_ee, corner_ids, corners_px, robot_noise)
    corners = _Corners.of(corner_ids, corners_px, spec)
    A = robot_side_poses(np.asarray(T_base_ee, dtype=float), setup)
    prior = _prior_std(intrinsics) if opts.intrinsics_prior else None
    prob = _Problem(A, corners, intrinsics, X0, Y0, opts.refine_intrinsics or opts.intrinsics_prior, prior)
    fit = _fit_plain(prob, loss, opts.loss_scale_px)
    robot, cov = None, None
    if robot_noise == "estimate" and loss == "linear":
        fit, robot, cov = _fit_with_robot_noise(prob, prob.robot_jacobian(setup), corners.rows, fit)
    X, Y, intr = prob.unpack(fit.x)
    n_pix = 2 * len(corners.view)
    per_view, outliers, rms = _view_errors(fit.residuals[:n_pix], corners.view, len(T_base_ee))
    if robot is None or not robot.has_robot_error:
        cov = _scaled_covariance(fit, loss, prob)
    diagnostics = _robot_diagnostics(robot, rms, robot_noise, loss)
    warned = []
    if diagnostics.get("robot_dominates"):
        warned.append(diagnostics["warning"])
        warnings.warn(diagnostics["warning"], RobotPoseErrorWarning, stacklevel=2)
    return ReprojectionResult(
        X,
        Y,
        prob.intrinsics_at(intr, cov),
        rms,
        per_view,
        outliers,
        cov,
        sigma_of_blocks(cov),
        robot,
        diagnostics,
        warned,
    )


def _prior_std(intrinsics: CameraIntrinsics) -> np.ndarray:
    """The prior's one-sigma of ``(fx, fy, cx, cy, k1, k2, p1, p2, k3)``: the intrinsics' own
    (:meth:`~classic.vision.camera.CameraIntrinsics.std_vector`), a zero (what OpenCV writes for a parameter its
    calibration held fixed) taken as :data:`HELD_STD_SHARE` of the default rule's, so that the parameter stays put
    without a row of 1e12 that the covariance's pseudo-inverse answers with zero variance for the pose."""
    std = intrinsics.std_vector()[0]
    default = dataclasses.replace(intrinsics, std=None).std_vector()[0]
    return np.where(std > 0, std, HELD_STD_SHARE * default)


def _fit_plain(prob: "_Problem", loss: str, loss_scale_px: float):
    """The fit with every corner independent; with a prior on the intrinsics, refitted once with the prior's
    rows in the pixel noise's units (the first pass guesses 1 px)."""
    fit = fit_least_squares(
        prob.residuals, prob.jac, prob.n_params, loss=loss, loss_scale=loss_scale_px, max_evaluations=200, tol=1e-12
    )
    if prob.prior_std is None:
        return fit
    n_pix = 2 * len(prob.corners.view)
    prob.prior_scale = float(np.sqrt(np.mean(fit.residuals[:n_pix] ** 2)))
    return _refit_from(prob, fit.x, loss, loss_scale_px)


def _refit_from(prob: "_Problem", x0: np.ndarray, loss: str, loss_scale_px: float):
    """:func:`fit_least_squares` started at ``x0`` instead of zero; the fit's ``x`` is the total increment."""
    jac = prob.jac if isinstance(prob.jac, str) else (lambda d: prob.jac(x0 + d))
    fit = fit_least_squares(
        lambda d: prob.residuals(x0 + d),
        jac,
        prob.n_params,
        loss=loss,
        loss_scale=loss_scale_px,
        max_evaluations=200,
        tol=1e-12,
    )
    return dataclasses.replace(fit, x=x0 + fit.x)


def _check_arguments(T_base_ee, corner_ids, corners_px, robot_noise: str) -> None:
    """Refuse an unknown robot-noise model, and corner lists that are not one per robot pose."""
    if robot_noise not in ("estimate", "none"):
        raise HandEyeInputError(f"robot_noise must be 'estimate' or 'none', got {robot_noise!r}")
    n_views = len(T_base_ee)
    if not (len(corner_ids) == len(corners_px) == n_views):
        raise HandEyeInputError(
            f"{n_views} robot poses but {len(corner_ids)} corner-id lists and {len(corners_px)} corner lists: "
            "one entry per view is needed"
        )


@dataclass
class _Corners:
    """Every detected corner of every view: its view, its point in the target frame and its pixel."""

    view: np.ndarray  # (M,) int
    p_target: np.ndarray  # (M, 3)
    uv: np.ndarray  # (M, 2)
    rows: list  # each view's rows of the residual vector (views with corners only), slices

    @classmethod
    def of(cls, corner_ids, corners_px, spec: BoardSpec) -> _Corners:
        """The corners of the views concatenated; refused unless at least 3 views have some."""
        view = np.concatenate([np.full(len(ids), k) for k, ids in enumerate(corner_ids)] + [np.zeros(0)]).astype(int)
        if len(np.unique(view)) < 3:
            raise HandEyeInputError("the reprojection refinement needs corners in at least 3 views")
        p_target = spec.corners_target()[np.concatenate(corner_ids).astype(int)]
        uv = np.concatenate([np.asarray(c, dtype=float).reshape(-1, 2) for c in corners_px])
        starts = np.concatenate([[0], np.cumsum([2 * len(ids) for ids in corner_ids])])
        rows = [slice(a, b) for a, b in zip(starts[:-1], starts[1:]) if b > a]
        return cls(view, p_target, uv, rows)


class _Problem:
    """The pixel residuals and their Jacobians of the increment ``[w_X, v_X, w_Y, v_Y, (intrinsics)]``.

    With a prior on the intrinsics (``prior_std``, shape (9,)), 9 rows follow the pixels':
    ``prior_scale * (intrinsics - given) / prior_std``, in the pixel noise's units (``prior_scale`` its
    one-sigma per axis).
    """

    def __init__(
        self, A, corners: _Corners, intrinsics: CameraIntrinsics, X0, Y0, refine_intrinsics: bool, prior_std=None
    ):
        self.A, self.corners, self.intrinsics, self.X0, self.Y0 = A, corners, intrinsics, X0, Y0
        self.refine_intrinsics = refine_intrinsics
        self.prior_std = None if prior_std is None else np.asarray(prior_std, dtype=float)
        self.prior_scale = 1.0
        K0 = intrinsics.K
        # rational / thin prism / tilted: cv2.projectPoints, 2-point
        self.full_model = bool(np.any(intrinsics.dist[5:]))
        self.tail = intrinsics.dist[5:] if self.full_model else np.zeros(0)
        d0 = np.zeros(5)
        d0[: min(5, intrinsics.dist.size)] = intrinsics.dist[:5]
        self.intr0 = np.array([K0[0, 0], K0[1, 1], K0[0, 2], K0[1, 2], *d0[:5]])

    @property
    def n_params(self) -> int:
        return 12 + (9 if self.refine_intrinsics else 0)

    @property
    def names(self) -> tuple:
        """What each parameter is, as a refusal of an undetermined direction names it."""
        return POSE_NAMES + (STD_NAMES if self.refine_intrinsics else ())

    @property
    def jac(self):
        """The analytic Jacobian, or scipy's "2-point" with a full distortion model."""
        return "2-point" if self.full_model else self.jacobian

    def unpack(self, params):
        """``(X, Y, (fx, fy, cx, cy, k1, k2, p1, p2, k3))`` at the increment ``params``."""
        X = _pose(self.X0, params[0:3], params[3:6])
        Y = _pose(self.Y0, params[6:9], params[9:12])
        intr = self.intr0 + params[12:] if self.refine_intrinsics else self.intr0
        return X, Y, intr

    def residuals(self, params):
        X, Y, intr = self.unpack(params)
        c = self.corners
        T_cam_target = invert_transform(X) @ self.A @ Y  # (V, 4, 4)
        R, t = T_cam_target[c.view, :3, :3], T_cam_target[c.view, :3, 3]
        p_cam = np.einsum("mab,mb->ma", R, c.p_target) + t
        r = (project(p_cam, *intr[:4], np.concatenate([intr[4:9], self.tail])) - c.uv).ravel()
        if self.prior_std is None:
            return r
        return np.concatenate([r, self.prior_scale * params[12:] / self.prior_std])

    def jacobian(self, params):
        X, Y, intr = self.unpack(params)
        J = _reprojection_jacobian(self.A[self.corners.view], X, Y, self.corners.p_target, intr, self.refine_intrinsics)
        if self.prior_std is None:
            return J
        return np.vstack([J, self.prior_rows(self.prior_scale)])

    def prior_rows(self, scale: float) -> np.ndarray:
        """The prior rows' Jacobian at the pixel noise ``scale``, shape (9, 21)."""
        return np.hstack([np.zeros((9, 12)), np.diag(scale / self.prior_std)])

    def robot_jacobian(self, setup: str):
        """``params -> (2M, 6)``: :func:`robot_pose_jacobian` at those parameters."""

        def robot_jacobian(params):
            X, Y, intr = self.unpack(params)
            return robot_pose_jacobian(self.A[self.corners.view], X, Y, self.corners.p_target, intr, setup)

        return robot_jacobian

    def intrinsics_at(self, intr: np.ndarray, cov: np.ndarray) -> CameraIntrinsics:
        """The camera of the parameters ``intr`` (the skew and the distortion beyond the fifth kept); refined,
        with their one-sigma from the covariance ``cov``, else with the given one-sigma (or none)."""
        K0 = self.intrinsics.K
        K = np.array([[intr[0], K0[0, 1], intr[2]], [0, intr[1], intr[3]], [0, 0, 1]])
        dist = np.concatenate([intr[4:9], self.tail])
        std = self.intrinsics.std
        if self.refine_intrinsics:
            std = dict(zip(STD_NAMES, map(float, np.sqrt(np.diag(cov)[12:21]))))
        return CameraIntrinsics(K, dist, self.intrinsics.width, self.intrinsics.height, std)


def _view_errors(residuals: np.ndarray, view: np.ndarray, n_views: int) -> tuple[np.ndarray, list, float]:
    """Per-view RMS (px), the outlier views (:data:`OUTLIER_VIEW_FACTOR`), and the RMS over all corners."""
    sq = np.sum(residuals.reshape(-1, 2) ** 2, axis=1)
    counts = np.bincount(view, minlength=n_views)
    per_view = np.sqrt(np.bincount(view, weights=sq, minlength=n_views) / np.maximum(counts, 1))
    has = counts > 0
    med = float(np.median(per_view[has]))
    outliers = [int(k) for k in np.flatnonzero(has & (per_view > max(OUTLIER_VIEW_FACTOR * med, 1.0)))]
    return per_view, outliers, float(np.sqrt(np.mean(sq)))


def _scaled_covariance(fit, loss: str, prob: "_Problem") -> np.ndarray:
    """``s^2 (G^T G)^-1`` with ``s`` the per-axis pixel noise from the residuals (robustly with a robust loss);
    with a prior on the intrinsics, ``(G^T G / s^2 + diag(1 / std^2))^-1``."""
    n_pix = 2 * len(prob.corners.view)
    sq = np.sum(fit.residuals[:n_pix].reshape(-1, 2) ** 2, axis=1)
    if loss == "linear":
        s2 = float(np.sum(sq)) / max(n_pix - prob.n_params, 1)  # per-axis variance, dof-corrected
    else:
        # a robust fit's outliers must not set the scale: |r|^2 / s^2 is chi2 with 2 dof, median 1.386
        s2 = float(np.median(sq)) / 1.3863
    J, weights = fit.jacobian, fit.weights
    if prob.prior_std is not None:
        J = np.vstack([J[:n_pix], prob.prior_rows(np.sqrt(s2))])
        weights = np.concatenate([weights[:n_pix], np.ones(9)])
    return covariance_from_jacobian(J, weights, s2, names=prob.names, remedy=_REMEDY)


def _fit_with_robot_noise(prob: "_Problem", robot_jacobian, rows, fit):
    """The REML estimate of the variance components, then the generalised least-squares fit under it.

    The estimate is taken once, at the unweighted fit: REML's residual term ``r^T P r`` (``P G = 0``) is the
    same wherever a linear model is linearised, and the weighted optimum moves X and Y by about their
    sigma, which changes ``G`` and ``J_i`` by a negligible fraction.

    Parameters
    ----------
    prob : _Problem
        The pixel residuals (and the intrinsics' prior rows, after them) and their Jacobian (or "2-point") of
        the parameter increment.
    robot_jacobian : callable
        ``params -> (2M, 6)``: :func:`robot_pose_jacobian` at those parameters.
    rows : list of slice
        Each view's rows of the residual vector (views with corners only).
    fit : LeastSquaresFit
        The unweighted fit.

    Returns
    -------
    fit : LeastSquaresFit
        The weighted fit, with its residuals and Jacobian unwhitened.
    estimate : RobotNoiseEstimate
    covariance : array, shape (P, P) or None
        ``(G^T S^-1 G)^-1`` under the estimate at the weighted fit; None when it finds no robot error.
    """
    residuals, jac = prob.residuals, prob.jac
    n_pix = 2 * len(prob.corners.view)
    unit = 1.0 / prob.prior_scale  # the prior rows (none without a prior) in units of their own sigma
    J_rob = robot_jacobian(fit.x)
    estimate = estimate_robot_noise(
        [J_rob[s] for s in rows], [fit.jacobian[s] for s in rows], [fit.residuals[s] for s in rows]
    )
    if not estimate.has_robot_error:
        return fit, estimate, None
    x0 = fit.x
    W = [_inverse_cholesky(S) for S in view_covariances([J_rob[s] for s in rows], estimate)]

    def whitened(d):
        v = residuals(x0 + d)
        return np.concatenate([w @ v[s] for w, s in zip(W, rows)] + [unit * v[n_pix:]])

    def whitened_jacobian(d):
        Jm = jac(x0 + d)
        return np.concatenate([w @ Jm[s] for w, s in zip(W, rows)] + [unit * Jm[n_pix:]])

    # increments about where the unweighted fit ended; every row belongs to one view, so the whitened
    # residuals keep the rows' layout
    numeric = isinstance(jac, str)
    gls = fit_least_squares(whitened, jac if numeric else whitened_jacobian, len(x0), max_evaluations=200)
    x = x0 + gls.x
    if numeric:  # unwhiten scipy's finite differences: G_i = W_i^-1 (W_i G_i)
        G = np.concatenate(
            [np.linalg.solve(w, gls.jacobian[s]) for w, s in zip(W, rows)] + [gls.jacobian[n_pix:] / unit]
        )
    else:
        G = np.asarray(jac(x))
    J_rob = robot_jacobian(x)
    W = [_inverse_cholesky(S) for S in view_covariances([J_rob[s] for s in rows], estimate)]
    Gw = np.concatenate([w @ G[s] for w, s in zip(W, rows)] + [unit * G[n_pix:]])
    require_determined(Gw, names=prob.names, remedy=_REMEDY)
    fit = dataclasses.replace(gls, x=x, residuals=residuals(x), jacobian=G)
    return fit, estimate, np.linalg.inv(Gw.T @ Gw)


def _inverse_cholesky(S: np.ndarray) -> np.ndarray:
    """``W`` with ``W^T W = S^-1``: the inverse of ``S``'s lower Cholesky factor."""
    return solve_triangular(np.linalg.cholesky(S), np.eye(len(S)), lower=True)


def _robot_diagnostics(robot: RobotNoiseEstimate | None, rms_px: float, robot_noise: str, loss: str) -> dict:
    """What the result says of the robot's pose error, and the warning when it dominates the residuals."""
    if robot is None:
        why = "not asked for" if robot_noise == "none" else f"not modelled with the robust loss {loss!r}"
        return {"robot_noise": None, "robot_noise_reason": why}
    out = {"robot_noise": robot.describe()}
    detection_rms = np.sqrt(2.0) * robot.sigma_px  # 2-D RMS the corners' detection alone leaves
    out["detection_rms_px"] = float(detection_rms)
    out["robot_dominates"] = robot_dominates(rms_px, detection_rms)
    if out["robot_dominates"]:
        d = robot.describe()
        out["warning"] = (
            f"the robot's pose error dominates: {rms_px:.2f} px RMS per corner against {detection_rms:.3f} px for "
            f"the corner detection alone; the sigma includes an estimated robot error of "
            f"{d['robot_rotation_deg']:.4f} deg / {d['robot_translation_mm']:.3f} mm per axis"
        )
    return out
