"""Analytic images of a sphere, for checking rendered images against the camera model."""

from __future__ import annotations

import numpy as np


def ray_sphere(centre_cam: np.ndarray, radius: float, K: np.ndarray, width: int, height: int):
    """Mask and depth (camera z of the first hit) of a sphere, pixel centres at integers (OpenCV).

    Parameters
    ----------
    centre_cam : array, shape (3,)
        Sphere centre in the camera frame, metres.
    radius : float
    K : array, shape (3, 3)
    width, height : int

    Returns
    -------
    hit : array of bool, shape (H, W)
    depth_m : array, shape (H, W)
        0 where the ray misses.
    """
    u, v = np.meshgrid(np.arange(width, dtype=float), np.arange(height, dtype=float))
    rays = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], axis=-1)
    b = rays @ centre_cam
    a = np.sum(rays**2, axis=-1)
    disc = b**2 - a * (centre_cam @ centre_cam - radius**2)
    hit = disc > 0
    t = (b - np.sqrt(np.where(hit, disc, 0.0))) / a
    return hit, np.where(hit, t, 0.0)  # rays have z = 1, so t is the depth
