"""Planned robot motions: board mount geometry, camera matrix, reachable board views, data configurations."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pinocchio")

from classic.vision.board import BoardSpec  # noqa: E402
from handeye.core.se3 import invert_transform, rotation_angle  # noqa: E402
from handeye.robot.model import load_robot  # noqa: E402
from sim.cameras import get_preset, place_cameras  # noqa: E402
from sim.recording import (  # noqa: E402
    DEFAULT_BOARD,
    board_mount,
    camera_matrix,
    in_image,
    sample_calibration_view,
    sample_data_configuration,
)
from tests.tolerances import EXACT, IK_REACHED  # noqa: E402

SIZE_M = BoardSpec(**DEFAULT_BOARD).size_m


def test_board_is_centred_on_the_flange_axis_facing_out():
    T_ee_target = board_mount(SIZE_M, standoff_m=0.01)
    centre = T_ee_target @ np.array([SIZE_M[0] / 2, SIZE_M[1] / 2, 0.0, 1.0])
    np.testing.assert_allclose(centre[:3], [0.0, 0.0, 0.01], atol=EXACT)
    # the printed face looks along the target's -z, which is the flange's +z (away from the wrist)
    np.testing.assert_allclose(T_ee_target[:3, :3] @ [0, 0, -1.0], [0, 0, 1.0], atol=EXACT)
    assert np.isclose(np.linalg.det(T_ee_target[:3, :3]), 1.0)


def test_camera_matrix_has_the_field_of_view():
    K = camera_matrix(256, 192, 60.0)
    # the image's left and right edges (pixel -0.5 and 255.5) are 30 degrees off the axis
    assert np.isclose(np.degrees(np.arctan((255.5 - K[0, 2]) / K[0, 0])), 30.0)
    assert np.isclose(np.degrees(np.arctan((K[0, 2] + 0.5) / K[0, 0])), 30.0)
    assert K[1, 2] == 95.5


@pytest.fixture(scope="module")
def scene():
    preset = get_preset("paper-sim")
    return load_robot("ur5"), place_cameras(preset, np.random.default_rng(0)), preset


@pytest.mark.parametrize("camera", [0, 30, 61, 95])
def test_calibration_views_are_reachable_in_view_and_diverse(scene, camera):
    robot, cams, preset = scene
    T_base_cam = cams.T_base_cam[camera]
    size = preset.calibration_image_size
    K = camera_matrix(*size, preset.fov_deg)
    T_ee_target = board_mount(SIZE_M)
    rng = np.random.default_rng(camera)
    views = [sample_calibration_view(robot, T_base_cam, K, size, T_ee_target, SIZE_M, rng) for _ in range(8)]
    w, h = SIZE_M
    outline = np.array([[0, 0, 0, 1], [w, 0, 0, 1], [w, h, 0, 1], [0, h, 0, 1]], dtype=float)
    normals = []
    for v in views:
        # the joints reach the planned board pose exactly
        np.testing.assert_allclose(robot.fk(v.q) @ T_ee_target, v.T_base_target, atol=IK_REACHED)
        corners_cam = (invert_transform(T_base_cam) @ v.T_base_target @ outline.T).T[:, :3]
        assert in_image(corners_cam, K, *size).all()
        facing = -v.T_base_target[:3, 2]
        to_camera = T_base_cam[:3, 3] - v.T_base_target[:3, 3]
        assert np.dot(facing, to_camera) > 0  # the printed face is towards the camera
        normals.append(v.T_base_target[:3, :3])
    # rotation diversity: relative rotations between views of 10 degrees and more, typically
    angles = [np.degrees(rotation_angle(normals[i].T @ normals[j])) for i in range(8) for j in range(i)]
    assert np.median(angles) > 20.0


def test_data_configurations_keep_the_tool_in_the_image(scene):
    robot, cams, preset = scene
    K = camera_matrix(*preset.image_size, preset.fov_deg)
    rng = np.random.default_rng(1)
    qs = np.array([sample_data_configuration(robot, cams.T_base_cam[5], K, preset.image_size, rng) for _ in range(20)])
    p_cam = (invert_transform(cams.T_base_cam[5]) @ robot.fk_ref(qs))[:, :3, 3]
    assert in_image(p_cam, K, *preset.image_size).all()
    assert np.all(robot.fk(qs)[:, 2, 3] > 0.08)
    assert np.std(qs[:, 0]) > 1.0  # spread over the workspace, not one pose
