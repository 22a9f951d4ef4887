"""Simulated active stereo (sim/stereo.py): two infrared views of a dot pattern matched by OpenCV's SGBM.

Checked against geometry with a known answer: a tilted plane is measured without bias beyond a small share
of its noise, the noise grows with depth squared as stereo's does (``sigma_z = z^2 sigma_d / (f B)``), and
a box in front of a wall leaves the band of wall that only one camera sees without depth.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("cv2")

from sim.sensors import PROFILES, SensorTruth, apply_sensor  # noqa: E402
from sim.stereo import active_stereo_depth  # noqa: E402

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
    # the unit's scale and offset on the matcher's depth
    assert np.median(out[ok] - (1.01 * depth[ok] + 0.002)) == pytest.approx(0, abs=3e-3)
