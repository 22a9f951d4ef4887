"""The cross-frame keypoint solve: exact keypoints give the pose to 1e-9; most keypoints wrong is refused."""

from __future__ import annotations

import numpy as np

from classic.keypoint_pose import solve_keypoint_pose
from handeye.core.se3 import make_transform, so3_exp
from tests.tolerances import SIGMA_BOUND

N_FRAMES, K = 50, 8


def _problem(rng):
    T = make_transform(so3_exp(rng.normal(size=3)), rng.normal(size=3))
    p_cam = rng.uniform(-0.5, 0.5, (N_FRAMES * K, 3)) + [0, 0, 1.5]
    return T, p_cam, p_cam @ T[:3, :3].T + T[:3, 3], np.repeat(np.arange(N_FRAMES), K)


def test_exact_keypoints_give_the_pose(rng):
    T, p_cam, p_base, frame = _problem(rng)
    res = solve_keypoint_pose(p_cam, p_base, frame)
    assert res.ok and res.inliers.all()
    np.testing.assert_allclose(res.T_base_cam, T, atol=1e-9)


def test_noisy_keypoints_within_their_sigma(rng):
    T, p_cam, p_base, frame = _problem(rng)
    noisy = p_base + rng.normal(scale=0.005, size=p_base.shape)
    res = solve_keypoint_pose(p_cam, noisy, frame)
    assert res.ok
    err_mm = np.linalg.norm(res.T_base_cam[:3, 3] - T[:3, 3]) * 1e3
    assert err_mm <= SIGMA_BOUND * res.sigma["translation_mm"]


def test_outliers_are_ignored_and_most_wrong_is_refused(rng):
    T, p_cam, p_base, frame = _problem(rng)
    some = p_base.copy()
    wrong = rng.random(len(some)) < 0.2
    some[wrong] += rng.uniform(-1, 1, (wrong.sum(), 3))
    res = solve_keypoint_pose(p_cam, some, frame)
    assert res.ok
    np.testing.assert_allclose(res.T_base_cam, T, atol=1e-9)  # the exact 80 % decide
    most = p_base.copy()
    wrong = rng.random(len(most)) < 0.7
    most[wrong] += rng.uniform(-1, 1, (wrong.sum(), 3))
    res = solve_keypoint_pose(p_cam, most, frame)
    assert not res.ok and res.T_base_cam is None and "too few keypoints agree" in res.refused
