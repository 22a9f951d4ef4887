"""The robot-error warning stays quiet on exact data: the residual is rounding there, not a robot error."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from classic.vision.reprojection import ReprojectionOptions, refine_reprojection
from classic.vision.robot_noise import DOMINANCE_FACTOR, DOMINANCE_FLOOR_PX, RobotPoseErrorWarning, robot_dominates
from handeye.core.synthetic import make_problem
from tests.vision._helpers import CENTRE, INTR, SPEC, corners_in_image


def test_the_floor_and_the_factor():
    # exact data: 1e-6 px against a detection RMS of 0 is "3 times" it, but below the floor
    assert not robot_dominates(1e-6, 0.0)
    assert not robot_dominates(0.5 * DOMINANCE_FLOOR_PX, 0.0)
    assert robot_dominates(2 * DOMINANCE_FLOOR_PX, 0.0)
    assert robot_dominates(1.01 * DOMINANCE_FACTOR * 0.1, 0.1)
    assert not robot_dominates(0.99 * DOMINANCE_FACTOR * 0.1, 0.1)


@pytest.mark.parametrize("setup", ["eye_to_hand", "eye_in_hand"])
def test_exact_corners_and_robot_give_no_warning(setup):
    """Before, exact data warned "0.00 px RMS per corner against 0.000 px for the corner detection alone"."""
    p = make_problem(12, setup, np.random.default_rng(5))
    ids, uv = zip(*(corners_in_image(T @ CENTRE) for T in p.T_cam_target))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = refine_reprojection(
            p.T_base_ee, list(ids), list(uv), SPEC, INTR, p.X_true, p.Y_true @ CENTRE, ReprojectionOptions(setup=setup)
        )
    assert not any(issubclass(w.category, RobotPoseErrorWarning) for w in caught)
    assert not res.diagnostics["robot_dominates"] and res.warnings == []
