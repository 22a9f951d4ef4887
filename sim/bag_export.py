"""A simulated camera placement written as a real cell records it: a ROS 2 bag per recording.

For checking the import of real recordings (:mod:`handeye.import_bag`) against a known truth. Each
placement's recordings become two bags, ``cam_XXXX_data`` and ``cam_XXXX_calibration``, as a robot cell
with an RGB-D camera and a ROS 2 driver would write them:

* the robot drives from one pose to the next (linearly in joint space for ``move_s`` seconds), stands
  still for ``still_s`` seconds, and the camera's frame of that pose is stamped in the middle of the
  stillness: the images are the simulator's still frames, so none is stamped while the robot moves;
* ``/joint_states`` at ``joint_rate_hz`` throughout, the joints sorted by name as a driver lists them,
  with a gripper joint the robot model does not have;
* ``/tf``: ``base_link -> tool0`` at every joint state (robot_state_publisher's composed chain);
* colour (``rgb8`` Image, or CompressedImage as JPEG or PNG), depth (``16UC1`` millimetres or ``32FC1``
  metres, registered to the colour camera) and the colour camera's ``camera_info``, the colour stamped
  ``color_delay_s`` after the depth (a sensor whose streams are not hardware-synchronised).

Written with ``rosbags`` (``pip install "handeye[ros]"``), sqlite3 or MCAP storage.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from handeye.core.optional import require_package
from handeye.core.se3 import pos_quat_xyzw_from_transform

__all__ = ["EPOCH_NS", "GRIPPER_JOINT", "BagTiming", "BagWriter", "write_placement_bags"]

#: Header stamps on a wall clock (2023-11-14), as a live robot's are.
EPOCH_NS = 1_700_000_000 * 10**9
#: A joint the driver publishes and the arm's model does not have (it must be ignored on import).
GRIPPER_JOINT = "gripper_finger_joint"
_STORAGES = ("sqlite3", "mcap")


@dataclass(frozen=True)
class BagTiming:
    """How the recorded cell moves and stamps (:func:`write_placement_bags`).

    Attributes
    ----------
    color_delay_s : float
        The colour stamp after the depth stamp (a sensor whose streams are not hardware-synchronised).
    move_s, still_s : float
        The drive between poses and the stillness around each frame.
    joint_rate_hz : float
        ``/joint_states`` and ``/tf`` rate.
    """

    color_delay_s: float = 0.004
    move_s: float = 1.0
    still_s: float = 0.5
    joint_rate_hz: float = 125.0


class BagWriter:
    """A rosbags writer with the message constructors used here: :meth:`add` holds a message, :meth:`close`
    writes them all in log order (``benchmarks/reliability_faults.py`` wraps :meth:`add` to spoil messages).

    Parameters
    ----------
    path : Path
        The bag folder to create.
    storage : {"sqlite3", "mcap"}
    """

    def __init__(self, path: Path, storage: str):
        require_package("rosbags", extra="ros", purpose="writing ROS 2 bags")
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore

        self.ts = get_typestore(Stores.ROS2_HUMBLE)
        self.M = self.ts.types
        plugin = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}[storage]
        self.writer = Writer(path, version=9, storage_plugin=plugin)
        self.messages: list = []

    def header(self, stamp_ns: int, frame: str):
        M = self.M
        return M["std_msgs/msg/Header"](M["builtin_interfaces/msg/Time"](stamp_ns // 10**9, stamp_ns % 10**9), frame)

    def add(self, topic: str, msgtype: str, stamp_ns: int, msg) -> None:
        self.messages.append((topic, msgtype, int(stamp_ns), msg))

    def close(self) -> None:
        """Write the messages in log order (the header stamp plus a small transport delay)."""
        with self.writer as writer:
            conns = {}
            for topic, msgtype, stamp, msg in sorted(self.messages, key=lambda m: m[2]):
                if topic not in conns:
                    conns[topic] = writer.add_connection(topic, msgtype, typestore=self.ts)
                writer.write(conns[topic], stamp + 2_000_000, self.ts.serialize_cdr(msg, msgtype))


def _image(bag: BagWriter, stamp: int, frame: str, pixels: np.ndarray, encoding: str):
    h, w = pixels.shape[:2]
    data = np.ascontiguousarray(pixels).reshape(h, -1).view(np.uint8)
    return bag.M["sensor_msgs/msg/Image"](bag.header(stamp, frame), h, w, encoding, 0, data.shape[1], data.reshape(-1))


def _compressed(bag: BagWriter, stamp: int, frame: str, rgb: np.ndarray, fmt: str):
    import cv2

    ok, buf = cv2.imencode(".jpg" if fmt == "jpeg" else ".png", rgb[..., ::-1])
    return bag.M["sensor_msgs/msg/CompressedImage"](
        bag.header(stamp, frame), f"rgb8; {fmt} compressed bgr8", buf.reshape(-1)
    )


def _camera_info(bag: BagWriter, stamp: int, frame: str, intrinsics: dict):
    K = np.asarray(intrinsics["K"], dtype=float)
    d = np.asarray(intrinsics.get("dist", np.zeros(5)), dtype=float)
    P = np.concatenate([K, np.zeros((3, 1))], axis=1)
    roi = bag.M["sensor_msgs/msg/RegionOfInterest"](0, 0, 0, 0, False)
    return bag.M["sensor_msgs/msg/CameraInfo"](
        bag.header(stamp, frame),
        int(intrinsics["height"]),
        int(intrinsics["width"]),
        "plumb_bob",
        d,
        K.reshape(-1),
        np.eye(3).reshape(-1),
        P.reshape(-1),
        0,
        0,
        roi,
    )


def _robot_messages(bag: BagWriter, robot, q: np.ndarray, t0_ns: int, timing: BagTiming):
    """Joint states and tf over the drive through ``q`` (K, nq); returns the frames' stamps (the stills' middles)."""
    move_s, still_s, rate_hz = timing.move_s, timing.still_s, timing.joint_rate_hz
    names = [str(n) for n in list(robot.model.names)[1:]]
    published = sorted(names + [GRIPPER_JOINT])
    cols = [names.index(n) if n in names else -1 for n in published]
    period = move_s + still_s
    stamps = t0_ns + ((np.arange(len(q)) * period + move_s + still_s / 2) * 1e9).astype(np.int64)
    end = len(q) * period
    tf_type = "tf2_msgs/msg/TFMessage"
    M = bag.M
    for t in np.arange(0.0, end, 1.0 / rate_hz):
        k = min(int(t // period), len(q) - 1)
        into = t - k * period
        prev = q[k - 1] if k > 0 else q[0]
        w = min(into / move_s, 1.0) if move_s > 0 else 1.0
        qt = (1 - w) * prev + w * q[k]
        stamp = t0_ns + int(round(t * 1e9))
        pos = np.array([qt[c] if c >= 0 else 0.01 for c in cols])
        bag.add(
            "/joint_states",
            "sensor_msgs/msg/JointState",
            stamp,
            M["sensor_msgs/msg/JointState"](bag.header(stamp, ""), published, pos, np.zeros(0), np.zeros(0)),
        )
        trans, quat = pos_quat_xyzw_from_transform(robot.fk(qt))
        tr = M["geometry_msgs/msg/Transform"](
            M["geometry_msgs/msg/Vector3"](*trans), M["geometry_msgs/msg/Quaternion"](*quat)
        )
        bag.add(
            "/tf",
            tf_type,
            stamp,
            M[tf_type]([M["geometry_msgs/msg/TransformStamped"](bag.header(stamp, "base_link"), "tool0", tr)]),
        )
    return stamps


def write_placement_bags(
    ds,
    camera_id: int,
    out: str | Path,
    storage: str = "sqlite3",
    depth_encoding: str = "16UC1",
    color_format: str = "raw",
    timing: BagTiming | None = None,
) -> dict:
    """Write one camera placement's recordings of a simulated dataset as ROS 2 bags.

    Parameters
    ----------
    ds : handeye.core.dataset.Dataset
    camera_id : int
    out : str or Path
        Folder for the bags (created).
    storage : {"sqlite3", "mcap"}
    depth_encoding : {"16UC1", "32FC1"}
        Millimetres (rounded, as a driver delivers them) or float metres.
    color_format : {"raw", "jpeg", "png"}
    timing : BagTiming, optional
        The drive, the stillness, the joint states' rate and the colour's delay; None: ``BagTiming()``.

    Returns
    -------
    dict
        ``{"data": Path, "calibration": Path}`` (the recordings the dataset has).

    Raises
    ------
    HandEyeInputError
        An unknown storage, encoding or format.
    """
    from handeye.core.errors import HandEyeInputError
    from handeye.robot.model import load_robot_entry

    if (
        storage not in _STORAGES
        or depth_encoding not in ("16UC1", "32FC1")
        or color_format not in ("raw", "jpeg", "png")
    ):
        raise HandEyeInputError(
            f"storage {storage!r} (sqlite3, mcap), depth {depth_encoding!r} (16UC1, 32FC1), colour {color_format!r} "
            "(raw, jpeg, png)"
        )
    timing = timing or BagTiming()
    robot = load_robot_entry(ds.meta["robot"])
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = {}
    for recording in ("data", "calibration"):
        rows = ds.select(camera_id, recording)
        if not len(rows["frame"]):
            continue
        path = out / f"cam_{camera_id:04d}_{recording}"
        bag = BagWriter(path, storage)
        stamps = _robot_messages(bag, robot, ds.joints(rows), EPOCH_NS, timing)
        intr = (
            ds.meta["intrinsics"]
            if recording == "data"
            else ds.meta.get("calibration_intrinsics", ds.meta["intrinsics"])
        )
        frame = "camera_color_optical_frame"
        color_delay = int(round(timing.color_delay_s * 1e9))
        for k, stamp in enumerate(stamps):
            rgb = ds.rgb(camera_id, rows["rgb"][k])
            c_stamp = int(stamp) + (color_delay if recording == "data" else 0)
            if color_format == "raw":
                msg, kind = _image(bag, c_stamp, frame, rgb, "rgb8"), "sensor_msgs/msg/Image"
            else:
                msg, kind = _compressed(bag, c_stamp, frame, rgb, color_format), "sensor_msgs/msg/CompressedImage"
            bag.add("/camera/color/image_raw", kind, c_stamp, msg)
            bag.add(
                "/camera/color/camera_info",
                "sensor_msgs/msg/CameraInfo",
                c_stamp,
                _camera_info(bag, c_stamp, frame, intr),
            )
            if recording == "data":
                depth_m = ds.depth_m(camera_id, rows["depth"][k])
                if depth_encoding == "16UC1":
                    pixels = np.clip(np.rint(depth_m * 1e3), 0, 65535).astype(np.uint16)
                else:
                    pixels = np.where(depth_m > 0, depth_m, np.nan).astype(np.float32)
                bag.add(
                    "/camera/aligned_depth_to_color/image_raw",
                    "sensor_msgs/msg/Image",
                    int(stamp),
                    _image(bag, int(stamp), frame, pixels, depth_encoding),
                )
        bag.close()
        written[recording] = path
    return written
