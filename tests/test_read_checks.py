"""Each reader of a user's file refuses a number outside the grammar, an absurd value or a non-file, in one line.

Issue 40 items 5, 9 and 12: ``0_2`` read as 2.0, full-width and Arabic-Indic digits accepted, a 5,000-digit
JSON integer ending in a traceback, a non-orthonormal ``--truth`` accepted, a ``1_000`` truth cell giving a
998,815 mm "error", a FIFO called "table missing", a zero quaternion called "NaN or infinity", a NaN in
meta.json's camera matrix called "surface spacing must be > 0 m", a BOM giving "missing column 'camera_id'".
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from handeye.cli import main
from handeye.core.dataset import CAMERA_COLUMNS, FORMAT, FORMAT_VERSION, Dataset, read_table
from handeye.core.errors import DatasetError, HandEyeInputError, PoseFileError, TruthFileError
from handeye.core.limits import MAX_MESSAGE_CHARS
from handeye.core.posefile import read_pose_file, write_pose_csv
from handeye.core.se3 import make_transform, so3_exp
from handeye.core.synthetic import make_problem
from handeye.markerless import read_start
from handeye.truthfile import TRUTH_ROTATION_TOL, read_truth

DATA = Path(__file__).resolve().parent / "data"
EXAMPLES = Path(__file__).resolve().parents[1] / "handeye" / "data"


def _one_line(exc: pytest.ExceptionInfo, *parts: str) -> str:
    message = str(exc.value)
    assert "\n" not in message and len(message) <= MAX_MESSAGE_CHARS, message
    for part in parts:
        assert part in message, message
    return message


@pytest.fixture
def poses_csv(tmp_path) -> Path:
    p = make_problem(8, "eye_to_hand", np.random.default_rng(0))
    path = tmp_path / "poses.csv"
    write_pose_csv(path, p.T_base_ee, p.T_cam_target)
    return path


# ------------------------------------------------------------------ pose files


@pytest.mark.parametrize("bad", ["0_2", "\uff10.2", "\u0660.2", "0x1p3", "1e", "9" * 5000, "nan"])
def test_pose_csv_refuses_the_cell_naming_line_and_column(poses_csv, bad):
    lines = poses_csv.read_text().splitlines()
    cells = lines[3].split(",")
    cells[2] = bad  # T_base_ee.z of the third pose
    lines[3] = ",".join(cells)
    poses_csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(PoseFileError) as info:
        read_pose_file(poses_csv)
    _one_line(info, "poses.csv, line 4, column T_base_ee.z")


def test_pose_csv_spaces_around_a_cell_still_read(poses_csv):
    before = read_pose_file(poses_csv)
    poses_csv.write_text(poses_csv.read_text().replace(",", ", "))
    after = read_pose_file(poses_csv)
    np.testing.assert_array_equal(after.T_base_ee, before.T_base_ee)


@pytest.mark.parametrize(
    "value, expect",
    [('"0_2"', "poses[1].T_base_ee.translation"), ("9" * 5000, "5,000 characters"), ("true", "boolean")],
)
def test_pose_json_refuses_bad_numbers(tmp_path, value, expect):
    poses = [
        {
            "T_base_ee": {"translation": [0.1 * k, 0.2, 0.3], "quaternion": [0, 0, 0, 1]},
            "T_cam_target": {"translation": [0.0, 0.1 * k, 0.8], "quaternion": [0, 0, 0, 1]},
        }
        for k in range(3)
    ]
    text = json.dumps({"poses": poses}).replace("[0.1, 0.2, 0.3]", f"[{value}, 0.2, 0.3]")
    path = tmp_path / "p.json"
    path.write_text(text)
    with pytest.raises(PoseFileError) as info:
        read_pose_file(path)
    _one_line(info, "p.json", expect)


@pytest.mark.parametrize(
    "old, new, expect",
    [
        ("x: 0.4\n", "x: 0_4\n", "line 14: '0_4' is not a number"),
        ("x: 0.4\n", "x: 0x4\n", "line 14: '0x4' is not a number"),
        ("x: 0.4\n", "x: \uff10.4\n", "line 14: samples[0].robot.translation.x '\uff10.4' is not a number"),
    ],
)
def test_easy_handeye_yaml_refuses_what_yaml_1_1_reads_as_numbers(tmp_path, old, new, expect):
    source = DATA / "easy_handeye2_eye_on_base.samples"
    path = tmp_path / source.name
    path.write_text(source.read_text().replace(old, new, 1))
    with pytest.raises(PoseFileError) as info:
        read_pose_file(path, setup="eye_to_hand")
    _one_line(info, source.name, expect)


def test_yaml_exponents_without_a_dot_read_as_numbers(tmp_path):
    source = DATA / "easy_handeye2_eye_on_base.samples"
    path = tmp_path / source.name
    path.write_text(source.read_text().replace("x: 0.4\n", "x: 4e-1\n", 1))
    np.testing.assert_array_equal(
        read_pose_file(path, setup="eye_to_hand").T_base_ee, read_pose_file(source, setup="eye_to_hand").T_base_ee
    )


# a full-width digit; a no-break space before a number, an ideographic one after it (str.strip drops both)
@pytest.mark.parametrize("new", ["\uff11., 0., 0., 4.0", "\u00a01., 0., 0., 4.0", "1., 0., 0., 4.0\u3000"])
def test_opencv_yaml_refuses_a_full_width_digit_naming_the_key(tmp_path, new):
    path = tmp_path / "pairs.yml"
    path.write_text((DATA / "camodocal_pairs.yml").read_text().replace("1., 0., 0., 4.0", new, 1))
    with pytest.raises(PoseFileError) as info:
        read_pose_file(path)
    _one_line(info, "pairs.yml", "T1_0", "not a number")


@pytest.mark.parametrize("bad", ["0_1", "\u0661", "1_0e-1", "\u00a00", "0\u3000"])
def test_matrix_text_file_refuses_the_token_naming_the_line(tmp_path, bad):
    path = tmp_path / "robot.txt"
    path.write_text("1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n" + f"1 0 0 {bad} 0 1 0 0 0 0 1 0 0 0 0 1\n")
    from handeye.core.matrix_poses import read_pose_matrices

    with pytest.raises(PoseFileError) as info:
        read_pose_matrices(path)
    _one_line(info, "robot.txt, line 2", "is not a number")


def test_noise_options_refuse_python_only_numbers(poses_csv, capsys):
    with pytest.raises(SystemExit) as info:  # argparse's own exit: usage and the option's error
        main(["calibrate", str(poses_csv), "--setup", "eye-to-hand", "--camera-noise", "0_2", "1"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "--camera-noise" in err and "'0_2' is not a number" in err and "Traceback" not in err


# ------------------------------------------------------------------ --truth


def _truth(tmp_path, T) -> Path:
    path = tmp_path / "truth.json"
    path.write_text(json.dumps({"T_base_cam": np.asarray(T).tolist()}))
    return path


def test_truth_that_is_not_a_rotation_is_refused_naming_the_file(tmp_path):
    rng = np.random.default_rng(1)
    T = make_transform(so3_exp(rng.normal(size=3)), [0.3, 0.2, 0.9])
    assert set(read_truth(_truth(tmp_path, T), ("T_base_cam", "T_ee_target"))) == {"T_base_cam"}
    # printed with six decimals: within the tolerance (about 3e-6 off)
    read_truth(_truth(tmp_path, np.round(T, 6)), ("T_base_cam",))
    sheared = T.copy()
    sheared[:3, :3] = T[:3, :3] @ np.diag([1.0, 1.0, 1.0 + 10 * TRUTH_ROTATION_TOL])
    with pytest.raises(TruthFileError) as info:
        read_truth(_truth(tmp_path, sheared), ("T_base_cam",))
    _one_line(info, "truth.json, T_base_cam", "not a rotation")
    reflected = T.copy()
    reflected[:3, 0] *= -1
    with pytest.raises(TruthFileError, match="reflection"):
        read_truth(_truth(tmp_path, reflected), ("T_base_cam",))
    in_mm = T.copy()
    in_mm[:3, 3] *= 1000
    with pytest.raises(TruthFileError, match="millimetres"):
        read_truth(_truth(tmp_path, in_mm), ("T_base_cam",))
    with pytest.raises(TruthFileError, match="holds none of T_ee_cam"):
        read_truth(_truth(tmp_path, T), ("T_ee_cam",))


def test_calibrate_refuses_a_non_orthonormal_truth(tmp_path, capsys):
    truth = json.loads((EXAMPLES / "example_eye_to_hand_truth.json").read_text())
    truth["T_base_cam"][0][0] *= 1.01
    path = tmp_path / "truth.json"
    path.write_text(json.dumps(truth))
    example = EXAMPLES / "example_eye_to_hand.csv"
    code = main(["calibrate", str(example), "--setup", "eye-to-hand", "--truth", str(path)])
    err = capsys.readouterr().err
    assert code == 2 and "truth.json, T_base_cam" in err and "not a rotation" in err, err


# ------------------------------------------------------------------ the dataset


def _meta(**intrinsics) -> dict:
    K = [[120.0, 0.0, 80.0], [0.0, 120.0, 60.0], [0.0, 0.0, 1.0]]
    intr = {"K": K, "dist": [0.0] * 5, "width": 160, "height": 120, **intrinsics}
    return {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "robot": "ur5e",
        "intrinsics": intr,
        "depth": {"scale_m": 1e-4},
        "n_joints": 6,
        "cameras": 2,
    }


def _cameras(root: Path, x_cell: str = "0.5", bom: bool = False) -> Path:
    rows = [",".join(CAMERA_COLUMNS)]
    for k, x in enumerate([x_cell, "0.25"]):
        rows.append(f"{k},0,train,10,20,1.5,{x},0.1,0.9,0,0,0,1")
    path = root / "cameras.csv"
    path.write_text(("\ufeff" if bom else "") + "\n".join(rows) + "\n")
    return path


def test_cameras_table_with_a_byte_order_mark_reads(tmp_path):
    _cameras(tmp_path, bom=True)
    assert read_table(tmp_path / "cameras.csv", CAMERA_COLUMNS)["camera_id"].tolist() == [0, 1]


@pytest.mark.parametrize(
    "cell, expect",
    [
        ("1_000", "row 2 column T_base_cam_true.x: '1_000' is not a number ('_' digit separators"),
        ("\u0661", "row 2 column T_base_cam_true.x: '\u0661' is not a number (digits other than ASCII"),
        ("inf", "row 2 column T_base_cam_true.x: 'inf' is not finite"),
    ],
)
def test_cameras_table_refuses_absurd_truth_cells_naming_row_and_column(tmp_path, cell, expect):
    path = _cameras(tmp_path, cell)
    with pytest.raises(DatasetError) as info:
        read_table(path, CAMERA_COLUMNS)
    _one_line(info, "cameras.csv", expect)


def test_dataset_refuses_a_translation_over_100_m_naming_row_and_column(tmp_path):
    (tmp_path / "meta.json").write_text(json.dumps(_meta()))
    _cameras(tmp_path, "1000")
    assert read_table(tmp_path / "cameras.csv", CAMERA_COLUMNS)["T_base_cam_true.x"][0] == 1000  # a number
    with pytest.raises(DatasetError) as info:
        Dataset.open(tmp_path).truth()  # but no robot cell's translation
    _one_line(info, "cameras.csv: row 2 column T_base_cam_true.x: 1000 m is absurd for a translation (over 100 m)")


def test_a_fifo_is_named_as_such(tmp_path):
    fifo = tmp_path / "cameras.csv"
    os.mkfifo(fifo)
    with pytest.raises(DatasetError) as info:
        read_table(fifo, CAMERA_COLUMNS)  # checked before it is opened: a FIFO would block
    _one_line(info, "cameras.csv: a FIFO (named pipe), not a file")
    start = tmp_path / "start.json"
    os.mkfifo(start)
    with pytest.raises(HandEyeInputError) as info:
        read_start(start)
    _one_line(info, "start.json: a FIFO (named pipe), not a file")
    os.mkfifo(tmp_path / "meta.json")
    with pytest.raises(DatasetError) as info:
        Dataset.open(tmp_path)
    _one_line(info, "meta.json: a FIFO (named pipe), not a file")
    with pytest.raises(DatasetError) as info:
        read_table("/dev/null", CAMERA_COLUMNS)
    _one_line(info, "/dev/null: a character device, not a file")


@pytest.mark.parametrize(
    "K, expect",
    [
        ("NaN", "'NaN' is not a finite number"),
        ('"nan"', "intrinsics.K: 'nan' is not a finite number"),
        ("1e-300", "intrinsics.K: fx = 1e-300 px is no camera's"),
    ],
)
def test_meta_camera_matrix_is_checked_where_it_is_read(tmp_path, K, expect):
    text = json.dumps(_meta()).replace('"K": [[120.0', f'"K": [[{K}', 1)
    (tmp_path / "meta.json").write_text(text)
    with pytest.raises(DatasetError) as info:
        Dataset.open(tmp_path)
    _one_line(info, "meta.json", expect)


def test_a_valid_meta_and_table_open(tmp_path):
    (tmp_path / "meta.json").write_text(json.dumps(_meta()))
    _cameras(tmp_path)
    ds = Dataset.open(tmp_path)
    np.testing.assert_array_equal(ds.truth()[:, 0, 3], [0.5, 0.25])


# ------------------------------------------------------------------ --start


def test_start_zero_quaternion_is_called_one(tmp_path):
    path = tmp_path / "start.json"
    path.write_text(json.dumps({"translation_m": [0.1, 0.2, 0.9], "quaternion_xyzw": [0, 0, 0, 0]}))
    with pytest.raises(HandEyeInputError) as info:
        read_start(path)
    _one_line(info, "start.json", "zero quaternion")
    path.write_text(json.dumps({"translation_m": ["0_1", 0.2, 0.9], "quaternion_xyzw": [0, 0, 0, 1]}))
    with pytest.raises(HandEyeInputError) as info:
        read_start(path)
    _one_line(info, "start.json: translation_m", "'0_1'")
    path.write_text(json.dumps({"translation_m": [0.1, 0.2, 0.9], "quaternion_xyzw": [0, 0, 0, 1]}))
    np.testing.assert_array_equal(read_start(path)[:3, 3], [0.1, 0.2, 0.9])


# ------------------------------------------------------------------ vision files


@pytest.mark.parametrize(
    "field, value, expect",
    [
        ("squares_x", '"0_7"', "squares_x: '0_7' is not an integer"),
        ("squares_x", "7.5", "squares_x: 7.5 is not a whole number"),
        ("square_length_m", '"\uff10.03"', "square_length_m: '\uff10.03' is not a number"),
        ("square_length_m", "true", "square_length_m: True is a boolean"),
    ],
)
def test_board_file_refuses_numbers_python_would_take(tmp_path, field, value, expect):
    from classic.vision.board import BoardSpec, BoardSpecError

    doc = {"kind": "checkerboard", "squares_x": 7, "squares_y": 5, "square_length_m": 0.03}
    path = tmp_path / "board.json"
    path.write_text(json.dumps(doc).replace(f'"{field}": {json.dumps(doc[field])}', f'"{field}": {value}'))
    with pytest.raises(BoardSpecError) as info:
        BoardSpec.load(path)
    _one_line(info, "board.json", expect)
    assert str(info.value).count("board.json") == 1


def test_intrinsics_file_refuses_a_string_number_python_would_take(tmp_path):
    from classic.vision.camera import CameraIntrinsics, IntrinsicsError

    path = tmp_path / "camera.json"
    good = {"K": [[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]], "dist": [0] * 5, "width": 640, "height": 480}
    path.write_text(json.dumps(good))
    assert CameraIntrinsics.load(path).K[0, 0] == 600.0
    path.write_text(json.dumps({**good, "K": [["6_00", 0, 320], [0, 600.0, 240], [0, 0, 1]]}))
    with pytest.raises(IntrinsicsError) as info:
        CameraIntrinsics.load(path)
    _one_line(info, "camera.json", "'6_00' is not a number")
    path.write_text(json.dumps({**good, "width": "６４０"}))
    with pytest.raises(IntrinsicsError) as info:
        CameraIntrinsics.load(path)
    _one_line(info, "camera.json", "width", "not an integer")


@pytest.mark.parametrize("bad", ["0612", "0x264"])
def test_camera_yaml_refuses_integers_opencv_reads_in_another_base(tmp_path, bad):
    from classic.vision.camera import CameraIntrinsics, IntrinsicsError

    path = tmp_path / "camera_info.yaml"
    text = (DATA / "camera_info.yaml").read_text()
    assert "data: [612.5," in text
    path.write_text(text.replace("data: [612.5,", f"data: [{bad},"))
    with pytest.raises(IntrinsicsError) as info:  # OpenCV alone reads 0612 as 394 and 0x264 as 612
        CameraIntrinsics.load(path)
    _one_line(info, "camera_info.yaml, line 7", f"'{bad}' is not a decimal number")


# ------------------------------------------------------------------ a shard's manifest (issue 40 items 11, 12)


def _shard(tmp_path: Path, frames) -> Path:
    shard = tmp_path / "cam_0000"
    shard.mkdir()
    (shard / "frames.csv").write_text("camera_id\n0\n")
    doc = {"camera_id": 0, "frames": frames, "files": {"frames.csv": 12}}
    (shard / "manifest.json").write_text(json.dumps(doc))
    return shard


@pytest.mark.parametrize("frames", ["all", [3], {"data": "3"}, {"data": True}])
def test_a_manifest_whose_frame_counts_are_not_counts_is_damaged(tmp_path, frames):
    from handeye.core.dataset import shard_is_complete

    (tmp_path / "good").mkdir()
    assert shard_is_complete(_shard(tmp_path / "good", {"data": 1})) == (True, "")  # the same shard, counts right
    ok, why = shard_is_complete(_shard(tmp_path, frames))
    assert not ok and "'frames'" in why and "damaged manifest" in why


def test_a_fifo_listed_in_the_manifest_is_named_as_such(tmp_path):
    from handeye.core.dataset import shard_is_complete

    shard = _shard(tmp_path, {"data": 1})
    (shard / "frames.csv").unlink()
    os.mkfifo(shard / "frames.csv")
    ok, why = shard_is_complete(shard)
    assert not ok and why == f"{shard / 'frames.csv'}: a FIFO (named pipe), not a file"
