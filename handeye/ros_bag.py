"""ROS 2 bags to arrays: the robot's pose from tf, the camera's marker poses or images, paired by time.

Reads rosbag2 recordings (sqlite3 or MCAP storage) with the pure-Python ``rosbags`` package
(``pip install "handeye[ros]"``), no ROS installation:

* the robot: ``T_base_ee`` over time, the pose of the end frame (``tool0``) in the base frame
  (``base_link``), chained through the tf tree of ``/tf`` and ``/tf_static``
  (``tf2_msgs/msg/TFMessage``; :mod:`handeye.tf_tree`);
* the camera: ``T_cam_target`` from a marker pose topic (``geometry_msgs/msg/PoseStamped``,
  ``PoseWithCovarianceStamped`` or ``TransformStamped``: the target's pose in the camera's frame), or
  images (``sensor_msgs/msg/Image``) as numpy arrays for the board detection.

Times are header stamps (the sensor's time, not the recorder's), in seconds since the bag's start
time, so that every stream read from one bag shares one clock. Pairing: :meth:`BagRecording.pair`
(:func:`handeye.time_pairing.pair_by_time`); the raw streams go to :func:`classic.calibrate_stream`
when the clocks disagree.

Example
-------
::

    rec = read_bag("recording", base_frame="base_link", ee_frame="tool0", marker_topic="/marker_pose")
    pairs = rec.pair(tolerance_s=0.01)                 # pairs.kept, pairs.dropped
    res = classic.calibrate(pairs.T_base_ee, pairs.T_cam_target, setup="eye_to_hand")
    # clocks that disagree: the raw streams, and the offset estimated with X and Y
    res = classic.calibrate_stream(rec.robot_times_s, rec.T_base_ee, rec.camera_times_s, rec.T_cam_target)
"""

from __future__ import annotations

import struct
from contextlib import contextmanager
from dataclasses import dataclass
from itertools import chain
from pathlib import Path
from typing import NoReturn

import numpy as np

from handeye.core.errors import BagError, BagTopicError, NotABagError
from handeye.core.limits import ABSURD_TRANSLATION_M, check_image_size
from handeye.core.optional import require_package
from handeye.core.se3 import transform_from_pos_quat_xyzw
from handeye.tf_tree import QUAT_NORM_TOL, TfTree
from handeye.time_pairing import PairedPoses, pair_by_time

__all__ = [
    "POSE_TYPES",
    "IMAGE_ENCODINGS",
    "BagRecording",
    "BagImages",
    "read_bag",
    "read_images",
    "image_array",
    "open_bag",
    "topic_connections",
    "bag_messages",
    "stamp_ns",
]

TF_TYPE = "tf2_msgs/msg/TFMessage"
POSE_TYPES = (
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "geometry_msgs/msg/TransformStamped",
)
IMAGE_TYPE = "sensor_msgs/msg/Image"
#: ``sensor_msgs/Image`` encodings read: (channels, dtype, channel order).
IMAGE_ENCODINGS = {
    "mono8": (1, "u1", None),
    "8UC1": (1, "u1", None),
    "mono16": (1, "u2", None),
    "16UC1": (1, "u2", None),
    "32FC1": (1, "f4", None),
    "rgb8": (3, "u1", "rgb"),
    "bgr8": (3, "u1", "bgr"),
    "8UC3": (3, "u1", "bgr"),
    "rgba8": (4, "u1", "rgb"),
    "bgra8": (4, "u1", "bgr"),
}


