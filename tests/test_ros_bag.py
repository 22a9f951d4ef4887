"""ROS 2 bags: tf chained to T_base_ee, marker poses and images read, pairing by time, the bag-poses command.

Each bag is written here with rosbags' own writer (sqlite3 and MCAP storage) from a synthetic problem
with a known answer, so the extracted poses are compared with what was written and the calibration
with its truth.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

import classic
from handeye.cli import main
from handeye.core.errors import (
    BagError,
    BagTopicError,
    FramesNotConnectedError,
    MissingDependencyError,
    NoPairsError,
    NotABagError,
)
from handeye.core.posefile import read_pose_file
from handeye.core.se3 import (
    invert_transform,
    make_transform,
    pos_quat_xyzw_from_transform,
    so3_exp,
    transform_from_pos_quat_xyzw,
)
from handeye.core.synthetic import make_problem, random_rotations
from handeye.ros_bag import read_bag, read_images
from handeye.tf_tree import TfTree
from handeye.time_pairing import pair_by_time
from tests.tolerances import ABSOLUTE_ONLY, EXACT, FLOAT

pytest.importorskip("rosbags")
from rosbags.rosbag2 import StoragePlugin, Writer  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

TS = get_typestore(Stores.ROS2_HUMBLE)
M = TS.types
STORAGES = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}
EPOCH_NS = 1_700_000_000 * 10**9  # header stamps on a wall clock
MS = 1_000_000


def _header(stamp_ns: int, frame: str):
    return M["std_msgs/msg/Header"](M["builtin_interfaces/msg/Time"](stamp_ns // 10**9, stamp_ns % 10**9), frame)


def _transform(stamp_ns: int, parent: str, child: str, T: np.ndarray):
    t, q = pos_quat_xyzw_from_transform(T)
    tr = M["geometry_msgs/msg/Transform"](M["geometry_msgs/msg/Vector3"](*t), M["geometry_msgs/msg/Quaternion"](*q))
    return M["geometry_msgs/msg/TransformStamped"](_header(stamp_ns, parent), child, tr)


def _pose_stamped(stamp_ns: int, frame: str, T: np.ndarray):
    t, q = pos_quat_xyzw_from_transform(T)
    pose = M["geometry_msgs/msg/Pose"](M["geometry_msgs/msg/Point"](*t), M["geometry_msgs/msg/Quaternion"](*q))
    return M["geometry_msgs/msg/PoseStamped"](_header(stamp_ns, frame), pose)


def _as_written(T: np.ndarray) -> np.ndarray:
    """The transform a reader gets back from the message: through its translation and quaternion."""
    return transform_from_pos_quat_xyzw(*pos_quat_xyzw_from_transform(T))


def _image(stamp_ns: int, encoding: str, pixels: np.ndarray, pad: int = 0):
    """A sensor_msgs/Image of ``pixels`` (H, W[, C]), rows padded by ``pad`` bytes."""
    h, w = pixels.shape[:2]
    rows = pixels.reshape(h, -1).view(np.uint8)
    data = np.concatenate([rows, np.zeros((h, pad), np.uint8)], axis=1).reshape(-1)
    return M["sensor_msgs/msg/Image"](
        _header(stamp_ns, "camera_optical_frame"), h, w, encoding, 0, rows.shape[1] + pad, data
    )


def _write(path, storage: str, messages: list) -> None:
    """``messages``: (topic, msgtype, log time ns, message), in any order."""
    with Writer(path, version=9, storage_plugin=STORAGES[storage]) as writer:
        conns = {}
        for topic, msgtype, log_ns, msg in sorted(messages, key=lambda m: m[2]):
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=TS)
            writer.write(conns[topic], log_ns, TS.serialize_cdr(msg, msgtype))


def _tf_messages(stamps_ns, T_base_ee, rng) -> tuple[list, np.ndarray, np.ndarray]:
    """/tf and /tf_static of a robot whose flange follows ``T_base_ee`` (M, 4, 4) at ``stamps_ns``.

    Chain: world -> base_link (static) -> shoulder (moving) -> wrist (moving) -> tool0 (static), a camera
    mount on the base (static) and a second tree map -> odom. Returns the messages, ``T_base_ee`` as
    the product of the chain's transforms as written, and ``T_base_mount`` as written.
    """
    T_wrist_tool0 = make_transform(random_rotations(rng, 1)[0], [0.0, 0.0, 0.08])
    T_base_shoulder = make_transform(
        so3_exp(np.outer(np.linspace(0, 2.0, len(stamps_ns)), [0, 0, 1])), [0.0, 0.0, 0.09]
    )
    T_shoulder_wrist = invert_transform(T_base_shoulder) @ T_base_ee @ invert_transform(T_wrist_tool0)
    tf = "tf2_msgs/msg/TFMessage"
    T_base_mount = make_transform(random_rotations(rng, 1)[0], [0.5, 0.0, 1.0])
    static = [
        _transform(EPOCH_NS, "world", "base_link", make_transform(np.eye(3), [1.0, 2.0, 0.0])),
        _transform(EPOCH_NS, "wrist", "tool0", T_wrist_tool0),
        _transform(EPOCH_NS, "/base_link", "camera_mount", T_base_mount),  # a ROS 1 habit: leading slash
        _transform(EPOCH_NS, "map", "odom", np.eye(4)),
    ]
    msgs = [("/tf_static", tf, EPOCH_NS - 5 * MS, M[tf](static))]
    for s, A, B in zip(stamps_ns, T_base_shoulder, T_shoulder_wrist):  # robot_state_publisher: one stamp per message
        msgs.append(
            (
                "/tf",
                tf,
                int(s) + 3 * MS,
                M[tf]([_transform(int(s), "base_link", "shoulder", A), _transform(int(s), "shoulder", "wrist", B)]),
            )
        )
    composed = _as_written(T_base_shoulder) @ _as_written(T_shoulder_wrist) @ _as_written(T_wrist_tool0)
    return msgs, composed, _as_written(T_base_mount)


def write_exact_bag(path, storage: str) -> tuple:
    """A bag of an eye-to-hand problem at ``path``: robot at 100 Hz, the 12 camera poses at 12 of its stamps,
    2 outside (``/tf``, ``/tf_static``, ``/marker_pose``, ``/marker_tf``, ``/image``). Returns the path, the
    problem, the robot stamps, (T_base_ee as composed, T_base_mount), the camera stamps and the image pixels.
    """
    rng = np.random.default_rng(0)
    p = make_problem(12, "eye_to_hand", rng)
    cam_stamps = EPOCH_NS + 250 * MS + 500 * MS * np.arange(12)
    robot_stamps = np.arange(cam_stamps[0], cam_stamps[-1] + 1, 10 * MS)
    t = lambda s: (s - EPOCH_NS) * 1e-9  # noqa: E731
    T_robot = classic.RobotStream(t(cam_stamps), p.T_base_ee).at(t(robot_stamps))[0]
    T_robot[np.searchsorted(robot_stamps, cam_stamps)] = p.T_base_ee  # exactly the problem's poses there
    msgs, composed, T_base_mount = _tf_messages(robot_stamps, T_robot, rng)
    ps = "geometry_msgs/msg/PoseStamped"
    outside = [cam_stamps[0] - 1000 * MS, cam_stamps[-1] + 1000 * MS]  # no robot pose near these
    for s, B in zip(list(cam_stamps) + outside, list(p.T_cam_target) + [np.eye(4), np.eye(4)]):
        msgs.append(("/marker_pose", ps, int(s) + 30 * MS, _pose_stamped(int(s), "camera_optical_frame", B)))
    for s, B in zip(cam_stamps[:4], p.T_cam_target):  # 4 poses as TransformStamped, 7 s later: the robot has stopped
        msgs.append(
            (
                "/marker_tf",
                "geometry_msgs/msg/TransformStamped",
                int(s) + 7000 * MS,
                _transform(int(s) + 7000 * MS, "camera_optical_frame", "board", B),
            )
        )
    img = "sensor_msgs/msg/Image"
    pix = rng.integers(0, 256, (2, 5, 4, 3), dtype=np.uint8)
    depth = rng.integers(0, 65535, (5, 4), dtype=np.uint16)
    msgs += [
        ("/image", img, int(cam_stamps[1]), _image(int(cam_stamps[1]), "rgb8", pix[0], pad=4)),
        ("/image", img, int(cam_stamps[0]), _image(int(cam_stamps[0]), "bgr8", pix[1])),
        ("/image", img, int(cam_stamps[2]), _image(int(cam_stamps[2]), "mono8", pix[0, ..., 0], pad=3)),
        ("/image", img, int(cam_stamps[3]), _image(int(cam_stamps[3]), "16UC1", depth)),
    ]
    _write(path, storage, msgs)
    return path, p, robot_stamps, (composed, T_base_mount), cam_stamps, (pix, depth)


@pytest.fixture(scope="module", params=list(STORAGES))
def exact_bag(request, tmp_path_factory):
    """:func:`write_exact_bag` in each storage."""
    return write_exact_bag(tmp_path_factory.mktemp(request.param) / "recording", request.param)


def test_tf_chain_is_the_written_chain_composed(exact_bag):
    path, _, robot_stamps, (composed, T_base_mount), _, _ = exact_bag
    rec = read_bag(path, "base_link", "tool0")
    assert rec.frames == ["base_link", "shoulder", "wrist", "tool0"]
    np.testing.assert_array_equal(np.round(rec.robot_times_s * 1e9).astype(np.int64) + rec.origin_ns, robot_stamps)
    np.testing.assert_allclose(rec.T_base_ee, composed, rtol=ABSOLUTE_ONLY, atol=FLOAT)
    # up to the common ancestor and down: the camera mount in the tool frame; the storage file opens the bag too
    storage_file = next(f for f in path.iterdir() if f.suffix in (".db3", ".mcap"))
    up = read_bag(storage_file, "tool0", "camera_mount")
    assert up.frames == ["tool0", "wrist", "shoulder", "base_link", "camera_mount"]
    np.testing.assert_allclose(up.T_base_ee, invert_transform(composed) @ T_base_mount, rtol=ABSOLUTE_ONLY, atol=FLOAT)


def test_pairs_within_the_tolerance_recover_the_truth(exact_bag):
    path, p, _, _, cam_stamps, _ = exact_bag
    rec = read_bag(path, "base_link", "tool0", marker_topic="/marker_pose")
    assert rec.camera_frame == "camera_optical_frame" and len(rec.T_cam_target) == 14
    pairs = rec.pair(tolerance_s=0.01)
    assert (pairs.kept, pairs.dropped) == (12, 2)
    np.testing.assert_array_equal(pairs.dropped_index, [0, 13])  # sorted by stamp: the two outside
    np.testing.assert_array_equal(pairs.gap_s, 0.0)
    np.testing.assert_allclose(pairs.T_base_ee, p.T_base_ee, rtol=ABSOLUTE_ONLY, atol=FLOAT)
    np.testing.assert_allclose(pairs.T_cam_target, _as_written(p.T_cam_target), rtol=ABSOLUTE_ONLY, atol=FLOAT)
    res = classic.calibrate(pairs.T_base_ee, pairs.T_cam_target, setup="eye_to_hand")
    np.testing.assert_allclose(res.T_base_cam, p.X_true, rtol=ABSOLUTE_ONLY, atol=EXACT)
    np.testing.assert_allclose(res.T_ee_target, p.Y_true, rtol=ABSOLUTE_ONLY, atol=EXACT)
    assert rec.pair(0.01, method="nearest").kept == 12


def test_pairing_keeps_only_robot_samples_within_the_tolerance():
    rng = np.random.default_rng(1)
    t_r = np.arange(0.0, 1.0001, 0.01)
    T_r = make_transform(so3_exp(np.outer(t_r, [0.3, -0.2, 1.0])), np.outer(t_r, [0.1, 0.2, 0.3]))
    t_c = np.array([0.004, 0.5, 0.503, 1.02, -0.003])
    B = make_problem(len(t_c), "eye_to_hand", rng).T_cam_target
    near = pair_by_time(t_r, T_r, t_c, B, tolerance_s=0.005, method="nearest")
    np.testing.assert_array_equal(near.camera_index, [0, 1, 2, 4])  # 1.02 is 0.02 s past the last sample
    np.testing.assert_array_equal(near.dropped_index, [3])
    np.testing.assert_array_equal(near.T_base_ee, T_r[[0, 50, 50, 0]])
    np.testing.assert_allclose(near.gap_s, [0.004, 0.0, 0.003, 0.003], atol=FLOAT)
    assert pair_by_time(t_r, T_r, t_c, B, tolerance_s=0.0035, method="nearest").kept == 3
    interp = pair_by_time(t_r, T_r, t_c, B, tolerance_s=0.01)
    np.testing.assert_array_equal(interp.camera_index, [0, 1, 2])  # outside the recording: never extrapolated
    # the trajectory is a constant twist about a fixed axis: geodesic interpolation is exact on it
    w, v = np.array([0.3, -0.2, 1.0]), np.array([0.1, 0.2, 0.3])
    np.testing.assert_allclose(interp.T_base_ee[2], make_transform(so3_exp(0.503 * w), 0.503 * v), atol=FLOAT)
    np.testing.assert_array_equal(interp.T_cam_target, B[[0, 1, 2]])
    assert pair_by_time(t_r, T_r, t_c, B, tolerance_s=0.005).kept == 1  # both samples around must be within it
    # a dropout in the robot's stream (0.40-0.42 s missing) is not bridged by interpolation
    t_gap, T_gap = np.delete(t_r, [40, 41, 42]), np.delete(T_r, [40, 41, 42], axis=0)
    assert pair_by_time(t_gap, T_gap, [0.415], B[:1], 0.02, "nearest").kept == 1
    with pytest.raises(NoPairsError, match=r"none of 1 camera samples has a robot pose within 0.02 s \(interpolate\)"):
        pair_by_time(t_gap, T_gap, [0.415], B[:1], 0.02, source="somewhere")


def test_tf_edges_stamped_apart_are_interpolated_as_tf2_does():
    """Shoulder and wrist published at interleaved stamps, both constant twists: the chain is exact between."""
    s_sh = np.arange(0, 101, 10) * MS
    s_wr = np.arange(5, 96, 10) * MS
    w_sh, w_wr = np.array([0.0, 0.0, 2.0]), np.array([0.5, 1.0, 0.0])

    def pose(s, w, v):
        return make_transform(so3_exp(np.outer(s * 1e-9, w)), np.outer(s * 1e-9, v) + [0.1, 0, 0.3])

    T_sh, T_wr = pose(s_sh, w_sh, [1, 0, 0]), pose(s_wr, w_wr, [0, 1, 0])
    n_sh, n_wr = len(s_sh), len(s_wr)
    tree = TfTree.from_transforms(
        ["base"] * n_sh + ["shoulder"] * n_wr,
        ["shoulder"] * n_sh + ["wrist"] * n_wr,
        np.concatenate([s_sh, s_wr]),
        np.concatenate([T_sh, T_wr])[:, :3, 3],
        pos_quat_xyzw_from_transform(np.concatenate([T_sh, T_wr]))[1],
        np.zeros(n_sh + n_wr, bool),
    )
    chain = tree.chain("base", "wrist")
    expect = np.unique(np.concatenate([s_sh, s_wr]))
    expect = expect[(expect >= 5 * MS) & (expect <= 95 * MS)]
    np.testing.assert_array_equal(chain.stamps_ns, expect)
    np.testing.assert_allclose(
        chain.T_base_ee, pose(expect, w_sh, [1, 0, 0]) @ pose(expect, w_wr, [0, 1, 0]), atol=FLOAT
    )


@pytest.mark.parametrize("storage", list(STORAGES))
def test_time_offset_recovered_from_the_bag_streams(storage, tmp_path):
    """Camera stamps on a clock 37.1 ms behind the robot's: calibrate_stream finds the offset from the raw streams."""
    rng = np.random.default_rng(3)
    robot_stamps = EPOCH_NS + np.arange(0, 20_000, 10) * MS
    t_r = (robot_stamps - EPOCH_NS) * 1e-9
    f, ph = rng.uniform(0.2, 0.6, (2, 3)), rng.uniform(0, 2 * np.pi, (2, 3))
    T_r = make_transform(
        so3_exp(0.6 * np.sin(f[0] * t_r[:, None] + ph[0])), [0.5, 0.0, 0.4] + 0.15 * np.sin(f[1] * t_r[:, None] + ph[1])
    )
    msgs = _tf_messages(robot_stamps, T_r, rng)[0]
    p = make_problem(3, "eye_to_hand", rng)
    offset_s = 0.0371
    cam_stamps = EPOCH_NS + np.arange(1000, 19000, 100) * MS
    t_c = (cam_stamps - EPOCH_NS) * 1e-9
    B = invert_transform(p.X_true) @ classic.RobotStream(t_r, T_r).at(t_c + offset_s)[0] @ p.Y_true
    msgs += [
        ("/marker_pose", "geometry_msgs/msg/PoseStamped", int(s) + 30 * MS, _pose_stamped(int(s), "cam", Bi))
        for s, Bi in zip(cam_stamps, B)
    ]
    _write(tmp_path / "bag", storage, msgs)
    rec = read_bag(tmp_path / "bag", "base_link", "tool0", marker_topic="/marker_pose")
    res = classic.calibrate_stream(
        rec.robot_times_s, rec.T_base_ee, rec.camera_times_s, rec.T_cam_target, setup="eye_to_hand", max_offset_s=0.5
    )
    assert res.diagnostics["time_offset"]["value_s"] == pytest.approx(offset_s, abs=EXACT)
    np.testing.assert_allclose(res.X, p.X_true, rtol=ABSOLUTE_ONLY, atol=EXACT)


