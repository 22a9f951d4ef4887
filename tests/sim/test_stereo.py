"""Simulated active stereo (sim/stereo.py): two infrared views of a dot pattern matched by OpenCV's SGBM.

Checked against geometry with a known answer: a tilted plane is measured without bias beyond a small share
of its noise, the noise grows with depth squared as stereo's does (``sigma_z = z^2 sigma_d / (f B)``), and
a box in front of a wall leaves the band of wall that only one camera sees without depth.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("cv2")

from handeye.robot.depth_sensors import PROFILES  # noqa: E402
from sim.sensors import SensorTruth, apply_sensor  # noqa: E402
from sim.stereo import active_stereo_depth  # noqa: E402
from tests.tolerances import FLOAT, SGBM_LOCKING_MAX_PX, SIGMA_BOUND

K = np.array([[222.0, 0, 127.5], [0, 222.0, 127.5], [0, 0, 1]])
U, V = np.meshgrid(np.arange(256.0), np.arange(256.0))
#: A D435's baseline scaled from its native 447 px to these 222 px (what apply_sensor does).
B = 0.05 * 447 / 222


def tilted_plane(z0: float) -> np.ndarray:
    """A plane through (0, 0, z0) turned about the camera's y axis: depth varies across the image."""
    return z0 / (1 - 0.15 * (U - 127.5) / 222)


def measured(z0: float, seed: int = 0):
    truth = tilted_plane(z0)
    depth = active_stereo_depth(truth, K, B, np.random.default_rng(seed))
    inside = (depth > 0) & (np.abs(U - 150) < 90) & (np.abs(V - 128) < 100)  # right of the matcher's blind band
    err = depth[inside] - truth[inside]
    return err, 1.4826 * np.median(np.abs(err - np.median(err))), inside.mean()


def test_a_plane_is_measured_with_stereo_noise_growing_as_depth_squared():
    near_err, near_sd, near_valid = measured(0.7)
    far_err, far_sd, far_valid = measured(1.4)
    assert near_valid > 0.4 and far_valid > 0.4  # the box is 0.49 of the image; matches almost everywhere
    # the median error is a small part of the noise (no scale bias of the simulated pair)
    assert abs(np.median(near_err)) < 0.3 * near_sd and abs(np.median(far_err)) < 0.3 * far_sd
    # sigma_z = z^2 sigma_d / (f B): twice the depth, four times the noise (the matcher's sigma_d the same)
    assert 4 / 1.5 < far_sd / near_sd < 4 * 1.5
    # the disparity noise is a fraction of a pixel
    sigma_d = near_sd * K[0, 0] * B / 0.7**2
    assert 0.02 < sigma_d < 0.5


def test_a_box_in_front_of_a_wall_leaves_the_occluded_band_empty():
    """The right camera (at +x) cannot see the wall just left of the box: no match there."""
    wall, box = 1.5, 1.0
    depth = np.full((256, 256), wall)
    depth[80:180, 120:200] = box
    out = active_stereo_depth(depth, K, B, np.random.default_rng(1))
    shift = K[0, 0] * B * (1 / box - 1 / wall)  # the band's width in pixels: the disparity difference
    band = out[90:170, int(120 - shift) + 2 : 118]
    assert (band == 0).mean() > 0.8
    assert (out[90:170, 130:190] > 0).mean() > 0.9
    # a surface facing the cameras has one disparity, which SGBM's sub-pixel fit pulls toward a whole pixel
    # ("pixel locking": up to a quarter pixel, 1 % of the depth here), so the box is right to a few percent
    assert np.median(np.abs(out[90:170, 130:190][out[90:170, 130:190] > 0] - box)) < 0.03 * box


def test_the_sgbm_profile_goes_through_apply_sensor():
    sensor = PROFILES["d435-sgbm"]
    truth = SensorTruth(1.01, 0.002, np.zeros(3))
    depth = tilted_plane(1.0)
    out = apply_sensor(depth, K, sensor, truth, np.random.default_rng(2))
    ok = (out > 0) & (np.abs(U - 150) < 90)
    # the unit's scale and offset on the matcher's depth: what is left is the matcher's locking averaged over the
    # plane's disparities (at 1 m, 1 px of disparity is 1 / fB m of depth) and the median's sampling error over
    # the image's independent 7 x 7 matching windows
    err = out[ok] - (1.01 * depth[ok] + 0.002)
    disparities = sensor.stereo_fb_px_m / depth[ok]
    locking_m = SGBM_LOCKING_MAX_PX / (np.pi * np.ptp(disparities)) / sensor.stereo_fb_px_m
    sd = 1.4826 * np.median(np.abs(err - np.median(err)))
    sampling_m = SIGMA_BOUND * np.sqrt(np.pi / 2) * sd / np.sqrt(ok.sum() / 7**2)
    assert abs(np.median(err)) <= locking_m + sampling_m


