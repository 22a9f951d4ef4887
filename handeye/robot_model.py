"""The robot model of a dataset, for the front: its UR by name (``meta.json``), or any URDF with meshes.

``meta["robot"]`` is a UR's name (``"ur5"``, the simulator's datasets) or, for an imported recording,
``{"urdf": path, "package_dirs": [paths], "ee_frame": name}`` (``handeye import ... --urdf``).
"""

from __future__ import annotations

from pathlib import Path

from handeye.core.dataset import Dataset
from handeye.core.errors import ShapeError

__all__ = ["dataset_robot", "robot_meta"]


def robot_meta(name: str | None = None, urdf=None, package_dirs=(), ee_frame: str = "tool0"):
    """``meta["robot"]`` of a UR's name, or of a URDF (its path made absolute, so the dataset can move).

    Raises
    ------
    HandEyeInputError
        Neither or both given.
    """
    from handeye.core.errors import HandEyeInputError

    if (name is None) == (urdf is None):
        raise HandEyeInputError("give the robot as a UR's name (--robot ur5) or a URDF (--urdf robot.urdf)")
    if name is not None:
        return name
    return {
        "urdf": str(Path(urdf).resolve()),
        "package_dirs": [str(Path(d).resolve()) for d in package_dirs],
        "ee_frame": ee_frame,
    }


def dataset_robot(ds: Dataset, urdf: str | Path | None = None, package_dirs=(), ee_frame: str = "tool0"):
    """:func:`handeye.robot.model.load_robot` of ``meta["robot"]`` (a name or a recorded URDF), or
    :func:`handeye.robot.model.load_robot_urdf` of ``urdf``, checked against the dataset's joint count.

    Raises
    ------
    ShapeError
        When the model's joint count is not the dataset's (naming ``meta.json``).
    HandEyeInputError
        An unknown robot, a missing URDF or mesh (from ``handeye.robot.model``).
    """
    from handeye.robot.model import load_robot_entry, load_robot_urdf

    robot = load_robot_urdf(urdf, package_dirs, ee_frame) if urdf else load_robot_entry(ds.meta["robot"])
    if robot.nq != ds.meta["n_joints"]:
        raise ShapeError(
            f"{ds.root / 'meta.json'}: {ds.meta['n_joints']} joints, the robot model {robot.name} has {robot.nq}"
        )
    return robot