@dataclass
class BagRecording:
    """The robot's and the camera's poses over time, read from one bag.

    Attributes
    ----------
    bag : str
    origin_ns : int
        The bag's start time; every ``*_times_s`` is seconds since it.
    robot_times_s : array, shape (M,)
        Strictly increasing header stamps of the chain.
    T_base_ee : array, shape (M, 4, 4)
        Pose of ``ee_frame`` in ``base_frame``, metres.
    frames : list of str
        The tf path from the base frame to the end frame.
    camera_times_s : array, shape (N,) or None
        Header stamps of the marker poses, sorted.
    T_cam_target : array, shape (N, 4, 4) or None
        Pose of the marker in the camera (the message's ``header.frame_id``), metres.
    camera_frame : str or None
    marker_topic : str or None
    """

    bag: str
    origin_ns: int
    robot_times_s: np.ndarray
    T_base_ee: np.ndarray
    frames: list
    camera_times_s: np.ndarray | None = None
    T_cam_target: np.ndarray | None = None
    camera_frame: str | None = None
    marker_topic: str | None = None

    def pair(self, tolerance_s: float, method: str = "interpolate") -> PairedPoses:
        """Each marker pose with the robot pose at its stamp, within ``tolerance_s`` seconds.

        Parameters
        ----------
        tolerance_s : float
        method : {"interpolate", "nearest"}
            See :mod:`handeye.time_pairing`.

        Returns
        -------
        PairedPoses
            ``T_base_ee`` and ``T_cam_target`` of shape (K, 4, 4), the dropped samples counted.

        Raises
        ------
        NoPairsError
            No marker pose has a robot pose within the tolerance.
        """
        if self.T_cam_target is None:
            raise BagTopicError(f"{self.bag}: read without a marker topic: no camera poses to pair")
        return pair_by_time(
            self.robot_times_s,
            self.T_base_ee,
            self.camera_times_s,
            self.T_cam_target,
            tolerance_s,
            method,
            source=f"{self.bag}, {self.marker_topic} with tf",
        )


@dataclass
class BagImages:
    """Images of one topic.

    Attributes
    ----------
    times_s : array, shape (N,)
        Header stamps, seconds since the bag's start time ``origin_ns``.
    images : list of array
        Each ``(H, W)`` (mono, depth) or ``(H, W, 3)`` uint8 in ``order``; alpha dropped.
    encodings : list of str
    frame_id : str
    origin_ns : int
    order : str
        ``"bgr"`` (OpenCV's, what :func:`classic.vision.detect.detect_board` takes) or ``"rgb"``.
    """

    times_s: np.ndarray
    images: list
    encodings: list
    frame_id: str
    origin_ns: int
    order: str


def _bag_dir(path: Path) -> Path:
    """The rosbag2 directory of a path, or :class:`NotABagError` saying what the path is instead."""
    if not path.exists():
        raise NotABagError(f"{path}: no such file or directory")
    if path.is_file() and path.suffix in (".db3", ".mcap") and (path.parent / "metadata.yaml").is_file():
        return path.parent
    if path.is_file() and path.suffix == ".bag":
        raise NotABagError(f"{path}: a ROS 1 bag; this reads ROS 2 bags (convert it with rosbags-convert)")
    if path.is_file() and path.suffix in (".db3", ".mcap"):
        raise NotABagError(
            f"{path}: a {path.suffix} file without metadata.yaml beside it; a ROS 2 bag is the "
            "directory holding both (ros2 bag reindex writes a missing metadata.yaml)"
        )
    if not path.is_dir() or not (path / "metadata.yaml").is_file():
        raise NotABagError(f"{path}: not a ROS 2 bag (a rosbag2 directory with metadata.yaml and .db3 or .mcap files)")
    return path


@contextmanager
def open_bag(bag):
    """An open ``rosbags.highlevel.AnyReader`` on the bag; reader errors become :class:`NotABagError`.

    Parameters
    ----------
    bag : str or Path
        The bag's folder (or its storage file).

    Yields
    ------
    rosbags.highlevel.AnyReader
    """
    require_package("rosbags", extra="ros", purpose="reading ROS 2 bags")
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_typestore

    path = _bag_dir(Path(bag))
    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except (AnyReaderError, OSError, KeyError, ValueError) as exc:
        raise NotABagError(f"{path}: cannot be read as a ROS 2 bag ({_reason(exc)})") from None
    except Exception as exc:  # a corrupt record in the storage (rosbags' struct, overflow and memory errors)
        raise NotABagError(f"{path}: the bag's storage is corrupt ({_reason(exc)})") from None
    try:
        for storage in _mcap_files(reader):
            check_mcap(storage)
    except BaseException:
        reader.close()
        raise
    try:
        yield reader
    finally:
        reader.close()


