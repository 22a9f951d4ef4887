"""A ROS 2 bag of an RGB-D camera and a robot to a :class:`~handeye.recording_import.RecordedPlacement`.

One pass over the bag (sqlite3 or MCAP storage, read with ``rosbags``: no ROS installation) reads

* the depth topic: ``sensor_msgs/msg/Image`` in ``16UC1``/``mono16`` (millimetres) or ``32FC1`` (metres), or
  ``sensor_msgs/msg/CompressedImage`` of image_transport's ``compressedDepth`` PNG form (16-bit); another unit
  with ``depth_unit_m``. A frame whose valid depth is implausible in that unit (its median outside
  :data:`handeye.recording_checks.DEPTH_MEDIAN_RANGE_M`: millimetres in a 32FC1 image) is refused with the unit
  that fits, as is a depth topic without one valid pixel;
* the colour topic: ``sensor_msgs/msg/Image`` (``rgb8``, ``bgr8``, ``mono8``, ...) or ``CompressedImage``
  (JPEG or PNG);
* the ``camera_info`` topic of the camera the depth is registered to (the colour camera's): size, ``K``,
  plumb_bob or rational_polynomial distortion; every message must agree; a ``K`` no camera has (``fx`` of
  1e-300, the principal point outside the image) is refused naming the field
  (:func:`handeye.recording_checks.check_camera_matrix`);
* ``sensor_msgs/msg/JointState`` (names matched to the robot model's joints; a name listed twice in a message
  is refused) and/or tf (the flange's pose in the base, chained through ``/tf`` and ``/tf_static``:
  :mod:`handeye.tf_tree`).

Stamps are the messages' header stamps, seconds since the bag's start, so every stream shares the
sensor's clock. A topic that is missing or holds another type is a :class:`BagTopicError` listing the
bag's topics.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from handeye.core.errors import BagError, BagTopicError, RecordingError
from handeye.core.limits import check_image_bytes
from handeye.recording_checks import check_camera_matrix, check_depth_frame, check_depth_stream, check_joint_names
from handeye.recording_import import JointSamples, PoseSamples, RecordedPlacement, TimedImages
from handeye.ros_bag import IMAGE_TYPE, bag_messages, image_array, open_bag, read_bag, stamp_ns, topic_connections

__all__ = ["INFO_TYPE", "JOINTS_TYPE", "COMPRESSED_TYPE", "TfSource", "read_camera_bag"]

INFO_TYPE = "sensor_msgs/msg/CameraInfo"
JOINTS_TYPE = "sensor_msgs/msg/JointState"
COMPRESSED_TYPE = "sensor_msgs/msg/CompressedImage"
#: image_transport's compressedDepth messages start with a 12-byte ConfigHeader (format, two floats)
#: before the PNG.
_COMPRESSED_DEPTH_HEADER = 12


def _decode_compressed(msg, where: str, depth: bool) -> np.ndarray:
    import cv2

    data = np.frombuffer(bytes(msg.data), dtype=np.uint8)
    fmt = str(msg.format).lower()
    if depth:
        if "compresseddepth" not in fmt or "png" not in fmt:
            raise BagError(f"{where}: compressed depth of format {msg.format!r}; read: compressedDepth PNG")
        if "32fc1" in fmt:
            raise BagError(f"{where}: compressedDepth of 32FC1 (quantised inverse depth) is not read; record 16UC1")
        data = data[_COMPRESSED_DEPTH_HEADER:]
    check_image_bytes(data.tobytes(), where, BagError)
    img = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    if img is None:
        raise BagError(f"{where}: the compressed image ({msg.format!r}) cannot be decoded")
    if depth:
        if img.dtype != np.uint16 or img.ndim != 2:
            raise BagError(f"{where}: compressedDepth decoded to {img.dtype} {img.shape}, expected 16-bit")
        return img
    if img.ndim == 2:
        img = cv2.cvtColor(img, cv2.COLOR_GRAY2RGB)
    elif img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2RGB)
    else:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
    return img


def _color(msg, msgtype: str, where: str) -> np.ndarray:
    if msgtype == COMPRESSED_TYPE:
        return _decode_compressed(msg, where, depth=False)
    try:
        img = image_array(msg, "rgb")
    except BagError as exc:
        raise BagError(f"{where}: {exc}") from None
    if img.dtype != np.uint8:
        raise BagError(f"{where}: colour of encoding {msg.encoding!r}; an 8-bit colour or mono image is needed")
    return np.repeat(img[..., None], 3, axis=2) if img.ndim == 2 else img


def _depth(msg, msgtype: str, where: str, depth_unit_m: float | None) -> np.ndarray:
    """Depth in metres (0 or NaN: none), its unit checked against the plausible range."""
    if msgtype == COMPRESSED_TYPE:
        img = _decode_compressed(msg, where, depth=True)
    else:
        try:
            img = image_array(msg)
        except BagError as exc:
            raise BagError(f"{where}: {exc}") from None
        if img.ndim != 2 or img.dtype == np.uint8:
            raise BagError(f"{where}: depth of encoding {msg.encoding!r}; read: 16UC1/mono16 (units) or 32FC1 (metres)")
    unit = depth_unit_m if depth_unit_m is not None else (1e-3 if img.dtype == np.uint16 else 1.0)
    depth = img.astype(np.float32) * np.float32(unit)
    check_depth_frame(depth, unit, where)
    return depth


def _intrinsics(msg, where: str):
    from classic.vision.camera import CameraIntrinsics, IntrinsicsError
    from classic.vision.camera_yaml import ROS_DISTORTION_MODELS

    d = np.asarray(msg.d, dtype=float)
    model = str(msg.distortion_model)
    if d.size and np.any(d) and model not in ROS_DISTORTION_MODELS:
        raise BagError(f"{where}: distortion model {model!r} is not read; read: {', '.join(ROS_DISTORTION_MODELS)}")
    if d.size == 0:
        d = np.zeros(5)
    check_camera_matrix(msg.k, msg.width, msg.height, where)
    try:
        return CameraIntrinsics(np.asarray(msg.k, dtype=float).reshape(3, 3), d, int(msg.width), int(msg.height))
    except IntrinsicsError as exc:  # the field of view (FOV_RANGE_DEG) is checked there, not twice
        raise IntrinsicsError(f"{where}: {exc}") from None


def read_camera_bag(
    bag,
    color_topic: str,
    info_topic: str,
    depth_topic: str | None = None,
    joints_topic: str | None = "/joint_states",
    tf_frames: tuple | None = None,
    depth_unit_m: float | None = None,
) -> RecordedPlacement:
    """Read one camera placement's recording from a ROS 2 bag.

    Parameters
    ----------
    bag : str or Path
        A rosbag2 directory (or the ``.db3``/``.mcap`` file in it).
    color_topic : str
        ``sensor_msgs/msg/Image`` or ``CompressedImage``.
    info_topic : str
        ``sensor_msgs/msg/CameraInfo`` of the colour camera (to which the depth is registered).
    depth_topic : str, optional
        ``sensor_msgs/msg/Image`` (16UC1, mono16, 32FC1) or compressedDepth; None for a calibration recording.
    joints_topic : str or None
        ``sensor_msgs/msg/JointState``; None reads no joints (then ``tf_frames`` is needed).
    tf_frames : (str, str) or TfSource, optional
        ``(base_frame, ee_frame)``: ``T_base_ee`` from tf instead of the joints' forward kinematics; a
        :class:`TfSource` names other tf topics too.
    depth_unit_m : float, optional
        Metres per unit of the depth as recorded; None: the encoding's convention (``REP 118``): 1e-3
        (millimetres) for 16-bit depth, 1 (metres) for 32FC1.

    Returns
    -------
    RecordedPlacement

    Raises
    ------
    NotABagError, BagTopicError, BagError
        Naming the bag and topic; a record the bag's storage cannot read.
    RecordingError
        Neither joints nor tf asked for; a topic without messages; depth in another unit than ``depth_unit_m``
        (the unit that fits named) or without a valid pixel; a joint name twice in a message.
    IntrinsicsError
        A ``camera_info`` no camera has, naming the field.
    """
    _check_arguments(bag, joints_topic, tf_frames, depth_unit_m)
    topics = _Topics(color_topic, info_topic, depth_topic, joints_topic)
    with open_bag(bag) as reader:
        name = str(Path(reader.paths[0]))
        streams = _Streams(name, topics, depth_unit_m)
        for conn, msg in bag_messages(reader, name, _connections(reader, name, topics)):
            streams.add(conn, msg)
        origin = int(reader.start_time)
    streams.check_complete()
    poses = None if tf_frames is None else _tf_poses(bag, name, TfSource(*tf_frames))
    return RecordedPlacement(name, streams.info, *streams.timed(origin), poses)


class TfSource(NamedTuple):
    """Where :func:`read_camera_bag` finds the flange's pose in tf: the two frames and the tf topics."""

    base_frame: str
    ee_frame: str
    topic: str = "/tf"
    static_topic: str = "/tf_static"


