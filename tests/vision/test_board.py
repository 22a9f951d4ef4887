"""BoardSpec: corner coordinates, the printable image and its detection, the file, invalid specs."""

from __future__ import annotations

import json

import numpy as np
import pytest

from classic.vision import BoardSpec, detect_board
from classic.vision.board import BoardSpecError
from tests.tolerances import ABSOLUTE_ONLY, FLAT_CORNER_PX, FLOAT32_M, SAME_FORMULA

SPECS = [
    BoardSpec(7, 5, 0.04, 0.03, "5X5_100"),
    BoardSpec(5, 7, 0.04, 0.03, "5X5_100"),
    BoardSpec(6, 6, 0.025, 0.018, "4X4_50"),
    BoardSpec(9, 4, 0.03, 0.02, "DICT_6X6_250"),
    BoardSpec(3, 2, 0.1, 0.07, "7x7_50"),
]


@pytest.mark.parametrize("spec", SPECS, ids=lambda s: f"{s.squares_x}x{s.squares_y}_{s.dictionary}")
def test_corners_target_agree_with_opencv(spec):
    ours = spec.corners_target()
    theirs = np.asarray(spec.cv_board().getChessboardCorners(), dtype=float)
    assert ours.shape == theirs.shape == (spec.n_corners, 3)
    # same order (corner id k = r (squares_x - 1) + c), same place
    np.testing.assert_allclose(ours, theirs, rtol=ABSOLUTE_ONLY, atol=FLOAT32_M)
    # and the documented convention itself: x along columns, y along rows, z = 0
    L = spec.square_length_m
    k = np.arange(spec.n_corners)
    np.testing.assert_allclose(ours[:, 0], (k % (spec.squares_x - 1) + 1) * L, rtol=ABSOLUTE_ONLY, atol=SAME_FORMULA)
    np.testing.assert_allclose(ours[:, 1], (k // (spec.squares_x - 1) + 1) * L, rtol=ABSOLUTE_ONLY, atol=SAME_FORMULA)
    assert np.all(ours[:, 2] == 0)


def test_size_and_corner_count():
    spec = BoardSpec(7, 5, 0.04, 0.03)
    assert spec.n_corners == 24
    assert spec.size_m == pytest.approx((0.28, 0.20), abs=SAME_FORMULA)


def _assert_detected_at(image, spec, pixels_per_metre, margin):
    det = detect_board(image, spec)
    assert det.reason is None
    assert det.image_size == (image.shape[1], image.shape[0])
    # every corner, each once
    assert sorted(det.ids.tolist()) == list(range(spec.n_corners))
    # corner k at ((c + 1) L, (r + 1) L) m; the board's outer corner (target origin) is the top-left
    # corner of pixel (margin, margin), i.e. at margin - 0.5 with pixel centres at integers
    expected = spec.corners_target()[det.ids, :2] * pixels_per_metre + margin - 0.5
    err = np.linalg.norm(det.corners_px - expected, axis=1)
    assert err.max() <= FLAT_CORNER_PX


# scales with a whole number of pixels per square, where render() draws exactly at pixels_per_metre
@pytest.mark.parametrize("spec", SPECS[:3], ids=["7x5", "5x7", "6x6"])
@pytest.mark.parametrize("pixels_per_square,margin", [(50, 0), (80, 10), (101, 37)])
def test_rendered_board_is_detected_where_the_frame_convention_puts_it(spec, pixels_per_square, margin):
    pixels_per_metre = pixels_per_square / spec.square_length_m
    image = spec.render(pixels_per_metre, margin_px=margin)
    assert image.dtype == np.uint8
    assert image.shape == (
        spec.squares_y * pixels_per_square + 2 * margin,
        spec.squares_x * pixels_per_square + 2 * margin,
    )
    _assert_detected_at(image, spec, pixels_per_metre, margin)


@pytest.mark.parametrize("pixels_per_metre", [2510.0, 1234.5, 11811.0])  # 11811 = 300 dpi
def test_render_at_any_scale_draws_whole_pixel_squares(pixels_per_metre):
    spec = BoardSpec(7, 5, 0.04, 0.03)
    n = spec.pixels_per_square(pixels_per_metre)
    assert n == round(spec.square_length_m * pixels_per_metre)
    margin = 5
    image = spec.render(pixels_per_metre, margin_px=margin)
    assert image.shape == (5 * n + 2 * margin, 7 * n + 2 * margin)
    # the drawing's true scale is n pixels per square, within half a pixel per square of the request
    assert abs(n / spec.square_length_m - pixels_per_metre) <= 0.5 / spec.square_length_m
    _assert_detected_at(image, spec, n / spec.square_length_m, margin)


def test_render_margin_is_white_and_origin_square_is_black():
    spec = BoardSpec(7, 5, 0.04, 0.03)
    m = 12
    image = spec.render(1000.0, margin_px=m)
    assert np.all(image[:m] == 255) and np.all(image[-m:] == 255)
    assert np.all(image[:, :m] == 255) and np.all(image[:, -m:] == 255)
    # OpenCV's ChArUco layout: the square at the target origin (row 0, column 0) is black
    s = int(0.04 * 1000)
    assert image[m + s // 2, m + s // 2] == 0


@pytest.mark.parametrize("spec", SPECS, ids=lambda s: f"{s.squares_x}x{s.squares_y}_{s.dictionary}")
def test_save_load_round_trip(tmp_path, spec):
    path = tmp_path / "board.json"
    spec.save(path)
    doc = json.loads(path.read_text())
    assert doc["type"] == "charuco"
    loaded = BoardSpec.load(path)
    assert loaded == spec
    np.testing.assert_array_equal(loaded.corners_target(), spec.corners_target())


@pytest.mark.parametrize(
    "args,fragment",
    [
        ((7, 5, 0.03, 0.04, "5X5_100"), "swapped"),  # marker and square lengths swapped
        ((7, 5, 0.04, 0.04, "5X5_100"), "smaller than the square"),  # marker as large as the square
        ((7, 5, 40.0, 30.0, "5X5_100"), "millimetres"),  # lengths in mm
        ((7, 5, 0.04, 0.0, "5X5_100"), "positive"),
        ((7, 5, 0.04, -0.03, "5X5_100"), "positive"),
        ((7, 5, 0.04, 0.03, "5X5_99"), "unknown ArUco dictionary"),
        ((7, 5, 0.04, 0.03, "DICT_9X9_100"), "unknown ArUco dictionary"),
        ((11, 10, 0.04, 0.03, "5X5_50"), "55 markers"),  # 55 markers, the dictionary has 50
        ((14, 14, 0.02, 0.015, "4X4_50"), "98 markers"),
        ((1, 5, 0.04, 0.03, "5X5_100"), "2x2"),
        ((5, 1, 0.04, 0.03, "5X5_100"), "2x2"),
    ],
)
def test_invalid_specs_raise_with_the_reason(args, fragment):
    with pytest.raises(BoardSpecError, match=fragment):
        BoardSpec(*args)


def test_board_exactly_filling_its_dictionary_is_accepted():
    spec = BoardSpec(10, 10, 0.02, 0.015, "5X5_50")  # 50 markers, 50 in the dictionary
    assert len(spec.cv_board().getIds()) == 50


@pytest.mark.parametrize("name", ["foo", "DICT_FOO"])
def test_unknown_dictionary_without_a_number_raises_board_spec_error(name):
    with pytest.raises(BoardSpecError, match="unknown ArUco dictionary"):
        BoardSpec(7, 5, 0.04, 0.03, name)


def test_aruco_original_dictionary_is_accepted():
    spec = BoardSpec(7, 5, 0.04, 0.03, "ARUCO_ORIGINAL")
    assert len(spec.cv_board().getIds()) == 17
