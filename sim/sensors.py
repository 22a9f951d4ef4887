"""Depth sensors as they are: per-unit scale and offset, axial and correlated noise, flying pixels, holes.

The renderer gives the true depth ``d`` of every pixel. A real RGB-D camera reports

.. math:: d_{obs} = s\\, d + o + \\epsilon(d)

with a scale ``s`` and offset ``o`` of its own (a unit's calibration error, fixed for a placement), and a
noise ``epsilon`` whose size grows with depth as the sensing principle makes it grow: with ``z^2`` for
triangulation (active stereo, structured light: ``sigma_z = z^2 sigma_d / (f B)``), roughly constant plus a
term linear in ``z`` for time of flight. The noise is partly spatially correlated (stereo matches windows of
pixels; time-of-flight sensors filter), pixels at depth edges mix the foreground and the background
("flying pixels"), surfaces seen at grazing angles and dark surfaces return no depth, and the depth image,
registered to the colour camera through a factory extrinsic, carries that extrinsic's error. Where a profile
says so (``d435-real-cell``), the aligned depth image is also misregistered against the colour camera's model
by a pixel or two and a fraction of a degree (shifted and turned about the principal point), and carries a
fixed-pattern error: one noise field per unit and placement, the same in every frame (:func:`fixed_pattern`).

The profiles (:class:`handeye.robot.depth_sensors.DepthSensor`, ``PROFILES``) are data of the robot
layer, with their datasheet sources; this module makes their errors. :func:`apply_sensor` turns a rendered
depth image into what the sensor would report; :func:`draw_systematic` draws a unit's scale, offset and
extrinsic error for one placement, from a seed, so that the generator records them as the placement's truth.

Not modelled: multipath at concave corners of time-of-flight sensors (a positive bias of millimetres
there), the temperature drift of the scale, rolling shutter and motion blur, IR interference between
sensors.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage
from scipy.special import ndtri

from handeye.core.dataset import REGISTRATION_COLUMNS
from handeye.robot.depth_sensors import DepthSensor

__all__ = [
    "SensorTruth",
    "draw_systematic",
    "truth_columns",
    "apply_sensor",
    "fixed_pattern",
]


@dataclass(frozen=True)
class SensorTruth:
    """One unit's systematic errors at one placement: what the method does not know.

    Attributes
    ----------
    scale : float
        ``d_obs = scale * d + offset_m``.
    offset_m : float
    t_colour_depth_m : array, shape (3,)
        Error of the depth-to-colour extrinsic: the registered depth is that of a camera displaced by
        this much from the colour camera (colour camera frame), metres.
    pattern_seed : int, optional
        The unit's projected dot pattern (``simulated-stereo``): the same in every frame; None draws one
        per frame.
    registration_px : array, shape (2,)
        The depth image's shift ``(du, dv)`` against the camera model it is paired with, pixels: what the
        truth camera sees at pixel ``u`` the depth image has at ``u + du`` (after the roll).
    registration_roll_deg : float
        Its rotation about the principal point, degrees: positive turns ``+u`` toward ``+v``.
    fixed_pattern_seed : int, optional
        Seed of the unit's fixed-pattern noise field (the same in every frame); None: no fixed pattern.
    """

    scale: float = 1.0
    offset_m: float = 0.0
    t_colour_depth_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    pattern_seed: int | None = None
    registration_px: np.ndarray = field(default_factory=lambda: np.zeros(2))
    registration_roll_deg: float = 0.0
    fixed_pattern_seed: int | None = None


def draw_systematic(sensor: DepthSensor, seed: int, camera_id: int) -> SensorTruth:
    """Draw a unit's scale, offset, extrinsic error, misregistration and fixed pattern for one placement,
    repeatably from ``(seed, camera)``.

    Each is normal with the profile's spread, cut at 2.5 sigma (a unit outside its datasheet's bound is
    returned to the vendor). The misregistration and the fixed pattern are drawn after the others, so a
    profile without them draws what it drew before.
    """
    rng = np.random.default_rng([seed, camera_id, 2])
    z = np.clip(rng.normal(size=5), -2.5, 2.5)
    pattern_seed = int(rng.integers(2**31))
    z_reg = np.clip(rng.normal(size=3), -2.5, 2.5)
    fixed_seed = int(rng.integers(2**31))
    return SensorTruth(
        scale=float(1.0 + sensor.scale_sigma * z[0]),
        offset_m=float(sensor.offset_sigma_m * z[1]),
        t_colour_depth_m=sensor.extrinsic_sigma_m * z[2:5],
        pattern_seed=pattern_seed,
        registration_px=sensor.registration_shift_sigma_px * z_reg[:2],
        registration_roll_deg=float(sensor.registration_roll_sigma_deg * z_reg[2]),
        fixed_pattern_seed=fixed_seed if sensor.fixed_pattern_sigma_m_at_1m > 0 else None,
    )


def truth_columns(sensor: DepthSensor, truths: Sequence[SensorTruth]) -> dict:
    """``cameras.csv``'s truth columns of the units' drawn errors, one row per truth.

    Parameters
    ----------
    sensor : DepthSensor
        The profile the truths were drawn from.
    truths : sequence of SensorTruth
        One per camera row.

    Returns
    -------
    dict
        Column name to array: ``depth_scale_true``, ``depth_offset_mm_true``, ``depth_extrinsic_mm_true.x/y/z``
        (millimetres) and, for a profile that misregisters its depth image,
        :data:`handeye.core.dataset.REGISTRATION_COLUMNS`
        (pixels and degrees).
    """
    table = {
        "depth_scale_true": np.array([t.scale for t in truths]),
        "depth_offset_mm_true": np.array([t.offset_m * 1e3 for t in truths]),
    }
    for k, axis in enumerate("xyz"):
        table[f"depth_extrinsic_mm_true.{axis}"] = np.array([t.t_colour_depth_m[k] * 1e3 for t in truths])
    if sensor.registration_shift_sigma_px > 0 or sensor.registration_roll_sigma_deg > 0:
        u, v, roll = REGISTRATION_COLUMNS
        table[u] = np.array([t.registration_px[0] for t in truths])
        table[v] = np.array([t.registration_px[1] for t in truths])
        table[roll] = np.array([t.registration_roll_deg for t in truths])
    return table


def _correlated_field(shape, length_px: float, rng: np.random.Generator) -> np.ndarray:
    """Unit-variance Gaussian noise, correlated over about ``length_px`` pixels."""
    white = rng.normal(size=shape)
    if length_px <= 0.5:
        return white
    smooth = ndimage.gaussian_filter(white, length_px, mode="reflect")
    # a Gaussian filter of sigma L on white noise leaves a variance of 1 / (4 pi L^2)
    return smooth * np.sqrt(4 * np.pi * length_px**2)


def _shift_depth(depth: np.ndarray, K: np.ndarray, t_m: np.ndarray, edge_jump_m: float) -> np.ndarray:
    """The depth a camera displaced by ``-t_m`` would see, for a displacement of a fraction of a pixel.

    Every point moves by ``t_m``: its depth by ``t_z``, its pixel by ``f t_xy / z``. Each pixel takes the depth
    found that far back, interpolated bilinearly between neighbours on one surface (their depths within
    ``edge_jump_m``), the nearest one across an edge.
    """
    if not np.any(t_m):
        return depth
    h, w = depth.shape
    v, u = np.mgrid[0:h, 0:w].astype(float)
    z = np.where(depth > 0, depth, np.nan)
    us = u - K[0, 0] * t_m[0] / np.where(np.isfinite(z), z, 1.0)
    vs = v - K[1, 1] * t_m[1] / np.where(np.isfinite(z), z, 1.0)
    return _sample(z, us, vs, edge_jump_m, t_m[2])


def _misregister(depth: np.ndarray, K: np.ndarray, shift_px: np.ndarray, roll_deg: float, edge_jump_m: float):
    """The depth image shifted by ``shift_px`` ``(du, dv)`` and rotated by ``roll_deg`` about the principal point.

    What the input has at pixel ``u`` the output has at ``R (u - c) + c + shift`` (``R`` turns ``+u`` toward
    ``+v``); each output pixel takes the input's depth found there, bilinear on one surface, the nearest
    across an edge (:func:`_shift_depth`).
    """
    if not np.any(shift_px) and roll_deg == 0:
        return depth
    h, w = depth.shape
    v, u = np.mgrid[0:h, 0:w].astype(float)
    z = np.where(depth > 0, depth, np.nan)
    a = np.radians(roll_deg)
    du, dv = u - K[0, 2] - shift_px[0], v - K[1, 2] - shift_px[1]
    us = K[0, 2] + np.cos(a) * du + np.sin(a) * dv  # R^-1 (u - c - shift) + c
    vs = K[1, 2] - np.sin(a) * du + np.cos(a) * dv
    out = _sample(z, us, vs, edge_jump_m, 0.0, keep_holes=False)
    inside = (us > -0.5) & (us < w - 0.5) & (vs > -0.5) & (vs < h - 0.5)
    return np.where(inside, out, 0.0)


def _sample(z, us, vs, edge_jump_m: float, dz_m: float, keep_holes: bool = True) -> np.ndarray:
    """The depth ``z`` (NaN without) at the pixels ``(us, vs)``, bilinear on one surface, nearest across an
    edge, plus ``dz_m``; 0 where there is none (and, with ``keep_holes``, where the output pixel had none)."""
    h, w = z.shape
    u0 = np.clip(np.floor(us).astype(np.int64), 0, w - 2)
    v0 = np.clip(np.floor(vs).astype(np.int64), 0, h - 2)
    a, b = np.clip(us - u0, 0, 1), np.clip(vs - v0, 0, 1)
    corners = np.stack([z[v0, u0], z[v0, u0 + 1], z[v0 + 1, u0], z[v0 + 1, u0 + 1]])
    weights = np.stack([(1 - a) * (1 - b), a * (1 - b), (1 - a) * b, a * b])
    one_surface = np.all(np.isfinite(corners), axis=0) & (np.ptp(np.nan_to_num(corners), axis=0) < edge_jump_m)
    bilinear = np.sum(np.nan_to_num(corners) * weights, axis=0)
    nearest = z[np.clip(np.rint(vs).astype(np.int64), 0, h - 1), np.clip(np.rint(us).astype(np.int64), 0, w - 1)]
    out = np.where(one_surface, bilinear, nearest) + dz_m
    return np.where(np.isfinite(out) & (np.isfinite(z) | (not keep_holes)), out, 0.0)


def fixed_pattern(z_m: np.ndarray, K: np.ndarray, sensor: DepthSensor, seed: int) -> np.ndarray:
    """The unit's fixed-pattern depth error at depth ``z_m``: the same field in every frame of one ``seed``.

    Parameters
    ----------
    z_m : array, shape (H, W)
        Depth, metres.
    K : array, shape (3, 3)
        Camera matrix of the image (scales ``fixed_pattern_px`` by ``f_x / native_focal_px``).
    sensor : DepthSensor
    seed : int
        :attr:`SensorTruth.fixed_pattern_seed`.

    Returns
    -------
    array, shape (H, W)
        Metres: ``fixed_pattern_sigma_m_at_1m z^2`` times a unit-variance field correlated over
        ``fixed_pattern_px``.
    """
    z = np.asarray(z_m, dtype=float)
    length = sensor.fixed_pattern_px * (K[0, 0] / sensor.native_focal_px if sensor.native_focal_px else 1.0)
    unit = _correlated_field(z.shape, length, np.random.default_rng([seed, 41]))
    return sensor.fixed_pattern_sigma_m_at_1m * z**2 * unit


def _normals_cos(depth: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Cosine between each pixel's surface normal (from the depth's gradient) and its line of sight."""
    h, w = depth.shape
    v, u = np.mgrid[0:h, 0:w].astype(float)
    P = np.stack([(u - K[0, 2]) / K[0, 0] * depth, (v - K[1, 2]) / K[1, 1] * depth, depth], axis=-1)
    du = np.gradient(P, axis=1)
    dv = np.gradient(P, axis=0)
    n = np.cross(du, dv)
    ray = P / np.maximum(np.linalg.norm(P, axis=-1, keepdims=True), 1e-9)
    norm = np.maximum(np.linalg.norm(n, axis=-1), 1e-12)
    return np.abs(np.einsum("hwk,hwk->hw", n, ray)) / norm


