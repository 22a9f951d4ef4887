"""Intrinsics from ROS camera_info and OpenCV FileStorage YAML: the hand-written files, round trips, errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("cv2")

from classic.vision.camera import CameraIntrinsics, IntrinsicsError  # noqa: E402
from classic.vision.camera_yaml import write_camera_info_yaml, write_opencv_yaml  # noqa: E402
from tests.tolerances import FLOAT, RELATIVE_ONLY  # noqa: E402

DATA = Path(__file__).resolve().parents[1] / "data"
_PLUMB_BOB_FIVE = (
    "distortion_model: plumb_bob\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n"
    "  data: [0.125, -0.25, 0.001, -0.002, 0.0625]\n"
)


def test_camera_info_file():
    intr = CameraIntrinsics.load(DATA / "camera_info.yaml")
    np.testing.assert_array_equal(intr.K, [[612.5, 0, 321.25], [0, 611.75, 238.5], [0, 0, 1]])
    np.testing.assert_array_equal(intr.dist, [0.125, -0.25, 0.001, -0.002, 0.0625])
    assert (intr.width, intr.height) == (640, 480)


def test_opencv_filestorage_file():
    intr = CameraIntrinsics.load(DATA / "opencv_intrinsics.yml")
    np.testing.assert_array_equal(intr.K, [[910.25, 0, 639.5], [0, 909.75, 360.25], [0, 0, 1]])
    np.testing.assert_array_equal(intr.dist, [0.15, -0.3125, 5e-4, -2.5e-4, 0.125])
    assert (intr.width, intr.height) == (1280, 720)


def test_camera_info_message_as_rostopic_echo_prints_it(tmp_path):
    path = tmp_path / "echo.yaml"
    path.write_text(
        'header: \n  seq: 0\n  stamp: \n    secs: 1\n    nsecs: 0\n  frame_id: "camera_optical_frame"\n'
        'height: 480\nwidth: 640\ndistortion_model: "plumb_bob"\nD: [0.1, -0.2, 0.0, 0.0, 0.0]\n'
        "K: [500.0, 0.0, 320.0, 0.0, 500.0, 240.0, 0.0, 0.0, 1.0]\n"
        "R: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]\nbinning_x: 0\n---\n"
    )
    intr = CameraIntrinsics.load(path)
    np.testing.assert_array_equal(intr.K, [[500, 0, 320], [0, 500, 240], [0, 0, 1]])
    assert intr.dist[1] == -0.2 and (intr.width, intr.height) == (640, 480)


@pytest.mark.parametrize(
    "dist",
    [
        [0.11, -0.23, 1e-3, -2e-3, 0.0456],
        [0.11, -0.23, 1e-3, -2e-3, 0.0456, 0.01, -0.02, 0.003],  # rational_polynomial
    ],
)
@pytest.mark.parametrize("writer", [write_camera_info_yaml, write_opencv_yaml])
def test_round_trip(tmp_path, writer, dist):
    intr = CameraIntrinsics(
        np.array([[612.123456789, 0.25, 321.987654321], [0, 611.5, 238.0], [0, 0, 1]]), np.array(dist), 1280, 720
    )
    path = tmp_path / "camera.yaml"
    writer(path, intr)
    back = CameraIntrinsics.load(path)
    np.testing.assert_allclose(back.K, intr.K, rtol=FLOAT, atol=RELATIVE_ONLY)
    np.testing.assert_allclose(back.dist, intr.dist, rtol=FLOAT, atol=RELATIVE_ONLY)
    assert (back.width, back.height) == (1280, 720)


def test_save_to_a_yaml_name_writes_what_load_reads(tmp_path):
    """``handeye intrinsics -o camera.yaml`` then ``handeye detect --intrinsics camera.yaml``."""
    intr = CameraIntrinsics(
        np.array([[500.5, 0, 320.25], [0, 501.5, 240.75], [0, 0, 1]]), np.array([0.1, -0.2, 1e-3, 2e-3, 0.05]), 640, 480
    )
    intr.save(tmp_path / "camera.yaml")
    assert (tmp_path / "camera.yaml").read_text().startswith("%YAML:1.0")
    back = CameraIntrinsics.load(tmp_path / "camera.yaml")
    np.testing.assert_array_equal(back.K, intr.K)
    np.testing.assert_array_equal(back.dist, intr.dist)


def test_four_coefficients_are_written_as_plumb_bob(tmp_path):
    intr = CameraIntrinsics(np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]), np.array([0.1, -0.2, 0.0, 0.01]))
    write_camera_info_yaml(tmp_path / "c.yaml", intr)
    assert "distortion_model: plumb_bob" in (tmp_path / "c.yaml").read_text()
    np.testing.assert_array_equal(CameraIntrinsics.load(tmp_path / "c.yaml").dist, [0.1, -0.2, 0.0, 0.01, 0.0])


@pytest.mark.parametrize(
    "source, old, new, message",
    [
        ("camera_info.yaml", "plumb_bob", "equidistant", r"line 8: distortion_model 'equidistant' is not OpenCV's"),
        ("camera_info.yaml", "  rows: 1\n", "  rows: [1,\n", r"line \d+: not a YAML file OpenCV can read"),
        (
            "camera_info.yaml",
            "0, 0, 1]\ndistortion_model",
            "0, 1]\ndistortion_model",
            r"line 4: camera_matrix holds 8 numbers; a camera matrix has 9",
        ),
        ("camera_info.yaml", "[612.5, 0,", "[612.5, zero,", r"line 4: camera_matrix \(camera matrix\) is not a matrix"),
        ("camera_info.yaml", "camera_matrix:", "camera_matrice:", r"no camera matrix: expected one of camera_matrix"),
        (
            "camera_info.yaml",
            "0.125, -0.25, 0.001, -0.002, 0.0625]",
            "0.125, -0.25, 0.001]",
            r"line 9: plumb_bob takes 4 or 5 coefficients, distortion_coefficients holds 3",
        ),
        (
            "camera_info.yaml",
            "[612.5, 0, 321.25, 0, 611.75",
            "[-612.5, 0, 321.25, 0, 611.75",
            r"line 4: K is not a camera matrix",
        ),
        ("opencv_intrinsics.yml", "rows: 3", "rows: 4", r"line 7: camera_matrix .* data does not hold rows x cols"),
        (
            "camera_info.yaml",
            _PLUMB_BOB_FIVE,
            "distortion_model: rational_polynomial\n",
            r"line 8: distortion_model rational_polynomial takes 8 coefficients, but the file has no D key",
        ),
        (
            "camera_info.yaml",
            _PLUMB_BOB_FIVE,
            "distortion_model: rational_polynomial\nD: []\n",
            r"line 9: rational_polynomial takes 8 coefficients, D holds 0$",
        ),
    ],
)
def test_malformed_files_name_file_and_line(tmp_path, source, old, new, message):
    text = (DATA / source).read_text()
    assert old in text
    path = tmp_path / source
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(IntrinsicsError, match=rf"{source}.*{message}"):
        CameraIntrinsics.load(path)


def test_a_file_not_found_is_named(tmp_path):
    with pytest.raises(IntrinsicsError, match="nope.yaml: no such intrinsics file"):
        CameraIntrinsics.load(tmp_path / "nope.yaml")
