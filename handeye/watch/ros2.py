"""Live ROS 2 for the watcher: frames from topics (:class:`Ros2Frames`), the calibration as a static transform
(:class:`TfPublisher`). Both import ``rclpy`` lazily; without it :func:`require_rclpy` says how to get it.

**Untested against a real ROS 2**: rclpy is not installable from PyPI, so the tests run this code against a
small fake ``rclpy``/``tf2_ros`` that records the calls (tests/watch/test_ros2.py); the message fields used are
those of ``sensor_msgs/msg/Image``, ``CameraInfo``, ``JointState`` and ``geometry_msgs/msg/TransformStamped``.

A user runs, in a shell where ROS 2 is sourced::

    handeye watch --ros2 --sensor d435 --camera-start start.json --history cell.jsonl --current cell.json \\
        --depth-topic /camera/aligned_depth_to_color/image_raw --info-topic /camera/color/camera_info \\
        --joints-topic /joint_states --base-frame base_link --camera-frame camera_color_optical_frame

Each depth image becomes a :class:`handeye.watch.Frame` with the joints of the ``JointState`` nearest its stamp
within ``joint_tolerance_s`` (not interpolated: off by up to half the driver's period of motion; none: the frame
is left out and counted); its time is seconds since the first depth image's stamp. The depth is read as the bag
reader reads it (:func:`handeye.ros_bag.image_array`; 16-bit in millimetres, 32FC1 in metres, REP 118) and must
be registered to the camera of ``camera_info`` (the first one; a different one later is refused), of its size
(another size is refused, as the import refuses it), without distortion (a distorted one is refused: replay a bag,
which undistorts as the import does). The colour topic (``Ros2Topics.color``, None for none) gives each frame the
colour image nearest its stamp within the same tolerance (the continual learner's input).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.watch.source import Frame

__all__ = ["BASE_FRAME", "STATUS_TOPIC", "Ros2Topics", "Ros2Frames", "TfPublisher", "require_rclpy"]

#: What a user does to get rclpy (it comes with ROS 2, not from PyPI).
RCLPY_HINT = (
    "watching live ROS 2 topics needs rclpy, which comes with a ROS 2 installation (Humble or later), not from "
    "pip: install ROS 2 and run `source /opt/ros/<distro>/setup.bash` in this shell, with this Python the "
    "distribution's (python3 -c 'import rclpy, tf2_ros' must work); or replay a recording: handeye watch BAG"
)
#: The static transform's parent frame: the robot model's root, the frame its kinematics (and so ``T_base_cam``)
#: are in; for the UR models ``base_link`` (UR's ``base`` link is turned 180 degrees about z from it).
BASE_FRAME = "base_link"
#: Joint samples kept to pair with depth stamps (a few seconds at a driver's 100-500 Hz).
JOINT_SAMPLES_KEPT = 1000
#: Colour images kept to pair with depth stamps (a second at 30 Hz).
COLOUR_IMAGES_KEPT = 30
#: The calibration's status (std_msgs/String, JSON; :class:`TfPublisher`): tf cannot say a pose is stale.
STATUS_TOPIC = "/handeye/calibration_status"
#: The latched static transforms read before publishing (:meth:`TfPublisher.attach`).
STATIC_TOPIC = "/tf_static"
#: Seconds ``/tf_static`` is read for (latched: a running driver's tree comes within the first spins).
TF_STATIC_WAIT_S = 2.0


def require_rclpy():
    """The ``rclpy`` module.

    Raises
    ------
    HandEyeInputError
        Without rclpy, saying how to get it (:data:`RCLPY_HINT`).
    """
    try:
        import rclpy
    except ImportError:
        raise HandEyeInputError(RCLPY_HINT) from None
    return rclpy


def _stamp_s(header) -> float:
    return float(header.stamp.sec) + 1e-9 * float(header.stamp.nanosec)


@dataclass(frozen=True)
class Ros2Topics:
    """The topics subscribed to (the RealSense driver's names by default)."""

    depth: str = "/camera/aligned_depth_to_color/image_raw"
    info: str = "/camera/color/camera_info"
    joints: str = "/joint_states"
    color: str | None = "/camera/color/image_raw"


class Ros2Frames:
    """Frames from live ROS 2 topics (module docstring; untested against a real ROS 2).

    Parameters
    ----------
    joint_names : list of str
        The robot model's joints, in its order; a JointState without one of them is skipped.
    topics : Ros2Topics, optional
    depth_unit_m : float, optional
        Metres per depth unit; None: 1e-3 for 16-bit depth, 1 for 32FC1.
    joint_tolerance_s : float
        Largest gap between a depth stamp and the joint sample it takes.
    node_name : str
    """

    def __init__(
        self,
        joint_names: list,
        topics: Ros2Topics | None = None,
        depth_unit_m: float | None = None,
        joint_tolerance_s: float = 0.02,
        node_name: str = "handeye_watch",
    ):
        self.rclpy = require_rclpy()
        from sensor_msgs.msg import CameraInfo, Image, JointState

        self.joint_names = [str(n) for n in joint_names]
        self.topics = topics or Ros2Topics()
        self.depth_unit_m = depth_unit_m
        self.joint_tolerance_s = float(joint_tolerance_s)
        if not self.rclpy.ok():
            self.rclpy.init()
        self.node = self.rclpy.create_node(node_name)
        self.K: np.ndarray | None = None
        self.size: tuple | None = None
        self.dropped = {"no camera_info yet": 0, "no joints within the tolerance": 0}
        self._joints: deque = deque(maxlen=JOINT_SAMPLES_KEPT)  # (stamp_s, q in the model's order)
        self._colour: deque = deque(maxlen=COLOUR_IMAGES_KEPT)  # (stamp_s, message), decoded when taken
        self._pending: deque = deque()
        self._origin: float | None = None
        self._index = 0
        self.node.create_subscription(CameraInfo, self.topics.info, self._on_info, 10)
        self.node.create_subscription(JointState, self.topics.joints, self._on_joints, 100)
        self.node.create_subscription(Image, self.topics.depth, self._on_depth, 10)
        if self.topics.color:
            self.node.create_subscription(Image, self.topics.color, self._on_colour, 10)

    def _on_info(self, msg) -> None:
        from handeye.recording_checks import check_camera_matrix

        where = f"{self.topics.info}"
        check_camera_matrix(msg.k, msg.width, msg.height, where)
        if np.any(np.asarray(msg.d, dtype=float)):
            raise HandEyeInputError(
                f"{where}: distortion {list(msg.d)}: the live source takes rectified depth (a camera_info without "
                "distortion, as aligned RealSense depth has); record a bag and replay it, which undistorts"
            )
        K, size = np.asarray(msg.k, dtype=float).reshape(3, 3), (int(msg.width), int(msg.height))
        if self.K is not None and (size != self.size or not np.array_equal(K, self.K)):
            raise HandEyeInputError(
                f"{where}: the camera_info changed ({self.size[0]}x{self.size[1]}, K {self.K.tolist()} -> "
                f"{size[0]}x{size[1]}, K {K.tolist()}): the watcher keeps the first camera's K; restart it"
            )
        self.K, self.size = K, size

    def _on_joints(self, msg) -> None:
        names = [str(n) for n in msg.name]
        if any(n not in names for n in self.joint_names):
            return  # a group of other joints (a gripper's)
        pos = np.asarray(msg.position, dtype=float)
        self._joints.append((_stamp_s(msg.header), pos[[names.index(n) for n in self.joint_names]]))

    def _on_colour(self, msg) -> None:
        self._colour.append((_stamp_s(msg.header), msg))

    def _nearest(self, samples: deque, stamp: float):
        """The sample nearest ``stamp`` within the tolerance, None without one."""
        best = None
        for t, item in samples:
            gap = abs(t - stamp)
            if gap <= self.joint_tolerance_s and (best is None or gap < best[0]):
                best = (gap, item)
        return None if best is None else best[1]

    def _on_depth(self, msg) -> None:
        from handeye.recording_import import UNREGISTERED_DEPTH_HINT, check_image_size
        from handeye.ros_bag import image_array

        if self.K is None:
            self.dropped["no camera_info yet"] += 1
            return
        stamp = _stamp_s(msg.header)
        q = self._nearest(self._joints, stamp)
        if q is None:
            self.dropped["no joints within the tolerance"] += 1
            return
        if isinstance(msg.data, (bytes, bytearray, memoryview)):  # some bindings give bytes, not an array
            msg = _with_array_data(msg)
        img = image_array(msg)
        check_image_size(
            img, self.size, "the depth image", f"{self.topics.depth} at {stamp:.6f} s", UNREGISTERED_DEPTH_HINT
        )
        unit = self.depth_unit_m if self.depth_unit_m is not None else (1e-3 if img.dtype == np.uint16 else 1.0)
        depth = img.astype(np.float32) * np.float32(unit)
        depth = np.where(np.isfinite(depth) & (depth > 0), depth, 0).astype(np.float32)
        if self._origin is None:
            self._origin = stamp
        colour = self._nearest(self._colour, stamp)
        rgb = None if colour is None else _rgb(colour)
        if rgb is not None:
            check_image_size(rgb, self.size, "the colour image", f"{self.topics.color} at {stamp:.6f} s")
        self._pending.append(Frame(stamp - self._origin, depth, q, self._index, None, rgb))
        self._index += 1

    def wait_for_camera_info(self, timeout_s: float = 10.0) -> np.ndarray:
        """Spin until the camera_info has come; its ``K``.

        Raises
        ------
        HandEyeInputError
            None within ``timeout_s`` (naming the topic).
        """
        clock = self.node.get_clock()
        start = clock.now().nanoseconds
        while self.K is None and self.rclpy.ok():
            self.rclpy.spin_once(self.node, timeout_sec=0.1)
            if clock.now().nanoseconds - start > timeout_s * 1e9:
                raise HandEyeInputError(f"{self.topics.info}: no camera_info within {timeout_s:g} s")
        if self.K is None:
            raise HandEyeInputError(f"{self.topics.info}: ROS 2 shut down before a camera_info came")
        return self.K

    def __iter__(self) -> Iterator[Frame]:
        """The frames as they come, until ROS 2 shuts down (Ctrl-C)."""
        while self.rclpy.ok():
            self.rclpy.spin_once(self.node, timeout_sec=0.1)
            while self._pending:
                yield self._pending.popleft()

    def close(self) -> None:
        """Destroy the node (and shut rclpy down)."""
        self.node.destroy_node()
        if self.rclpy.ok():
            self.rclpy.shutdown()


def _rgb(msg) -> np.ndarray | None:
    """An 8-bit colour Image as (H, W, 3) RGB; None for another encoding (the frame then has no colour)."""
    from handeye.ros_bag import image_array

    if isinstance(msg.data, (bytes, bytearray, memoryview)):
        msg = _with_array_data(msg)
    img = image_array(msg, "rgb")
    if img.dtype != np.uint8:
        return None
    return np.repeat(img[..., None], 3, axis=2) if img.ndim == 2 else img


def _with_array_data(msg):
    """An Image's fields with its data as a numpy array (what :func:`handeye.ros_bag.image_array` reads)."""
    from types import SimpleNamespace

    fields = ("header", "height", "width", "encoding", "is_bigendian", "step")
    return SimpleNamespace(**{f: getattr(msg, f) for f in fields}, data=np.frombuffer(bytes(msg.data), np.uint8))


class TfPublisher:
    """The current calibration as a static transform ``parent_frame -> camera_frame`` (``T_base_cam``), and its
    status on :data:`STATUS_TOPIC`.

    Untested against a real ROS 2 (module docstring). A :class:`handeye.watch.CellWatcher` ``on_commit`` hook:
    called with each committed ``T_base_cam``; :meth:`start` for the start, :meth:`publish` for a rollback;
    :meth:`stale` its ``on_stale`` hook.

    **A stale calibration on tf**: a static transform cannot be withdrawn (``/tf_static`` is latched and tf2 keeps
    the last one), so from a ``moved`` until the next commit the old pose stays on tf and nothing new is sent
    there. What says it is stale: a ``std_msgs/String`` on :data:`STATUS_TOPIC` (transient local, so a late
    subscriber gets the last one), JSON ``{"calibration": "stale" | "valid", "stale_since": s | null,
    "version": n, "parent_frame", "child_frame"}``, sent ``valid`` with each transform and ``stale`` on a
    ``moved`` or at a restart on a version the record says is stale (:meth:`start`); and ``--current``'s JSON
    (``stale_since``). A consumer that picks must check one of them before it trusts the transform: tf alone
    cannot tell.

    **A camera frame that has a parent**: a camera driver publishes its own tree (``camera_link ->
    camera_color_optical_frame`` on ``/tf_static``); a second parent of the optical frame is rejected or flaps
    in tf2. :meth:`attach` reads ``/tf_static`` first: a camera frame with a static parent is reached through the
    root of its tree (``parent_frame -> root``, ``T_base_cam`` composed with the driver's chain); a tree already
    joined to ``parent_frame`` (a URDF that places the camera, another watcher) is refused, naming the chain.
    Parents on ``/tf`` (dynamic) are not seen.

    Parameters
    ----------
    node : rclpy.node.Node
    parent_frame, camera_frame : str
        The tf frame of the robot model's root, in which its kinematics give ``T_base_cam`` (:data:`BASE_FRAME`),
        and the depth camera's optical frame.

    Attributes
    ----------
    child_frame : str
        The frame published under ``parent_frame``: ``camera_frame``, or the root of its driver's tree after
        :meth:`attach`.
    T_cam_child : array, shape (4, 4)
        ``child_frame``'s pose in ``camera_frame`` (identity unless composed).
    """

    def __init__(self, node, parent_frame: str = BASE_FRAME, camera_frame: str = "camera_color_optical_frame"):
        from std_msgs.msg import String
        from tf2_ros import StaticTransformBroadcaster

        self.node = node
        self.parent_frame, self.camera_frame = parent_frame, camera_frame
        self.child_frame, self.T_cam_child = camera_frame, np.eye(4)
        self.broadcaster = StaticTransformBroadcaster(node)
        self.status = node.create_publisher(String, STATUS_TOPIC, _latched_qos())

    def __call__(self, T_base_cam: np.ndarray, frames=(), version: int | None = None) -> None:
        self.publish(T_base_cam, version)

    def attach(self, rclpy, wait_s: float = TF_STATIC_WAIT_S) -> str:
        """Read ``/tf_static`` for ``wait_s`` and choose :attr:`child_frame` (class docstring); what was chosen.

        Raises
        ------
        HandEyeInputError
            The camera frame's tree already joined to ``parent_frame``, naming the chain and ``--camera-frame``.
        """
        from tf2_msgs.msg import TFMessage

        from handeye.core.se3 import invert_transform

        parents = {}  # child -> (parent, T_parent_child)

        def take(msg) -> None:
            for tr in msg.transforms:
                parents[str(tr.child_frame_id)] = (str(tr.header.frame_id), _matrix(tr.transform))

        self.node.create_subscription(TFMessage, STATIC_TOPIC, take, _latched_qos())
        clock = self.node.get_clock()
        start = clock.now().nanoseconds
        while rclpy.ok() and clock.now().nanoseconds - start < wait_s * 1e9:
            rclpy.spin_once(self.node, timeout_sec=0.1)
        chain, T_root_cam = [self.camera_frame], np.eye(4)
        while chain[-1] in parents and len(chain) <= len(parents):
            parent, T = parents[chain[-1]]
            chain.append(parent)
            T_root_cam = T @ T_root_cam
        if len(chain) == 1:
            return f"{self.parent_frame} -> {self.camera_frame}"
        base_chain = [self.parent_frame]
        while base_chain[-1] in parents and len(base_chain) <= len(parents):
            base_chain.append(parents[base_chain[-1]][0])
        if chain[-1] in base_chain:
            raise HandEyeInputError(
                f"{self.camera_frame} is already placed under {self.parent_frame} on {STATIC_TOPIC} "
                f"({'<-'.join(chain)}; {'<-'.join(base_chain)}); tf2 takes one parent: stop that publisher (a running "
                f"handeye watch takes a rollback itself: omit --publish-tf) or name one without with --camera-frame"
            )
        self.child_frame, self.T_cam_child = chain[-1], invert_transform(T_root_cam)
        return (
            f"{self.parent_frame} -> {self.child_frame} (the root of {self.camera_frame}'s tree on {STATIC_TOPIC}: "
            f"{'<-'.join(chain)}; composed with it, as {self.camera_frame} has a parent)"
        )

    def publish(self, T_base_cam: np.ndarray, version: int | None = None) -> None:
        """Send ``T_base_cam`` (4x4, metres) as the static transform (to :attr:`child_frame`), and ``valid``."""
        from geometry_msgs.msg import TransformStamped

        from handeye.core.se3 import pos_quat_xyzw_from_transform

        T = np.asarray(T_base_cam, dtype=float) @ self.T_cam_child
        t, q = pos_quat_xyzw_from_transform(T)
        msg = TransformStamped()
        msg.header.stamp = self.node.get_clock().now().to_msg()
        msg.header.frame_id = self.parent_frame
        msg.child_frame_id = self.child_frame
        msg.transform.translation.x, msg.transform.translation.y, msg.transform.translation.z = (float(v) for v in t)
        r = msg.transform.rotation
        r.x, r.y, r.z, r.w = (float(v) for v in q)
        self.broadcaster.sendTransform(msg)
        self._send_status("valid", None, version)

    def start(self, T_base_cam: np.ndarray, version: int | None, stale_since: float | None) -> None:
        """A watcher's start: :meth:`publish` ``T_base_cam`` when it is valid; when the record says it is stale
        (``stale_since``, a restart after an earlier run's ``moved``: :class:`handeye.watch.CellWatcher`) nothing on
        tf (a pose known off is not put there) and ``stale`` on :data:`STATUS_TOPIC`."""
        if stale_since is None:
            self.publish(T_base_cam, version)
        else:
            self.stale(stale_since, version)

    def stale(self, stale_since: float, version: int | None = None) -> None:
        """The ``on_stale`` hook: nothing sent on tf (it cannot be withdrawn), ``stale`` on :data:`STATUS_TOPIC`."""
        self._send_status("stale", stale_since, version)

    def _send_status(self, calibration: str, stale_since: float | None, version: int | None) -> None:
        import json

        from std_msgs.msg import String

        doc = {"calibration": calibration, "stale_since": stale_since, "version": version}
        doc.update(parent_frame=self.parent_frame, child_frame=self.child_frame)
        msg = String()
        msg.data = json.dumps(doc)
        self.status.publish(msg)


def _latched_qos():
    """Transient local, depth 1: a late subscriber gets the last message (as ``/tf_static``)."""
    from rclpy.qos import DurabilityPolicy, QoSProfile

    return QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def _matrix(transform) -> np.ndarray:
    """A ``geometry_msgs/Transform`` as a 4x4."""
    from handeye.core.se3 import transform_from_pos_quat_xyzw

    t, r = transform.translation, transform.rotation
    return transform_from_pos_quat_xyzw([t.x, t.y, t.z], [r.x, r.y, r.z, r.w])
