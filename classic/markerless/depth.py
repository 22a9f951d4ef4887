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


def depth_noise_curve(
    depth_m: np.ndarray, max_frames: int = 12, bins: int = 10, lag_px: int = 2
) -> tuple[np.ndarray, np.ndarray]:
    """The sensor's depth noise against depth, measured on the static background of the frames.

    Two measures, the larger taken per depth bin:

    - **over time**: the camera is static, so a background pixel's depth differs between frames only by
      the sensor's noise: its robust spread over frames (1.4826 MAD) is that pixel's noise sigma, whatever
      the sensor's principle (growing with depth squared for stereo, nearly constant for time of flight).
      The arm covers a pixel in a few frames at most; the median ignores them.
    - **over space**: an error that stays put from frame to frame (a stereo matcher's error under a fixed
      projector pattern, a time-of-flight camera's multipath) has no spread over time. Across the image it
      does: on a plane the inverse depth is affine in the pixel coordinates, so its second difference at a
      lag of ``lag_px`` pixels, ``w(u - k) - 2 w(u) + w(u + k)``, is zero but for the noise (variance 6
      sigma^2 for errors correlated over less than the lag), and the background's floor and walls are planes.
      Taken in rows and columns of each frame where it shows the background, robustly (1.4826 MAD), so
      the stencils that cross an edge do not count.

    Pixels are binned by depth and each bin's median sigma taken.

    Parameters
    ----------
    depth_m : array, shape (N, H, W)
        Depth of N frames from one static camera, 0 where missing.
    max_frames : int
        Frames used (spread over the recording): pixels with depth in all of them are measured.
    bins : int
        Depth bins (equal counts).
    lag_px : int
        Lag of the second difference (at least the sensor's correlation length in these pixels).

    Returns
    -------
    z_m : array, shape (B,)
        Bin centres (median depth of each bin), increasing; empty when fewer than 3 frames or 100
        pixels can be measured.
    sigma_m : array, shape (B,)
        Noise sigma at ``z_m``.
    """
    depth_m = np.asarray(depth_m, dtype=float)
    n = len(depth_m)
    if n < 3:
        return np.empty(0), np.empty(0)
    use = depth_m[np.unique(np.linspace(0, n - 1, min(n, max_frames)).round().astype(int))]
    valid = (use > 0).all(axis=0)
    if valid.sum() < 100:
        return np.empty(0), np.empty(0)
    z = use[:, valid]
    med = np.median(z, axis=0)
    sigma = 1.4826 * np.median(np.abs(z - med), axis=0)
    spatial = _spatial_second_difference(use, med, valid, lag_px)  # (2 F, P): depth error units, NaN unusable
    order = np.argsort(med)
    chunks = np.array_split(order, min(bins, max(1, len(order) // 50)))
    z_bins, sigma_bins = [], []
    for c in chunks:
        s_time = float(np.median(sigma[c]))
        d = spatial[:, c]
        d = d[np.isfinite(d)]
        s_space = 1.4826 * float(np.median(np.abs(d - np.median(d)))) / np.sqrt(6.0) if len(d) >= 50 else 0.0
        z_bins.append(float(np.median(med[c])))
        sigma_bins.append(max(s_time, s_space))
    return np.array(z_bins), np.array(sigma_bins)


def _spatial_second_difference(frames: np.ndarray, med: np.ndarray, valid: np.ndarray, lag: int) -> np.ndarray:
    """Second differences of inverse depth along rows and columns at the valid pixels, in metres of depth.

    A stencil counts where all three pixels show the background in that frame (within 2 cm of their median
    depth over the frames) and lie within 5 % of the centre's depth (one surface); NaN elsewhere.
    """
    med_img = np.zeros(frames.shape[1:])
    med_img[valid] = med
    background = (frames > 0) & (np.abs(frames - med_img) < 0.02) & valid
    inv = np.where(background, 1.0 / np.where(background, frames, 1.0), np.nan)
    out = []
    for axis in (1, 2):
        n = inv.shape[axis]
        centre, a, b = (inv.take(np.arange(lo, n - 2 * lag + lo), axis=axis) for lo in (lag, 0, 2 * lag))
        d2 = np.full(inv.shape, np.nan)
        with np.errstate(invalid="ignore"):
            same = (np.abs(a - centre) < 0.05 * centre) & (np.abs(b - centre) < 0.05 * centre)
            inner = np.where(same, (a - 2 * centre + b) / np.where(same, centre, 1.0) ** 2, np.nan)
        d2[(slice(None),) * axis + (slice(lag, n - lag),)] = inner
        out.append(d2[:, valid])
    return np.concatenate(out, axis=0)


def _over_3x3(op, a: np.ndarray) -> np.ndarray:
    """``op`` (``np.minimum`` or ``np.maximum``) over each pixel's 3x3 neighbourhood in every frame of ``a``
    (N, H, W), the border's missing neighbours left out: ``scipy.ndimage.minimum_filter(a, size=(1, 3, 3))``
    (and ``maximum_filter``) value for value, in place on shifted views, a fifth of its time."""
    out = a.copy()
    op(out[:, 1:], a[:, :-1], out=out[:, 1:])
    op(out[:, :-1], a[:, 1:], out=out[:, :-1])
    rows = out.copy()
    op(out[:, :, 1:], rows[:, :, :-1], out=out[:, :, 1:])
    op(out[:, :, :-1], rows[:, :, 1:], out=out[:, :, :-1])
    return out


def mixed_pixels(depth_m: np.ndarray, tolerance_m, min_jump_m: float = 0.03) -> np.ndarray:
    """Pixels at a depth edge whose depth lies between the two surfaces: a sensor's "flying" pixels.

    A pixel that straddles an edge returns a mix of the near and the far surface (time-of-flight sensors
    average the two returns; stereo matching windows span both). On any smooth surface, a pixel's inverse
    depth is the mean of its two neighbours' along some direction (exactly, on a plane: ``1/z`` is affine in
    the pixel coordinates), and at an edge the direction along the edge still is. A mixed pixel is on no
    surface: its 3x3 neighbourhood spans more than ``min_jump_m`` and it agrees with no pair of opposite
    neighbours (horizontal, vertical, diagonal) within ``tolerance_m``. They are outliers to any surface
    model: the registration treats them as missing.

    Parameters
    ----------
    depth_m : array, shape (N, H, W)
        0 where missing.
    tolerance_m : float or array, shape (N, H, W)
        How far a pixel of a surface may lie from its neighbours' mean: a few noise sigmas.
    min_jump_m : float
        Span of depth that makes an edge.

    Returns
    -------
    mask : array of bool, shape (N, H, W)
    """
    depth_m = np.asarray(depth_m, dtype=float)
    valid = depth_m > 0
    near = _over_3x3(np.minimum, np.where(valid, depth_m, np.inf).astype(np.float32))
    far = _over_3x3(np.maximum, np.where(valid, depth_m, 0.0).astype(np.float32))
    edge = valid & (far - near > min_jump_m)
    if not edge.any():
        return edge
    # the neighbour test at the edge pixels only, in inverse depth (NaN where missing, and in a border of one pixel)
    n_frames, height, width = depth_m.shape
    inv = np.full((n_frames, height + 2, width + 2), np.nan)
    inner = inv[:, 1:-1, 1:-1]
    with np.errstate(divide="ignore"):
        np.divide(1.0, depth_m, out=inner)
    inner[~valid] = np.nan
    inv = inv.reshape(-1)
    n, v, u = np.nonzero(edge)
    at = (n * (height + 2) + v + 1) * (width + 2) + u + 1  # flat, in the bordered image
    centre = inv[at]
    tol_inv = np.broadcast_to(tolerance_m, depth_m.shape)[edge] * centre**2  # d(1/z) = dz / z^2
    left = np.arange(len(at))  # the edge pixels no pair of neighbours has put on a surface yet
    for dv, du in ((0, 1), (1, 0), (1, 1), (1, -1)):
        step = dv * (width + 2) + du
        a, b = inv[at[left] + step], inv[at[left] - step]
        with np.errstate(invalid="ignore"):
            left = left[~(np.abs(centre[left] - 0.5 * (a + b)) <= tol_inv[left])]
    mixed = np.zeros(depth_m.shape, dtype=bool)
    mixed[n[left], v[left], u[left]] = True
    return mixed
