"""``handeye calibrate`` with ROS files: easy_handeye samples in, easy_handeye2 / launch / URDF out; YAML intrinsics."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from handeye.cli import main
from handeye.core.easy_handeye import read_easy_handeye_calibration, write_easy_handeye_samples
from handeye.core.posefile import write_pose_csv
from handeye.core.ros_launch import read_static_tf_launch
from handeye.core.synthetic import make_problem
from handeye.core.urdf_joint import read_urdf_joint
from tests.tolerances import EXACT, FLOAT

pytest.importorskip("yaml")

FRAMES = {"base": "base_link", "ee": "tool0", "cam": "camera_color_optical_frame", "target": "charuco"}


def _exports(tmp_path: Path) -> list[str]:
    return [
        "--export-easy-handeye",
        str(tmp_path / "my_calib.calib"),
        "--export-launch",
        str(tmp_path / "handeye_tf.launch.py"),
        "--export-urdf",
        str(tmp_path / "camera_joint.urdf"),
    ]


def _read_exports(tmp_path: Path):
    calib = read_easy_handeye_calibration(tmp_path / "my_calib.calib")
    launch = read_static_tf_launch(tmp_path / "handeye_tf.launch.py")
    urdf = read_urdf_joint(tmp_path / "camera_joint.urdf")
    return calib, launch, urdf


@pytest.mark.parametrize("ros", [1, 2])
def test_easy_handeye_samples_in_every_export_out(tmp_path, capsys, ros):
    """Eye-to-hand samples (T_ee_base in the file) calibrate to the truth; each export reads back the result."""
    p = make_problem(10, "eye_to_hand", np.random.default_rng(21))
    samples = tmp_path / ("cell.samples" if ros == 2 else "cell.yaml")
    write_easy_handeye_samples(samples, p.T_base_ee, p.T_cam_target, "eye_to_hand", frames=FRAMES, ros=ros)
    out = tmp_path / "r.json"
    assert main(["calibrate", str(samples), "--setup", "eye-to-hand", "-o", str(out), *_exports(tmp_path)]) == 0
    X = np.array(json.loads(out.read_text())["T_base_cam"]["matrix"])
    np.testing.assert_allclose(X, p.X_true, atol=EXACT)
    calib, launch, urdf = _read_exports(tmp_path)
    # ROS 2 sample lists carry the tf names; ROS 1 ones do not: the project's names
    parent, child = ("base_link", "camera_color_optical_frame") if ros == 2 else ("base", "cam")
    for T, p_name, c_name in ((calib.T_parent_cam, calib.parent_frame, calib.child_frame), launch, urdf):
        np.testing.assert_allclose(T, X, atol=FLOAT)
        assert (p_name, c_name) == (parent, child)
    assert calib.setup == "eye_to_hand" and calib.name == "my_calib"
    assert f"exported T_base_cam as the transform from '{parent}' to '{child}'" in capsys.readouterr().out


def test_eye_in_hand_csv_with_named_frames(tmp_path):
    p = make_problem(10, "eye_in_hand", np.random.default_rng(22))
    path = tmp_path / "poses.csv"
    write_pose_csv(path, p.T_base_ee, p.T_cam_target)
    out = tmp_path / "r.json"
    assert (
        main(
            [
                "calibrate",
                str(path),
                "--setup",
                "eye-in-hand",
                "-o",
                str(out),
                "--frames",
                "tool0",
                "cam_optical",
                *_exports(tmp_path),
            ]
        )
        == 0
    )
    X = np.array(json.loads(out.read_text())["T_ee_cam"]["matrix"])
    calib, launch, urdf = _read_exports(tmp_path)
    assert calib.setup == "eye_in_hand" and (calib.parent_frame, calib.child_frame) == ("tool0", "cam_optical")
    for T, parent, child in (launch, urdf):
        np.testing.assert_allclose(T, X, atol=FLOAT)
        assert (parent, child) == ("tool0", "cam_optical")


def test_export_arguments_are_checked_before_calibrating(tmp_path, capsys):
    p = make_problem(6, "eye_to_hand", np.random.default_rng(2))
    path = tmp_path / "poses.csv"
    write_pose_csv(path, p.T_base_ee, p.T_cam_target)
    assert main(["calibrate", str(path), "--setup", "eye-to-hand", "--frames", "base", "cam"]) == 2
    assert "--frames names the frames of an export" in capsys.readouterr().err
    assert (
        main(
            [
                "calibrate",
                str(path),
                "--setup",
                "eye-to-hand",
                "--export-launch",
                str(tmp_path / "missing" / "t.launch.py"),
            ]
        )
        == 2
    )
    assert "does not exist" in capsys.readouterr().err
    assert (
        main(
            [
                "calibrate",
                str(path),
                "--setup",
                "eye-to-hand",
                "--frames",
                "base link",
                "cam",
                "--export-urdf",
                str(tmp_path / "j.urdf"),
            ]
        )
        == 2
    )
    assert "frame name 'base link'" in capsys.readouterr().err


def test_a_malformed_sample_file_exits_2_naming_the_line(tmp_path, capsys):
    p = make_problem(4, "eye_to_hand", np.random.default_rng(0))
    samples = tmp_path / "bad.samples"
    write_easy_handeye_samples(samples, p.T_base_ee, p.T_cam_target, "eye_to_hand")
    samples.write_text(samples.read_text().replace("w: ", "w: x", 1))
    assert main(["calibrate", str(samples), "--setup", "eye-to-hand"]) == 2
    err = capsys.readouterr().err
    assert "bad.samples, line" in err and "rotation.w" in err and "Traceback" not in err
    assert main(["calibrate", str(samples.with_name("ok.samples")), "--setup", "eye-in-hand"]) == 2


def test_detect_takes_yaml_intrinsics(tmp_path):
    """``handeye detect --intrinsics camera.yaml`` (camera_info) gives the same poses as the JSON it came from."""
    pytest.importorskip("cv2")
    from classic.vision.camera import CameraIntrinsics
    from classic.vision.camera_yaml import write_camera_info_yaml
    from classic.vision.synthetic import make_image_dataset

    make_image_dataset(tmp_path, 3, "eye_in_hand", rng=np.random.default_rng(7), noise_gray=2.0)
    write_camera_info_yaml(tmp_path / "camera.yaml", CameraIntrinsics.load(tmp_path / "camera.json"))
    results = []
    for name in ("camera.json", "camera.yaml"):
        out = tmp_path / f"det_{Path(name).suffix[1:]}.json"
        assert (
            main(
                [
                    "detect",
                    str(tmp_path / "images"),
                    "--board",
                    str(tmp_path / "board.json"),
                    "--intrinsics",
                    str(tmp_path / name),
                    "-o",
                    str(out),
                ]
            )
            == 0
        )
        doc = json.loads(out.read_text())
        results.append((doc["intrinsics"], [v["T_cam_target"] for v in doc["views"]]))
    assert results[0] == results[1]
    assert sum(T is not None for T in results[0][1]) >= 2
