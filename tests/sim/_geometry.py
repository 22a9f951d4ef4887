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


def assert_sphere_rendered(
    mask: np.ndarray,
    depth_m: np.ndarray,
    centre_cam: np.ndarray,
    radius: float,
    K: np.ndarray,
    min_pixels: int,
    min_core: int,
    depth_atol_m: float,
) -> tuple[float, float]:
    """A rendered sphere covers the pixels whose rays hit it (to MAX_MASK_MISMATCH_PX) at the ray-sphere depth.

    The depth is compared on the core (within CORE_FRACTION of the projected radius, where the facets do
    not graze the rays). Returns the projected centre ``(u, v)``.
    """
    from tests.tolerances import CORE_FRACTION, MAX_MASK_MISMATCH_PX

    H, W = mask.shape
    u = K[0, 0] * centre_cam[0] / centre_cam[2] + K[0, 2]
    v = K[1, 1] * centre_cam[1] / centre_cam[2] + K[1, 2]
    expected, expected_depth = ray_sphere(centre_cam, radius, K, W, H)
    assert expected.sum() > min_pixels
    assert np.sum(mask != expected) <= MAX_MASK_MISMATCH_PX
    rows, cols = np.mgrid[0:H, 0:W]
    core = np.hypot(cols - u, rows - v) < CORE_FRACTION * K[0, 0] * radius / centre_cam[2]
    assert core.sum() >= min_core
    np.testing.assert_allclose(depth_m[core], expected_depth[core], atol=depth_atol_m)
    return u, v
