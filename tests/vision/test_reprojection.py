"""Hand-eye refinement on corner reprojection error, on exactly projected corners with pixel noise."""

from __future__ import annotations

import numpy as np
import pytest

import classic
from classic.vision import CameraIntrinsics, Detection, ReprojectionOptions, estimate_pose, refine_reprojection
from classic.vision.detect import project_points
from classic.vision.reprojection import OUTLIER_VIEW_FACTOR, project
from handeye.core.synthetic import make_problem, perturb
from tests.tolerances import (
    ABSOLUTE_ONLY,
    ESTIMATED_SIGMA_BOUND,
    EXACT,
    EXACT_PX,
    FLOAT,
    MC_SIGMA_RATIO,
    MC_TRIALS,
    OPENCV_PROJECTION_PX,
    REPROJECTION_TRIALS,
    ROBUST_SIGMA_FACTOR,
    SIGMA_JACOBIAN_RTOL,
)
from tests.vision._helpers import (
    CENTRE,
    INTR,
    SPEC,
    corners_in_image,
    handeye_jacobian,
    per_axis_sigma_px,
    predicted_block_sigma,
    rotation_error_rad,
    translation_error_m,
)

SETUPS = ["eye_to_hand", "eye_in_hand"]
N_VIEWS = 15
PIXEL_NOISE = 0.3


def _problem(setup, seed):
    """make_problem's geometry (noise-free poses) with the board centred where it puts the target."""
    p = make_problem(N_VIEWS, setup, np.random.default_rng(seed))
    p.T_cam_target = p.T_cam_target @ CENTRE
    p.Y_true = p.Y_true @ CENTRE
    return p


def _corners(p, sigma_px, rng):
    ids, uv = zip(*(corners_in_image(T, INTR, sigma_px, rng) for T in p.T_cam_target))
    return list(ids), list(uv)


def _pnp_calibration(p, ids, uv, setup):
    """classic.calibrate on the PnP poses of the views (the usual start of the refinement)."""
    poses = [estimate_pose(Detection(i, u, 0, (INTR.width, INTR.height)), SPEC, INTR) for i, u in zip(ids, uv)]
    ok = np.array([v.ok for v in poses])
    assert ok.sum() >= N_VIEWS - 2, [v.reason for v in poses]
    return classic.calibrate(p.T_base_ee[ok], np.stack([v.T_cam_target for v in poses if v.ok]), setup=setup)


def _errors(res, p):
    return (
        rotation_error_rad(res.X, p.X_true),
        translation_error_m(res.X, p.X_true),
        rotation_error_rad(res.Y, p.Y_true),
        translation_error_m(res.Y, p.Y_true),
    )


def _sigmas_si(res):
    """result.sigma in radians and metres, ordered as _errors."""
    s = res.sigma
    return (
        np.radians(s["X_rotation_deg"]),
        s["X_translation_mm"] / 1000,
        np.radians(s["Y_rotation_deg"]),
        s["Y_translation_mm"] / 1000,
    )


def test_project_is_opencvs_projection():
    rng = np.random.default_rng(0)
    p_cam = np.column_stack([rng.uniform(-0.3, 0.3, (50, 2)), rng.uniform(0.4, 1.0, 50)])
    K = INTR.K
    ours = project(p_cam, K[0, 0], K[1, 1], K[0, 2], K[1, 2], INTR.dist)
    theirs = project_points(p_cam, np.eye(4), INTR)
    np.testing.assert_allclose(ours, theirs, rtol=ABSOLUTE_ONLY, atol=OPENCV_PROJECTION_PX)


@pytest.mark.parametrize("setup", SETUPS)
def test_noise_free_corners_give_the_exact_x_and_y(setup):
    p = _problem(setup, 3)
    rng = np.random.default_rng(33)
    ids, uv = _corners(p, 0.0, rng)
    X0 = perturb(p.X_true[None], rng, np.radians(2.0), 0.02)[0]
    Y0 = perturb(p.Y_true[None], rng, np.radians(2.0), 0.02)[0]
    assert np.abs(X0 - p.X_true).max() > 1e-3  # the start is really off
    res = refine_reprojection(p.T_base_ee, ids, uv, SPEC, INTR, X0, Y0, ReprojectionOptions(setup=setup))
    assert np.abs(res.X - p.X_true).max() <= EXACT
    assert np.abs(res.Y - p.Y_true).max() <= EXACT
    assert res.rms_px <= EXACT_PX
    assert res.outlier_views == []
    # not refined: the input's values come back
    np.testing.assert_array_equal(res.intrinsics.K, INTR.K)
    np.testing.assert_array_equal(res.intrinsics.dist, INTR.dist)


