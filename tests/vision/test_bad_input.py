"""Bad files and mismatched inputs raise HandEyeInputError subclasses that name the problem."""

from __future__ import annotations

import re

import cv2
import numpy as np
import pytest

from classic.vision import BoardSpec, CameraIntrinsics, ReprojectionOptions, read_image, refine_reprojection
from classic.vision.board import BoardSpecError
from classic.vision.camera import IntrinsicsError
from classic.vision.images import ImageError, list_images
from handeye.core.errors import HandEyeInputError
from handeye.core.synthetic import make_problem
from tests.tolerances import EXACT_PX
from tests.vision._helpers import CENTRE, INTR, SPEC, corners_in_image


def test_error_types_are_input_errors():
    for cls in (ImageError, BoardSpecError, IntrinsicsError):
        assert issubclass(cls, HandEyeInputError) and issubclass(cls, ValueError)


# --- images ---------------------------------------------------------------


def test_read_image_missing_file_names_it(tmp_path):
    path = tmp_path / "nowhere" / "view_007.png"
    with pytest.raises(ImageError, match="view_007.png") as info:
        read_image(path)
    assert str(path) in str(info.value) and "no such image" in str(info.value)


@pytest.mark.parametrize(
    "name,content", [("notes.png", b"this is not a PNG"), ("empty.jpg", b""), ("data.csv", b"a,b\n1,2\n")]
)
def test_read_image_non_image_file_names_it(tmp_path, name, content):
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(ImageError, match="not a readable image") as info:
        read_image(path)
    assert str(path) in str(info.value)


def test_read_image_on_a_folder_raises(tmp_path):
    with pytest.raises(ImageError, match=re.escape(str(tmp_path))):
        read_image(tmp_path)


def test_read_image_returns_grayscale(tmp_path):
    rng = np.random.default_rng(0)
    gray = rng.integers(0, 256, (30, 40), dtype=np.uint8)
    color = cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR)
    cv2.imwrite(str(tmp_path / "gray.png"), gray)
    cv2.imwrite(str(tmp_path / "color.png"), color)
    np.testing.assert_array_equal(read_image(tmp_path / "gray.png"), gray)
    back = read_image(str(tmp_path / "color.png"))  # str paths too
    assert back.shape == (30, 40) and back.dtype == np.uint8
    np.testing.assert_array_equal(back, gray)  # equal channels convert back exactly


def test_list_images_sorted_and_errors(tmp_path):
    with pytest.raises(ImageError, match="no such folder"):
        list_images(tmp_path / "missing")
    (tmp_path / "notes.txt").write_text("x")
    with pytest.raises(ImageError, match="no images"):
        list_images(tmp_path)
    for name in ("b.PNG", "a.jpg", "c.tiff"):
        (tmp_path / name).write_bytes(b"")
    assert [p.name for p in list_images(tmp_path)] == ["a.jpg", "b.PNG", "c.tiff"]


# --- board and camera files -----------------------------------------------


def test_board_load_errors_name_the_file(tmp_path):
    missing = tmp_path / "board.json"
    with pytest.raises(BoardSpecError, match="no such board file") as info:
        BoardSpec.load(missing)
    assert str(missing) in str(info.value)

    bad_json = tmp_path / "bad.json"
    bad_json.write_text("{squares_x: 7")
    with pytest.raises(BoardSpecError, match="not valid JSON") as info:
        BoardSpec.load(bad_json)
    assert str(bad_json) in str(info.value)

    partial = tmp_path / "partial.json"
    partial.write_text('{"squares_x": 7, "squares_y": 5, "square_length_m": 0.04}')
    with pytest.raises(BoardSpecError, match="missing marker_length_m, dictionary") as info:
        BoardSpec.load(partial)
    assert str(partial) in str(info.value)

    mm = tmp_path / "mm.json"
    mm.write_text(
        '{"squares_x": 7, "squares_y": 5, "square_length_m": 40, "marker_length_m": 30, "dictionary": "5X5_100"}'
    )
    with pytest.raises(BoardSpecError, match="millimetres") as info:
        BoardSpec.load(mm)
    assert str(mm) in str(info.value)


