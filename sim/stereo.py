"""Active stereo simulated: two infrared views of a projected dot pattern, matched by semi-global block matching.

The most faithful depth of an active-stereo camera (a RealSense D4xx) is the one its principle produces:
a projector between two infrared cameras throws a random dot pattern on the scene, each camera sees it,
a block matcher finds each left pixel's disparity ``d`` in the right image, and depth is ``z = f B / d``.
Its errors are the matcher's: sub-pixel disparity noise that grows as ``z^2``, correlated over the
matching window, lost matches where one camera does not see what the other does (occlusion), and mixed
depths at edges where the window straddles foreground and background.

From a true depth image of the left infrared camera (the depth camera, intrinsics ``K``):

1. the left view: each pixel's surface point, seen by the projector (half the baseline to the right),
   takes the dot pattern's intensity there; dark background where nothing was rendered;
2. the right view: the left pixels forward-warped by their disparity (a z-buffer per row keeps the
   nearest), the right camera's depth interpolated in ``1/z`` along each row between the visible samples,
   and each right pixel's surface point lit by the same pattern;
3. sensor noise on both 8-bit images, OpenCV's ``StereoSGBM`` on the pair, ``z = f B / d``.

The stereo runs at the rendered image's resolution; the baseline is scaled by the sensor's native focal
length over the rendered one (``B f_native / f``), so that the disparities, and with them the matcher's
sub-pixel error in depth, are those of the sensor at its own resolution.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

__all__ = ["dot_pattern", "ir_views", "active_stereo_depth"]


def dot_pattern(shape: tuple, rng: np.random.Generator, density: float = 0.25, blur_px: float = 0.7) -> np.ndarray:
    """A random dot pattern (the projector's image), values in [0, 1], shape ``shape``."""
    dots = (rng.random(shape) < density).astype(float)
    pattern = ndimage.gaussian_filter(dots, blur_px)
    return pattern / max(pattern.max(), 1e-12)


def _sample(pattern: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear samples of the pattern at (u, v), 0 outside."""
    return ndimage.map_coordinates(pattern, [v, u], order=1, mode="constant", cval=0.0)


def _right_depth(depth: np.ndarray, fb: float) -> np.ndarray:
    """The right camera's depth from the left's: warped by disparity, nearest kept, ``1/z`` interpolated."""
    h, w = depth.shape
    out = np.zeros_like(depth)
    u = np.arange(w, dtype=float)
    for r in range(h):
        z = depth[r]
        ok = z > 0
        if ok.sum() < 2:
            continue
        x_r = u[ok] - fb / z[ok]
        inv = 1.0 / z[ok]
        # z-buffer on the integer grid: a right pixel sees the nearest warped sample (largest 1/z)
        cell = np.round(x_r).astype(int)
        inside = (cell >= 0) & (cell < w)
        best = np.full(w, -np.inf)
        np.maximum.at(best, cell[inside], inv[inside])
        visible = inside & (inv >= best[np.clip(cell, 0, w - 1)] - 1e-9)
        if visible.sum() < 2:
            continue
        order = np.argsort(x_r[visible])
        xs, ivs = x_r[visible][order], inv[visible][order]
        covered = (u >= xs[0]) & (u <= xs[-1])
        row = np.interp(u, xs, ivs)
        # no sample within 1.5 pixels: a hole the right camera sees into (the background behind an edge)
        gap = np.abs(u - xs[np.clip(np.searchsorted(xs, u), 0, len(xs) - 1)])
        gap = np.minimum(gap, np.abs(u - xs[np.clip(np.searchsorted(xs, u) - 1, 0, len(xs) - 1)]))
        good = covered & (gap <= 1.5)
        out[r, good] = 1.0 / row[good]
    return out


def ir_views(
    depth_m: np.ndarray, K: np.ndarray, baseline_m: float, pattern: np.ndarray, rng: np.random.Generator,
    noise_grey: float = 2.0, ambient: float = 0.08,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The left and right infrared images (uint8) of the projected pattern on the scene.

    Parameters
    ----------
    depth_m : array, shape (H, W)
        The left camera's true depth, 0 where nothing is.
    K : array, shape (3, 3)
    baseline_m : float
        The right camera sits ``baseline_m`` along the left camera's x axis; the projector halfway.
    pattern : array, shape (H, W)
        The projector's image (:func:`dot_pattern`), seen through the same intrinsics as the cameras.
    rng : numpy.random.Generator
        For the image noise.
    noise_grey : float
        Sensor noise, grey levels (one sigma).
    ambient : float
        Ambient light reflected by every surface, as a share of the dots' brightness.
    """
    fx = K[0, 0]
    fb = fx * baseline_m
    h, w = depth_m.shape
    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    views = []
    for z, shift in ((depth_m, 0.5), (_right_depth(depth_m, fb), -0.5)):
        ok = z > 0
        zz = np.where(ok, z, 1.0)
        # projector at +B/2 from the left camera, -B/2 from the right one: u_p = u - f (x_p) / z
        u_p = u - shift * fb / zz
        lit = np.where(ok, 0.85 * _sample(pattern, u_p, v) + ambient, 0.02)
        grey = 220.0 * lit + rng.normal(0.0, noise_grey, size=lit.shape)
        views.append(np.clip(np.rint(grey), 0, 255).astype(np.uint8))
    return views[0], views[1]


def active_stereo_depth(
    depth_m: np.ndarray,
    K: np.ndarray,
    baseline_m: float,
    rng: np.random.Generator,
    block_px: int = 7,
    noise_grey: float = 2.0,
) -> np.ndarray:
    """Depth as an active-stereo camera measures it, from the true depth of its left camera.

    Parameters
    ----------
    depth_m : array, shape (H, W)
        True depth, metres, 0 where nothing is.
    K : array, shape (3, 3)
        The left (depth) camera's intrinsics.
    baseline_m : float
        Stereo baseline at this image's resolution (the sensor's scaled by ``f_native / f``).
    rng : numpy.random.Generator
        The dot pattern and the image noise.
    block_px : int
        The matching window (odd).
    noise_grey : float
        Image noise, grey levels.

    Returns
    -------
    array, shape (H, W)
        Measured depth, metres, 0 where the matcher found no disparity.
    """
    import cv2

    valid = depth_m > 0
    if not valid.any():
        return np.zeros_like(depth_m, dtype=float)
    fb = K[0, 0] * baseline_m
    pattern = dot_pattern(depth_m.shape, rng)
    left, right = ir_views(depth_m, K, baseline_m, pattern, rng, noise_grey)
    d_max = fb / depth_m[valid].min()
    n_disp = int(16 * np.ceil((d_max + 8) / 16))
    sgbm = cv2.StereoSGBM_create(
        minDisparity=0,
        numDisparities=n_disp,
        blockSize=block_px,
        P1=8 * block_px**2,
        P2=32 * block_px**2,
        uniquenessRatio=5,
        speckleWindowSize=50,
        speckleRange=2,
        disp12MaxDiff=1,
        mode=cv2.STEREO_SGBM_MODE_HH,
    )
    disparity = sgbm.compute(left, right).astype(float) / 16.0  # fixed point, 4 fractional bits
    ok = disparity > 0.5
    return np.where(ok, fb / np.where(ok, disparity, 1.0), 0.0)
