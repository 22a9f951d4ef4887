"""Motion sets that cannot determine X are refused; weak ones warn; the diagnostics say why."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import classic
from classic.diagnostics import THRESHOLDS
from handeye.core.errors import DegenerateMotionError, WeakMotionWarning
from handeye.core.se3 import (
    invert_transform,
    make_transform,
    quat_xyzw_from_matrix,
    so3_exp,
    so3_log,
)
from handeye.core.synthetic import make_problem, random_rotations
from tests.tolerances import EXACT, GRAM_FLOOR

SETUPS = ["eye_to_hand", "eye_in_hand"]
FRAME = {"eye_to_hand": "base", "eye_in_hand": "end-effector"}
MOTION_KEYS = {
    "n_poses",
    "n_motions",
    "max_rotation_deg",
    "axis_singular_values",
    "axis_diversity",
    "dominant_axis",
    "translation_condition",
    "angle_mismatch_deg",
    "warnings",
}


def _from_target_rotations(rotvecs, setup, rng):
    """A noise-free problem whose camera sees the board at the given orientations (rotation vectors)."""
    n = len(rotvecs)
    t = np.column_stack([rng.uniform(-0.1, 0.1, (n, 2)), rng.uniform(0.4, 0.9, n)])
    B = make_transform(so3_exp(rotvecs), t)
    X = make_transform(random_rotations(rng, 1)[0], rng.uniform(-0.5, 0.5, 3))
    Y = make_transform(random_rotations(rng, 1)[0], rng.uniform(-0.5, 0.5, 3))
    # A_i Y = X B_i with A = T_base_ee (eye-to-hand) or T_ee_base (eye-in-hand)
    A = X @ B @ invert_transform(Y)
    T_base_ee = A if setup == "eye_to_hand" else invert_transform(A)
    return T_base_ee, B, X, Y


# ---------------------------------------------------------------- refused


@pytest.mark.parametrize("pairs", ["all", "consecutive"])
@pytest.mark.parametrize("setup", SETUPS)
def test_rotation_about_one_axis_is_refused(setup, pairs):
    p = make_problem(10, setup, np.random.default_rng(0), motion="one_axis")
    with pytest.raises(DegenerateMotionError) as exc:
        classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup, options=classic.CalibrateOptions(pairs=pairs))
    msg = str(exc.value)
    assert "one axis" in msg
    assert "second axis" in msg  # says what motion is missing
    assert f"{FRAME[setup]} frame" in msg


@pytest.mark.parametrize("setup", SETUPS)
def test_one_axis_message_names_the_right_axis(setup):
    p = make_problem(10, setup, np.random.default_rng(0), motion="one_axis")
    with pytest.warns(WeakMotionWarning, match="nearly parallel"):
        diag = classic.diagnose_motion(p.T_base_ee, p.T_cam_target, setup, raise_on_degenerate=False)
    # the camera turns about one axis n_B (in the camera frame); the robot then
    # turns about R_X n_B in the frame X is expressed in (base or flange)
    B01 = p.T_cam_target[1] @ invert_transform(p.T_cam_target[0])
    n_B = so3_log(B01[:3, :3])
    n_A = p.X_true[:3, :3] @ (n_B / np.linalg.norm(n_B))
    assert abs(abs(np.dot(diag.dominant_axis, n_A)) - 1.0) < EXACT
    assert diag.axis_diversity < GRAM_FLOOR
    axis_text = "[" + ", ".join(f"{v:.2f}" for v in diag.dominant_axis) + "]"
    with pytest.raises(DegenerateMotionError, match=axis_text.replace("[", r"\[").replace("]", r"\]")):
        classic.diagnose_motion(p.T_base_ee, p.T_cam_target, setup)


@pytest.mark.parametrize("setup", SETUPS)
def test_translation_only_is_refused(setup):
    p = make_problem(10, setup, np.random.default_rng(0), motion="translation_only")
    with pytest.raises(DegenerateMotionError) as exc:
        classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup)
    msg = str(exc.value)
    assert "barely rotates" in msg
    assert "Rotate the end-effector" in msg and "two different axes" in msg  # says what motion is missing


@pytest.mark.parametrize("method", list(classic.METHODS))
def test_every_method_refuses_degenerate_motion(method):
    p = make_problem(10, "eye_in_hand", np.random.default_rng(1), motion="one_axis")
    with pytest.raises(DegenerateMotionError):
        classic.calibrate(p.T_base_ee, p.T_cam_target, setup="eye_in_hand", method=method)


def test_check_off_does_not_refuse_but_still_reports():
    p = make_problem(10, "eye_to_hand", np.random.default_rng(0), motion="one_axis")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", WeakMotionWarning)
        res = classic.calibrate(
            p.T_base_ee, p.T_cam_target, setup="eye_to_hand", options=classic.CalibrateOptions(check=False)
        )
    assert res.diagnostics["motion"]["axis_diversity"] < GRAM_FLOOR


# ---------------------------------------------------------------- warned


@pytest.mark.parametrize("setup", SETUPS)
def test_few_poses_warn(setup):
    p = make_problem(4, setup, np.random.default_rng(0))
    with pytest.warns(WeakMotionWarning, match="only 4 poses") as record:
        res = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup)
    # the warning points at the caller's line, not inside the library
    assert any(w.filename == __file__ for w in record)
    assert "only 4 poses" in " ".join(res.diagnostics["motion"]["warnings"])
    # weak, not wrong: noise-free data still give the truth
    np.testing.assert_allclose(res.X, p.X_true, atol=EXACT)


@pytest.mark.parametrize("setup", SETUPS)
def test_small_rotations_warn(setup):
    rng = np.random.default_rng(3)
    n = 10
    axes = rng.normal(size=(n, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    rotvecs = axes * np.radians(rng.uniform(1.0, 4.0, n))[:, None]  # motions of at most 8 degrees
    T_base_ee, T_cam_target, X, Y = _from_target_rotations(rotvecs, setup, rng)
    with pytest.warns(WeakMotionWarning, match="small rotations"):
        res = classic.calibrate(T_base_ee, T_cam_target, setup=setup)
    motion = res.diagnostics["motion"]
    assert THRESHOLDS["max_rotation_error_deg"] < motion["max_rotation_deg"] < THRESHOLDS["max_rotation_warn_deg"]
    np.testing.assert_allclose(res.X, X, atol=EXACT)
    np.testing.assert_allclose(res.Y, Y, atol=EXACT)


@pytest.mark.parametrize("setup", SETUPS)
def test_nearly_parallel_axes_warn(setup):
    rng = np.random.default_rng(4)
    n = 10
    theta = np.radians(np.linspace(-40.0, 40.0, n))
    # mostly about the camera's z axis, with a small tilt about x (about 6 % of the largest turn)
    rotvecs = np.column_stack([0.06 * np.abs(theta).max() * rng.choice([-1.0, 1.0], n), np.zeros(n), theta])
    T_base_ee, T_cam_target, X, _ = _from_target_rotations(rotvecs, setup, rng)
    with pytest.warns(WeakMotionWarning, match="nearly parallel"):
        res = classic.calibrate(T_base_ee, T_cam_target, setup=setup)
    motion = res.diagnostics["motion"]
    assert THRESHOLDS["axis_diversity_error"] <= motion["axis_diversity"] < THRESHOLDS["axis_diversity_warn"]
    np.testing.assert_allclose(res.X, X, atol=EXACT)


@pytest.mark.filterwarnings("error::handeye.core.errors.WeakMotionWarning")
@pytest.mark.parametrize("setup", SETUPS)
def test_good_motion_does_not_warn(setup):
    p = make_problem(12, setup, np.random.default_rng(0))
    res = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup)
    assert res.diagnostics["motion"]["warnings"] == []


# ---------------------------------------------------------------- the diagnostics themselves


@pytest.mark.parametrize("pairs", ["all", "consecutive"])
@pytest.mark.parametrize("setup", SETUPS)
def test_motion_diagnostics_fields(setup, pairs):
    n = 12
    p = make_problem(n, setup, np.random.default_rng(2))
    res = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup, options=classic.CalibrateOptions(pairs=pairs))
    motion = res.diagnostics["motion"]
    assert MOTION_KEYS <= set(motion)
    assert motion["n_poses"] == n
    assert motion["n_motions"] == (n * (n - 1) // 2 if pairs == "all" else n - 1)
    s = np.array(motion["axis_singular_values"])
    assert s.shape == (3,) and np.all(np.diff(s) <= 0) and s[-1] >= 0
    assert motion["axis_diversity"] == pytest.approx(s[1] / s[0])
    assert np.linalg.norm(motion["dominant_axis"]) == pytest.approx(1.0)
    assert motion["translation_condition"] >= 1.0
    assert motion["angle_mismatch_deg"] < EXACT  # noise free
    # the largest robot rotation, recomputed independently
    A, _ = classic.motion_pairs(p.T_base_ee, p.T_cam_target, setup, pairs)
    q = quat_xyzw_from_matrix(A[:, :3, :3])
    expected = np.degrees(2.0 * np.arctan2(np.linalg.norm(q[:, :3], axis=1), q[:, 3])).max()
    assert motion["max_rotation_deg"] == pytest.approx(expected, abs=EXACT)
    # and the dictionary is JSON-serialisable, as a report needs
    import json

    json.dumps(res.diagnostics)