@pytest.mark.parametrize("setup", SETUPS)
def test_reprojection_beats_pose_based_calibration_on_pnp_poses(setup):
    rot_cal, trans_cal, rot_rep, trans_rep = [], [], [], []
    for seed in range(REPROJECTION_TRIALS):
        p = _problem(setup, 100 + seed)
        ids, uv = _corners(p, PIXEL_NOISE, np.random.default_rng(1000 + seed))
        cal = _pnp_calibration(p, ids, uv, setup)
        rep = refine_reprojection(p.T_base_ee, ids, uv, SPEC, INTR, cal.X, cal.Y, ReprojectionOptions(setup=setup))
        rot_cal.append(rotation_error_rad(cal.X, p.X_true))
        trans_cal.append(translation_error_m(cal.X, p.X_true))
        rot_rep.append(rotation_error_rad(rep.X, p.X_true))
        trans_rep.append(translation_error_m(rep.X, p.X_true))
    assert np.median(rot_rep) < np.median(rot_cal)
    assert np.median(trans_rep) < np.median(trans_cal)


@pytest.mark.parametrize("setup", SETUPS)
def test_predicted_sigma_matches_monte_carlo(setup):
    p = _problem(setup, 5)
    sq_err, sq_sig = [], []
    for trial in range(MC_TRIALS):
        ids, uv = _corners(p, PIXEL_NOISE, np.random.default_rng([5, trial]))
        res = refine_reprojection(
            p.T_base_ee, ids, uv, SPEC, INTR, p.X_true, p.Y_true, ReprojectionOptions(setup=setup)
        )
        sq_err.append(np.square(_errors(res, p)))
        sq_sig.append(np.square(_sigmas_si(res)))
    rms_err = np.sqrt(np.mean(sq_err, axis=0))
    rms_sig = np.sqrt(np.mean(sq_sig, axis=0))
    ratio = rms_err / rms_sig
    assert np.all(np.abs(ratio - 1) <= MC_SIGMA_RATIO), ratio


@pytest.mark.parametrize("setup", SETUPS)
def test_sigma_is_the_covariance_of_the_reprojection_model(setup):
    """result.sigma = sqrt(trace) of s^2 (J^T J)^-1 blocks, J our own Jacobian: units deg and mm, order X then Y.

    The corners-only model (``robot_noise="none"``); the robot's error is tested in test_robot_noise.py."""
    p = _problem(setup, 8)
    ids, uv = _corners(p, PIXEL_NOISE, np.random.default_rng(8))
    res = refine_reprojection(
        p.T_base_ee, ids, uv, SPEC, INTR, p.X_true, p.Y_true, ReprojectionOptions(setup=setup, robot_noise="none")
    )
    J = handeye_jacobian(p.T_base_ee, ids, res.X, res.Y, setup)
    n_points = sum(len(i) for i in ids)
    ours = predicted_block_sigma(J, per_axis_sigma_px(res.rms_px, n_points, 12))
    np.testing.assert_allclose(_sigmas_si(res), ours, rtol=SIGMA_JACOBIAN_RTOL)
    C = res.covariance
    assert C.shape == (12, 12)
    np.testing.assert_allclose(C, C.T, rtol=ABSOLUTE_ONLY, atol=FLOAT * np.abs(C).max())


@pytest.mark.parametrize("setup", SETUPS)
def test_refine_intrinsics_recovers_k_noise_free(setup):
    p = _problem(setup, 4)
    rng = np.random.default_rng(44)
    ids, uv = _corners(p, 0.0, rng)
    K1 = INTR.K.copy()
    K1[0, 0] *= 1.01
    start = CameraIntrinsics(K1, INTR.dist, INTR.width, INTR.height)
    X0 = perturb(p.X_true[None], rng, np.radians(1.0), 0.01)[0]
    Y0 = perturb(p.Y_true[None], rng, np.radians(1.0), 0.01)[0]
    # with the wrong K the pose-only fit cannot match the corners...
    fixed = refine_reprojection(p.T_base_ee, ids, uv, SPEC, start, X0, Y0, ReprojectionOptions(setup=setup))
    assert fixed.rms_px > 100 * EXACT_PX
    # ...refining K too recovers everything
    res = refine_reprojection(
        p.T_base_ee, ids, uv, SPEC, start, X0, Y0, ReprojectionOptions(setup=setup, refine_intrinsics=True)
    )
    assert np.abs(res.intrinsics.K - INTR.K).max() <= EXACT_PX
    assert np.abs(res.intrinsics.dist - INTR.dist).max() <= EXACT
    assert np.abs(res.X - p.X_true).max() <= EXACT
    assert np.abs(res.Y - p.Y_true).max() <= EXACT
    assert res.covariance.shape == (21, 21)
    assert (res.intrinsics.width, res.intrinsics.height) == (INTR.width, INTR.height)


