"""Rejected views say why, and never come with a silently usable pose."""

from __future__ import annotations

import numpy as np
import pytest

from classic.vision import BoardSpec, CameraIntrinsics, Detection, detect_board, estimate_pose
from classic.vision.detect import POSE_LIMITS, project_points
from classic.vision.synthetic import render_view
from handeye.core.se3 import make_transform, so3_exp
from tests.vision._helpers import CENTRE, INTR, SPEC, corners_in_image


def _assert_rejected(pose, *fragments):
    """A rejection: not ok, a reason naming the cause, and no pose to be used by mistake."""
    assert not pose.ok
    assert isinstance(pose.reason, str) and pose.reason
    assert any(f in pose.reason for f in fragments), pose.reason
    # a pose may be kept for diagnosis (RMS rejections), but only together with the reason
    assert pose.T_cam_target is None or pose.reason is not None


def _row(r):
    """Corner ids of inner row r."""
    n = SPEC.squares_x - 1
    return np.arange(r * n, (r + 1) * n)


@pytest.mark.parametrize("value", [0, 128, 255])
def test_blank_image_board_not_found(value):
    image = np.full((INTR.height, INTR.width), value, np.uint8)
    det = detect_board(image, SPEC)
    assert det.reason is not None and det.reason.startswith("board not found")
    assert len(det.ids) == 0 and det.corners_px.shape == (0, 2) and det.n_markers == 0
    pose = estimate_pose(det, SPEC, INTR)
    _assert_rejected(pose, "board not found")
    assert pose.T_cam_target is None and np.isnan(pose.rms_px)
    assert pose.reason == det.reason  # the detection's reason is passed on unchanged


def test_noise_image_board_not_found():
    image = np.random.default_rng(0).integers(0, 256, (INTR.height, INTR.width), dtype=np.uint8)
    pose = estimate_pose(detect_board(image, SPEC), SPEC, INTR)
    _assert_rejected(pose, "board not found")
    assert pose.T_cam_target is None


@pytest.mark.parametrize("dictionary", ["4X4_50", "6X6_250", "7X7_1000"])
def test_wrong_dictionary_finds_no_marker(rendered_views, dictionary):
    wrong = BoardSpec(SPEC.squares_x, SPEC.squares_y, SPEC.square_length_m, SPEC.marker_length_m, dictionary)
    det = detect_board(rendered_views[0].image, wrong)
    assert det.n_markers == 0 and len(det.ids) == 0
    assert "board not found" in det.reason and "no marker" in det.reason and dictionary in det.reason
    pose = estimate_pose(det, wrong, INTR)
    _assert_rejected(pose, "board not found")
    assert pose.T_cam_target is None


def test_swapped_square_counts_are_rejected_with_a_reason(rendered_views):
    swapped = BoardSpec(SPEC.squares_y, SPEC.squares_x, SPEC.square_length_m, SPEC.marker_length_m, SPEC.dictionary)
    det = detect_board(rendered_views[0].image, swapped)
    pose = estimate_pose(det, swapped, INTR)
    # whatever the detector makes of it, no pose comes out without a reason
    assert not pose.ok
    assert pose.T_cam_target is None or pose.reason is not None
    if len(det.ids) == 0:
        # markers of the right dictionary are there, so the message points at the spec
        assert det.n_markers > 0
        assert "swapped" in det.reason and "5x7" in det.reason
        assert pose.reason == det.reason


def test_too_few_corners_from_a_partial_view(rendered_views):
    view = rendered_views[0]
    full = detect_board(view.image, SPEC)
    # keep only the image around the four corners of the black square at row 2, column 2 (the markers
    # of its four white neighbours are partly in view), the rest is background
    keep = np.isin(full.ids, [7, 8, 13, 14])
    lo = np.floor(full.corners_px[keep].min(axis=0) - 25).astype(int)
    hi = np.ceil(full.corners_px[keep].max(axis=0) + 25).astype(int)
    image = np.full_like(view.image, 128)
    image[lo[1] : hi[1], lo[0] : hi[0]] = view.image[lo[1] : hi[1], lo[0] : hi[0]]
    det = detect_board(image, SPEC)
    assert 0 < len(det.ids) < POSE_LIMITS["min_corners"], det
    pose = estimate_pose(det, SPEC, INTR)
    _assert_rejected(pose, "too few corners")
    assert pose.T_cam_target is None and pose.n_corners == len(det.ids)


