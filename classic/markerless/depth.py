"""Depth images as points, and the robot's pixels found from motion alone.

The camera is static while the robot moves (the data recording of one camera
placement), so everything that never moves (floor, walls, table, the robot's
base) has the same depth in every frame. A pixel whose depth in a frame is
clearly nearer than that static depth shows something that moved there: the
arm. This gives a mask of the arm without a model, a start or a colour cue.
"""

from __future__ import annotations

import numpy as np

from handeye.core.errors import ShapeError

__all__ = ["backproject", "static_depth", "moving_mask", "pixel_rays"]


def pixel_rays(K: np.ndarray, height: int, width: int) -> np.ndarray:
    """Camera-frame rays ``(x/z, y/z, 1)`` of every pixel centre.

    Parameters
    ----------
    K : array, shape (3, 3)
        OpenCV camera matrix (pixel centres at integer coordinates).
    height, width : int

    Returns
    -------
    rays : array, shape (height, width, 3)
    """
    v, u = np.mgrid[0:height, 0:width].astype(float)
    x = (u - K[0, 2] - K[0, 1] * (v - K[1, 2]) / K[1, 1]) / K[0, 0]
    y = (v - K[1, 2]) / K[1, 1]
    return np.stack([x, y, np.ones_like(x)], axis=-1)


def backproject(depth_m: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Camera-frame points of depth images (z along the optical axis).

    Parameters
    ----------
    depth_m : array, shape (..., H, W)
        Depth in metres, 0 (or NaN) where the sensor has none.
    K : array, shape (3, 3)

    Returns
    -------
    p_cam : array, shape (..., H, W, 3)
        Points in the OpenCV camera frame, metres; NaN where there is no depth.
    """
    depth_m = np.asarray(depth_m, dtype=float)
    if depth_m.ndim < 2:
        raise ShapeError(f"depth must be (..., H, W), got shape {depth_m.shape}")
    z = np.where(depth_m > 0, depth_m, np.nan)
    return pixel_rays(K, *depth_m.shape[-2:]) * z[..., None]


def static_depth(depth_m: np.ndarray, percentile: float = 90.0) -> np.ndarray:
    """Depth of what does not move, per pixel: a high percentile over the frames.

    A pixel the arm covers in some frames shows the background in the others,
    and the background is the farthest thing seen there; a high percentile
    rather than the maximum ignores a few far outliers of the sensor.

    Parameters
    ----------
    depth_m : array, shape (N, H, W)
        Depth of N frames from one static camera, 0 where missing.
    percentile : float

    Returns
    -------
    static_m : array, shape (H, W)
        0 where no frame has depth.
    """
    depth_m = np.asarray(depth_m, dtype=float)
    if depth_m.ndim != 3:
        raise ShapeError(f"depth must be (N, H, W), got shape {depth_m.shape}")
    # nearest-rank percentile of the valid depths per pixel (np.nanpercentile loops per pixel: far slower)
    z = np.sort(np.where(depth_m > 0, depth_m, np.inf), axis=0)
    count = (depth_m > 0).sum(axis=0)
    rank = np.floor(percentile / 100.0 * np.maximum(count - 1, 0)).astype(np.int64)
    out = np.take_along_axis(z, rank[None], axis=0)[0]
    out[count == 0] = 0.0
    return out


def moving_mask(depth_m: np.ndarray, static_m: np.ndarray, min_gap_m: float) -> np.ndarray:
    """Pixels of each frame nearer than the static depth by more than ``min_gap_m``.

    Parameters
    ----------
    depth_m : array, shape (N, H, W)
    static_m : array, shape (H, W)
        From :func:`static_depth`.
    min_gap_m : float or array, shape (N, H, W)
        Several depth-noise sigmas; pixels where the static depth is unknown count as moving
        when the frame has depth there.

    Returns
    -------
    mask : array of bool, shape (N, H, W)
    """
    depth_m = np.asarray(depth_m, dtype=float)
    valid = depth_m > 0
    return valid & ((static_m <= 0) | (depth_m < static_m - min_gap_m))
