"""One gross outlier in an otherwise clean pose set, as real cells make them: for tests and benchmarks.

Kinds (``size`` in metres or degrees):

* ``robot_translation``: the robot pose's translation moved by ``size`` m (a mis-typed row, a robot pose
  recorded before the arm settled);
* ``camera_translation``: the camera pose's translation moved by ``size`` m (a board detected at the wrong
  scale, a wrong PnP solution);
* ``camera_rotation``: the camera pose turned by ``size`` deg about a random axis of the board;
* ``board_flip``: the camera pose turned by 180 deg about the board's normal (a symmetric board detected the
  other way round; ``size`` unused).
"""

from __future__ import annotations

import numpy as np

from handeye.core.se3 import so3_exp

__all__ = ["OUTLIER_KINDS", "inject_outlier"]

OUTLIER_KINDS = ("robot_translation", "camera_translation", "camera_rotation", "board_flip")


def inject_outlier(
    T_base_ee: np.ndarray, T_cam_target: np.ndarray, kind: str, size: float, index: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Copies of the poses with pose ``index`` made a gross outlier of ``kind``.

    Parameters
    ----------
    T_base_ee, T_cam_target : array, shape (N, 4, 4)
    kind : str
        One of :data:`OUTLIER_KINDS`.
    size : float
        Metres for the translation kinds, degrees for ``camera_rotation``.
    index : int
    rng : numpy.random.Generator
        Draws the direction.

    Returns
    -------
    T_base_ee, T_cam_target : array, shape (N, 4, 4)
    """
    A, B = np.array(T_base_ee, dtype=float), np.array(T_cam_target, dtype=float)
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    if kind == "robot_translation":
        A[index, :3, 3] += size * direction
    elif kind == "camera_translation":
        B[index, :3, 3] += size * direction
    elif kind == "camera_rotation":
        B[index, :3, :3] = B[index, :3, :3] @ so3_exp(np.radians(size) * direction)
    elif kind == "board_flip":
        B[index, :3, :3] = B[index, :3, :3] @ so3_exp(np.array([0.0, 0.0, np.pi]))
    else:
        raise ValueError(f"unknown outlier kind {kind!r}: use one of {OUTLIER_KINDS}")
    return A, B
