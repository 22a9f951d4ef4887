"""Camera placement: poses on a hemisphere around the robot base, grouped into regions by azimuth.

Positions come from sines and cosines of azimuth and elevation (the paper's
recipe), each camera looking at the workspace centre with its x axis
horizontal, in the OpenCV optical convention (x right, y down, z forward).
Regions (the subsets S1..Sk of the continual-learning protocol) are azimuth
sectors; within each region a seeded choice of poses is held out for test.

Presets: ``paper-sim`` (the paper's 108 poses, UR5), ``paper-real`` (the
paper's 24-pose real rig, UR3), ``demo`` and ``small`` (quick looks, tests),
and ``dense-sim``: 1,000 poses over the whole hemisphere (10 azimuth sectors
of 36 deg, 80 train + 20 test each; elevation 10-75 deg, distance 1.1-1.8 m)
in 4 scenes, the robot standing at different places and headings in the lab
(:mod:`sim.lab`: camera ``c`` is in scene ``c % 4``, the lab posed by
``T_base_lab(scene)``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.smoke import smoke_test
from handeye.robot.look_at import look_at

__all__ = ["CameraPreset", "CameraSet", "PRESETS", "camera_on_sphere", "get_preset", "place_cameras"]


@dataclass(frozen=True)
class CameraPreset:
    """How cameras and robot configurations are laid out for a dataset.

    Attributes
    ----------
    name : str
    robot : {"ur5", "ur3"}
    region_azimuths_deg : tuple of (float, float)
        Azimuth sector of each region, degrees, in time-step order.
    train_per_region, test_per_region : tuple of int
        Camera poses of each region for training and for testing.
    configurations : int
        Robot configurations recorded per camera pose (data recording).
    calibration_views : int
        Board views recorded per camera pose (calibration recording).
    radius_m : (float, float)
        Camera distance from the look-at point.
    elevation_deg : (float, float)
        Camera elevation above the base plane.
    look_at_m : (float, float, float)
        Workspace centre the cameras look at, in the base frame.
    image_size : (int, int)
        ``(width, height)`` of the data images.
    calibration_image_size : (int, int)
        ``(width, height)`` of the calibration images: the same camera at a higher resolution (the
        learner gets downscaled images; the calibration uses the sensor's resolution).
    fov_deg : float
        Horizontal field of view.
    scenes : int
        Scenes (>= 1): where the robot stands in the lab; camera ``c`` is in scene ``c % scenes``
        and the lab is posed by :func:`sim.lab.T_base_lab`. 1 is today's lab for every camera.
    """

    name: str
    robot: str
    region_azimuths_deg: tuple
    train_per_region: tuple
    test_per_region: tuple
    configurations: int
    calibration_views: int = 15
    radius_m: tuple = (1.3, 1.7)
    elevation_deg: tuple = (20.0, 50.0)
    look_at_m: tuple = (0.0, 0.0, 0.3)
    image_size: tuple = (256, 256)
    calibration_image_size: tuple = (640, 640)
    fov_deg: float = 60.0
    scenes: int = 1

    def __post_init__(self):
        k = len(self.region_azimuths_deg)
        if not (len(self.train_per_region) == len(self.test_per_region) == k):
            raise HandEyeInputError(f"preset {self.name}: one train and one test count per region ({k} regions)")
        if isinstance(self.scenes, bool) or not isinstance(self.scenes, (int, np.integer)) or self.scenes < 1:
            raise HandEyeInputError(f"preset {self.name}: scenes must be an integer >= 1, got {self.scenes!r}")
        object.__setattr__(self, "scenes", int(self.scenes))  # a plain int, for the JSON recipe

    @classmethod
    def from_dict(cls, doc: dict) -> "CameraPreset":
        """Inverse of ``dataclasses.asdict`` after a JSON round trip (lists back to tuples)."""

        def as_tuple(v):
            return tuple(as_tuple(x) for x in v) if isinstance(v, list) else v

        return cls(**{k: as_tuple(v) for k, v in doc.items()})

    def to_dict(self) -> dict:
        """The preset as a dataset recipe stores it: ``dataclasses.asdict`` without ``scenes`` when it is 1.

        Recipes written before presets had scenes lack the field; leaving it out when it is 1 keeps
        their recipes, and so the resume check that compares them, unchanged.
        :meth:`from_dict` reads either back (a missing ``scenes`` is 1).
        """
        doc = asdict(self)
        if self.scenes == 1:
            del doc["scenes"]
        return doc

    def smoke(self) -> "CameraPreset":
        """This preset cut to a smoke run's size (:mod:`handeye.core.smoke`): at most 2 train and 1 test
        placements per region, 6 configurations and 6 calibration views (15 motion pairs: the classic labels
        still determined, in seconds); the same name, robot, regions,
        distances, image sizes and scenes."""
        return replace(
            self,
            train_per_region=tuple(min(int(n), 2) for n in self.train_per_region),
            test_per_region=tuple(min(int(n), 1) for n in self.test_per_region),
            configurations=min(self.configurations, 6),
            calibration_views=min(self.calibration_views, 6),
        )

    @property
    def n_cameras(self) -> int:
        """Camera poses in all."""
        return int(sum(self.train_per_region) + sum(self.test_per_region))


def _sectors(k: int, start: float = 0.0, span: float = 360.0) -> tuple:
    width = span / k
    return tuple((start + i * width, start + (i + 1) * width) for i in range(k))


PRESETS = {
    # the paper's simulation: 108 poses, 6 regions of 14 train + 4 test, 50 configurations, UR5
    "paper-sim": CameraPreset("paper-sim", "ur5", _sectors(6), (14,) * 6, (4,) * 6, 50),
    # the paper's real rig: 24 poses on three sides of the table (front, side at 90 deg, back at 180 deg),
    # 19 train + 5 test in all, 100 configurations, UR3
    "paper-real": CameraPreset(
        "paper-real",
        "ur3",
        ((-30.0, 30.0), (60.0, 120.0), (150.0, 210.0)),
        (6, 7, 6),
        (2, 1, 2),
        100,
        radius_m=(0.9, 1.2),
        elevation_deg=(25.0, 45.0),
        look_at_m=(0.0, 0.0, 0.2),
    ),
    # the README's demo: 2 regions of 4 train + 1 test, 20 configurations, small images
    "demo": CameraPreset(
        "demo",
        "ur5",
        ((0.0, 30.0), (30.0, 60.0)),
        (6, 6),
        (1, 1),
        20,
        calibration_views=10,
        radius_m=(1.4, 1.6),
        elevation_deg=(30.0, 40.0),
        image_size=(128, 128),
        calibration_image_size=(480, 480),
    ),
    # for tests and CI: 2 regions of 2 train + 1 test, 6 configurations
    "small": CameraPreset(
        "small",
        "ur5",
        _sectors(2),
        (2, 2),
        (1, 1),
        6,
        calibration_views=10,
        image_size=(128, 128),
        calibration_image_size=(480, 480),
    ),
    # dense coverage of the whole hemisphere in several scenes: 1,000 poses, 10 azimuth sectors of 36 deg with
    # 80 train + 20 test each, elevation 10-75 deg (look_at refuses straight down), 1.1-1.8 m from the workspace
    # centre, in 4 scenes (camera c in scene c % 4: the robot at another place and heading in the lab, sim.lab;
    # the lab's objects stay >= 1.95 m from the base axis, the cameras within 1.8 cos 10 deg = 1.77 m);
    # UR5, 50 configurations and 15 calibration views, 256x256 data and 640x640 calibration images as paper-sim
    "dense-sim": CameraPreset(
        "dense-sim",
        "ur5",
        _sectors(10),
        (80,) * 10,
        (20,) * 10,
        50,
        calibration_views=15,
        radius_m=(1.1, 1.8),
        elevation_deg=(10.0, 75.0),
        image_size=(256, 256),
        calibration_image_size=(640, 640),
        scenes=4,
    ),
}


def get_preset(name: str) -> CameraPreset:
    """A preset by name; in a smoke run (:func:`handeye.core.smoke.smoke_test`) cut to its
    :meth:`CameraPreset.smoke` size.

    Raises
    ------
    HandEyeInputError
        Naming the known presets.
    """
    if name not in PRESETS:
        raise HandEyeInputError(f"unknown preset {name!r}: use one of {', '.join(PRESETS)}")
    return PRESETS[name].smoke() if smoke_test() else PRESETS[name]


@dataclass
class CameraSet:
    """Camera poses of a preset.

    Attributes
    ----------
    T_base_cam : array, shape (N, 4, 4)
    region : array of int, shape (N,)
        0-based region (subset S1 is 0).
    split : array of str, shape (N,)
        ``"train"`` or ``"test"``.
    azimuth_deg, elevation_deg, radius_m : array, shape (N,)
    """

    T_base_cam: np.ndarray
    region: np.ndarray
    split: np.ndarray
    azimuth_deg: np.ndarray
    elevation_deg: np.ndarray
    radius_m: np.ndarray
    meta: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.T_base_cam)


def camera_on_sphere(centre_m, azimuth_deg, elevation_deg, radius_m) -> np.ndarray:
    """``T_base_cam`` of cameras on a sphere around ``centre_m``, each looking at it (:func:`look_at`).

    Parameters
    ----------
    centre_m : array, shape (3,)
        Base frame, metres.
    azimuth_deg, elevation_deg, radius_m : float or array, shape (N,)
        Azimuth from the base's x axis toward its y axis and elevation above its xy plane, degrees; distance
        from the centre, metres.

    Returns
    -------
    T_base_cam : array, shape (4, 4) or (N, 4, 4)
    """
    centre = np.asarray(centre_m, dtype=float)
    a, e = np.radians(azimuth_deg), np.radians(elevation_deg)
    direction = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=-1)
    return look_at(centre + np.asarray(radius_m, dtype=float)[..., None] * direction, centre)


def place_cameras(preset: CameraPreset, rng: np.random.Generator) -> CameraSet:
    """Camera poses of a preset: per region, azimuths spread over the sector, elevations and radii drawn.

    Within a region the azimuths are evenly spaced with a random jitter (so the
    region is covered evenly), elevation and radius uniform in their ranges;
    the test poses are a seeded random choice within the region.

    Parameters
    ----------
    preset : CameraPreset
    rng : numpy.random.Generator

    Returns
    -------
    CameraSet
        Ordered by region, then azimuth.
    """
    T, region, split, az_all, el_all, r_all = [], [], [], [], [], []
    for k, (a0, a1) in enumerate(preset.region_azimuths_deg):
        n = preset.train_per_region[k] + preset.test_per_region[k]
        width = (a1 - a0) / n
        az = a0 + width * (np.arange(n) + rng.uniform(0.2, 0.8, n))
        el = rng.uniform(*preset.elevation_deg, n)
        r = rng.uniform(*preset.radius_m, n)
        T.append(camera_on_sphere(preset.look_at_m, az, el, r))
        is_test = np.zeros(n, dtype=bool)
        is_test[rng.choice(n, preset.test_per_region[k], replace=False)] = True
        split.append(np.where(is_test, "test", "train"))
        region.append(np.full(n, k))
        az_all.append(az)
        el_all.append(el)
        r_all.append(r)
    return CameraSet(
        np.concatenate(T),
        np.concatenate(region),
        np.concatenate(split),
        np.concatenate(az_all),
        np.concatenate(el_all),
        np.concatenate(r_all),
        {"preset": preset.name},
    )
