"""Checkerboard, ArUco/AprilTag grid and legacy ChArUco on rendered views: corners, PnP, hand-eye X."""

from __future__ import annotations

import numpy as np
import pytest

import classic
from classic.vision import BoardSpec, ReprojectionOptions, detect_board, estimate_pose, refine_reprojection
from classic.vision.detect import POSE_LIMITS, project_points
from classic.vision.synthetic import render_view
from handeye.core.se3 import invert_transform, make_transform, so3_exp
from handeye.core.setups import robot_side_poses
from handeye.core.synthetic import make_problem
from handeye.core.validation import MIN_POSES
from tests.tolerances import CORNER_SIGMA_BOUND, ESTIMATED_SIGMA_BOUND, MARKER_CORNER_BIAS_PX, RENDER_BIAS_PX
from tests.vision._helpers import (
    INTR,
    common_shift_floor,
    numeric_jacobian,
    per_axis_sigma_px,
    perturbed,
    predicted_block_sigma,
    rotation_error_rad,
    translation_error_m,
)

TARGETS = {
    "checkerboard": BoardSpec.checkerboard(8, 7, 0.035),
    "aruco_grid": BoardSpec.aruco_grid(5, 4, 0.045, 0.01, "APRILTAG_36h11"),
    "charuco_legacy": BoardSpec(6, 6, 0.04, 0.03, "4X4_50", legacy=True),
}
#: Per-corner bias beyond the renderer's: a marker corner is a convex L (classic.vision.aruco_grid).
EXTRA_BIAS_PX = {"checkerboard": 0.0, "aruco_grid": MARKER_CORNER_BIAS_PX, "charuco_legacy": 0.0}


def _centre(spec):
    return make_transform(np.eye(3), [-spec.size_m[0] / 2, -spec.size_m[1] / 2, 0.0])


