"""Pose files with robot controllers' columns: KUKA .a .b .c, Fanuc .w .p .r, ABB .q1-.q4 (mm and degrees)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from handeye.cli import main
from handeye.core.errors import PoseFileError
from handeye.core.posefile import read_pose_file, read_robot_poses
from handeye.core.robot_angles import fanuc_wpr_from_matrix, kuka_abc_from_matrix
from handeye.core.se3 import pos_quat_xyzw_from_transform, quat_xyzw_to_wxyz
from handeye.core.synthetic import make_problem
from tests.tolerances import EXACT, FLOAT

CAMERA_COLUMNS = [f"T_cam_target.{c}" for c in ("x", "y", "z", "qx", "qy", "qz", "qw")]


def _robot_columns(kind: str, T_base_ee: np.ndarray) -> tuple[list, np.ndarray]:
    """Header and values of T_base_ee in a controller's columns: millimetres and that rotation form."""
    t_mm = T_base_ee[:, :3, 3] * 1000.0
    if kind == "kuka":
        names, rot = "abc", kuka_abc_from_matrix(T_base_ee[:, :3, :3])
    elif kind == "fanuc":
        names, rot = "wpr", fanuc_wpr_from_matrix(T_base_ee[:, :3, :3])
    else:
        names, rot = ["q1", "q2", "q3", "q4"], quat_xyzw_to_wxyz(pos_quat_xyzw_from_transform(T_base_ee)[1])
    return [f"T_base_ee.{c}" for c in ("x", "y", "z", *names)], np.column_stack([t_mm, rot])


def _write(path, header, rows):
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")


def _controller_file(tmp_path, kind, problem):
    header, robot = _robot_columns(kind, problem.T_base_ee)
    t, q = pos_quat_xyzw_from_transform(problem.T_cam_target)
    path = tmp_path / f"{kind}.csv"
    _write(path, header + CAMERA_COLUMNS, np.column_stack([robot, t, q]))
    return path


@pytest.fixture
def problem():
    return make_problem(8, "eye_to_hand", np.random.default_rng(6))


@pytest.mark.parametrize("kind", ["kuka", "fanuc", "abb"])
def test_controller_columns_round_trip(tmp_path, problem, kind):
    """The robot pose in the controller's mm and degrees, the camera's in metres: both come back to 1e-12."""
    poses = read_pose_file(_controller_file(tmp_path, kind, problem))
    np.testing.assert_allclose(poses.T_base_ee, problem.T_base_ee, atol=FLOAT)
    np.testing.assert_allclose(poses.T_cam_target, problem.T_cam_target, atol=FLOAT)
    robot = read_robot_poses(_controller_file(tmp_path, kind, problem))  # the image-calibration reader too
    np.testing.assert_allclose(robot.T_base_ee, problem.T_base_ee, atol=FLOAT)


@pytest.mark.parametrize(
    "header, row, expected",
    [
        (["a", "b", "c"], [90, 0, 0], [[0, -1, 0], [1, 0, 0], [0, 0, 1]]),  # KUKA A about z
        (["w", "p", "r"], [90, 0, 0], [[1, 0, 0], [0, 0, -1], [0, 1, 0]]),  # Fanuc W about x
        (
            ["q1", "q2", "q3", "q4"],
            [np.sqrt(0.5), 0, 0, np.sqrt(0.5)],
            [[0, -1, 0], [1, 0, 0], [0, 0, 1]],
        ),  # ABB w first
    ],
)
def test_known_rotation_and_millimetres(tmp_path, header, row, expected):
    path = tmp_path / "one.csv"
    _write(
        path,
        [f"T_base_ee.{c}" for c in ["x", "y", "z", *header]] + CAMERA_COLUMNS,
        [[100.0, -250.0, 500.0, *row, 0.1, 0.2, 0.3, 0, 0, 0, 1]],
    )
    poses = read_pose_file(path)
    np.testing.assert_allclose(poses.T_base_ee[0, :3, :3], expected, atol=FLOAT)
    np.testing.assert_allclose(poses.T_base_ee[0, :3, 3], [0.1, -0.25, 0.5], atol=FLOAT)  # mm read as mm
    np.testing.assert_allclose(poses.T_cam_target[0, :3, 3], [0.1, 0.2, 0.3], atol=FLOAT)  # metres as metres
    in_m = read_pose_file(path, units="m")  # --units applies to every pose
    np.testing.assert_allclose(in_m.T_base_ee[0, :3, 3], [100.0, -250.0, 500.0], atol=FLOAT)


