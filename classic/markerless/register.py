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

A result is accepted only when most of the visible model is matched, the
residual is of the depth noise's size, the frames calibrate the depth and the last step has converged;
otherwise it is refused with the reason (:attr:`MarkerlessResult.refused`),
never returned as a calibration. What it achieves: ``docs/benchmarks/markerless.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from classic.clustered_covariance import pose_sigma
from classic.markerless.consistency import frame_splits, split_excess
from classic.markerless.depth import backproject, depth_noise_curve, mixed_pixels, moving_mask, static_depth
from classic.markerless.intrinsics import camera_matrix, intrinsics_summary, intrinsics_vector, rays_for
from classic.markerless.kinematics import JOINT_OFFSET_PRIORS_DEG, joint_offsets_summary, joint_status, moved_surface
from classic.markerless.point_to_plane import (
    MatchedModel,
    PlaneFit,
    PlaneFitOptions,
    corrected_points,
    solve_point_to_plane,
)
from classic.markerless.visibility import project, visible_points
from handeye.core.errors import HandEyeInputError, NonFiniteError, ShapeError
from handeye.core.metrics import pose_error
from handeye.core.rigid import rigid_transform
from handeye.core.se3 import invert_transform
from handeye.core.validation import check_transforms

__all__ = ["RobotSurfaceFrames", "MarkerlessOptions", "MarkerlessResult", "register_robot", "RefusedError"]

_FRAME_KEY_M = 1000.0  # frames kept apart in the KD-tree by this offset on a 4th coordinate


class RefusedError(HandEyeInputError):
    """Raised by :meth:`MarkerlessResult.require` when the registration refused to answer."""


@dataclass
class RobotSurfaceFrames:
    """The robot's surface at every frame, base frame, stacked.

    Attributes
    ----------
    points_base : array, shape (M, 3)
        Surface samples, metres.
    normals_base : array, shape (M, 3)
        Outward unit normals.
    frame : array of int, shape (M,)
        Frame index (0..N-1) of each sample.
    part : array of int, shape (M,)
        Rigid part (link mesh) of each sample; parts whose position changes between frames
        are "moving" (found from the data, not from names).
    curvatures : array, shape (M, 2), optional
        Principal curvatures ``kappa_1 >= kappa_2`` of each sample, 1/m (convex positive), from
        :func:`classic.markerless.curvature.sample_curvatures`. With them the fine stage's residual
        is second order; without, first order (biased by a fraction of a millimetre on curved links).
    direction_base : array, shape (M, 3), optional
        Unit tangent along ``kappa_1``, base frame; given with ``curvatures``.
    joint_twists_base : array, shape (N_frames, n_parts, n_joints, 6), optional
        Each part's motion per joint at each frame, ``(omega, v)`` in the base frame: a point ``p`` of the part
        moves by ``omega x p + v`` per radian of the joint
        (:meth:`handeye.robot.surface.RobotSurface.joint_twists`). Given, the joints' zero offsets can be
        estimated with the pose (:mod:`classic.markerless.kinematics`).
    """

    points_base: np.ndarray
    normals_base: np.ndarray
    frame: np.ndarray
    part: np.ndarray
    curvatures: np.ndarray | None = None
    direction_base: np.ndarray | None = None
    joint_twists_base: np.ndarray | None = None

    def __post_init__(self):
        m = len(self.points_base)
        for name in ("points_base", "normals_base"):
            setattr(self, name, _surface_array(name, getattr(self, name), (m, 3)))
        for name in ("frame", "part"):
            a = np.asarray(getattr(self, name)).astype(np.int64)
            if a.shape != (m,):
                raise ShapeError(f"surface {name} must be (M,), got {a.shape}")
            setattr(self, name, a)
        if (self.curvatures is None) != (self.direction_base is None):
            raise HandEyeInputError("surface curvatures and direction_base are given together or not at all")
        if self.curvatures is not None:
            for name, cols in (("curvatures", 2), ("direction_base", 3)):
                setattr(self, name, _surface_array(name, getattr(self, name), (m, cols)))
        if self.joint_twists_base is not None:
            a = np.asarray(self.joint_twists_base, dtype=float)
            need = (int(self.frame.max()) + 1, int(self.part.max()) + 1) if m else (0, 0)
            if a.ndim != 4 or a.shape[3] != 6 or a.shape[0] < need[0] or a.shape[1] < need[1]:
                raise ShapeError(
                    f"surface joint_twists_base must be (N_frames >= {need[0]}, n_parts >= {need[1]}, n_joints, 6), "
                    f"got {a.shape}"
                )
            if not np.all(np.isfinite(a)):
                raise NonFiniteError("surface joint_twists_base has NaN or inf")
            self.joint_twists_base = a