def _mcap_files(reader) -> list:
    """The MCAP files rosbags reads for an open ``AnyReader`` (none for sqlite3 storage)."""
    from rosbags.rosbag2.storage_mcap import McapReader

    return [
        Path(s.path)
        for r in getattr(reader, "readers", [])
        for s in getattr(getattr(r, "storage", None), "storages", [])
        if isinstance(s, McapReader)
    ]


#: MCAP record names by opcode, for the messages of :func:`check_mcap`.
_MCAP_RECORDS = {1: "header", 3: "schema", 4: "channel", 5: "message", 6: "chunk", 7: "message index"}
_MCAP_RECORDS.update({8: "chunk index", 9: "attachment", 11: "statistics", 12: "metadata", 15: "data end"})


def _refuse_mcap(path: Path, what: str) -> NoReturn:
    """Raise the :class:`BagError` of a corrupt MCAP file, naming it and ``what`` is wrong."""
    raise BagError(f"{path}: the MCAP storage is corrupt: {what}")


def check_mcap(path) -> None:
    """Refuse an MCAP file whose records do not hold together, which rosbags' reader would pass over.

    rosbags reads an indexed MCAP file by its summary (the channels, the chunk indexes, the statistics) and
    skips, without a word, a message of a channel it does not know and a chunk's own records length; so a
    message record naming an undeclared channel, a channel record naming an undeclared schema and a chunk
    declaring records past the end of the file all read as a good bag. This walks every record of the data
    section (and inside each chunk) once: each record must fit in its chunk and the file, each channel name a
    declared schema (or 0, none), each message a declared channel, the summary's chunk indexes point at the
    chunks, and the messages counted per channel equal the summary's statistics. The record headers are
    parsed with :mod:`struct` (the ``mcap`` package is not among the project's dependencies); uncompressed
    chunks are read in place (a memory map: the payloads are not copied), compressed ones decompressed one
    at a time as rosbags does.

    Raises
    ------
    BagError
        Naming the file, the record and its byte offset.
    """
    import mmap

    path = Path(path)
    try:
        with path.open("rb") as fh, mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as mm:
            size = len(mm)
            if size < 8 + 37:
                _refuse_mcap(path, f"{size} bytes, shorter than the magic and footer")
            (summary,) = _U64.unpack_from(mm, size - 28)  # the footer's summary_start
            walked = _McapWalk(path, size)
            walked.records(mm, 8, summary or size - 37, None)
            if summary:
                walked.records(mm, summary, size - 37, None)
    except OSError as exc:
        raise BagError(f"{path}: the MCAP file cannot be read ({_reason(exc)})") from None
    _check_mcap_summary(walked)


_U16, _U64 = struct.Struct("<H"), struct.Struct("<Q")


