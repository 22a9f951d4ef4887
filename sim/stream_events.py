"""What happens to a simulated running cell, as data: the stream presets and their events.

A stream preset (:class:`StreamPreset`) says where the camera stands, how long the
recording runs and at what rate, which depth sensor it is, and what happens:
bumps of the camera (:class:`Bump`, a re-mount is a large one), a box or a person
passing between the camera and the arm (:class:`Occlusion`), the lights dimmed
(:class:`Lighting`), depth frames lost (:class:`Dropout`) and the camera's slow
thermal drift (:class:`Drift`). Times are seconds from the first frame; an
event takes effect at the first frame at or after its time. Occlusions,
lighting changes and dropouts may repeat (``every_s``) so that a long static
stream (the false-alarm measurement) keeps meeting them.

:mod:`sim.stream_timeline` turns a preset into per-frame truth; :mod:`sim.stream`
renders it.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

from handeye.core.errors import HandEyeInputError
from handeye.core.smoke import smoke_test

__all__ = [
    "Bump",
    "Occlusion",
    "Lighting",
    "Dropout",
    "Drift",
    "StreamPreset",
    "STREAM_PRESETS",
    "OCCLUDER_SHAPES",
    "PERSON_HEIGHT_M",
    "PERSON_RADIUS_M",
    "BOX_EXTENTS_M",
    "get_stream_preset",
]

#: Occluder shapes: a carried box and a person-sized upright cylinder.
OCCLUDER_SHAPES = ("box", "person")
#: The person: an upright cylinder of this height and radius standing on the floor, metres.
PERSON_HEIGHT_M = 1.75
PERSON_RADIUS_M = 0.25
#: The carried box's size, metres.
BOX_EXTENTS_M = (0.5, 0.4, 0.4)


def _positive(name: str, value: float, zero_ok: bool = False) -> None:
    ok = value >= 0 if zero_ok else value > 0
    if not (ok and value == value and value != float("inf")):
        raise HandEyeInputError(f"{name} must be a finite number {'>=' if zero_ok else '>'} 0, got {value!r}")


def _check_interval(kind: str, t_s: float, duration_s: float, every_s: float | None) -> None:
    """An event lasting ``duration_s`` from ``t_s``, repeated every ``every_s`` (longer than it) or not."""
    _positive(f"{kind} t_s", t_s, zero_ok=True)
    _positive(f"{kind} duration_s", duration_s)
    if every_s is not None and every_s <= duration_s:
        raise HandEyeInputError(f"{kind} every_s {every_s} must exceed its duration {duration_s}")


@dataclass(frozen=True)
class Bump:
    """The camera knocked at ``t_s``: turned by ``rotation_deg`` about its optical centre and moved by
    ``translation_mm``, both in directions drawn from the stream's seed (camera frame).

    Attributes
    ----------
    t_s : float
    translation_mm : float
    rotation_deg : float
    label : str
        ``"bump"`` or ``"remount"`` (what the benchmark calls it).
    """

    t_s: float
    translation_mm: float
    rotation_deg: float
    label: str = "bump"

    def __post_init__(self):
        _positive("bump t_s", self.t_s, zero_ok=True)
        _positive("bump translation_mm", self.translation_mm, zero_ok=True)
        _positive("bump rotation_deg", self.rotation_deg, zero_ok=True)


@dataclass(frozen=True)
class Occlusion:
    """A shape passing between the camera and the arm for ``duration_s`` from ``t_s``.

    It crosses the line of sight from the camera to the tool sideways, at half the
    distance, and is on it at the middle of the occlusion.

    Attributes
    ----------
    t_s, duration_s : float
    shape : {"box", "person"}
    every_s : float, optional
        Repeat every so many seconds until the stream ends.
    """

    t_s: float
    duration_s: float
    shape: str = "person"
    every_s: float | None = None

    def __post_init__(self):
        _check_interval("occlusion", self.t_s, self.duration_s, self.every_s)
        if self.shape not in OCCLUDER_SHAPES:
            raise HandEyeInputError(f"occlusion shape {self.shape!r}: use one of {', '.join(OCCLUDER_SHAPES)}")


@dataclass(frozen=True)
class Lighting:
    """The lights (directional and ambient) scaled by ``factor`` from ``t_s``, back to 1 after ``duration_s``.

    Attributes
    ----------
    t_s : float
    factor : float
        Light intensity relative to the stream's start (> 0).
    duration_s : float, optional
        None: for the rest of the stream.
    every_s : float, optional
        Repeat every so many seconds (needs ``duration_s``).
    """

    t_s: float
    factor: float
    duration_s: float | None = None
    every_s: float | None = None

    def __post_init__(self):
        _positive("lighting t_s", self.t_s, zero_ok=True)
        _positive("lighting factor", self.factor)
        if self.every_s is not None and (self.duration_s is None or self.every_s <= self.duration_s):
            raise HandEyeInputError("a repeated lighting change needs a duration_s shorter than every_s")


@dataclass(frozen=True)
class Dropout:
    """Depth frames lost for ``duration_s`` from ``t_s`` (the colour image and joints still arrive).

    Attributes
    ----------
    t_s, duration_s : float
    every_s : float, optional
    """

    t_s: float
    duration_s: float
    every_s: float | None = None

    def __post_init__(self):
        _check_interval("dropout", self.t_s, self.duration_s, self.every_s)


@dataclass(frozen=True)
class Drift:
    """Slow thermal drift of the camera's position, in steps (each step a new segment of the dataset).

    Attributes
    ----------
    rate_mm_per_min : float
    step_s : float
        The position moves by ``rate * step_s`` every ``step_s`` seconds.
    direction_base : (float, float, float)
        Direction of the motion in the robot base frame (normalised); default up, a mounting post growing.
    """

    rate_mm_per_min: float = 0.1
    step_s: float = 30.0
    direction_base: tuple = (0.0, 0.0, 1.0)

    def __post_init__(self):
        _positive("drift rate_mm_per_min", self.rate_mm_per_min, zero_ok=True)
        _positive("drift step_s", self.step_s)
        if sum(c * c for c in self.direction_base) == 0:
            raise HandEyeInputError("drift direction_base must not be zero")


@dataclass(frozen=True)
class StreamPreset:
    """A running cell to simulate.

    Attributes
    ----------
    name : str
    robot : {"ur5", "ur3"}
    azimuth_deg, elevation_deg, radius_m : float
        The camera's first placement: on a sphere around ``look_at_m``, looking at it (:mod:`sim.cameras`).
    look_at_m : (float, float, float)
        Base frame.
    minutes : float
    rate_hz : float
        Frames per second.
    image_size : (int, int)
        ``(width, height)``.
    fov_deg : float
        Horizontal field of view.
    sensor : str
        Depth sensor profile (:data:`handeye.robot.depth_sensors.PROFILES`).
    pixel_sigma : float
        Colour noise, grey levels.
    joint_sigma_deg : float
        Encoder noise on the recorded joints (the rendering uses the true ones).
    joint_speed_rad_s : float
        The arm's joint speed between work configurations (the slowest joint sets a move's duration).
    dwell_s : float
        Pause at each work configuration.
    bumps, occlusions, lighting, dropouts : tuple
    drift : Drift, optional
    """

    name: str
    robot: str = "ur5"
    azimuth_deg: float = 20.0
    elevation_deg: float = 35.0
    radius_m: float = 1.2
    look_at_m: tuple = (0.0, 0.0, 0.3)
    minutes: float = 3.0
    rate_hz: float = 5.0
    image_size: tuple = (256, 256)
    fov_deg: float = 60.0
    sensor: str = "d435"
    pixel_sigma: float = 2.0
    joint_sigma_deg: float = 0.01
    joint_speed_rad_s: float = 0.8
    dwell_s: float = 0.5
    bumps: tuple = ()
    occlusions: tuple = ()
    lighting: tuple = ()
    dropouts: tuple = ()
    drift: Drift | None = None

    def __post_init__(self):
        _positive("minutes", self.minutes)
        _positive("rate_hz", self.rate_hz)
        _positive("joint_speed_rad_s", self.joint_speed_rad_s)
        w, h = self.image_size
        if not (isinstance(w, int) and isinstance(h, int) and 16 <= w <= 4096 and 16 <= h <= 4096):
            raise HandEyeInputError(f"image_size {self.image_size!r}: two integers from 16 to 4096")

    @property
    def n_frames(self) -> int:
        """Frames in the stream: ``round(minutes * 60 * rate_hz)``."""
        return int(round(self.minutes * 60.0 * self.rate_hz))

    def to_dict(self) -> dict:
        """The preset as JSON-ready data (the recipe in ``meta.json`` and ``stream.json``)."""
        return asdict(self)

    def smoke(self) -> "StreamPreset":
        """This preset cut to a smoke run: 96 x 96 images, 30 s at 2 Hz (the events after 30 s drop out)."""
        return replace(self, minutes=min(self.minutes, 0.5), rate_hz=min(self.rate_hz, 2.0), image_size=(96, 96))


#: The issue's bump sizes, (mm, deg): 0.5 mm / 0.05 deg up to 50 mm / 5 deg.
BUMP_SIZES = ((0.5, 0.05), (2.0, 0.2), (5.0, 0.5), (20.0, 2.0), (50.0, 5.0))

STREAM_PRESETS = {
    # the running cell in 3 minutes: a bump of each size every 25 s, then a re-mount; a box and a
    # person in front of the arm, the lights dimmed and restored, two depth dropouts, 0.1 mm/min drift
    # in 30 s steps (bumps placed off the drift steps' times)
    "bumps": StreamPreset(
        "bumps",
        minutes=3.0,
        bumps=tuple(Bump(17.0 + 25.0 * k, mm, deg) for k, (mm, deg) in enumerate(BUMP_SIZES))
        + (Bump(145.0, 200.0, 20.0, "remount"),),
        occlusions=(Occlusion(27.0, 4.0, "box"), Occlusion(102.0, 5.0, "person")),
        lighting=(Lighting(52.0, 0.5, duration_s=12.0),),
        dropouts=(Dropout(37.0, 1.0), Dropout(112.0, 2.0)),
        drift=Drift(),
    ),
    # a static camera (the false-alarm measurement): a person every 40 s, a box every 60 s (never together), the lights
    # dimmed for 10 s every 90 s, a depth dropout every 50 s; no bump, no drift
    "static": StreamPreset(
        "static",
        minutes=3.0,
        occlusions=(Occlusion(10.0, 5.0, "person", every_s=40.0), Occlusion(26.0, 3.0, "box", every_s=60.0)),
        lighting=(Lighting(20.0, 0.4, duration_s=10.0, every_s=90.0),),
        dropouts=(Dropout(44.0, 1.0, every_s=50.0),),
    ),
    # for tests: 30 s at 2 Hz of 96 x 96 images, one of each event
    "smoke": StreamPreset(
        "smoke",
        minutes=0.5,
        rate_hz=2.0,
        image_size=(96, 96),
        bumps=(Bump(7.0, 20.0, 2.0), Bump(24.0, 200.0, 20.0, "remount")),
        occlusions=(Occlusion(11.0, 3.0, "person"),),
        lighting=(Lighting(16.0, 0.4, duration_s=3.0),),
        dropouts=(Dropout(20.0, 1.5),),
        drift=Drift(rate_mm_per_min=0.1, step_s=10.0),
    ),
}


def get_stream_preset(name: str) -> StreamPreset:
    """A stream preset by name; in a smoke run (:func:`handeye.core.smoke.smoke_test`) cut to its
    :meth:`StreamPreset.smoke` size.

    Raises
    ------
    HandEyeInputError
        Naming the known presets.
    """
    if name not in STREAM_PRESETS:
        raise HandEyeInputError(f"unknown stream preset {name!r}: use one of {', '.join(STREAM_PRESETS)}")
    return STREAM_PRESETS[name].smoke() if smoke_test() else STREAM_PRESETS[name]
