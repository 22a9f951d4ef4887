"""A camera's pose from where it is and what it looks at."""

from __future__ import annotations

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import make_transform

__all__ = ["look_at"]


def look_at(position: np.ndarray, target: np.ndarray, up: np.ndarray = np.array([0.0, 0.0, 1.0])) -> np.ndarray:
    """``T_base_cam`` of an OpenCV camera at ``position`` looking at ``target``, x axis horizontal.

    Parameters
    ----------
    position, target : array, shape (..., 3)
        Base frame, metres.
    up : array, shape (3,)
        The world's up direction; the camera's y axis points away from it (down).

    Returns
    -------
    T_base_cam : array, shape (..., 4, 4)

    Raises
    ------
    HandEyeInputError
        When looking straight along ``up`` (the horizontal is undefined).
    """
    position = np.asarray(position, dtype=float)
    z = np.asarray(target, dtype=float) - position
    z = z / np.linalg.norm(z, axis=-1, keepdims=True)
    x = np.cross(z, up)
    norm = np.linalg.norm(x, axis=-1, keepdims=True)
    if np.any(norm < 1e-9):
        raise HandEyeInputError("camera looks straight up or down: its horizontal axis is undefined")
    x = x / norm
    y = np.cross(z, x)
    return make_transform(np.stack([x, y, z], axis=-1), position)
