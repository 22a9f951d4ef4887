"""Which model points a camera sees: a point-splat z-buffer, in numpy.

The model is a dense sample of the robot's surface with outward normals.
Points facing away from the camera are dropped, the rest are projected, and
in every pixel the nearest one is kept. With a sample spacing near the
pixel footprint this is what a renderer's depth test gives, without an
OpenGL context, for all frames in one sort.
"""

from __future__ import annotations

import numpy as np

__all__ = ["project", "visible_points", "zbuffer_grid"]

_Z_STEPS = 1 << 24  # depth resolution of the sort key: 1 um steps up to 16.7 m


def project(p_cam: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Pinhole projection (no distortion) of camera-frame points, pixels ``(u, v)``, shape (..., 2)."""
    z = p_cam[..., 2]
    u = K[0, 0] * p_cam[..., 0] / z + K[0, 1] * p_cam[..., 1] / z + K[0, 2]
    v = K[1, 1] * p_cam[..., 1] / z + K[1, 2]
    return np.stack([u, v], axis=-1)


def zbuffer_grid(K: np.ndarray, height: int, width: int, stride: int) -> tuple[np.ndarray, int, int]:
    """The camera of a z-buffer ``stride`` image pixels wide: its matrix and its size.

    The focal lengths and the skew are divided by ``stride``; the principal point is moved so that each
    coarse pixel's centre is the centre of the ``stride`` x ``stride`` image pixels it covers:

    .. math:: c' = (c + 1/2) / s - 1/2

    Parameters
    ----------
    K : array, shape (3, 3)
        Camera matrix of the image (OpenCV convention: pixel centres at integers).
    height, width : int
        The image's size, pixels.
    stride : int
        Image pixels per z-buffer pixel, at least 1; 1 gives ``K`` (a copy) and the image's size.

    Returns
    -------
    K_grid : array, shape (3, 3)
        Camera matrix of the coarser grid.
    height_grid, width_grid : int
        Its size: the image's divided by ``stride``, rounded up.
    """
    K_grid = np.array(K, dtype=float)
    if stride > 1:
        K_grid[:2] /= stride
        K_grid[:2, 2] = (np.asarray(K, dtype=float)[:2, 2] + 0.5) / stride - 0.5  # pixel centres of the coarser grid
    return K_grid, -(-height // stride), -(-width // stride)


def visible_points(
    p_cam: np.ndarray,
    n_cam: np.ndarray,
    frame: np.ndarray,
    K: np.ndarray,
    height: int,
    width: int,
    znear_m: float = 0.05,
) -> np.ndarray:
    """The nearest front-facing model point in every pixel of every frame.

    Parameters
    ----------
    p_cam : array, shape (M, 3)
        Model points in the camera frame (all frames stacked).
    n_cam : array, shape (M, 3), or None
        Their outward unit normals in the camera frame; None when the caller has already dropped
        the points facing away.
    frame : array of int, shape (M,)
        Frame index of each point.
    K : array, shape (3, 3)
    height, width : int
    znear_m : float

    Returns
    -------
    index : array of int, shape (V,)
        Indices into the M points of the visible ones (one per covered pixel).
    """
    front = p_cam[:, 2] > znear_m
    if n_cam is not None:
        front &= np.einsum("ij,ij->i", p_cam, n_cam) < 0
    idx = np.flatnonzero(front)
    uv = np.rint(project(p_cam[idx], K)).astype(np.int64)
    inside = (uv[:, 0] >= 0) & (uv[:, 0] < width) & (uv[:, 1] >= 0) & (uv[:, 1] < height)
    idx, uv = idx[inside], uv[inside]
    key = (frame[idx].astype(np.int64) * height + uv[:, 1]) * width + uv[:, 0]
    # a scatter-min of (depth in 1 um steps, position) packed in one int64 per pixel: the nearest point
    # of each pixel, ties to the lower position, in one pass (6x faster than an argsort of the keys)
    z_um = np.minimum(np.rint(p_cam[idx, 2] * 1e6), _Z_STEPS - 1).astype(np.int64)
    if len(idx) == 0:
        return idx
    bits = max(1, (len(idx) - 1).bit_length())
    if bits + (_Z_STEPS - 1).bit_length() > 63:
        raise ValueError(f"{len(idx)} projected points are too many for one z-buffer pass; split the frames")
    empty = np.iinfo(np.int64).max
    zbuf = np.full(int(key.max()) + 1, empty, dtype=np.int64)
    np.minimum.at(zbuf, key, (z_um << bits) | np.arange(len(idx), dtype=np.int64))
    nearest = zbuf[zbuf != empty] & ((1 << bits) - 1)  # in pixel order
    return idx[nearest]
