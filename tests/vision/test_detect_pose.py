"""Detection and PnP on rendered views: corners at the true projections, poses within the noise."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from classic.vision import CameraIntrinsics, Detection, detect_board, estimate_pose
from classic.vision.detect import POSE_LIMITS, project_points
from classic.vision.synthetic import render_view
from handeye.core.se3 import make_transform, so3_exp
from tests.tolerances import CORNER_SIGMA_BOUND, ESTIMATED_SIGMA_BOUND, EXACT, FLOAT, RENDER_BIAS_PX
from tests.vision._helpers import (
    CENTRE,
    INTR,
    SPEC,
    board_pose,
    common_shift_floor,
    per_axis_sigma_px,
    predicted_block_sigma,
    rotation_error_rad,
    translation_error_m,
    view_jacobian,
)
from tests.vision.conftest import NOISE_LEVELS, POSE_SEEDS

VIEWS = range(len(POSE_SEEDS) * len(NOISE_LEVELS))


def _detect(view):
    det = detect_board(view.image, SPEC)
    assert det.reason is None, det.reason
    return det


@pytest.mark.parametrize("index", VIEWS)
def test_detected_corners_are_at_the_true_projections(rendered_views, index):
    view = rendered_views[index]
    det = _detect(view)
    ids = det.ids
    assert len(np.unique(ids)) == len(ids) and ids.min() >= 0 and ids.max() < SPEC.n_corners
    assert len(ids) >= POSE_LIMITS["min_corners"]
    assert det.n_markers > 0 and det.image_size == (INTR.width, INTR.height)

    pose = estimate_pose(det, SPEC, INTR)
    assert pose.ok, pose.reason
    M = len(ids)
    sigma = per_axis_sigma_px(pose.rms_px, M, 6)
    err = det.corners_px - project_points(SPEC.corners_target()[ids], view.T_cam_target, INTR)
    bound = np.sqrt(2) * RENDER_BIAS_PX + CORNER_SIGMA_BOUND * sigma
    assert np.linalg.norm(err, axis=1).max() <= bound
    # the error common to the view (invisible in the residuals) is within the renderer's bias
    assert np.all(np.abs(err.mean(axis=0)) <= RENDER_BIAS_PX + CORNER_SIGMA_BOUND * sigma / np.sqrt(M))


@pytest.mark.parametrize("index", VIEWS)
def test_pnp_pose_is_within_the_noise_predicted_from_the_views_residuals(rendered_views, index):
    view = rendered_views[index]
    det = _detect(view)
    pose = estimate_pose(det, SPEC, INTR)
    assert pose.ok, pose.reason
    assert pose.n_corners == len(det.ids)
    T = pose.T_cam_target
    assert pose.rms_px == pytest.approx(
        np.sqrt(
            np.mean(np.sum((project_points(SPEC.corners_target()[det.ids], T, INTR) - det.corners_px) ** 2, axis=1))
        ),
        rel=FLOAT,  # the same formula on the same pose
    )

    # predicted covariance sigma^2 (J^T J)^-1, sigma from the view's own RMS (2M - 6 dof)
    J = view_jacobian(T, det.ids)
    sigma_px = per_axis_sigma_px(pose.rms_px, len(det.ids), 6)
    sig_rot, sig_trans = predicted_block_sigma(J, sigma_px)
    floor_rot, floor_trans = common_shift_floor(J, np.zeros(len(det.ids), int), RENDER_BIAS_PX)

    assert rotation_error_rad(T, view.T_cam_target) <= ESTIMATED_SIGMA_BOUND * sig_rot + floor_rot
    assert translation_error_m(T, view.T_cam_target) <= ESTIMATED_SIGMA_BOUND * sig_trans + floor_trans
    # the bound is a bound on something small: well under a degree and a centimetre here
    assert ESTIMATED_SIGMA_BOUND * sig_rot + floor_rot < np.radians(1.0)
    assert ESTIMATED_SIGMA_BOUND * sig_trans + floor_trans < 0.01


def test_more_image_noise_gives_more_corner_noise(rendered_views):
    # same pose drawn at noise_gray 2 and 8: the detections' RMS does not fall
    by_seed = {}
    for v in rendered_views:
        by_seed.setdefault(v.seed, {})[v.noise_gray] = estimate_pose(_detect(v), SPEC, INTR).rms_px
    low, high = min(NOISE_LEVELS), max(NOISE_LEVELS)
    assert np.mean([r[high] for r in by_seed.values()]) > np.mean([r[low] for r in by_seed.values()])


@pytest.mark.parametrize("seed", range(6))
def test_exact_corners_give_the_exact_pose(seed):
    T_true = board_pose(np.random.default_rng(seed))
    uv = project_points(SPEC.corners_target(), T_true, INTR)
    pose = estimate_pose(Detection(np.arange(SPEC.n_corners), uv, 0, (INTR.width, INTR.height)), SPEC, INTR)
    assert pose.ok, pose.reason
    assert np.abs(pose.T_cam_target - T_true).max() <= EXACT
    assert pose.rms_px <= EXACT


def test_color_image_gives_the_same_detection(rendered_views):
    view = rendered_views[0]
    gray = detect_board(view.image, SPEC)
    color = detect_board(cv2.cvtColor(view.image, cv2.COLOR_GRAY2BGR), SPEC)
    np.testing.assert_array_equal(color.ids, gray.ids)
    np.testing.assert_array_equal(color.corners_px, gray.corners_px)


def test_pnp_uses_the_distortion():
    """The same distorted image, once with the true intrinsics and once with the distortion left out."""
    # board near and off-centre, where barrel distortion moves corners most
    R = so3_exp(np.radians([30.0, -15.0, 10.0]))
    T_true = make_transform(R, [0.08, 0.05, 0.45]) @ CENTRE
    image = render_view(SPEC, INTR, T_true, 2.0, np.random.default_rng(3))
    det = detect_board(image, SPEC)
    assert det.reason is None
    no_dist = CameraIntrinsics(INTR.K, np.zeros(5), INTR.width, INTR.height)

    right = estimate_pose(det, SPEC, INTR)
    wrong = estimate_pose(det, SPEC, no_dist)
    assert right.ok
    # model error of the distortion-free camera on these corners: its best fit to their exact projections
    exact = project_points(SPEC.corners_target()[det.ids], T_true, INTR)
    model_rms = estimate_pose(Detection(det.ids, exact, 0, det.image_size), SPEC, no_dist).rms_px
    detection_rms = float(np.sqrt(np.mean(np.sum((det.corners_px - exact) ** 2, axis=1))))
    # triangle inequality on the residual vectors: the wrong model cannot fit the detections better than
    # it fits the exact projections, less the detection error
    assert wrong.rms_px >= model_rms - detection_rms
    assert model_rms - detection_rms > right.rms_px  # the geometry makes the difference visible
    assert wrong.rms_px > right.rms_px
    # and the pose of the wrong model is further from the truth
    assert translation_error_m(wrong.T_cam_target, T_true) > translation_error_m(right.T_cam_target, T_true)