def _pose(spec, seed):
    """Board centre 0.45 to 0.7 m ahead, tilted up to 35 degrees; odd seeds turned by 180 degrees in plane."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(0.45, 0.7)
    axis = rng.normal(size=2)
    w = np.r_[np.radians(rng.uniform(10, 35)) * axis / np.linalg.norm(axis), rng.uniform(-0.5, 0.5)]
    turn = make_transform(so3_exp([0, 0, np.pi * (seed % 2)]), [0, 0, 0])
    return make_transform(so3_exp(w), [rng.uniform(-0.03, 0.03), rng.uniform(-0.03, 0.03), z]) @ turn @ _centre(spec)


@pytest.fixture(scope="module")
def views():
    out = {}
    for name, spec in TARGETS.items():
        for seed in range(4):
            T = _pose(spec, seed)
            out[name, seed] = (T, render_view(spec, INTR, T, 2.0, np.random.default_rng(seed)))
    return out


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("name", list(TARGETS))
def test_corners_at_true_projections_and_pnp_within_noise(views, name, seed):
    spec = TARGETS[name]
    T_true, image = views[name, seed]
    det = detect_board(image, spec)
    assert det.reason is None, det.reason
    assert len(np.unique(det.ids)) == len(det.ids) and det.ids.max() < spec.n_corners
    assert len(det.ids) >= POSE_LIMITS["min_corners"]
    pose = estimate_pose(det, spec, INTR)
    assert pose.ok, pose.reason
    M = len(det.ids)
    sigma = per_axis_sigma_px(pose.rms_px, M, 6)
    P = spec.corners_target()[det.ids]
    err = det.corners_px - project_points(P, T_true, INTR)
    bias = RENDER_BIAS_PX + EXTRA_BIAS_PX[name]
    assert np.linalg.norm(err, axis=1).max() <= np.sqrt(2) * bias + CORNER_SIGMA_BOUND * sigma
    assert np.all(np.abs(err.mean(axis=0)) <= RENDER_BIAS_PX + CORNER_SIGMA_BOUND * sigma / np.sqrt(M))

    J = numeric_jacobian(lambda d: project_points(P, perturbed(pose.T_cam_target, d), INTR).ravel(), 6)
    sig_rot, sig_trans = predicted_block_sigma(J, sigma)
    floor_rot, floor_trans = common_shift_floor(J, np.zeros(M, int), RENDER_BIAS_PX)
    assert rotation_error_rad(pose.T_cam_target, T_true) <= ESTIMATED_SIGMA_BOUND * sig_rot + floor_rot
    assert translation_error_m(pose.T_cam_target, T_true) <= ESTIMATED_SIGMA_BOUND * sig_trans + floor_trans
    assert ESTIMATED_SIGMA_BOUND * sig_trans + floor_trans < 0.01


def test_checkerboard_order_follows_the_colours_when_turned(views):
    # seeds 1 and 3 are turned by 180 degrees: the same corner ids land where the truth puts them
    spec = TARGETS["checkerboard"]
    for seed in (1, 3):
        T_true, image = views["checkerboard", seed]
        det = detect_board(image, spec)
        err = det.corners_px - project_points(spec.corners_target()[det.ids], T_true, INTR)
        assert np.linalg.norm(err, axis=1).max() < 1.0


@pytest.mark.parametrize(
    "name",
    [
        "checkerboard",
        pytest.param(
            "aruco_grid",
            marks=pytest.mark.xfail(
                strict=True,
                reason=(
                    "marker corners shrink toward each marker's centre by ~0.2 px (MARKER_CORNER_BIAS_PX): a bias "
                    "the per-view mean-shift floor does not cover; X is 0.47 mm off for a 0.34 mm bound"
                ),
            ),
        ),
        "charuco_legacy",
    ],
)
def test_hand_eye_from_rendered_views_recovers_x(name):
    spec = TARGETS[name]
    setup = "eye_in_hand"
    p = make_problem(10, setup, np.random.default_rng(21), max_tilt_deg=30.0)
    C = _centre(spec)
    p.T_cam_target = p.T_cam_target @ C
    p.Y_true = p.Y_true @ C
    rng = np.random.default_rng(22)
    dets = [detect_board(render_view(spec, INTR, T, 2.0, rng), spec) for T in p.T_cam_target]
    poses = [estimate_pose(d, spec, INTR) for d in dets]
    ok = np.array([v.ok for v in poses])
    assert ok.sum() >= MIN_POSES, [v.reason for v in poses]
    cal = classic.calibrate(p.T_base_ee[ok], np.stack([v.T_cam_target for v in poses if v.ok]), setup=setup)
    ids = [d.ids if d.reason is None else np.zeros(0, int) for d in dets]
    uv = [d.corners_px if d.reason is None else np.zeros((0, 2)) for d in dets]
    res = refine_reprojection(p.T_base_ee, ids, uv, spec, INTR, cal.X, cal.Y, ReprojectionOptions(setup=setup))
    # the part of the corner error common to a view is invisible in sigma: measured and propagated through
    # the refinement's Jacobian, as in test_end_to_end
    sig_rot, sig_trans = np.radians(res.sigma["X_rotation_deg"]), res.sigma["X_translation_mm"] / 1000
    A = robot_side_poses(p.T_base_ee, setup)

    def corners(d):
        X, Y = perturbed(res.X, d[:6]), perturbed(res.Y, d[6:])
        return np.concatenate(
            [
                project_points(spec.corners_target()[i], invert_transform(X) @ A[k] @ Y, INTR).ravel()
                for k, i in enumerate(ids)
                if len(i)
            ]
        )

    J = numeric_jacobian(corners, 12)
    shift = np.concatenate(
        [
            np.tile((u - project_points(spec.corners_target()[i], T, INTR)).mean(axis=0), len(i))
            for i, u, T in zip(ids, uv, p.T_cam_target)
            if len(i)
        ]
    )
    floor_rot, floor_trans = np.linalg.norm((np.linalg.pinv(J) @ shift).reshape(4, 3), axis=1)[:2]
    assert rotation_error_rad(res.X, p.X_true) <= ESTIMATED_SIGMA_BOUND * sig_rot + floor_rot
    assert translation_error_m(res.X, p.X_true) <= ESTIMATED_SIGMA_BOUND * sig_trans + floor_trans
    assert translation_error_m(res.X, p.X_true) < 1e-3 and rotation_error_rad(res.X, p.X_true) < np.radians(0.1)
