"""The vision commands end to end: board, intrinsics, detect, calibrate --detections; and their errors."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

pytest.importorskip("cv2")

from classic.vision.board import BoardSpec  # noqa: E402
from classic.vision.synthetic import make_image_dataset  # noqa: E402
from handeye.cli import main  # noqa: E402
from handeye.core.metrics import pose_error  # noqa: E402

N_VIEWS = 10


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """A synthetic eye-in-hand recording: images, robot.csv with image names, board, camera, truth."""
    folder = tmp_path_factory.mktemp("recording")
    make_image_dataset(folder, N_VIEWS, "eye_in_hand", rng=np.random.default_rng(7), noise_gray=2.0)
    return folder


def test_board_command_writes_a_detectable_board(tmp_path, capsys):
    out = tmp_path / "board.png"
    assert (
        main(
            [
                "board",
                "--squares",
                "6x4",
                "--square",
                "0.03",
                "--marker",
                "0.022",
                "--dict",
                "4X4_50",
                "--dpi",
                "200",
                "-o",
                str(out),
            ]
        )
        == 0
    )
    spec = BoardSpec.load(tmp_path / "board.json")
    assert (spec.squares_x, spec.squares_y, spec.dictionary) == (6, 4, "4X4_50")
    from classic.vision.detect import detect_board
    from classic.vision.images import read_image

    det = detect_board(read_image(out), spec)
    assert det.reason is None and len(det.ids) == spec.n_corners
    assert "written" in capsys.readouterr().out


def test_board_command_refuses_swapped_lengths(tmp_path, capsys):
    assert main(["board", "--square", "0.03", "--marker", "0.04", "-o", str(tmp_path / "b.png")]) == 2
    assert "swapped" in capsys.readouterr().err


def test_detect_calibrate_from_images(dataset, tmp_path, capsys):
    """detect (intrinsics calibrated from the same images), then calibrate with the reprojection refinement."""
    det_path = tmp_path / "detections.json"
    assert main(["detect", str(dataset / "images"), "--board", str(dataset / "board.json"), "-o", str(det_path)]) == 0
    assert (tmp_path / "camera.json").is_file() and det_path.with_suffix(".csv").is_file()
    doc = json.loads(det_path.read_text())
    assert len(doc["views"]) == N_VIEWS and all(not v["image"].startswith("/") for v in doc["views"])
    result = tmp_path / "result.json"
    assert (
        main(
            [
                "calibrate",
                "--detections",
                str(det_path),
                "--robot-poses",
                str(dataset / "robot.csv"),
                "--setup",
                "eye-in-hand",
                "--refine-intrinsics",
                "--truth",
                str(dataset / "truth.json"),
                "-o",
                str(result),
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "refined on corner reprojection error" in printed and "px" in printed
    res = json.loads(result.read_text())["reprojection"]
    truth = json.loads((dataset / "truth.json").read_text())
    rot, trans = pose_error(np.array(res["T_ee_cam"]), np.array(truth["T_ee_cam"]))
    # within 5 predicted sigma (the sigma includes the intrinsics, which are refined)
    assert rot < 5 * res["sigma"]["X_rotation_deg"] and trans < 5 * res["sigma"]["X_translation_mm"]
    assert len(res["per_view_rms_px"]) >= N_VIEWS - 1


def test_images_and_poses_of_different_counts(dataset, tmp_path, capsys):
    det_path = tmp_path / "detections.json"
    assert (
        main(
            [
                "detect",
                str(dataset / "images"),
                "--board",
                str(dataset / "board.json"),
                "--intrinsics",
                str(dataset / "camera.json"),
                "-o",
                str(det_path),
            ]
        )
        == 0
    )
    lines = (dataset / "robot.csv").read_text().splitlines()
    no_names = tmp_path / "robot_unnamed.csv"
    no_names.write_text("\n".join(",".join(line.split(",")[1:]) for line in lines[:-2]) + "\n")
    assert (
        main(["calibrate", "--detections", str(det_path), "--robot-poses", str(no_names), "--setup", "eye-in-hand"])
        == 2
    )
    err = capsys.readouterr().err
    assert f"{N_VIEWS} images but {N_VIEWS - 2} robot poses" in err and "robot_unnamed.csv" in err
    missing = tmp_path / "robot_missing.csv"
    missing.write_text("\n".join(lines[:-1]) + "\n")
    assert (
        main(["calibrate", "--detections", str(det_path), "--robot-poses", str(missing), "--setup", "eye-in-hand"]) == 2
    )
    assert f"no robot pose for image(s) view_{N_VIEWS - 1:03d}.png" in capsys.readouterr().err


def test_wrong_board_and_unreadable_image(dataset, tmp_path, capsys):
    images = tmp_path / "images"
    shutil.copytree(dataset / "images", images)
    (images / "broken.png").write_bytes(b"not a png")
    assert (
        main(
            [
                "detect",
                str(images),
                "--board",
                str(dataset / "board.json"),
                "--intrinsics",
                str(dataset / "camera.json"),
                "-o",
                str(tmp_path / "d.json"),
            ]
        )
        == 2
    )
    assert "broken.png" in capsys.readouterr().err
    (images / "broken.png").unlink()
    wrong = tmp_path / "wrong.json"
    BoardSpec(7, 5, 0.04, 0.03, "6X6_250").save(wrong)
    assert (
        main(
            [
                "detect",
                str(images),
                "--board",
                str(wrong),
                "--intrinsics",
                str(dataset / "camera.json"),
                "-o",
                str(tmp_path / "d.json"),
            ]
        )
        == 2
    )
    assert "wrong.json" in capsys.readouterr().err
    rows = (tmp_path / "d.csv").read_text().splitlines()[1:]
    assert rows and all("board not found" in r for r in rows)
    swapped = tmp_path / "swapped.json"
    BoardSpec(5, 7, 0.04, 0.03, "5X5_100").save(swapped)
    assert (
        main(
            [
                "detect",
                str(images),
                "--board",
                str(swapped),
                "--intrinsics",
                str(dataset / "camera.json"),
                "-o",
                str(tmp_path / "d.json"),
            ]
        )
        == 2
    )
    assert "swapped.json" in capsys.readouterr().err
    assert main(["detect", str(images), "--board", str(tmp_path / "nope.json"), "-o", str(tmp_path / "d.json")]) == 2
    assert "nope.json" in capsys.readouterr().err


def test_missing_intrinsics_where_needed(dataset, tmp_path, capsys):
    """Two images cannot calibrate a camera: without --intrinsics the command says to pass them."""
    images = tmp_path / "two"
    images.mkdir()
    for name in ("view_000.png", "view_001.png"):
        shutil.copy(dataset / "images" / name, images / name)
    assert main(["detect", str(images), "--board", str(dataset / "board.json"), "-o", str(tmp_path / "d.json")]) == 2
    assert "--intrinsics" in capsys.readouterr().err
    assert (
        main(
            [
                "detect",
                str(images),
                "--board",
                str(dataset / "board.json"),
                "--intrinsics",
                str(tmp_path / "camera.json"),
                "-o",
                str(tmp_path / "d.json"),
            ]
        )
        == 2
    )
    assert "camera.json: no such intrinsics file" in capsys.readouterr().err
