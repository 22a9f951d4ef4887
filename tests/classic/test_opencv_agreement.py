"""Noisy data: each closed form agrees with OpenCV's implementation of the same method.

On noisy data two *different* estimators disagree by a sizeable fraction of
the noise, so agreement to a tiny fraction of it (tests/tolerances.py) shows
the same algebra, the same pairing and the same frame conventions.

OpenCV mapping (its docs name frames the other way round: "gripper2base" is
the pose of the gripper in the base, our T_base_ee):

* eye-in-hand: R/t_gripper2base = T_base_ee, R/t_target2cam = T_cam_target,
  output cam2gripper = T_ee_cam.
* eye-to-hand: pass T_ee_base (base2gripper) in the gripper2base slot; the
  output is then T_base_cam.
* AX=YB: calibrateRobotWorldHandEye(R/t_world2cam = A, R/t_base2gripper = B)
  returns (base2world, gripper2cam) = our (X, Y) of classic.shah / classic.li
  with A = robot_side_poses(T_base_ee, setup), B = T_cam_target.
"""

from __future__ import annotations

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

import classic  # noqa: E402
from handeye.core.metrics import rotation_error_deg  # noqa: E402
from handeye.core.se3 import (  # noqa: E402
    hat,
    invert_transform,
    make_transform,
    quat_xyzw_from_matrix,
    rotation_angle,
)
from handeye.core.setups import robot_side_poses  # noqa: E402
from handeye.core.synthetic import make_problem  # noqa: E402
from tests.tolerances import (  # noqa: E402
    DANIILIDIS_MAX_PAIR_ANGLE_DEG,
    DEG,
    MM,
    SAME_ALGORITHM_FRACTION,
    TSAI_OPENCV_FRACTION,
    TSAI_RESIDUAL_RTOL,
)

CAMERA_NOISE = (0.5, 5.0)  # deg, mm (per axis)
ROBOT_NOISE = (0.01, 0.2)
SIGMA_ROT = CAMERA_NOISE[0] * DEG  # rad
SIGMA_TRANS = CAMERA_NOISE[1] * MM  # m
N_POSES = 20  # see TSAI_OPENCV_FRACTION for why 20
SEEDS = [0, 1, 2, 3]
SETUPS = ["eye_to_hand", "eye_in_hand"]

AXXB_FLAGS = {
    "tsai": cv2.CALIB_HAND_EYE_TSAI,
    "park": cv2.CALIB_HAND_EYE_PARK,
    "horaud": cv2.CALIB_HAND_EYE_HORAUD,
    "andreff": cv2.CALIB_HAND_EYE_ANDREFF,
    "daniilidis": cv2.CALIB_HAND_EYE_DANIILIDIS,
}
AXYB_FLAGS = {"shah": cv2.CALIB_ROBOT_WORLD_HAND_EYE_SHAH, "li": cv2.CALIB_ROBOT_WORLD_HAND_EYE_LI}


def _problem(setup, seed):
    return make_problem(N_POSES, setup, np.random.default_rng(seed), camera_noise=CAMERA_NOISE, robot_noise=ROBOT_NOISE)


def _split(T):
    return [np.ascontiguousarray(R) for R in T[:, :3, :3]], [np.ascontiguousarray(t.reshape(3, 1)) for t in T[:, :3, 3]]


def _opencv_hand_eye(p, flag):
    gripper2base = p.T_base_ee if p.setup == "eye_in_hand" else invert_transform(p.T_base_ee)
    R_g, t_g = _split(gripper2base)
    R_c, t_c = _split(p.T_cam_target)
    R, t = cv2.calibrateHandEye(R_g, t_g, R_c, t_c, method=flag)
    return make_transform(R, t.ravel())


def _differences(T_ours, T_cv):
    """Rotation difference (rad) and translation difference (m)."""
    return np.radians(rotation_error_deg(T_ours, T_cv)), np.linalg.norm(T_ours[:3, 3] - T_cv[:3, 3])


def _assert_agree(T_ours, T_cv, fraction):
    d_rot, d_trans = _differences(T_ours, T_cv)
    assert d_rot <= fraction * SIGMA_ROT, f"rotation differs by {d_rot / SIGMA_ROT:.2e} sigma"
    assert d_trans <= fraction * SIGMA_TRANS, f"translation differs by {d_trans / SIGMA_TRANS:.2e} sigma"