def _surface_array(name: str, a, shape: tuple) -> np.ndarray:
    """``a`` as floats of ``shape`` ``(M, k)``, all finite, or the error that names the surface's ``name``."""
    a = np.asarray(a, dtype=float)
    if a.shape != shape:
        raise ShapeError(f"surface {name} must be (M, {shape[1]}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"surface {name} has NaN or inf")
    return a


@dataclass(frozen=True)
class MarkerlessOptions:
    """Settings of :func:`register_robot` (defaults fit RGB-D sensors at 0.5-3 m).

    Attributes
    ----------
    depth_sigma_m_at_1m : float or None
        Depth noise sigma at 1 m, growing with depth squared (a sensor profile's figure); sets the robust
        scales and the expected residual. None (the default): measured on the static background of the
        frames, at every depth (:func:`classic.markerless.depth.depth_noise_curve`), 1 mm at 1 m where
        too little background has depth in every frame.
    depth_model : {"scale-offset", "fixed"}
        ``"scale-offset"`` (the default) estimates the sensor's depth scale and offset with the pose;
        ``"fixed"`` takes the depth as exact.
    depth_scale_prior_sigma : float
        Spread of the sensor's depth scale ``s - 1`` before the data (a datasheet's figure: 1 % by default;
        consumer RGB-D cameras quote 1-2 % of the distance as a bound).
    depth_offset_prior_sigma_m : float
        Spread of its depth offset before the data, metres (5 mm by default).
    max_depth_prior_share : float
        Refused when the data leave the depth scale's or offset's sigma above this share of its prior's: the
        frames span too little range of depth to calibrate it, and the answer would rest on the datasheet.
    stereo_fb_px_m : float or None
        An active-stereo sensor's disparity constant ``f B``: its depth camera's focal length in pixels at the
        resolution it matches at, times its baseline in metres (a D435 at 848x480: about 447 x 0.050). Given,
        the matcher's sub-pixel bias periodic in disparity (pixel locking) is estimated with the scale and
        offset and reported (:mod:`classic.markerless.point_to_plane`). None (the default): not modelled.
    pixel_locking_prior_px : float
        Spread of that bias before the data, pixels (0.25 by default).
    intrinsics_model : {"estimate", "fixed"}
        ``"estimate"`` (the default) estimates the depth camera's ``(f_x, f_y, c_x, c_y)`` with the pose, under a
        prior of the camera matrix given and ``intrinsics_prior_sigma``; ``"fixed"`` takes the camera matrix as
        exact.
    intrinsics_prior_sigma : tuple of 4 float
        Stated uncertainty of the camera matrix given: ``f_x`` and ``f_y`` relative, ``c_x`` and ``c_y`` in pixels
        (one sigma; a factory-calibrated D435-class camera's 0.7 % and 3 px by default,
        :data:`classic.markerless.intrinsics.INTRINSICS_PRIORS` per profile).
    intrinsics_determined_share : float
        A parameter counts as determined by the frames where they leave its sigma below this share of the
        prior's (reported, not a refusal: an undetermined one stays near the value given, its prior in the sigma).
    joint_offsets_model : {"estimate", "fixed"}
        ``"estimate"`` (the default) estimates the robot's joint zero offsets with the pose where the surface
        carries its twists per joint (:attr:`RobotSurfaceFrames.joint_twists_base`; without them they are taken as
        exact, and the result says so), under a prior about 0 of ``joint_offset_prior_deg``; ``"fixed"`` takes
        the recorded joints as exact. A joint that moves every fitted part rigidly (the base rotation) is never
        estimated (:mod:`classic.markerless.kinematics`).
    joint_offset_prior_deg : float or tuple of float
        One sigma of each joint's zero offset, degrees (one value for every joint, or one per joint): a UR-class
        arm's 0.2 by default (:data:`classic.markerless.kinematics.JOINT_OFFSET_PRIORS_DEG`, with its reasoning).
    joint_offset_determined_share : float
        A joint counts as determined by the frames where they leave its sigma below this share of the prior's.
    depth_extrinsic_sigma_m : float
        Uncertainty of the depth-to-colour extrinsic per axis, metres (a sensor profile's figure): the
        registration finds the depth camera, the board and the learned model the colour camera; added to
        the translation sigma.
    depth_extrinsic_sigma_deg : float
        Uncertainty of the depth-to-colour extrinsic's rotation per axis, degrees (a sensor profile's figure).
        Depth aligned to the colour image through an extrinsic turned by ``theta`` is the depth of a camera turned
        by ``theta``: the registration finds that camera, exactly, and no depth can tell it from the colour one
        (measured: a tilt of 0.5 degrees came out as the pose's, not as a shift of the principal point). Bounded:
        added to the rotation sigma. A pure shift of the depth image against the camera model (an alignment
        that is off by pixels) is the principal point's error and is estimated with it
        (``intrinsics_model="estimate"``). :attr:`MarkerlessResult.registration` says which part was estimated and
        which bounded.
    min_moving_pixels : int
        Fewer moving pixels in all frames than this: refused (the arm is not in view).
    min_matched_fraction : float
        Fraction of the visible model that must land on the observed surface.
    max_residual_ratio : float
        Inlier RMS residual at most this times the expected noise plus the model floor.
    model_floor_m : float
        Residual the model itself leaves (mesh detail, unmodelled cables), metres.
    model_radius_m : float
        Radius of the robot's thinnest rounded links (the UR's are 4 cm and more): with the pixel
        footprint it bounds the model's sampling bias, a term of the reported sigma.
    coarse_windows_m : tuple of float
        Match windows of the coarse stage, widest first.
    fine_iterations : int
    max_points : int
        Moving pixels used by the coarse stage (a random subset beyond this).
    max_model_points : int
        Model points used by the coarse stages (a random subset beyond this).
    zbuffer_stride : int
        Image pixels per z-buffer pixel: 1 when the model's sample spacing is below the pixel
        footprint, 2 when below two (the front chooses the spacing to match).
    depth_clusters : int
        Depth bins (equal counts) of the covariance's second clustering: a sensor's depth-dependent error is
        shared by every frame at that depth. Below 2: clustered by frame only.
    image_tiles : int
        Square image tiles across the image's width of a third clustering of the covariance (multiway with the
        frames and the depth bins): a sensor's fixed pattern, an error the same in every frame at one image
        position, is shared by every frame in that tile. Below 2 (0, the default): not clustered by tile. Off
        by default: on the d435 benchmarks it did not widen the sigma where a fixed pattern was added, and it
        widened it on clean depth (``benchmarks/results/markerless_sensor_errors.md``).
    split_check : bool
        Solve groups of the frames (by depth, by the arm's image column) again and add their scatter beyond
        their own noise to the sigma (:mod:`classic.markerless.consistency`): errors the frames share by depth or image
        position, which the clustered covariance cannot see. True by default.
    static_parts : bool
        Fit the parts of the robot that do not move over the recording (the base, a joint held still) as
        well. False (the default): the fine stage fits the moving parts only. A static part is seen the same
        way in every frame, so whatever error the sensor makes on it (an active-stereo unit's fixed projector
        pattern, multipath, a flat-field error) is one error repeated in every frame: it biases the pose and
        the frames cannot reveal it. The moving parts, seen anew in every frame, carry the calibration. With no
        part moving, the static ones are used.
    seed : int
    """

    depth_sigma_m_at_1m: float | None = None
    depth_model: str = "scale-offset"
    depth_scale_prior_sigma: float = 0.01
    depth_offset_prior_sigma_m: float = 0.005
    stereo_fb_px_m: float | None = None
    pixel_locking_prior_px: float = 0.25
    max_depth_prior_share: float = 0.5
    intrinsics_model: str = "estimate"
    intrinsics_prior_sigma: tuple = (0.007, 0.007, 3.0, 3.0)
    intrinsics_determined_share: float = 0.5
    joint_offsets_model: str = "estimate"
    joint_offset_prior_deg: float | tuple = JOINT_OFFSET_PRIORS_DEG["ur"]
    joint_offset_determined_share: float = 0.5
    depth_extrinsic_sigma_m: float = 0.0
    depth_extrinsic_sigma_deg: float = 0.0
    min_moving_pixels: int = 200
    min_matched_fraction: float = 0.6
    max_residual_ratio: float = 3.0
    model_floor_m: float = 0.0015
    model_radius_m: float = 0.04
    coarse_windows_m: tuple = (0.3, 0.2, 0.12, 0.08, 0.05, 0.03, 0.02, 0.01)
    fine_iterations: int = 20
    max_points: int = 20000
    max_model_points: int = 300000
    zbuffer_stride: int = 1
    depth_clusters: int = 12
    image_tiles: int = 0
    split_check: bool = True
    static_parts: bool = False
    seed: int = 0

    def __post_init__(self):
        self._check_depth_model()
        self._check_intrinsics_model()
        self._check_sigmas()
        self._check_joint_offsets_model()

    def _check_depth_model(self):
        """The depth model, its priors and the stereo matcher's constant."""
        if self.depth_model not in ("scale-offset", "fixed"):
            raise HandEyeInputError(f"depth_model must be 'scale-offset' or 'fixed', got {self.depth_model!r}")
        priors = (self.depth_scale_prior_sigma, self.depth_offset_prior_sigma_m)
        if self.depth_model == "scale-offset" and not min(priors) > 0:
            raise HandEyeInputError(
                "depth_model 'scale-offset' needs positive prior sigmas of the scale and offset; a sensor known "
                "exactly is depth_model='fixed'"
            )
        fb = self.stereo_fb_px_m
        if fb is not None:
            if not (np.isfinite(fb) and fb > 0):
                raise HandEyeInputError(f"stereo_fb_px_m must be None or a positive disparity constant, got {fb}")
            if self.depth_model != "scale-offset":
                raise HandEyeInputError(
                    "stereo_fb_px_m models the stereo matcher's bias; it needs depth_model='scale-offset'"
                )
            if not self.pixel_locking_prior_px > 0:
                raise HandEyeInputError(f"pixel_locking_prior_px must be positive, got {self.pixel_locking_prior_px}")

    def _check_intrinsics_model(self):
        """The intrinsics model and its prior sigmas."""
        if self.intrinsics_model not in ("estimate", "fixed"):
            raise HandEyeInputError(f"intrinsics_model must be 'estimate' or 'fixed', got {self.intrinsics_model!r}")
        prior = np.asarray(self.intrinsics_prior_sigma, dtype=float)
        if self.intrinsics_model == "estimate" and not (
            prior.shape == (4,) and np.all(np.isfinite(prior)) and np.all(prior > 0)
        ):
            raise HandEyeInputError(
                "intrinsics_model 'estimate' needs four positive prior sigmas (fx, fy relative; cx, cy pixels), got "
                f"{self.intrinsics_prior_sigma!r}; a camera matrix known exactly is intrinsics_model='fixed'"
            )

    def _check_sigmas(self):
        """The depth-to-colour extrinsic's sigmas and the depth noise given: finite, at least 0."""
        for key in ("depth_extrinsic_sigma_m", "depth_extrinsic_sigma_deg"):
            value = getattr(self, key)
            if not (np.isfinite(value) and value >= 0):
                raise HandEyeInputError(f"{key} must be a finite value >= 0, got {value}")
        sigma = self.depth_sigma_m_at_1m
        if sigma is not None and not (np.isfinite(sigma) and sigma >= 0):
            raise HandEyeInputError(f"depth_sigma_m_at_1m must be None or a finite value >= 0, got {sigma}")

    def _check_joint_offsets_model(self):
        """The joint offsets model and its prior sigmas."""
        if self.joint_offsets_model not in ("estimate", "fixed"):
            raise HandEyeInputError(
                f"joint_offsets_model must be 'estimate' or 'fixed', got {self.joint_offsets_model!r}"
            )
        joint_prior = np.atleast_1d(np.asarray(self.joint_offset_prior_deg, dtype=float))
        if self.joint_offsets_model == "estimate" and not (
            joint_prior.ndim == 1 and len(joint_prior) and np.all(np.isfinite(joint_prior)) and np.all(joint_prior > 0)
        ):
            raise HandEyeInputError(
                "joint_offsets_model 'estimate' needs positive prior sigmas (degrees, one or one per joint), got "
                f"{self.joint_offset_prior_deg!r}; joints known exactly are joint_offsets_model='fixed'"
            )


@dataclass
class MarkerlessResult:
    """A camera pose from the robot's surface, or a refusal with its reason.

    Attributes
    ----------
    T_base_cam : array, shape (4, 4) or None
        None when refused.
    refused : str or None
        Why no answer is given (too few robot pixels, did not converge, residual too large,
        start outside the basin); None when accepted.
    covariance : array, shape (6, 6)
        Of the camera's rotation (rad, camera frame) and position (m, camera frame).
    sigma : dict
        ``rotation_deg`` and ``translation_mm``: predicted RMS error of the estimate, in quadrature: the noise
        the frame-clustered covariance sees, the model's sampling bias bound, the frames' disagreement between
        groups (``diagnostics`` ``sigma_noise``, ``sigma_sampling``, ``sigma_consistency``), and the bounded part
        of the depth-to-colour registration (``registration``).
    residual_mm_per_frame : array, shape (N,)
        RMS point-to-plane residual of the matched points of each frame.
    matched_fraction : float
        Visible model points landing on the observed surface, over all frames.
    start : str
        Which start led to the answer.
    diagnostics : dict
        Among others ``fitted_parts``: ``"moving"`` (the fine stage fitted the parts that move over the recording)
        or ``"all"`` (``static_parts``, or no part moved).
    depth : dict
        The sensor's depth as the registration found it: ``model``, and with ``"scale-offset"`` the
        ``scale`` and ``offset_mm`` of ``d_obs = scale d + offset`` with their sigmas (``scale_sigma``,
        ``offset_sigma_mm``); ``observability``: the same sigmas from the frames' spread alone (given the
        intrinsics), which decide a refusal for too little depth range; ``range_m`` (the matched depths' 10th
        and 90th percentiles), and the
        noise used (``noise_source``, ``noise_mm_at_median_depth``). With ``stereo_fb_px_m``, ``pixel_locking_px``:
        the matcher's disparity error ``sin`` and ``cos`` coefficients (pixels) with their sigmas, and its
        ``amplitude``.
    intrinsics : dict
        The depth camera's intrinsics as the registration found them: ``model`` (``"estimated"`` or ``"fixed"``),
        ``given`` (``f_x, f_y, c_x, c_y`` of the camera matrix given), and when estimated per name (``fx``,
        ``fy``, ``cx``, ``cy``) the ``estimate``, its ``change`` from the value given, ``sigma``,
        ``prior_sigma``, ``ratio`` (what the frames leave of the sigma over the prior's) and ``determined``
        (the ratio below ``intrinsics_determined_share``); pixels.
    registration : dict
        How the depth-to-colour registration was treated, per part: ``shift_px`` (the depth image's shift against
        the camera model: ``estimated`` with the principal point, its change ``dx``, ``dy`` and ``sigma``; or
        ``taken as exact`` with the intrinsics fixed), ``rotation`` and ``translation`` of the depth-to-colour
        extrinsic (``bounded``: the sigma per axis, ``sigma_deg`` or ``sigma_mm``, added to the pose's over the
        three axes as ``rss_deg``, ``rss_mm``).
    joint_offsets : dict
        The robot's joint zero offsets (true joint = recorded + offset) as the registration found them: ``model``
        (``"estimated"`` or ``"fixed"``, with a ``reason`` when fixed for want of twists), and when estimated
        ``joints``: per joint its ``status`` (``"estimated"``; ``"absorbed"``: it moves every fitted part
        rigidly, so its offset is part of the pose, which is then the camera in the robot's kinematic base frame;
        ``"not seen"``), ``estimate_deg``, ``sigma_deg``, ``prior_sigma_deg``, ``ratio`` (what the frames leave
        of the sigma over the prior's) and ``determined``; ``note`` on the absorbed ones.
    """

    T_base_cam: np.ndarray | None
    refused: str | None
    covariance: np.ndarray
    sigma: dict
    residual_mm_per_frame: np.ndarray
    matched_fraction: float
    start: str
    diagnostics: dict = field(default_factory=dict)
    depth: dict = field(default_factory=dict)
    intrinsics: dict = field(default_factory=dict)
    registration: dict = field(default_factory=dict)
    joint_offsets: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.refused is None

    def require(self) -> np.ndarray:
        """``T_base_cam``, or :class:`RefusedError` with the reason."""
        if self.refused is not None:
            raise RefusedError(f"markerless registration refused: {self.refused}")
        return self.T_base_cam

    def to_dict(self) -> dict:
        """JSON-serialisable summary."""
        from handeye.core.se3 import pos_quat_xyzw_from_transform

        out = {
            "status": "ok" if self.ok else "refused",
            "refused": self.refused,
            "start": self.start,
            "matched_fraction": self.matched_fraction,
            "sigma": self.sigma,
            "depth": self.depth,
            "intrinsics": self.intrinsics,
            "joint_offsets": self.joint_offsets,
            "registration": self.registration,
            "residual_mm_per_frame": [float(x) for x in self.residual_mm_per_frame],
            "diagnostics": self.diagnostics,
        }
        if self.T_base_cam is not None:
            t, q = pos_quat_xyzw_from_transform(self.T_base_cam)
            out["T_base_cam"] = {
                "matrix": self.T_base_cam.tolist(),
                "translation_m": t.tolist(),
                "quaternion_xyzw": q.tolist(),
            }
        return out


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


def _moving_parts(surface: RobotSurfaceFrames) -> np.ndarray:
    """Whether each sample's part moves between frames: the RMS spread of its centroid over the frames above 2 cm."""
    n_parts, n_fr = int(surface.part.max()) + 1, int(surface.frame.max()) + 1
    key = surface.part * n_fr + surface.frame
    count = np.bincount(key, minlength=n_parts * n_fr).reshape(n_parts, n_fr)
    sums = np.stack(
        [np.bincount(key, surface.points_base[:, k], minlength=n_parts * n_fr) for k in range(3)], axis=-1
    ).reshape(n_parts, n_fr, 3)
    spread = np.zeros(n_parts)
    for k in range(n_parts):
        seen = count[k] > 0
        cent = sums[k, seen] / count[k, seen, None]
        spread[k] = np.sqrt(((cent - cent.mean(0)) ** 2).sum(1).mean()) if len(cent) > 1 else 0.0
    return spread[surface.part] > 0.02


#: Depth noise taken when it can be neither measured nor was given: 1 mm at 1 m, growing with depth squared.
FALLBACK_SIGMA_M_AT_1M = 0.001


class _Outcome(NamedTuple):
    """The fine stage's outcome from one start (:meth:`_Problem.fine`); ``fit`` None: too few points matched."""

    name: str  # the start's
    T: np.ndarray  # T_base_cam
    fit: PlaneFit | None  # the last fit, on the last matches
    step: float  # the last step, rad + m
    matched: float  # the visible model's fraction landing on the observed surface
    geometry: tuple | None = None  # the matched points' median depth and RMS spread about their centroid, metres
    depth_range: tuple | None = None  # their depths' 10th and 90th percentiles, metres
    matches: tuple | None = None  # (model points, frames, observed points) of the last fit


class _Problem:
    """Everything the stages share for one camera placement."""

    def __init__(self, depth_m, K, surface, opts):
        self.K, self.s, self.opts = K, surface, opts
        self.depth_correction = (1.0, 0.0)  # (k, c[, a, b]), estimated by the fine stage
        # the camera matrix given, which back-projects the depth once (self.P), and the intrinsics estimated,
        # which project the model (self.K)
        self.K_given = K
        self.theta_given = intrinsics_vector(K)
        self.theta = self.theta_given
        self.estimate_intrinsics = opts.intrinsics_model == "estimate"
        relative = np.array([self.theta_given[0], self.theta_given[1], 1.0, 1.0])
        self.intrinsics_prior_sigma = np.asarray(opts.intrinsics_prior_sigma, dtype=float) * relative
        if opts.depth_sigma_m_at_1m is not None:
            self.noise_z, self.noise_sigma, self.noise_source = None, None, "given"
        else:
            self.noise_z, self.noise_sigma = depth_noise_curve(depth_m)
            self.noise_source = "measured on the static background" if len(self.noise_z) else "fallback 1 mm at 1 m"
        # pixels that straddle a depth edge report a depth between its two surfaces: treated as missing
        mixed = mixed_pixels(depth_m, np.maximum(0.005, 4 * self.sigma_z(np.where(depth_m > 0, depth_m, 1.0))))
        self.n_mixed = int(mixed.sum())
        depth_m = np.where(mixed, 0.0, depth_m)
        self.n, self.h, self.w = depth_m.shape
        self.P = backproject(depth_m, K)  # (N, H, W, 3), NaN without depth, as the sensor reports it
        static = static_depth(depth_m)
        # moved there: nearer than the static depth by 2 cm or six depth-noise sigmas, whichever is larger
        z = np.where(depth_m > 0, depth_m, 1.0)
        moving = moving_mask(depth_m, static, np.maximum(0.02, 6 * self.sigma_z(z)))
        # the arm moves as a body, many pixels wide; what moves in a line a pixel or two wide is the sensor's
        # (flying pixels along static edges, holes that come and go): an opening keeps bodies only
        self.moving = ndimage.binary_opening(moving, structure=np.ones((1, 3, 3), bool))
        f, r, c = np.nonzero(self.moving)
        self.n_moving = len(f)
        rng = np.random.default_rng(opts.seed)
        if len(f) > opts.max_points:
            keep = np.sort(rng.choice(len(f), opts.max_points, replace=False))
            f, r, c = f[keep], r[keep], c[keep]
        self.moving_frame, self.moving_p_cam = f, self.P[f, r, c]
        self.moving_part = _moving_parts(surface)
        # the model points the fine stage fits: the moving parts' (MarkerlessOptions.static_parts)
        self.fitted_part = self.moving_part if self.moving_part.any() and not opts.static_parts else None
        self._init_joints(surface, opts)  # the joints whose offsets the fine stage estimates
        # the coarse stages work on a subset of the model (their windows are centimetres)
        m = len(surface.frame)
        self.coarse_subset = (
            np.sort(rng.choice(m, opts.max_model_points, replace=False)) if m > opts.max_model_points else np.arange(m)
        )
        cs = self.coarse_subset
        self.tree = cKDTree(np.c_[surface.points_base[cs], surface.frame[cs] * _FRAME_KEY_M])

    def sigma_z(self, z):
        """Depth noise sigma at depth ``z`` (metres): given, or measured, or the fallback."""
        if self.opts.depth_sigma_m_at_1m is not None:
            return self.opts.depth_sigma_m_at_1m * np.asarray(z) ** 2
        if self.noise_z is None or len(self.noise_z) == 0:
            return FALLBACK_SIGMA_M_AT_1M * np.asarray(z) ** 2
        if len(self.noise_z) == 1:
            return np.full(np.shape(z), self.noise_sigma[0])
        return np.interp(z, self.noise_z, self.noise_sigma)

    def _init_joints(self, surface, opts):
        """Which joints' offsets the fine stage estimates (:func:`classic.markerless.kinematics.joint_status`)."""
        self._moved = (surface.points_base, surface.normals_base)  # the model while no offset moves it (model())
        self.joint_estimated, self.joint_status = None, None
        twists = surface.joint_twists_base
        if twists is None or opts.joint_offsets_model != "estimate":
            self.joint_offsets = np.zeros(0 if twists is None else twists.shape[2])
            return
        n_joints = twists.shape[2]
        prior = np.atleast_1d(np.asarray(opts.joint_offset_prior_deg, dtype=float))
        if len(prior) not in (1, n_joints):
            raise HandEyeInputError(
                f"joint_offset_prior_deg has {len(prior)} values for a robot of {n_joints} joints "
                f"(give 1 or {n_joints})"
            )
        self.joint_prior_sigma = np.radians(np.broadcast_to(prior, (n_joints,))).copy()
        fitted = np.ones(len(surface.part), bool) if self.fitted_part is None else self.fitted_part
        self.joint_status = joint_status(twists, surface.frame[fitted], surface.part[fitted])
        self.joint_estimated = np.array([s == "estimated" for s in self.joint_status])
        self.joint_offsets = np.zeros(n_joints)
        # rigid over the moving parts (the base rotation): estimated only where static parts are fitted, and kept
        # only where they determine it (hold_undetermined)
        moving = fitted & self.moving_part if self.moving_part.any() else fitted
        self.joint_rigid = np.array(
            [s == "absorbed" for s in joint_status(twists, surface.frame[moving], surface.part[moving])]
        )
        if not self.joint_estimated.any():
            self.joint_estimated = None

    def hold_undetermined(self, fit) -> bool:
        """Hold at 0 the joints rigid over the moving parts that the fitted static parts did not determine.

        With static parts fitted, the base rotation's offset is estimated: the base does not turn with it. A
        round base cannot tell it from the camera's rotation about the base's axis, and it would stay at its prior
        with the prior's sigma in the pose's; it is then absorbed into the pose as with the moving parts alone
        (the camera in the kinematic base frame). Returns whether any joint was held (the fit is to be redone).
        """
        if self.joint_estimated is None or fit.joint_offsets_covariance_frames is None:
            return False
        est = np.flatnonzero(self.joint_estimated)
        sd = np.sqrt(np.maximum(np.diag(fit.joint_offsets_covariance_frames), 0.0))
        share = self.opts.joint_offset_determined_share
        weak = [j for i, j in enumerate(est) if self.joint_rigid[j] and sd[i] >= share * self.joint_prior_sigma[j]]
        if not weak:
            return False
        delta = self.joint_offsets.copy()
        for j in weak:
            self.joint_estimated[j], self.joint_status[j], delta[j] = False, "absorbed", 0.0
        self.set_joint_offsets(delta)
        if not self.joint_estimated.any():
            self.joint_estimated = None
        return True

    def set_joint_offsets(self, delta):
        """Move the model by the joint offsets ``delta`` (radians, all joints) from now on."""
        self.joint_offsets = np.asarray(delta, dtype=float)
        self._moved = None if self.joint_offsets.any() else (self.s.points_base, self.s.normals_base)

    def model(self, idx):
        """The points and normals (base frame) of the model points ``idx``, moved by the current joint offsets."""
        s = self.s
        if self._moved is not None:
            return self._moved[0][idx], self._moved[1][idx]
        return moved_surface(
            s.points_base[idx], s.normals_base[idx], s.frame[idx], s.part[idx], s.joint_twists_base, self.joint_offsets
        )

    def set_intrinsics(self, theta):
        """Project the model with the intrinsics ``theta`` ``(f_x, f_y, c_x, c_y)`` from now on."""
        self.theta = np.asarray(theta, dtype=float)
        self.K = camera_matrix(self.theta)

    def corrected(self, q_obs):
        """Observed camera-frame points with the current intrinsics and depth correction."""
        if not np.array_equal(self.theta, self.theta_given):
            with np.errstate(invalid="ignore", divide="ignore"):  # points without depth stay NaN
                q_obs = rays_for(q_obs, self.K_given, self.theta)[0]
        if self.depth_correction == (1.0, 0.0):
            return q_obs
        return corrected_points(q_obs, *self.depth_correction, stereo_fb_px_m=self.opts.stereo_fb_px_m)

    # -- visibility

    def visible(self, T_base_cam, subset=None):
        """Visible model points (indices into the whole model), their pixels and camera-frame points.

        The z-buffer's pixels are ``zbuffer_stride`` image pixels wide (twice that on a ``subset``),
        as sparse as the model's samples; each visible point's pixel is where it projects in the image.
        """
        T_cam_base = invert_transform(T_base_cam)
        pts, nrm, frm = self.s.points_base, self.s.normals_base, self.s.frame
        if subset is not None:
            pts, nrm, frm = pts[subset], nrm[subset], frm[subset]
        stride = self.opts.zbuffer_stride * (1 if subset is None else 2)
        # facing the camera, tested in the base frame (n . (p - c) < 0), before anything is transformed; on the
        # model at the recorded joints (the offsets turn a normal by tenths of a degree), then the front moved
        front = np.flatnonzero(np.einsum("ij,ij->i", nrm, pts - T_base_cam[:3, 3]) < 0)
        sel = front if subset is None else subset[front]
        p = self.model(sel)[0] @ T_cam_base[:3, :3].T + T_cam_base[:3, 3]
        Ks = self.K.copy()
        Ks[:2] /= stride
        Ks[:2, 2] = (self.K[:2, 2] + 0.5) / stride - 0.5  # pixel centres of the coarser grid
        idx = visible_points(p, None, frm[front], Ks, -(-self.h // stride), -(-self.w // stride))
        p = p[idx]
        uv = np.rint(project(p, self.K)).astype(np.int64)
        inside = (uv[:, 0] >= 0) & (uv[:, 0] < self.w) & (uv[:, 1] >= 0) & (uv[:, 1] < self.h)
        return sel[idx[inside]], uv[inside][:, ::-1], p[inside]

    # -- stage 2: centroids

    def _centroids(self, frame, points):
        count = np.bincount(frame, minlength=self.n).astype(float)
        sums = np.stack([np.bincount(frame, points[:, k], minlength=self.n) for k in range(3)], axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return sums / count[:, None], count

    def centroid_start(self, iterations=4):
        c_obs, counts = self._centroids(self.moving_frame, self.moving_p_cam)
        use = counts >= 20
        if use.sum() < 3:
            return None
        T = None
        for _ in range(iterations + 1):
            idx = self.coarse_subset if T is None else self.visible(T, subset=self.coarse_subset)[0]
            idx = idx[self.moving_part[idx]]
            c_mod, n_mod = self._centroids(self.s.frame[idx], self.s.points_base[idx])
            ok = use & (n_mod >= 10)
            if ok.sum() < 3:
                return T
            T = rigid_transform(c_obs[ok], c_mod[ok], counts[ok])
        return T

    # -- stage 3: coarse ICP in 3-D

    def coarse(self, T):
        """3-D ICP of the moving pixels to the model, window shrinking; up to 3 matchings per window,
        fewer once a matching moves the pose by less than a tenth of the window (the rotation taken at 1 m)."""
        moving_p_cam = self.corrected(self.moving_p_cam)
        for window in self.opts.coarse_windows_m:
            for _ in range(3):
                p_base = moving_p_cam @ T[:3, :3].T + T[:3, 3]
                d, j = self.tree.query(
                    np.c_[p_base, self.moving_frame * _FRAME_KEY_M], distance_upper_bound=window, workers=-1
                )
                ok = np.isfinite(d)
                if ok.sum() < 50:
                    break
                jj = self.coarse_subset[j[ok]]
                n = self.s.normals_base[jj]
                # front-facing matches only: the normal must point towards the camera
                towards = np.einsum("ij,ij->i", n, T[:3, 3] - self.s.points_base[jj]) > 0
                sel = np.flatnonzero(ok)[towards]
                jj = jj[towards]
                if len(sel) < 50:
                    break
                fit = solve_point_to_plane(
                    moving_p_cam[sel],
                    MatchedModel(self.s.points_base[jj], self.s.normals_base[jj]),
                    T,
                    PlaneFitOptions(scale_m=window / 3, loss="cauchy", iterations=2, covariance=False),
                )
                moved = pose_error(T, fit.T_base_cam)
                T = fit.T_base_cam
                if np.radians(moved[0]) + moved[1] / 1e3 < 0.1 * window:
                    break
        return T

    # -- stage 4: fine, projective

    def associate(self, T, gate_m, cached=None):
        """Projective matches: each visible model point and the observed point in its pixel.

        ``cached`` (indices of visible points from an earlier pose) skips the z-buffer: the points
        are only projected again, for iterations where the pose moves by less than a pixel.
        """
        if cached is None:
            idx, pix, p_cam = self.visible(T)
        else:
            idx = cached
            T_cam_base = invert_transform(T)
            p_cam = self.model(idx)[0] @ T_cam_base[:3, :3].T + T_cam_base[:3, 3]
            uv = np.rint(project(p_cam, self.K)).astype(np.int64)
            inside = (uv[:, 0] >= 0) & (uv[:, 0] < self.w) & (uv[:, 1] >= 0) & (uv[:, 1] < self.h) & (p_cam[:, 2] > 0)
            idx, p_cam, pix = idx[inside], p_cam[inside], uv[inside][:, ::-1]
        f = self.s.frame[idx]
        q_obs = self.P[f, pix[:, 0], pix[:, 1]]
        q = self.corrected(q_obs)
        has_depth = np.isfinite(q[:, 2]) & (q_obs[:, 2] > 0)
        close = has_depth & (np.abs(q[:, 2] - p_cam[:, 2]) < gate_m)
        return idx, f, q_obs, q, has_depth, close

    def _solve(self, T, matches, iterations, covariance=True):
        """Point-to-plane fit of fixed ``matches`` (model points ``m``, frames ``f``, observed ``q_obs``) from ``T``
        and the current depth correction, intrinsics and joint offsets; returns the fit and the median expected
        residual."""
        m, f, q_obs = matches
        expected = float(np.median(np.sqrt(self.sigma_z(q_obs[:, 2]) ** 2 + self.opts.model_floor_m**2)))
        curved = self.s.curvatures is not None
        estimate_depth = self.opts.depth_model == "scale-offset"
        if estimate_depth or self.estimate_intrinsics:
            observed = q_obs  # as back-projected with the camera matrix given; the fit corrects it
        else:
            observed = self.corrected(q_obs)
        intrinsics = {}
        if self.estimate_intrinsics:
            intrinsics = {
                "intrinsics_K_ref": self.K_given,
                "intrinsics_start": self.theta,
                "intrinsics_prior": (self.theta_given, self.intrinsics_prior_sigma),
            }
        joints, twists = {}, None
        if self.joint_estimated is not None:  # the model posed at the recorded joints; the fit moves it
            e = self.joint_estimated
            twists = self.s.joint_twists_base[f, self.s.part[m]][:, e]
            joints = {"joint_start": self.joint_offsets[e], "joint_prior_sigma": self.joint_prior_sigma[e]}
        model = MatchedModel(
            self.s.points_base[m],
            self.s.normals_base[m],
            curvatures=self.s.curvatures[m] if curved else None,
            direction_base=self.s.direction_base[m] if curved else None,
            joint_twists=twists,
        )
        options = PlaneFitOptions(
            scale_m=expected * 2,
            loss="cauchy",
            iterations=iterations,
            covariance=covariance,
            depth_start=self.depth_correction if estimate_depth else None,
            depth_prior_sigma=(self.opts.depth_scale_prior_sigma, self.opts.depth_offset_prior_sigma_m),
            stereo_fb_px_m=self.opts.stereo_fb_px_m,
            pixel_locking_prior_px=self.opts.pixel_locking_prior_px,
            **intrinsics,
            **joints,
        )
        fit = solve_point_to_plane(observed, model, T, options, group=f, cross_group=self._cross_groups(q_obs))
        return fit, expected

    def _cross_groups(self, q_obs):
        """The covariance's clusterings beside the frames: depth bins, and image tiles where asked; None without
        any (the frame-clustered covariance is then the only one, not computed twice)."""
        crosses = [
            c
            for c in (
                _depth_bins(q_obs[:, 2], self.opts.depth_clusters),
                _image_tiles(q_obs, self.K_given, self.w, self.opts.image_tiles),
            )
            if c is not None
        ]
        return crosses or None

    def _fitted(self, idx, close):
        """The matches the fine stage fits: ``close`` ones on the parts it fits (``static_parts``)."""
        return close if self.fitted_part is None else close & self.fitted_part[idx]

    def _fit(self, T, idx, f, q_obs, close, covariance=True):
        """The fit of the ``close`` matches, adopted (:meth:`adopt`); returns it, the median expected residual and
        the matches ``(model points, frames, observed points)``."""
        sel = np.flatnonzero(close)
        matches = (idx[sel], f[sel], q_obs[sel])
        iterations = 3 if self.opts.depth_model == "fixed" else 5
        fit, expected = self._solve(T, matches, iterations, covariance)
        self.adopt(fit)
        return fit, expected, matches

    def restart(self):
        """No depth correction, the intrinsics given and no joint offsets: the state a start begins from."""
        self.depth_correction = (1.0, 0.0)
        self.set_intrinsics(self.theta_given)
        self.set_joint_offsets(np.zeros_like(self.joint_offsets))

    def adopt(self, fit):
        """Take the fit's depth correction, intrinsics and joint offsets as the current ones."""
        if fit.depth_correction is not None:
            self.depth_correction = fit.depth_correction
        if fit.intrinsics is not None:
            self.set_intrinsics(fit.intrinsics)
        if fit.joint_offsets is not None:
            delta = np.zeros_like(self.joint_offsets)
            delta[self.joint_estimated] = fit.joint_offsets
            self.set_joint_offsets(delta)

    def split_check(self, T, matches):
        """Groups of the frames solved again from the final matches, from the current depth correction, intrinsics
        and joint offsets (those of the fit that made the matches): the sigma their scatter adds
        (:func:`classic.markerless.consistency.split_excess`)."""
        m, f, q_obs = matches

        def solve(mask):
            fit, _ = self._solve(T, (m[mask], f[mask], q_obs[mask]), iterations=5)
            return fit.T_base_cam, fit.covariance

        return split_excess(solve, f, frame_splits(f, q_obs, self.n))

    def fine(self, T, name):
        """Projective point-to-plane from ``T``, gate shrinking to 4 robust sigmas; returns the start ``name``'s
        outcome.

        The z-buffer is rebuilt on the first and fourth association and every fifth after; in between the
        visible points are only projected again. The last association always has a fresh z-buffer, and the
        matched fraction (visible model points with depth within 1 cm) is taken from it.
        """
        opts = self.opts
        gates = [0.05, 0.03, 0.02, 0.01]
        fit, step, scale, visible_idx = None, np.inf, None, None
        for it in range(opts.fine_iterations):
            gate = gates[it] if it < len(gates) else max(4 * scale, 0.004)
            full = it in (0, 3) or (it > 3 and (it - 3) % 5 == 0)
            idx, f, q_obs, q, has_depth, close = self.associate(T, gate, None if full else visible_idx)
            if full:
                visible_idx = idx
            fitted = self._fitted(idx, close)
            if fitted.sum() < 50:
                return _Outcome(name, T, None, np.inf, 0.0)
            fit, expected, _ = self._fit(T, idx, f, q_obs, fitted, covariance=False)  # the matches change next
            T, step = fit.T_base_cam, fit.step_norm
            inl = fit.weights > 0.5
            scale = max(1.4826 * float(np.median(np.abs(fit.residuals_m[inl]))) if inl.any() else gate, expected)
            if it >= len(gates) and step < 1e-7:
                break
        # the final association, fresh z-buffer: one more fit on it, and the matched fraction
        idx, f, q_obs, q, has_depth, close = self.associate(T, max(4 * scale, 0.004))
        fitted = self._fitted(idx, close)
        if fitted.sum() < 50:
            return _Outcome(name, T, None, np.inf, 0.0)
        fit, _, matches = self._fit(T, idx, f, q_obs, fitted)
        q = self.corrected(q_obs)
        step = max(step, fit.step_norm)
        matched_q = q[fitted]  # what calibrated the depth
        geometry = (
            float(np.median(matched_q[:, 2])),
            float(np.sqrt(np.mean(np.sum((matched_q - matched_q.mean(0)) ** 2, axis=1)))),
        )
        depth_range = tuple(np.percentile(matched_q[:, 2], [10, 90]))
        within_1cm = has_depth & (
            np.abs(q[:, 2] - (self.model(idx)[0] - fit.T_base_cam[:3, 3]) @ fit.T_base_cam[:3, 2]) < 0.01
        )
        matched = float(within_1cm.sum()) / max(int(has_depth.sum()), 1)
        return _Outcome(name, fit.T_base_cam, fit, step, matched, geometry, depth_range, matches)


def register_robot(
    depth_m: np.ndarray,
    K: np.ndarray,
    surface: RobotSurfaceFrames,
    starts: dict | None = None,
    options: MarkerlessOptions | None = None,
    centroid_start: bool = True,
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

    Returns
    -------
    MarkerlessResult
        Accepted, or refused with the reason; each start's outcome in ``diagnostics["starts"]``.

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
    problem = _Problem(depth_m, K, surface, opts)
    n = problem.n
    diag = {"frames": n, "moving_pixels": int(problem.n_moving), "mixed_pixels": problem.n_mixed, "starts": {}}
    if problem.n_moving < opts.min_moving_pixels:
        return _refused(
            f"too few robot pixels: {problem.n_moving} pixels moved between the {n} frames "
            f"(at least {opts.min_moving_pixels} needed); is the arm in view and moving?",
            diag,
        )
    if centroid_start:
        T0 = problem.centroid_start()
        if T0 is not None:
            starts["centroids"] = T0
    if not starts:
        return _refused("no start: the moving pixels of too few frames to align centroids, and none was given", diag)
    best = _best_of_starts(problem, starts, diag)
    if isinstance(best, str):
        return _refused(best, diag)
    return _result(problem, best, diag)


def _refused(reason: str, diag: dict) -> MarkerlessResult:
    """A refusal: no pose, no sigma; only the reason and what was seen."""
    n = diag["frames"]
    nan_sigma = {"rotation_deg": np.nan, "translation_mm": np.nan}
    return MarkerlessResult(None, reason, np.full((6, 6), np.nan), nan_sigma, np.full(n, np.nan), 0.0, "", diag)


def _best_of_starts(problem: _Problem, starts: dict, diag: dict) -> _Outcome | str:
    """Stages 3 and 4 from each start in turn, until one clearly succeeds; the best kept, the problem left in its
    state. Returns its outcome, or the reason none would do."""
    opts, best = problem.opts, None
    for name, T_start in starts.items():
        problem.restart()
        outcome = problem.fine(problem.coarse(np.asarray(T_start, dtype=float)), name)
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
        best = problem.fine(best.T, best.name)
        if best.fit is None:
            return "did not converge: the fit with the base rotation's offset absorbed kept too few points"
    return best


def _result(problem: _Problem, best: _Outcome, diag: dict) -> MarkerlessResult:
    """The best start's fit as the answer with its sigma, or refused with the reason; ``diag`` completed."""
    opts, fit = problem.opts, best.fit
    z_med, lever_m = best.geometry
    res_frame, rms_mm, inl = _residuals_mm(fit, problem.n)
    noise_mm = float(problem.sigma_z(z_med) * 1e3)
    expected_mm = float(np.hypot(noise_mm, opts.model_floor_m * 1e3))
    noise = pose_sigma(fit.covariance, best.T[:3, :3])
    sampling = _sampling_sigma(z_med, lever_m, problem.K_given, opts)
    # the depth camera is what the registration finds; the colour camera's pose carries the extrinsic's error
    registration = _registration_terms(opts, fit, problem.theta_given)
    extrinsic = {
        "rotation_deg": registration["rotation"]["rss_deg"],
        "translation_mm": registration["translation"]["rss_mm"],
    }
    depth = _depth_summary(fit, opts, best.depth_range, problem.noise_source, noise_mm)
    refused = _refusal(opts, best.matched, rms_mm, expected_mm, best.step, depth)
    # what the frames share and differ in by depth or image position: the groups' scatter (an answer only)
    split = None
    if opts.split_check and not refused:
        split = problem.split_check(best.T, best.matches)
    no_split = {"rotation_deg": 0.0, "translation_mm": 0.0}
    diag.update(
        {
            "inlier_rms_mm": rms_mm,
            "expected_rms_mm": expected_mm,
            "last_step": float(best.step),
            "matched_points": int(inl.sum()),
            "fitted_parts": "all" if problem.fitted_part is None else "moving",
            "sigma_noise": noise,
            "sigma_sampling": sampling,
            "sigma_consistency": split,
        }
    )
    return MarkerlessResult(
        None if refused else best.T,
        refused,
        fit.covariance,
        _in_quadrature(noise, sampling, extrinsic, split or no_split),
        res_frame,
        best.matched,
        best.name,
        diag,
        depth,
        _intrinsics_result(fit, problem),
        registration=registration,
        joint_offsets=_joint_offsets_result(fit, problem, opts),
    )


def _residuals_mm(fit: PlaneFit, n: int) -> tuple[np.ndarray, float, np.ndarray]:
    """The inliers' (weight above 1/2) RMS residual per frame (NaN where none) and over all frames, millimetres,
    and the inliers."""
    inl = fit.weights > 0.5
    group = fit.group
    res_frame = np.array(
        [
            np.sqrt(np.mean(fit.residuals_m[inl & (group == i)] ** 2)) * 1e3 if np.any(inl & (group == i)) else np.nan
            for i in range(n)
        ]
    )
    rms_mm = float(np.sqrt(np.mean(fit.residuals_m[inl] ** 2)) * 1e3) if inl.any() else np.inf
    return res_frame, rms_mm, inl


def _sampling_sigma(z_med: float, lever_m: float, K: np.ndarray, opts: MarkerlessOptions) -> dict:
    """What all frames share and the covariance cannot see: the model's sampling bias.

    A model point stands for the surface up to half a pixel off its ray, off the tangent plane by at most
    ``F^2 / (8 r)`` on a link of radius ``r`` for a pixel footprint ``F``; taken as a uniform error
    (std = bound / sqrt 3) in translation, and over the matched points' spread ``lever_m`` in rotation.
    """
    footprint_m = z_med / max(K[0, 0], K[1, 1])
    sampling_mm = footprint_m**2 / (8 * opts.model_radius_m) / np.sqrt(3) * 1e3
    return {
        "rotation_deg": float(np.degrees(sampling_mm / 1e3 / max(lever_m, 1e-3))),
        "translation_mm": float(sampling_mm),
    }


def _in_quadrature(*terms: dict) -> dict:
    """The sigma's terms (each ``rotation_deg`` and ``translation_mm``) added in quadrature."""
    return {key: float(np.sqrt(sum(t[key] ** 2 for t in terms))) for key in ("rotation_deg", "translation_mm")}


def _intrinsics_result(fit: PlaneFit, problem: _Problem) -> dict:
    """:attr:`MarkerlessResult.intrinsics` of the final fit."""
    if fit.intrinsics is None:
        return {"model": "fixed", "given": [float(x) for x in problem.theta_given]}
    return intrinsics_summary(
        fit.intrinsics,
        fit.intrinsics_covariance,
        fit.intrinsics_covariance_frames,
        problem.K_given,
        problem.intrinsics_prior_sigma,
        problem.opts.intrinsics_determined_share,
    )


def _refusal(opts: MarkerlessOptions, matched: float, rms_mm: float, expected_mm: float, step: float, depth: dict):
    """Why the fit is no calibration (outside the basin, residual too large, not converged, depth not observable),
    or None."""
    observe = depth.get("observability", {})  # the frames' geometry alone decides whether the depth is observable
    if matched < opts.min_matched_fraction:
        return (
            f"start outside the basin: only {matched:.0%} of the visible model lands on the observed surface "
            f"(at least {opts.min_matched_fraction:.0%} needed)"
        )
    if rms_mm > opts.max_residual_ratio * expected_mm:
        return f"residual too large: {rms_mm:.2f} mm RMS against {expected_mm:.2f} mm expected from the depth noise"
    if step > 1e-4:
        return f"did not converge: last step {step:.2g} (rad + m)"
    if observe.get("scale_sigma", 0.0) > opts.max_depth_prior_share * opts.depth_scale_prior_sigma or (
        observe.get("offset_sigma_mm", 0.0) > opts.max_depth_prior_share * opts.depth_offset_prior_sigma_m * 1e3
    ):
        return (
            f"depth scale and offset not observable: the matched depths span {depth['range_m'][0]:.2f}-"
            f"{depth['range_m'][1]:.2f} m, which leaves the scale at {observe['scale_sigma']:.2%} and the offset at "
            f"{observe['offset_sigma_mm']:.1f} mm (1 sigma; at most {opts.max_depth_prior_share:.0%} of the prior's "
            f"{opts.depth_scale_prior_sigma:.2%} and {opts.depth_offset_prior_sigma_m * 1e3:.1f} mm); move the arm "
            "nearer to and farther from the camera, or take the depth as exact (depth_model='fixed')"
        )
    return None


def _joint_offsets_result(fit, problem, opts: MarkerlessOptions) -> dict:
    """:attr:`MarkerlessResult.joint_offsets` of the final fit."""
    if problem.s.joint_twists_base is None:
        return {"model": "fixed", "reason": "the surface carries no joint twists"}
    if opts.joint_offsets_model == "fixed":
        return {"model": "fixed", "reason": "joint_offsets_model='fixed': the recorded joints taken as exact"}
    if problem.joint_estimated is None:  # every joint absorbed or not seen
        return joint_offsets_summary(
            problem.joint_offsets, problem.joint_status, None, None, problem.joint_prior_sigma, 0
        )
    return joint_offsets_summary(
        problem.joint_offsets,
        problem.joint_status,
        fit.joint_offsets_covariance,
        fit.joint_offsets_covariance_frames,
        problem.joint_prior_sigma,
        opts.joint_offset_determined_share,
    )


def _registration_terms(opts: MarkerlessOptions, fit, theta_given: np.ndarray) -> dict:
    """What the depth-to-colour registration adds to the sigma, and which of its parts the fit estimated.

    The extrinsic's rotation and translation move the colour camera off the depth camera the fit finds: bounded,
    per axis. A shift of the depth image against the camera model is the principal point's error: estimated with
    the intrinsics (the change found holds the camera matrix's own error there too), or taken as exact with them.
    """
    estimated = fit.intrinsics is not None
    out = {
        "translation": {
            "treatment": "bounded",
            "sigma_mm": float(opts.depth_extrinsic_sigma_m * 1e3),
            "rss_mm": float(np.sqrt(3) * opts.depth_extrinsic_sigma_m * 1e3),
        },
        "rotation": {
            "treatment": "bounded",
            "sigma_deg": float(opts.depth_extrinsic_sigma_deg),
            "rss_deg": float(np.sqrt(3) * opts.depth_extrinsic_sigma_deg),
        },
    }
    if estimated:
        change = np.asarray(fit.intrinsics[2:4]) - np.asarray(theta_given[2:4])
        sigma = np.sqrt(np.clip(np.diag(fit.intrinsics_covariance)[2:4], 0.0, None))
        out["shift_px"] = {
            "treatment": "estimated (with the principal point)",
            "dx": float(change[0]),
            "dy": float(change[1]),
            "sigma": [float(x) for x in sigma],
        }
    else:
        out["shift_px"] = {"treatment": "taken as exact (intrinsics fixed)"}
    return out


def _image_tiles(p_cam: np.ndarray, K: np.ndarray, width: int, tiles: int) -> np.ndarray | None:
    """Each observed point's image tile: square tiles, ``tiles`` across the image's ``width`` (None when
    ``tiles`` < 2). ``p_cam`` as back-projected with ``K``, so its pixel is found again exactly."""
    if tiles < 2 or len(p_cam) < 2 * tiles:
        return None
    size = width / tiles
    uv = np.floor(project(p_cam, K) / size).astype(np.int64)
    return uv[:, 1] * (tiles + 1) + uv[:, 0]


def _depth_bins(z: np.ndarray, bins: int) -> np.ndarray | None:
    """Each depth's bin among ``bins`` of equal counts (None when ``bins`` < 2)."""
    if bins < 2 or len(z) < 2 * bins:
        return None
    edges = np.quantile(z, np.linspace(0, 1, bins + 1)[1:-1])
    return np.searchsorted(edges, z)


def _depth_summary(fit, opts: MarkerlessOptions, depth_range: tuple, noise_source: str, noise_mm: float) -> dict:
    """The depth correction as the sensor's scale and offset, ``d_obs = s d + o``, with their sigmas."""
    out = {"model": opts.depth_model, "noise_source": noise_source, "noise_mm_at_median_depth": noise_mm}
    out["range_m"] = [float(depth_range[0]), float(depth_range[1])]
    if fit.depth_correction is None:
        return out
    k, c = fit.depth_correction[:2]
    # s = 1 / k, o = -c / k; first order through the Jacobian of (s, o) in (k, c)
    G = np.array([[-1 / k**2, 0.0], [c / k**2, -1 / k]])
    C = G @ fit.depth_covariance[:2, :2] @ G.T
    frames = fit.depth_covariance if fit.depth_covariance_frames is None else fit.depth_covariance_frames
    F = G @ frames[:2, :2] @ G.T
    out.update(
        {
            "scale": float(1 / k),
            "scale_sigma": float(np.sqrt(max(C[0, 0], 0.0))),
            "offset_mm": float(-c / k * 1e3),
            "offset_sigma_mm": float(np.sqrt(max(C[1, 1], 0.0)) * 1e3),
            "observability": {
                "scale_sigma": float(np.sqrt(max(F[0, 0], 0.0))),
                "offset_sigma_mm": float(np.sqrt(max(F[1, 1], 0.0)) * 1e3),
            },
        }
    )
    if len(fit.depth_correction) == 4:  # the stereo matcher's disparity error a sin(2 pi d) + b cos(2 pi d)
        (a, b), L = fit.depth_correction[2:], fit.depth_covariance[2:, 2:]
        out["pixel_locking_px"] = {
            "sin": a,
            "cos": b,
            "sin_sigma": float(np.sqrt(max(L[0, 0], 0.0))),
            "cos_sigma": float(np.sqrt(max(L[1, 1], 0.0))),
            "amplitude": float(np.hypot(a, b)),
        }
    return out