def test_refine_intrinsics_with_noise_is_within_its_covariance():
    setup = "eye_to_hand"
    p = _problem(setup, 6)
    ids, uv = _corners(p, PIXEL_NOISE, np.random.default_rng(66))
    K1 = INTR.K.copy()
    K1[0, 0] *= 1.01
    start = CameraIntrinsics(K1, INTR.dist, INTR.width, INTR.height)
    res = refine_reprojection(
        p.T_base_ee, ids, uv, SPEC, start, p.X_true, p.Y_true, ReprojectionOptions(setup=setup, refine_intrinsics=True)
    )
    K, d = res.intrinsics.K, res.intrinsics.dist
    est = np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2], *d])
    truth = np.array([INTR.K[0, 0], INTR.K[1, 1], INTR.K[0, 2], INTR.K[1, 2], *INTR.dist])
    std = np.sqrt(np.diag(res.covariance)[12:])
    assert np.all(np.abs(est - truth) <= ESTIMATED_SIGMA_BOUND * std), (est - truth) / std
    # the 1 % start error (5.5 px) is far outside that: the intrinsics did move
    assert ESTIMATED_SIGMA_BOUND * std[0] < 0.01 * INTR.K[0, 0]
    errors, sigmas = _errors(res, p), _sigmas_si(res)
    assert all(e <= ESTIMATED_SIGMA_BOUND * s for e, s in zip(errors, sigmas))


def _with_outlier(setup, seed, k, shift_px):
    p = _problem(setup, seed)
    ids, uv = _corners(p, PIXEL_NOISE, np.random.default_rng(seed))
    bad = list(uv)
    bad[k] = uv[k] + shift_px
    return p, ids, uv, bad


@pytest.mark.parametrize("setup", SETUPS)
@pytest.mark.parametrize("shift", [(20.0, 0.0), (0.0, -20.0), (20.0, 20.0)])
def test_an_outlier_view_is_flagged(setup, shift):
    k = 5
    p, ids, uv, bad = _with_outlier(setup, 2, k, np.array(shift))
    res = refine_reprojection(p.T_base_ee, ids, bad, SPEC, INTR, p.X_true, p.Y_true, ReprojectionOptions(setup=setup))
    assert k in res.outlier_views
    assert int(np.argmax(res.per_view_rms_px)) == k
    med = np.median(res.per_view_rms_px)
    assert all(res.per_view_rms_px[v] > max(OUTLIER_VIEW_FACTOR * med, 1.0) for v in res.outlier_views)
    # a robust loss flags it alone and keeps X within the noise of the other views
    rob, clean = _robust_and_without(p, ids, uv, bad, k, setup)
    assert rob.outlier_views == [k]
    errors, sigmas = _errors(rob, p), _sigmas_si(clean)
    assert all(e <= ESTIMATED_SIGMA_BOUND * s for e, s in zip(errors, sigmas))


def _robust_and_without(p, ids, uv, bad, k, setup):
    """The Cauchy fit on the corners ``bad`` (view ``k`` shifted), and the least-squares fit without view ``k``."""
    rob = refine_reprojection(
        p.T_base_ee, ids, bad, SPEC, INTR, p.X_true, p.Y_true, ReprojectionOptions(setup=setup, loss="cauchy")
    )
    keep = [v for v in range(N_VIEWS) if v != k]
    kept = (p.T_base_ee[keep], [ids[v] for v in keep], [uv[v] for v in keep])
    clean = refine_reprojection(*kept, SPEC, INTR, p.X_true, p.Y_true, ReprojectionOptions(setup=setup))
    return rob, clean


def test_clean_data_has_no_outlier_view():
    p = _problem("eye_to_hand", 2)
    ids, uv = _corners(p, PIXEL_NOISE, np.random.default_rng(2))
    res = refine_reprojection(p.T_base_ee, ids, uv, SPEC, INTR, p.X_true, p.Y_true)
    assert res.outlier_views == []
    assert res.per_view_rms_px.shape == (N_VIEWS,)
    # per-view RMS of 2-D residuals at per-axis noise sigma: about sqrt(2) sigma
    assert np.all(res.per_view_rms_px < 3 * np.sqrt(2) * PIXEL_NOISE)


@pytest.mark.parametrize("setup", SETUPS)
def test_robust_sigma_is_not_inflated_by_a_rejected_outlier_view(setup):
    k = 5
    p, ids, uv, bad = _with_outlier(setup, 2, k, np.array([20.0, 20.0]))
    rob, clean = _robust_and_without(p, ids, uv, bad, k, setup)
    assert rob.outlier_views == [k]
    ratio = np.array(_sigmas_si(rob)) / np.array(_sigmas_si(clean))
    assert np.all((1 / ROBUST_SIGMA_FACTOR <= ratio) & (ratio <= ROBUST_SIGMA_FACTOR)), ratio


def test_views_without_corners_are_allowed():
    p = _problem("eye_to_hand", 9)
    ids, uv = _corners(p, 0.0, np.random.default_rng(9))
    ids[3], uv[3] = np.zeros(0, int), np.zeros((0, 2))
    res = refine_reprojection(p.T_base_ee, ids, uv, SPEC, INTR, p.X_true, p.Y_true)
    assert np.abs(res.X - p.X_true).max() <= EXACT
    assert res.per_view_rms_px.shape == (N_VIEWS,) and res.per_view_rms_px[3] == 0
    assert 3 not in res.outlier_views
