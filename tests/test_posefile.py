"""Pose files: CSV and JSON round trips, rotation forms, units, and the errors users hit."""

from __future__ import annotations

import json

import numpy as np
import pytest

from handeye.checked_poses import load_poses
from handeye.core.errors import PoseFileError, QuaternionOrderError
from handeye.core.posefile import read_pose_file, write_pose_csv
from handeye.core.se3 import pos_quat_xyzw_from_transform, quat_xyzw_to_wxyz, so3_log
from handeye.core.synthetic import make_problem
from tests.tolerances import EXACT, FLOAT


@pytest.fixture
def problem():
    return make_problem(8, "eye_to_hand", np.random.default_rng(5))


def _write_csv(path, header, rows):
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(f"{v:.15g}" for v in r) for r in rows) + "\n")


def test_csv_round_trip(tmp_path, problem):
    path = tmp_path / "poses.csv"
    write_pose_csv(path, problem.T_base_ee, problem.T_cam_target, comment="a comment\nover two lines")
    poses = load_poses(path, "eye_to_hand")
    np.testing.assert_allclose(poses.T_base_ee, problem.T_base_ee, atol=FLOAT)
    np.testing.assert_allclose(poses.T_cam_target, problem.T_cam_target, atol=FLOAT)
    assert poses.rows[0] == 4  # two comment lines, the header, then the first row


def test_csv_named_columns_in_any_order_and_rotvec(tmp_path, problem):
    """Named quaternion columns state their order; rotation vectors (UR style) are accepted."""
    t1, q1 = pos_quat_xyzw_from_transform(problem.T_base_ee)
    t2 = problem.T_cam_target[:, :3, 3]
    r2 = so3_log(problem.T_cam_target[:, :3, :3])
    header = [
        "T_base_ee.qw",
        "T_base_ee.x",
        "T_base_ee.qz",
        "T_base_ee.y",
        "T_base_ee.qy",
        "T_base_ee.z",
        "T_base_ee.qx",
        "T_cam_target.rx",
        "T_cam_target.ry",
        "T_cam_target.rz",
        "T_cam_target.x",
        "T_cam_target.y",
        "T_cam_target.z",
    ]
    rows = np.column_stack([q1[:, 3], t1[:, 0], q1[:, 2], t1[:, 1], q1[:, 1], t1[:, 2], q1[:, 0], r2, t2])
    path = tmp_path / "poses.csv"
    _write_csv(path, header, rows)
    poses = read_pose_file(path)
    np.testing.assert_allclose(poses.T_base_ee, problem.T_base_ee, atol=EXACT)
    np.testing.assert_allclose(poses.T_cam_target, problem.T_cam_target, atol=EXACT)


def _json_doc(problem, order="xyzw", units="m"):
    scale = 1000.0 if units == "mm" else 1.0
    poses = []
    for A, B in zip(problem.T_base_ee, problem.T_cam_target):
        t, q = pos_quat_xyzw_from_transform(A)
        q = q if order == "xyzw" else quat_xyzw_to_wxyz(q)
        B_scaled = B.copy()
        B_scaled[:3, 3] *= scale
        poses.append(
            {
                "T_base_ee": {"translation": (t * scale).tolist(), "quaternion": q.tolist()},
                "T_cam_target": {"matrix": B_scaled.tolist()},
            }
        )
    return {"units": units, "quaternion_order": order, "poses": poses}


@pytest.mark.parametrize("order", ["xyzw", "wxyz"])
@pytest.mark.parametrize("units", ["m", "mm"])
def test_json_orders_and_units(tmp_path, problem, order, units):
    path = tmp_path / "poses.json"
    path.write_text(json.dumps(_json_doc(problem, order, units)))
    poses = load_poses(path, "eye_to_hand")
    np.testing.assert_allclose(poses.T_base_ee, problem.T_base_ee, atol=EXACT)
    np.testing.assert_allclose(poses.T_cam_target, problem.T_cam_target, atol=EXACT)


def test_quaternion_order_mistake_is_detected(tmp_path, problem):
    """A file written in wxyz but declared xyzw: the motions expose it, and the message says which order fits."""
    doc = _json_doc(problem, order="wxyz")
    doc["quaternion_order"] = "xyzw"
    path = tmp_path / "poses.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(QuaternionOrderError, match="T_base_ee look like they are in wxyz order"):
        load_poses(path, "eye_to_hand")
    # read with the right order it goes through
    load_poses(path, "eye_to_hand", quat_order="wxyz")


def test_non_unit_quaternion_names_the_line(tmp_path, problem):
    path = tmp_path / "poses.csv"
    write_pose_csv(path, problem.T_base_ee, problem.T_cam_target)
    lines = path.read_text().splitlines()
    fields = lines[3].split(",")
    fields[3] = str(float(fields[3]) + 0.5)  # T_base_ee.qx of the third row
    lines[3] = ",".join(fields)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(PoseFileError, match=r"line 4.*norm"):
        read_pose_file(path)


def test_bad_number_and_missing_column(tmp_path, problem):
    path = tmp_path / "poses.csv"
    write_pose_csv(path, problem.T_base_ee, problem.T_cam_target)
    text = path.read_text().splitlines()
    broken = text[:2] + [text[2].replace(text[2].split(",")[0], "abc", 1)] + text[3:]
    path.write_text("\n".join(broken) + "\n")
    with pytest.raises(PoseFileError, match=r"line 3, column T_base_ee.x: 'abc'"):
        read_pose_file(path)
    path.write_text(text[0].replace("T_cam_target.qw", "T_cam_target.w") + "\n" + "\n".join(text[1:]) + "\n")
    with pytest.raises(PoseFileError, match="columns for T_cam_target not found"):
        read_pose_file(path)


def test_missing_file_and_bad_json(tmp_path):
    with pytest.raises(PoseFileError, match="no such file"):
        read_pose_file(tmp_path / "nope.csv")
    path = tmp_path / "bad.json"
    path.write_text("{not json")
    with pytest.raises(PoseFileError, match="not valid JSON"):
        read_pose_file(path)
    path.write_text(json.dumps({"poses": [{"T_base_ee": {"matrix": np.eye(4).tolist()}}]}))
    with pytest.raises(PoseFileError, match=r"poses\[0\]: missing T_cam_target"):
        read_pose_file(path)


@pytest.mark.parametrize(
    "content, message",
    [
        (b"\x00\x01\x02binary\xff\xfe", "a binary file, not a pose file"),
        (b"T_base_ee.x\n\xe9\xe9\n", "not UTF-8 text"),
    ],
)
def test_unreadable_pose_files_give_one_named_line(tmp_path, content, message):
    from handeye.cli import main

    path = tmp_path / "poses.csv"
    path.write_bytes(content)
    with pytest.raises(PoseFileError, match=f"poses.csv: {message}"):
        read_pose_file(path)
    assert main(["calibrate", str(path), "--setup", "eye-to-hand"]) == 2


def test_a_directory_and_a_huge_file_are_named(tmp_path, monkeypatch):
    import handeye.core.posefile as posefile

    with pytest.raises(PoseFileError, match="is a directory, not a pose file"):
        read_pose_file(tmp_path)
    big = tmp_path / "big.csv"
    big.write_text("x" * 2048)
    monkeypatch.setattr(posefile, "MAX_POSE_FILE_BYTES", 1024)
    with pytest.raises(PoseFileError, match="big.csv: 2,048 bytes, too large for a pose file"):
        read_pose_file(big)
