"""The ROS 2 static-transform launch file and the URDF joint: round trips, known answers, malformed files."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from handeye.core.errors import PoseFileError
from handeye.core.robot_angles import matrix_from_kuka_abc
from handeye.core.ros_launch import read_static_tf_launch, write_static_tf_launch
from handeye.core.se3 import make_transform
from handeye.core.synthetic import make_problem
from handeye.core.urdf_joint import read_urdf_joint, write_urdf_joint
from tests.tolerances import FLOAT


@pytest.fixture
def T_base_cam():
    return make_problem(3, "eye_to_hand", np.random.default_rng(12)).X_true


def test_launch_round_trip(tmp_path, T_base_cam):
    path = tmp_path / "handeye_tf.launch.py"
    write_static_tf_launch(path, T_base_cam, "base_link", "camera_color_optical_frame", "T_base_cam")
    T, parent, child = read_static_tf_launch(path)
    np.testing.assert_allclose(T, T_base_cam, atol=FLOAT)
    assert (parent, child) == ("base_link", "camera_color_optical_frame")
    text = path.read_text()
    compile(text, str(path), "exec")  # valid Python
    assert '"--frame-id", "base_link"' in text and 'package="tf2_ros"' in text


def test_launch_known_answer(tmp_path):
    """90 degrees about z: the quaternion (x, y, z, w) = (0, 0, sin 45, cos 45) in the named arguments."""
    path = tmp_path / "t.launch.py"
    write_static_tf_launch(path, make_transform(matrix_from_kuka_abc([90, 0, 0]), [0.5, 0, 1]), "base", "cam")
    text = path.read_text()
    values = dict(re.findall(r'"(--[\w-]+)", "([^"]+)"', text))
    assert values["--x"] == "0.5" and values["--frame-id"] == "base" and values["--child-frame-id"] == "cam"
    q = [float(values[k]) for k in ("--qx", "--qy", "--qz", "--qw")]
    np.testing.assert_allclose(q, [0, 0, np.sqrt(0.5), np.sqrt(0.5)], atol=FLOAT)


@pytest.mark.parametrize("abc", [(10.0, 20.0, 30.0), (0.0, 90.0, 45.0), (170.0, -90.0, 0.0), (180.0, 0.0, 180.0)])
def test_urdf_round_trip_including_gimbal_lock(tmp_path, T_base_cam, abc):
    T = T_base_cam.copy()
    T[:3, :3] = matrix_from_kuka_abc(abc)
    path = tmp_path / "joint.urdf"
    write_urdf_joint(path, T, "base_link", "camera", x_name="T_base_cam")
    T_read, parent, child = read_urdf_joint(path)
    np.testing.assert_allclose(T_read, T, atol=FLOAT)
    assert (parent, child) == ("base_link", "camera")


def test_urdf_rpy_is_fixed_axis_xyz(tmp_path):
    """The rpy written reads back through scipy's extrinsic "xyz" as the same rotation (the URDF convention)."""
    R = Rotation.from_euler("xyz", [0.3, -0.2, 1.1]).as_matrix()
    path = tmp_path / "joint.urdf"
    write_urdf_joint(path, make_transform(R, [0.1, 0.2, 0.3]), "base", "cam")
    rpy = [float(v) for v in path.read_text().split('rpy="')[1].split('"')[0].split()]
    np.testing.assert_allclose(rpy, [0.3, -0.2, 1.1], atol=FLOAT)
    np.testing.assert_allclose(Rotation.from_euler("xyz", rpy).as_matrix(), R, atol=FLOAT)


def test_urdf_joint_found_by_name_in_a_whole_robot(tmp_path):
    path = tmp_path / "cell.urdf"
    path.write_text(
        '<?xml version="1.0"?>\n<robot name="cell">\n  <link name="base"/>\n  <link name="cam"/>\n'
        '  <joint name="other" type="fixed"><parent link="base"/><child link="x"/></joint>\n'
        '  <joint name="base_to_cam" type="fixed">\n    <parent link="base"/>\n    <child link="cam"/>\n'
        '    <origin xyz="1 2 3" rpy="0 0 1.5707963267948966"/>\n  </joint>\n</robot>\n'
    )
    T, parent, child = read_urdf_joint(path, "base_to_cam")
    np.testing.assert_allclose(T, make_transform(matrix_from_kuka_abc([90, 0, 0]), [1, 2, 3]), atol=FLOAT)
    with pytest.raises(PoseFileError, match=r"cell.urdf: 2 joints in all \(joints: other, base_to_cam\)"):
        read_urdf_joint(path)
    np.testing.assert_allclose(read_urdf_joint(path, "other")[0], np.eye(4))  # no origin: identity (URDF)


def test_urdf_that_is_not_text_is_refused(tmp_path):
    path = tmp_path / "cell.urdf"
    path.write_bytes(b'<?xml version="1.0"?>\n<robot name="\xff\xfe"/>\n')  # not UTF-8
    with pytest.raises(PoseFileError, match=r"cell.urdf: not UTF-8 text \(byte 35\)"):
        read_urdf_joint(path)


@pytest.mark.parametrize(
    "old, new, message",
    [
        ('"--qw", ', '"--qw_", ', r"line 24: argument '--qw_' not understood"),
        ('"--x", "', '"--x", "x', r"line 18: --x: 'x.*' is not a number"),
        ('                "--qw", ', '                # "--qw", ', r"line 24: .* has no value|missing --qw"),
        ("def generate", "def generate(", r"line \d+: not a Python launch file"),
        ('executable="static_transform_publisher"', 'executable="other"', r"0 static_transform_publisher nodes"),
    ],
)
def test_malformed_launch_file_names_file_and_line(tmp_path, T_base_cam, old, new, message):
    path = tmp_path / "t.launch.py"
    write_static_tf_launch(path, T_base_cam, "base", "cam")
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(PoseFileError, match=rf"t.launch.py.*{message}"):
        read_static_tf_launch(path)


def test_old_style_positional_arguments_are_refused(tmp_path):
    path = tmp_path / "old.launch.py"
    path.write_text(
        'from launch_ros.actions import Node\n\nNode(package="tf2_ros", executable="static_transform_'
        'publisher",\n     arguments=["0", "0", "1", "0", "0", "0", "base", "cam"])\n'
    )
    with pytest.raises(PoseFileError, match=r"old.launch.py, line 4: argument '0' not understood; expected the named"):
        read_static_tf_launch(path)


@pytest.mark.parametrize(
    "old, new, message",
    [
        ('<child link="cam"/>', "<child/>", r"line 2: joint 'base_to_cam' has no <child link"),
        ('rpy="', 'rpy="1 ', r"line 5: origin rpy='1 .*' is not three finite numbers"),
        ("</joint>", "</joint", r"line 6: not valid XML"),
    ],
)
def test_malformed_urdf_names_file_and_line(tmp_path, T_base_cam, old, new, message):
    path = tmp_path / "joint.urdf"
    write_urdf_joint(path, T_base_cam, "base", "cam")
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(PoseFileError, match=rf"joint.urdf.*{message}"):
        read_urdf_joint(path)


def test_frame_names_are_checked(tmp_path, T_base_cam):
    with pytest.raises(PoseFileError, match="frame name 'base link'"):
        write_static_tf_launch(tmp_path / "t.launch.py", T_base_cam, "base link", "cam")
    with pytest.raises(PoseFileError, match="frame name ''"):
        write_urdf_joint(tmp_path / "j.urdf", T_base_cam, "/", "cam")
