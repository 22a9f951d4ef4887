"""The keypoint benchmark's camera-frame decomposition recovers a rotation error put in about the robot."""

from __future__ import annotations

import numpy as np

from handeye.core.se3 import matrix_from_quat_xyzw, quat_xyzw_from_matrix, so3_exp
from learned.data import with_keypoints
from learned.keypoints import keypoint_targets
from tests.learned._synthetic import make_frames
from tests.tolerances import ABSOLUTE_ONLY, FLOAT


def test_a_camera_turned_about_the_robot_is_read_as_that_rotation_and_its_translation():
    from benchmarks.keypoint_errors import camera_frame_errors

    rng = np.random.default_rng(3)
    frames = make_frames(rng, train_per_region=1, test_per_region=2, frames_per_camera=5, size=(32, 32))
    n = len(frames)
    frames.intrinsics_norm = np.tile(np.array([1.0, 1.0, 0.5, 0.5], np.float32), (n, 1))
    frames = with_keypoints(frames, rng.uniform(-0.3, 0.3, (n, 6, 3)) + [0.0, 0.0, 0.3])
    index = np.flatnonzero(frames.split == "test")
    pred = np.zeros((len(index), 6, 3))
    turns, offsets = [], []
    for c in np.unique(frames.camera[index]):
        m = frames.camera[index] == c
        i0 = index[m][0]
        R = matrix_from_quat_xyzw(frames.truth_q_base_cam_xyzw[i0])
        t = frames.truth_t_base_cam_mm[i0] / 1000.0
        p_c = (R.T @ (frames.keypoints_base[index][m].reshape(-1, 3) - t).T).T.mean(0)
        w = rng.normal(size=3) * np.radians(0.5)
        R_w = so3_exp(w)
        # the camera turned by w about the robot: T_est = T_true [R_w, p_c - R_w p_c]
        R_est, t_est = R @ R_w, t + R @ (p_c - R_w @ p_c)
        pred[m] = keypoint_targets(
            frames.keypoints_base[index][m].astype(float),
            np.tile(t_est * 1000.0, (m.sum(), 1)),
            np.tile(quat_xyzw_from_matrix(R_est), (m.sum(), 1)),
            frames.intrinsics_norm[index][m],
        )
        turns.append(np.degrees(w))
        offsets.append((p_c - R_w @ p_c) * 1000.0)
    ce = camera_frame_errors(pred, frames, index, stats=None)
    # exact predictions: the fit is exact to rounding, FLOAT of unit-size quantities in their units: radians
    # shown in degrees, and millimetres of the keypoints' distance |p_c| (about 1.4 m)
    np.testing.assert_allclose(ce[:, 3:6], turns, atol=np.degrees(FLOAT), rtol=ABSOLUTE_ONLY)  # rotation, deg
    np.testing.assert_allclose(ce[:, 0:3], offsets, atol=FLOAT * ce[:, 9].max(), rtol=ABSOLUTE_ONLY)  # its mm
    # -w x p_c is that translation to first order: (I - R_w) p_c = -w x p_c - w x (w x p_c) / 2 - ..., the rest
    # within |w|^2 |p_c| (twice the second-order term), against the translation itself, |w| |p_c|
    w, rest = np.radians(ce[:, 3:6]), np.linalg.norm(ce[:, 0:3] - ce[:, 6:9], axis=1)
    assert np.all(rest <= np.sum(w**2, axis=1) * ce[:, 9])
    assert np.all(rest < 0.05 * np.linalg.norm(ce[:, 0:3], axis=1))
