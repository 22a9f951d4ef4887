"""Where the lab stands around the robot: each camera's scene and the lab's pose ``T_base_lab`` in that scene.

A preset with ``scenes > 1`` records the robot standing at different places
and orientations in the same lab: the environment meshes of
:func:`sim.scene.environment_meshes` (floor, walls, objects; built in the lab
frame) are posed in the base frame by ``T_base_lab``. Scene 0 is today's lab
(the identity); in scene ``s >= 1`` the lab is turned about the vertical axis
by ``s`` times the golden angle (137.5 deg, so any number of scenes spreads
over the turn) and the robot stands :data:`LAB_SHIFT_M` from the lab's centre,
towards lab azimuth ``-s * 137.5`` deg (a different place and heading in each
scene). The robot, the cameras and the lights stay where they are in the base
frame: only the background changes.

Camera ``c`` of a preset with ``scenes`` scenes is in scene ``c % scenes``:
deterministic, independent of the seed, and even over regions (cameras are
numbered region by region, azimuth by azimuth, so neighbouring cameras are in
different scenes).

Clearance: the lab's objects and walls stand at least
:func:`lab_horizontal_clearance_m` from the base's vertical axis (2.15 m in
scene 0, at least 2.15 - 0.2 m = 1.95 m in any scene). A camera closer to the
axis than that is neither inside the scene geometry nor behind an object seen
from the robot: anything on the segment from such a camera to the robot (itself
within 1 m of the axis) is no farther from the axis than the camera, so the lab's
objects are background and never hide the robot.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import make_transform

__all__ = [
    "LAB_SHIFT_M",
    "LAB_TURN_DEG",
    "camera_scene",
    "T_base_lab",
    "lab_horizontal_clearance_m",
    "camera_horizontal_reach_m",
]

#: How far the lab is shifted horizontally in every scene but scene 0, metres.
LAB_SHIFT_M = 0.2
#: The lab's turn per scene index about the vertical axis, degrees (the golden angle).
LAB_TURN_DEG = 137.50776405003785


def camera_scene(camera_id, scenes: int):
    """The scene of each camera: ``camera_id % scenes``.

    Parameters
    ----------
    camera_id : int or array of int, shape (N,)
    scenes : int
        Scenes of the preset (>= 1).

    Returns
    -------
    int or array of int, shape (N,)
    """
    if int(scenes) < 1:
        raise HandEyeInputError(f"scenes must be >= 1, got {scenes}")
    return np.asarray(camera_id) % int(scenes) if np.ndim(camera_id) else int(camera_id) % int(scenes)


def T_base_lab(scene: int) -> np.ndarray:
    """The lab's pose in the base frame in a scene.

    Parameters
    ----------
    scene : int
        0-based scene index; scene 0 is the identity.

    Returns
    -------
    T_base_lab : array, shape (4, 4)
        Maps lab-frame points (the environment meshes) to the base frame: the lab turned by
        ``scene * LAB_TURN_DEG`` about the vertical axis, the base origin at ``LAB_SHIFT_M`` from
        the lab's origin towards lab azimuth ``-scene * LAB_TURN_DEG``, on the floor's plane.
    """
    scene = int(scene)
    if scene < 0:
        raise HandEyeInputError(f"scene must be >= 0, got {scene}")
    if scene == 0:
        return np.eye(4)
    turn = np.radians((scene * LAB_TURN_DEG) % 360.0)
    c, s = np.cos(turn), np.sin(turn)
    R_base_lab = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    p_lab_base = LAB_SHIFT_M * np.array([np.cos(-turn), np.sin(-turn), 0.0])  # where the robot stands in the lab
    return make_transform(R_base_lab, -R_base_lab @ p_lab_base)


def _distance_to_convex_polygon(xy: np.ndarray) -> float:
    """Distance from the origin to the convex hull of 2-D points (0 when the origin is inside).

    Parameters
    ----------
    xy : array, shape (N, 2)
    """
    from scipy.spatial import ConvexHull

    hull = ConvexHull(xy)
    if np.all(hull.equations[:, 2] <= 0):  # origin on the inner side of every edge (normal . 0 + offset <= 0)
        return 0.0
    a, b = xy[hull.simplices[:, 0]], xy[hull.simplices[:, 1]]
    ab = b - a
    t = np.clip(np.sum(-a * ab, axis=1) / np.sum(ab * ab, axis=1), 0.0, 1.0)
    return float(np.min(np.linalg.norm(a + t[:, None] * ab, axis=1)))


def lab_horizontal_clearance_m(T_base_lab: np.ndarray) -> float:
    """Horizontal distance from the base's vertical axis to the nearest wall or object of the lab (not the floor).

    Each environment mesh but the floor is convex; its distance to the axis is the distance
    from the origin to its footprint (the convex hull of its vertices projected on the
    ground).

    Parameters
    ----------
    T_base_lab : array, shape (4, 4)

    Returns
    -------
    float
        Metres.
    """
    R, t = np.asarray(T_base_lab)[:3, :3], np.asarray(T_base_lab)[:3, 3]
    return min(_distance_to_convex_polygon((v @ R.T + t)[:, :2]) for v in _walls_and_objects_lab())


@lru_cache(maxsize=1)
def _walls_and_objects_lab() -> tuple:
    """Vertices of each environment mesh but the floor, lab frame, metres: tuple of arrays, shape (V, 3)."""
    from sim.scene import environment_meshes

    return tuple(np.array(m.vertices) for m in environment_meshes()[1:])  # [0] is the floor


def camera_horizontal_reach_m(preset) -> float:
    """The farthest any camera of a preset stands from the base's vertical axis, metres.

    ``radius * cos(elevation)`` at the largest radius and the smallest elevation, plus the
    look-at point's own distance from the axis.

    Parameters
    ----------
    preset : sim.cameras.CameraPreset

    Returns
    -------
    float
    """
    elevation_min = np.radians(max(0.0, min(preset.elevation_deg)))
    return float(max(preset.radius_m) * np.cos(elevation_min) + np.linalg.norm(np.asarray(preset.look_at_m)[:2]))
