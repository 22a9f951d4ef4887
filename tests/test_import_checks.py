"""``handeye import``: recordings in the wrong unit, impossible joints and intrinsics, corrupt storage refused.

Each recording is a bag (or folder) of four 8x6 frames written here with ``rosbags``: a flat depth of
0.812 m, UR5 joint states stamped with the frames, the colour camera's ``camera_info``. One field at a time
is made wrong (millimetres in 32FC1, degrees in the joints, fx = 1e-300, a corrupt MCAP record, ...) and
the import must refuse it in one line naming the file or topic, the frame and the field; the same
recording with the field right (or the option that says its unit) imports the truth.
"""

from __future__ import annotations

import errno
import json
import os
import socket
import struct
import tracemalloc
from types import SimpleNamespace

import numpy as np
import pytest

pytest.importorskip("rosbags")
pytest.importorskip("pinocchio")

from rosbags.rosbag2 import StoragePlugin, Writer  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

from classic.vision.camera_yaml import write_camera_info_yaml  # noqa: E402
from handeye.cli import main  # noqa: E402
from handeye.core.dataset import Dataset, shard_is_complete  # noqa: E402
from handeye.core.errors import BagError, DatasetError, HandEyeInputError, IntrinsicsError, RecordingError  # noqa: E402
from handeye.core.limits import MAX_MESSAGE_CHARS  # noqa: E402
from handeye.import_bag import read_camera_bag  # noqa: E402
from handeye.import_folder import read_frame_folder  # noqa: E402
from handeye.recording_checks import DEPTH_MEDIAN_RANGE_M  # noqa: E402
from handeye.recording_import import import_recordings  # noqa: E402
from handeye.robot.model import load_robot  # noqa: E402
from tests.tolerances import ABSOLUTE_ONLY, DEPTH_QUANTUM_M, FLOAT32_POSITION_MM, MM  # noqa: E402

TS = get_typestore(Stores.ROS2_HUMBLE)
MSG = TS.types
EPOCH_NS = 1_700_000_000 * 10**9
COLOR, DEPTH, INFO, JOINTS = (
    "/camera/color/image_raw",
    "/camera/aligned_depth_to_color/image_raw",
    "/camera/color/camera_info",
    "/joint_states",
)
UR5 = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
W, H, N = 8, 6, 4
K = np.array([[10.0, 0.0, 3.5], [0.0, 10.0, 2.5], [0.0, 0.0, 1.0]])
#: The scene: a flat depth of this many metres, inside DEPTH_MEDIAN_RANGE_M.
DEPTH_M = 0.812
#: The joints at the four frames (radians), well inside the UR5's limits.
Q = np.array([0.1, -1.2, 1.0, -0.5, 1.5, 0.3]) + 0.05 * np.arange(N)[:, None]


