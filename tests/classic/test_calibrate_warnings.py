"""``classic.calibrate``'s warnings point at its caller's line, whichever stage raises them.

Each stage that warns passes a ``stacklevel`` counted from its depth below :func:`classic.calibrate`; a stage
moved one call deeper (or shallower) without its count moved points the warning into the library instead.
"""

from __future__ import annotations

import numpy as np
import pytest

import classic
from handeye.core.errors import SuspectPosesWarning, WeakMotionWarning
from handeye.core.synthetic import make_problem
from handeye.core.synthetic_outliers import inject_outlier


def _from_here(record, category) -> bool:
    return any(issubclass(w.category, category) and w.filename == __file__ for w in record)


def test_a_named_pose_warns_at_the_callers_line():
    """40 poses, one camera pose 8 mm off across the line of sight: named, returned with it."""
    p = make_problem(40, "eye_to_hand", np.random.default_rng(0), camera_noise=(0.1, 1.0))
    B = p.T_cam_target.copy()
    B[17, 0, 3] += 0.008
    with pytest.warns(SuspectPosesWarning) as record:
        res = classic.calibrate(p.T_base_ee, B)
    assert res.diagnostics["outlier_test"]["action"] == "named"
    assert _from_here(record, SuspectPosesWarning)


@pytest.mark.parametrize("setup", ["eye_to_hand", "eye_in_hand"])
def test_a_pose_left_out_warns_at_the_callers_line(setup):
    """8 poses, one camera pose 20 mm off: not gross, but it moves the answer by over 2 sigma: left out."""
    p = make_problem(8, setup, np.random.default_rng(0), camera_noise=(0.1, 1.0), robot_noise=(0.01, 0.2))
    A, B = inject_outlier(p.T_base_ee, p.T_cam_target, "camera_translation", 0.02, 2, np.random.default_rng(0))
    with pytest.warns(SuspectPosesWarning) as record:
        res = classic.calibrate(A, B, setup=setup)
    assert res.diagnostics["outlier_test"]["action"] == "left out"
    assert _from_here(record, SuspectPosesWarning)


@pytest.mark.parametrize("robust", [False, True])
def test_weak_motion_warns_at_the_callers_line(robust):
    """Four poses warn; robust, the warning is held until the final inliers are known, then given."""
    p = make_problem(4, "eye_in_hand", np.random.default_rng(0))
    with pytest.warns(WeakMotionWarning, match="only 4 poses") as record:
        classic.calibrate(p.T_base_ee, p.T_cam_target, setup="eye_in_hand", robust=robust)
    assert _from_here(record, WeakMotionWarning)
