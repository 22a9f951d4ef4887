"""Robust point-to-plane least squares for a camera pose, with a covariance that trusts frames, not pixels.

Observed points ``p`` (camera frame) are matched to model points ``m`` with
outward normals ``n`` (base frame). The camera pose minimises

.. math:: \\sum_i \\rho\\big(n_i^T (T_{base,cam}\\, p_i - m_i) / s\\big)

with ``rho`` a robust loss and ``s`` the residual scale. The pose is
perturbed on the right, ``T = T_0 \\exp(\\xi)``, ``\\xi = (\\omega, v)`` in the
camera frame, so ``\\omega`` is the camera's rotation error and ``R_0 v`` its
position error in the base frame.

Written by hand (iteratively reweighted Gauss-Newton, one 6x6 solve per
step) rather than with ``scipy.optimize.least_squares``: the matches change
after every step (ICP), so each problem is a handful of linear solves, and
the exact Jacobian at the current pose is the closed form below.

With a depth start (``PlaneFitOptions.depth_start``) the sensor's depth scale and offset are estimated too. A
sensor that reports ``d_obs = s d + o`` places a point at ``q_obs = d_obs r`` on its pixel's ray ``r = (x_n,
y_n, 1)``; the true point is ``q = k q_obs + c r`` with ``k = 1 / s`` and ``c = -o / s``, linear in ``(k,
c)``. Their columns of the Jacobian are ``n_cam . q_obs`` and ``n_cam . r``. The robot's size is known in
metres, so ``k`` is fixed by the arm's size in the image as much as by its depth; ``c`` apart from the
camera's position along its axis by the rays' spread across the image and the arm's range of depths.

An active-stereo sensor errs in disparity, not in depth, and its matcher's sub-pixel interpolation pulls
the disparity towards whole pixels ("pixel locking"): an error periodic in the disparity ``d = f B / z``
with a period of one pixel, ``e(d) = a sin(2 pi d) + b cos(2 pi d)`` to first order. With the sensor's
disparity constant ``f B`` (pixels x metres) given, ``(a, b)`` are estimated too (10 parameters): the
true depth is ``z = z_a + z_a^2 / (f B k) e(f B k / z_a)`` with ``z_a = k z_obs + c``. The camera converts
its disparity with its own ``f B``; its scale error ``k`` is that constant's error against the true one, so
the matcher's disparity is ``f B k / z_a``. One pixel of disparity spans ``z^2 / (f B)`` of depth: 60 mm at
1.15 m for a D435 (447 px x 50 mm), so the arm's range of depths covers several periods and ``(a, b)`` are
observable apart from the scale and offset.

With ``PlaneFitOptions.intrinsics_K_ref`` the depth camera's intrinsics ``(f_x, f_y, c_x, c_y)`` are estimated
too, under a Gaussian prior (:mod:`classic.markerless.intrinsics`): each observed point keeps its pixel and
depth, its ray moves with them, and their columns of the Jacobian are ``z n_cam[:2] . d(x_n, y_n) / d theta``.

With ``MatchedModel.joint_twists`` the robot's joint zero offsets ``delta`` are estimated too, under a
Gaussian prior about 0 (:mod:`classic.markerless.kinematics`): the model points move by ``omega_j x m + v_j``
per radian of joint ``j`` (first order), and their columns of the Jacobian are ``-(n . (omega_j x m + v_j))``.

The covariance is the sandwich (cluster-robust) estimate with one cluster per
frame: neighbouring pixels of one frame share the model's discretisation and
the sensor's systematic error, so counting them as independent would make
the sigma far too small. The plain ``s^2 H^{-1}`` is kept as a floor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from classic.clustered_covariance import clustered_covariance
from classic.least_squares import loss_weights
from classic.markerless.curvature import residual_under_noise, second_order_residual
from classic.markerless.intrinsics import intrinsics_vector, rays_for
from classic.markerless.kinematics import moved_model, offset_columns, turned_directions
from classic.markerless.pixel_effect import (
    compact_pixels,
    pixel_gain,
    pixel_variance_components,
    reduced_rows,
    schur_reduction,
)
from classic.markerless.repeated_error import repeated_error_covariance
from classic.markerless.rows import cross_rows
from handeye.core.se3 import make_transform, so3_exp

__all__ = [
    "PlaneFit",
    "PlaneFitOptions",
    "MatchedModel",
    "solve_point_to_plane",
    "apply_right",
    "corrected_points",
    "pixel_locking_basis",
]


@dataclass
class PlaneFit:
    """Result of :func:`solve_point_to_plane`.

    Attributes
    ----------
    T_base_cam : array, shape (4, 4)
    covariance : array, shape (6, 6), or None
        Of ``(omega, v)``, the right perturbation in the camera frame (radians, metres); None when the fit was
        asked for none (``PlaneFitOptions.covariance`` False), as are the depth correction's.
    residuals_m : array, shape (N,)
        Signed point-to-plane residuals at the solution.
    weights : array, shape (N,)
        Robust weights at the solution (1 inlier, 0 outlier).
    group : array of int, shape (N,)
        Frame of each residual (all 0 when no groups were given).
    steps : int
    step_norm : float
        Size of the last update: rotation (rad) plus translation (m), plus the depth scale and offset when
        estimated (the pixel locking and the intrinsics not).
    depth_correction : tuple of float or None
        ``(k, c)``: the estimated correction ``q = k q_obs + c r`` (``k = 1 / s``, ``c = -o / s``), when
        asked for; ``(k, c, a, b)`` with the stereo matcher's pixel locking ``(a, b)`` (pixels); the pose's
        ``covariance`` then includes their uncertainty.
    depth_covariance : array, shape (D, D) or None
        Of ``depth_correction`` (``D`` = 2 or 4).
    depth_covariance_frames : array, shape (D, D) or None
        The same, clustered by frame only: what the frames' spread of depths leaves of them, without the
        errors the frames share (whether the depth is observable at all is a question of geometry); with the
        intrinsics estimated, given them (conditional), so that it judges the depth range alone.
    intrinsics : array, shape (4,) or None
        The estimated ``(f_x, f_y, c_x, c_y)``, pixels, when asked for (``PlaneFitOptions.intrinsics_K_ref``).
    intrinsics_covariance, intrinsics_covariance_frames : array, shape (4, 4) or None
        Their covariance, two-way and frame-clustered as the depth's.
    joint_offsets : array, shape (J,) or None
        The estimated joint zero offsets, radians, when asked for (``MatchedModel.joint_twists``).
    joint_offsets_covariance, joint_offsets_covariance_frames : array, shape (J, J) or None
        Their covariance, two-way and frame-clustered as the depth's.
    repeated : dict or None
        With ``PlaneFitOptions.repeated_radius_px``: what an error repeated per image pixel across frames adds,
        :func:`classic.markerless.repeated_error.repeated_error_covariance` (``covariance`` of all parameters), with
        the intrinsics estimated their block as ``intrinsics_covariance`` (4, 4).
    """

    T_base_cam: np.ndarray
    covariance: np.ndarray
    residuals_m: np.ndarray
    weights: np.ndarray
    group: np.ndarray
    steps: int
    step_norm: float
    depth_correction: tuple | None = None
    depth_covariance: np.ndarray | None = None
    depth_covariance_frames: np.ndarray | None = None
    intrinsics: np.ndarray | None = None
    intrinsics_covariance: np.ndarray | None = None
    intrinsics_covariance_frames: np.ndarray | None = None
    joint_offsets: np.ndarray | None = None
    joint_offsets_covariance: np.ndarray | None = None
    joint_offsets_covariance_frames: np.ndarray | None = None
    repeated: dict | None = None


@dataclass(frozen=True)
class MatchedModel:
    """The model side of the matches of :func:`solve_point_to_plane`, base frame, one row per match.

    Attributes
    ----------
    points_base, normals_base : array, shape (N, 3)
        The matched model points and their outward unit normals, metres.
    curvatures : array, shape (N, 2), optional
        Principal curvatures of the model at each match (1/m); with ``direction_base`` the residual is taken to
        second order (:func:`classic.markerless.curvature.second_order_residual`), which removes the bias of
        matching a sample anywhere in a pixel on a curved surface.
    direction_base : array, shape (N, 3), optional
        First principal direction of each match; given with ``curvatures``.
    joint_twists : array, shape (N, J, 6), optional
        Each match's part's twist per joint at its frame
        (:attr:`classic.markerless.RobotSurfaceFrames.joint_twists_base`); given, the zero offsets of these ``J``
        joints are estimated with the pose (the points and normals are then posed at the recorded joints).
    depth_variance : array, shape (N,), optional
        The observed point's depth-noise variance at each match (m^2, along the camera's axis); given, the fit
        takes the noise out of its equations (:func:`classic.markerless.curvature.residual_under_noise`: the
        residual's mean under the noise, and the gradient and the columns that hold the observed point taken at
        the point moved along its ray onto the surface).
    """

    points_base: np.ndarray
    normals_base: np.ndarray
    curvatures: np.ndarray | None = None
    direction_base: np.ndarray | None = None
    joint_twists: np.ndarray | None = None
    depth_variance: np.ndarray | None = None


@dataclass(frozen=True)
class PlaneFitOptions:
    """Settings of :func:`solve_point_to_plane`: the loss, the iterations, and which unknowns beside the pose are
    estimated, from which start, under which priors.

    Attributes
    ----------
    scale_m : float
        Residual scale of the robust loss (a few depth-noise sigmas).
    loss : {"cauchy", "huber", "linear"}
    iterations : int
    tol : float
        Stop when the update (rad + m) is below this.
    covariance : bool
        False: skip the covariances (the fit's covariance fields are None), for the passes of an iteration
        whose matches are about to change.
    depth_start : (float, float), optional
        Start ``(k, c)`` of the depth correction ``q = k p_cam + c r`` (``(1, 0)``: none); given, it is
        estimated with the pose (8 parameters).
    depth_prior_sigma : (float, float), optional
        Sigmas of a Gaussian prior on ``k`` about 1 and ``c`` about 0 (a datasheet's spread of the scale and
        the offset, metres): with few frames or little depth range the prior keeps them, and their
        uncertainty enters the pose's covariance. None: no prior.
    stereo_fb_px_m : float, optional
        With ``depth_start``: the active-stereo sensor's disparity constant ``f B`` (pixels x metres);
        its matcher's pixel locking ``(a, b)`` is estimated too (10 parameters; ``depth_start`` may
        then start it as ``(k, c, a, b)``).
    pixel_locking_prior_px : float
        Sigma of a Gaussian prior on ``a`` and ``b`` about 0, pixels (a parabola-fitting matcher's
        locking reaches a few tenths of a pixel).
    intrinsics_K_ref : array, shape (3, 3), optional
        The camera matrix the observed points were back-projected with; given, the intrinsics
        ``(f_x, f_y, c_x, c_y)`` are estimated with the pose (4 more parameters, :mod:`classic.markerless.intrinsics`).
    intrinsics_start : array, shape (4,), optional
        Their start, pixels (those of ``intrinsics_K_ref`` by default).
    intrinsics_prior : (array (4,), array (4,)), optional
        Mean and sigmas of a Gaussian prior on them, pixels (the camera matrix given and its stated
        uncertainty). None: no prior.
    joint_start : array, shape (J,), optional
        With :attr:`MatchedModel.joint_twists`: the joint offsets' start, radians (0 by default).
    joint_prior_sigma : array, shape (J,), optional
        Sigmas of a Gaussian prior on them about 0, radians. None: no prior.
    pixel_effect : bool
        With the matches' pixels given (``solve_point_to_plane(pixel=...)``): a depth error per image pixel, the
        same in every frame (a fixed pattern), marginalised under a sigma measured from the residuals
        (:mod:`classic.markerless.pixel_effect`).
    repeated_radius_px : int
        With the matches' image pixels given (``solve_point_to_plane(uv=...)``) and above 0: the covariance an
        error repeated per image pixel across frames adds (:mod:`classic.markerless.repeated_error`), its field's
        covariance measured out to this many pixels; ``PlaneFit.repeated``. 0: not computed.
    """

    scale_m: float
    loss: str = "cauchy"
    iterations: int = 5
    tol: float = 1e-7
    covariance: bool = True
    depth_start: tuple | None = None
    depth_prior_sigma: tuple | None = None
    stereo_fb_px_m: float | None = None
    pixel_locking_prior_px: float = 0.25
    intrinsics_K_ref: np.ndarray | None = None
    intrinsics_start: np.ndarray | None = None
    intrinsics_prior: tuple | None = None
    joint_start: np.ndarray | None = None
    joint_prior_sigma: np.ndarray | None = None
    pixel_effect: bool = False
    repeated_radius_px: int = 0


def apply_right(T: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """``T @ [exp(omega) | v]``: the right perturbation of the parametrisation above, ``xi = (omega, v)``."""
    return T @ make_transform(so3_exp(xi[:3]), xi[3:])


def pixel_locking_basis(z_m: np.ndarray, k: float, stereo_fb_px_m: float) -> np.ndarray:
    """Depth change of one pixel of disparity error, times ``(sin, cos)`` of the matcher's disparity phase.

    Parameters
    ----------
    z_m : array, shape (N,)
        Depths with the scale and offset corrected, ``k z_obs + c``, metres.
    k : float
        The scale correction (the sensor's ``f B`` over the true one).
    stereo_fb_px_m : float
        The sensor's disparity constant ``f B``, pixels x metres.

    Returns
    -------
    array, shape (N, 2)
        ``z^2 / (f B k) (sin, cos)(2 pi f B k / z)``, metres per pixel.
    """
    return _locking_terms(z_m, k, stereo_fb_px_m)[3]


def _locking_terms(z_a, k, stereo_fb_px_m):
    """``f B k``, the sine and cosine of the matcher's disparity phase ``2 pi f B k / z_a``, and the basis
    ``z_a^2 / (f B k) (sin, cos)`` of :func:`pixel_locking_basis`."""
    fb = stereo_fb_px_m * k
    phase = 2 * np.pi * fb / z_a
    sin, cos = np.sin(phase), np.cos(phase)
    return fb, sin, cos, (z_a**2 / fb)[:, None] * np.stack([sin, cos], axis=1)


def corrected_points(q_obs: np.ndarray, k: float, c: float, a: float = 0.0, b: float = 0.0, stereo_fb_px_m=None):
    """Observed camera-frame points with the depth correction, on their rays ``r = q_obs / z_obs``.

    ``k q_obs + c r``, and with ``stereo_fb_px_m`` the pixel locking ``(a, b)`` (pixels) removed as well
    (:func:`pixel_locking_basis`). ``q_obs`` has shape (N, 3); so has the result.
    """
    if stereo_fb_px_m is None:
        return q_obs * (k + c / q_obs[:, 2])[:, None]
    z_a = k * q_obs[:, 2] + c
    z = z_a + pixel_locking_basis(z_a, k, stereo_fb_px_m) @ np.array([a, b])
    return q_obs * (z / q_obs[:, 2])[:, None]


def _locked_points_and_jacobian(q_obs, depth, stereo_fb_px_m):
    """:func:`corrected_points` with the locking, and ``dz / d(k, c, a, b)`` (N, 4), the phase computed once.

    ``z = z_a + z_a^2 / fb (a sin p + b cos p)``, ``p = 2 pi fb / z_a``, ``z_a = k z_obs + c``, ``fb = f B k``:
    the locking's phase moves with ``k`` and ``c``.
    """
    k, c, a, b = depth
    z_obs = q_obs[:, 2]
    z_a = k * z_obs + c
    fb, sin, cos, basis = _locking_terms(z_a, k, stereo_fb_px_m)
    e, de = a * sin + b * cos, a * cos - b * sin  # the disparity error and its derivative over the phase
    z = z_a + basis @ np.array([a, b])  # as corrected_points
    dz_dza = 1 + 2 * z_a / fb * e - 2 * np.pi * de
    dz_dfb = -((z_a / fb) ** 2) * e + 2 * np.pi * z_a / fb * de
    jacobian = np.column_stack([dz_dza * z_obs + dz_dfb * stereo_fb_px_m, dz_dza, basis])
    return q_obs * (z / z_obs)[:, None], jacobian


def _linearise(q_obs: np.ndarray, model: MatchedModel, T: np.ndarray, x: _Unknowns, jacobian: bool = True):
    """The residuals ``r`` (N,) at the current unknowns and their Jacobian (N, ``x.n_par``), pose columns first
    (None without ``jacobian``)."""
    R, t = T[:3, :3], T[:3, 3]
    m_base, n_base, d_base = model.points_base, model.normals_base, model.direction_base
    if x.delta is not None:  # the model moved by the joint offsets delta, its tangents turned with it
        m_base, n_base = moved_model(m_base, n_base, x.twists, x.delta)
        if d_base is not None:
            d_base = turned_directions(d_base, x.twists, x.delta)
    if x.theta is not None:  # the points' rays with the intrinsics theta
        q_obs, dray = rays_for(q_obs, x.K_ref, x.theta)
    if x.depth is None:
        p_cam = q_obs
    elif x.fb is None:
        p_cam = corrected_points(q_obs, *x.depth)
    else:
        p_cam, dz = _locked_points_and_jacobian(q_obs, x.depth, x.fb)
    x_base = p_cam @ R.T + t
    move = None
    if model.depth_variance is not None:
        ray_base = (p_cam / p_cam[:, 2:3]) @ R.T
        r, grad, move = residual_under_noise(
            x_base, m_base, n_base, model.curvatures, d_base, ray_base, model.depth_variance
        )
    elif model.curvatures is None:
        r, grad = np.einsum("ij,ij->i", n_base, x_base - m_base), n_base
    else:
        r, grad = second_order_residual(x_base, m_base, n_base, model.curvatures, d_base)
    if not jacobian:
        return r, None
    n_cam = grad @ R  # R^T grad, row-wise
    # the columns that hold the observed point, at the point moved back along its ray (residual_under_noise)
    p_at = p_cam if move is None else p_cam * (1.0 - move / p_cam[:, 2])[:, None]
    J = np.empty((len(r), x.n_par))  # each block written in place
    cross_rows(p_at, n_cam, out=J[:, :3])
    J[:, 3:6] = n_cam
    if x.depth is not None:
        ray = q_obs / q_obs[:, 2:3]
        n_ray = np.einsum("ij,ij->i", n_cam, ray)[:, None]
        if x.fb is None:
            J[:, 6] = np.einsum("ij,ij->i", n_cam, q_obs)
            if move is not None:  # d(k q + c ray)/dk = q at the raw depth whose corrected point is the moved one
                J[:, 6] -= n_ray[:, 0] * move / x.depth[0]
            J[:, 7:8] = n_ray
        else:
            if move is not None:  # the locking's columns too, at the raw depth whose corrected point is the moved one
                raw_move = move / (x.depth[0] * dz[:, 1])  # dz / dz_obs = k dz / dz_a
                dz = _locked_points_and_jacobian(q_obs * (1.0 - raw_move / q_obs[:, 2])[:, None], x.depth, x.fb)[1]
            np.multiply(n_ray, dz, out=J[:, x.depth_cols])
    if x.theta is not None:
        J[:, x.intrinsics_cols] = p_at[:, 2:3] * (n_cam[:, 0:1] * dray[:, 0] + n_cam[:, 1:2] * dray[:, 1])
    if x.delta is not None:
        J[:, x.joint_cols] = offset_columns(grad, m_base, x.twists)
    return r, J


class _Unknowns:
    """The unknowns beside the pose, in the order of the Jacobian's columns: the depth correction ``(k, c[, a, b])``,
    the intrinsics ``theta``, the joint offsets ``delta`` (each None where not estimated), at their current values."""

    def __init__(self, options: PlaneFitOptions, joint_twists: np.ndarray | None):
        o = options
        depth = None if o.depth_start is None else np.array(o.depth_start, dtype=float)
        self.fb = None if depth is None else o.stereo_fb_px_m
        if depth is not None:
            depth = depth[:2] if self.fb is None else np.r_[depth, np.zeros(4 - len(depth))]  # the locking starts at 0
        self.depth = depth
        self.K_ref = None if o.intrinsics_K_ref is None else np.asarray(o.intrinsics_K_ref, dtype=float)
        self.theta = None
        if self.K_ref is not None:
            start = o.intrinsics_start
            self.theta = intrinsics_vector(self.K_ref) if start is None else np.array(start, dtype=float)
        self.twists, self.delta = None, None
        if joint_twists is not None:
            self.twists = np.asarray(joint_twists, dtype=float)
            start = o.joint_start
            self.delta = np.zeros(self.twists.shape[1]) if start is None else np.array(start, dtype=float)
        n_depth = 0 if depth is None else len(depth)
        n_intr = 0 if self.theta is None else 4
        self.n_par = 6 + n_depth + n_intr + (0 if self.delta is None else len(self.delta))
        self.depth_cols = slice(6, 6 + n_depth)
        self.intrinsics_cols = slice(6 + n_depth, 6 + n_depth + n_intr)
        self.joint_cols = slice(6 + n_depth + n_intr, self.n_par)
        self.precision, self.mean = self._prior(options)
        self.has_prior = bool(self.precision.any())

    def _prior(self, options: PlaneFitOptions) -> tuple[np.ndarray, np.ndarray]:
        """Precision and mean of the Gaussian prior of each parameter (precision 0: none)."""
        o = options
        precision, mean = np.zeros(self.n_par), np.zeros(self.n_par)
        if self.depth is not None:
            mean[6] = 1.0
            if o.depth_prior_sigma is not None:
                precision[6:8] = 1.0 / np.square(np.asarray(o.depth_prior_sigma, dtype=float))
            if self.fb is not None:
                precision[8:10] = 1.0 / o.pixel_locking_prior_px**2
        if self.theta is not None and o.intrinsics_prior is not None:
            mean[self.intrinsics_cols] = np.asarray(o.intrinsics_prior[0], dtype=float)
            precision[self.intrinsics_cols] = 1.0 / np.square(np.asarray(o.intrinsics_prior[1], dtype=float))
        if self.delta is not None and o.joint_prior_sigma is not None:  # about 0
            precision[self.joint_cols] = 1.0 / np.square(np.asarray(o.joint_prior_sigma, dtype=float))
        return precision, mean

    def params(self) -> np.ndarray:
        """All parameters, the pose's right perturbation (zero at the current pose) first."""
        return np.concatenate([np.zeros(6), *(p for p in (self.depth, self.theta, self.delta) if p is not None)])

    def update(self, xi: np.ndarray) -> float:
        """Take the step ``xi``'s part beyond the pose; returns its share of the step's size: the depth scale's and
        offset's (the locking's pixels not; the intrinsics and the joint offsets not either: they follow the
        matches by hundredths of a pixel, the pose not)."""
        step = 0.0
        if self.depth is not None:
            self.depth = self.depth + xi[self.depth_cols]
            step = float(abs(xi[6]) + abs(xi[7]))
        if self.theta is not None:
            self.theta = self.theta + xi[self.intrinsics_cols]
        if self.delta is not None:
            self.delta = self.delta + xi[self.joint_cols]
        return step


def _prior_information(precision: np.ndarray, r: np.ndarray, w: np.ndarray) -> np.ndarray:
    """A prior of the given precisions as information in the units of ``J^T W J``: times the residual variance."""
    variance = float((w * r**2).sum() / max(float(w.sum()), 1.0))
    return np.diag(precision * variance)


def solve_point_to_plane(
    p_cam: np.ndarray,
    model: MatchedModel,
    T_base_cam: np.ndarray,
    options: PlaneFitOptions,
    group: np.ndarray | None = None,
    cross_group=None,
    pixel: np.ndarray | None = None,
    uv: np.ndarray | None = None,
) -> PlaneFit:
    """Camera pose from fixed point-to-plane matches (IRLS Gauss-Newton).

    Parameters
    ----------
    p_cam : array, shape (N, 3)
        Observed points, camera frame, metres (as the sensor reports them when the depth correction is
        estimated, ``options.depth_start``; they must then have ``z > 0``).
    model : MatchedModel
        The model point matched to each, with its normal (base frame), and optionally its curvature and its
        part's twists per joint.
    T_base_cam : array, shape (4, 4)
        Start.
    options : PlaneFitOptions
        The loss, the iterations, and which unknowns beside the pose are estimated, from which start, under
        which priors.
    group : array of int, shape (N,), optional
        Frame of each match, for the covariance; all one group when omitted.
    cross_group : array of int, shape (N,), or a sequence of them (None entries skipped), optional
        Further clusterings for the covariance (the depth bin of each match: the sensor's depth-dependent
        error is shared by all frames; its image tile: a fixed pattern is), multiway with ``group``
        (:func:`classic.clustered_covariance.clustered_covariance`).
    pixel : array of int, shape (N,), optional
        Image pixel of each match (any integer id), for ``options.pixel_effect``.
    uv : array of int, shape (N, 2), optional
        Image pixel of each match (column, row), for ``options.repeated_radius_px``.

    Returns
    -------
    PlaneFit
    """
    x = _Unknowns(options, model.joint_twists)
    pixel = compact_pixels(pixel) if options.pixel_effect and pixel is not None else None
    T, steps, step_norm = _gauss_newton(p_cam, model, np.array(T_base_cam, dtype=float), x, options, pixel)
    # the Jacobian at the answer only where the covariance or the pixel effect needs it: the residuals otherwise
    r, J = _linearise(p_cam, model, T, x, jacobian=options.covariance or pixel is not None)
    w = loss_weights(r / options.scale_m, options.loss, 1.0)
    if pixel is not None:  # the covariance of the rows with each pixel's effect taken out
        reduction = _pixel_reduction(p_cam, J, r, w, pixel)
        if reduction is not None:
            J, r = reduced_rows(J, r, *reduction[2:])
    groups = np.zeros(len(r), dtype=np.int64) if group is None else np.asarray(group)
    correction = None if x.depth is None else tuple(float(v) for v in x.depth)
    fit = PlaneFit(T, None, r, w, groups, steps, step_norm, correction, intrinsics=x.theta, joint_offsets=x.delta)
    if not options.covariance:
        return fit
    prior = _prior_information(x.precision, r, w) if x.has_prior else None
    cov = clustered_covariance(J, r, w, group, prior, cross_group)
    fit.covariance = cov[:6, :6]
    if uv is not None and options.repeated_radius_px > 0:
        gain = pixel_gain(J[:, 3:6], p_cam)  # the translation's columns are the normals in the camera frame
        fit.repeated = repeated_error_covariance(J, r, w, gain, uv, groups, prior, options.repeated_radius_px)
        if x.theta is not None:  # the intrinsics' share of it, which their frame-clustered covariance omits
            e = x.intrinsics_cols
            fit.repeated["intrinsics_covariance"] = fit.repeated["covariance"][e, e]
    if x.n_par > 6:
        frames = cov if cross_group is None else clustered_covariance(J, r, w, group, prior)
        _set_covariances(fit, x, cov, frames)
    return fit


def _pixel_reduction(p_cam, J, r, w, pixel):
    """:func:`classic.markerless.pixel_effect.schur_reduction` with the effect's sigma and the temporal variance
    measured from ``r`` (their one-way split), and the rows' gains; None where the residuals show no per-pixel
    effect."""
    gain = pixel_gain(J[:, 3:6], p_cam)  # the translation's columns are the normals in the camera frame
    sigma_p, variance = pixel_variance_components(r, w, gain, pixel)
    if not sigma_p > 0:
        return None
    dH, dg, pix, coef = schur_reduction(J, r, w, gain, pixel, sigma_p, variance)
    return dH, dg, gain, pix, coef


def _gauss_newton(
    p_cam: np.ndarray, model: MatchedModel, T: np.ndarray, x: _Unknowns, options: PlaneFitOptions, pixel=None
):
    """Iteratively reweighted Gauss-Newton from the pose ``T`` and the unknowns ``x`` (updated in place); returns
    the pose, the steps taken and the last step's size. With ``pixel``, each pixel's effect marginalised."""
    step_norm, steps = np.inf, 0
    for steps in range(1, options.iterations + 1):
        r, J = _linearise(p_cam, model, T, x)
        w = loss_weights(r / options.scale_m, options.loss, 1.0)
        Jw = J * w[:, None]
        H = Jw.T @ J
        g = Jw.T @ r
        reduction = None if pixel is None else _pixel_reduction(p_cam, J, r, w, pixel)
        if reduction is not None:
            H, g = H - reduction[0], g - reduction[1]
        if x.has_prior:
            # the prior in the residuals' units: their variance over the prior's
            P = _prior_information(x.precision, r, w)
            H = H + P
            g = g + P @ np.where(x.precision > 0, x.params() - x.mean, 0.0)
        # a ridge of 1e-12 relative: a direction the data do not fix stays put instead of running away
        xi = -np.linalg.solve(H + 1e-12 * np.trace(H) * np.eye(x.n_par), g)
        T = apply_right(T, xi[:6])
        step_norm = float(np.linalg.norm(xi[:3]) + np.linalg.norm(xi[3:6])) + x.update(xi)
        if step_norm < options.tol:
            break
    return T, steps, step_norm


def _set_covariances(fit: PlaneFit, x: _Unknowns, cov: np.ndarray, frames: np.ndarray) -> None:
    """The fit's covariances of the unknowns beside the pose, two-way (``cov``) and frame-clustered (``frames``)."""
    d, e, j = x.depth_cols, x.intrinsics_cols, x.joint_cols
    if x.depth is not None:
        fit.depth_covariance, fit.depth_covariance_frames = cov[d, d], frames[d, d]
        if x.theta is not None:  # the depth's spread given the intrinsics: the depth range's part alone
            fit.depth_covariance_frames = frames[d, d] - frames[d, e] @ np.linalg.pinv(frames[e, e]) @ frames[e, d]
    if x.theta is not None:
        fit.intrinsics_covariance, fit.intrinsics_covariance_frames = cov[e, e], frames[e, e]
    if x.delta is not None:
        fit.joint_offsets_covariance, fit.joint_offsets_covariance_frames = cov[j, j], frames[j, j]
