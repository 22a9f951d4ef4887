"""The simulator's errors of a real cell (issue 41): the depth image misregistered against the camera model it
is paired with, and a fixed-pattern noise the same in every frame, on depth images whose truth is known."""

from __future__ import annotations

import numpy as np
import pytest

from handeye.robot.depth_sensors import PROFILES, DepthSensor
from sim.sensors import SensorTruth, apply_sensor, draw_systematic, fixed_pattern
from tests.tolerances import CORRELATED_FIELD_SPREADS, FLOAT, NEAREST_PX

H, W, F_PX = 120, 160, 150.0
C_U, C_V = (W - 1) / 2, (H - 1) / 2
K = np.array([[F_PX, 0, C_U], [0, F_PX, C_V], [0, 0, 1.0]])


def _square(centre_uv, half=4, near=0.8, far=1.5):
    """A plane at ``far`` with a square at ``near`` centred on pixel ``centre_uv``."""
    d = np.full((H, W), far)
    u, v = centre_uv
    d[v - half : v + half + 1, u - half : u + half + 1] = near
    return d


def _centroid(depth, near=0.8):
    v, u = np.nonzero(np.abs(depth - near) < 1e-9)
    return np.array([u.mean(), v.mean()])


NOTHING = DepthSensor("nothing but the registration", "ideal")


@pytest.mark.parametrize("shift", [(1.0, 0.0), (0.0, 2.0), (-2.0, 1.0)])
def test_a_shift_moves_the_depth_image_by_whole_pixels_exactly(shift):
    depth = _square((60, 50))
    truth = SensorTruth(registration_px=np.array(shift))
    out = apply_sensor(depth, K, NOTHING, truth, np.random.default_rng(0))
    du, dv = int(shift[0]), int(shift[1])
    expected = np.roll(depth, (dv, du), axis=(0, 1))
    inner = (slice(3, H - 3), slice(3, W - 3))  # the border, where the image has nothing to shift in
    np.testing.assert_array_equal(out[inner], expected[inner])


def test_a_half_pixel_shift_interpolates_on_one_surface():
    ramp = 1.0 + 0.001 * np.arange(W)[None, :] * np.ones((H, 1))  # one surface: no edge
    out = apply_sensor(ramp, K, NOTHING, SensorTruth(registration_px=np.array([0.5, 0.0])), np.random.default_rng(0))
    np.testing.assert_allclose(out[:, 2:-2], ramp[:, 2:-2] - 0.0005, atol=FLOAT)


def test_the_roll_turns_the_image_about_the_principal_point():
    centre = np.array([C_U + 0.5 + 40, C_V + 0.5])  # a pixel 40 px right of the principal point
    depth = _square(tuple(int(x) for x in centre))
    roll = 10.0
    out = apply_sensor(depth, K, NOTHING, SensorTruth(registration_roll_deg=roll), np.random.default_rng(0))
    a = np.radians(roll)
    d = _centroid(depth) - [C_U, C_V]
    expected = np.array([C_U, C_V]) + [np.cos(a) * d[0] - np.sin(a) * d[1], np.sin(a) * d[0] + np.cos(a) * d[1]]
    assert np.linalg.norm(_centroid(out) - expected) < NEAREST_PX  # turned +u toward +v by 7 px
    assert np.linalg.norm(_centroid(out) - _centroid(depth)) > 5


FP_SIGMA, FP_PX = 0.003, 3.0
PATTERN = DepthSensor("fixed pattern only", "ideal", fixed_pattern_sigma_m_at_1m=FP_SIGMA, fixed_pattern_px=FP_PX)


def test_the_fixed_pattern_is_the_same_in_every_frame_and_another_units_differs():
    plane = np.full((H, W), 1.5)
    truth = draw_systematic(PATTERN, seed=3, camera_id=1)
    frames = [apply_sensor(plane, K, PATTERN, truth, np.random.default_rng(k)) for k in range(3)]
    np.testing.assert_array_equal(frames[0], frames[1])
    np.testing.assert_array_equal(frames[0], frames[2])
    other = apply_sensor(plane, K, PATTERN, draw_systematic(PATTERN, seed=3, camera_id=2), np.random.default_rng(0))
    assert np.std(other - frames[0]) > FP_SIGMA  # two independent fields: sqrt(2) sigma z^2 apart


def test_the_fixed_pattern_has_the_stated_sigma_growing_with_depth_squared():
    n = 256 * 256
    spread = CORRELATED_FIELD_SPREADS * np.sqrt(np.pi * FP_PX**2 / n)
    for seed in range(3):
        near = fixed_pattern(np.full((256, 256), 1.0), K, PATTERN, seed)
        far = fixed_pattern(np.full((256, 256), 2.0), K, PATTERN, seed)
        assert abs(near.std() / FP_SIGMA - 1) < spread
        np.testing.assert_allclose(far, 4 * near, rtol=FLOAT)  # the same field, times z^2


def test_the_existing_profiles_draw_no_misregistration_and_no_fixed_pattern():
    for name, sensor in PROFILES.items():
        truth = draw_systematic(sensor, 0, 5)
        if name == "d435-real-cell":
            assert truth.fixed_pattern_seed is not None and np.any(truth.registration_px)
            continue
        assert truth.fixed_pattern_seed is None and not np.any(truth.registration_px)
        assert truth.registration_roll_deg == 0.0
