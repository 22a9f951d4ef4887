"""Settings of the markerless registration (:func:`classic.markerless.register_robot`), checked on construction."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from classic.markerless.kinematics import JOINT_OFFSET_PRIORS_DEG
from handeye.core.errors import HandEyeInputError

__all__ = ["MarkerlessOptions"]


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
    intrinsics_floor_prior_sigma : tuple of 4 float or None
        Where the intrinsics' prior is narrower than the camera matrix's stated uncertainty (a pooled prior,
        :func:`classic.markerless.shared_intrinsics.second_pass_options`): that stated uncertainty, in the units of
        ``intrinsics_prior_sigma``. The answer's sigma is found again under it at the same matches and kept no
        narrower (``diagnostics["sigma_shared_floor"]``, with the ``floor`` itself): the pooled prior may move the
        answer, not narrow its sigma below what one placement alone claims. Set for pools of fewer than
        :data:`classic.markerless.shared_intrinsics.MIN_OTHERS_OWN_SIGMA` other placements, whose agreement cannot
        show an error they share; on larger pools it is two to four times their answers' errors
        (``docs/benchmarks/markerless.md``, 'The pooled sigma, the pool's own'). None (the default): no floor.
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
    fine_gates_m : tuple of float
        Match gates of the fine stage's first associations, widest first; after them the gate is 4 robust
        sigmas of the residual (at least 4 mm). A registration started at an accepted answer needs only the
        last (:func:`classic.markerless.shared_intrinsics.second_pass_options`).
    fine_iterations : int
        Associations of the fine stage at most; it stops earlier once past ``fine_gates_m`` and converged.
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
        part moving, the static ones are used. When fitted, a static part's matches count once per z-buffer cell,
        not once per frame, and the sigma is the moving parts' own plus how far the static parts moved the
        answer (``diagnostics["sigma_static"]``): they may move the answer, never narrow its sigma (with a 3.6 mm
        fixed pattern they were accepted 26.6 mm off at 3.6 sigma when counted per frame).
    pixel_effect_px : int
        Above 0: marginalise a depth error per image cell of this many pixels square, the same in every frame where
        the arm covers the cell (a sensor's fixed pattern, correlated over a few pixels), under a sigma measured
        from the residuals (:mod:`classic.markerless.pixel_effect`). 0 (the default): not modelled. Off by default:
        it does not always help. On the error table's every row (paper-real and paper-sim at 1.2 m, five
        placements each, 2 px cells) it leaves 0 beyond 3 sigma and the all-together rows improve (2.60 and 1.39
        mm median against 5.13 and 1.94), but paper-sim's fixed-pattern row worsens 0.89 -> 1.28 mm median (3 px
        cells: 1.43); it takes out what repeats within a cell, not the pattern's correlation between cells, and
        the sigma then runs short of the error (the pattern alone, 2 px cells: 2.69 mm at a sigma of 1.29 mm).
        Its cost: about 1.3-1.5 s more CPU per placement (all together, paper-real: 6.4-6.5 -> 7.8-8.0 s on one
        core). Measured on simulated placements only (``benchmarks/results/markerless_errors.md``), never on a
        real sensor. The front (``handeye markerless``) sets it to 2 where four or more placements share their
        intrinsics (:data:`classic.markerless.shared_intrinsics.SHARED_PIXEL_EFFECT_PX`).
    repeated_error_px : int
        Above 0: the sigma holds what a depth error repeated at one image position in every frame adds (a fixed
        pattern; an error of the camera matrix or the depth image's registration the fit leaves), its covariance
        over the image measured from the final residuals across frames out to this many pixels
        (:mod:`classic.markerless.repeated_error`; ``diagnostics["sigma_repeated"]``). 0: not counted. 16 by
        default: at a D435's 848x480 a real cell's errors together were accepted beyond 3 sigma in 3 of 10
        registrations without it (12.03 mm at a sigma of 3.79), 0 of 10 with it (4.95); at 256x256 the clean
        d435's sigma moved by under 0.5 % (``benchmarks/results/markerless_resolution.md``).
    max_incidence_deg : float or None
        Matches whose model normal is farther than this from the pixel's ray are left out (the arm's grazing
        edges, where the projective match pairs a pixel's ray with a sample far along a steep surface); None, the
        default, keeps them. Measured, not a default: on the white-noise datasets 70 deg shrank the error the
        placements share along the optical axis; on the D435 real-cell table it helped and harmed alike
        (``benchmarks/results/markerless_incidence.md``).
    crease_radius_m : float or None
        Model samples with a neighbour this near whose normal is over 35 deg from theirs (a link's side meeting its
        end cap) are left out of every association of the fine stage (:mod:`classic.markerless.gating`): there a
        pixel's ray can meet the other face within the gate, a row the second-order residual cannot fit. 8 mm by
        default; None keeps them.
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
    intrinsics_floor_prior_sigma: tuple | None = None
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
    fine_gates_m: tuple = (0.05, 0.03, 0.02, 0.01)
    fine_iterations: int = 20
    max_points: int = 20000
    max_model_points: int = 300000
    zbuffer_stride: int = 1
    depth_clusters: int = 12
    image_tiles: int = 0
    split_check: bool = True
    static_parts: bool = False
    pixel_effect_px: int = 0
    repeated_error_px: int = 16
    max_incidence_deg: float | None = None
    crease_radius_m: float | None = 0.008
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
        floor = self.intrinsics_floor_prior_sigma
        if floor is not None and not (
            np.shape(floor) == (4,) and np.all(np.isfinite(floor)) and np.all(np.asarray(floor, dtype=float) > 0)
        ):
            raise HandEyeInputError(
                f"intrinsics_floor_prior_sigma must be None or four positive sigmas as intrinsics_prior_sigma, got "
                f"{floor!r}"
            )

    def _check_sigmas(self):
        """The depth-to-colour extrinsic's sigmas and the depth noise given: finite, at least 0; the incidence bound;
        the fine stage's gates."""
        gates = np.asarray(self.fine_gates_m, dtype=float)
        if not (gates.ndim == 1 and len(gates) and np.all(np.isfinite(gates)) and np.all(gates > 0)):
            raise HandEyeInputError(
                f"fine_gates_m must be one or more positive distances (m), got {self.fine_gates_m!r}"
            )
        for key in ("depth_extrinsic_sigma_m", "depth_extrinsic_sigma_deg"):
            value = getattr(self, key)
            if not (np.isfinite(value) and value >= 0):
                raise HandEyeInputError(f"{key} must be a finite value >= 0, got {value}")
        for key in ("pixel_effect_px", "repeated_error_px"):
            value = getattr(self, key)
            if not (isinstance(value, (int, np.integer)) and value >= 0):
                raise HandEyeInputError(f"{key} must be an integer >= 0, got {value!r}")
        sigma = self.depth_sigma_m_at_1m
        if sigma is not None and not (np.isfinite(sigma) and sigma >= 0):
            raise HandEyeInputError(f"depth_sigma_m_at_1m must be None or a finite value >= 0, got {sigma}")
        angle = self.max_incidence_deg
        if angle is not None and not (np.isfinite(angle) and 0 < angle < 90):
            raise HandEyeInputError(f"max_incidence_deg must be None or between 0 and 90 degrees, got {angle}")
        radius = self.crease_radius_m
        if radius is not None and not (np.isfinite(radius) and radius > 0):
            raise HandEyeInputError(f"crease_radius_m must be None or a finite value > 0, got {radius}")

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
