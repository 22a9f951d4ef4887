"""easy_handeye (ROS 1) and easy_handeye2 (ROS 2) files: the hand-written samples in tests/data, round trips, errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from handeye.core.easy_handeye import (
    read_easy_handeye_calibration,
    read_easy_handeye_samples,
    write_easy_handeye_calibration,
    write_easy_handeye_samples,
)
from handeye.core.errors import PoseFileError
from handeye.core.posefile import read_pose_file
from handeye.core.se3 import invert_transform, make_transform
from handeye.core.synthetic import make_problem
from tests.tolerances import FLOAT

pytest.importorskip("yaml")

DATA = Path(__file__).resolve().parent / "data"
SAMPLES_ROS2 = DATA / "easy_handeye2_eye_on_base.samples"
SAMPLES_ROS1 = DATA / "easy_handeye_sample_list.yaml"

RX90 = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
RY90 = np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]])
RZ90 = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
RY180 = np.diag([-1.0, 1, -1])

#: The files' robot and tracking transforms, written out: (robot, tracking) per sample.
SAMPLES = [
    (make_transform(np.eye(3), [0.4, 0.1, 0.3]), make_transform(RZ90, [0.05, -0.02, 0.6])),
    (make_transform(RX90, [0.35, 0.12, 0.28]), make_transform(np.eye(3), [0.0, 0.01, 0.55])),
    (make_transform(RY180, [0.5, -0.1, 0.25]), make_transform(RY90, [-0.03, 0.04, 0.62])),
]


def test_easy_handeye2_samples_eye_on_base():
    """Eye-on-base samples hold T_ee_base: read as eye-to-hand, T_base_ee is its inverse; the camera's as given."""
    poses = read_easy_handeye_samples(SAMPLES_ROS2, setup="eye_to_hand")
    np.testing.assert_allclose(poses.T_base_ee, invert_transform(np.array([r for r, _ in SAMPLES])), atol=FLOAT)
    np.testing.assert_allclose(poses.T_cam_target, np.array([c for _, c in SAMPLES]), atol=FLOAT)
    assert poses.rows == [12, 32, 52]  # the line of each '- robot:'
    assert poses.frames == {}  # the sampler leaves the parameters empty


def test_easy_handeye2_samples_eye_in_hand_and_the_pose_file_path():
    poses = read_pose_file(SAMPLES_ROS2, setup="eye-in-hand")  # the existing reader, by suffix
    np.testing.assert_allclose(poses.T_base_ee, np.array([r for r, _ in SAMPLES]), atol=FLOAT)


def test_easy_handeye_ros1_sample_list():
    poses = read_pose_file(SAMPLES_ROS1, setup="eye_to_hand")
    np.testing.assert_allclose(poses.T_base_ee, invert_transform(np.array([r for r, _ in SAMPLES[:2]])), atol=FLOAT)
    np.testing.assert_allclose(poses.T_cam_target, np.array([c for _, c in SAMPLES[:2]]), atol=FLOAT)
    assert len(poses.rows) == 2 and all(r > 0 for r in poses.rows)


def test_without_a_setup_the_sample_list_is_refused():
    with pytest.raises(PoseFileError, match=r"easy_handeye2_eye_on_base.samples: .* give the setup \(--setup\)"):
        read_easy_handeye_samples(SAMPLES_ROS2)


@pytest.mark.parametrize("setup", ["eye_to_hand", "eye_in_hand"])
@pytest.mark.parametrize("ros", [1, 2])
def test_samples_round_trip(tmp_path, setup, ros):
    p = make_problem(6, setup, np.random.default_rng(3))
    path = tmp_path / ("s.samples" if ros == 2 else "s.yaml")
    frames = {"base": "base_link", "ee": "tool0", "cam": "camera_color_optical_frame", "target": "marker"}
    write_easy_handeye_samples(path, p.T_base_ee, p.T_cam_target, setup, frames=frames, ros=ros)
    poses = read_easy_handeye_samples(path, setup=setup if ros == 1 else None)  # ROS 2 files state their setup
    np.testing.assert_allclose(poses.T_base_ee, p.T_base_ee, atol=FLOAT)
    np.testing.assert_allclose(poses.T_cam_target, p.T_cam_target, atol=FLOAT)
    assert poses.frames == (frames if ros == 2 else {})


def test_a_setup_contradicting_the_file_is_refused(tmp_path):
    p = make_problem(4, "eye_to_hand", np.random.default_rng(0))
    path = tmp_path / "eob.samples"
    write_easy_handeye_samples(path, p.T_base_ee, p.T_cam_target, "eye_to_hand")
    message = r"eob.samples, line 4: the file says calibration_type: eye_on_base \(eye-to-hand\), but the setup"
    with pytest.raises(PoseFileError, match=message):
        read_easy_handeye_samples(path, setup="eye_in_hand")


def test_read_easy_handeye2_calibration():
    calib = read_easy_handeye_calibration(DATA / "easy_handeye2_eye_in_hand.calib")
    np.testing.assert_allclose(calib.T_parent_cam, make_transform(RZ90, [0.03, -0.05, 0.08]), atol=FLOAT)
    assert calib.setup == "eye_in_hand" and calib.name == "my_eih_calib"
    assert (calib.parent_frame, calib.child_frame) == ("tool0", "camera_color_optical_frame")


