"""calibrate's refits on a subset of the poses (the outlier test's, the pair consensus check's) where the subset
leaves a direction free that the whole set fixes.

The data: robot motions about one axis (``make_problem(..., motion="one_axis")``: the translation along it is free)
and a few poses turned about other axes, which alone fix it. Gross errors on those few: the poses that would be
checked are the only ones that fix the direction, so nothing can check them and the answer is refused naming the
free direction, never returned with a sigma read as 0 along it. Clean, they are answered, even where least-median
sampling (which fits triples of poses, most of them turning about the one axis) sets them aside. The checks after
the outlier test left poses out fit the poses left, and name a pose by its own number.
"""

from __future__ import annotations

import re
import sys
import warnings

import numpy as np
import pytest

import classic
from classic.noise_model import NoiseModel
from classic.ransac import lmeds_inliers
from handeye.core.errors import ContaminatedPosesError, DegenerateMotionError, SuspectPosesWarning
from handeye.core.metrics import pose_error
from handeye.core.se3 import invert_transform, so3_exp, so3_log
from handeye.core.synthetic import make_problem
from tests.tolerances import PRINTED_THREE_DECIMALS_UNIT_VECTOR, SIGMA_BOUND

#: The camera's pose noise (deg, mm per axis); the robot poses are exact, so the one-axis motions stay exactly so.
CAMERA_NOISE = (0.05, 0.5)