@pytest.mark.parametrize("n", [1, 4, POSE_LIMITS["min_corners"] - 1])
def test_too_few_corners_detection(rendered_views, n):
    full = detect_board(rendered_views[0].image, SPEC)
    ids = np.array([7, 8, 13, 14, 9, 15, 19, 20][:n])
    corners = full.corners_px[np.searchsorted(full.ids, ids)]
    pose = estimate_pose(Detection(ids, corners, 4, full.image_size), SPEC, INTR)
    _assert_rejected(pose, "too few corners")
    assert f"{n} < {POSE_LIMITS['min_corners']}" in pose.reason
    assert pose.T_cam_target is None


@pytest.mark.parametrize("row", range(SPEC.squares_y - 1))
def test_collinear_corners_are_rejected(row):
    T = make_transform(so3_exp(np.radians([25.0, 10.0, 5.0])), [0.0, 0.0, 0.6]) @ CENTRE
    ids = _row(row)
    assert len(ids) >= POSE_LIMITS["min_corners"]  # so it is the collinearity that rejects them
    uv = project_points(SPEC.corners_target()[ids], T, INTR)
    pose = estimate_pose(Detection(ids, uv, 6, (INTR.width, INTR.height)), SPEC, INTR)
    _assert_rejected(pose, "collinear")
    assert pose.T_cam_target is None


def test_collinear_column_rejected_once_the_corner_count_allows_it():
    T = make_transform(so3_exp(np.radians([25.0, 10.0, 5.0])), [0.0, 0.0, 0.6]) @ CENTRE
    ids = np.arange(2, SPEC.n_corners, SPEC.squares_x - 1)  # column 2: 4 corners
    uv = project_points(SPEC.corners_target()[ids], T, INTR)
    det = Detection(ids, uv, 4, (INTR.width, INTR.height))
    _assert_rejected(estimate_pose(det, SPEC, INTR), "too few corners")
    _assert_rejected(estimate_pose(det, SPEC, INTR, limits={"min_corners": 3}), "collinear")
    # two rows are not collinear
    ids2 = np.concatenate([_row(0), _row(2)])
    uv2 = project_points(SPEC.corners_target()[ids2], T, INTR)
    assert estimate_pose(Detection(ids2, uv2, 6, (INTR.width, INTR.height)), SPEC, INTR).ok


def test_grossly_wrong_focal_length_is_rejected_for_its_rms():
    # a near, strongly tilted board: perspective pins the focal length down
    T = make_transform(so3_exp(np.radians([40.0, 0.0, 0.0])), [0.0, 0.0, 0.4]) @ CENTRE
    K2 = INTR.K.copy()
    K2[0, 0] *= 2
    K2[1, 1] *= 2
    doubled = CameraIntrinsics(K2, INTR.dist, INTR.width, INTR.height)
    image = render_view(SPEC, INTR, T, 2.0, np.random.default_rng(5))
    det = detect_board(image, SPEC)
    assert det.reason is None

    # the doubled focal length cannot fit even the exact projections to within the limit...
    exact = project_points(SPEC.corners_target()[det.ids], T, INTR)
    model_rms = estimate_pose(Detection(det.ids, exact, 0, det.image_size), SPEC, doubled).rms_px
    detection_rms = float(np.sqrt(np.mean(np.sum((det.corners_px - exact) ** 2, axis=1))))
    assert model_rms - detection_rms > POSE_LIMITS["max_rms_px"]
    # ...so (triangle inequality) it cannot fit the detections either
    right = estimate_pose(det, SPEC, INTR)
    wrong = estimate_pose(det, SPEC, doubled)
    assert right.ok
    _assert_rejected(wrong, "reprojection RMS")
    assert wrong.rms_px > POSE_LIMITS["max_rms_px"]
    assert f"{wrong.rms_px:.2f}" in wrong.reason


def test_near_fronto_parallel_distant_board_is_ambiguous():
    # IPPE's two planar solutions fit equally well when the board faces the camera from afar
    T = make_transform(so3_exp(np.radians([2.0, 1.0, 0.0])), [0.0, 0.0, 2.5]) @ CENTRE
    ids, uv = corners_in_image(T, INTR, 0.5, np.random.default_rng(0))
    assert len(ids) == SPEC.n_corners
    pose = estimate_pose(Detection(ids, uv, 17, (INTR.width, INTR.height)), SPEC, INTR)
    _assert_rejected(pose, "ambiguous")
    assert pose.T_cam_target is None


def test_a_rejection_limit_can_be_tightened(rendered_views):
    det = detect_board(rendered_views[0].image, SPEC)
    pose = estimate_pose(det, SPEC, INTR, limits={"max_rms_px": 1e-3})
    _assert_rejected(pose, "reprojection RMS")
    assert pose.rms_px > 1e-3
    pose = estimate_pose(det, SPEC, INTR, limits={"min_corners": SPEC.n_corners + 1})
    _assert_rejected(pose, "too few corners")