def test_read_easy_handeye_ros1_calibration():
    calib = read_easy_handeye_calibration(DATA / "easy_handeye_eye_on_base.yaml")
    np.testing.assert_allclose(calib.T_parent_cam, make_transform(RX90, [1.2, 0.1, 0.9]), atol=FLOAT)
    assert calib.setup == "eye_to_hand" and calib.name == "my_eob_calib_eye_on_base"
    assert (calib.parent_frame, calib.child_frame) == ("base_link", "camera_link")
    assert calib.frames["target"] == "ar_marker"


@pytest.mark.parametrize("setup", ["eye_to_hand", "eye_in_hand"])
def test_calibration_round_trip(tmp_path, setup):
    p = make_problem(3, setup, np.random.default_rng(8))
    path = tmp_path / "my_calib.calib"
    frames = {"base": "base_link", "cam": "camera_color_optical_frame"}
    write_easy_handeye_calibration(path, p.X_true, setup, frames)
    calib = read_easy_handeye_calibration(path)
    np.testing.assert_allclose(calib.T_parent_cam, p.X_true, atol=FLOAT)
    assert calib.setup == setup and calib.name == "my_calib"
    assert calib.frames == {"base": "base_link", "ee": "ee", "cam": "camera_color_optical_frame", "target": "target"}
    text = path.read_text()
    assert f"calibration_type: {'eye_on_base' if setup == 'eye_to_hand' else 'eye_in_hand'}" in text


def _damaged(tmp_path, source: Path, old: str, new: str, count: int = 1) -> Path:
    text = source.read_text()
    assert old in text
    path = tmp_path / source.name
    path.write_text(text.replace(old, new, count))
    return path


@pytest.mark.parametrize(
    "source, old, new, message",
    [
        (SAMPLES_ROS2, "x: 0.4\n", "x: abc\n", r"line 14: samples\[0\].robot.translation.x 'abc' is not a number"),
        (SAMPLES_ROS2, "      w: 1.0\n", "", r"line 18: samples\[0\].robot.rotation.w missing"),
        (SAMPLES_ROS2, "z: 0.7071067811865476", "z: 0.8", r"line 22, samples\[0\].tracking: quaternion .* has norm"),
        (SAMPLES_ROS2, "x: 0.35\n", "x: .nan\n", r"line 34: samples\[1\].robot.translation.x = nan is not finite"),
        (SAMPLES_ROS2, "    translation:\n      x: 0.4", "    translation:\n     x: 0.4", r"line \d+: not valid YAML"),
        (SAMPLES_ROS2, "  tracking:\n", "  robot:\n", r"line \d+: not valid YAML \(.*duplicate key 'robot'"),
        (
            SAMPLES_ROS2,
            "calibration_type: ''",
            "calibration_type: eye_on_table",
            r"line 3: calibration_type 'eye_on_table' is neither",
        ),
        (
            SAMPLES_ROS1,
            "  camera_marker_samples: \n    - \n",
            "  camera_marker_samples: \n    - \n      foo: 1\n    - \n",
            r"line 23: 3 camera_marker_samples but 2 hand_world_samples",
        ),
        (
            DATA / "easy_handeye2_eye_in_hand.calib",
            "transform:",
            "transforms:",
            r"easy_handeye2_eye_in_hand.calib, line 1: not an easy_handeye sample list",
        ),
    ],
)
def test_malformed_sample_files_name_file_and_line(tmp_path, source, old, new, message):
    path = _damaged(tmp_path, source, old, new)
    with pytest.raises(PoseFileError, match=f"{path.name}.*{message}" if path.name not in message else message):
        read_easy_handeye_samples(path, setup="eye_to_hand")


@pytest.mark.parametrize(
    "old, new, message",
    [
        ("    x: 0.03\n", "    x: [0.03]\n", r"line 13: transform.translation.x \[0.03\] is not a number"),
        ("calibration_type: eye_in_hand", "calibration_type: ''", r"does not say whether it is eye-in-hand"),
        ("transform:\n", "transform: 3\nold_transform:\n", r"line 11: transform must be a transform"),
    ],
)
def test_malformed_calibration_names_file_and_line(tmp_path, old, new, message):
    path = _damaged(tmp_path, DATA / "easy_handeye2_eye_in_hand.calib", old, new)
    with pytest.raises(PoseFileError, match=rf"easy_handeye2_eye_in_hand.calib.*{message}"):
        read_easy_handeye_calibration(path)


def test_empty_and_missing_files(tmp_path):
    empty = tmp_path / "empty.samples"
    empty.write_text("samples: []\n")
    with pytest.raises(PoseFileError, match=r"empty.samples, line 1: the sample list is empty"):
        read_easy_handeye_samples(empty, setup="eye_to_hand")
    with pytest.raises(PoseFileError, match="no such file"):
        read_easy_handeye_samples(tmp_path / "nope.yaml", setup="eye_to_hand")
