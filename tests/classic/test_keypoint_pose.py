"""The cross-frame keypoint solve: exact keypoints give the pose to 1e-9; most keypoints wrong is refused."""

from __future__ import annotations

import numpy as np
import pytest

from classic.keypoint_pose import KeypointPoseOptions, solve_keypoint_pose
from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import make_transform, so3_exp
from tests.tolerances import EXACT, SIGMA_BOUND

N_FRAMES, K = 50, 8


def _problem(rng):
    T = make_transform(so3_exp(rng.normal(size=3)), rng.normal(size=3))
    p_cam = rng.uniform(-0.5, 0.5, (N_FRAMES * K, 3)) + [0, 0, 1.5]
    return T, p_cam, p_cam @ T[:3, :3].T + T[:3, 3], np.repeat(np.arange(N_FRAMES), K)


def test_exact_keypoints_give_the_pose(rng):
    T, p_cam, p_base, frame = _problem(rng)
    res = solve_keypoint_pose(p_cam, p_base, frame)
    assert res.ok and res.inliers.all()
    np.testing.assert_allclose(res.T_base_cam, T, atol=EXACT)


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
    np.testing.assert_allclose(res.T_base_cam, T, atol=EXACT)  # the exact 80 % decide
    most = p_base.copy()
    wrong = rng.random(len(most)) < 0.7
    most[wrong] += rng.uniform(-1, 1, (wrong.sum(), 3))
    res = solve_keypoint_pose(p_cam, most, frame)
    assert not res.ok and res.T_base_cam is None and "too few keypoints agree" in res.refused


# ------------------------------------------------------------ with the measurements: image positions and depths

INTR = np.array([0.9, 0.9, 0.5, 0.5])  # normalised fx, fy, cx, cy


def _measured(p_cam):
    """``(x_n, y_n, z)`` of camera-frame points, and their intrinsics (M, 4)."""
    x, y, z = p_cam.T
    return np.column_stack([INTR[0] * x / z + INTR[2], INTR[1] * y / z + INTR[3], z]), np.tile(INTR, (len(p_cam), 1))


def _back(meas):
    z = meas[:, 2]
    return np.column_stack([(meas[:, 0] - INTR[2]) / INTR[0] * z, (meas[:, 1] - INTR[3]) / INTR[1] * z, z])


def test_exact_measurements_give_the_pose_and_outliers_are_left_to_the_consensus(rng):
    T, p_cam, p_base, frame = _problem(rng)
    meas, intr = _measured(p_cam)
    sigma = np.tile([1e-3, 1e-3, 0.01], (len(meas), 1))
    res = solve_keypoint_pose(p_cam, p_base, frame, meas=meas, intrinsics_norm=intr, sigma=sigma)
    assert res.ok and res.inliers.all()
    np.testing.assert_allclose(res.T_base_cam, T, atol=EXACT)
    wrong = rng.random(len(meas)) < 0.2
    bad = meas.copy()
    bad[wrong] += rng.uniform(-0.3, 0.3, (wrong.sum(), 3)) * [1, 1, 0]  # far off in the image
    res = solve_keypoint_pose(_back(bad), p_base, frame, meas=bad, intrinsics_norm=intr, sigma=sigma)
    assert res.ok and not res.inliers[wrong].any()
    np.testing.assert_allclose(res.T_base_cam, T, atol=EXACT)


def test_measurement_weights_beat_the_3d_fit_and_their_sigma_matches_the_error(rng):
    """Depth noise 20 mm, image noise 1 mm across the line of sight (at 1.5 m): weighing each component by its
    sigma makes the pose several times better than the 3-D fit, which reads depth noise as position. Over 30
    trials the RMS error over the mean predicted sigma estimates 1 with a spread of about 1 / sqrt(2 * 30 * 3)
    from the errors (8 %) and as much again from the clustered sigma (50 clusters): 0.7-1.4 is over 3 of it."""
    sig = np.array([0.9 * 1e-3 / 1.5, 0.9 * 1e-3 / 1.5, 0.02])  # normalised image, normalised image, metres
    errs, errs_3d, sigmas = [], [], []
    for _ in range(30):
        T, p_cam, p_base, frame = _problem(rng)
        meas, intr = _measured(p_cam)
        noisy = meas + rng.normal(size=meas.shape) * sig
        p_noisy = _back(noisy)
        sigma = np.tile(sig, (len(meas), 1))
        wide = KeypointPoseOptions(inlier_m=0.1)
        res = solve_keypoint_pose(p_noisy, p_base, frame, meas=noisy, intrinsics_norm=intr, sigma=sigma, options=wide)
        res_3d = solve_keypoint_pose(p_noisy, p_base, frame, options=wide)
        assert res.ok and res_3d.ok
        errs.append(np.linalg.norm(res.T_base_cam[:3, 3] - T[:3, 3]) * 1e3)
        errs_3d.append(np.linalg.norm(res_3d.T_base_cam[:3, 3] - T[:3, 3]) * 1e3)
        sigmas.append(res.sigma["translation_mm"])
    rms, rms_3d = np.sqrt(np.mean(np.square(errs))), np.sqrt(np.mean(np.square(errs_3d)))
    assert rms < 0.5 * rms_3d, (rms, rms_3d)
    assert 0.7 <= rms / np.mean(sigmas) <= 1.4, (rms, np.mean(sigmas))


def test_measurements_come_complete_and_shaped_or_are_refused(rng):
    import pytest

    from handeye.core.errors import ShapeError

    T, p_cam, p_base, frame = _problem(rng)
    meas, intr = _measured(p_cam)
    sigma = np.tile([1e-3, 1e-3, 0.01], (len(meas), 1))
    with pytest.raises(ShapeError, match="all three or none"):
        solve_keypoint_pose(p_cam, p_base, frame, meas=meas, intrinsics_norm=intr)
    with pytest.raises(ShapeError, match="intrinsics_norm"):
        solve_keypoint_pose(p_cam, p_base, frame, meas=meas, intrinsics_norm=intr[:, :3], sigma=sigma)


@pytest.mark.parametrize(
    "setting",
    [
        {"min_inlier_fraction": float("nan")},
        {"min_inlier_fraction": 1.5},
        {"inlier_m": float("nan")},
        {"inlier_m": 0.0},
        {"iterations": 0},
    ],
)
def test_settings_that_would_never_refuse_are_refused(setting):
    # min_inlier_fraction = NaN compared False with every fraction: a pose from no agreement at all came back unchecked
    with pytest.raises(HandEyeInputError, match=next(iter(setting))):  # refused when made, before any solve
        KeypointPoseOptions(**setting)