def _locking(scale: float) -> np.ndarray:
    """The first harmonic ``(sin, cos)`` of the reported depth's disparity error over its own disparity phase."""
    sensor = PROFILES["d435-sgbm"]
    depth = tilted_plane(1.0)
    out = apply_sensor(depth, K, sensor, SensorTruth(scale, 0.0, np.zeros(3), pattern_seed=3), np.random.default_rng(4))
    ok = (out > 0) & (np.abs(U - 150) < 90)
    fb = sensor.stereo_fb_px_m
    d_obs = fb / out[ok]
    err_px = d_obs - fb / (scale * depth[ok])  # against the camera's own conversion of the true disparity
    phase = 2 * np.pi * d_obs
    A = np.column_stack([np.ones_like(phase), np.sin(phase), np.cos(phase)])
    return np.linalg.lstsq(A, err_px, rcond=None)[0][1:]


def test_the_matchers_pull_toward_whole_disparities_follows_the_cameras_own_f_b():
    """A stereo unit's scale error is its f B calibration's: the matcher works on the true geometry and the camera
    converts with its own f B, so the pull toward whole disparities is periodic in ``f B / z_obs`` whatever the
    scale (what the registration's ``stereo_fb_px_m`` relies on). A scale applied after the matching instead would
    move the phase by 2 % of 21 px, 0.4 of a period, between these two units."""
    low, high = _locking(0.98), _locking(1.02)
    assert np.hypot(*low) > 0.05 and np.hypot(*high) > 0.05  # OpenCV's matcher locks by about 0.2 px
    assert np.hypot(*(low - high)) < 0.3 * np.hypot(*low)


def test_the_depth_is_brought_up_exactly_on_a_plane_and_decimated_as_librealsense_does():
    from sim.stereo import decimate_depth, upsample_depth

    plane = tilted_plane(1.0)
    fine = upsample_depth(plane, 2)
    # the fine pixels' centres: u_fine = 2 (u + 0.5) - 0.5, inside the coarse image's interpolation range
    uf = (np.arange(512) + 0.5) / 2 - 0.5
    truth = 1.0 / (1 - 0.15 * (uf - 127.5) / 222)
    inside = (uf >= 0) & (uf <= 255)
    np.testing.assert_allclose(fine[100, inside], truth[inside], rtol=FLOAT)  # 1/z is affine on a plane
    # across an edge the nearest sample, never a depth between the two surfaces
    step = np.where(U < 128, 1.0, 2.0)
    assert set(np.unique(upsample_depth(step, 2))) == {1.0, 2.0}
    # decimation: the median of each block's valid pixels, 0 where none is
    block = np.array([[1.0, 0.0, 0.0, 0.0], [3.0, 2.0, 0.0, 0.0]])
    np.testing.assert_array_equal(decimate_depth(block, 2), [[2.0, 0.0]])


def test_the_projector_pattern_is_fixed_to_the_unit():
    """The same dots in every frame: a static scene's depth changes between frames by the image noise's effect
    only, a third of what another pattern changes (measured: 0.9 against 2.6 mm mean at 1 m)."""
    sensor = PROFILES["d435-sgbm"]
    depth = tilted_plane(1.0)
    a = apply_sensor(depth, K, sensor, SensorTruth(pattern_seed=5), np.random.default_rng(1))
    b = apply_sensor(depth, K, sensor, SensorTruth(pattern_seed=5), np.random.default_rng(2))
    c = apply_sensor(depth, K, sensor, SensorTruth(pattern_seed=6), np.random.default_rng(2))
    both = (a > 0) & (b > 0) & (c > 0)
    same_pattern = np.abs(a - b)[both]
    other_pattern = np.abs(a - c)[both]
    # (medians are 0 for both: the matcher locks many pixels to one disparity whatever the dots)
    assert np.mean(same_pattern) < 0.5 * np.mean(other_pattern)