class _Topics(NamedTuple):
    """The topics :func:`read_camera_bag` reads (depth and joints optional)."""

    color: str
    info: str
    depth: str | None
    joints: str | None


def _check_arguments(bag, joints_topic: str | None, tf_frames, depth_unit_m: float | None) -> None:
    """Refuse a read without the robot's motion, or a depth unit that is not a positive number."""
    if joints_topic is None and tf_frames is None:
        raise RecordingError(f"{bag}: give the joint states topic or the tf base and flange frames")
    if depth_unit_m is not None and not (np.isfinite(depth_unit_m) and depth_unit_m > 0):
        raise RecordingError(f"depth_unit_m must be finite and > 0, got {depth_unit_m!r}")


def _connections(reader, name: str, topics: _Topics) -> list:
    """The bag's connections of the topics asked for, each checked to be there with a type read here."""
    image_types = (IMAGE_TYPE, COMPRESSED_TYPE)
    conns = topic_connections(reader, name, topics.color, image_types) + topic_connections(
        reader, name, topics.info, (INFO_TYPE,)
    )
    if topics.depth:
        conns += topic_connections(reader, name, topics.depth, image_types)
    if topics.joints:
        conns += topic_connections(reader, name, topics.joints, (JOINTS_TYPE,))
    return conns


