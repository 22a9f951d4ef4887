"""Frames for the learned module with what only the front can add: the arm's keypoints from its kinematics.

``learned`` never imports the robot model (``sim``); the keypoint model needs the base-frame
positions of points on the arm at every frame. This module reads the frames with
:func:`learned.data.load_frames` and fills them from the dataset's robot (or any URDF) with
:meth:`handeye.robot.model.Robot.keypoints_base`.
"""

from __future__ import annotations

from pathlib import Path

from handeye.core.dataset import Dataset
from handeye.robot_model import dataset_robot

__all__ = ["load_keypoint_frames"]


def load_keypoint_frames(
    root: str | Path,
    image_size: tuple,
    labels: str = "classic",
    progress: bool = True,
    urdf: str | Path | None = None,
    package_dirs=(),
):
    """:func:`learned.data.load_frames` with ``keypoints_base`` filled
    (:meth:`handeye.robot.model.Robot.keypoints_base`)."""
    from learned.data import load_frames, with_keypoints

    robot = dataset_robot(Dataset.open(root), urdf, package_dirs)
    frames = load_frames(root, image_size, labels, progress=progress)
    return with_keypoints(frames, robot.keypoints_base(frames.joints.astype(float)))