def test_images_decoded_with_their_stamps(exact_bag):
    path, _, _, _, cam_stamps, (pix, depth) = exact_bag
    bgr = read_images(path, "/image")
    np.testing.assert_array_equal(np.round(bgr.times_s * 1e9).astype(np.int64) + bgr.origin_ns, cam_stamps[:4])
    assert bgr.encodings == ["bgr8", "rgb8", "mono8", "16UC1"] and bgr.frame_id == "camera_optical_frame"
    np.testing.assert_array_equal(bgr.images[0], pix[1])
    np.testing.assert_array_equal(bgr.images[1], pix[0][..., ::-1])
    np.testing.assert_array_equal(bgr.images[2], pix[0, ..., 0])
    assert bgr.images[3].dtype == np.uint16
    np.testing.assert_array_equal(bgr.images[3], depth)
    rgb = read_images(path, "/image", order="rgb", every=2)
    assert len(rgb.images) == 2
    np.testing.assert_array_equal(rgb.images[0], pix[1][..., ::-1])


def test_bad_input_raises_named_errors(exact_bag, tmp_path):
    path, p = exact_bag[:2]
    with pytest.raises(
        BagTopicError, match=r"recording: no topic '/nope'; the bag has: .*/marker_pose \(PoseStamped\)"
    ):
        read_bag(path, "base_link", "tool0", marker_topic="/nope")
    with pytest.raises(BagTopicError, match="topic '/image' holds sensor_msgs/msg/Image; expected geometry_msgs"):
        read_bag(path, "base_link", "tool0", marker_topic="/image")
    with pytest.raises(
        FramesNotConnectedError,
        match="frames 'base_link' and 'odom' are not connected in the tf tree; "
        "frames reachable from 'base_link': base_link, camera_mount, shoulder, tool0, world, wrist",
    ):
        read_bag(path, "base_link", "odom")
    with pytest.raises(FramesNotConnectedError, match=r"recording, /tf and /tf_static: frame 'tool1' not in the tf"):
        read_bag(path, "base_link", "tool1")
    late = read_bag(path, "base_link", "tool0", marker_topic="/marker_tf")
    np.testing.assert_allclose(late.T_cam_target, _as_written(p.T_cam_target[:4]), rtol=ABSOLUTE_ONLY, atol=FLOAT)
    with pytest.raises(NoPairsError, match=r"recording, /marker_tf with tf: none of 4 camera samples"):
        late.pair(0.01)
    with pytest.raises(BagError, match="base_link -> camera_mount holds only static transforms"):
        read_bag(path, "base_link", "camera_mount")
    (tmp_path / "notes.txt").write_text("not a bag")
    (tmp_path / "empty").mkdir()
    for bad, why in [
        (tmp_path / "notes.txt", "not a ROS 2 bag"),
        (tmp_path / "empty", "not a ROS 2 bag"),
        (tmp_path / "missing", "no such file"),
        (tmp_path / "old.bag", "a ROS 1 bag"),
    ]:
        if bad.suffix == ".bag":
            bad.write_bytes(b"#ROSBAG V2.0\n")
        with pytest.raises(NotABagError, match=why):
            read_bag(bad, "base_link", "tool0")


