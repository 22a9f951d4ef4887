"""calibrate_intrinsics recovers the synthetic camera; too few views and mixed sizes are refused."""

from __future__ import annotations

import contextlib
import dataclasses

import cv2
import numpy as np
import pytest

from classic.vision import CameraIntrinsics, Detection, calibrate_intrinsics, detect_board, read_image
from classic.vision.camera import IntrinsicsError
from handeye.core.errors import HandEyeInputError
from tests.tolerances import (
    ABSOLUTE_ONLY,
    ESTIMATED_SIGMA_BOUND,
    INTRINSICS_MAX_RMS_PX,
    REFIT_SAME_VIEWS_PX,
    RENDER_BIAS_PX,
)
from tests.vision._helpers import INTR, SPEC

N_VIEWS_PER_SETUP = 6  # 12 views in all, from two differently seeded recordings


@pytest.fixture(scope="module")
def detections(handeye_recordings):
    paths = [p for rec in handeye_recordings.values() for p in rec.paths[:N_VIEWS_PER_SETUP]]
    return [detect_board(read_image(p), SPEC) for p in paths]


@pytest.fixture(scope="module")
def calibration(detections):
    return calibrate_intrinsics(detections, SPEC)


def _params(intr: CameraIntrinsics) -> dict:
    K, d = intr.K, intr.dist
    return {
        "fx": K[0, 0],
        "fy": K[1, 1],
        "cx": K[0, 2],
        "cy": K[1, 2],
        "k1": d[0],
        "k2": d[1],
        "p1": d[2],
        "p2": d[3],
        "k3": d[4],
    }


def test_intrinsics_recover_the_synthetic_camera(detections, calibration):
    res = calibration
    assert len(detections) == 2 * N_VIEWS_PER_SETUP
    usable = [k for k, d in enumerate(detections) if d.reason is None and len(d.ids) >= 6]
    assert res.used == usable and len(usable) >= 10
    assert res.intrinsics.width == INTR.width and res.intrinsics.height == INTR.height
    assert res.rms_px < INTRINSICS_MAX_RMS_PX
    assert res.per_view_rms_px.shape == (len(res.used),)
    assert np.all(res.per_view_rms_px < INTRINSICS_MAX_RMS_PX)

    est, truth = _params(res.intrinsics), _params(INTR)
    floor = {"cx": RENDER_BIAS_PX, "cy": RENDER_BIAS_PX}  # see INTRINSICS_MAX_RMS_PX
    for name in est:
        assert res.std[name] > 0
        bound = ESTIMATED_SIGMA_BOUND * res.std[name] + floor.get(name, 0.0)
        assert abs(est[name] - truth[name]) <= bound, (name, est[name], truth[name], res.std[name])
    # the bounds are tight enough to mean something: focal length and principal point to a few pixels
    for name in ("fx", "fy", "cx", "cy"):
        assert ESTIMATED_SIGMA_BOUND * res.std[name] + floor.get(name, 0.0) < 0.01 * truth["fx"]
    assert "RMS" in res.summary() and f"{len(res.used)} views" in res.summary()


def test_intrinsics_round_trip_through_their_file(tmp_path, calibration):
    path = tmp_path / "camera.json"
    calibration.intrinsics.save(path)
    back = CameraIntrinsics.load(path)
    np.testing.assert_array_equal(back.K, calibration.intrinsics.K)
    np.testing.assert_array_equal(back.dist, calibration.intrinsics.dist)
    assert (back.width, back.height) == (INTR.width, INTR.height)


def test_unusable_views_are_left_out(detections, calibration):
    blank = Detection(np.zeros(0, int), np.zeros((0, 2)), 0, (INTR.width, INTR.height), "board not found")
    few = dataclasses.replace(detections[0], ids=detections[0].ids[:4], corners_px=detections[0].corners_px[:4])
    row = np.isin(detections[1].ids, np.arange(6))  # one row of corners: collinear
    collinear = dataclasses.replace(detections[1], ids=detections[1].ids[row], corners_px=detections[1].corners_px[row])
    assert len(collinear.ids) == 6
    with _one_opencv_thread():  # the two fits then take their sums in one order (REFIT_SAME_VIEWS_PX)
        res = calibrate_intrinsics([blank, few, collinear] + detections, SPEC)
        usable = calibrate_intrinsics(detections, SPEC)
    assert res.used == [k + 3 for k in usable.used] and usable.used == calibration.used
    np.testing.assert_allclose(res.intrinsics.K, usable.intrinsics.K, rtol=ABSOLUTE_ONLY, atol=REFIT_SAME_VIEWS_PX)


@contextlib.contextmanager
def _one_opencv_thread():
    """OpenCV on one thread within the block, its thread count as it was after it."""
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        cv2.setNumThreads(threads)


def test_too_few_views_raise(detections):
    with pytest.raises(HandEyeInputError, match="at least 4 views"):
        calibrate_intrinsics(detections[:3], SPEC)
    with pytest.raises(HandEyeInputError, match="got 0 of 0"):
        calibrate_intrinsics([], SPEC)
    blank = Detection(np.zeros(0, int), np.zeros((0, 2)), 0, (INTR.width, INTR.height), "board not found")
    with pytest.raises(HandEyeInputError, match="got 2 of 5"):
        calibrate_intrinsics(detections[:2] + [blank] * 3, SPEC)
    with pytest.raises(HandEyeInputError, match="at least 13 views"):
        calibrate_intrinsics(detections, SPEC, min_views=13)


def test_views_of_different_sizes_raise(detections):
    other = dataclasses.replace(detections[0], image_size=(800, 600))
    with pytest.raises(HandEyeInputError, match="different sizes"):
        calibrate_intrinsics(detections + [other], SPEC)


def test_views_of_different_sizes_raise_from_images(handeye_recordings):
    image = read_image(handeye_recordings["eye_to_hand"].paths[0])
    cropped = image[:400, :600]
    dets = [detect_board(image, SPEC)] * 3 + [detect_board(cropped, SPEC)] * 3
    assert dets[-1].image_size == (600, 400)
    with pytest.raises(HandEyeInputError, match="different sizes"):
        calibrate_intrinsics(dets, SPEC)


@pytest.mark.parametrize(
    "K,dist,fragment",
    [
        (np.eye(2), np.zeros(5), "3x3"),
        ([[500, 0, 320], [0, -500, 240], [0, 0, 1]], np.zeros(5), "camera matrix"),
        ([[500, 0, 320], [1, 500, 240], [0, 0, 1]], np.zeros(5), "camera matrix"),
        ([[500, 0, 320], [0, 500, 240], [0, 0, 2]], np.zeros(5), "camera matrix"),
        ([[500, 0, np.nan], [0, 500, 240], [0, 0, 1]], np.zeros(5), "finite"),
        (np.diag([500.0, 500.0, 1.0]), np.zeros(6), "distortion"),
        (np.diag([500.0, 500.0, 1.0]), [0.1, np.inf, 0, 0, 0], "distortion"),
    ],
)
def test_invalid_intrinsics_raise(K, dist, fragment):
    with pytest.raises(IntrinsicsError, match=fragment):
        CameraIntrinsics(K, dist, 640, 480)