def test_intrinsics_load_errors_name_the_file(tmp_path):
    missing = tmp_path / "camera.json"
    with pytest.raises(IntrinsicsError, match="no such intrinsics file") as info:
        CameraIntrinsics.load(missing)
    assert str(missing) in str(info.value)
    for name, text in [
        ("a.json", "not json"),
        ("b.json", '{"dist": [0, 0, 0, 0, 0]}'),
        ("c.json", '{"K": [[1, 2], [3, 4]]}'),
        # a focal length no camera has: the field of view over the image is outside 0.1-170 degrees
        ("d.json", '{"K": [[1e-300, 0, 320], [0, 1e-300, 240], [0, 0, 1]], "width": 640, "height": 480}'),
        ("e.json", '{"K": [[1e300, 0, 320], [0, 1e300, 240], [0, 0, 1]], "width": 640, "height": 480}'),
    ]:
        path = tmp_path / name
        path.write_text(text)
        with pytest.raises(IntrinsicsError) as info:
            CameraIntrinsics.load(path)
        assert str(path) in str(info.value)


# --- reprojection refinement inputs ---------------------------------------


@pytest.fixture(scope="module")
def small_problem():
    p = make_problem(6, "eye_to_hand", np.random.default_rng(0))
    p.T_cam_target = p.T_cam_target @ CENTRE
    p.Y_true = p.Y_true @ CENTRE
    ids, uv = zip(*(corners_in_image(T) for T in p.T_cam_target))
    return p, list(ids), list(uv)


@pytest.mark.parametrize("which", ["poses", "ids", "corners"])
def test_refinement_mismatched_lengths_raise(small_problem, which):
    p, ids, uv = small_problem
    T = p.T_base_ee[:-1] if which == "poses" else p.T_base_ee
    ids = ids[:-1] if which == "ids" else ids
    uv = uv[:-1] if which == "corners" else uv
    with pytest.raises(HandEyeInputError, match="one entry per view"):
        refine_reprojection(T, ids, uv, SPEC, INTR, p.X_true, p.Y_true)


def test_refinement_needs_corners_in_three_views(small_problem):
    p, ids, uv = small_problem
    empty_ids, empty_uv = np.zeros(0, int), np.zeros((0, 2))
    ids2 = ids[:2] + [empty_ids] * 4
    uv2 = uv[:2] + [empty_uv] * 4
    with pytest.raises(HandEyeInputError, match="at least 3 views"):
        refine_reprojection(p.T_base_ee, ids2, uv2, SPEC, INTR, p.X_true, p.Y_true)


def test_refinement_with_no_views_raises_input_error():
    with pytest.raises(HandEyeInputError, match="at least 3 views"):
        refine_reprojection(np.zeros((0, 4, 4)), [], [], SPEC, INTR, np.eye(4), np.eye(4))


def test_refinement_takes_opencvs_full_distortion_models(small_problem):
    # issue 12: rational (8) coefficients are projected by OpenCV, the tail held fixed (no longer refused)
    p, ids, uv = small_problem
    eight = CameraIntrinsics(INTR.K, np.r_[INTR.dist, 0.01, 0.0, 0.0], INTR.width, INTR.height)
    res = refine_reprojection(
        p.T_base_ee, ids, uv, SPEC, eight, p.X_true, p.Y_true, ReprojectionOptions(refine_intrinsics=True)
    )
    np.testing.assert_array_equal(res.intrinsics.dist[5:], eight.dist[5:])
    # eight coefficients whose tail is zero are the five-coefficient model
    zero_tail = CameraIntrinsics(INTR.K, np.r_[INTR.dist, 0.0, 0.0, 0.0], INTR.width, INTR.height)
    res = refine_reprojection(p.T_base_ee, ids, uv, SPEC, zero_tail, p.X_true, p.Y_true)
    assert res.rms_px <= EXACT_PX


def test_refinement_unknown_setup_raises(small_problem):
    p, ids, uv = small_problem
    with pytest.raises(HandEyeInputError, match="unknown setup"):
        refine_reprojection(
            p.T_base_ee, ids, uv, SPEC, INTR, p.X_true, p.Y_true, ReprojectionOptions(setup="eye_on_hand")
        )