def _one_axis_and_others(n_other: int, seed: int, shift_m: float = 0.0, turn_deg: float = 0.0):
    """12 eye-to-hand poses turning about one axis, then ``n_other`` turned 30, 40, ... degrees about other axes
    (exact camera poses), their camera poses moved by ``shift_m`` and turned by ``turn_deg``. Returns
    ``T_base_ee, T_cam_target, X, Y, axis`` (the one axis, base frame)."""
    p = make_problem(12, "eye_to_hand", np.random.default_rng(seed), camera_noise=CAMERA_NOISE, motion="one_axis")
    axes = (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    other = np.repeat(p.T_cam_target[:1], n_other, axis=0)
    for k in range(n_other):
        other[k, :3, :3] = other[k, :3, :3] @ so3_exp(np.radians(30.0 + 10.0 * k) * axes[k % 2])
    T_base_ee = np.concatenate([p.T_base_ee, p.X_true @ other @ invert_transform(p.Y_true)])
    bad = other.copy()
    bad[:, :3, 3] += [shift_m, 0.0, 0.0]
    bad[:, :3, :3] = so3_exp(np.radians(turn_deg) * np.array([0.0, 0.0, 1.0])) @ bad[:, :3, :3]
    w = so3_log(p.T_base_ee[-1, :3, :3] @ p.T_base_ee[0, :3, :3].T)
    return T_base_ee, np.concatenate([p.T_cam_target, bad]), p.X_true, p.Y_true, w / np.linalg.norm(w)


def _calibrate(T_base_ee, T_cam_target):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # weak motion, suspect poses: what is returned or raised is the test
        return classic.calibrate(T_base_ee, T_cam_target, setup="eye_to_hand")


def _assert_recovers(res, X):
    err_deg, err_mm = pose_error(res.T_base_cam, X)
    assert err_deg < SIGMA_BOUND * res.sigma["X_rotation_deg"], (err_deg, res.sigma)
    assert err_mm < SIGMA_BOUND * res.sigma["X_translation_mm"], (err_mm, res.sigma)


def _assert_names_the_axis(message: str, axis: np.ndarray):
    found = re.search(r"X translation along \[([-+0-9., ]+)\]", message)
    assert found, message
    printed = np.array([float(c) for c in found.group(1).split(",")])
    assert min(np.linalg.norm(printed - axis), np.linalg.norm(printed + axis)) < PRINTED_THREE_DECIMALS_UNIT_VECTOR


@pytest.mark.parametrize("n_other", [1, 2, 3])
@pytest.mark.parametrize("shift_m, turn_deg", [(0.2, 20.0), (0.0, 10.0)])
def test_gross_errors_on_the_only_poses_turning_about_other_axes_are_refused_naming_the_free_direction(
    n_other, shift_m, turn_deg
):
    T_base_ee, T_cam_target, X, _, axis = _one_axis_and_others(n_other, 0)
    _assert_recovers(_calibrate(T_base_ee, T_cam_target), X)  # the whole set, clean: determined, answered
    T_base_ee, T_cam_target, X, _, axis = _one_axis_and_others(n_other, 0, shift_m, turn_deg)
    with pytest.raises(DegenerateMotionError) as refused:
        _calibrate(T_base_ee, T_cam_target)
    message = str(refused.value)
    _assert_names_the_axis(message, axis)
    assert message.startswith("Without ") and "nothing checks" in message, message


def test_the_pair_consensus_check_names_the_poses_the_rest_cannot_check_by_their_own_numbers():
    """Seed 10, the three poses moved 5 cm: the outlier test leaves pose 13 out (warned), the pair consensus check
    suspects the other two, 12 and 14 (12 and 13 among the 14 poses left: the old message's numbers), and
    without them the translation along the axis is free."""
    T_base_ee, T_cam_target, _, _, axis = _one_axis_and_others(3, 10, shift_m=0.05)
    with pytest.raises(DegenerateMotionError, match=r"^Without poses 12, 14, suspected by the pair consensus") as no:
        with pytest.warns(SuspectPosesWarning, match=r"pose 13: .* returned the fit without it"):
            classic.calibrate(T_base_ee, T_cam_target, setup="eye_to_hand")
    _assert_names_the_axis(str(no.value), axis)


def test_a_clean_set_whose_sampling_sets_aside_the_other_axes_is_answered():
    """Seed 17: least-median sampling's best triple turns about the one axis, so the two clean poses that fix the
    translation along it look like outliers to it (checked here); the outlier test then starts from all poses."""
    T_base_ee, T_cam_target, X, _, _ = _one_axis_and_others(2, 17)
    found = lmeds_inliers(T_base_ee, T_cam_target, np.random.default_rng(0))
    assert np.flatnonzero(~found.inliers).tolist() == [12, 13]
    _assert_recovers(_calibrate(T_base_ee, T_cam_target), X)


def test_a_pose_refused_after_the_screen_left_one_out_is_named_by_its_own_number():
    """Seed 3, the two other-axis poses moved 5 cm: the outlier test leaves pose 12 out (warned), then the
    contamination check refuses pose 13, which it named 12 among the 13 poses left."""
    T_base_ee, T_cam_target, _, _, _ = _one_axis_and_others(2, 3, shift_m=0.05)
    with pytest.raises(ContaminatedPosesError, match=r"^1 of 13 poses fitted disagree .*: pose 13 \("):
        with pytest.warns(SuspectPosesWarning, match=r"pose 12: .* returned the fit without it"):
            classic.calibrate(T_base_ee, T_cam_target, setup="eye_to_hand")


def test_the_pair_consensus_refit_takes_the_callers_per_pose_noise_of_the_poses_left(monkeypatch):
    """A per-pose noise model holds every pose; after the outlier test leaves one out the consensus check's refit
    takes the model of the poses left (the full model cut by the inliers' mask raised IndexError)."""
    rng = np.random.default_rng(0)
    p = make_problem(15, "eye_to_hand", rng, camera_noise=CAMERA_NOISE)
    B = p.T_cam_target.copy()
    B[4, :3, 3] += [0.004, -0.003, 0.002]  # 5.4 mm: left out, not gross
    C = np.tile(np.diag([np.radians(CAMERA_NOISE[0]) ** 2] * 3 + [(CAMERA_NOISE[1] * 1e-3) ** 2] * 3), (15, 1, 1))
    front = sys.modules["classic.calibrate"]
    monkeypatch.setattr(front, "pair_consensus_suspects", lambda *args: np.array([0]))  # a suspect, to refit
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SuspectPosesWarning)
        res = classic.calibrate(p.T_base_ee, B, noise=NoiseModel(camera_covariance=C))
    assert res.diagnostics["outlier_test"]["action"] == "left out" and res.diagnostics["outliers"] == [4]
    _assert_recovers(res, p.X_true)