def test_bag_poses_command_writes_what_calibrate_reads(exact_bag, tmp_path, capsys):
    path, p = exact_bag[:2]
    out = tmp_path / "poses.csv"
    assert (
        main(
            [
                "bag-poses",
                str(path),
                "--base",
                "base_link",
                "--ee",
                "tool0",
                "--marker-topic",
                "/marker_pose",
                "--tolerance",
                "0.01",
                "-o",
                str(out),
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "pairs: 12 kept" in printed and "2 dropped" in printed
    assert "base_link -> shoulder -> wrist -> tool0" in printed
    poses = read_pose_file(out)
    np.testing.assert_allclose(poses.T_base_ee, p.T_base_ee, rtol=ABSOLUTE_ONLY, atol=EXACT)
    np.testing.assert_allclose(poses.T_cam_target, p.T_cam_target, rtol=ABSOLUTE_ONLY, atol=EXACT)
    assert main(["calibrate", str(out), "--setup", "eye-to-hand"]) == 0
    assert (
        main(
            ["bag-poses", str(tmp_path), "--base", "base_link", "--ee", "tool0", "--marker-topic", "/m", "-o", str(out)]
        )
        == 2
    )
    assert "not a ROS 2 bag" in capsys.readouterr().err


def test_without_rosbags_the_error_names_the_extra(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "rosbags", None)
    with pytest.raises(MissingDependencyError, match=r'pip install "handeye\[ros\]"'):
        read_bag(tmp_path, "base_link", "tool0")
