"""``handeye watch``'s other inputs and outputs: a ROS 2 bag replayed, live ROS 2 topics, the static transform
published, the continual learner fed.

::

    handeye watch BAG --sensor d435 --robot ur5 --camera-start start.json --history cell.jsonl --current cell.json
    handeye watch BAG --fast ...                     # as fast as the check goes, not at the recorded rate
    handeye watch --ros2 --sensor d435 --robot ur5 --history cell.jsonl --current cell.json   # needs rclpy
    handeye watch ... --learner cell.pt              # each commit offered to the continual learner

A bag (sqlite3 or MCAP) is read by the import's reader (:func:`handeye.watch.source.bag_frames`) and replayed at
its recorded rate unless ``--fast``. ``--ros2`` subscribes to ``--depth-topic``, ``--info-topic`` and
``--joints-topic`` (:class:`handeye.watch.ros2.Ros2Frames`) and publishes the calibration as a static
transform ``--base-frame`` -> ``--camera-frame`` at the start and on each commit (``--publish-tf`` does it for a
replay too; while the watcher says the calibration is stale the old transform stays published, as a static
transform cannot be withdrawn: ``/handeye/calibration_status`` and ``--current``'s ``stale_since`` say it is
stale, also after a restart, which publishes no transform until a recalibration; a ``--camera-frame`` with a
parent on ``/tf_static``, as a camera driver's optical frame has, is reached through its tree's root:
:class:`handeye.watch.ros2.TfPublisher`); the ROS 2 code is untested against a real ROS 2 (its tests use a fake
rclpy). ``--learner PATH``
loads a :class:`learned.calibrator.ContinualCalibrator` saved there (a new one of ``--learner-preset`` when
there is none), offers it each committed camera pose in the background, saves it after each training, and
starts each recalibration from its prediction too; the command ends after the offers are learnt, or, stopped by
Ctrl-C or an error, after the training under way (the offers not yet learnt are dropped, each said).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

from handeye.core.numbers import cli_float

__all__ = [
    "add_source_arguments",
    "is_bag",
    "CellInputs",
    "bag_inputs",
    "ros2_inputs",
    "outputs",
    "tf_publisher",
    "hold",
]


def add_source_arguments(p: argparse.ArgumentParser) -> None:
    """The options of a bag, of live ROS 2, of the published transform and of the learner."""
    from handeye.watch.ros2 import BASE_FRAME
    from handeye.watch.source import BagTopics

    g = p.add_argument_group("ROS 2 bag or live topics (module handeye.commands.watch_sources)")
    g.add_argument("--ros2", action="store_true", help="watch live ROS 2 topics (needs rclpy)")
    g.add_argument("--fast", action="store_true", help="replay a bag as fast as possible, not at its rate")
    g.add_argument("--robot", default="ur5", help="a UR by name for a bag or live topics (default ur5)")
    g.add_argument("--depth-topic", default=BagTopics.depth, help=f"default {BagTopics.depth}")
    g.add_argument("--info-topic", default=BagTopics.info, help=f"the depth's camera_info, default {BagTopics.info}")
    g.add_argument("--color-topic", default=BagTopics.color, help=f"default {BagTopics.color} (live: '' for none)")
    g.add_argument("--joints-topic", default=BagTopics.joints, help=f"default {BagTopics.joints}")
    g.add_argument("--depth-unit", type=cli_float, default=None, help="metres per depth unit (default: REP 118)")
    g.add_argument("--joint-tolerance", type=cli_float, default=0.02, help="depth stamp to joints, s (default 0.02)")
    g.add_argument("--publish-tf", action="store_true", help="publish the static transform (implied by --ros2)")
    g.add_argument(
        "--base-frame",
        default=BASE_FRAME,
        help=f"tf parent frame: the robot model's root, whose kinematics T_base_cam is in (default {BASE_FRAME}; "
        "not UR's 'base', turned 180 deg about z from it)",
    )
    g.add_argument("--camera-frame", default="camera_color_optical_frame", help="tf child frame")
    g.add_argument("--learner", type=Path, help="continual learner state (loaded when there, saved after training)")
    g.add_argument("--learner-preset", default="cpu", help="preset of a new learner (default cpu)")


def is_bag(path) -> bool:
    """Whether ``path`` is a ROS 2 bag (a directory with ``metadata.yaml``, or its ``.db3``/``.mcap`` file)."""
    path = Path(path)
    return (path / "metadata.yaml").is_file() or (path.suffix in (".db3", ".mcap") and path.is_file())


@dataclass
class CellInputs:
    """What a bag or live topics give the watcher: the frames, the camera matrix, the robot, its surface."""

    frames: object
    K: object
    robot: object
    surface: object
    stride: int
    rate_hz: float
    node: object = None
    source: object = None


def robot_model(args):
    """The robot model: ``--urdf``, else the UR ``--robot``."""
    from handeye.robot.model import load_robot, load_robot_urdf

    return load_robot_urdf(args.urdf) if args.urdf is not None else load_robot(args.robot)


def _surface(robot, K, width: int) -> tuple:
    """The robot's surface sampled for this camera, and the z-buffer stride (as ``robot_surface_for``)."""
    from handeye.robot.surface import RobotSurface, spacing_for_camera

    stride = 1 if width <= 160 else 2
    return RobotSurface(robot, spacing_m=spacing_for_camera(K, 0.8) * stride), stride


