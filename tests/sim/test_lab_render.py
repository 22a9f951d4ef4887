"""Rendering a scene: the lab moves in the background, the robot's pixels do not, one scene renders as before."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pinocchio")
pytest.importorskip("pyrender")

from handeye.robot.model import load_robot  # noqa: E402
from sim.cameras import CameraPreset, get_preset, place_cameras  # noqa: E402
from sim.lab import T_base_lab  # noqa: E402
from sim.recording import camera_matrix, sample_data_configuration  # noqa: E402
from sim.render import Renderer  # noqa: E402

SIZE = (128, 128)
FOV_DEG = 60.0
#: The lab moved beyond the far clipping plane: a robot-only image from the same renderer (one OpenGL context per
#: process: closing a second one's renderer breaks the first).
T_BASE_LAB_AWAY = np.array([[1.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 100.0], [0, 0, 0, 1]])


@pytest.fixture(scope="module")
def cell():
    """A renderer, a low dense-sim camera (walls and objects behind the robot), a pose, and the renderer's first
    image, rendered before any environment pose was set (today's renderer)."""
    robot = load_robot("ur5")
    K = camera_matrix(*SIZE, FOV_DEG)
    cams = place_cameras(get_preset("dense-sim"), np.random.default_rng(0))
    T_base_cam = cams.T_base_cam[int(np.argmin(cams.elevation_deg))]
    q = sample_data_configuration(robot, T_base_cam, K, SIZE, np.random.default_rng(0))
    lab = Renderer(robot, K, *SIZE)
    first = lab.render(q, T_base_cam)
    yield dict(robot=robot, K=K, lab=lab, T_base_cam=T_base_cam, q=q, first=first)
    lab.close()


def test_scene_0_renders_byte_identical_to_a_renderer_without_scenes(cell):
    lab = cell["lab"]
    lab.set_environment_pose(T_base_lab(1))
    lab.render(cell["q"], cell["T_base_cam"])
    lab.set_environment_pose(T_base_lab(0))
    rgb, depth = lab.render(cell["q"], cell["T_base_cam"])
    np.testing.assert_array_equal(rgb, cell["first"][0])
    np.testing.assert_array_equal(depth, cell["first"][1])


def test_another_scene_changes_the_background_and_not_the_robot(cell):
    lab, q, T_base_cam = cell["lab"], cell["q"], cell["T_base_cam"]
    lab.set_environment_pose(T_BASE_LAB_AWAY)
    _, robot_depth = lab.render(q, T_base_cam)
    robot = robot_depth > 0
    assert 0.02 < robot.mean() < 0.8
    lab.set_environment_pose(T_base_lab(0))
    rgb0, depth0 = lab.render(q, T_base_cam)
    lab.set_environment_pose(T_base_lab(1))
    rgb1, depth1 = lab.render(q, T_base_cam)
    # nothing of the lab in front of the robot but the floor, which cuts the base mesh's lowest 3 mm (a few pixels)
    seen = robot & (depth0 == robot_depth)
    assert seen.sum() > 0.99 * robot.sum()
    np.testing.assert_array_equal(seen, robot & (depth1 == robot_depth))
    # the robot's pixels: the same colour and depth in both scenes
    np.testing.assert_array_equal(rgb0[seen], rgb1[seen])
    np.testing.assert_array_equal(depth0[seen], depth1[seen])
    # the background: another floor, walls and objects
    background = ~robot
    changed = np.any(rgb0 != rgb1, axis=2) & background
    assert changed.sum() > 0.3 * background.sum()
    assert np.mean(np.abs(depth0[background] - depth1[background]) > 0.01) > 0.3


def test_generated_shards_render_each_camera_in_its_scene(cell, tmp_path):
    """A 2-scene preset generated through the worker: camera 0 in today's lab, camera 1 in scene 1, byte for byte."""
    from handeye.core.dataset import Dataset
    from handeye.core.engine_protocol import EngineOptions
    from sim.generate import Recipe, generate

    preset = CameraPreset(
        "two-scenes", "ur5", ((0.0, 360.0),), (2,), (0,), 1, image_size=SIZE, fov_deg=FOV_DEG, scenes=2
    )
    recipe = Recipe(preset, seed=0, recordings=("data",))
    generate(tmp_path / "ds", recipe, options=EngineOptions(workers=1, progress=False))
    ds = Dataset.open(tmp_path / "ds")
    T_base_cam_all = place_cameras(preset, np.random.default_rng(0)).T_base_cam
    lab = cell["lab"]
    for c in range(2):
        t = ds.select(c, "data")
        recorded = ds.rgb(c, t["rgb"][0])
        lab.set_environment_pose(T_base_lab(c))
        rgb, _ = lab.render(ds.joints(t)[0], T_base_cam_all[c])
        np.testing.assert_array_equal(recorded, rgb)
        lab.set_environment_pose(T_base_lab(1 - c))
        other, _ = lab.render(ds.joints(t)[0], T_base_cam_all[c])
        assert np.any(recorded != other)
