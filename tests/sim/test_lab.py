"""Scenes: each camera's scene, the lab's pose per scene, and the lab's clearance from every preset's cameras."""

from __future__ import annotations

import numpy as np
import pytest

from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import invert_transform
from sim.cameras import PRESETS, get_preset, place_cameras
from sim.lab import LAB_SHIFT_M, T_base_lab, camera_horizontal_reach_m, camera_scene, lab_horizontal_clearance_m
from tests.tolerances import FLOAT

#: The lab's nearest wall or object in scene 0: the yellow box of sim.scene, its corner at (-1.85, -1.1) m.
SCENE_0_CLEARANCE_M = float(np.hypot(1.85, 1.1))
#: Room a camera keeps from the lab's walls and objects (a camera body, and the lab's meshes never in front).
CAMERA_ROOM_M = 0.1


def test_scenes_are_camera_id_modulo_scenes():
    ids = np.arange(1000)
    np.testing.assert_array_equal(camera_scene(ids, 4), ids % 4)
    np.testing.assert_array_equal(camera_scene(ids, 1), 0)
    assert camera_scene(7, 4) == 3 and isinstance(camera_scene(7, 4), int)
    # even over every region of dense-sim, and independent of the seed (a function of the camera id only)
    preset = get_preset("dense-sim")
    for seed in (0, 1):
        cams = place_cameras(preset, np.random.default_rng(seed))
        scene = camera_scene(np.arange(len(cams)), preset.scenes)
        for k in range(len(preset.region_azimuths_deg)):
            np.testing.assert_array_equal(np.bincount(scene[cams.region == k], minlength=4), [25] * 4)
    with pytest.raises(HandEyeInputError, match="scenes"):
        camera_scene(3, 0)


def test_scene_0_is_the_identity_and_others_turn_and_shift_the_lab_on_the_floor():
    np.testing.assert_array_equal(T_base_lab(0), np.eye(4))
    poses = [T_base_lab(s) for s in range(1, 8)]
    for T in poses:
        R = T[:3, :3]
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=FLOAT)
        np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=FLOAT)
        np.testing.assert_allclose(R[:, 2], [0, 0, 1], atol=FLOAT)  # about the vertical axis: the floor stays level
        np.testing.assert_allclose(T[2, 3], 0.0, atol=FLOAT)
        # the robot stands LAB_SHIFT_M from the lab's centre
        np.testing.assert_allclose(np.linalg.norm(invert_transform(T)[:2, 3]), LAB_SHIFT_M, atol=FLOAT)
    # every scene a different heading and a different place in the lab
    turns = np.degrees([np.arctan2(T[1, 0], T[0, 0]) for T in poses]) % 360
    places = np.array([invert_transform(T)[:2, 3] for T in poses])
    assert np.min(np.abs(np.diff(np.sort(np.append(turns, [0.0, 360.0]))))) > 10.0
    assert min(np.linalg.norm(places[i] - places[j]) for i in range(7) for j in range(i)) > 0.05
    np.testing.assert_array_equal(T_base_lab(3), T_base_lab(3))  # a pure function
    with pytest.raises(HandEyeInputError, match="scene"):
        T_base_lab(-1)


def test_lab_clearance_is_the_nearest_object_footprint():
    pytest.importorskip("trimesh")
    assert lab_horizontal_clearance_m(np.eye(4)) == pytest.approx(SCENE_0_CLEARANCE_M, abs=FLOAT)
    for s in range(1, 12):  # turning changes nothing, shifting by LAB_SHIFT_M brings nothing closer than that
        assert lab_horizontal_clearance_m(T_base_lab(s)) >= SCENE_0_CLEARANCE_M - LAB_SHIFT_M - FLOAT


@pytest.mark.parametrize("name", list(PRESETS))
def test_every_camera_stands_clear_of_the_lab_in_its_scene(name):
    """Cameras closer to the base axis than every wall and object: not inside them, and nothing between them and
    the robot (the objects are background)."""
    pytest.importorskip("trimesh")
    preset = get_preset(name)
    reach_m = camera_horizontal_reach_m(preset)
    cams = place_cameras(preset, np.random.default_rng(0))
    horizontal_m = np.linalg.norm(cams.T_base_cam[:, :2, 3], axis=1)
    assert np.all(horizontal_m <= reach_m + FLOAT)  # the bound holds for the placed cameras
    scene = camera_scene(np.arange(len(cams)), preset.scenes)
    assert set(scene) == set(range(preset.scenes))
    for s in range(preset.scenes):
        assert reach_m + CAMERA_ROOM_M < lab_horizontal_clearance_m(T_base_lab(s)), f"scene {s}"
    assert np.all(cams.T_base_cam[:, 2, 3] > 0.3)  # and above the floor
