"""Load a pose file and check it against the hand-eye model: the front's reader.

This module composes :mod:`handeye.core.posefile` (reading) with
:mod:`classic.diagnostics` (a quick closed-form fit), so it lives in the front
and imports ``classic`` lazily.
"""

from __future__ import annotations

from pathlib import Path

from handeye.core.errors import PoseFileError, QuaternionOrderError
from handeye.core.posefile import POSE_NAMES, QUAT_ORDERS, YAML_SUFFIXES, PoseSet, read_pose_file

__all__ = ["FIT_RATIO", "load_poses"]

#: Another quaternion order that fits this many times better is taken as the file's real order.
FIT_RATIO = 10.0


def load_poses(
    path: str | Path,
    setup: str,
    quat_order: str | None = None,
    units: str | None = None,
    camera_frame: str | None = None,
) -> PoseSet:
    """Read a pose file and refuse it if its quaternions are in the other order.

    Relative rotation angles cannot reveal a permuted quaternion order (they
    depend only on ``|q_i . q_j|``), so the file is fitted by a closed form
    as read and with the other order for the robot poses, the camera poses, or
    both; if one of those fits ten times better, the order is wrong. easy_handeye
    YAML sample lists (``.yaml``, ``.yml``) name their quaternion components, so
    they are read for the setup without that test.

    Parameters
    ----------
    path : str or Path
    setup : {"eye_to_hand", "eye_in_hand"}
    quat_order : {"xyzw", "wxyz"}, optional
    units : {"m", "mm"}, optional
    camera_frame : {"optical", "ros-body"}, optional
        The frame of the camera poses (:func:`handeye.core.posefile.read_pose_file`).

    Returns
    -------
    PoseSet

    Raises
    ------
    PoseFileError, QuaternionOrderError
    """
    from classic.diagnostics import fit_residual_m
    from handeye.core.validation import MIN_POSES

    if Path(path).suffix.lower() in YAML_SUFFIXES:  # easy_handeye: quaternions named x, y, z, w; no order to test
        poses = read_pose_file(path, units=units, setup=setup, camera_frame=camera_frame)
    else:
        poses = read_pose_file(path, quat_order=quat_order, units=units, camera_frame=camera_frame)
    if len(poses.T_base_ee) < MIN_POSES:
        raise PoseFileError(
            f"{path}: {len(poses.T_base_ee)} pose pair(s); a hand-eye calibration needs at least {MIN_POSES} "
            "(10 to 20 well spread ones is typical)"
        )
    if Path(path).suffix.lower() in YAML_SUFFIXES:
        return poses
    given = fit_residual_m(poses.T_base_ee, poses.T_cam_target, setup)
    if given <= 1e-6:
        return poses
    order = quat_order or "xyzw"
    other = QUAT_ORDERS[1 - QUAT_ORDERS.index(order)] if order in QUAT_ORDERS else "wxyz"
    for names in (POSE_NAMES[:1], POSE_NAMES[1:], POSE_NAMES):
        try:
            alt = read_pose_file(
                path, quat_order=quat_order, units=units, swap_order_of=names, camera_frame=camera_frame
            )
        except PoseFileError:
            continue
        residual = fit_residual_m(alt.T_base_ee, alt.T_cam_target, setup)
        if residual < given / FIT_RATIO:
            raise QuaternionOrderError(
                f"{path}: the quaternions of {' and '.join(names)} look like they are in {other} order, not "
                f"{order}: read as {other} the poses fit the hand-eye model (median residual "
                f"{1000 * residual:.2f} mm), read as {order} they do not ({1000 * given:.1f} mm). "
                f"Fix the file or pass quat_order='{other}' (CLI: --quat-order {other})."
            )
    return poses
