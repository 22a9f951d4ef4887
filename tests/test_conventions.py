"""The conventions page's mappings, checked against the libraries they describe."""

from __future__ import annotations

import numpy as np
import pytest

from handeye.core.conventions import opencv_hand_eye_args
from handeye.core.se3 import make_transform
from handeye.core.synthetic import make_problem
from tests.tolerances import EXACT

cv2 = pytest.importorskip("cv2")


@pytest.mark.parametrize("setup", ["eye_to_hand", "eye_in_hand"])
def test_opencv_mapping_gives_the_named_camera_pose(setup):
    """Following handeye.core.conventions, OpenCV's cam2gripper is T_base_cam (eye-to-hand) or T_ee_cam
    (eye-in-hand)."""
    p = make_problem(10, setup, np.random.default_rng(3))
    R, t = cv2.calibrateHandEye(
        *opencv_hand_eye_args(p.T_base_ee, p.T_cam_target, setup), method=cv2.CALIB_HAND_EYE_PARK
    )
    np.testing.assert_allclose(make_transform(R, t.ravel()), p.X_true, atol=EXACT)
