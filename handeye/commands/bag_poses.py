"""``handeye bag-poses``: a pose file from a ROS 2 bag (tf and a marker pose topic), paired by time.

Example
-------
::

    handeye bag-poses recording/ --base base_link --ee tool0 --marker-topic /marker_pose --tolerance 0.01 \\
        -o poses.csv
    handeye calibrate poses.csv --setup eye-to-hand

reads the bag (rosbag2, sqlite3 or MCAP; ``pip install "handeye[ros]"``, no ROS installation), chains
``T_base_ee`` through the tf tree of ``/tf`` and ``/tf_static``, reads ``T_cam_target`` from the
marker topic (``PoseStamped``, ``PoseWithCovarianceStamped`` or ``TransformStamped``), pairs each
marker pose with the robot pose at its header stamp (interpolated between robot samples within
``--tolerance`` seconds of it, or the nearest with ``--nearest``), and writes the pairs as the pose
file ``handeye calibrate`` reads. Marker poses without a robot pose within the tolerance are dropped
and counted. Details in :mod:`handeye.ros_bag`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from handeye.commands import command_parser
from handeye.core.numbers import cli_float

__all__ = ["add_parser", "run"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command."""
    p = command_parser(
        sub, "bag-poses", "pose file from a ROS 2 bag: tf chain and marker poses paired by time", __doc__
    )
    p.add_argument("bag", type=Path, help="rosbag2 directory (sqlite3 or MCAP storage)")
    p.add_argument("--base", required=True, help="tf base frame, e.g. base_link")
    p.add_argument("--ee", required=True, help="tf end-effector frame, e.g. tool0")
    p.add_argument(
        "--marker-topic",
        required=True,
        help="T_cam_target topic: PoseStamped, PoseWithCovarianceStamped or TransformStamped",
    )
    p.add_argument(
        "--tolerance",
        type=cli_float,
        default=0.01,
        help="largest time between a marker pose and a robot sample used for it, seconds (default 0.01)",
    )
    p.add_argument(
        "--nearest",
        action="store_true",
        help="take the nearest robot sample instead of interpolating between the two around the stamp",
    )
    p.add_argument("--tf-topic", default="/tf", help="default /tf")
    p.add_argument("--tf-static-topic", default="/tf_static", help="default /tf_static")
    p.add_argument("-o", "--output", type=Path, required=True, help="pose file to write (CSV)")
    p.set_defaults(run=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run the command; returns the exit status."""
    from handeye.core.posefile import write_pose_csv
    from handeye.ros_bag import read_bag

    rec = read_bag(
        args.bag,
        args.base,
        args.ee,
        marker_topic=args.marker_topic,
        tf_topic=args.tf_topic,
        tf_static_topic=args.tf_static_topic,
    )
    method = "nearest" if args.nearest else "interpolate"
    pairs = rec.pair(args.tolerance, method)
    how = "nearest robot sample" if args.nearest else "robot pose interpolated"
    comment = (
        f"from ROS 2 bag {rec.bag}\n"
        f"T_base_ee: {args.ee} in {args.base} (tf: {' -> '.join(rec.frames)}); "
        f"T_cam_target: {args.marker_topic} (frame {rec.camera_frame}); metres\n"
        f"{pairs.kept} pairs ({how} within {args.tolerance} s), {pairs.dropped} marker poses dropped"
    )
    write_pose_csv(args.output, pairs.T_base_ee, pairs.T_cam_target, comment=comment)
    t_r, t_c = rec.robot_times_s, rec.camera_times_s
    print(
        "\n".join(
            [
                f"handeye bag-poses {args.bag} --base {args.base} --ee {args.ee} --marker-topic {args.marker_topic} "
                f"--tolerance {args.tolerance}" + (" --nearest" if args.nearest else ""),
                f"  robot: {len(t_r)} poses of {args.ee} in {args.base} ({' -> '.join(rec.frames)}), "
                f"{t_r[0]:.3f} to {t_r[-1]:.3f} s",
                f"  camera: {len(t_c)} poses on {args.marker_topic} (frame {rec.camera_frame}), "
                f"{t_c[0]:.3f} to {t_c[-1]:.3f} s",
                f"  pairs: {pairs.kept} kept ({how} within {args.tolerance} s), {pairs.dropped} dropped "
                f"(no robot pose within {args.tolerance} s)",
                f"  written: {args.output}",
            ]
        )
    )
    return 0