def test_calibrate_from_a_kuka_file(tmp_path, problem):
    out = tmp_path / "r.json"
    assert (
        main(["calibrate", str(_controller_file(tmp_path, "kuka", problem)), "--setup", "eye-to-hand", "-o", str(out)])
        == 0
    )
    np.testing.assert_allclose(
        np.array(json.loads(out.read_text())["T_base_cam"]["matrix"]), problem.X_true, atol=EXACT
    )


def _damage(path, line_index: int, column: str, value: str):
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    fields = lines[line_index].split(",")
    fields[header.index(column)] = value
    lines[line_index] = ",".join(fields)
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize(
    "kind, column, value, message",
    [
        ("kuka", "T_base_ee.b", "abc", r"kuka.csv, line 3, column T_base_ee.b: 'abc' is not a number"),
        ("fanuc", "T_base_ee.p", "nan", r"fanuc.csv, line 3, column T_base_ee.p: 'nan' is not a finite number"),
        ("abb", "T_base_ee.q2", "0.9", r"abb.csv, line 3, T_base_ee: quaternion .* has norm"),
    ],
)
def test_bad_values_name_the_file_and_line(tmp_path, problem, kind, column, value, message):
    path = _controller_file(tmp_path, kind, problem)
    _damage(path, 2, column, value)
    with pytest.raises(PoseFileError, match=message):
        read_pose_file(path)


def test_radians_in_degree_columns_are_refused(tmp_path, problem):
    header, robot = _robot_columns("kuka", problem.T_base_ee)
    robot[:, 3:] = np.radians(robot[:, 3:])
    t, q = pos_quat_xyzw_from_transform(problem.T_cam_target)
    path = tmp_path / "radians.csv"
    _write(path, header + CAMERA_COLUMNS, np.column_stack([robot, t, q]))
    with pytest.raises(PoseFileError, match=r"radians.csv, line 2, T_base_ee and every other row: .* like radians"):
        read_pose_file(path)


def test_two_rotation_forms_for_one_pose_are_refused(tmp_path, problem):
    header, robot = _robot_columns("kuka", problem.T_base_ee)
    _, q = pos_quat_xyzw_from_transform(problem.T_base_ee)
    t2, q2 = pos_quat_xyzw_from_transform(problem.T_cam_target)
    path = tmp_path / "both.csv"
    _write(
        path,
        header + ["T_base_ee.qx", "T_base_ee.qy", "T_base_ee.qz", "T_base_ee.qw"] + CAMERA_COLUMNS,
        np.column_stack([robot, q, t2, q2]),
    )
    with pytest.raises(PoseFileError, match=r"line 1\): columns for T_base_ee give 2 rotations"):
        read_pose_file(path)


@pytest.mark.parametrize("kind", ["kuka", "fanuc", "abb"])
def test_controller_file_in_metres_is_refused_not_read_as_millimetres(tmp_path, problem, kind):
    """A controller file written in metres read as its millimetres put every flange within 2 mm of the base and
    calibrated with exit 0 (a 145 mm residual, no hint at the units); it is refused with the fix, and --units m
    reads it right."""
    header, robot = _robot_columns(kind, problem.T_base_ee)
    robot[:, :3] /= 1000.0  # the same poses, translations in metres
    t, q = pos_quat_xyzw_from_transform(problem.T_cam_target)
    path = tmp_path / f"{kind}_metres.csv"
    _write(path, header + CAMERA_COLUMNS, np.column_stack([robot, t, q]))
    with pytest.raises(PoseFileError, match="give --units m"):
        read_pose_file(path)
    with pytest.raises(PoseFileError, match="give --units m"):
        read_robot_poses(path)
    np.testing.assert_allclose(read_pose_file(path, units="m").T_base_ee, problem.T_base_ee, atol=FLOAT)