def _header(stamp: int, frame: str = "camera_color_optical_frame"):
    return MSG["std_msgs/msg/Header"](MSG["builtin_interfaces/msg/Time"](stamp // 10**9, stamp % 10**9), frame)


def _image(stamp: int, encoding: str, pixels: np.ndarray):
    rows = np.ascontiguousarray(pixels).reshape(pixels.shape[0], -1).view(np.uint8)
    return MSG["sensor_msgs/msg/Image"](
        _header(stamp), pixels.shape[0], pixels.shape[1], encoding, 0, rows.shape[1], rows.reshape(-1)
    )


def _info(stamp: int, k: np.ndarray, width: int, height: int):
    roi = MSG["sensor_msgs/msg/RegionOfInterest"](0, 0, 0, 0, False)
    P = np.concatenate([k, np.zeros((3, 1))], axis=1).reshape(-1)
    return MSG["sensor_msgs/msg/CameraInfo"](
        _header(stamp), height, width, "plumb_bob", np.zeros(5), k.reshape(-1), np.eye(3).reshape(-1), P, 0, 0, roi
    )


def write_bag(path, storage="sqlite3", depth=DEPTH_M * 1e3, encoding="16UC1", infos=None, joints=None):
    """A bag of N frames: colour, depth (a constant ``depth`` in the encoding's values), camera_info, joints.

    ``infos``: ``{topic: (K, (width, height))}``, camera_info topics besides INFO (K and W x H);
    ``joints``: ``{topic: (q (N, J), names)}``, JointState topics besides JOINTS (Q of UR5).
    """
    dtype = "<u2" if encoding == "16UC1" else "<f4"
    infos = {INFO: (K, (W, H)), **(infos or {})}
    joints = {JOINTS: (Q, UR5), **(joints or {})}
    messages = []
    for i in range(N):
        s = EPOCH_NS + i * 500_000_000
        messages += [
            (COLOR, "sensor_msgs/msg/Image", s, _image(s, "rgb8", np.full((H, W, 3), 90 + i, np.uint8))),
            (DEPTH, "sensor_msgs/msg/Image", s, _image(s, encoding, np.full((H, W), depth, dtype))),
        ]
        for topic, (k, size) in infos.items():
            messages.append((topic, "sensor_msgs/msg/CameraInfo", s, _info(s, np.asarray(k, float), *size)))
        for topic, (q, names) in joints.items():
            state = MSG["sensor_msgs/msg/JointState"](
                _header(s, ""), list(names), np.asarray(q[i], float), np.zeros(0), np.zeros(0)
            )
            messages.append((topic, "sensor_msgs/msg/JointState", s, state))
    return _write_messages(path, messages, storage)


def _write_messages(path, messages, storage="sqlite3"):
    """A bag at ``path`` of ``(topic, msgtype, stamp, msg)`` messages, in the order given."""
    plugin = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}[storage]
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        conns = {}
        for topic, msgtype, stamp, msg in messages:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=TS)
            writer.write(conns[topic], stamp, TS.serialize_cdr(msg, msgtype))
    return path


@pytest.fixture(scope="module")
def robot():
    return load_robot("ur5")


