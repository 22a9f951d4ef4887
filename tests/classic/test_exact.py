"""Noise-free synthetic data: every solver recovers the known truth to EXACT."""

from __future__ import annotations

import numpy as np
import pytest

import classic
from handeye.core.setups import robot_side_poses
from handeye.core.synthetic import make_problem
from tests.tolerances import ABSOLUTE_ONLY, DANIILIDIS_MAX_PAIR_ANGLE_DEG, EXACT

SETUPS = ["eye_to_hand", "eye_in_hand"]
MOTIONS = ["random", "structured"]
SEEDS = [0, 1, 2]
PAIRS = ["all", "consecutive"]
AXXB = ["tsai", "park", "horaud", "andreff", "daniilidis"]
AXYB = ["shah", "li"]


def _problem(setup, motion, seed, n=10):
    return make_problem(n, setup, np.random.default_rng(seed), motion=motion)


def _assert_pose_equal(T_est, T_true):
    assert T_est.shape == (4, 4)
    np.testing.assert_allclose(T_est, T_true, rtol=ABSOLUTE_ONLY, atol=EXACT)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("motion", MOTIONS)
@pytest.mark.parametrize("setup", SETUPS)
@pytest.mark.parametrize("pairs", PAIRS)
@pytest.mark.parametrize("solver", AXXB)
def test_axxb_solver_recovers_x(solver, pairs, setup, motion, seed):
    p = _problem(setup, motion, seed)
    A, B = classic.motion_pairs(p.T_base_ee, p.T_cam_target, setup, pairs)
    n = len(p.T_base_ee)
    assert len(A) == (n * (n - 1) // 2 if pairs == "all" else n - 1)
    # the motion pairs satisfy A X = X B with the true X: checks the pairing itself
    np.testing.assert_allclose(A @ p.X_true, p.X_true @ B, atol=EXACT)
    _assert_pose_equal(getattr(classic, solver)(A, B), p.X_true)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("motion", MOTIONS)
@pytest.mark.parametrize("setup", SETUPS)
@pytest.mark.parametrize("solver", AXYB)
def test_axyb_solver_recovers_x_and_y(solver, setup, motion, seed):
    p = _problem(setup, motion, seed)
    A = robot_side_poses(p.T_base_ee, setup)
    # A_i X' = Y' B_i with X' the target pose and Y' the camera pose
    target, camera = getattr(classic, solver)(A, p.T_cam_target)
    _assert_pose_equal(target, p.Y_true)
    _assert_pose_equal(camera, p.X_true)


@pytest.mark.parametrize("solver", AXXB)
def test_axxb_solver_needs_only_two_motions(solver):
    # two motions with non-parallel axes determine X
    p = _problem("eye_to_hand", "random", 3, n=3)
    A, B = classic.motion_pairs(p.T_base_ee, p.T_cam_target, "eye_to_hand", "consecutive")
    assert len(A) == 2
    _assert_pose_equal(getattr(classic, solver)(A, B), p.X_true)


@pytest.mark.parametrize("solver", AXYB)
def test_axyb_solver_with_three_poses(solver):
    p = _problem("eye_in_hand", "random", 3, n=3)
    target, camera = getattr(classic, solver)(robot_side_poses(p.T_base_ee, "eye_in_hand"), p.T_cam_target)
    _assert_pose_equal(target, p.Y_true)
    _assert_pose_equal(camera, p.X_true)


@pytest.mark.parametrize("solver", AXXB)
def test_axxb_solver_handles_large_motions(solver):
    # boards tilted up to 80 degrees: motions beyond 120 degrees, where the
    # matrix-to-quaternion branch and the quaternion sign matter
    from handeye.core.se3 import rotation_angle

    p = make_problem(12, "eye_to_hand", np.random.default_rng(11), max_tilt_deg=80.0)
    A, B = classic.motion_pairs(p.T_base_ee, p.T_cam_target, "eye_to_hand")
    assert np.degrees(rotation_angle(A[:, :3, :3])).max() > DANIILIDIS_MAX_PAIR_ANGLE_DEG
    _assert_pose_equal(getattr(classic, solver)(A, B), p.X_true)


@pytest.mark.parametrize("refine", [True, False], ids=["refine", "closed_form"])
@pytest.mark.parametrize("setup", SETUPS)
@pytest.mark.parametrize("method", list(classic.METHODS))
def test_calibrate_recovers_truth(method, setup, refine):
    p = _problem(setup, "random", 5, n=12)
    options = classic.CalibrateOptions(refine=refine)
    res = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup, method=method, options=options)
    _assert_pose_equal(res.X, p.X_true)
    _assert_pose_equal(res.Y, p.Y_true)
    assert res.setup == setup
    assert res.method.startswith(method) and res.method.endswith("+lm") == refine
    # frame names map to X and Y as documented in handeye.core.setups
    if setup == "eye_to_hand":
        assert res.T_base_cam is res.X and res.T_ee_target is res.Y
        with pytest.raises(AttributeError):
            _ = res.T_ee_cam
    else:
        assert res.T_ee_cam is res.X and res.T_base_target is res.Y
        with pytest.raises(AttributeError):
            _ = res.T_base_cam
    # noise free: residuals vanish
    assert res.residuals.rms_rotation_deg < np.degrees(EXACT)
    assert res.residuals.rms_translation_mm < 1000 * EXACT


