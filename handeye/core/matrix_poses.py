"""Text files of 4x4 pose matrices, robot poses in one file and camera poses in another.

Robot-world calibration datasets ship their poses this way:

* one matrix per line, 16 numbers row-major (Ali et al.'s ``RobotPosesVec.txt``, tab separated), or 12
  numbers (the top 3 x 4, as KITTI's pose files)::

      r00 r01 r02 tx r10 r11 r12 ty r20 r21 r22 tz 0 0 0 1

* one matrix per 4 lines of 4 numbers, with or without blank lines between matrices, optionally after a
  first line holding the number of matrices (Tabb and Ahmad Yousef's ``robot_cali.txt``)::

      2
      r00 r01 r02 tx
      r10 r11 r12 ty
      r20 r21 r22 tz
      0 0 0 1

      ...

Numbers are separated by spaces, tabs, commas or semicolons; ``#``, ``%`` and ``//`` start comments.

Directions, as this reader takes them by default: the robot file holds ``T_base_ee`` (the flange in the
robot base, what a controller reports), the camera file ``T_cam_target`` (the target in the camera's
optical frame, what ``cv2.solvePnP`` or ``cv2.calibrateCamera`` return as ``rvec, tvec``). Datasets
differ: Tabb's ``robot_cali.txt`` holds the inverse, ``T_ee_base`` (its README: "our definition is the
inverse of some other works"); ``invert_robot`` / ``invert_camera`` (CLI ``--robot-inverse``,
``--camera-inverse``) read such a file. Units are metres unless ``units`` says otherwise; translations
beyond 20 m are refused as millimetres read as metres (Tabb's are millimetres: give ``units="mm"``).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from handeye.core.camera_frame import check_camera_frame, check_camera_frame_name, to_optical
from handeye.core.errors import PoseFileError
from handeye.core.numbers import parse_float
from handeye.core.pose_matrices import checked_pose_matrix, scaled_to_metres
from handeye.core.poseset import PoseSet
from handeye.core.textfile import read_text

__all__ = ["read_matrix_pose_pairs", "read_pose_matrices"]

_SEPARATORS = re.compile(r"[ \t\r\n,;]+")  # ASCII spaces: a no-break space beside a number is refused with it
_COMMENT = re.compile(r"(#|%|//).*$")


def _number_lines(path: Path) -> list[tuple[int, list[float]]]:
    """``(line number, numbers)`` of every line that holds any, or a :class:`PoseFileError` naming the line."""
    text = read_text(path, "pose matrix file")
    out = []
    for number, line in enumerate(text.splitlines(), start=1):
        body = _COMMENT.sub("", line).replace("[", " ").replace("]", " ").strip(" \t\r\n")
        if not body:
            out.append((number, []))
            continue
        values = []
        for token in _SEPARATORS.split(body):
            if not token:
                continue
            values.append(parse_float(token, f"{path}, line {number}", PoseFileError))
        out.append((number, values))
    return out


def _matrices(path: Path) -> tuple[list[np.ndarray], list[int]]:
    """The file's matrices ``(4, 4)`` as written (unchecked) and the line each starts on."""
    lines = _number_lines(path)
    data = [(n, v) for n, v in lines if v]
    if not data:
        raise PoseFileError(f"{path}: no numbers; expected 4x4 pose matrices (16 numbers a line, or 4 lines of 4)")
    count, (first_line, first) = None, data[0]
    if len(first) == 1:
        count = _matrix_count(path, first_line, first[0], len(data) - 1)
        data, lines = data[1:], [(n, v) for n, v in lines if n > first_line]
    width = _line_width(path, data)
    Ms, starts = _one_line_matrices(data, width) if width in (16, 12) else _four_line_matrices(path, lines)
    if count is not None and count != len(Ms):
        raise PoseFileError(f"{path}, line {first_line}: the file says {count} matrices but holds {len(Ms)}")
    return Ms, starts


def _matrix_count(path: Path, line: int, value: float, lines_after: int) -> int:
    """The count of matrices a first line holding one number gives, refusing one with no numbers after it."""
    if value != int(value) or value < 0:
        raise PoseFileError(f"{path}, line {line}: {value:g} is not a count of matrices")
    if not lines_after:
        raise PoseFileError(
            f"{path}, line {line}: the file says {int(value)} matrices and holds none after it; expected 4x4 "
            "pose matrices (16 numbers a line, or 4 lines of 4) after the count"
        )
    return int(value)


def _line_width(path: Path, data: list[tuple[int, list[float]]]) -> int:
    """The one count of numbers every line holds: 16, 12 or 4."""
    widths = {len(v) for _, v in data}
    if len(widths) > 1 or not widths <= {16, 12, 4}:
        odd = next((n, v) for n, v in data if len(v) != len(data[0][1]) or len(v) not in (16, 12, 4))
        raise PoseFileError(
            f"{path}, line {odd[0]}: {len(odd[1])} numbers; a pose matrix file has 16 (or 12) numbers on every "
            f"line, or 4 on every line (4 lines a matrix), and line {data[0][0]} has {len(data[0][1])}"
        )
    return widths.pop()