def _one_line(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and len(err) <= MAX_MESSAGE_CHARS + 1 and "Traceback" not in err, err
    return err


def _import_bag(bag, out, *extra) -> int:
    return main(["import", "bag", str(bag), "--robot", "ur5", "--out", str(out), "--quiet", *extra])


# ------------------------------------------------------------------ depth units (issue 40, item 6)


def test_float_depth_in_millimetres_is_refused_with_the_unit_that_fits(tmp_path, capsys):
    bag = write_bag(tmp_path / "mm32", encoding="32FC1", depth=DEPTH_M * 1e3)
    assert _import_bag(bag, tmp_path / "a") == 2
    err = _one_line(capsys)
    assert "depth looks like millimetres" in err and "--depth-unit 0.001" in err and DEPTH in err
    assert not (tmp_path / "a").exists()
    assert _import_bag(bag, tmp_path / "b", "--depth-unit", "0.001") == 0
    ds = Dataset.open(tmp_path / "b")
    rows = ds.select(0, "data")
    assert len(rows["frame"]) == N
    assert np.abs(ds.depth_m(0, rows["depth"][0]) - DEPTH_M).max() <= DEPTH_QUANTUM_M + 1e-6  # + float32


def test_16_bit_depth_in_metres_and_empty_depth_are_refused(tmp_path):
    with pytest.raises(RecordingError, match=r"depth looks like metres .*--depth-unit 1 "):
        read_camera_bag(write_bag(tmp_path / "m16", depth=1), COLOR, INFO, DEPTH)
    with pytest.raises(RecordingError, match=f"none of the {N} depth frames has a valid pixel"):
        read_camera_bag(write_bag(tmp_path / "zero", depth=0), COLOR, INFO, DEPTH)
    with pytest.raises(RecordingError, match=f"none of the {N} depth frames"):
        read_camera_bag(write_bag(tmp_path / "nan", encoding="32FC1", depth=np.nan), COLOR, INFO, DEPTH)
    part = read_camera_bag(write_bag(tmp_path / "ok32", encoding="32FC1", depth=DEPTH_M), COLOR, INFO, DEPTH)
    assert np.all(part.depth.images[0] == np.float32(DEPTH_M))  # the convention: 32FC1 in metres
    lo, hi = DEPTH_MEDIAN_RANGE_M
    assert lo < DEPTH_M < hi and not lo < DEPTH_M * 1e3 < hi and not lo < DEPTH_M * 1e-3 < hi


def _joint_lines(q: np.ndarray, names: list = UR5) -> list:
    """joints.csv's lines: a header and one row per frame f0, f1, ..."""
    return ["frame," + ",".join(names)] + [f"f{i}," + ",".join(repr(float(v)) for v in row) for i, row in enumerate(q)]


def test_depth_beyond_what_the_dataset_stores_is_refused(tmp_path, robot):
    """Tenths of a millimetre read as millimetres: 8.12 m, plausible for a sensor, beyond the dataset's 16-bit
    0.1 mm PNGs (6.55 m): refused, where it would have been stored as no depth."""
    part = read_camera_bag(write_bag(tmp_path / "bag", depth=DEPTH_M * 1e4), COLOR, INFO, DEPTH)
    with pytest.raises(RecordingError, match=rf"{W * H} of {W * H} valid depth pixels are beyond 6.55 m.*0\.0001"):
        import_recordings(tmp_path / "out", [part], robot, "ur5")
    assert not (tmp_path / "out").exists()


def _folder(root, depth=None, joints=None, intrinsics=K, size=(W, H)):
    """A placement folder of N frames; ``depth(i)`` an array saved as .npy (default a 16-bit mm PNG)."""
    from PIL import Image

    (root / "rgb").mkdir(parents=True)
    (root / "depth").mkdir()
    # written from a plain record, not CameraIntrinsics, which refuses a K no camera has before it is written
    camera = SimpleNamespace(K=np.asarray(intrinsics), dist=np.zeros(5), width=size[0], height=size[1])
    write_camera_info_yaml(root / "intrinsics.yaml", camera)
    (root / "joints.csv").write_text("\n".join(joints or _joint_lines(Q)) + "\n")
    for i in range(N):
        Image.fromarray(np.full((H, W, 3), 90, np.uint8)).save(root / "rgb" / f"f{i}.png")
        if depth is None:
            Image.fromarray(np.full((H, W), round(DEPTH_M * 1e3), np.uint16)).save(root / "depth" / f"f{i}.png")
        else:
            np.save(root / "depth" / f"f{i}.npy", depth(i))
    return root


def test_folder_npy_depth_in_millimetres_and_its_fix(tmp_path):
    folder = _folder(tmp_path / "p", depth=lambda i: np.full((H, W), DEPTH_M * 1e3, np.float32))
    with pytest.raises(RecordingError, match=r"f0\.npy: depth looks like millimetres .*--depth-unit 0\.001"):
        read_frame_folder(folder)
    part = read_frame_folder(folder, depth_unit_m=1e-3)
    assert np.allclose(part.depth.images[0], DEPTH_M, rtol=ABSOLUTE_ONLY, atol=FLOAT32_POSITION_MM * MM)
    png = read_frame_folder(_folder(tmp_path / "png"))
    assert np.allclose(png.depth.images[0], DEPTH_M, rtol=ABSOLUTE_ONLY, atol=FLOAT32_POSITION_MM * MM)


def test_npy_header_declaring_a_huge_image_is_refused_before_reading(tmp_path):
    folder = _folder(tmp_path / "p", depth=lambda i: np.full((H, W), DEPTH_M, np.float32))
    path = folder / "depth" / "f2.npy"
    header = {"descr": "<f4", "fortran_order": False, "shape": (100_000, 100_000)}
    with path.open("wb") as f:
        np.lib.format.write_array_header_1_0(f, header)
        f.write(b"\0" * 64)
    tracemalloc.start()
    with pytest.raises(RecordingError, match=r"f2\.npy: the \.npy header: declares 100000x100000 pixels"):
        read_frame_folder(folder)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 50e6  # the 40 GB it declares never allocated
    with path.open("wb") as f:  # a plausible size, but the data cut short
        np.lib.format.write_array_header_1_0(f, dict(header, shape=(H, W)))
        f.write(b"\0" * 8)
    with pytest.raises(RecordingError, match="truncated"):
        read_frame_folder(folder)


# ------------------------------------------------------------------ joints (item 7)


#: A bag whose joint topics each hold one impossible value of elbow_joint at the third frame, and what is said.
BAD_JOINTS = {
    "/nan": (np.nan, r"joint 'elbow_joint' is nan \(1 such samples\); a joint angle must be a finite number"),
    "/inf": (np.inf, r"joint 'elbow_joint' is inf"),
    "/huge": (1e300, r"joint 'elbow_joint' is 1e\+300, beyond its limits \[-3.142, 3.142\] rad"),
    "/degrees": (np.nan, r"joint 'shoulder_pan_joint' is 8.59437, beyond its limits .*look like degrees"),
    "/twice": (np.nan, r"joint 'elbow_joint' is listed twice"),
}


def _bad(value):
    q = Q.copy()
    q[2, 2] = value
    return q, UR5


@pytest.fixture(scope="module")
def bad_joints(tmp_path_factory):
    topics = {t: _bad(v) for t, (v, _) in BAD_JOINTS.items()}
    topics["/degrees"] = (np.rad2deg(Q), UR5)
    topics["/twice"] = (np.insert(Q, 3, 0.0, axis=1), UR5[:3] + ["elbow_joint"] + UR5[3:])
    topics["/gripper"] = (np.concatenate([Q, np.full((N, 1), np.nan)], axis=1), UR5 + ["finger"])
    return write_bag(tmp_path_factory.mktemp("joints") / "bag", joints=topics)


@pytest.mark.parametrize("topic", ["/nan", "/inf", "/huge", "/degrees"])
def test_impossible_joint_values_are_refused_naming_topic_stamp_and_joint(bad_joints, tmp_path, robot, topic):
    part = read_camera_bag(bad_joints, COLOR, INFO, DEPTH, topic)
    stamp = EPOCH_NS + (500_000_000 if topic == "/degrees" else 2 * 500_000_000)  # the first sample beyond
    with pytest.raises(RecordingError, match=rf"{topic}, the message stamped {stamp} ns: {BAD_JOINTS[topic][1]}"):
        import_recordings(tmp_path / "out", [part], robot, "ur5")
    assert not (tmp_path / "out").exists()


def test_joints_in_degrees_in_a_folder_are_one_line(tmp_path, capsys):
    folder = _folder(tmp_path / "p", joints=_joint_lines(np.rad2deg(Q)))
    assert main(["import", "folder", str(folder), "--robot", "ur5", "--out", str(tmp_path / "f"), "--quiet"]) == 2
    err = _one_line(capsys)
    assert "joints.csv, frame 'f1': joint 'shoulder_pan_joint'" in err and "degrees" in err


@pytest.mark.parametrize(
    "cell, reason", [("nan", "is not a finite number"), ("0_2", r"is not a number \('_' digit separators")]
)
def test_a_joint_cell_that_is_no_number_is_named(tmp_path, cell, reason):
    lines = _joint_lines(Q)
    lines[3] = lines[3].rsplit(",", 1)[0] + "," + cell  # frame f2, the last column
    where = r"joints.csv: row 4 \(frame 'f2'\), column 'wrist_3_joint'"
    with pytest.raises(RecordingError, match=rf"{where}: '{cell}' {reason}"):
        read_frame_folder(_folder(tmp_path / "p", joints=lines))


def test_a_joint_named_twice_is_refused_and_an_unused_joint_is_not_checked(bad_joints, tmp_path, robot):
    with pytest.raises(RecordingError, match=rf"/twice at stamp {EPOCH_NS}: {BAD_JOINTS['/twice'][1]}"):
        read_camera_bag(bad_joints, COLOR, INFO, DEPTH, "/twice")
    q, names = np.insert(Q, 3, 0.0, axis=1), UR5[:3] + ["elbow_joint"] + UR5[3:]
    with pytest.raises(RecordingError, match=r"joints.csv, header: joint 'elbow_joint' is listed twice"):
        read_frame_folder(_folder(tmp_path / "p", joints=_joint_lines(q, names)))
    part = read_camera_bag(bad_joints, COLOR, INFO, DEPTH, "/gripper")  # NaN in a joint the model has not
    report = import_recordings(tmp_path / "out", [part], robot, "ur5")
    assert report.frames[0]["data"] == N
    ds = Dataset.open(tmp_path / "out")
    assert np.array_equal(ds.joints(ds.select(0, "data")), Q)


def _pose_bag(path, tf_x: float):
    """/tf base -> ee moving along x (its third translation ``tf_x``) and /marker poses, the last at x = NaN."""
    tf, ps = "tf2_msgs/msg/TFMessage", "geometry_msgs/msg/PoseStamped"
    messages = []
    for i, (x, ee) in enumerate([(0.1, 0.0), (0.2, 0.1), (0.3, tf_x), (np.nan, 0.3)]):
        s = EPOCH_NS + i * 500_000_000
        tr = MSG["geometry_msgs/msg/Transform"](
            MSG["geometry_msgs/msg/Vector3"](ee, 0.0, 0.5), MSG["geometry_msgs/msg/Quaternion"](0.0, 0.0, 0.0, 1.0)
        )
        edge = MSG["geometry_msgs/msg/TransformStamped"](_header(s, "base"), "ee", tr)
        messages.append(("/tf", tf, s, MSG[tf]([edge])))
        pose = MSG["geometry_msgs/msg/Pose"](
            MSG["geometry_msgs/msg/Point"](x, 0.0, 0.8), MSG["geometry_msgs/msg/Quaternion"](0.0, 0.0, 0.0, 1.0)
        )
        messages.append(("/marker", ps, s, MSG[ps](_header(s), pose)))
    return _write_messages(path, messages)


def test_a_marker_position_or_tf_translation_that_is_not_finite_is_refused(tmp_path):
    """bag-poses: a PoseStamped or a tf transform of NaN or 1e300 metres is named by its stamp, not written."""
    from handeye.ros_bag import read_bag

    stamp = EPOCH_NS + 3 * 500_000_000
    with pytest.raises(BagError, match=rf"/marker: the message stamped {stamp} ns has a position of \[nan, 0.0, 0.8\]"):
        read_bag(_pose_bag(tmp_path / "a", 0.2), "base", "ee", marker_topic="/marker")
    stamp = EPOCH_NS + 2 * 500_000_000
    with pytest.raises(BagError, match=rf"/tf: transform base -> ee at stamp {stamp} ns has a translation of \[1e"):
        read_bag(_pose_bag(tmp_path / "b", 1e300), "base", "ee")


# ------------------------------------------------------------------ intrinsics (item 9)


def _with(r, c, value):
    k = K.copy()
    k[r, c] = value
    return k


#: camera_info topics of K (and W x H) no camera has, and what is said.
BAD_INFOS = {
    "/fx_tiny": (_with(0, 0, 1e-300), (W, H), r"fx = 1e-300 pixels gives a 180-degree field of view"),
    "/fy_huge": (_with(1, 1, 1e300), (W, H), r"fy = 1e\+300 pixels gives a 3.44e-298-degree field of view"),
    "/fx_negative": (_with(0, 0, -10.0), (W, H), r"fx is -10; a focal length must be > 0"),
    "/cx_nan": (_with(0, 2, np.nan), (W, H), r"cx \(K\[0\]\[2\]\) is nan"),
    "/cx_outside": (_with(0, 2, 812.0), (W, H), r"cx = 812 is outside the image \(0 to 8 pixels\)"),
    "/transposed": (K.T, (W, H), r"K\[2\]\[0\] is 3.5; a camera matrix is"),
    "/scaled": (_with(2, 2, 2.0), (W, H), r"K\[2\]\[2\] is 2, not 1"),
    "/uncalibrated": (np.zeros((3, 3)), (W, H), r"K is all zero: the camera is not calibrated"),
    "/no_size": (K, (0, H), r"width 0 and height 6"),
}


@pytest.fixture(scope="module")
def bad_infos(tmp_path_factory):
    return write_bag(tmp_path_factory.mktemp("infos") / "bag", infos={t: v[:2] for t, v in BAD_INFOS.items()})


@pytest.mark.parametrize("topic", list(BAD_INFOS))
def test_camera_info_no_camera_has_is_refused_naming_the_field(bad_infos, topic):
    with pytest.raises(IntrinsicsError, match=rf"{topic} at stamp {EPOCH_NS}: {BAD_INFOS[topic][2]}"):
        read_camera_bag(bad_infos, COLOR, topic, DEPTH)


def test_intrinsics_file_no_camera_has_is_refused(tmp_path):
    with pytest.raises(IntrinsicsError, match=r"intrinsics.yaml(, line \d+)?: fx = 1e-300 pixels"):
        read_frame_folder(_folder(tmp_path / "a", intrinsics=_with(0, 0, 1e-300)))
    with pytest.raises(IntrinsicsError, match=r"intrinsics.yaml: cy = -2.5 is outside the image"):
        read_frame_folder(_folder(tmp_path / "b", intrinsics=_with(1, 2, -2.5)))
    assert read_frame_folder(_folder(tmp_path / "c")).intrinsics.width == W


# ------------------------------------------------------------------ corrupt storage and manifests (item 11)


def _mcap_records(data: bytes):
    """(offset, opcode, length) of the top-level MCAP records after the 8-byte magic."""
    k = 8
    while k + 9 <= len(data):
        op, n = data[k], struct.unpack_from("<Q", data, k + 1)[0]
        yield k, op, n
        if op == 0x0F:  # the footer's magic follows
            return
        k += 9 + n


def _corrupt(data: bytes, how: str) -> bytes:
    data = bytearray(data)
    k = next(off for off, op, _ in _mcap_records(bytes(data)) if op == 0x06)  # the first Chunk record
    # its body: start, end, uncompressed size (u64 each), CRC (u32), compression (u32 length, ""), records length
    # (u64), the records (opcode, u64 length, ...)
    records = k + 9 + 40  # the chunk's first record (the compression name is "")
    inside = {}  # opcode -> offsets of the chunk's records (rosbags writes them uncompressed)
    r, end = records, records + struct.unpack_from("<Q", data, records - 8)[0]
    while r < end:
        inside.setdefault(data[r], []).append(r)
        r += 9 + struct.unpack_from("<Q", data, r + 1)[0]
    if how == "checksum":  # the CRC of its records: rosbags checks it when it reads the chunk
        struct.pack_into("<I", data, k + 9 + 24, 12345)
    elif how == "record":  # its first record's length past the chunk (rosbags passed the chunk over)
        struct.pack_into("<Q", data, records + 1, 2**62)
    elif how == "length":  # the header record's length: rosbags' reader allocates from it when it opens the file
        struct.pack_into("<Q", data, 9, 2**63 - 1)
    # rosbags reads by the summary's index and passed these over in silence (issue 40, benchmarks'
    # reliability_faults.corrupt_mcap): a message of channel 0xFFFF, ...
    elif how == "channel":
        struct.pack_into("<H", data, inside[0x05][len(inside[0x05]) // 2] + 9, 0xFFFF)
    elif how == "schema":  # ... the chunk's channel record naming schema 0xFFFF, ...
        struct.pack_into("<H", data, inside[0x04][0] + 9 + 2, 0xFFFF)
    else:  # ... the chunk's records length 2^40, past the end of the file
        assert how == "chunk"
        struct.pack_into("<Q", data, records - 8, 2**40)
    return bytes(data)


@pytest.mark.parametrize(
    "how, message",
    [
        ("checksum", "storage is corrupt after 0 messages: a record cannot be read .*Chunk checksum mismatch"),
        ("length", r"storage is corrupt \(OverflowError"),
        (
            "record",
            r"bag.mcap: the MCAP storage is corrupt: the schema record at byte \d+ in the chunk at byte \d+ "
            r"declares 4611686018427387904 bytes, past the end of its chunk",
        ),
    ],
)
def test_a_corrupt_mcap_record_is_one_line(tmp_path, capsys, how, message):
    bag = write_bag(tmp_path / "bag", storage="mcap")
    mcap = next(bag.glob("*.mcap"))
    mcap.write_bytes(_corrupt(mcap.read_bytes(), how))
    with pytest.raises(BagError, match=message):
        read_camera_bag(bag, COLOR, INFO, DEPTH)
    if how == "checksum":  # and through the command: one line, nothing written
        assert _import_bag(bag, tmp_path / "out") == 2
        assert "storage is corrupt" in _one_line(capsys)
        assert not (tmp_path / "out").exists()


@pytest.fixture(scope="module")
def good_mcap(tmp_path_factory):
    return write_bag(tmp_path_factory.mktemp("mcap") / "bag", storage="mcap")


@pytest.mark.parametrize(
    "how, message",
    [
        ("channel", r"the message record at byte \d+ in the chunk at byte \d+ names channel 65535, which the file "),
        (
            "schema",
            r"the channel record at byte \d+ in the chunk at byte \d+ \(channel \d+\) names schema 65535, which",
        ),
        ("chunk", r"the chunk at byte \d+ declares 1099511627776 bytes of records, past the end of the file"),
    ],
)
def test_mcap_records_the_reader_passed_over_are_refused_in_one_line(good_mcap, tmp_path, capsys, how, message):
    import re
    import shutil

    bag = shutil.copytree(good_mcap, tmp_path / "bag")
    mcap = next(bag.glob("*.mcap"))
    mcap.write_bytes(_corrupt(mcap.read_bytes(), how))
    with pytest.raises(BagError, match=f"^{re.escape(str(mcap))}: the MCAP storage is corrupt: {message}"):
        read_camera_bag(bag, COLOR, INFO, DEPTH)
    assert _import_bag(bag, tmp_path / "out") == 2
    assert _one_line(capsys).startswith(f"handeye import bag: error: {mcap}: the MCAP storage is corrupt: ")
    assert not (tmp_path / "out").exists()


def test_a_good_mcap_bag_reads_as_its_sqlite3_twin(good_mcap, tmp_path):
    a, b = (
        read_camera_bag(good_mcap, COLOR, INFO, DEPTH),
        read_camera_bag(write_bag(tmp_path / "db"), COLOR, INFO, DEPTH),
    )
    for x, y in ((a.color, b.color), (a.depth, b.depth)):
        assert np.array_equal(x.times_s, y.times_s) and all(map(np.array_equal, x.images, y.images))
    assert np.array_equal(a.joints.q, b.joints.q) and a.joints.names == b.joints.names
    assert a.intrinsics.to_dict() == b.intrinsics.to_dict()


@pytest.fixture(scope="module")
def imported(tmp_path_factory, robot):
    root = tmp_path_factory.mktemp("imported")
    import_recordings(root / "ds", [read_camera_bag(write_bag(root / "bag"), COLOR, INFO, DEPTH)], robot, "ur5")
    return root / "ds"


@pytest.mark.parametrize(
    "manifest, message",
    [
        ("[1, 2]", r"not a shard manifest \(no 'files'"),
        ('"files"', r"not a shard manifest \(no 'files'"),
        ('{"files": ["frames.csv"]}', r"not a shard manifest \('files' a list"),
        ('{"files": {"frames.csv": "12"}}', r"the size of 'frames.csv' is '12', not a number of bytes"),
        ('{"files": {"../../meta.json": 1}}', r"lists '../../meta.json', not a path inside the shard"),
        ("[" * 100_000, r"unreadable"),
    ],
)
def test_a_manifest_of_the_wrong_type_is_one_line(imported, tmp_path, capsys, manifest, message):
    import shutil

    ds = shutil.copytree(imported, tmp_path / "ds")
    shard = ds / "shards" / "cam_0000"
    assert shard_is_complete(shard) == (True, "")
    (shard / "manifest.json").write_text(manifest)
    ok, why = shard_is_complete(shard)
    assert not ok and why.startswith(str(shard / "manifest.json")) and __import__("re").search(message, why)
    with pytest.raises(DatasetError, match=message):
        Dataset.open(ds).select(0, "data")


# ------------------------------------------------------------------ a failed import leaves nothing (item 3)


def test_a_failed_import_leaves_nothing_and_the_rerun_works(tmp_path, robot, monkeypatch, capsys):
    good = read_camera_bag(write_bag(tmp_path / "good"), COLOR, INFO, DEPTH)
    bad = read_camera_bag(write_bag(tmp_path / "bad"), COLOR, INFO, DEPTH)
    bad.depth.images[-1] = np.full((H + 1, W), np.float32(DEPTH_M))  # found when its frames are assembled
    out = tmp_path / "ds"
    with pytest.raises(HandEyeInputError, match="the depth image is 8x7, the camera_info is for 8x6"):
        import_recordings(out, [good, bad], robot, "ur5")  # the first shard was written
    assert sorted(os.listdir(tmp_path)) == ["bad", "good"]  # no dataset, no temporary folder

    from handeye.core import shard_writer

    def full_disk(self, *args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.partial / "rgb" / "data_000.png"))

    with monkeypatch.context() as m:
        m.setattr(shard_writer.ShardWriter, "add_frame", full_disk)
        with pytest.raises(DatasetError, match=r"the import failed writing .*No space left on device.*nothing was"):
            import_recordings(out, [good], robot, "ur5")
    assert sorted(os.listdir(tmp_path)) == ["bad", "good"]
    out.mkdir()  # an empty target is fine
    assert import_recordings(out, [good, good], robot, "ur5").frames[1]["data"] == N
    assert len(Dataset.open(out)) == 2 and sorted(os.listdir(tmp_path)) == ["bad", "ds", "good"]
    with pytest.raises(DatasetError, match="not empty; import into a new directory"):
        import_recordings(out, [good], robot, "ur5")


def test_an_unfinished_import_is_named_and_a_killed_ones_folder_removed(tmp_path, robot):
    good = read_camera_bag(write_bag(tmp_path / "good"), COLOR, INFO, DEPTH)
    out = tmp_path / "ds"
    out.mkdir()
    (out / "meta.json").write_text(json.dumps({"recipe": {"generator": "handeye import bag"}}))
    with pytest.raises(DatasetError, match=rf"{out}: an unfinished import left this folder .*rm -r {out}"):
        import_recordings(out, [good], robot, "ur5")
    (out / "meta.json").unlink()
    dead = tmp_path / f".ds.importing-{socket.gethostname()}-{2**22 + 7}"  # above Linux's largest pid
    (dead / "shards").mkdir(parents=True)
    import_recordings(out, [good], robot, "ur5")
    assert not dead.exists() and sorted(os.listdir(tmp_path)) == ["ds", "good"]
