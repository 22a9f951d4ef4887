"""Frames for the learned module with what only the front can add: the arm's keypoints from its kinematics.

``learned`` never imports the robot model (``sim``); the keypoint model needs the base-frame
positions of points on the arm at every frame. This module reads the frames with
:func:`learned.data.load_frames` and fills them from the dataset's robot (or any URDF) with
:meth:`sim.robot.Robot.keypoints_base`.
"""

from __future__ import annotations

from pathlib import Path

from handeye.core.dataset import Dataset
from handeye.core.errors import ShapeError

__all__ = ["load_keypoint_frames", "keypoint_robot"]


def keypoint_robot(root: str | Path, urdf: str | Path | None = None, package_dirs=(), ee_frame: str = "tool0"):
    """The robot model of a dataset (its UR by name, or a URDF), checked against the dataset's joint count."""
    from sim.robot import load_robot, load_robot_urdf

    ds = Dataset.open(root)
    robot = load_robot_urdf(urdf, package_dirs, ee_frame) if urdf else load_robot(ds.meta["robot"])
    if robot.nq != ds.meta["n_joints"]:
        raise ShapeError(f"{ds.root / 'meta.json'}: {ds.meta['n_joints']} joints, the robot model {robot.name} has "
                         f"{robot.nq}")
    return robot


def load_keypoint_frames(root: str | Path, image_size: tuple, labels: str = "classic", progress: bool = True,
                         urdf: str | Path | None = None, package_dirs=()):
    """:func:`learned.data.load_frames` with ``keypoints_base`` filled (joint origins, flange, reference point)."""
    from learned.data import load_frames, with_keypoints

    robot = keypoint_robot(root, urdf, package_dirs)
    frames = load_frames(root, image_size, labels, progress=progress)
    return with_keypoints(frames, robot.keypoints_base(frames.joints.astype(float)))
