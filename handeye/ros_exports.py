"""``handeye calibrate --export-*``: the calibrated camera pose as ROS files.

After a successful calibration the camera pose ``X`` (``T_base_cam`` eye-to-hand,
``T_ee_cam`` eye-in-hand) is written, from the frame ``PARENT`` (robot base, or
flange) to ``CHILD`` (the camera), as

* ``--export-easy-handeye PATH``: an easy_handeye2 calibration (``.calib``);
  :mod:`handeye.core.easy_handeye`;
* ``--export-launch PATH``: a ROS 2 launch file running tf2_ros's
  ``static_transform_publisher``; :mod:`handeye.core.ros_launch`;
* ``--export-urdf PATH``: a fixed URDF ``<joint>``; :mod:`handeye.core.urdf_joint`.

Frame names: ``--frames PARENT CHILD``; else the tf names of an easy_handeye2
sample file the poses came from; else the project's (``base`` or ``ee``, and ``cam``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from handeye.core.errors import HandEyeInputError

__all__ = ["add_export_arguments", "check_export_arguments", "export_frames", "write_exports"]

_EXPORTS = ("export_easy_handeye", "export_launch", "export_urdf")


def add_export_arguments(p: argparse.ArgumentParser) -> None:
    """Register ``--export-easy-handeye``, ``--export-launch``, ``--export-urdf`` and ``--frames``."""
    p.add_argument(
        "--export-easy-handeye",
        type=Path,
        metavar="PATH",
        help="write the camera pose as an easy_handeye2 calibration (YAML; easy_handeye2 publishes "
        "~/.ros2/easy_handeye2/calibrations/NAME.calib with publish.launch.py name:=NAME)",
    )
    p.add_argument(
        "--export-launch",
        type=Path,
        metavar="PATH",
        help="write a ROS 2 launch file (NAME.launch.py) publishing the camera pose as a static tf",
    )
    p.add_argument(
        "--export-urdf",
        type=Path,
        metavar="PATH",
        help="write the camera pose as a fixed URDF <joint> (xyz, rpy) to paste into the cell's URDF",
    )
    p.add_argument(
        "--frames",
        nargs=2,
        metavar=("PARENT", "CHILD"),
        help="tf/URDF names of the exported transform's frames: the robot base (eye-to-hand) or flange "
        "(eye-in-hand), and the camera; default those of an easy_handeye2 sample file, else "
        "'base' or 'ee', and 'cam'",
    )


def check_export_arguments(args: argparse.Namespace) -> None:
    """Refuse, before calibrating, exports that could not be written.

    Raises
    ------
    HandEyeInputError
        ``--frames`` without an export, a bad frame name, or a folder that does not exist.
    MissingDependencyError
        ``--export-easy-handeye`` without PyYAML (``handeye[ros]``).
    """
    from handeye.core.ros_launch import check_frame_name

    paths = [getattr(args, name, None) for name in _EXPORTS]
    if getattr(args, "frames", None) is not None:
        if not any(paths):
            raise HandEyeInputError(
                "--frames names the frames of an export: give --export-easy-handeye, "
                "--export-launch or --export-urdf too"
            )
        for name in args.frames:
            check_frame_name(name)
    from handeye.core.safe_write import check_output_path

    for path in paths:
        if path is not None and not Path(path).parent.is_dir():
            raise HandEyeInputError(f"{path}: its folder {Path(path).parent} does not exist")
        if path is not None:
            check_output_path(path)  # a directory, FIFO or device refused before calibrating
    if getattr(args, "export_easy_handeye", None) is not None:
        from handeye.core.optional import require_package

        require_package("yaml", extra="ros", purpose="writing the easy_handeye2 calibration")


def export_frames(setup: str, cli_frames: list | None = None, file_frames: dict | None = None) -> dict:
    """tf names of the project's frames (``base``, ``ee``, ``cam``, ``target``) for the exports.

    Parameters
    ----------
    setup : {"eye_to_hand", "eye_in_hand"}
    cli_frames : [PARENT, CHILD], optional
        ``--frames``: the parent is ``base`` (eye-to-hand) or ``ee`` (eye-in-hand), the child ``cam``.
    file_frames : dict, optional
        Names from the pose file (:attr:`handeye.core.posefile.PoseSet.frames`).

    Returns
    -------
    dict
    """
    from handeye.core.easy_handeye import DEFAULT_FRAMES

    frames = {**DEFAULT_FRAMES, **(file_frames or {})}
    if cli_frames:
        frames["base" if setup == "eye_to_hand" else "ee"] = str(cli_frames[0]).lstrip("/")
        frames["cam"] = str(cli_frames[1]).lstrip("/")
    return frames


def write_exports(args: argparse.Namespace, setup: str, X: np.ndarray, file_frames: dict | None = None) -> list[str]:
    """Write the exports asked for; the lines to print.

    Parameters
    ----------
    args : argparse.Namespace
        With the attributes of :func:`add_export_arguments`.
    setup : {"eye_to_hand", "eye_in_hand"}
    X : array, shape (4, 4)
        ``T_base_cam`` (eye-to-hand) or ``T_ee_cam`` (eye-in-hand), metres.
    file_frames : dict, optional
        Frame names the pose file gave.

    Returns
    -------
    list of str
    """
    from handeye.core.easy_handeye import write_easy_handeye_calibration
    from handeye.core.ros_launch import write_static_tf_launch
    from handeye.core.setups import UNKNOWN_NAMES
    from handeye.core.urdf_joint import write_urdf_joint

    if not any(getattr(args, name, None) for name in _EXPORTS):
        return []
    frames = export_frames(setup, getattr(args, "frames", None), file_frames)
    parent, child = frames["base" if setup == "eye_to_hand" else "ee"], frames["cam"]
    x_name = UNKNOWN_NAMES[setup][0]
    lines = [f"  exported {x_name} as the transform from '{parent}' to '{child}':"]
    if args.export_easy_handeye is not None:
        write_easy_handeye_calibration(args.export_easy_handeye, X, setup, frames)
        lines.append(f"    easy_handeye2 calibration: {args.export_easy_handeye}")
    if args.export_launch is not None:
        write_static_tf_launch(args.export_launch, X, parent, child, x_name)
        lines.append(f"    ROS 2 launch file: {args.export_launch}")
    if args.export_urdf is not None:
        write_urdf_joint(args.export_urdf, X, parent, child, x_name=x_name)
        lines.append(f"    URDF joint: {args.export_urdf}")
    return lines
