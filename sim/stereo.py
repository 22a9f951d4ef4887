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

The stereo runs at the sensor's own resolution: a depth image rendered coarser than that (a D435 recorded
at 424x240 computes its depth at 848x480 and decimates it) is first brought up by the whole factor
``m = round(f_native / f)`` (inverse depth interpolated bilinearly within a surface, which is exact for a plane;
the nearest sample across an edge), matched there with the sensor's 7x7 window, and decimated back as
librealsense's decimation filter does (the median of each block's valid pixels for ``m`` of 2 and 3, the mean
beyond; librealsense ``doc/post-processing-filters.md``). Matching at the rendered resolution instead would
widen the window over the scene by ``m`` and with it the matcher's bias on curved and slanted surfaces. The
baseline is scaled by whatever ratio remains (``B f_native / (m f)``), so that the disparities, and with
them the matcher's sub-pixel error in depth, are those of the sensor.

The projector's dot pattern is fixed to the unit (``pattern_seed``): the same dots in every frame, as a
real projector throws them, so a static surface's matching error stays put from frame to frame.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

__all__ = ["dot_pattern", "ir_views", "active_stereo_depth", "upsample_depth", "decimate_depth"]


def dot_pattern(shape: tuple, rng: np.random.Generator, density: float = 0.25, blur_px: float = 0.7) -> np.ndarray:
    """A random dot pattern (the projector's image), values in [0, 1], shape ``shape``."""
    dots = (rng.random(shape) < density).astype(float)
    pattern = ndimage.gaussian_filter(dots, blur_px)
    return pattern / max(pattern.max(), 1e-12)


def upsample_depth(depth_m: np.ndarray, factor: int, edge_jump_m: float = 0.02) -> np.ndarray:
    """A depth image at ``factor`` times the resolution, pixel centres kept (``u_up = factor (u + 0.5) - 0.5``).

    Inverse depth is interpolated bilinearly where the four neighbours lie on one surface (depths within
    ``edge_jump_m``; exact for a plane, whose inverse depth is linear in the image), the nearest sample is
    taken across an edge or beside a missing pixel.

    Parameters
    ----------
    depth_m : array, shape (H, W)
        Metres, 0 where nothing is.
    factor : int
        At least 1.
    edge_jump_m : float

    Returns
    -------
    array, shape (factor H, factor W)
    """
    if factor == 1:
        return np.asarray(depth_m, dtype=float).copy()
    h, w = depth_m.shape
    uu = np.clip((np.arange(factor * w) + 0.5) / factor - 0.5, 0, w - 1)
    vv = np.clip((np.arange(factor * h) + 0.5) / factor - 0.5, 0, h - 1)
    u0, v0 = np.minimum(np.floor(uu).astype(int), w - 2), np.minimum(np.floor(vv).astype(int), h - 2)
    a, b = uu - u0, vv - v0
    V0, U0 = np.meshgrid(v0, u0, indexing="ij")
    B_, A_ = np.meshgrid(b, a, indexing="ij")
    corners = np.stack([depth_m[V0, U0], depth_m[V0, U0 + 1], depth_m[V0 + 1, U0], depth_m[V0 + 1, U0 + 1]])
    weights = np.stack([(1 - A_) * (1 - B_), A_ * (1 - B_), (1 - A_) * B_, A_ * B_])
    valid = corners > 0
    one_surface = valid.all(axis=0) & (corners.max(axis=0) - corners.min(axis=0) <= edge_jump_m)
    inv = np.where(valid, 1.0 / np.where(valid, corners, 1.0), 0.0)
    smooth = 1.0 / np.maximum((weights * inv).sum(axis=0), 1e-12)
    nearest = corners[np.argmax(weights, axis=0), np.arange(len(vv))[:, None], np.arange(len(uu))[None, :]]
    return np.where(one_surface, smooth, nearest)


def decimate_depth(depth_m: np.ndarray, factor: int) -> np.ndarray:
    """librealsense's decimation filter: each ``factor x factor`` block's valid pixels, median (2, 3) or mean.

    Parameters
    ----------
    depth_m : array, shape (factor H, factor W)
        0 where the sensor has no depth.
    factor : int

    Returns
    -------
    array, shape (H, W)
        0 where the block has no valid pixel.
    """
    if factor == 1:
        return np.asarray(depth_m, dtype=float).copy()
    h, w = depth_m.shape[0] // factor, depth_m.shape[1] // factor
    blocks = depth_m[: h * factor, : w * factor].reshape(h, factor, w, factor).transpose(0, 2, 1, 3)
    blocks = np.where(blocks > 0, blocks, np.nan).reshape(h, w, factor * factor)
    empty = np.isnan(blocks).all(axis=-1)
    blocks[empty] = 0.0
    out = np.nanmedian(blocks, axis=-1) if factor <= 3 else np.nanmean(blocks, axis=-1)
    return np.where(empty, 0.0, out)


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
    upsample: int = 1,
    pattern_seed: int | None = None,
) -> np.ndarray:
    """Depth as an active-stereo camera measures it, from the true depth of its left camera.

    Parameters
    ----------
    depth_m : array, shape (H, W)
        True depth, metres, 0 where nothing is.
    K : array, shape (3, 3)
        The left (depth) camera's intrinsics.
    baseline_m : float
        Stereo baseline at the matching resolution (the sensor's scaled by ``f_native / (upsample f)``).
    rng : numpy.random.Generator
        The image noise, and the dot pattern when ``pattern_seed`` is None.
    block_px : int
        The matching window (odd), in pixels of the matching resolution.
    noise_grey : float
        Image noise, grey levels.
    upsample : int
        Match at this many times the image's resolution and decimate back (:func:`upsample_depth`,
        :func:`decimate_depth`): the sensor's own resolution when the image is rendered coarser.
    pattern_seed : int, optional
        The projector's pattern, fixed to the unit: the same dots for every frame of that seed.

    Returns
    -------
    array, shape (H, W)
        Measured depth, metres, 0 where the matcher found no disparity.
    """
    import cv2

    valid = depth_m > 0
    if not valid.any():
        return np.zeros_like(depth_m, dtype=float)
    m = int(upsample)
    if m < 1:
        raise ValueError(f"upsample must be a whole factor of at least 1, got {upsample}")
    fine = upsample_depth(depth_m, m)
    K_fine = np.array(K, dtype=float)
    K_fine[:2, :2] *= m
    K_fine[:2, 2] = m * (K_fine[:2, 2] + 0.5) - 0.5
    fb = K_fine[0, 0] * baseline_m
    pattern = dot_pattern(fine.shape, rng if pattern_seed is None else np.random.default_rng(pattern_seed))
    left, right = ir_views(fine, K_fine, baseline_m, pattern, rng, noise_grey)
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
    return decimate_depth(np.where(ok, fb / np.where(ok, disparity, 1.0), 0.0), m)