@pytest.mark.parametrize("pairs", PAIRS)
@pytest.mark.parametrize("setup", SETUPS)
def test_calibrate_structured_motion_and_pairings(setup, pairs):
    p = _problem(setup, "structured", 1, n=16)
    res = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup, options=classic.CalibrateOptions(pairs=pairs))
    _assert_pose_equal(res.X, p.X_true)
    _assert_pose_equal(res.Y, p.Y_true)


def test_calibrate_result_to_dict_round_trips_the_poses():
    from handeye.core.se3 import transform_from_pos_quat_xyzw

    p = _problem("eye_in_hand", "random", 2, n=10)
    d = classic.calibrate(p.T_base_ee, p.T_cam_target, setup="eye_in_hand").to_dict()
    for name, T_true in (("T_ee_cam", p.X_true), ("T_base_target", p.Y_true)):
        entry = d[name]
        q = np.array(entry["quaternion_xyzw"])
        assert q[3] >= 0
        _assert_pose_equal(transform_from_pos_quat_xyzw(entry["translation_m"], q), T_true)
        _assert_pose_equal(np.array(entry["matrix"]), T_true)
    assert d["units"] == {"translation": "m", "quaternion": "xyzw"}


@pytest.mark.parametrize("setup", SETUPS)
def test_motion_pairs_follow_the_documented_definition(setup):
    # pair (i, j), i < j: eye-to-hand A = T_base_ee(j) T_base_ee(i)^-1,
    # eye-in-hand A = T_base_ee(j)^-1 T_base_ee(i) (OpenCV's Hg_ij); B = T_cam_target(j) T_cam_target(i)^-1
    from handeye.core.se3 import invert_transform

    p = _problem(setup, "random", 0, n=6)
    i, j = classic.pair_indices(6, "all")
    assert len(i) == 15 and np.all(i < j)
    assert len(set(zip(i.tolist(), j.tolist()))) == 15
    ic, jc = classic.pair_indices(6, "consecutive")
    np.testing.assert_array_equal(ic, np.arange(5))
    np.testing.assert_array_equal(jc, np.arange(1, 6))
    for pairs, (ii, jj) in (("all", (i, j)), ("consecutive", (ic, jc))):
        A, B = classic.motion_pairs(p.T_base_ee, p.T_cam_target, setup, pairs)
        T = p.T_base_ee
        if setup == "eye_to_hand":
            A_ref = T[jj] @ invert_transform(T[ii])
        else:
            A_ref = invert_transform(T[jj]) @ T[ii]
        np.testing.assert_allclose(A, A_ref, atol=EXACT)
        np.testing.assert_allclose(B, p.T_cam_target[jj] @ invert_transform(p.T_cam_target[ii]), atol=EXACT)
    with pytest.raises(ValueError):
        classic.pair_indices(6, "random")
