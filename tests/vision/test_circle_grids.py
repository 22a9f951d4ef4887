"""Circle grids, symmetric and asymmetric, on rendered views: centres, PnP, order when turned, named errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from classic.vision import BoardSpec, detect_board, estimate_pose
from classic.vision.board import BoardSpecError
from classic.vision.detect import project_points
from classic.vision.synthetic import render_view
from handeye.cli import main
from handeye.core.se3 import make_transform, so3_exp
from tests.tolerances import (
    CIRCLE_CENTROID_POLYGON_POINTS,
    CORNER_SIGMA_BOUND,
    ESTIMATED_SIGMA_BOUND,
    RENDER_BIAS_PX,
)
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

GRIDS = {
    "circles": BoardSpec.circle_grid(7, 6, 0.03, 0.015),
    "asymmetric_circles": BoardSpec.circle_grid(4, 11, 0.02, 0.012, asymmetric=True),
}


def _centre(spec):
    return make_transform(np.eye(3), [-spec.size_m[0] / 2, -spec.size_m[1] / 2, 0.0])


def _turn(angle):
    return make_transform(so3_exp([0.0, 0.0, angle]), [0.0, 0.0, 0.0])


def _pose(spec, seed, turned):
    """Board centre 0.45 to 0.7 m ahead, tilted 10 to 35 degrees, turned in plane by 180 degrees if asked."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(0.45, 0.7)
    axis = rng.normal(size=2)
    w = np.r_[np.radians(rng.uniform(10, 35)) * axis / np.linalg.norm(axis), rng.uniform(-0.5, 0.5)]
    T = make_transform(so3_exp(w), [rng.uniform(-0.03, 0.03), rng.uniform(-0.03, 0.03), z])
    return T @ _turn(np.pi * turned) @ _centre(spec)


def _centroid_offset_px(spec, T):
    """Per circle: the centroid of its image minus the image of its centre (perspective), pixels ``(M, 2)``."""
    n = CIRCLE_CENTROID_POLYGON_POINTS
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = 0.5 * spec.marker_length_m * np.column_stack([np.cos(a), np.sin(a), np.zeros(n)])
    out = []
    for c in spec.corners_target():
        poly = project_points(c + ring, T, INTR)
        x, y = poly[:, 0], poly[:, 1]
        cross = x * np.roll(y, -1) - np.roll(x, -1) * y
        area = cross.sum() / 2
        centroid = np.array([((x + np.roll(x, -1)) * cross).sum(), ((y + np.roll(y, -1)) * cross).sum()]) / (6 * area)
        out.append(centroid - project_points(c[None], T, INTR)[0])
    return np.array(out)


def _pose_bounds(spec, det, pose, T_true):
    """The centres' per-axis noise sigma (px, from the pose's residuals), their bias bound (px), and the pose's
    error bounds: ESTIMATED_SIGMA_BOUND of its predicted sigma plus the floor of a shift common to the centres
    (rad, m)."""
    M = len(det.ids)
    sigma = per_axis_sigma_px(pose.rms_px, M, 6)
    P = spec.corners_target()[det.ids]
    bias = RENDER_BIAS_PX + np.abs(_centroid_offset_px(spec, T_true)).max()
    J = numeric_jacobian(lambda d: project_points(P, perturbed(pose.T_cam_target, d), INTR).ravel(), 6)
    sig_rot, sig_trans = predicted_block_sigma(J, sigma)
    floor_rot, floor_trans = common_shift_floor(J, np.zeros(M, int), bias)
    return sigma, bias, ESTIMATED_SIGMA_BOUND * sig_rot + floor_rot, ESTIMATED_SIGMA_BOUND * sig_trans + floor_trans


@pytest.fixture(scope="module")
def views():
    out = {}
    for name, spec in GRIDS.items():
        for seed in range(3):
            T = _pose(spec, seed, turned=seed % 2 == 1 and name == "asymmetric_circles")
            out[name, seed] = (T, render_view(spec, INTR, T, 2.0, np.random.default_rng(seed)))
    return out


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("name", list(GRIDS))
def test_centres_at_true_projections_and_pnp_within_noise(views, name, seed):
    """Asymmetric view 1 is turned by 180 degrees: the ids still land where the truth puts them."""
    spec = GRIDS[name]
    T_true, image = views[name, seed]
    det = detect_board(image, spec)
    assert det.reason is None, det.reason
    assert np.array_equal(det.ids, np.arange(spec.n_corners))
    pose = estimate_pose(det, spec, INTR)
    assert pose.ok, pose.reason
    M = len(det.ids)
    sigma, bias, rot_bound, trans_bound = _pose_bounds(spec, det, pose, T_true)
    err = det.corners_px - project_points(spec.corners_target()[det.ids], T_true, INTR)
    assert np.linalg.norm(err, axis=1).max() <= np.sqrt(2) * bias + CORNER_SIGMA_BOUND * sigma
    assert np.all(np.abs(err.mean(axis=0)) <= bias + CORNER_SIGMA_BOUND * sigma / np.sqrt(M))
    assert rotation_error_rad(pose.T_cam_target, T_true) <= rot_bound
    assert translation_error_m(pose.T_cam_target, T_true) <= trans_bound
    assert trans_bound < 0.01


