"""Motions that are half turns about a few axes: the rotations they cannot tell apart are found, the
translations choose between them, and a set whose translations cannot either is refused.

Before, a set of robot orientations a half turn apart about three perpendicular axes (a wrist flipped by
180 degrees between poses) calibrated 180 degrees and metres off with a rotation sigma of 0.04 deg.
"""

from __future__ import annotations

import numpy as np
import pytest

import classic
from classic.rotation_ambiguity import commuting_half_turns, half_turn, solve_translations
from classic.starts import resolve_half_turns
from handeye.core.errors import DegenerateMotionError
from handeye.core.metrics import rotation_error_deg, translation_error_mm
from handeye.core.synthetic import make_problem, random_rotations
from handeye.core.synthetic_half_turn import half_turn_problem
from tests.tolerances import EXACT, SIGMA_BOUND

SETUPS = ("eye_to_hand", "eye_in_hand")
CAMERA_NOISE = (0.1, 0.5)  # deg, mm per axis
ROBOT_NOISE = (0.05, 0.1)


def _klein(rng, n=12):
    """Rotations R0 E_i: E_i the identity or a half turn about x, y or z (pose i takes i mod 4)."""
    E = np.stack([np.eye(3), half_turn([1, 0, 0]), half_turn([0, 1, 0]), half_turn([0, 0, 1])])
    return random_rotations(rng, 1)[0] @ E[np.arange(n) % 4]


def test_three_perpendicular_half_turns_leave_three_axes():
    rng = np.random.default_rng(0)
    R = _klein(rng)
    axes = commuting_half_turns(R)
    assert len(axes) == 3
    # the axes are the lines R_i e_k, the same for every pose: each half turn about them commutes with every motion
    for c in axes:
        S = half_turn(c)
        for i in range(len(R)):
            M = R[i] @ R[0].T
            np.testing.assert_allclose(M @ S, S @ M, atol=EXACT)


def test_two_half_turn_axes_leave_their_common_normal():
    rng = np.random.default_rng(1)
    R0 = random_rotations(rng, 1)[0]
    a, b = np.array([1.0, 0, 0]), np.array([np.cos(1.0), np.sin(1.0), 0])
    R = R0 @ np.stack([np.eye(3), half_turn(a), half_turn(b)] * 3)
    axes = commuting_half_turns(R)
    assert len(axes) == 1
    assert abs(abs(axes[0] @ (R0 @ np.array([0, 0, 1.0]))) - 1) < 1e-9


@pytest.mark.parametrize("seed", range(5))
def test_ordinary_motions_leave_none(seed):
    p = make_problem(12, "eye_to_hand", np.random.default_rng(seed), camera_noise=CAMERA_NOISE)
    assert len(commuting_half_turns(p.T_cam_target[:, :3, :3])) == 0


@pytest.mark.parametrize("setup", SETUPS)
@pytest.mark.parametrize("seed", range(4))
def test_exact_half_turn_sets_calibrate_to_the_truth(setup, seed):
    """Orientations exactly a half turn apart about three perpendicular axes, realistic noise: within the
    noise of the truth (it was 180 deg off)."""
    rng = np.random.default_rng(seed)
    p = half_turn_problem(
        12, setup, rng, camera_noise=CAMERA_NOISE, robot_noise=ROBOT_NOISE, orientations="near", spread_deg=0.0
    )
    res = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup)
    s = res.sigma
    assert float(rotation_error_deg(res.X, p.X_true)) <= SIGMA_BOUND * s["X_rotation_deg"]
    assert float(translation_error_mm(res.X, p.X_true)) <= SIGMA_BOUND * s["X_translation_mm"]


def test_translations_that_cannot_tell_are_refused():
    """Targets at the camera's origin: the translations see no rotation of the camera, so the half-turn
    candidates fit equally and the start is refused, naming the axes."""
    rng = np.random.default_rng(3)
    p = half_turn_problem(12, "eye_to_hand", rng, orientations="near", spread_deg=0.0)
    B = p.T_cam_target.copy()
    B[:, :3, 3] = 0.0
    A = p.T_base_ee  # eye-to-hand: the robot side is T_base_ee
    X, Y = solve_translations(A, B, p.X_true[:3, :3])
    with pytest.raises(DegenerateMotionError, match="half turn about"):
        resolve_half_turns(A, B, X, Y)


def test_solve_translations_recovers_exact_poses():
    p = make_problem(10, "eye_to_hand", np.random.default_rng(4))
    X, Y = solve_translations(p.T_base_ee, p.T_cam_target, p.X_true[:3, :3])
    np.testing.assert_allclose(X, p.X_true, atol=EXACT)
    np.testing.assert_allclose(Y, p.Y_true, atol=EXACT)
