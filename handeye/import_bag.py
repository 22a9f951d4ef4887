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

import numpy as np

from handeye.core.errors import BagError, BagTopicError, RecordingError
from handeye.core.limits import check_image_bytes
from handeye.recording_checks import check_camera_matrix, check_depth_frame, check_depth_stream, check_joint_names
from handeye.recording_import import JointSamples, PoseSamples, RecordedPlacement, TimedImages
from handeye.ros_bag import IMAGE_TYPE, bag_messages, image_array, open_bag, stamp_ns, topic_connections

__all__ = ["INFO_TYPE", "JOINTS_TYPE", "COMPRESSED_TYPE", "read_camera_bag"]

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
    tf_topic: str = "/tf",
    tf_static_topic: str = "/tf_static",
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
    tf_frames : (str, str), optional
        ``(base_frame, ee_frame)``: ``T_base_ee`` from tf instead of the joints' forward kinematics.
    depth_unit_m : float, optional
        Metres per unit of the depth as recorded; None: the encoding's convention (``REP 118``): 1e-3
        (millimetres) for 16-bit depth, 1 (metres) for 32FC1.
    tf_topic, tf_static_topic : str

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
    from handeye.ros_bag import read_bag

    if joints_topic is None and tf_frames is None:
        raise RecordingError(f"{bag}: give the joint states topic or the tf base and flange frames")
    if depth_unit_m is not None and not (np.isfinite(depth_unit_m) and depth_unit_m > 0):
        raise RecordingError(f"depth_unit_m must be finite and > 0, got {depth_unit_m!r}")
    image_types = (IMAGE_TYPE, COMPRESSED_TYPE)
    with open_bag(bag) as reader:
        name = str(Path(reader.paths[0]))
        conns = topic_connections(reader, name, color_topic, image_types) + topic_connections(
            reader, name, info_topic, (INFO_TYPE,)
        )
        if depth_topic:
            conns += topic_connections(reader, name, depth_topic, image_types)
        if joints_topic:
            conns += topic_connections(reader, name, joints_topic, (JOINTS_TYPE,))
        streams = {t: {"stamps": [], "items": []} for t in (color_topic, info_topic, depth_topic, joints_topic) if t}
        joint_samples = []
        joint_names = None
        info = None
        for conn, msg in bag_messages(reader, name, conns):
            stamp = stamp_ns(msg.header)
            where = f"{name}, {conn.topic} at stamp {stamp}"
            if conn.topic == info_topic:
                intr = _intrinsics(msg, where)
                if info is None:
                    info = intr
                elif intr.to_dict() != info.to_dict():
                    raise BagError(f"{where}: the camera_info changed during the recording; one camera per bag")
                continue
            if conn.topic == joints_topic:
                names = [str(n) for n in msg.name]
                check_joint_names(names, where)
                pos = np.asarray(msg.position, dtype=float)
                if len(pos) != len(names):
                    raise BagError(f"{where}: {len(names)} joint names and {len(pos)} positions")
                if joint_names is None:
                    joint_names = names
                if names != joint_names:  # another order or subset: reorder to the first message's names
                    if set(joint_names) - set(names):
                        continue  # a partial message (some drivers publish joint groups apart)
                    pos = pos[[names.index(n) for n in joint_names]]
                item = pos
                joint_samples.append(f"the message stamped {stamp} ns")
            elif conn.topic == depth_topic:
                item = _depth(msg, conn.msgtype, where, depth_unit_m)
            else:
                item = _color(msg, conn.msgtype, where)
            streams[conn.topic]["stamps"].append(stamp)
            streams[conn.topic]["items"].append(item)
        origin = int(reader.start_time)
    for topic, s in streams.items():
        if topic != info_topic and not s["items"]:
            raise BagTopicError(f"{name}: topic {topic!r} has no messages")
    if info is None:
        raise BagTopicError(f"{name}: topic {info_topic!r} has no messages")
    if depth_topic:
        check_depth_stream(streams[depth_topic]["items"], f"{name}, {depth_topic}")

    def seconds(topic):
        return (np.asarray(streams[topic]["stamps"], dtype=np.int64) - origin) * 1e-9

    color = TimedImages(seconds(color_topic), streams[color_topic]["items"], f"{name}, {color_topic}")
    depth = None
    if depth_topic:
        depth = TimedImages(seconds(depth_topic), streams[depth_topic]["items"], f"{name}, {depth_topic}")
    joints = None
    if joints_topic:
        joints = JointSamples(
            seconds(joints_topic),
            joint_names,
            np.array(streams[joints_topic]["items"]),
            f"{name}, {joints_topic}",
            joint_samples,
        )
    poses = None
    if tf_frames is not None:
        rec = read_bag(bag, tf_frames[0], tf_frames[1], tf_topic=tf_topic, tf_static_topic=tf_static_topic)
        poses = PoseSamples(rec.robot_times_s, rec.T_base_ee, f"{name}, tf {' -> '.join(rec.frames)}")
    return RecordedPlacement(name, info, color, depth, joints, poses)
