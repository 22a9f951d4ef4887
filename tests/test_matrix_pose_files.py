"""Pose files real cells write: OpenCV FileStorage pose pairs (camodocal), matrix text files, camera frames.

Noise-free synthetic poses written in each format are read back to the truth and calibrate to the true
X and Y (``EXACT``); OpenCV's own ``cv2.FileStorage`` writes the YAML (an outside reference for the
parser); every malformed file is refused with the file, the line or key, and the cause.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import classic
from handeye.checked_poses import load_poses
from handeye.cli import main
from handeye.core.camera_frame import T_OPTICAL_BODY, camera_frame_looks_like_body, to_optical
from handeye.core.errors import PoseFileError
from handeye.core.matrix_poses import read_matrix_pose_pairs, read_pose_matrices
from handeye.core.opencv_pose_pairs import read_opencv_pose_pairs
from handeye.core.opencv_yaml import parse_opencv_yaml
from handeye.core.posefile import read_pose_file
from handeye.core.se3 import invert_transform
from handeye.core.synthetic import make_problem
from tests.tolerances import EXACT, PRINTED_SIX_DECIMALS

cv2 = pytest.importorskip("cv2")
DATA = Path(__file__).resolve().parent / "data"


@pytest.fixture
def problem():
    return make_problem(8, "eye_to_hand", np.random.default_rng(3))


def _write_camodocal(path, T1, T2, count=None):
    """Pairs as camodocal's writeTransformPairsToFile writes them: cv::FileStorage, frameCount, T1_i, T2_i."""
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("frameCount", len(T1) if count is None else count)
    for i, (a, b) in enumerate(zip(T1, T2)):
        fs.write(f"T1_{i}", np.ascontiguousarray(a))
        fs.write(f"T2_{i}", np.ascontiguousarray(b))
    fs.release()


def _body(T_cam_target):
    """The same target poses in the ROS body frame: T_body_target = T_optical_body^-1 T_optical_target."""
    return invert_transform(T_OPTICAL_BODY) @ T_cam_target


def test_camodocal_pairs_read_to_the_truth_and_calibrate(tmp_path, problem):
    path = tmp_path / "TransformPairsInput.yml"
    _write_camodocal(path, problem.T_base_ee, problem.T_cam_target)
    assert path.read_text().startswith("%YAML:1.0")
    poses = load_poses(path, "eye_to_hand")  # the command's reader: sniffs %YAML:1.0 among YAML files
    np.testing.assert_allclose(poses.T_base_ee, problem.T_base_ee, atol=EXACT)
    np.testing.assert_allclose(poses.T_cam_target, problem.T_cam_target, atol=EXACT)
    assert poses.rows[0] == 4  # %YAML:1.0, ---, frameCount, then T1_0
    res = classic.calibrate(
        poses.T_base_ee, poses.T_cam_target, setup="eye_to_hand", options=classic.CalibrateOptions(refine=False)
    )
    np.testing.assert_allclose(res.X, problem.X_true, atol=EXACT)
    np.testing.assert_allclose(res.Y, problem.Y_true, atol=EXACT)


def test_parser_agrees_with_opencv_on_the_subset(tmp_path):
    """cv2.FileStorage writes ints, reals, strings, sequences, nested maps and matrices; both read the same."""
    path = tmp_path / "mixed.yml"
    M = np.arange(12, dtype=float).reshape(3, 4) / 7.0
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("count", 3)
    fs.write("scale", 0.125)
    fs.write("name", "camera two")
    fs.write("M", M)
    fs.write("I", np.eye(2, dtype=np.int32))
    fs.startWriteStruct("nested", cv2.FileNode_MAP)
    fs.write("inner", 2.5)
    fs.endWriteStruct()
    fs.startWriteStruct("list", cv2.FileNode_SEQ)
    for v in (1.5, 2.5, 3.5):
        fs.write("", v)
    fs.endWriteStruct()
    fs.release()
    doc = parse_opencv_yaml(path.read_text(), str(path))
    ref = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    assert doc["count"] == int(ref.getNode("count").real()) == 3
    assert doc["scale"] == ref.getNode("scale").real()
    assert doc["name"] == ref.getNode("name").string()
    np.testing.assert_array_equal(doc["M"], ref.getNode("M").mat())
    np.testing.assert_array_equal(doc["I"], ref.getNode("I").mat())
    assert doc["nested"]["inner"] == ref.getNode("nested").getNode("inner").real()
    assert list(doc["list"]) == [ref.getNode("list").at(k).real() for k in range(3)]
    ref.release()


