"""Bad input is refused with a named ValueError subclass that says what and where.

Each error is triggered twice: by the validation function itself and through
classic.calibrate, on otherwise valid data from handeye.core.synthetic.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import classic
from handeye.core import errors, validation
from handeye.core.errors import (
    DegenerateMotionError,
    DuplicatePoseError,
    HandEyeInputError,
    InconsistentPosesError,
    LengthMismatchError,
    MissingDependencyError,
    NonFiniteError,
    NotARotationError,
    ShapeError,
    TooFewPosesError,
    UnitsError,
)
from handeye.core.optional import require_package
from handeye.core.se3 import invert_transform, make_transform, so3_exp, so3_log
from handeye.core.synthetic import make_problem
from tests.tolerances import EXACT

SETUPS = ["eye_to_hand", "eye_in_hand"]
BAD_INDEX = 4  # the pose we corrupt; messages must name it


@pytest.fixture(params=SETUPS)
def problem(request):
    return make_problem(10, request.param, np.random.default_rng(7))


def _calibrate(problem, T_base_ee=None, T_cam_target=None, **kw):
    return classic.calibrate(
        problem.T_base_ee if T_base_ee is None else T_base_ee,
        problem.T_cam_target if T_cam_target is None else T_cam_target,
        setup=problem.setup,
        **kw,
    )


def _names_index(message: str, index: int) -> bool:
    return re.search(rf"(?<![\d.]){index}(?![\d.])", message) is not None


# ---------------------------------------------------------------- the hierarchy


def test_every_input_error_is_a_value_error():
    input_errors = [
        obj
        for obj in vars(errors).values()
        if isinstance(obj, type)
        and issubclass(obj, Exception)
        and obj.__module__ == errors.__name__
        and not issubclass(obj, (Warning, ImportError))
    ]
    assert len(input_errors) >= 12
    for cls in input_errors:
        assert issubclass(cls, HandEyeInputError), cls
        assert issubclass(cls, ValueError), cls
    assert issubclass(MissingDependencyError, ImportError)
    assert issubclass(errors.WeakMotionWarning, UserWarning)


# ---------------------------------------------------------------- NaN / infinity


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_is_refused(problem, bad):
    T = problem.T_cam_target.copy()
    T[BAD_INDEX, 1, 3] = bad
    with pytest.raises(NonFiniteError) as exc:
        validation.check_transforms(T, "T_cam_target")
    assert _names_index(str(exc.value), BAD_INDEX) and "T_cam_target" in str(exc.value)
    with pytest.raises(NonFiniteError) as exc:
        _calibrate(problem, T_cam_target=T)
    assert _names_index(str(exc.value), BAD_INDEX)


def test_non_finite_robot_pose_is_refused(problem):
    T = problem.T_base_ee.copy()
    T[BAD_INDEX, 0, 0] = np.nan
    with pytest.raises(NonFiniteError, match="T_base_ee") as exc:
        _calibrate(problem, T_base_ee=T)
    assert _names_index(str(exc.value), BAD_INDEX)


# ---------------------------------------------------------------- rotations


def test_non_orthonormal_rotation_is_refused(problem):
    T = problem.T_base_ee.copy()
    T[BAD_INDEX, :3, :3] *= 1.01  # scaled: not orthonormal
    with pytest.raises(NotARotationError) as exc:
        validation.check_transforms(T, "T_base_ee")
    msg = str(exc.value)
    assert f"T_base_ee[{BAD_INDEX}]" in msg and "orthonormal" in msg
    assert "project_to_so3" in msg  # says how to fix rounded rotations
    with pytest.raises(NotARotationError, match=re.escape(f"T_base_ee[{BAD_INDEX}]")):
        _calibrate(problem, T_base_ee=T)


def test_reflection_is_refused(problem):
    T = problem.T_cam_target.copy()
    T[BAD_INDEX, :3, 2] *= -1.0  # orthonormal but det = -1
    assert np.isclose(np.linalg.det(T[BAD_INDEX, :3, :3]), -1.0)
    with pytest.raises(NotARotationError, match="reflection") as exc:
        validation.check_transforms(T, "T_cam_target")
    assert f"T_cam_target[{BAD_INDEX}]" in str(exc.value)
    with pytest.raises(NotARotationError, match="reflection"):
        _calibrate(problem, T_cam_target=T)


def test_rounded_rotations_within_tolerance_are_accepted(problem):
    T = problem.T_base_ee.copy()
    T[:, :3, :3] = np.round(T[:, :3, :3], 9)  # rounding error ~1e-9 < ROTATION_TOLERANCE
    out = validation.check_transforms(T, "T_base_ee")
    assert out.shape == T.shape and out.dtype == np.float64


# ---------------------------------------------------------------- shapes


@pytest.mark.parametrize(
    "make_bad",
    [
        lambda T: T[:, :3, :],  # (N, 3, 4): bottom row dropped
        lambda T: T[:, :3, :3],  # rotations only
        lambda T: T.reshape(len(T), 16),  # flattened
        lambda T: T[None],  # one dimension too many
        lambda T: T[0, 0],  # a vector
    ],
    ids=["N34", "N33", "N16", "1N44", "vector"],
)
def test_wrong_shape_is_refused(problem, make_bad):
    bad = make_bad(problem.T_cam_target)
    with pytest.raises(ShapeError, match="T_cam_target"):
        validation.check_transforms(bad, "T_cam_target")
    with pytest.raises(ShapeError):
        _calibrate(problem, T_cam_target=bad)


def test_non_numeric_input_is_a_shape_error():
    with pytest.raises(ShapeError):
        validation.check_transforms([["a"] * 4] * 4, "T")


def test_non_homogeneous_last_row_is_refused(problem):
    T = problem.T_base_ee.copy()
    T[BAD_INDEX, 3, :] = [0.0, 0.0, 0.0, 2.0]
    with pytest.raises(ShapeError, match=re.escape("[0, 0, 0, 1]")) as exc:
        validation.check_transforms(T, "T_base_ee")
    assert _names_index(str(exc.value), BAD_INDEX)


def test_single_4x4_is_promoted_to_a_batch(problem):
    out = validation.check_transforms(problem.T_base_ee[0], "T")
    assert out.shape == (1, 4, 4)
    np.testing.assert_array_equal(out[0], problem.T_base_ee[0])


# ---------------------------------------------------------------- counts


def test_mismatched_lengths_are_refused(problem):
    with pytest.raises(LengthMismatchError) as exc:
        validation.check_paired(problem.T_base_ee, problem.T_cam_target[:-1], ("T_base_ee", "T_cam_target"))
    n = len(problem.T_base_ee)
    assert f"{n} poses" in str(exc.value) and f"{n - 1}" in str(exc.value)
    with pytest.raises(LengthMismatchError):
        _calibrate(problem, T_cam_target=problem.T_cam_target[:-1])


@pytest.mark.parametrize("n", [1, 2])
def test_too_few_poses_are_refused(problem, n):
    with pytest.raises(TooFewPosesError, match=str(n)):
        validation.check_paired(problem.T_base_ee[:n], problem.T_cam_target[:n], ("a", "b"))
    with pytest.raises(TooFewPosesError):
        _calibrate(problem, T_base_ee=problem.T_base_ee[:n], T_cam_target=problem.T_cam_target[:n])


@pytest.mark.parametrize("solver", ["tsai", "park", "horaud", "andreff", "daniilidis"])
def test_plain_solvers_validate_their_input(problem, solver):
    A, B = classic.motion_pairs(problem.T_base_ee, problem.T_cam_target, problem.setup)
    fn = getattr(classic, solver)
    with pytest.raises(LengthMismatchError):
        fn(A, B[:-1])
    with pytest.raises(TooFewPosesError):
        fn(A[:1], B[:1])
    B_bad = B.copy()
    B_bad[2, 0, 0] = np.nan
    with pytest.raises(NonFiniteError):
        fn(A, B_bad)


@pytest.mark.parametrize("solver", ["shah", "li"])
def test_axyb_solvers_need_three_poses(problem, solver):
    with pytest.raises(TooFewPosesError):
        getattr(classic, solver)(problem.T_base_ee[:2], problem.T_cam_target[:2])


# ---------------------------------------------------------------- duplicates


def test_duplicated_pose_is_refused(problem):
    T_ee, T_ct = problem.T_base_ee.copy(), problem.T_cam_target.copy()
    T_ee[7], T_ct[7] = T_ee[2], T_ct[2]
    with pytest.raises(DuplicatePoseError, match="poses 2 and 7"):
        validation.check_no_duplicates(T_ee, T_ct, ("T_base_ee", "T_cam_target"))
    with pytest.raises(DuplicatePoseError, match="poses 2 and 7"):
        _calibrate(problem, T_base_ee=T_ee, T_cam_target=T_ct)


def test_same_robot_pose_with_different_camera_pose_is_not_a_duplicate(problem):
    # only a pair repeated on *both* sides is a bookkeeping error
    T_ee = problem.T_base_ee.copy()
    T_ee[7] = T_ee[2]
    validation.check_no_duplicates(T_ee, problem.T_cam_target, ("T_base_ee", "T_cam_target"))


# ---------------------------------------------------------------- units


@pytest.mark.parametrize("which", ["T_base_ee", "T_cam_target"])
def test_millimetre_translations_are_refused(problem, which):
    T_ee, T_ct = problem.T_base_ee.copy(), problem.T_cam_target.copy()
    T = T_ee if which == "T_base_ee" else T_ct
    T[:, :3, 3] *= 1000.0
    with pytest.raises(UnitsError) as exc:
        validation.check_units_metres(T, which)
    msg = str(exc.value)
    assert which in msg and "millimetres" in msg and "1000" in msg
    i = int(np.argmax(np.linalg.norm(T[:, :3, 3], axis=1)))
    assert f"{which}[{i}]" in msg  # names the worst pose
    with pytest.raises(UnitsError, match=which):
        _calibrate(problem, T_base_ee=T_ee, T_cam_target=T_ct)


def test_metres_read_as_millimetres_are_refused(problem):
    """Camera translations 1000 times too small (metres read with --units mm) put the board a fraction of a
    millimetre from the lens: refused as a units mistake, not calibrated (it used to exit 0, wrong)."""
    T_ct = problem.T_cam_target.copy()
    T_ct[:, :3, 3] /= 1000.0
    with pytest.raises(UnitsError, match="1000 times too small") as exc:
        validation.check_target_distance(T_ct)
    assert "--units mm" in str(exc.value)
    with pytest.raises(UnitsError, match="T_cam_target"):
        _calibrate(problem, T_cam_target=T_ct)
    validation.check_target_distance(problem.T_cam_target)  # the same poses in metres pass


def test_metre_translations_pass_the_units_check(problem):
    validation.check_units_metres(problem.T_base_ee, "T_base_ee")
    validation.check_units_metres(problem.T_cam_target, "T_cam_target")


# ---------------------------------------------------------------- options


@pytest.mark.parametrize(
    "kw, option",
    [({"setup": "eye_on_hand"}, {}), ({"method": "magic"}, {}), ({}, {"pairs": "some"}), ({}, {"loss": "l7"})],
    ids=["setup", "method", "pairs", "loss"],
)
def test_unknown_option_is_refused(problem, kw, option):
    args = {"setup": problem.setup, **kw, "options": classic.CalibrateOptions(**option)}
    bad = next(iter({**kw, **option}.values()))
    with pytest.raises(HandEyeInputError, match=re.escape(repr(bad))):
        classic.calibrate(problem.T_base_ee, problem.T_cam_target, **args)


def test_setup_names_are_normalised(problem):
    spelled = problem.setup.replace("_", "-").upper()
    res = classic.calibrate(problem.T_base_ee, problem.T_cam_target, setup=spelled)
    assert res.setup == problem.setup


# ---------------------------------------------------------------- consistency


def test_motions_no_hand_eye_transform_can_relate_are_refused(problem):
    # camera rotation vectors doubled (e.g. a units slip in the pose source):
    # the rotation angles of paired motions no longer match, whatever X is
    ct = problem.T_cam_target
    bad = make_transform(so3_exp(2.0 * so3_log(ct[:, :3, :3])), ct[:, :3, 3])
    with pytest.raises(InconsistentPosesError) as exc:
        _calibrate(problem, T_cam_target=bad)
    assert isinstance(exc.value, ValueError)
    assert "recorded together" in str(exc.value)  # no alternative fixes it: says to check the pairing


def test_consistent_data_pass_the_consistency_check(problem):
    report = classic.check_consistency(problem.T_base_ee, problem.T_cam_target, problem.setup)
    # noise free: the paired motions' angles match exactly and the data fit exactly
    assert 0.0 <= report["angle_mismatch_deg"] < np.degrees(EXACT)
    assert 0.0 <= report["fit_residual_mm"] < 1000 * EXACT


def _other(setup: str) -> str:
    return "eye_in_hand" if setup == "eye_to_hand" else "eye_to_hand"


@pytest.mark.parametrize("noisy", [False, True], ids=["exact", "noisy"])
def test_inverted_camera_poses_are_refused_with_the_fix(problem, noisy):
    p = problem
    if noisy:
        p = make_problem(10, problem.setup, np.random.default_rng(7), camera_noise=(0.5, 5.0), robot_noise=(0.01, 0.2))
    with pytest.raises(InconsistentPosesError) as exc:
        _calibrate(p, T_cam_target=invert_transform(p.T_cam_target))
    msg = str(exc.value)
    # names the mistake and the frames to swap
    assert "camera poses inverted" in msg and "T_target_cam" in msg


def test_inverted_robot_poses_are_refused_with_the_fix(problem):
    with pytest.raises(InconsistentPosesError) as exc:
        _calibrate(problem, T_base_ee=invert_transform(problem.T_base_ee))
    msg = str(exc.value)
    assert "robot poses" in msg and "T_ee_base" in msg


@pytest.mark.parametrize("noisy", [False, True], ids=["exact", "noisy"])
def test_wrong_setup_is_refused_with_the_fix(problem, noisy):
    p = problem
    if noisy:
        p = make_problem(10, problem.setup, np.random.default_rng(7), camera_noise=(0.5, 5.0), robot_noise=(0.01, 0.2))
    with pytest.raises(InconsistentPosesError) as exc:
        classic.calibrate(p.T_base_ee, p.T_cam_target, setup=_other(p.setup))
    # the message suggests the setup that fits
    assert f"setup='{p.setup}'" in str(exc.value)


def test_inverting_both_sides_only_swaps_the_unknowns(problem):
    # Not an error that can be detected: from A_i Y = X B_i,
    # A_i^-1 X = Y B_i^-1, so inverted robot *and* camera poses are a
    # consistent data set of the same setup whose X and Y are swapped. The
    # check must not refuse it, and the algebra must come out exactly.
    res = _calibrate(
        problem, T_base_ee=invert_transform(problem.T_base_ee), T_cam_target=invert_transform(problem.T_cam_target)
    )
    np.testing.assert_allclose(res.X, problem.Y_true, atol=EXACT)
    np.testing.assert_allclose(res.Y, problem.X_true, atol=EXACT)


def test_rows_shifted_by_one_are_refused():
    # noise free, so any disagreement is a mistake: pose i of the robot paired with pose i-1 of the camera
    accepted = []
    for setup in SETUPS:
        for seed in range(10):
            p = make_problem(10, setup, np.random.default_rng(seed))
            try:
                res = classic.calibrate(p.T_base_ee, np.roll(p.T_cam_target, 1, axis=0), setup=setup)
            except InconsistentPosesError as exc:
                assert "recorded together" in str(exc)
            else:
                accepted.append((setup, seed, round(res.residuals.rms_translation_mm)))
    assert accepted == [], f"shifted rows accepted (setup, seed, RMS residual mm): {accepted}"


# ---------------------------------------------------------------- degenerate input through calibrate


def test_degenerate_motion_is_a_value_error():
    p = make_problem(10, "eye_to_hand", np.random.default_rng(0), motion="one_axis")
    with pytest.raises(ValueError):
        classic.calibrate(p.T_base_ee, p.T_cam_target, setup="eye_to_hand")
    with pytest.raises(DegenerateMotionError):
        classic.calibrate(p.T_base_ee, p.T_cam_target, setup="eye_to_hand")


# ---------------------------------------------------------------- optional dependencies


def test_require_package_names_the_extra_for_a_missing_module():
    with pytest.raises(MissingDependencyError) as exc:
        require_package("handeye_no_such_module_x1", extra="learned", purpose="the learned model")
    msg = str(exc.value)
    assert "handeye_no_such_module_x1" in msg
    assert 'pip install "handeye[learned]"' in msg
    assert "the learned model" in msg
    assert isinstance(exc.value, ImportError)
    assert isinstance(exc.value.__cause__, ImportError)


def test_require_package_returns_an_installed_module():
    assert require_package("numpy", extra="core") is np
