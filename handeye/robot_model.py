"""The robot model of a dataset, for the front: its UR by name (``meta.json``), or any URDF with meshes."""

from __future__ import annotations

from pathlib import Path

from handeye.core.dataset import Dataset
from handeye.core.errors import ShapeError

__all__ = ["dataset_robot"]


def dataset_robot(ds: Dataset, urdf: str | Path | None = None, package_dirs=(), ee_frame: str = "tool0"):
    """:func:`sim.robot.load_robot` of ``meta["robot"]``, or :func:`sim.robot.load_robot_urdf`, checked against
    the dataset's joint count.

    Raises
    ------
    ShapeError
        When the model's joint count is not the dataset's (naming ``meta.json``).
    HandEyeInputError
        An unknown robot, a missing URDF or mesh (from ``sim.robot``).
    """
    from sim.robot import load_robot, load_robot_urdf

    robot = load_robot_urdf(urdf, package_dirs, ee_frame) if urdf else load_robot(ds.meta["robot"])
    if robot.nq != ds.meta["n_joints"]:
        raise ShapeError(
            f"{ds.root / 'meta.json'}: {ds.meta['n_joints']} joints, the robot model {robot.name} has {robot.nq}"
        )
    return robot