def apply_sensor(
    depth_m: np.ndarray,
    K: np.ndarray,
    sensor: DepthSensor,
    truth: SensorTruth,
    rng: np.random.Generator,
    rgb: np.ndarray | None = None,
) -> np.ndarray:
    """What the sensor reports for a rendered (true) depth image.

    Parameters
    ----------
    depth_m : array, shape (H, W)
        True depth, metres, 0 where nothing was rendered.
    K : array, shape (3, 3)
        Camera matrix of the image.
    sensor : DepthSensor
    truth : SensorTruth
        The unit's scale, offset and extrinsic error at this placement (:func:`draw_systematic`).
    rng : numpy.random.Generator
        For the noise, the flying pixels and the holes.
    rgb : array, shape (H, W, 3), optional
        The colour image, for the holes on dark surfaces.

    Returns
    -------
    array, shape (H, W)
        Reported depth, metres, 0 where the sensor returns none.
    """
    depth = np.asarray(depth_m, dtype=float)
    valid = depth > 0
    if not valid.any():
        return depth.copy()
    depth = _shift_depth(depth, K, truth.t_colour_depth_m, sensor.edge_jump_m)
    depth = _misregister(depth, K, truth.registration_px, truth.registration_roll_deg, sensor.edge_jump_m)
    valid = depth > 0
    z = np.where(valid, depth, 0.0)
    if sensor.principle == "simulated-stereo":  # the matcher's depth: its noise, holes and edges
        from sim.stereo import active_stereo_depth

        native = sensor.native_focal_px / K[0, 0] if sensor.native_focal_px else 1.0
        up = max(1, int(round(native)))  # match at the sensor's own resolution, decimate to this one
        # a stereo unit's scale error is its calibration's f B against the true one: the infrared views see the
        # true baseline B / s, the camera turns disparity into depth with its own f B (z_obs = f B / d, which is
        # s times the depth of the true geometry), so its matcher's disparity is f B / z_obs, as on the real camera
        measured = active_stereo_depth(
            z,
            K,
            sensor.stereo_baseline_m * native / up / truth.scale,
            rng,
            upsample=up,
            pattern_seed=truth.pattern_seed,
        )
        z = np.where(measured > 0, measured, 0.0)
        valid = valid & (z > 0)
    # axial noise, part white and part correlated over the matching window (scaled to these pixels)
    sigma = sensor.sigma_m(z)
    length = sensor.correlation_px * (K[0, 0] / sensor.native_focal_px if sensor.native_focal_px else 1.0)
    rho = sensor.correlated_fraction
    noise = np.sqrt(1 - rho) * rng.normal(size=z.shape)
    if rho > 0:
        noise += np.sqrt(rho) * _correlated_field(z.shape, length, rng)
    out = truth.scale * z + truth.offset_m + sigma * noise
    if truth.fixed_pattern_seed is not None and sensor.fixed_pattern_sigma_m_at_1m > 0:
        out = out + fixed_pattern(z, K, sensor, truth.fixed_pattern_seed)
    # flying pixels: at a depth edge, a mix of the nearest and the farthest neighbour
    if sensor.flying_fraction > 0:
        far = ndimage.maximum_filter(np.where(valid, z, 0.0), size=3)
        near = ndimage.minimum_filter(np.where(valid, z, np.inf), size=3)
        edge = valid & np.isfinite(near) & (far - near > sensor.edge_jump_m)
        fly = edge & (rng.random(z.shape) < sensor.flying_fraction)
        lam = rng.random(z.shape)
        mixed = truth.scale * (lam * near + (1 - lam) * far) + truth.offset_m
        out = np.where(fly, mixed, out)
    holes = ~valid
    if sensor.grazing_hole_deg < 90:
        holes |= valid & (_normals_cos(z, K) < np.cos(np.radians(sensor.grazing_hole_deg)))
    if sensor.dark_hole_fraction > 0 and rgb is not None:
        grey = np.asarray(rgb, dtype=float).mean(axis=-1)
        holes |= (grey < sensor.dark_level) & (rng.random(z.shape) < sensor.dark_hole_fraction)
    if sensor.hole_blob_fraction > 0:
        blob = _correlated_field(z.shape, sensor.hole_blob_px, rng)
        # the share of a unit normal above this threshold is the blob fraction
        holes |= blob > ndtri(1 - sensor.hole_blob_fraction)
    return np.where(holes | (out <= 0), 0.0, out)