def test_shipped_example_reads(tmp_path):
    """tests/data/camodocal_pairs.yml: written by hand in camodocal's layout (see tests/data/README.md)."""
    poses = read_pose_file(DATA / "camodocal_pairs.yml")
    assert poses.T_base_ee.shape == (3, 4, 4)
    np.testing.assert_allclose(poses.T_base_ee[1, :3, 3], [0.5, 0.0, 0.4], atol=EXACT)
    np.testing.assert_allclose(poses.T_cam_target[2, :3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=EXACT)


@pytest.mark.parametrize(
    "edit,message",
    [
        (lambda t: t.replace("frameCount: 8", "frameCount: 9"), "frameCount is 9 but T1_8 is missing"),
        (lambda t: t.replace("frameCount: 8", "frameCount: 7"), "frameCount is 7 but the file holds T1_7"),
        (lambda t: t.replace("rows: 4", "rows: 3", 1), "rows x cols = 3 x 4 = 12, but data holds 16"),
        (lambda t: t.replace("data: [ ", "data: [ 0., ", 1), "data holds 17 numbers"),
        (lambda t: t.replace("T2_3: !!opencv-matrix", "T2_3:"), "T2_3: not an !!opencv-matrix"),
        (lambda t: t.replace("dt: d", "dt: 3d", 1), "dt '3d' is not a one-channel number type"),
        (lambda t: t.replace("data: [", "data: ", 1), "indented more than the keys above it"),
        (lambda t: t.replace("]", "", 1), "a '[' list that is never closed"),
        (lambda t: t.replace("%YAML:1.0", "%YAML:1.0\n\tframeCount: 8"), "a tab in the indentation"),
    ],
)
def test_camodocal_malformed_files_name_line_and_cause(tmp_path, problem, edit, message):
    good = tmp_path / "good.yml"
    _write_camodocal(good, problem.T_base_ee, problem.T_cam_target)
    path = tmp_path / "bad.yml"
    path.write_text(edit(good.read_text()))
    with pytest.raises(PoseFileError, match=r"bad\.yml, line \d+") as info:
        read_opencv_pose_pairs(path)
    assert message in str(info.value)


def test_camodocal_without_frame_count(tmp_path, problem):
    """frameCount is what camodocal reads, but the keys say it too."""
    path = tmp_path / "pairs.yml"
    _write_camodocal(path, problem.T_base_ee, problem.T_cam_target)
    path.write_text(path.read_text().replace("frameCount: 8\n", ""))
    np.testing.assert_allclose(read_opencv_pose_pairs(path).T_cam_target, problem.T_cam_target, atol=EXACT)


@pytest.mark.parametrize(
    "change,message",
    [
        (lambda T: T.__setitem__((2, 0, 0), np.nan), "NaN or infinity"),
        (lambda T: T.__setitem__((2, slice(0, 3), slice(0, 3)), 1.01 * T[2, :3, :3]), "not a rotation"),
        (lambda T: T.__setitem__((2, slice(0, 3), 0), -T[2, :3, 0]), "a reflection"),
        (lambda T: T.__setitem__((2, 3, 0), 0.5), "not [0, 0, 0, 1]"),
        (lambda T: T.__setitem__((slice(None), slice(0, 3), 3), 1000 * T[:, :3, 3]), "look like millimetres"),
    ],
)
def test_camodocal_bad_matrices_are_named(tmp_path, problem, change, message):
    T1 = problem.T_base_ee.copy()
    change(T1)
    path = tmp_path / "pairs.yml"
    _write_camodocal(path, T1, problem.T_cam_target)
    with pytest.raises(PoseFileError, match=r"pairs\.yml, line \d+, T1_\d") as info:
        read_opencv_pose_pairs(path)
    assert message in str(info.value)


def test_millimetres_read_with_units(tmp_path, problem):
    T1, T2 = problem.T_base_ee.copy(), problem.T_cam_target.copy()
    T1[:, :3, 3] *= 1000
    T2[:, :3, 3] *= 1000
    path = tmp_path / "pairs.yml"
    _write_camodocal(path, T1, T2)
    poses = read_opencv_pose_pairs(path, units="mm")
    np.testing.assert_allclose(poses.T_base_ee, problem.T_base_ee, atol=EXACT)


# ---- the camera frame ------------------------------------------------------------------------------------


def test_body_frame_is_refused_then_converted(tmp_path, problem):
    """camodocal's default cameraTF is camera_link: the targets lie along +x. Refused, then read with the fix."""
    path = tmp_path / "pairs.yml"
    _write_camodocal(path, problem.T_base_ee, _body(problem.T_cam_target))
    with pytest.raises(PoseFileError, match="--camera-frame ros-body"):
        read_pose_file(path)
    poses = read_pose_file(path, camera_frame="ros-body")
    np.testing.assert_allclose(poses.T_cam_target, problem.T_cam_target, atol=EXACT)
    kept = read_pose_file(path, camera_frame="optical")  # the user's word: taken as is
    np.testing.assert_allclose(kept.T_cam_target, _body(problem.T_cam_target), atol=EXACT)


@pytest.mark.parametrize("motion", ["random", "structured", "one_axis", "translation_only"])
@pytest.mark.parametrize("seed", range(5))
def test_body_frame_detection_on_every_motion(motion, seed):
    """Optical poses are never taken for body ones, and the same poses in the body frame always are."""
    p = make_problem(10, "eye_in_hand", np.random.default_rng(seed), motion=motion, camera_noise=(0.5, 5.0))
    assert not camera_frame_looks_like_body(p.T_cam_target)
    assert camera_frame_looks_like_body(_body(p.T_cam_target))


def test_optical_from_body_axes():
    """x_opt = -y_body, y_opt = -z_body, z_opt = x_body: a point 1 m ahead (body x) is 1 m along optical z."""
    T_body_target = np.eye(4)[None].copy()
    T_body_target[0, :3, 3] = [1.0, 0.2, 0.1]
    np.testing.assert_allclose(to_optical(T_body_target, "ros-body")[0, :3, 3], [-0.2, -0.1, 1.0], atol=EXACT)


def test_csv_in_body_frame_is_refused_by_the_command(tmp_path, problem, capsys):
    from handeye.core.posefile import write_pose_csv

    path = tmp_path / "poses.csv"
    write_pose_csv(path, problem.T_base_ee, _body(problem.T_cam_target))
    assert main(["calibrate", str(path), "--setup", "eye-to-hand"]) != 0
    assert "--camera-frame ros-body" in capsys.readouterr().err
    assert main(["calibrate", str(path), "--setup", "eye-to-hand", "--camera-frame", "ros-body"]) == 0


# ---- text files of 4x4 matrices ----------------------------------------------------------------------------


def _rows16(T, sep="\t"):
    return "".join(sep.join(f"{v:.17g}" for v in M.ravel()) + "\n" for M in T)


def _blocks(T, blank=True, count=False):
    out = [f"{len(T)}\n"] if count else []
    for M in T:
        out.append("".join(" ".join(f"{v:.17g}" for v in row) + "\n" for row in M) + ("\n" if blank else ""))
    return "".join(out)


@pytest.mark.parametrize(
    "writer",
    [
        _rows16,
        lambda T: _rows16(T, sep=", "),
        lambda T: "".join(" ".join(f"{v:.17g}" for v in M[:3].ravel()) + "\n" for M in T),  # 12 a line
        _blocks,
        lambda T: _blocks(T, blank=False),
        lambda T: "# robot poses\n" + _blocks(T, count=True),
    ],
    ids=["16-tab", "16-comma", "12", "4-lines-blank", "4-lines", "count-first"],
)
def test_matrix_files_read_to_the_truth(tmp_path, problem, writer):
    robot, camera = tmp_path / "robot.txt", tmp_path / "camera.txt"
    robot.write_text(writer(problem.T_base_ee))
    camera.write_text(writer(problem.T_cam_target))
    poses = read_matrix_pose_pairs(robot, camera)
    np.testing.assert_allclose(poses.T_base_ee, problem.T_base_ee, atol=EXACT)
    np.testing.assert_allclose(poses.T_cam_target, problem.T_cam_target, atol=EXACT)


def test_inverse_files_and_millimetres(tmp_path, problem):
    """Tabb's robot_cali.txt: T_ee_base in millimetres, printed to 6 decimals, 4 lines a matrix after a count."""
    T_ee_base = invert_transform(problem.T_base_ee)
    T_ee_base[:, :3, 3] *= 1000
    text = f"{len(T_ee_base)}\n" + "\n".join(
        "".join(" ".join(f"{v:.6f}" for v in row) + "\n" for row in M) for M in T_ee_base
    )
    robot = tmp_path / "robot_cali.txt"
    robot.write_text(text)
    with pytest.raises(PoseFileError, match=r"robot_cali\.txt, line \d+: .*look like millimetres.*--units mm"):
        read_pose_matrices(robot)
    T, lines = read_pose_matrices(robot, units="mm", invert=True)
    assert lines[:2] == [2, 7]
    # six decimals: rotation entries within 5e-7, translations within 5e-7 mm, before the inverse's lever arm
    np.testing.assert_allclose(T, problem.T_base_ee, atol=PRINTED_SIX_DECIMALS)


@pytest.mark.parametrize(
    "text,message",
    [
        ("1 0 0 0\n0 1 0 0\n0 0 1 0\n\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", "line 1: a matrix of 3 line(s)"),
        ("3\n" + "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n" * 2, "line 1: the file says 3 matrices but holds 2"),
        ("1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n1 0 0 0 0 1 0 0 0 0 1 x 0 0 0 1\n", "line 2: 'x' is not a number"),
        ("1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n1 0 0 0 0 1 0 0 0 0 1 0 0 0 0\n", "line 2: 15 numbers"),
        ("1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 nan\n", "line 2: 'nan' is not a finite"),
        ("1 0 0 0 0 1 0 0 0 0 2 0 0 0 0 1\n", "line 1: the rotation block is not a rotation"),
        ("", "no numbers"),
        ("0\n", "line 1: the file says 0 matrices and holds none after it"),
        ("# robot poses\n3\n\n", "line 2: the file says 3 matrices and holds none after it"),
    ],
)
def test_matrix_file_errors_name_line_and_cause(tmp_path, text, message):
    path = tmp_path / "poses.txt"
    path.write_text(text)
    with pytest.raises(PoseFileError, match=r"poses\.txt") as info:
        read_pose_matrices(path)
    assert message in str(info.value)


def test_matrix_files_of_different_counts(tmp_path, problem):
    robot, camera = tmp_path / "robot.txt", tmp_path / "camera.txt"
    robot.write_text(_rows16(problem.T_base_ee))
    camera.write_text(_rows16(problem.T_cam_target[:-1]))
    with pytest.raises(PoseFileError, match="8 robot poses, .*camera.txt 7 camera poses"):
        read_matrix_pose_pairs(robot, camera)


def test_command_takes_two_matrix_files(tmp_path, problem, capsys):
    robot, camera = tmp_path / "robot.txt", tmp_path / "camera.txt"
    T_ee_base = invert_transform(problem.T_base_ee)
    T_ee_base[:, :3, 3] *= 1000
    robot.write_text(_rows16(T_ee_base))
    T_cam_target = problem.T_cam_target.copy()
    T_cam_target[:, :3, 3] *= 1000
    camera.write_text(_rows16(T_cam_target))
    out = tmp_path / "result.json"
    args = ["calibrate", "--robot-poses", str(robot), "--camera-poses", str(camera), "--setup", "eye-to-hand"]
    rc = main([*args, "--units", "mm", "--robot-inverse", "--no-refine", "-o", str(out)])
    assert rc == 0, capsys.readouterr().err
    import json

    doc = json.loads(out.read_text())
    np.testing.assert_allclose(np.asarray(doc["T_base_cam"]["matrix"]), problem.X_true, atol=EXACT)
    assert main([*args, "--units", "mm"]) != 0  # read as T_base_ee, the poses fit no hand-eye model
    assert main(["calibrate", "--camera-poses", str(camera), "--setup", "eye-to-hand"]) != 0
    assert "give --camera-poses with --robot-poses" in capsys.readouterr().err


def test_report_of_two_matrix_files_names_both(tmp_path, problem, capsys):
    """The HTML report of a calibration from two matrix files names them (it said 'pose file None')."""
    robot, camera = tmp_path / "robot.txt", tmp_path / "camera.txt"
    robot.write_text(_rows16(problem.T_base_ee))
    camera.write_text(_rows16(problem.T_cam_target))
    report = tmp_path / "report"
    args = ["calibrate", "--robot-poses", str(robot), "--camera-poses", str(camera), "--setup", "eye-to-hand"]
    assert main([*args, "--report", str(report)]) == 0, capsys.readouterr().err
    html = (report / "index.html").read_text()
    assert "pose file None" not in html
    assert f"pose files {robot} (robot) and {camera} (camera)" in html