@pytest.mark.parametrize("angle_deg", [60.0, 180.0])
def test_symmetric_grid_order_follows_the_image(angle_deg):
    """A symmetric grid turned by 180 degrees is the same picture: its ids follow the image, x to the right.

    Turned by under 90 degrees the ids are the board's; by more, those of the board turned by 180 degrees
    about its centre (the module's documented convention), so the pose is 180 degrees off.
    """
    spec = GRIDS["circles"]
    upright = _pose(spec, 0, turned=False)
    about_centre = np.linalg.inv(_centre(spec))
    T = upright @ about_centre @ _turn(np.radians(angle_deg)) @ np.linalg.inv(about_centre)
    det = detect_board(render_view(spec, INTR, T, 2.0, np.random.default_rng(1)), spec)
    assert det.reason is None, det.reason
    turned = abs((angle_deg + 180) % 360 - 180) > 90
    labelled = T @ about_centre @ _turn(np.pi * turned) @ np.linalg.inv(about_centre)
    err = det.corners_px - project_points(spec.corners_target()[det.ids], labelled, INTR)
    assert np.linalg.norm(err, axis=1).max() < 1.0  # a wrong order is a spacing, over 20 px, off
    pose = estimate_pose(det, spec, INTR)
    # within its noise of the labelled pose (T, or T turned by 180 degrees about the board's centre)
    assert rotation_error_rad(pose.T_cam_target, labelled) <= _pose_bounds(spec, det, pose, labelled)[2]


def test_partial_view_not_found_with_the_reason():
    spec = GRIDS["asymmetric_circles"]
    T = _pose(spec, 0, turned=False)
    T[1, 3] += 0.3  # part of the board below the image
    uv = project_points(spec.corners_target(), T, INTR)
    inside = np.mean((uv[:, 1] >= 0) & (uv[:, 1] < INTR.height) & (uv[:, 0] >= 0) & (uv[:, 0] < INTR.width))
    assert 0.2 < inside < 0.8
    det = detect_board(render_view(spec, INTR, T, 2.0, np.random.default_rng(0)), spec)
    assert "asymmetric circle grid of 4x11 circles not found: all 44 circles must be in view" in det.reason
    pose = estimate_pose(det, spec, INTR)
    assert not pose.ok and pose.T_cam_target is None and pose.reason == det.reason


@pytest.mark.parametrize("image", [np.full((480, 640), 128, np.uint8), None])
def test_blank_image_and_wrong_spec_not_found(views, image):
    if image is None:  # a 7x6 grid's image read with an 8x6 spec (6x7 is the same board turned by 90 degrees)
        image, spec = views["circles", 0][1], BoardSpec.circle_grid(8, 6, 0.03, 0.015)
    else:
        spec = GRIDS["circles"]
    det = detect_board(image, spec)
    assert "not found" in det.reason and "the spec's counts do not match" in det.reason
    assert len(det.ids) == 0 and det.corners_px.shape == (0, 2)


def test_too_few_points_rejected(views):
    spec = GRIDS["circles"]
    det = detect_board(views["circles", 0][1], spec)
    pose = estimate_pose(det, spec, INTR, limits={"min_corners": spec.n_corners + 1})
    assert not pose.ok and "too few corners: 42 < 43" in pose.reason


@pytest.mark.parametrize(
    "args,message",
    [
        ((6, 6, 0.03, 0.015), "looks the same turned by 90 degrees"),
        ((4, 10, 0.02, 0.012, True), "of 10 rows looks the same turned by 180 degrees"),
        ((7, 6, 0.03, 0.03), "smaller than the spacing"),
        ((7, 6, 30.0, 15.0), "millimetres given?"),
        ((2, 5, 0.03, 0.015), "at least 3x3"),
    ],
)
def test_spec_errors_named(args, message):
    with pytest.raises(BoardSpecError, match=message.replace("?", r"\?")):
        BoardSpec.circle_grid(*args)


def test_board_command_writes_spec_that_detects(tmp_path, capsys):
    png = tmp_path / "acircles.png"
    assert main(["board", "--kind", "asymmetric-circles", "--squares", "4x11", "--square", "0.02", "--marker",
                 "0.012", "-o", str(png)]) == 0  # fmt: skip
    assert "44 circles" in capsys.readouterr().out
    spec = BoardSpec.load(png.with_suffix(".json"))
    assert spec == GRIDS["asymmetric_circles"]
    assert json.loads(png.with_suffix(".json").read_text())["kind"] == "asymmetric_circles"
    import cv2

    printed = cv2.imread(str(png), cv2.IMREAD_GRAYSCALE)
    det = detect_board(printed, spec)  # the printable image itself, seen head-on
    assert det.reason is None, det.reason
    ppm = (printed.shape[1] - 2 * round(0.01 * 300 / 0.0254)) / spec.size_m[0]
    expected = spec.corners_target()[:, :2] * ppm + round(0.01 * 300 / 0.0254) - 0.5
    assert np.abs(det.corners_px - expected).max() < 0.1