class _Streams:
    """What the pass over a bag has read: per topic the stamps and items, the camera_info, the joints' names."""

    def __init__(self, name: str, topics: _Topics, depth_unit_m: float | None):
        self.name, self.topics, self.depth_unit_m = name, topics, depth_unit_m
        self.streams = {t: {"stamps": [], "items": []} for t in topics if t}
        self.joint_samples = []
        self.joint_names = None
        self.info = None

    def add(self, conn, msg) -> None:
        """One message: a camera_info checked against the first, or an item of its topic's stream."""
        stamp = stamp_ns(msg.header)
        where = f"{self.name}, {conn.topic} at stamp {stamp}"
        if conn.topic == self.topics.info:
            self._add_info(msg, where)
            return
        if conn.topic == self.topics.joints:
            item = self._joint_positions(msg, where, stamp)
            if item is None:
                return
        elif conn.topic == self.topics.depth:
            item = _depth(msg, conn.msgtype, where, self.depth_unit_m)
        else:
            item = _color(msg, conn.msgtype, where)
        self.streams[conn.topic]["stamps"].append(stamp)
        self.streams[conn.topic]["items"].append(item)

    def _add_info(self, msg, where: str) -> None:
        """The camera's intrinsics, the same in every camera_info message."""
        intr = _intrinsics(msg, where)
        if self.info is None:
            self.info = intr
        elif intr.to_dict() != self.info.to_dict():
            raise BagError(f"{where}: the camera_info changed during the recording; one camera per bag")

    def _joint_positions(self, msg, where: str, stamp: int) -> np.ndarray | None:
        """A JointState's positions in the first message's joint order; None for a partial message."""
        names = [str(n) for n in msg.name]
        check_joint_names(names, where)
        pos = np.asarray(msg.position, dtype=float)
        if len(pos) != len(names):
            raise BagError(f"{where}: {len(names)} joint names and {len(pos)} positions")
        if self.joint_names is None:
            self.joint_names = names
        if names != self.joint_names:  # another order or subset: reorder to the first message's names
            if set(self.joint_names) - set(names):
                return None  # a partial message (some drivers publish joint groups apart)
            pos = pos[[names.index(n) for n in self.joint_names]]
        self.joint_samples.append(f"the message stamped {stamp} ns")
        return pos

    def check_complete(self) -> None:
        """Refuse a topic without messages, and a depth stream the checks refuse."""
        for topic, s in self.streams.items():
            if topic != self.topics.info and not s["items"]:
                raise BagTopicError(f"{self.name}: topic {topic!r} has no messages")
        if self.info is None:
            raise BagTopicError(f"{self.name}: topic {self.topics.info!r} has no messages")
        if self.topics.depth:
            check_depth_stream(self.streams[self.topics.depth]["items"], f"{self.name}, {self.topics.depth}")

    def timed(self, origin: int) -> tuple:
        """``(color, depth, joints)`` with stamps in seconds since ``origin`` (ns); depth and joints may be None."""
        color = self._images(self.topics.color, origin)
        depth = self._images(self.topics.depth, origin) if self.topics.depth else None
        joints = None
        if self.topics.joints:
            topic = self.topics.joints
            items = np.array(self.streams[topic]["items"])
            joints = JointSamples(
                self._seconds(topic, origin), self.joint_names, items, f"{self.name}, {topic}", self.joint_samples
            )
        return color, depth, joints

    def _seconds(self, topic: str, origin: int) -> np.ndarray:
        return (np.asarray(self.streams[topic]["stamps"], dtype=np.int64) - origin) * 1e-9

    def _images(self, topic: str, origin: int) -> TimedImages:
        return TimedImages(self._seconds(topic, origin), self.streams[topic]["items"], f"{self.name}, {topic}")


def _tf_poses(bag, name: str, tf: TfSource) -> PoseSamples:
    """``T_base_ee`` over time from the bag's tf (a second pass, :func:`handeye.ros_bag.read_bag`)."""
    rec = read_bag(bag, tf.base_frame, tf.ee_frame, tf_topic=tf.topic, tf_static_topic=tf.static_topic)
    return PoseSamples(rec.robot_times_s, rec.T_base_ee, f"{name}, tf {' -> '.join(rec.frames)}")
