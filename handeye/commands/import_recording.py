"""``handeye import``: a real recording (ROS 2 bags or plain folders) to a dataset, one per camera placement.

Examples
--------
::

    # one bag per camera placement (depth registered to colour, camera_info, joint_states), and
    # per placement a bag with the board on the flange
    handeye import bag data_0/ data_1/ --calibration cal_0/ cal_1/ --board board.json \\
        --urdf my_robot.urdf --package-dir ~/ws/src --out data/my-cell \\
        --color-topic /camera/color/image_raw --depth-topic /camera/aligned_depth_to_color/image_raw \\
        --info-topic /camera/color/camera_info
    handeye label data/my-cell                       # the board
    handeye markerless data/my-cell --start guess.json --write-labels    # the robot's surface
    handeye compare data/my-cell                     # the two side by side

    # folders: intrinsics.yaml, joints.csv, rgb/, depth/ (and calibration/) per placement
    handeye import folder placement_0/ placement_1/ --robot ur5 --board board.json --out data/my-cell

Each recording is one camera placement (``camera_id`` in the order given). Depth frames are paired with
the colour frame nearest in time and the robot's state at their stamp (joints interpolated between
samples within ``--joint-tolerance``); the data frames are undistorted to a pinhole; a recording whose
streams are mostly further apart than the tolerances is refused, as is a recording in a unit it does not say
(depth in millimetres where metres are read: pass ``--depth-unit``; joints in degrees), a ``camera_info`` no
camera has, a joint named twice. The dataset is written beside ``--out`` and renamed to it when complete, so
a failed import leaves nothing behind and a rerun works. Details: :mod:`handeye.recording_import`,
:mod:`handeye.import_bag`, :mod:`handeye.import_folder`, :mod:`handeye.recording_checks`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from handeye.commands import command_parser
from handeye.core.numbers import cli_float, cli_int

__all__ = ["add_parser", "run"]


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", type=Path, required=True, help="new dataset directory")
    robot = p.add_mutually_exclusive_group(required=True)
    robot.add_argument("--robot", help="a UR by name (ur5, ur3)")
    robot.add_argument("--urdf", type=Path, help="the robot's URDF with visual meshes")
    p.add_argument(
        "--package-dir", type=Path, action="append", default=[], help="folder for package:// mesh paths (repeatable)"
    )
    p.add_argument("--ee", default="tool0", help="the flange frame of the URDF (default tool0)")
    p.add_argument("--board", type=Path, help="board spec written by 'handeye board' (needed with calibration frames)")
    p.add_argument(
        "--depth-unit",
        type=cli_float,
        default=None,
        help="metres per unit of the recorded depth (default: 0.001, millimetres, for 16-bit depth and integer "
        ".npy; 1, metres, for 32FC1 and float .npy, the ROS convention); a depth that looks like another unit is "
        "refused with the one that fits",
    )
    p.add_argument(
        "--max-frames",
        type=cli_int,
        default=100,
        help="data frames kept per placement, evenly spread (default 100; 0 keeps all)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command group."""
    p = command_parser(
        sub, "import", "a real recording (ROS 2 bags or folders of RGB-D frames and joints) to a dataset", __doc__
    )
    kinds = p.add_subparsers(dest="import_kind", required=True, metavar="KIND")
    b = command_parser(kinds, "bag", "ROS 2 bags (sqlite3 or MCAP), one per camera placement", __doc__)
    b.add_argument("bags", type=Path, nargs="+", help="rosbag2 directories, one per camera placement")
    b.add_argument(
        "--calibration", type=Path, nargs="+", default=[], help="bags of the board on the flange, one per placement"
    )
    b.add_argument("--color-topic", default="/camera/color/image_raw", help="Image or CompressedImage")
    b.add_argument(
        "--depth-topic",
        default="/camera/aligned_depth_to_color/image_raw",
        help="depth registered to the colour camera",
    )
    b.add_argument("--info-topic", default="/camera/color/camera_info", help="the colour camera's CameraInfo")
    b.add_argument("--joints-topic", default="/joint_states", help="JointState ('none': take the flange from tf)")
    b.add_argument("--tf", nargs=2, metavar=("BASE", "EE"), help="T_base_ee from tf between these frames")
    b.add_argument(
        "--sync-tolerance", type=cli_float, default=0.02, help="largest time between a depth and its colour frame, s"
    )
    b.add_argument(
        "--joint-tolerance", type=cli_float, default=0.02, help="largest time to each robot sample interpolated, s"
    )
    _common(b)
    b.set_defaults(run=run)
    f = command_parser(kinds, "folder", "folders of RGB-D frames and joints, one per camera placement", __doc__)
    f.add_argument(
        "folders", type=Path, nargs="+", help="placement folders (intrinsics.yaml, joints.csv, rgb/, depth/)"
    )
    f.add_argument("--intrinsics", type=Path, help="intrinsics for every folder (default: the folder's own)")
    _common(f)
    f.set_defaults(run=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run the command; returns the exit status."""
    from handeye.core.errors import HandEyeInputError
    from handeye.core.optional import require_package
    from handeye.recording_import import ImportOptions, import_recordings
    from handeye.robot.model import load_robot_entry
    from handeye.robot_model import robot_meta

    require_package("pinocchio", extra="robot", purpose="the robot model")
    options = ImportOptions(
        sync_tolerance_s=getattr(args, "sync_tolerance", 0.0),
        joint_tolerance_s=getattr(args, "joint_tolerance", 0.0),
        max_frames=args.max_frames or None,
    )
    entry = robot_meta(args.robot, args.urdf, args.package_dir, args.ee)
    robot = load_robot_entry(entry)
    board = None
    if args.board is not None:
        from classic.vision.board import BoardSpec

        board = BoardSpec.load(args.board)
    if args.import_kind == "bag":
        from handeye.import_bag import read_camera_bag

        require_package("rosbags", extra="ros", purpose="reading ROS 2 bags")
        if args.calibration and len(args.calibration) != len(args.bags):
            raise HandEyeInputError(
                f"{len(args.bags)} data bags and {len(args.calibration)} calibration bags: one of each per placement"
            )
        joints = None if args.joints_topic.lower() == "none" else args.joints_topic
        tf = tuple(args.tf) if args.tf else None

        def read(bag, depth):
            return read_camera_bag(
                bag, args.color_topic, args.info_topic, args.depth_topic if depth else None, joints, tf, args.depth_unit
            )

        placements = []
        for k, bag in enumerate(args.bags):
            part = read(bag, True)
            if args.calibration:
                part.calibration = read(args.calibration[k], False)
            placements.append(part)
    else:
        from handeye.import_folder import read_frame_folder

        placements = [read_frame_folder(f, args.intrinsics, args.depth_unit) for f in args.folders]
    report = import_recordings(
        args.out, placements, robot, entry, board, options, f"handeye import {args.import_kind}", not args.quiet
    )
    print(report.summary())
    print(
        f"wrote {args.out} in {report.wall_s:.1f} s; next: handeye label {args.out} (board), "
        f"handeye markerless {args.out} --start guess.json (no board)"
    )
    return 0
