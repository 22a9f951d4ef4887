"""A direction the data do not determine is refused with its name, never reported with sigma 0.

``pinv(J^T J)`` gives a direction of the parameters that ``J`` does not see zero variance: before this check,
``refine_xy`` on robot motions about one axis reported X's translation to a few mm while it was 0.36 m off
(the translation along the common axis is free), and on pure translations reported X's translation to
0.3 mm while it was 60 mm off (only ``t_X - R_A t_Y`` is fixed: three free directions).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import classic
from classic.least_squares import RANK_TOLERANCE, covariance_from_jacobian, undetermined_directions
from classic.refine import RefineOptions, cramer_rao_bound, refine_xy
from classic.vision import ReprojectionOptions, refine_reprojection
from handeye.core.errors import DegenerateMotionError, WeakMotionWarning
from handeye.core.synthetic import make_problem
from tests.tolerances import EXACT
from tests.vision._helpers import CENTRE, INTR, SPEC, corners_in_image

SETUPS = ["eye_to_hand", "eye_in_hand"]
#: The camera's pose noise of the problems (deg, mm per axis): the robot poses stay exact, so a motion set that
#: is degenerate stays exactly degenerate.
CAMERA_NOISE = (0.05, 0.5)


def _robot_side(p):
    return p.T_base_ee if p.setup == "eye_to_hand" else np.linalg.inv(p.T_base_ee)


@pytest.mark.parametrize("setup", SETUPS)
@pytest.mark.parametrize(
    "motion, free",
    [("one_axis", "1 direction"), ("translation_only", "3 directions")],  # the translation along the axis; all of it
)
def test_degenerate_motions_refuse_the_translations_they_leave_free(setup, motion, free):
    p = make_problem(10, setup, np.random.default_rng(0), camera_noise=CAMERA_NOISE, motion=motion)
    with pytest.raises(DegenerateMotionError, match=free) as exc:
        refine_xy(_robot_side(p), p.T_cam_target, p.X_true, p.Y_true, RefineOptions(setup=setup))
    msg = str(exc.value)
    assert "X translation" in msg and "Y translation" in msg
    assert "X rotation" not in msg and "Y rotation" not in msg


def test_the_bound_of_a_degenerate_set_is_refused():
    p = make_problem(10, "eye_to_hand", np.random.default_rng(0), motion="one_axis")
    with pytest.raises(DegenerateMotionError, match="X translation"):
        cramer_rao_bound(p.T_base_ee, p.X_true, p.Y_true, (1e-3, 1e-3))


@pytest.mark.parametrize("robot_noise", ["none", "estimate"])
def test_reprojection_on_one_axis_views_is_refused(robot_noise):
    rng = np.random.default_rng(0)
    p = make_problem(12, "eye_to_hand", rng, motion="one_axis")
    ids, uv = zip(*(corners_in_image(T, INTR, 0.2, rng) for T in p.T_cam_target @ CENTRE))
    opts = ReprojectionOptions(robot_noise=robot_noise)
    with pytest.raises(DegenerateMotionError, match="X translation"):
        refine_reprojection(p.T_base_ee, list(ids), list(uv), SPEC, INTR, p.X_true, p.Y_true @ CENTRE, opts)


def test_the_null_direction_is_named_and_found_whatever_the_units():
    rng = np.random.default_rng(0)
    J = rng.normal(size=(40, 4)) * np.array([1e-6, 1.0, 1e3, 1.0])  # columns in very different units: all determined
    assert undetermined_directions(J).shape == (4, 0)
    covariance_from_jacobian(J)  # no refusal
    J[:, 3] = 1e6 * J[:, 0] + 1e-3 * J[:, 2]  # one free direction, (1e6, 0, 1e-3, -1) in the parameters' units
    V = undetermined_directions(J)
    assert V.shape == (4, 1)
    assert np.abs(J @ V[:, 0]).max() < EXACT
    assert abs(V[1, 0]) < EXACT
    with pytest.raises(DegenerateMotionError, match=r"1 direction of the estimate: a, c, d\b"):
        covariance_from_jacobian(J, names=["a", "b", "c", "d"])


def test_a_parameter_the_residuals_do_not_depend_on_is_named():
    J = np.random.default_rng(1).normal(size=(20, 3))
    J[:, 1] = 0.0
    with pytest.raises(DegenerateMotionError, match=r"estimate: scale\b"):
        covariance_from_jacobian(J, names=["w", "scale", "w"])
    V = undetermined_directions(J)
    assert V.shape == (3, 1) and abs(abs(V[1, 0]) - 1.0) < EXACT
    with pytest.raises(ValueError, match="2 names for 3 parameters"):
        covariance_from_jacobian(J, names=["w", "scale"])


def test_a_weak_but_determined_direction_is_kept_with_its_large_sigma():
    """A column ``d = 1e3 * RANK_TOLERANCE`` of the way from dependence is not refused: its sigma is about
    ``1 / (d sqrt(2))`` times the others' (4.7e4), asserted to a tenth of that."""
    rng = np.random.default_rng(2)
    J = rng.normal(size=(50, 3))
    d = 1e3 * RANK_TOLERANCE
    J[:, 2] = J[:, 0] + d * rng.normal(size=50)
    C = covariance_from_jacobian(J)
    assert np.sqrt(C[2, 2]) > 0.1 / (d * np.sqrt(2.0)) * np.sqrt(C[1, 1])


def test_asked_not_to_refuse_the_free_parameters_read_infinite():
    p = make_problem(10, "eye_to_hand", np.random.default_rng(0), camera_noise=CAMERA_NOISE, motion="one_axis")
    opts = RefineOptions(undetermined="infinite")
    C = refine_xy(p.T_base_ee, p.T_cam_target, p.X_true, p.Y_true, opts).covariance
    sigma = np.sqrt(np.diag(C))
    assert np.all(np.isinf(sigma[3:6])) and np.all(np.isinf(sigma[9:12]))  # the translations, X's and Y's
    assert np.all(np.isfinite(sigma[0:3])) and np.all(np.isfinite(sigma[6:9]))  # the rotations stay determined


def test_calibrate_with_the_checks_off_reports_an_infinite_sigma():
    p = make_problem(10, "eye_to_hand", np.random.default_rng(0), motion="one_axis")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", WeakMotionWarning)
        res = classic.calibrate(
            p.T_base_ee, p.T_cam_target, setup="eye_to_hand", options=classic.CalibrateOptions(check=False)
        )
    assert np.isinf(res.sigma["X_translation_mm"])
