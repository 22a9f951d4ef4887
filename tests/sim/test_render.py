"""Rendering agrees with geometry: the flange origin appears where the intrinsics and T_base_cam put it."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pinocchio")
pytest.importorskip("pyrender")

from handeye.core.se3 import invert_transform  # noqa: E402
from handeye.robot.look_at import look_at  # noqa: E402
from handeye.robot.model import load_robot  # noqa: E402
from sim.render import Renderer, SceneContents  # noqa: E402
from tests.sim._geometry import assert_sphere_rendered  # noqa: E402
from tests.tolerances import DEPTH_M  # noqa: E402

W, H = 320, 240
K = np.array([[300.0, 0.0, 161.3], [0.0, 302.0, 118.6], [0.0, 0.0, 1.0]])  # off-centre principal point
RADIUS = 0.015


@pytest.fixture(scope="module")
def setup():
    robot = load_robot("ur5")
    drawn = SceneContents(environment=False, gripper=False, robot_visible=False, marker_radius_m=RADIUS)
    renderer = Renderer(robot, K, W, H, drawn)
    yield robot, renderer
    renderer.close()


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_flange_origin_projects_where_the_image_shows_it(setup, seed):
    """A sphere centred on the flange origin covers exactly the pixels whose rays hit it, at the right depth."""
    robot, renderer = setup
    rng = np.random.default_rng(seed)
    q = np.array([0.3, -1.2, 1.5, -1.8, -1.57, 0.4]) + rng.normal(scale=0.3, size=6)
    p_base = robot.fk(q)[:3, 3]
    # a camera 0.6-1.0 m away, looking near (not exactly at) the flange so it lands off the image centre
    direction = rng.normal(size=3)
    direction[2] = abs(direction[2]) + 0.3
    direction /= np.linalg.norm(direction)
    T_base_cam = look_at(p_base + rng.uniform(0.6, 1.0) * direction, p_base + rng.normal(scale=0.08, size=3))
    p_cam = (invert_transform(T_base_cam) @ np.append(p_base, 1.0))[:3]
    rgb, depth = renderer.render(q, T_base_cam)
    blob = depth > 0
    u, v = assert_sphere_rendered(blob, depth, p_cam, RADIUS, K, min_pixels=40, min_core=10, depth_atol_m=DEPTH_M)
    assert 15 < u < W - 15 and 15 < v < H - 15
    # the blob is the marker's colour (magenta) and sits around the projected flange origin
    assert np.all(rgb[blob][:, 1] < rgb[blob][:, 0]) and np.all(rgb[blob][:, 1] < rgb[blob][:, 2])
    assert blob[int(round(v)), int(round(u))]