def _one_line_matrices(data: list[tuple[int, list[float]]], width: int) -> tuple[list[np.ndarray], list[int]]:
    """Matrices of 16 numbers a line, or 12 (the top 3 x 4), and their lines."""
    last_row = [0.0, 0.0, 0.0, 1.0] if width == 12 else []
    return [np.array(v + last_row).reshape(4, 4) for _, v in data], [n for n, _ in data]


def _four_line_matrices(path: Path, lines: list[tuple[int, list[float]]]) -> tuple[list[np.ndarray], list[int]]:
    """Matrices of 4 lines of 4 numbers, and the line each starts on."""
    blocks = _blocks(lines)
    for block in blocks:
        if len(block) != 4:
            raise PoseFileError(
                f"{path}, line {block[0][0]}: a matrix of {len(block)} line(s) of 4 numbers; each pose matrix "
                "is 4 lines"
            )
    return [np.array([v for _, v in block]) for block in blocks], [block[0][0] for block in blocks]


def _blocks(lines: list[tuple[int, list[float]]]) -> list[list[tuple[int, list[float]]]]:
    """The lines with numbers, in blocks: blank lines separate blocks; without them, every 4 lines are one."""
    blocks, block = [], []
    for n, v in lines:
        if v:
            block.append((n, v))
        if block and (not v or len(block) == 4):
            blocks.append(block)
            block = []
    return blocks + [block] if block else blocks


def read_pose_matrices(
    path: str | Path, units: str | None = None, invert: bool = False, what: str = "pose"
) -> tuple[np.ndarray, list[int]]:
    """Read a text file of 4x4 pose matrices (formats in this module's docstring).

    Parameters
    ----------
    path : str or Path
    units : {"m", "mm"}, optional
        Translation unit; default metres, refused with the fix beyond 20 m (millimetres read as metres).
    invert : bool
        The file holds the inverse of the pose wanted (``T_ee_base`` for ``T_base_ee``): return the inverses.
    what : str
        The pose's name (``"T_base_ee"``), for messages.

    Returns
    -------
    T : array, shape (N, 4, 4)
        Metres; rotation blocks re-orthonormalised within
        :data:`~handeye.core.pose_matrices.PRINTED_ROTATION_TOL`.
    lines : list of int
        The line each matrix starts on.

    Raises
    ------
    PoseFileError
        Naming the file and line: not text, a token that is not a number, a line of another count of numbers,
        a 4-line matrix cut short, a count line that disagrees, NaN or infinity, a last row other than
        ``[0, 0, 0, 1]``, a rotation block that is not a rotation, millimetres read as metres.
    """
    path = Path(path)
    Ms, starts = _matrices(path)
    where = [f"{path}, line {n}" for n in starts]
    T = np.array([checked_pose_matrix(M, w) for M, w in zip(Ms, where)]).reshape(-1, 4, 4)
    return scaled_to_metres(T, units, where, what, invert=invert), starts


def read_matrix_pose_pairs(
    robot_path: str | Path,
    camera_path: str | Path,
    units: str | None = None,
    invert_robot: bool = False,
    invert_camera: bool = False,
    camera_frame: str | None = None,
    camera_units: str | None = None,
) -> PoseSet:
    """Read paired poses from two matrix files: ``T_base_ee`` from one, ``T_cam_target`` from the other.

    The i-th matrix of one file pairs with the i-th of the other.

    Parameters
    ----------
    robot_path : str or Path
        Robot poses ``T_base_ee`` (``T_ee_base`` with ``invert_robot``).
    camera_path : str or Path
        Target poses in the camera ``T_cam_target`` (``T_target_cam`` with ``invert_camera``).
    units : {"m", "mm"}, optional
        Translation unit of the robot file, and of the camera file unless ``camera_units`` is given;
        default metres, checked.
    invert_robot, invert_camera : bool
        The file holds the inverse poses.
    camera_frame : {"optical", "ros-body"}, optional
        The frame of the camera poses (after ``invert_camera``); ``None``: optical, refused when the targets
        say it is a ROS body frame (:func:`~handeye.core.camera_frame.check_camera_frame`).
    camera_units : {"m", "mm"}, optional
        Translation unit of the camera file when it differs from the robot file's (a controller's
        millimetres beside PnP poses in metres).

    Returns
    -------
    PoseSet
        ``rows``: the line each robot matrix starts on.

    Raises
    ------
    PoseFileError
        As :func:`read_pose_matrices`, and files of different counts.
    """
    check_camera_frame_name(camera_frame)
    T_base_ee, rows = read_pose_matrices(robot_path, units, invert_robot, "T_base_ee")
    T_cam_target, _ = read_pose_matrices(camera_path, camera_units or units, invert_camera, "T_cam_target")
    if len(T_base_ee) != len(T_cam_target):
        raise PoseFileError(
            f"{robot_path} holds {len(T_base_ee)} robot poses, {camera_path} {len(T_cam_target)} camera poses: "
            "the i-th of one pairs with the i-th of the other, so the counts must agree"
        )
    if camera_frame is None:
        check_camera_frame(T_cam_target, str(camera_path))
        camera_frame = "optical"
    return PoseSet(T_base_ee, to_optical(T_cam_target, camera_frame), f"{robot_path} + {camera_path}", rows)
