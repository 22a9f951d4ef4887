"""Camera placement: counts per region, look-at geometry, OpenCV axes, sectors, reproducibility."""

from __future__ import annotations

import numpy as np
import pytest

from handeye.core.errors import HandEyeInputError
from handeye.robot.look_at import look_at
from sim.cameras import PRESETS, camera_on_sphere, get_preset, place_cameras
from tests.tolerances import FLOAT


@pytest.mark.parametrize("name", list(PRESETS))
def test_counts_per_region_and_split(name):
    preset = get_preset(name)
    cams = place_cameras(preset, np.random.default_rng(0))
    assert len(cams) == preset.n_cameras
    for k in range(len(preset.region_azimuths_deg)):
        in_region = cams.region == k
        assert np.sum(in_region & (cams.split == "train")) == preset.train_per_region[k]
        assert np.sum(in_region & (cams.split == "test")) == preset.test_per_region[k]


def test_paper_presets_match_the_paper():
    sim, real = get_preset("paper-sim"), get_preset("paper-real")
    assert (
        sim.n_cameras,
        len(sim.region_azimuths_deg),
        sim.train_per_region,
        sim.test_per_region,
        sim.configurations,
        sim.robot,
    ) == (108, 6, (14,) * 6, (4,) * 6, 50, "ur5")
    assert (real.n_cameras, sum(real.train_per_region), sum(real.test_per_region), real.configurations, real.robot) == (
        24,
        19,
        5,
        100,
        "ur3",
    )
    centres = [np.mean(s) % 360 for s in real.region_azimuths_deg]
    assert sorted(centres) == [0.0, 90.0, 180.0]  # front, perpendicular and reflected views


@pytest.mark.parametrize("name", list(PRESETS))
def test_cameras_look_at_the_workspace_with_opencv_axes(name):
    preset = get_preset(name)
    cams = place_cameras(preset, np.random.default_rng(1))
    R, t = cams.T_base_cam[:, :3, :3], cams.T_base_cam[:, :3, 3]
    np.testing.assert_allclose(np.swapaxes(R, 1, 2) @ R, np.broadcast_to(np.eye(3), R.shape), atol=FLOAT)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=FLOAT)
    # the look-at point lies on the optical axis, in front of the camera
    p_cam = np.einsum("nba,nb->na", R, np.asarray(preset.look_at_m) - t)
    np.testing.assert_allclose(p_cam[:, :2], 0.0, atol=FLOAT)
    assert np.all(p_cam[:, 2] > 0)
    # x horizontal, y pointing down (negative base z component), cameras above the look-at point
    np.testing.assert_allclose(R[:, 2, 0], 0.0, atol=FLOAT)
    assert np.all(R[:, 2, 1] < 0)
    # position: distance, elevation and azimuth within the preset's ranges and the region's sector
    d = t - np.asarray(preset.look_at_m)
    r = np.linalg.norm(d, axis=1)
    el = np.degrees(np.arcsin(d[:, 2] / r))
    az = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
    assert np.all((r >= preset.radius_m[0] - FLOAT) & (r <= preset.radius_m[1] + FLOAT))
    assert np.all((el >= preset.elevation_deg[0] - 1e-9) & (el <= preset.elevation_deg[1] + 1e-9))
    for k, (a0, a1) in enumerate(preset.region_azimuths_deg):
        rel = (az[cams.region == k] - a0) % 360
        assert np.all(rel <= (a1 - a0) + 1e-9)


def test_placement_is_seeded():
    a = place_cameras(get_preset("paper-sim"), np.random.default_rng(3))
    b = place_cameras(get_preset("paper-sim"), np.random.default_rng(3))
    c = place_cameras(get_preset("paper-sim"), np.random.default_rng(4))
    np.testing.assert_array_equal(a.T_base_cam, b.T_base_cam)
    np.testing.assert_array_equal(a.split, b.split)
    assert not np.allclose(a.T_base_cam, c.T_base_cam)


def test_errors():
    with pytest.raises(HandEyeInputError, match="paper-sim"):
        get_preset("paper")
    with pytest.raises(HandEyeInputError, match="straight up or down"):
        look_at(np.array([0.0, 0.0, 2.0]), np.array([0.0, 0.0, 0.0]))


def test_a_camera_on_the_sphere_stands_at_its_azimuth_elevation_and_distance_looking_at_the_centre():
    centre = np.array([0.1, -0.2, 0.3])
    T = camera_on_sphere(centre, 90.0, 30.0, 2.0)
    expected = centre + 2.0 * np.array([0.0, np.cos(np.radians(30.0)), np.sin(np.radians(30.0))])
    assert np.allclose(T[:3, 3], expected, atol=FLOAT)
    assert np.allclose(T[:3, 2], (centre - expected) / 2.0, atol=FLOAT)  # the optical axis at the centre
    many = camera_on_sphere(centre, [90.0, 200.0], [30.0, 10.0], [2.0, 1.5])
    assert many.shape == (2, 4, 4) and np.array_equal(many[0], T)
