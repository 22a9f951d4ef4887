"""Board kinds: spec file round trip, invalid fields, legacy ChArUco, OpenCV's full distortion models."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from classic.vision import BoardSpec, CameraIntrinsics, detect_board
from classic.vision.board import BoardSpecError, dictionary_id
from classic.vision.reprojection import project
from tests.tolerances import ABSOLUTE_ONLY, FLOAT32_M, OPENCV_PROJECTION_PX
from tests.vision._helpers import INTR, board_pose

SPECS = [
    BoardSpec(7, 5, 0.04, 0.03, "5X5_100"),
    BoardSpec(6, 6, 0.04, 0.03, "4X4_50", legacy=True),
    BoardSpec.checkerboard(10, 7, 0.025),
    BoardSpec.aruco_grid(5, 4, 0.045, 0.01, "APRILTAG_36h11"),
    BoardSpec.aruco_grid(3, 2, 0.03, 0.006, "4X4_50"),
]


@pytest.mark.parametrize("spec", SPECS, ids=lambda s: f"{s.kind}_{s.squares_x}x{s.squares_y}")
def test_spec_json_round_trip(tmp_path, spec):
    spec.save(tmp_path / "b.json")
    assert BoardSpec.load(tmp_path / "b.json") == spec
    assert BoardSpec(**spec.to_dict()) == spec  # what detections.json stores


def test_old_spec_files_are_charuco(tmp_path):
    path = tmp_path / "old.json"
    path.write_text(
        '{"type": "charuco", "squares_x": 7, "squares_y": 5, "square_length_m": 0.04, '
        '"marker_length_m": 0.03, "dictionary": "5X5_100"}'
    )
    spec = BoardSpec.load(path)
    assert spec.kind == "charuco" and spec.legacy is False


@pytest.mark.parametrize(
    "fields,match",
    [
        ({"kind": "ring_grid"}, "unknown board kind"),
        ({"kind": "checkerboard", "squares_x": 8, "squares_y": 6}, "ambiguous"),
        ({"kind": "checkerboard", "squares_x": 7, "squares_y": 7}, "ambiguous"),
        ({"kind": "checkerboard", "squares_x": 2, "squares_y": 3}, "at least 3x3"),
        ({"kind": "aruco_grid", "legacy": True}, "legacy is a ChArUco"),
        ({"legacy": "yes"}, "legacy must be true or false"),
        ({"kind": "aruco_grid", "marker_length_m": 0.05}, "smaller than the square"),
        ({"kind": "aruco_grid", "dictionary": "4X4_50", "squares_x": 10, "squares_y": 6}, "has 50"),
        ({"dictionary": "APRILTAG_99h1"}, "unknown ArUco dictionary"),
    ],
)
def test_bad_spec_fields_raise(tmp_path, fields, match):
    doc = {
        "squares_x": 5,
        "squares_y": 4,
        "square_length_m": 0.04,
        "marker_length_m": 0.03,
        "dictionary": "4X4_50",
        **fields,
    }
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(BoardSpecError, match=match) as info:
        BoardSpec.load(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize("name", ["APRILTAG_36h11", "apriltag_36H11", "DICT_APRILTAG_16h5", "APRILTAG_25h9"])
def test_apriltag_dictionaries_by_name(name):
    assert dictionary_id(name) in (
        cv2.aruco.DICT_APRILTAG_36h11,
        cv2.aruco.DICT_APRILTAG_16h5,
        cv2.aruco.DICT_APRILTAG_25h9,
    )


def test_marker_grid_corners_agree_with_opencvs_grid_board():
    spec = SPECS[3]
    theirs = np.asarray(spec.cv_board().getObjPoints(), dtype=float).reshape(-1, 3)
    np.testing.assert_allclose(spec.corners_target(), theirs, rtol=ABSOLUTE_ONLY, atol=FLOAT32_M)


# ChArUco's flat drawing is tested in test_board.py (at OpenCV's 0.1 px refinement stop)
@pytest.mark.parametrize("spec", SPECS[2:], ids=lambda s: f"{s.kind}_{s.squares_x}x{s.squares_y}")
def test_flat_drawing_is_detected_where_the_frame_convention_puts_it(spec):
    n, margin = 60, 20
    ppm = n / spec.square_length_m
    det = detect_board(spec.render(ppm, margin_px=margin), spec)
    assert det.reason is None, det.reason
    assert sorted(det.ids.tolist()) == list(range(spec.n_corners))
    expected = spec.corners_target()[det.ids, :2] * ppm + margin - 0.5
    # a marker's side is round(m / L * n) px: here 48 and 50 px of exactly 48.0 and 50.0
    assert np.linalg.norm(det.corners_px - expected, axis=1).max() <= 0.25


def test_legacy_charuco_needs_the_legacy_spec():
    # OpenCV's legacy pattern differs from the current one on boards with an even number of rows: the
    # chessboard is shifted by a square, so the markers sit in the other squares. A current-pattern spec
    # finds the markers but interpolates no corner (CharucoDetector checks the markers against the squares).
    legacy = SPECS[1]
    current = BoardSpec(6, 6, 0.04, 0.03, "4X4_50")
    image = legacy.render(60 / legacy.square_length_m, margin_px=20)
    assert detect_board(image, legacy).reason is None
    wrong = detect_board(image, current)
    assert len(wrong.ids) == 0 and wrong.n_markers > 0 and "legacy pattern?" in wrong.reason
    # and the other way round
    assert len(detect_board(current.render(60 / 0.04, margin_px=20), legacy).ids) == 0


@pytest.mark.parametrize("n_coeffs", [8, 12, 14])
def test_full_distortion_models_project_as_opencv(n_coeffs):
    rng = np.random.default_rng(n_coeffs)
    dist = np.r_[INTR.dist, rng.uniform(-0.02, 0.02, n_coeffs - 5)]
    intr = CameraIntrinsics(INTR.K, dist, INTR.width, INTR.height)
    T = board_pose(rng)
    p_target = np.column_stack([rng.uniform(0, 0.28, 50), rng.uniform(0, 0.2, 50), np.zeros(50)])
    p_cam = p_target @ T[:3, :3].T + T[:3, 3]
    ours = project(p_cam, intr.K[0, 0], intr.K[1, 1], intr.K[0, 2], intr.K[1, 2], intr.dist)
    rvec, _ = cv2.Rodrigues(T[:3, :3])
    theirs, _ = cv2.projectPoints(p_target, rvec, T[:3, 3], intr.K, intr.dist)
    np.testing.assert_allclose(ours, theirs.reshape(-1, 2), rtol=ABSOLUTE_ONLY, atol=OPENCV_PROJECTION_PX)
