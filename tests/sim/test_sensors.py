"""Depth sensor profiles: each error term does what its model says, on depth images whose truth is known."""

from __future__ import annotations

import json

import numpy as np
import pytest

from handeye.core.errors import HandEyeInputError
from handeye.robot.depth_sensors import PROFILES, DepthSensor, sensor_profile
from sim.sensors import SensorTruth, apply_sensor, draw_systematic
from tests.tolerances import ABSOLUTE_ONLY, CLIPPED_DRAWS_STD_RTOL, CORRELATED_FIELD_SPREADS, FLOAT

H, W, F_PX = 120, 160, 150.0
K = np.array([[F_PX, 0, (W - 1) / 2], [0, F_PX, (H - 1) / 2], [0, 0, 1.0]])


def _plane(z_m=1.5):
    return np.full((H, W), z_m)


def _step(near=1.0, far=2.0):
    """Fronto-parallel: the left half near, the right half far."""
    d = np.full((H, W), far)
    d[:, : W // 2] = near
    return d


def test_scale_and_offset_are_applied_exactly():
    sensor = DepthSensor("systematic only", "active-stereo")
    out = apply_sensor(_step(), K, sensor, SensorTruth(1.013, 0.004), np.random.default_rng(0))
    np.testing.assert_allclose(out, 1.013 * _step() + 0.004, rtol=ABSOLUTE_ONLY, atol=FLOAT)


@pytest.mark.parametrize("name", ["d435", "l515", "zivid"])
def test_white_axial_noise_has_the_profiles_sigma(name):
    """With the other terms off, the noise's spread at 1.5 m is the profile's sigma (19,200 pixels: 1 %)."""
    p = PROFILES[name]
    sensor = DepthSensor(
        name, p.principle, noise_const_m=p.noise_const_m, noise_linear=p.noise_linear,
        noise_quadratic_per_m=p.noise_quadratic_per_m,
    )  # fmt: skip
    out = apply_sensor(_plane(1.5), K, sensor, SensorTruth(), np.random.default_rng(1))
    relative_se = 1 / np.sqrt(2 * out.size)  # of a standard deviation from n normal samples
    assert abs(np.std(out - 1.5) / sensor.sigma_m(1.5) - 1) < 5 * relative_se


def test_stereo_noise_grows_with_depth_squared():
    d435 = PROFILES["d435"]
    assert d435.sigma_m(2.0) / d435.sigma_m(1.0) == pytest.approx(4.0)
    # Intel's RMS formula at 848x480 with a 50 mm baseline and 0.08 px subpixel: about 3.6 mm at 1 m
    assert d435.sigma_m(1.0) == pytest.approx(0.08 / (447.0 * 0.05))


def test_correlated_noise_keeps_its_variance_and_correlates_neighbours():
    sensor = DepthSensor(
        "correlated", "active-stereo", noise_quadratic_per_m=0.002, correlated_fraction=1.0, correlation_px=3.0
    )
    out = apply_sensor(_plane(1.0), K, sensor, SensorTruth(), np.random.default_rng(2))
    e = out - 1.0
    # a smooth field has far fewer independent samples: its sigma's relative spread is 3.8 % here
    spread = np.sqrt(np.pi * sensor.correlation_px**2 / (H * W))
    assert np.std(e) == pytest.approx(0.002, rel=CORRELATED_FIELD_SPREADS * spread)
    corr = np.corrcoef(e[:, :-1].ravel(), e[:, 1:].ravel())[0, 1]
    assert corr > 0.8  # neighbours one pixel apart, correlation length 3 px: exp(-1/36) for a Gaussian kernel


def test_flying_pixels_appear_only_at_depth_edges_and_lie_between_the_surfaces():
    sensor = DepthSensor("flying", "time-of-flight", flying_fraction=1.0, edge_jump_m=0.05)
    out = apply_sensor(_step(1.0, 2.0), K, sensor, SensorTruth(), np.random.default_rng(3))
    moved = np.abs(out - _step(1.0, 2.0)) > 1e-9
    cols = np.unique(np.nonzero(moved)[1])
    assert set(cols) <= {W // 2 - 1, W // 2}  # the two columns beside the step
    assert moved[:, W // 2 - 1].mean() > 0.5
    assert np.all((out[moved] >= 1.0) & (out[moved] <= 2.0))


def test_holes_at_grazing_angles_not_facing_the_camera():
    v, u = np.mgrid[0:H, 0:W].astype(float)
    sensor = DepthSensor("grazing", "active-stereo", grazing_hole_deg=75.0)
    for tilt_deg, holes in ((30.0, False), (85.0, True)):
        # a plane through (0, 0, 1.5) turned about the camera's y axis: z = 1.5 / (1 - tan(tilt) x_n)
        x_n = (u - K[0, 2]) / F_PX
        z = 1.5 / (1 - np.tan(np.radians(tilt_deg)) * x_n)
        z = np.where((z > 0) & (z < 20), z, 0.0)
        out = apply_sensor(z, K, sensor, SensorTruth(), np.random.default_rng(4))
        centre = out[H // 3 : 2 * H // 3, W // 2 - 5 : W // 2 + 5]
        assert (centre == 0).mean() > 0.9 if holes else (centre > 0).all()


def test_dark_pixels_and_blobs_lose_their_depth():
    rgb = np.full((H, W, 3), 200, np.uint8)
    rgb[:, :40] = 10
    sensor = DepthSensor("holes", "active-stereo", dark_hole_fraction=1.0, hole_blob_fraction=0.05)
    out = apply_sensor(_plane(), K, sensor, SensorTruth(), np.random.default_rng(5), rgb=rgb)
    assert (out[:, :40] == 0).all()
    lost = (out[:, 40:] == 0).mean()
    assert 0.02 < lost < 0.1  # blobs of 5 % of the image, give or take their size's sampling


def test_extrinsic_error_moves_the_depth_camera():
    """The registered depth is that of a camera displaced by -t: a plane at 1.5 m is seen at 1.5 + t_z."""
    t = np.array([0.0, 0.0, 0.002])
    out = apply_sensor(
        _plane(), K, DepthSensor("x", "active-stereo"), SensorTruth(1.0, 0.0, t), np.random.default_rng(6)
    )
    np.testing.assert_allclose(out[out > 0], 1.502, atol=FLOAT)


def test_systematic_draws_are_repeatable_and_bounded():
    d435 = PROFILES["d435"]
    a, b = draw_systematic(d435, 7, 3), draw_systematic(d435, 7, 3)
    assert a.scale == b.scale and a.offset_m == b.offset_m
    draws = [draw_systematic(d435, 0, c) for c in range(200)]
    scales = np.array([d.scale for d in draws]) - 1
    assert np.abs(scales).max() <= 2.5 * d435.scale_sigma + 1e-15
    assert np.std(scales) == pytest.approx(d435.scale_sigma, rel=CLIPPED_DRAWS_STD_RTOL)
    assert draw_systematic(PROFILES["ideal"], 0, 0).scale == 1.0


def test_profiles_from_names_and_parameters():
    assert sensor_profile("zivid") is PROFILES["zivid"]
    custom = sensor_profile({"name": "mine", "principle": "structured-light", "noise_quadratic_per_m": 0.0005})
    assert custom.sigma_m(2.0) == pytest.approx(0.002)
    assert DepthSensor.from_dict(json.loads(json.dumps(PROFILES["d435"].to_dict()))) == PROFILES["d435"]
    with pytest.raises(HandEyeInputError, match="unknown sensor"):
        sensor_profile("kinect-v1")
    with pytest.raises(HandEyeInputError, match="unknown keys"):
        sensor_profile({"name": "x", "principle": "ideal", "baseline": 0.05})
    with pytest.raises(HandEyeInputError, match="principle"):
        DepthSensor("x", "sonar")
    with pytest.raises(HandEyeInputError, match="fraction"):
        DepthSensor("x", "ideal", flying_fraction=2.0)
    with pytest.raises(HandEyeInputError, match=">= 0"):
        DepthSensor("x", "ideal", scale_sigma=-0.01)


def test_every_profile_cites_its_source():
    for name, p in PROFILES.items():
        assert p.name == name and p.source


def test_extrinsic_error_shifts_the_image_by_a_fraction_of_a_pixel():
    """t_x = 2 mm at 1.5 m and f = 150 px is 0.2 px: on a surface whose depth rises 1 mm per pixel along x,
    each pixel reads the depth 0.2 px back, 0.2 mm less."""
    u = np.arange(W, dtype=float)
    depth = np.tile(1.5 + 0.001 * (u - K[0, 2]), (H, 1))
    t = np.array([0.002, 0.0, 0.0])
    out = apply_sensor(depth, K, DepthSensor("x", "active-stereo"), SensorTruth(1.0, 0.0, t), np.random.default_rng(7))
    shift_px = F_PX * t[0] / depth
    inner = np.s_[2:-2, 2:-2]
    np.testing.assert_allclose(out[inner], (depth - 0.001 * shift_px)[inner], atol=FLOAT)
