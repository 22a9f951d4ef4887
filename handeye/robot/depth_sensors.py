"""Depth sensors as data: the errors of each kind of RGB-D camera a robot cell uses.

A real RGB-D camera reports

.. math:: d_{obs} = s\\, d + o + \\epsilon(d)

with a scale ``s`` and offset ``o`` of its own (a unit's calibration error, fixed for a placement), and a
noise ``epsilon`` whose size grows with depth as the sensing principle makes it grow: with ``z^2`` for
triangulation (active stereo, structured light: ``sigma_z = z^2 sigma_d / (f B)``), roughly constant plus a
term linear in ``z`` for time of flight. A :class:`DepthSensor` holds these numbers for one kind of camera;
:data:`PROFILES` has the cameras a robot cell uses, with the figures taken from their vendors' datasheets and
white papers (cited beside each). Where a datasheet gives a bound ("accuracy within 2 % at 2 m"), the spread
here is a third of it, so that the bound is a 3-sigma one.

The markerless registration reads a profile for its priors (the depth noise, the stereo constant, the
depth-to-colour registration's spread); the simulator (:mod:`sim.sensors`) draws a unit's errors from it and
applies them to rendered depth. This module is data and needs only numpy: a real cell's calibration imports it
without the simulator.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from handeye.core.errors import HandEyeInputError

__all__ = ["DepthSensor", "PROFILES", "sensor_profile", "FACTORY_ROLL_BOUND_DEG"]

#: The depth-to-colour rotation a real unit's factory extrinsic is taken to be off by, per axis, degrees, where
#: depth and colour come from separate imagers (``extrinsic_sigma_m > 0``): the ``d435-real-cell`` profile's
#: spread. The simulator draws no such turn for the other profiles (their rendered depth is registered exactly),
#: but a camera of that model in a real cell has one: the front bounds it by this much
#: (:attr:`DepthSensor.registration_roll_bound_deg`), so that naming the camera never makes the rotation's sigma
#: tighter than naming none (the unnamed camera's prior is ``d435-real-cell``).
FACTORY_ROLL_BOUND_DEG = 0.2


@dataclass(frozen=True)
class DepthSensor:
    """The depth errors of one kind of RGB-D camera.

    Attributes
    ----------
    name : str
    principle : {"ideal", "active-stereo", "time-of-flight", "structured-light", "simulated-stereo"}
        ``simulated-stereo`` measures the depth by matching two simulated infrared views of a dot pattern
        (:mod:`sim.stereo`) instead of adding the parametric noise: its noise, holes and edge errors are
        the matcher's.
    scale_sigma : float
        Spread of a unit's depth scale ``s - 1`` (one sigma, unitless), drawn per placement.
    offset_sigma_m : float
        Spread of a unit's depth offset ``o``, metres, drawn per placement.
    noise_const_m : float
        Axial noise sigma that does not grow with depth (time of flight), metres.
    noise_linear : float
        Axial noise sigma per metre of depth (time of flight), unitless.
    noise_quadratic_per_m : float
        Axial noise sigma per square metre of depth, 1/m: ``subpixel / (f B)`` for a stereo pair of
        baseline ``B`` with focal length ``f`` pixels at the sensor's own resolution.
    correlated_fraction : float
        Share of the noise variance that is spatially correlated (0: white).
    correlation_px : float
        Correlation length of that part in the sensor's own pixels (the stereo matching window).
    native_focal_px : float
        Focal length of the depth sensor at its own resolution; scales ``correlation_px`` to the
        rendered image. 0 for no scaling.
    flying_fraction : float
        Share of the pixels at a depth edge that mix foreground and background.
    edge_jump_m : float
        Depth difference between neighbours that makes an edge.
    grazing_hole_deg : float
        Surfaces seen at more than this angle from their normal return no depth (90: never).
    dark_hole_fraction : float
        Share of dark pixels (grey level below ``dark_level``) that return no depth.
    dark_level : float
        Grey level (0-255) below which a pixel is dark.
    hole_blob_fraction : float
        Share of each image lost in random blobs (specular spots, dropped matches).
    hole_blob_px : float
        Blob size, rendered pixels.
    stereo_baseline_m : float
        The stereo pair's baseline, metres (``active-stereo``, ``simulated-stereo``): with ``native_focal_px``
        the disparity constant ``f B`` (:attr:`stereo_fb_px_m`).
    extrinsic_sigma_m : float
        Spread of the depth-to-colour extrinsic's translation error per axis, metres: the depth image is
        registered to the colour camera through a factory extrinsic that is off by this much.
    registration_shift_sigma_px : float
        Spread of the depth image's misregistration against the colour camera's model it is paired with
        (aligned depth), per image axis, pixels, drawn per placement: the image is shifted by this much.
    registration_roll_sigma_deg : float
        Spread of its rotation about the principal point, degrees, drawn per placement.
    fixed_pattern_sigma_m_at_1m : float
        Sigma of a fixed-pattern depth error at 1 m, growing with depth squared like the stereo noise: one
        noise field per unit and placement, the same in every frame (a real sensor's error on a static scene
        repeats), metres.
    fixed_pattern_px : float
        Its correlation length in the sensor's own pixels (scaled like ``correlation_px``).
    source : str
        Where the numbers come from.
    """

    name: str
    principle: str
    scale_sigma: float = 0.0
    offset_sigma_m: float = 0.0
    noise_const_m: float = 0.0
    noise_linear: float = 0.0
    noise_quadratic_per_m: float = 0.0
    correlated_fraction: float = 0.0
    correlation_px: float = 0.0
    native_focal_px: float = 0.0
    flying_fraction: float = 0.0
    edge_jump_m: float = 0.05
    grazing_hole_deg: float = 90.0
    dark_hole_fraction: float = 0.0
    dark_level: float = 30.0
    hole_blob_fraction: float = 0.0
    hole_blob_px: float = 6.0
    extrinsic_sigma_m: float = 0.0
    stereo_baseline_m: float = 0.0
    registration_shift_sigma_px: float = 0.0
    registration_roll_sigma_deg: float = 0.0
    fixed_pattern_sigma_m_at_1m: float = 0.0
    fixed_pattern_px: float = 0.0
    source: str = ""

    def __post_init__(self):
        if self.principle not in ("ideal", "active-stereo", "time-of-flight", "structured-light", "simulated-stereo"):
            raise HandEyeInputError(f"sensor {self.name!r}: unknown principle {self.principle!r}")
        for key, value in asdict(self).items():
            if key in ("name", "principle", "source"):
                continue
            if not np.isfinite(value) or value < 0:
                raise HandEyeInputError(f"sensor {self.name!r}: {key} must be a finite value >= 0, got {value}")
        if self.principle == "simulated-stereo" and not self.stereo_baseline_m > 0:
            raise HandEyeInputError(f"sensor {self.name!r}: simulated-stereo needs stereo_baseline_m > 0")
        for key in ("correlated_fraction", "flying_fraction", "dark_hole_fraction", "hole_blob_fraction"):
            if getattr(self, key) > 1:
                raise HandEyeInputError(f"sensor {self.name!r}: {key} is a fraction, got {getattr(self, key)}")

    @property
    def stereo_fb_px_m(self) -> float | None:
        """The disparity constant ``f B`` of a stereo sensor at its own resolution (pixels x metres), else None.

        What the registration needs to model the matcher's pull toward whole disparities
        (:class:`classic.markerless.MarkerlessOptions` ``stereo_fb_px_m``).
        """
        stereo = self.principle in ("active-stereo", "simulated-stereo")
        if stereo and self.stereo_baseline_m > 0 and self.native_focal_px > 0:
            return float(self.native_focal_px * self.stereo_baseline_m)
        return None

    @property
    def registration_roll_bound_deg(self) -> float:
        """The depth-to-colour rotation's bound per axis for a real unit of this model, degrees: the profile's
        drawn spread, and at least :data:`FACTORY_ROLL_BOUND_DEG` where depth and colour come from separate
        imagers (``extrinsic_sigma_m > 0``); 0 for one imager (a Zivid) or an ideal camera."""
        floor = FACTORY_ROLL_BOUND_DEG if self.extrinsic_sigma_m > 0 else 0.0
        return float(max(self.registration_roll_sigma_deg, floor))

    def sigma_m(self, z_m: np.ndarray) -> np.ndarray:
        """Axial noise sigma at depth ``z_m`` (metres), any shape."""
        z = np.asarray(z_m, dtype=float)
        return np.sqrt(self.noise_const_m**2 + (self.noise_linear * z) ** 2 + (self.noise_quadratic_per_m * z**2) ** 2)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "DepthSensor":
        unknown = set(d) - set(cls.__dataclass_fields__)
        if unknown:
            raise HandEyeInputError(f"sensor parameters: unknown keys {sorted(unknown)}")
        return cls(**d)


def _stereo(subpixel: float, focal_px: float, baseline_m: float) -> float:
    """``sigma_z / z^2`` of a stereo pair: ``subpixel / (f B)`` (Intel's depth RMS error formula)."""
    return subpixel / (focal_px * baseline_m)


#: Intel RealSense D4xx at 848x480: 87 deg horizontal field of view, so f = 424 / tan(43.5 deg) = 447 px.
_D4XX_FOCAL_PX = 447.0

#: The profiles of ``handeye sim generate --sensor``.
PROFILES: dict[str, DepthSensor] = {
    # today's simulator: white noise of 1 mm at 1 m growing with depth squared, nothing else
    "ideal": DepthSensor("ideal", "ideal", noise_quadratic_per_m=0.001, source="the simulator's default noise"),
    "d435": DepthSensor(
        "d435",
        "active-stereo",
        scale_sigma=0.02 / 3,  # absolute depth accuracy within 2 % at 2 m (D400 series datasheet)
        offset_sigma_m=0.002,
        noise_quadratic_per_m=_stereo(0.08, _D4XX_FOCAL_PX, 0.050),  # subpixel RMS 0.08 px, 50 mm baseline
        correlated_fraction=0.5,
        correlation_px=3.5,  # half of the 7x7 census window of the D4 vision processor
        native_focal_px=_D4XX_FOCAL_PX,
        flying_fraction=0.3,
        grazing_hole_deg=75.0,
        dark_hole_fraction=0.3,
        hole_blob_fraction=0.03,
        extrinsic_sigma_m=0.0005,
        stereo_baseline_m=0.050,
        source="Intel RealSense D400 series datasheet (accuracy 2 % at 2 m, 50 mm baseline, 87 deg HFOV); "
        "Intel white paper 'Tuning depth cameras for best performance' (RMS error = z^2 subpixel / (f B), "
        "subpixel 0.08 px)",
    ),
    "d455": DepthSensor(
        "d455",
        "active-stereo",
        scale_sigma=0.02 / 3 / 2,  # within 2 % at 4 m (D455 datasheet): 1 % at the 2 m of the D435's bound
        offset_sigma_m=0.002,
        noise_quadratic_per_m=_stereo(0.08, _D4XX_FOCAL_PX, 0.095),  # 95 mm baseline
        correlated_fraction=0.5,
        correlation_px=3.5,
        native_focal_px=_D4XX_FOCAL_PX,
        flying_fraction=0.3,
        grazing_hole_deg=75.0,
        dark_hole_fraction=0.3,
        hole_blob_fraction=0.03,
        extrinsic_sigma_m=0.0005,
        stereo_baseline_m=0.095,
        source="Intel RealSense D455 datasheet (accuracy 2 % at 4 m, 95 mm baseline, 87 deg HFOV); "
        "the D435's subpixel RMS",
    ),
    "l515": DepthSensor(
        "l515",
        "time-of-flight",
        scale_sigma=0.001,
        offset_sigma_m=0.005 / 3,  # depth accuracy about 5 mm near the sensor (L515 datasheet: 5 mm to 14 mm)
        noise_const_m=0.0010,
        noise_linear=0.0015,  # precision about 2.5 mm at 1 m (L515 datasheet)
        correlated_fraction=0.3,
        correlation_px=2.0,
        native_focal_px=0.0,
        flying_fraction=0.5,  # a lidar's beam spans both sides of an edge
        grazing_hole_deg=80.0,
        dark_hole_fraction=0.5,
        hole_blob_fraction=0.02,
        extrinsic_sigma_m=0.0005,
        source="Intel RealSense LiDAR Camera L515 datasheet (accuracy about 5-14 mm over its range, "
        "precision about 2.5 mm at 1 m)",
    ),
    "azure-kinect": DepthSensor(
        "azure-kinect",
        "time-of-flight",
        scale_sigma=0.001 / 3,  # systematic error < 11 mm + 0.1 % of distance (Azure Kinect DK specification)
        offset_sigma_m=0.011 / 3,
        noise_const_m=0.0015,
        noise_linear=0.001,  # random error std <= 17 mm over the range; 1.5-2.5 mm at 1 m measured by users
        correlated_fraction=0.3,
        correlation_px=2.0,
        native_focal_px=0.0,
        flying_fraction=0.5,
        grazing_hole_deg=80.0,
        dark_hole_fraction=0.4,
        hole_blob_fraction=0.02,
        extrinsic_sigma_m=0.0005,
        source="Azure Kinect DK depth camera specification (systematic error < 11 mm + 0.1 % of distance, "
        "random error std <= 17 mm)",
    ),
    "zivid": DepthSensor(
        "zivid",
        "structured-light",
        scale_sigma=0.002 / 3,  # trueness error < 0.2 % (Zivid 2+ datasheet)
        offset_sigma_m=0.0002,
        noise_quadratic_per_m=0.00012 / 0.7**2,  # point precision about 0.12 mm at 0.7 m (Zivid 2+ M70)
        correlated_fraction=0.2,
        correlation_px=1.5,
        native_focal_px=0.0,
        flying_fraction=0.05,  # its filters remove most edge points
        grazing_hole_deg=80.0,
        dark_hole_fraction=0.1,
        hole_blob_fraction=0.005,
        extrinsic_sigma_m=0.0,  # colour and depth from the same imager
        source="Zivid 2+ datasheet (trueness error < 0.2 %, point precision about 0.1 mm at 0.7 m)",
    ),
}


def sensor_profile(name_or_params: str | dict) -> DepthSensor:
    """A profile by name (:data:`PROFILES`), or a :class:`DepthSensor` from a parameter dict."""
    if isinstance(name_or_params, dict):
        return DepthSensor.from_dict(name_or_params)
    if name_or_params not in PROFILES:
        raise HandEyeInputError(f"unknown sensor {name_or_params!r}: use one of {', '.join(PROFILES)} or a file")
    return PROFILES[name_or_params]


# the D435's geometry and systematic errors, its depth measured by OpenCV's semi-global block matching on two
# simulated infrared views of a dot pattern (sim/stereo.py) instead of the parametric noise: a check of "d435"
PROFILES["d435-sgbm"] = replace(
    PROFILES["d435"],
    name="d435-sgbm",
    principle="simulated-stereo",
    noise_quadratic_per_m=0.0,
    correlated_fraction=0.0,
    correlation_px=0.0,
    flying_fraction=0.0,
    source="the d435 profile's geometry (50 mm baseline, f = 447 px at 848x480) and systematic errors; the "
    "matching is OpenCV's StereoSGBM (7x7 window), not Intel's D4 processor",
)

# the d435 as a real cell has it (issue 41): its depth image misregistered against the colour camera's model by
# a pixel or two, and a fixed-pattern error as large as its stereo noise, the same in every frame of a placement.
# The camera matrix's error and the robot's joint offsets are the benchmark's options (--intrinsics-error
# fx=0.007,fy=0.007,cx=3, --joint-offsets): the depth is rendered with the true camera matrix and joints.
PROFILES["d435-real-cell"] = replace(
    PROFILES["d435"],
    name="d435-real-cell",
    registration_shift_sigma_px=1.0,  # per axis: 1.4 px in the image plane, median
    registration_roll_sigma_deg=0.2,
    fixed_pattern_sigma_m_at_1m=PROFILES["d435"].noise_quadratic_per_m,  # 3.6 mm at 1 m, the stereo noise's size
    fixed_pattern_px=PROFILES["d435"].correlation_px,  # the matching window
    source=PROFILES["d435"].source + "; misregistration and fixed pattern at issue 41's sizes",
)