class _McapWalk:
    """What :func:`check_mcap` gathers walking an MCAP file's records, each record checked to fit as it goes.

    ``schemas``: the declared schema ids (0, none, included); ``channels``: channel id -> [(schema id, where)];
    ``counts``: channel id -> [messages, where of the first]; ``chunks``: offset -> record length, opcode and
    length prefix included; ``stats``: the summary's statistics; ``index``: its (offset, length) chunk indexes.
    """

    def __init__(self, path: Path, size: int):
        self.path, self.size = path, size
        self.schemas, self.channels, self.counts = {0}, {}, {}
        self.chunks, self.stats, self.index = {}, {}, []

    def records(self, buf, start: int, end: int, base: int | None, packed: bool = False) -> None:
        """The records of buf[start:end]; base: the chunk's offset in the file (None: the file); packed:
        buf is the chunk's decompressed records (offsets in them), else the file."""
        k = start
        inside = "its chunk" if base is not None else "the file"
        while k < end:
            at = f"byte {k}" + (f" in the chunk at byte {base}" if base is not None else "")
            if packed:
                at = f"byte {k} of the decompressed chunk at byte {base}"
            if end - k < 9:
                _refuse_mcap(self.path, f"{end - k} stray bytes at {at}, not a record")
            op, (n,) = buf[k], _U64.unpack_from(buf, k + 1)
            name = _MCAP_RECORDS.get(op, f"0x{op:02x}")
            if n > end - k - 9:
                _refuse_mcap(self.path, f"the {name} record at {at} declares {n} bytes, past the end of {inside}")
            if op in (3, 4, 5) and n < {3: 2, 4: 4, 5: 22}[op]:
                _refuse_mcap(self.path, f"the {name} record at {at} is {n} bytes, too short")
            self._record(buf, op, k, n, at, base)
            k += 9 + n

    def _record(self, buf, op: int, k: int, n: int, at: str, base: int | None) -> None:
        """One record of ``n`` bytes at ``k``, opcode ``op``: what it declares, counts or indexes."""
        body = k + 9
        if op == 3:
            self.schemas.add(_U16.unpack_from(buf, body)[0])
        elif op == 4:
            cid, sid = struct.unpack_from("<HH", buf, body)
            self.channels.setdefault(cid, []).append((sid, at))
        elif op == 5:
            self.counts.setdefault(_U16.unpack_from(buf, body)[0], [0, at])[0] += 1
        elif base is None:
            self._file_record(buf, op, k, n, at)

    def _file_record(self, buf, op: int, k: int, n: int, at: str) -> None:
        """A record of the file outside the chunks: a chunk, the summary's statistics and chunk indexes."""
        body = k + 9
        if op == 6:
            self._chunk(buf, k, n, at)
        elif op == 11 and n >= 46:  # statistics (in the summary)
            total, per = _U64.unpack_from(buf, body)[0], min(struct.unpack_from("<I", buf, body + 42)[0], n - 46)
            self.stats.update(
                total=total, per=dict(struct.iter_unpack("<HQ", buf[body + 46 : body + 46 + per // 10 * 10]))
            )
        elif op == 8 and n >= 32:  # a chunk index (in the summary)
            self.index.append(struct.unpack_from("<QQ", buf, body + 16))

    def _chunk(self, buf, k: int, n: int, at: str) -> None:
        """A chunk record of the file: its header checked, its records walked (read in place when uncompressed,
        else decompressed as rosbags does)."""
        body = k + 9
        if n < 40:
            _refuse_mcap(self.path, f"the chunk record at {at} is {n} bytes, too short")
        raw_size, crc, clen = struct.unpack_from("<QII", buf, body + 16)
        head = body + 32 + clen
        if head + 8 > body + n:
            _refuse_mcap(self.path, f"the chunk at {at} declares a compression name of {clen} bytes, past its record")
        (records,) = _U64.unpack_from(buf, head)
        if records > body + n - head - 8:
            past = "the file" if head + 8 + records > self.size else "its record"
            _refuse_mcap(self.path, f"the chunk at {at} declares {records} bytes of records, past the end of {past}")
        compression = bytes(buf[body + 32 : head]).decode("utf-8", "replace")
        self.chunks[k] = n + 9
        if not compression:
            self.records(buf, head + 8, head + 8 + records, k)
            return
        from rosbags.rosbag2.storage_mcap import decompress

        try:
            raw = decompress(bytes(buf[head + 8 : head + 8 + records]), compression, raw_size, crc)
        except Exception as exc:
            _refuse_mcap(self.path, f"the chunk at {at} cannot be decompressed ({_reason(exc)})")
        self.records(raw, 0, len(raw), k, packed=True)


def _check_mcap_summary(walked: _McapWalk) -> None:
    """The records :func:`check_mcap` walked (:class:`_McapWalk`), checked against each other and against the
    summary: the first problem of the chunk indexes, the channels, the messages' channels, the statistics.

    Raises
    ------
    BagError
    """
    problems = chain(
        _index_problems(walked.chunks, walked.index),
        _channel_problems(walked.schemas, walked.channels),
        (
            f"the message record at {at} names channel {cid}, which the file does not declare"
            for cid, (_, at) in sorted(walked.counts.items())
            if cid not in walked.channels
        ),
        _statistics_problems(walked.counts, walked.stats),
    )
    first = next(problems, None)
    if first is not None:
        _refuse_mcap(walked.path, first)


def _index_problems(chunks: dict, index: list):
    """The summary's chunk indexes ``(offset, length)`` that name no chunk the walk found."""
    for offset, length in index:
        if chunks.get(offset) != length:
            yield f"the summary indexes a chunk of {length} bytes at byte {offset}, which the file does not hold"


def _channel_problems(schemas: set, channels: dict):
    """Channels naming an undeclared schema, or declared with several."""
    for cid, declared in sorted(channels.items()):
        for sid, at in declared:
            if sid not in schemas:
                yield f"the channel record at {at} (channel {cid}) names schema {sid}, which the file lacks"
        if len({sid for sid, _ in declared}) > 1:
            yield f"channel {cid} is declared with schemas {sorted({sid for sid, _ in declared})}"


def _statistics_problems(counts: dict, stats: dict):
    """Message counts, per channel and in all, other than the summary's statistics (none without statistics)."""
    if not stats:
        return
    for cid in sorted(set(counts) | set(stats["per"])):
        found, listed = counts.get(cid, [0])[0], stats["per"].get(cid, 0)
        if found != listed:
            yield f"{found} messages of channel {cid} in the file, the summary's statistics list {listed}"
    if stats["total"] != sum(c for c, _ in counts.values()):
        yield f"{sum(c for c, _ in counts.values())} messages in the file, the summary lists {stats['total']}"


def topic_connections(reader, bag, topic: str, types: tuple, required: bool = True) -> list:
    """The topic's connections, checked to carry one of ``types``.

    Parameters
    ----------
    reader : rosbags.highlevel.AnyReader
        From :func:`open_bag`.
    bag : str
        The bag's name in messages.
    topic : str
    types : tuple of str
        Message types accepted (``sensor_msgs/msg/Image``).
    required : bool
        Whether a missing topic raises :class:`BagTopicError` (else: no connections).

    Returns
    -------
    list of rosbags connections
    """
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns and required:
        topics = sorted({(c.topic, c.msgtype.split("/")[-1]) for c in reader.connections})
        have = ", ".join(f"{t} ({m})" for t, m in topics[:8]) + (
            f" and {len(topics) - 8} more" if len(topics) > 8 else ""
        )
        raise BagTopicError(f"{bag}: no topic {topic!r}; the bag has: {have or 'no topics'}")
    wrong = sorted({c.msgtype for c in conns if c.msgtype not in types})
    if wrong:
        raise BagTopicError(f"{bag}: topic {topic!r} holds {', '.join(wrong)}; expected {' or '.join(types)}")
    return conns


def _reason(exc: BaseException) -> str:
    """An exception as a short reason for a one-line message (its type where its text is empty)."""
    text = " ".join(str(exc).split())[:120]
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _check_counts(bag, conns, seen: dict) -> None:
    """Refuse a topic of which fewer messages were read than the bag's metadata lists: records the storage
    skipped (a corrupt MCAP chunk is passed over by the reader), not a complete recording."""
    for conn in conns:
        listed = int(getattr(conn, "msgcount", 0) or 0)
        if seen.get(id(conn), 0) < listed:
            raise BagError(
                f"{bag}: {seen.get(id(conn), 0)} of the {listed} messages on {conn.topic} that metadata.yaml lists "
                "could be read: the bag's storage is corrupt (ros2 bag reindex rebuilds a stale metadata.yaml)"
            )


def bag_messages(reader, bag, conns):
    """``(connection, message)`` in bag order; a record the storage cannot read or a message that cannot be
    decoded is a :class:`BagError` naming the bag (and the topic).

    Parameters
    ----------
    reader, bag
        As for :func:`topic_connections`.
    conns : list
        From :func:`topic_connections`.

    Yields
    ------
    (connection, message)
    """
    records = iter(reader.messages(connections=conns))
    count = 0
    seen: dict = {}
    while True:
        try:
            conn, _, raw = next(records)
        except StopIteration:
            _check_counts(bag, conns, seen)
            return
        except Exception as exc:  # MCAP chunks and records, sqlite pages: rosbags, struct, zstd, overflow errors
            raise BagError(
                f"{bag}: the bag's storage is corrupt after {count} messages: a record cannot be read ({_reason(exc)})"
            ) from None
        count += 1
        seen[id(conn)] = seen.get(id(conn), 0) + 1
        try:
            message = reader.deserialize(raw, conn.msgtype)
        except Exception as exc:  # rosbags raises its own and struct errors on corrupt data
            raise BagError(f"{bag}: a message on {conn.topic} cannot be decoded ({_reason(exc)})") from None
        yield conn, message


def stamp_ns(header) -> int:
    """A ROS ``std_msgs/Header``'s stamp in integer nanoseconds.

    Parameters
    ----------
    header : std_msgs/msg/Header

    Returns
    -------
    int
    """
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def _pose_of(msg, msgtype: str) -> tuple:
    """Translation and (x, y, z, w) quaternion of a marker pose message."""
    if msgtype.endswith("TransformStamped"):
        t, q = msg.transform.translation, msg.transform.rotation
    else:
        pose = msg.pose.pose if msgtype.endswith("PoseWithCovarianceStamped") else msg.pose
        t, q = pose.position, pose.orientation
    return (t.x, t.y, t.z), (q.x, q.y, q.z, q.w)


def read_bag(
    bag,
    base_frame: str,
    ee_frame: str,
    marker_topic: str | None = None,
    tf_topic: str = "/tf",
    tf_static_topic: str = "/tf_static",
) -> BagRecording:
    """Read the robot's pose from tf, and the marker poses if a topic is given, in one pass over the bag.

    Parameters
    ----------
    bag : str or Path
        A rosbag2 directory (or the ``.db3`` / ``.mcap`` file inside it).
    base_frame, ee_frame : str
        tf frames: the result is ``T_base_ee``, the pose of ``ee_frame`` in ``base_frame``.
    marker_topic : str, optional
        A ``PoseStamped``, ``PoseWithCovarianceStamped`` or ``TransformStamped`` topic: the target's
        pose in the camera, ``T_cam_target``.
    tf_topic, tf_static_topic : str
        The tf topics (``/robot1/tf`` for a namespaced robot); the static one may be absent.

    Returns
    -------
    BagRecording

    Raises
    ------
    NotABagError
        The path is not a readable ROS 2 bag.
    BagTopicError
        No ``tf_topic`` or ``marker_topic``, or one of another message type; the bag's topics are listed.
    FramesNotConnectedError
        The frames are not connected in the tf tree; the frames reachable from the base are listed.
    BagError
        Undecodable messages or a corrupt record, a frame with two parents, a non-unit quaternion, a marker
        position that is not finite or beyond :data:`handeye.core.limits.ABSURD_TRANSLATION_M`, a chain that
        never moves.
    """
    with open_bag(bag) as reader:
        name = str(reader.paths[0])
        static_conns = topic_connections(reader, name, tf_static_topic, (TF_TYPE,), required=False)
        tf_conns = topic_connections(reader, name, tf_topic, (TF_TYPE,)) + static_conns
        cam_conns = topic_connections(reader, name, marker_topic, POSE_TYPES) if marker_topic else []
        tf = {"parents": [], "children": [], "stamps": [], "t": [], "q": [], "static": []}
        cam = {"stamps": [], "t": [], "q": [], "frames": set()}
        for conn, msg in bag_messages(reader, name, tf_conns + cam_conns):
            if conn.topic == marker_topic:
                _add_marker_pose(cam, msg, conn.msgtype)
            else:
                _add_transforms(tf, msg, conn.topic == tf_static_topic)
        origin = int(reader.start_time)
    topics = tf_topic + (f" and {tf_static_topic}" if static_conns else "")
    chain = _tf_tree(tf, f"{name}, {topics}").chain(base_frame, ee_frame)
    rec = BagRecording(name, origin, (chain.stamps_ns - origin) * 1e-9, chain.T_base_ee, chain.frames)
    if marker_topic:
        rec.camera_times_s, rec.T_cam_target = _marker_poses(cam, name, marker_topic, origin)
        rec.camera_frame = ", ".join(sorted(cam["frames"]))
        rec.marker_topic = marker_topic
    return rec


# -- the stages of read_bag(), in its order


def _add_marker_pose(cam: dict, msg, msgtype: str) -> None:
    """A marker pose message's stamp, translation, quaternion and camera frame, appended to ``cam``'s lists."""
    t, q = _pose_of(msg, msgtype)
    cam["stamps"].append(stamp_ns(msg.header))
    cam["t"].append(t)
    cam["q"].append(q)
    cam["frames"].add(msg.header.frame_id.lstrip("/"))


def _add_transforms(tf: dict, msg, static: bool) -> None:
    """A tf message's transforms (parent, child, stamp, translation, quaternion, static), appended to ``tf``."""
    for tr in msg.transforms:
        tf["parents"].append(tr.header.frame_id)
        tf["children"].append(tr.child_frame_id)
        tf["stamps"].append(stamp_ns(tr.header))
        r, p = tr.transform.rotation, tr.transform.translation
        tf["t"].append((p.x, p.y, p.z))
        tf["q"].append((r.x, r.y, r.z, r.w))
        tf["static"].append(static)


def _tf_tree(tf: dict, source: str) -> TfTree:
    """The tf tree of the transforms read; a translation not finite or beyond
    :data:`handeye.core.limits.ABSURD_TRANSLATION_M` is a :class:`BagError` naming the first."""
    t = np.asarray(tf["t"], dtype=float).reshape(-1, 3)
    far = np.flatnonzero(~(np.abs(t).max(axis=1, initial=0.0) <= ABSURD_TRANSLATION_M))
    if len(far):
        i = far[0]
        raise BagError(
            f"{source}: transform {tf['parents'][i]} -> {tf['children'][i]} at stamp {tf['stamps'][i]} ns has "
            f"a translation of {t[i].tolist()} m: not finite or beyond {ABSURD_TRANSLATION_M:g} m ({len(far)} such)"
        )
    return TfTree.from_transforms(
        tf["parents"], tf["children"], tf["stamps"], tf["t"], tf["q"], tf["static"], source=source
    )


def _marker_poses(cam: dict, name: str, topic: str, origin: int) -> tuple[np.ndarray, np.ndarray]:
    """``(camera_times_s, T_cam_target)`` of the marker poses read, sorted by stamp; none, a non-unit quaternion
    or a position not finite or beyond :data:`handeye.core.limits.ABSURD_TRANSLATION_M` is refused."""
    if not cam["stamps"]:
        raise BagTopicError(f"{name}: topic {topic!r} has no messages")
    stamps = np.asarray(cam["stamps"], dtype=np.int64)
    q = np.asarray(cam["q"], dtype=float)
    norm = np.linalg.norm(q, axis=1)
    bad = np.flatnonzero(~(np.abs(norm - 1.0) <= QUAT_NORM_TOL))
    if len(bad):
        raise BagError(
            f"{name}, {topic}: the message stamped {stamps[bad[0]]} ns has an orientation of "
            f"norm {norm[bad[0]]:.4g}, not 1 ({len(bad)} such messages)"
        )
    t = np.asarray(cam["t"], dtype=float)
    far = np.flatnonzero(~(np.abs(t).max(axis=1) <= ABSURD_TRANSLATION_M))
    if len(far):
        raise BagError(
            f"{name}, {topic}: the message stamped {stamps[far[0]]} ns has a position of "
            f"{t[far[0]].tolist()} m: not finite or beyond {ABSURD_TRANSLATION_M:g} m (metres are read; "
            f"{len(far)} such messages)"
        )
    order = np.argsort(stamps, kind="stable")
    return (stamps[order] - origin) * 1e-9, transform_from_pos_quat_xyzw(np.asarray(cam["t"])[order], q[order])


def image_array(msg, order: str = "bgr") -> np.ndarray:
    """A ``sensor_msgs/msg/Image`` as a numpy array.

    Parameters
    ----------
    msg : sensor_msgs/msg/Image
        As deserialised by rosbags (``height``, ``width``, ``encoding``, ``is_bigendian``, ``step``, ``data``).
    order : {"bgr", "rgb"}
        Channel order of colour images.

    Returns
    -------
    image : array, shape (H, W) or (H, W, 3)
        uint8 for 8-bit encodings (alpha dropped), uint16 for ``mono16``/``16UC1``, float32 for ``32FC1``.

    Raises
    ------
    BagError
        An encoding not in :data:`IMAGE_ENCODINGS`, or data shorter than ``height * step``.
    """
    if msg.encoding not in IMAGE_ENCODINGS:
        raise BagError(f"image encoding {msg.encoding!r} is not read; supported: {', '.join(IMAGE_ENCODINGS)}")
    channels, kind, native = IMAGE_ENCODINGS[msg.encoding]
    dtype = np.dtype(kind).newbyteorder(">" if msg.is_bigendian else "<")
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    check_image_size(w, h, f"image {msg.encoding}", BagError)
    data = np.asarray(msg.data, dtype=np.uint8)
    row = w * channels * dtype.itemsize
    if step < row or data.size < h * step:
        raise BagError(f"image {w}x{h} {msg.encoding}: {data.size} bytes with step {step}, need {h} rows of {row}")
    rows = data[: h * step].reshape(h, step)[:, :row]
    img = np.ascontiguousarray(rows).view(dtype).reshape(h, w, channels).astype(dtype.newbyteorder("="))
    if channels == 1:
        return img[..., 0]
    img = img[..., :3]
    return np.ascontiguousarray(img[..., ::-1] if native != order else img)


def read_images(bag, topic: str, order: str = "bgr", every: int = 1) -> BagImages:
    """The images of a ``sensor_msgs/msg/Image`` topic with their stamps.

    Parameters
    ----------
    bag : str or Path
    topic : str
    order : {"bgr", "rgb"}
    every : int
        Keep every ``every``-th image (a long recording holds thousands).

    Returns
    -------
    BagImages
        Sorted by stamp.

    Raises
    ------
    NotABagError, BagTopicError, BagError
    """
    if order not in ("bgr", "rgb") or every < 1:
        raise BagError(f"order must be 'bgr' or 'rgb' and every >= 1, got {order!r}, {every!r}")
    with open_bag(bag) as reader:
        name = str(reader.paths[0])
        conns = topic_connections(reader, name, topic, (IMAGE_TYPE,))
        stamps, images, encodings, frames = [], [], [], set()
        for k, (_, msg) in enumerate(bag_messages(reader, name, conns)):
            if k % every:
                continue
            try:
                images.append(image_array(msg, order))
            except BagError as exc:
                raise BagError(f"{name}, {topic}: {exc}") from None
            stamps.append(stamp_ns(msg.header))
            encodings.append(msg.encoding)
            frames.add(msg.header.frame_id.lstrip("/"))
        origin = int(reader.start_time)
    if not images:
        raise BagTopicError(f"{name}: topic {topic!r} has no messages")
    idx = np.argsort(np.asarray(stamps, dtype=np.int64), kind="stable")
    return BagImages(
        (np.asarray(stamps, dtype=np.int64)[idx] - origin) * 1e-9,
        [images[i] for i in idx],
        [encodings[i] for i in idx],
        ", ".join(sorted(frames)),
        origin,
        order,
    )