def test_different_methods_do_disagree_on_this_data():
    # the control that gives the tolerances their meaning: two different
    # estimators on the same noisy data differ by far more than the
    # same-algorithm tolerance
    p = _problem("eye_to_hand", 0)
    A, B = classic.motion_pairs(p.T_base_ee, p.T_cam_target, p.setup)
    d_rot, d_trans = _differences(classic.park(A, B), classic.andreff(A, B, translation="joint"))
    assert d_rot > 100 * SAME_ALGORITHM_FRACTION * SIGMA_ROT
    assert d_trans > 100 * SAME_ALGORITHM_FRACTION * SIGMA_TRANS


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("setup", SETUPS)
@pytest.mark.parametrize("method", ["park", "horaud", "andreff", "daniilidis"])
def test_axxb_matches_opencv(method, setup, seed):
    p = _problem(setup, seed)
    A, B = classic.motion_pairs(p.T_base_ee, p.T_cam_target, setup, "all")
    if method == "daniilidis":
        # OpenCV's quaternion signs equal ours only below 120 degrees (see the docstring of classic.daniilidis)
        for M in (A, B):
            assert np.degrees(rotation_angle(M[:, :3, :3])).max() < DANIILIDIS_MAX_PAIR_ANGLE_DEG
    # OpenCV's Andreff keeps the joint solve's translation; ours solves it again by default
    kwargs = {"translation": "joint"} if method == "andreff" else {}
    _assert_agree(
        getattr(classic, method)(A, B, **kwargs), _opencv_hand_eye(p, AXXB_FLAGS[method]), SAME_ALGORITHM_FRACTION
    )


def _tsai_eq12_residual(A, B, R_X):
    """|| skew(P_A + P_B) x - (P_B - P_A) || with P = 2 q_vec (w >= 0), x = P_X / sqrt(4 - |P_X|^2)."""
    P_A = 2.0 * quat_xyzw_from_matrix(A[:, :3, :3])[:, :3]
    P_B = 2.0 * quat_xyzw_from_matrix(B[:, :3, :3])[:, :3]
    P_X = 2.0 * quat_xyzw_from_matrix(R_X)[:3]
    x = P_X / np.sqrt(4.0 - P_X @ P_X)
    return float(np.linalg.norm((hat(P_A + P_B) @ x - (P_B - P_A)).ravel()))


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("setup", SETUPS)
def test_tsai_matches_opencv_within_its_known_difference(setup, seed):
    p = _problem(setup, seed)
    A, B = classic.motion_pairs(p.T_base_ee, p.T_cam_target, setup, "all")
    X = classic.tsai(A, B)
    X_cv = _opencv_hand_eye(p, AXXB_FLAGS["tsai"])
    # (a) ours is the least-squares minimiser of eq. 12 over all pairs: never a larger residual
    ours, theirs = _tsai_eq12_residual(A, B, X[:3, :3]), _tsai_eq12_residual(A, B, X_cv[:3, :3])
    assert ours <= theirs * (1.0 + TSAI_RESIDUAL_RTOL)
    # (b) and the two estimates are close on the scale of the noise
    _assert_agree(X, X_cv, TSAI_OPENCV_FRACTION)


def test_tsai_residual_is_minimal_among_nearby_rotations():
    # (a) above is only meaningful if our residual is the minimum: perturbing
    # our rotation in any direction must increase it
    from handeye.core.se3 import so3_exp

    p = _problem("eye_in_hand", 0)
    A, B = classic.motion_pairs(p.T_base_ee, p.T_cam_target, p.setup, "all")
    R = classic.tsai(A, B)[:3, :3]
    best = _tsai_eq12_residual(A, B, R)
    for axis in np.eye(3):
        for sign in (-1.0, 1.0):
            assert _tsai_eq12_residual(A, B, so3_exp(sign * 1e-4 * axis) @ R) > best


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("setup", SETUPS)
@pytest.mark.parametrize("method", ["shah", "li"])
def test_axyb_matches_opencv(method, setup, seed):
    p = _problem(setup, seed)
    A = robot_side_poses(p.T_base_ee, setup)
    X, Y = getattr(classic, method)(A, p.T_cam_target)
    R_A, t_A = _split(A)
    R_B, t_B = _split(p.T_cam_target)
    R_x, t_x, R_y, t_y = cv2.calibrateRobotWorldHandEye(R_A, t_A, R_B, t_B, method=AXYB_FLAGS[method])
    _assert_agree(X, make_transform(R_x, t_x.ravel()), SAME_ALGORITHM_FRACTION)
    _assert_agree(Y, make_transform(R_y, t_y.ravel()), SAME_ALGORITHM_FRACTION)


@pytest.mark.parametrize("setup", SETUPS)
@pytest.mark.parametrize("method", ["park", "shah"])
def test_calibrate_closed_form_is_the_opencv_estimate(method, setup):
    # the front without refinement returns the plain closed form: the same
    # camera pose as OpenCV, whatever the setup
    p = _problem(setup, 0)
    options = classic.CalibrateOptions(refine=False)
    res = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup, method=method, options=options)
    if method == "park":
        X_cv = _opencv_hand_eye(p, AXXB_FLAGS["park"])
    else:
        A = robot_side_poses(p.T_base_ee, setup)
        R_A, t_A = _split(A)
        R_B, t_B = _split(p.T_cam_target)
        _, _, R_y, t_y = cv2.calibrateRobotWorldHandEye(R_A, t_A, R_B, t_B, method=AXYB_FLAGS["shah"])
        X_cv = make_transform(R_y, t_y.ravel())
    _assert_agree(res.X, X_cv, SAME_ALGORITHM_FRACTION)
