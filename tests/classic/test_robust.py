"""Gross outliers: the robust path flags exactly the injected ones and keeps the accuracy."""

from __future__ import annotations

import numpy as np
import pytest

import classic
from handeye.core.errors import InconsistentPosesError
from handeye.core.metrics import rotation_error_deg, translation_error_mm
from handeye.core.synthetic import make_problem
from tests.tolerances import (
    INLIER_RMS_FACTOR,
    NONROBUST_FAILURE_FACTOR,
    ROBUST_ERROR_FACTOR,
)

N_POSES = 20
CAMERA_NOISE = (0.2, 1.0)
ROBOT_NOISE = (0.01, 0.2)
SETUPS = ["eye_to_hand", "eye_in_hand"]
SEEDS = [0, 1, 2]


def _problem(setup, seed, fraction):
    return make_problem(
        N_POSES,
        setup,
        np.random.default_rng(seed),
        camera_noise=CAMERA_NOISE,
        robot_noise=ROBOT_NOISE,
        outlier_fraction=fraction,
    )


def _errors(T_est, T_true):
    return float(rotation_error_deg(T_est, T_true)), float(translation_error_mm(T_est, T_true))


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("setup", SETUPS)
@pytest.mark.parametrize("fraction", [0.2, 0.3])
def test_robust_calibration_flags_exactly_the_outliers(fraction, setup, seed):
    p = _problem(setup, seed, fraction)
    truth = np.flatnonzero(p.outliers)
    assert len(truth) == round(fraction * N_POSES)

    res = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup, robust=True)
    assert res.diagnostics["outliers"] == truth.tolist()
    np.testing.assert_array_equal(res.residuals.inliers, ~p.outliers)
    assert res.method.startswith("ransac+")
    assert res.diagnostics["refinement"]["loss"] == "cauchy"

    # reference: the same data with the outliers removed by hand
    keep = ~p.outliers
    clean = classic.calibrate(p.T_base_ee[keep], p.T_cam_target[keep], setup=setup)
    clean_rot, clean_trans = _errors(clean.X, p.X_true)
    # the scale of "small": the clean error, or its predicted sigma when the clean error happens to be tiny
    scale_rot = max(clean_rot, clean.sigma["X_rotation_deg"])
    scale_trans = max(clean_trans, clean.sigma["X_translation_mm"])

    rob_rot, rob_trans = _errors(res.X, p.X_true)
    assert rob_rot <= ROBUST_ERROR_FACTOR * scale_rot
    assert rob_trans <= ROBUST_ERROR_FACTOR * scale_trans

    # the plain closed form on all poses is dragged far off by the outliers
    naive_X, _ = classic.solve(p.T_base_ee, p.T_cam_target, setup=setup)
    naive_rot, naive_trans = _errors(naive_X, p.X_true)
    assert naive_rot > NONROBUST_FAILURE_FACTOR * scale_rot
    assert naive_trans > NONROBUST_FAILURE_FACTOR * scale_trans


@pytest.mark.parametrize("setup", SETUPS)
def test_outliers_have_large_residuals_in_the_robust_result(setup):
    p = _problem(setup, 4, 0.25)
    res = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup, robust=True)
    r = res.residuals
    # every flagged pose is further from the fit than every kept pose
    assert r.translation_mm[p.outliers].min() > r.translation_mm[~p.outliers].max() or (
        r.rotation_deg[p.outliers].min() > r.rotation_deg[~p.outliers].max()
    )
    # RMS is over inliers only, so it stays at the noise level
    assert r.rms_translation_mm <= INLIER_RMS_FACTOR * np.sqrt(3.0) * CAMERA_NOISE[1]
    assert r.rms_rotation_deg <= INLIER_RMS_FACTOR * np.sqrt(3.0) * CAMERA_NOISE[0]


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("setup", SETUPS)
def test_robust_path_on_clean_data_loses_no_inlier(setup, seed):
    p = _problem(setup, seed, 0.0)
    assert not p.outliers.any()
    res = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup, robust=True)
    assert res.diagnostics["outliers"] == []
    assert res.residuals.inliers.all()
    plain = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup)
    rob_rot, rob_trans = _errors(res.X, p.X_true)
    assert rob_rot <= ROBUST_ERROR_FACTOR * max(_errors(plain.X, p.X_true)[0], plain.sigma["X_rotation_deg"])
    assert rob_trans <= ROBUST_ERROR_FACTOR * max(_errors(plain.X, p.X_true)[1], plain.sigma["X_translation_mm"])


def test_robust_result_is_reproducible():
    p = _problem("eye_to_hand", 1, 0.3)
    r1 = classic.calibrate(p.T_base_ee, p.T_cam_target, robust=True)
    r2 = classic.calibrate(p.T_base_ee, p.T_cam_target, robust=True)
    np.testing.assert_array_equal(r1.X, r2.X)
    assert r1.diagnostics["outliers"] == r2.diagnostics["outliers"]


@pytest.mark.parametrize("setup", SETUPS)
def test_a_moderate_outlier_is_flagged_too(setup):
    # Not only the 5-30 cm gross errors of make_problem: one camera pose moved
    # by 5 cm (about 10x the typical pose residual at this noise level, where
    # the per-axis noise is 1 mm and 0.2 deg x 0.65 m = 2.3 mm) must be flagged,
    # and nothing else.
    p = _problem(setup, 6, 0.0)
    T = p.T_cam_target.copy()
    k = 7
    T[k, :3, 3] += np.array([0.03, -0.03, 0.0283])  # |shift| = 5 cm
    res = classic.calibrate(p.T_base_ee, T, setup=setup, robust=True)
    assert res.diagnostics["outliers"] == [k]


@pytest.mark.parametrize("setup", SETUPS)
def test_non_robust_calibration_refuses_grossly_contaminated_data(setup):
    """Without robust=True, 30 % gross outliers are refused with a pointer to the robust path, not fitted."""
    p = _problem(setup, 0, 0.3)
    with pytest.raises(InconsistentPosesError, match="robust=True"):
        classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup)
