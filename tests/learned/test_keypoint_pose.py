"""The keypoint model's placement fit: residual statistics and the maximum-likelihood solve.

Synthetic placements: keypoints spread over a robot-sized volume in the base frame, seen from a
known ``T_base_cam`` through the normalised intrinsics, projected exactly by
:func:`learned.keypoints.keypoint_targets`. Tolerances come from the noise put in.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from handeye.core.se3 import make_transform, matrix_from_quat_xyzw, quat_xyzw_from_matrix
from learned.keypoints import (
    SIGMA_FLOOR,
    KeypointNet,
    camera_pose,
    frame_poses,
    keypoint_targets,
    model_residual_stats,
    pose_errors,
    residual_stats,
)
from learned.model import ModelConfig, load_weights
from tests.tolerances import EXACT

K_NORM = np.array([0.9, 0.9, 0.5, 0.5])  # fx / W, fy / H, cx, cy: a 58 deg field of view


def _placement(rng, n_frames=30, k=6):
    """Keypoints (N, K, 3) in the base frame, exact targets (N, K, 3), intrinsics (N, 4), ``T_base_cam``."""
    T_base_cam = make_transform(
        matrix_from_quat_xyzw(np.array([0.8, -0.3, 0.2, 0.45]) / np.linalg.norm([0.8, -0.3, 0.2, 0.45])),
        np.array([1.1, 0.4, 0.9]),
    )
    # points in front of the camera, 1.2-1.8 m deep, inside the image
    z = rng.uniform(1.2, 1.8, (n_frames, k))
    xy = rng.uniform(0.15, 0.85, (n_frames, k, 2))
    p_cam = np.stack([(xy[..., 0] - 0.5) / 0.9 * z, (xy[..., 1] - 0.5) / 0.9 * z, z], axis=-1)
    p_base = p_cam @ T_base_cam[:3, :3].T + T_base_cam[:3, 3]
    intr = np.tile(K_NORM, (n_frames, 1))
    t_mm = np.tile(T_base_cam[:3, 3] * 1000.0, (n_frames, 1))
    q = np.tile(quat_xyzw_from_matrix(T_base_cam[:3, :3]), (n_frames, 1))
    return p_base, keypoint_targets(p_base, t_mm, q, intr), intr, T_base_cam


def _error(T, T_true):
    q = quat_xyzw_from_matrix(T_true[:3, :3])[None]
    et, er = pose_errors(T[None], T_true[None, :3, 3] * 1000.0, q)
    return et[0], er[0]


def test_residual_stats_recover_the_offsets_and_sigmas_put_in():
    rng = np.random.default_rng(0)
    n, k = 4000, 3
    target = np.stack([rng.uniform(0.1, 0.9, (n, k)), rng.uniform(0.1, 0.9, (n, k)), rng.uniform(1, 2, (n, k))], -1)
    offset = np.array([[0.01, -0.02, 0.03], [0.0, 0.005, -0.01], [-0.004, 0.0, 0.02]])
    sigma = np.array([[0.002, 0.004, 0.01], [0.01, 0.003, 0.05], [0.005, 0.005, 0.02]])
    pred = target + offset + rng.normal(size=(n, k, 3)) * sigma
    stats = residual_stats(pred, target)
    # the median's standard error is 1.25 sigma / sqrt(n), the MAD's about 0.8 sigma / sqrt(n): 5 of each
    assert np.all(np.abs(stats[0] - offset) < 5 * 1.25 * sigma / np.sqrt(n))
    assert np.all(np.abs(stats[1] - sigma) < 5 * 0.8 * sigma / np.sqrt(n))


def test_a_keypoint_rarely_in_the_image_gets_no_offset_and_the_largest_sigma():
    rng = np.random.default_rng(1)
    n = 200
    target = np.stack([rng.uniform(0.1, 0.9, (n, 2)), rng.uniform(0.1, 0.9, (n, 2)), rng.uniform(1, 2, (n, 2))], -1)
    target[3:, 1, 0] = 1.5  # keypoint 1 outside the image in all but 3 frames
    pred = target + 0.01 + rng.normal(size=target.shape) * 0.001
    stats = residual_stats(pred, target)
    assert np.all(stats[0, 1] == 0.0)
    np.testing.assert_array_equal(stats[1, 1], stats[1, 0])
    assert np.all(stats[1] >= SIGMA_FLOOR)
    target[:, :, 0] = 1.5  # nothing in the image: no statistics at all
    assert np.isnan(residual_stats(pred, target)).all()


@pytest.mark.parametrize("with_stats", [False, True])
def test_the_cross_frame_fit_recovers_a_known_camera_pose_from_exact_keypoints(with_stats):
    p_base, target, intr, T_true = _placement(np.random.default_rng(2))
    stats = np.stack([np.zeros((6, 3)), np.full((6, 3), 0.01)]) if with_stats else None
    T, w = camera_pose(target, p_base, intr, stats=stats)
    np.testing.assert_allclose(T, T_true, atol=EXACT)
    assert w.shape == (p_base.shape[0] * p_base.shape[1],) and np.all(w > 0.99)


def test_predictions_of_another_keypoint_set_are_refused():
    """A model trained on 8 keypoints against frames that carry 14 (the set grew): a named refusal, not a crash."""
    from handeye.core.errors import ShapeError

    p_base, target, intr, _ = _placement(np.random.default_rng(4), n_frames=5, k=6)
    with pytest.raises(ShapeError, match="another keypoint set"):
        camera_pose(target[:, :4], p_base, intr)
    with pytest.raises(ShapeError, match="another keypoint set"):
        frame_poses(target[:, :4], p_base, intr)


def test_known_offsets_are_removed_before_the_fit():
    p_base, target, intr, T_true = _placement(np.random.default_rng(3))
    offset = np.array([0.01, -0.005, 0.03]) * np.linspace(0.5, 1.5, 6)[:, None]  # (K, 3): 3-9 px, 15-45 mm
    pred = target + offset
    stats = np.stack([offset, np.full((6, 3), 0.01)])
    T, _ = camera_pose(pred, p_base, intr, stats=stats)
    np.testing.assert_allclose(T, T_true, atol=EXACT)
    np.testing.assert_allclose(frame_poses(pred, p_base, intr, stats), np.broadcast_to(T_true, (30, 4, 4)), atol=EXACT)
    assert _error(camera_pose(pred, p_base, intr)[0], T_true)[0] > 10.0  # the plain fit is pulled off by them


def test_weighing_by_the_sigmas_beats_the_3d_fit_when_the_depths_are_noisier_than_the_pixels():
    """Depth noise 30 mm, pixel noise 0.002 (3.3 mm across the line of sight at 1.5 m).

    The 3-D fit weighs a millimetre along the line of sight as one across it; the likelihood fit
    weighs each by its sigma. Over 20 placements its RMS translation error must be below half the 3-D
    fit's (the depth noise is 9x the lateral, so the 3-D fit's error is mostly depth noise).
    """
    rng = np.random.default_rng(4)
    sigma = np.tile([0.002, 0.002, 0.03], (6, 1))
    plain, weighted = [], []
    for _ in range(20):
        p_base, target, intr, T_true = _placement(rng)
        pred = target + rng.normal(size=target.shape) * sigma
        plain.append(_error(camera_pose(pred, p_base, intr)[0], T_true)[0])
        weighted.append(
            _error(camera_pose(pred, p_base, intr, stats=np.stack([np.zeros_like(sigma), sigma]))[0], T_true)[0]
        )
    assert np.sqrt(np.mean(np.square(weighted))) < 0.5 * np.sqrt(np.mean(np.square(plain)))


def test_keypoints_behind_the_camera_get_no_weight():
    p_base, target, intr, T_true = _placement(np.random.default_rng(5))
    pred = target.copy()
    pred[0, 0, 2] = -1.0
    stats = np.stack([np.zeros((6, 3)), np.full((6, 3), 0.01)])
    T, w = camera_pose(pred, p_base, intr, stats=stats)
    assert w[0] == 0.0
    np.testing.assert_allclose(T, T_true, atol=EXACT)


def test_keypoints_outside_the_consensus_are_left_out_of_the_likelihood_fit():
    """Exact keypoints and 15 % of them 0.2-0.5 m off in depth: the robust 3-D fit puts those beyond
    CONSENSUS_M, the likelihood fit leaves them out and lands on the truth; with every keypoint in (the
    consensus made wide) the Cauchy loss only down-weights them and the pose is pulled off."""
    import learned.keypoints as kp

    rng = np.random.default_rng(6)
    p_base, target, intr, T_true = _placement(rng)
    pred = target.copy()
    bad = rng.random(pred.shape[:2]) < 0.15
    pred[bad, 2] += rng.uniform(0.2, 0.5, bad.sum())
    stats = np.stack([np.zeros((6, 3)), np.full((6, 3), 0.01)])
    T, w = camera_pose(pred, p_base, intr, stats=stats)
    np.testing.assert_allclose(T, T_true, atol=EXACT)
    assert np.all(w[bad.ravel()] == 0.0) and np.all(w[~bad.ravel()] > 0.99)
    wide = kp.CONSENSUS_M
    try:
        kp.CONSENSUS_M = 10.0
        T_all, w_all = camera_pose(pred, p_base, intr, stats=stats)
    finally:
        kp.CONSENSUS_M = wide
    assert np.all(w_all[bad.ravel()] > 0.0)
    assert np.abs(T_all - T_true).max() > 1e-6


def test_a_model_saved_without_residual_stats_loads_with_none_and_unexpected_weights_are_refused():
    model = KeypointNet(ModelConfig(kind="keypoints", image_size=(32, 32), channels=(8,), n_keypoints=4))
    assert model_residual_stats(model) is None  # NaN until estimated
    state = {k: v for k, v in model.state_dict().items() if k != "residual_stats"}
    again = KeypointNet(model.config)
    load_weights(again, state)
    assert model_residual_stats(again) is None
    model.residual_stats.copy_(torch.ones(2, 4, 3))
    load_weights(again, model.state_dict())
    np.testing.assert_array_equal(model_residual_stats(again), np.ones((2, 4, 3)))
    with pytest.raises(RuntimeError, match="unexpected"):
        load_weights(again, {**model.state_dict(), "extra": torch.zeros(1)})
    with pytest.raises(RuntimeError, match="missing"):
        load_weights(again, {k: v for k, v in state.items() if not k.startswith("heat")})


def test_per_frame_fits_with_statistics_recover_each_frame_and_leave_short_frames_nan():
    p_base, target, intr, T_true = _placement(np.random.default_rng(7), n_frames=5)
    stats = np.stack([np.zeros((6, 3)), np.full((6, 3), 0.01)])
    pred = target.copy()
    pred[2, 1:] = np.nan  # one keypoint left: no pose for that frame
    T = frame_poses(pred, p_base, intr, stats)
    assert np.isnan(T[2]).all()
    np.testing.assert_allclose(T[[0, 1, 3, 4]], np.broadcast_to(T_true, (4, 4, 4)), atol=EXACT)