def joint_names(robot) -> list:
    """The model's joints in its order (pinocchio's ``model.names[1:]``), as the import matches them."""
    return [str(x) for x in list(robot.model.names)[1:]]


def bag_inputs(args) -> CellInputs:
    """A bag's frames (paced unless ``--fast``), its camera matrix, the robot and surface."""
    import numpy as np

    from handeye.watch.source import BagTopics, bag_frames, paced

    robot = robot_model(args)
    topics = BagTopics(args.depth_topic, args.info_topic, args.color_topic, args.joints_topic)
    stream = bag_frames(args.dataset, joint_names(robot), topics, args.depth_unit, args.joint_tolerance)
    if stream.dropped:
        print(f"{stream.source}: {stream.dropped} depth frames without joint states within {args.joint_tolerance} s")
    times = np.array([f.t for f in stream.frames])
    rate = 1.0 / float(np.median(np.diff(times))) if len(times) > 1 and np.ptp(times) > 0 else 30.0
    surface, stride = _surface(robot, stream.K, stream.size[0])
    frames = stream.frames if args.fast else paced(stream.frames)
    return CellInputs(frames, stream.K, robot, surface, stride, rate)


def ros2_inputs(args) -> CellInputs:
    """Live frames (:class:`handeye.watch.ros2.Ros2Frames`), after the first camera_info; needs rclpy."""
    from handeye.watch.ros2 import Ros2Frames, Ros2Topics, require_rclpy

    require_rclpy()  # before the robot is loaded: the refusal first
    robot = robot_model(args)
    topics = Ros2Topics(args.depth_topic, args.info_topic, args.joints_topic, args.color_topic or None)
    live = Ros2Frames(joint_names(robot), topics, args.depth_unit, args.joint_tolerance)
    K = live.wait_for_camera_info()
    surface, stride = _surface(robot, K, live.size[0])
    rate = args.rate if args.rate is not None else 30.0
    return CellInputs(live, K, robot, surface, stride, rate, live.node, live)


def outputs(args, robot, K, node=None) -> tuple:
    """``(on_commit hooks, extra_starts, learner, tf publisher)`` the options ask for (``node``: the live
    source's ROS 2 node, else one is made for the publisher)."""
    hooks, starts, learner, tf = [], None, None, None
    if args.ros2 or args.publish_tf:
        tf = tf_publisher(args, node)
        hooks.append(tf)
    if args.learner is not None:
        from handeye.watch.learner import BackgroundLearner
        from learned.calibrator import ContinualCalibrator

        if args.learner.is_file():
            calibrator = ContinualCalibrator.load(args.learner)
        else:
            calibrator = ContinualCalibrator(args.learner_preset)
        learner = BackgroundLearner(calibrator, robot.fk_ref, K, args.learner)
        hooks.append(learner)
        starts = learner.starts
    return hooks, starts, learner, tf


def tf_publisher(args, node=None):
    """The static transform's publisher (``--base-frame`` -> ``--camera-frame``) on ``node`` or a new one, after
    ``/tf_static`` was read for the camera frame's parent (:meth:`handeye.watch.ros2.TfPublisher.attach`, which
    refuses a camera already placed under the base); prints the transform it will publish."""
    from handeye.watch.ros2 import TfPublisher, require_rclpy

    rclpy = require_rclpy()
    if node is None:
        if not rclpy.ok():
            rclpy.init()
        node = rclpy.create_node("handeye_watch")
    tf = TfPublisher(node, args.base_frame, args.camera_frame)
    print(f"tf: publishing {tf.attach(rclpy)}", flush=True)
    return tf


def hold(tf) -> None:
    """Keep a published static transform until ROS 2 shuts down or Ctrl-C (it lives as long as its node)."""
    from handeye.watch.ros2 import require_rclpy

    rclpy = require_rclpy()
    try:
        while rclpy.ok():
            rclpy.spin_once(tf.node, timeout_sec=1.0)
    except KeyboardInterrupt:
        pass
