"""Where the camera can see the target from: sampled views, the visibility test, and the flange poses they need.

A *view* is a target pose in the camera's optical frame, ``T_cam_target`` (OpenCV: x right, y down,
z forward; the target's z points into the board, so its printed face looks back along ``-z``). A view
is in view (:func:`target_in_view`) when

* the target's origin (take it at the board's centre) lies ``min_distance_m`` to ``max_distance_m``
  in front of the camera, measured along the optical axis;
* it is inside the field of view less a margin: ``|x / z| <= tan(half_fov_x)`` and
  ``|y / z| <= tan(half_fov_y)``; the defaults (20 and 15 degrees) are a 60 x 45 degree camera less
  the half-extent of a 40 x 30 cm board seen from 0.6 m;
* the board is tilted at most ``max_tilt_deg`` from facing the camera: the angle between the target's
  z axis and the line of sight from the camera to the target's origin.

The same test serves both setups: eye-to-hand the static camera sees the board on the flange,
eye-in-hand the flange camera sees the static board. A view becomes a flange pose through the
current estimate (or guess) of X and Y (:func:`flange_poses`), and back (:func:`views_of`):

.. math:: T_{base,ee} = X\\, T_{cam,target}\\, Y^{-1} \\;(\\text{eye-to-hand}), \\qquad
          T_{base,ee} = Y\\, T_{cam,target}^{-1}\\, X^{-1} \\;(\\text{eye-in-hand}).

No robot model here: which of these flange poses an arm reaches is the front's business
(:mod:`handeye.planning`, with :mod:`handeye.robot.model`'s inverse kinematics).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import invert_transform, make_transform, so3_exp
from handeye.core.setups import normalize_setup, robot_side_poses

__all__ = ["ViewLimits", "facing_rotation", "sample_views", "target_in_view", "flange_poses", "views_of"]


@dataclass(frozen=True)
class ViewLimits:
    """Where the target may be for the camera to see it (the planner's workspace, in the camera frame).

    Attributes
    ----------
    min_distance_m, max_distance_m : float
        Range of the target's depth along the optical axis (default that of
        :func:`handeye.core.synthetic.make_problem`, 0.4 to 0.9 m).
    half_fov_x_deg, half_fov_y_deg : float
        Half-angles within which the target's origin stays (the camera's half field of view less a margin
        for the board's extent).
    max_tilt_deg : float
        Largest angle between the target's z axis and the line of sight (a ChArUco board is still
        detected well at 40 degrees).
    max_roll_deg : float
        Largest turn of the board in its own plane, sampled in ``[-max_roll, max_roll]`` (the test does not
        limit it: a ChArUco board is read at any turn).
    """

    min_distance_m: float = 0.4
    max_distance_m: float = 0.9
    half_fov_x_deg: float = 20.0
    half_fov_y_deg: float = 15.0
    max_tilt_deg: float = 40.0
    max_roll_deg: float = 90.0

    def __post_init__(self):
        if not 0.0 < self.min_distance_m < self.max_distance_m:
            raise HandEyeInputError(
                f"view distances must satisfy 0 < min < max, got {self.min_distance_m} and {self.max_distance_m} m"
            )
        for name in ("half_fov_x_deg", "half_fov_y_deg"):
            if not 0.0 < getattr(self, name) < 89.0:
                raise HandEyeInputError(f"{name} must lie in (0, 89) degrees, got {getattr(self, name)}")
        if not 0.0 <= self.max_tilt_deg < 89.0:
            raise HandEyeInputError(f"max_tilt_deg must lie in [0, 89) degrees, got {self.max_tilt_deg}")
        if not 0.0 <= self.max_roll_deg <= 180.0:
            raise HandEyeInputError(f"max_roll_deg must lie in [0, 180] degrees, got {self.max_roll_deg}")


def facing_rotation(p_cam: np.ndarray) -> np.ndarray:
    """Rotation of a target at ``p_cam`` that faces the camera: its z along the line of sight, x along the image's x.

    Parameters
    ----------
    p_cam : array, shape (N, 3)
        Target origins in the camera frame, in front of it (``z > 0``), metres.

    Returns
    -------
    R_cam_target : array, shape (N, 3, 3)
    """
    z = p_cam / np.linalg.norm(p_cam, axis=1, keepdims=True)
    x = np.array([1.0, 0.0, 0.0]) - z[:, :1] * z  # the camera's x, made perpendicular to the line of sight
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    return np.stack([x, np.cross(z, x), z], axis=-1)


def sample_views(rng: np.random.Generator, n: int, limits: ViewLimits = ViewLimits()) -> np.ndarray:
    """Draw target poses the camera sees: spread over the frustum, tilted and turned.

    The depth is uniform in the range, the origin uniform over the field of view's cross-section at
    that depth, the tilt from facing the camera ``max_tilt * sqrt(u)`` about a uniform axis in the board's
    plane (uniform over the cap of normals), the turn in the board's plane uniform in
    ``[-max_roll, max_roll]``.

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int
    limits : ViewLimits

    Returns
    -------
    T_cam_target : array, shape (n, 4, 4)
        Every one passes :func:`target_in_view` with ``limits``.
    """
    z = rng.uniform(limits.min_distance_m, limits.max_distance_m, n)
    tx, ty = np.tan(np.radians([limits.half_fov_x_deg, limits.half_fov_y_deg]))
    p = np.column_stack([rng.uniform(-tx, tx, n) * z, rng.uniform(-ty, ty, n) * z, z])
    R_face = facing_rotation(p)
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    tilt = np.radians(limits.max_tilt_deg) * np.sqrt(rng.uniform(0.0, 1.0, n))
    tilt_axis = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(n)]) * tilt[:, None]  # in the board's plane
    roll = np.radians(limits.max_roll_deg) * rng.uniform(-1.0, 1.0, n)
    R = R_face @ so3_exp(tilt_axis) @ so3_exp(np.column_stack([np.zeros((n, 2)), roll]))
    return make_transform(R, p)


def target_in_view(T_cam_target: np.ndarray, limits: ViewLimits = ViewLimits(), slack: float = 1e-9) -> np.ndarray:
    """Whether the camera sees each target pose within ``limits`` (the module docstring's three conditions).

    Parameters
    ----------
    T_cam_target : array, shape (N, 4, 4)
    limits : ViewLimits
    slack : float
        Added to every bound (rounding of poses that lie on a bound by construction).

    Returns
    -------
    array of bool, shape (N,)
    """
    T = np.asarray(T_cam_target, dtype=float).reshape(-1, 4, 4)
    p = T[:, :3, 3]
    z = p[:, 2]
    ok = (z >= limits.min_distance_m - slack) & (z <= limits.max_distance_m + slack)
    safe_z = np.where(z > 0, z, 1.0)
    tx, ty = np.tan(np.radians([limits.half_fov_x_deg, limits.half_fov_y_deg]))
    ok &= (np.abs(p[:, 0] / safe_z) <= tx + slack) & (np.abs(p[:, 1] / safe_z) <= ty + slack)
    sight = p / np.linalg.norm(p, axis=1, keepdims=True)
    cos_tilt = np.einsum("ni,ni->n", T[:, :3, 2], sight)
    ok &= cos_tilt >= np.cos(np.radians(limits.max_tilt_deg)) - slack
    return ok


def flange_poses(T_cam_target: np.ndarray, X: np.ndarray, Y: np.ndarray, setup: str) -> np.ndarray:
    """The flange poses that put the target at the given views, through X and Y.

    Parameters
    ----------
    T_cam_target : array, shape (N, 4, 4)
    X : array, shape (4, 4)
        ``T_base_cam`` (eye-to-hand) or ``T_ee_cam`` (eye-in-hand).
    Y : array, shape (4, 4)
        ``T_ee_target`` (eye-to-hand) or ``T_base_target`` (eye-in-hand).
    setup : {"eye_to_hand", "eye_in_hand"}

    Returns
    -------
    T_base_ee : array, shape (N, 4, 4)
    """
    if normalize_setup(setup) == "eye_to_hand":
        return X @ T_cam_target @ invert_transform(Y)
    return Y @ invert_transform(T_cam_target) @ invert_transform(X)


def views_of(T_base_ee: np.ndarray, X: np.ndarray, Y: np.ndarray, setup: str) -> np.ndarray:
    """The views the camera has at given flange poses: ``T_cam_target = X^-1 A_i Y`` (inverse of :func:`flange_poses`).

    Parameters
    ----------
    T_base_ee : array, shape (N, 4, 4)
    X, Y : array, shape (4, 4)
        As in :func:`flange_poses`.
    setup : {"eye_to_hand", "eye_in_hand"}

    Returns
    -------
    T_cam_target : array, shape (N, 4, 4)
    """
    return invert_transform(X) @ robot_side_poses(T_base_ee, setup) @ Y
