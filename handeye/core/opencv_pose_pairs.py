"""Pose pairs in OpenCV FileStorage YAML, as camodocal's hand-eye tool writes them.

jhu-lcsr/handeye_calib_camodocal (``src/handeye_calibration.cpp``) records
``TransformPairsInput.yml`` with ``cv::FileStorage``::

    %YAML:1.0
    frameCount: 42
    T1_0: !!opencv-matrix
       rows: 4
       cols: 4
       dt: d
       data: [ r00, r01, r02, tx, r10, r11, r12, ty, r20, r21, r22, tz, 0., 0., 0., 1. ]
    T2_0: !!opencv-matrix
       ...
    T1_1: ...

What the matrices are, read from that tool's code:

* ``T1_i`` is ``tf::TransformListener::lookupTransform(baseTF, EETF)``: the pose of the end effector in
  the robot base, our ``T_base_ee`` (row-major 4x4, ``Eigen::Affine3d::matrix()`` through
  ``cv::eigen2cv``);
* ``T2_i`` is ``lookupTransform(cameraTF, ARTagTF)``: the pose of the marker in the camera frame
  ``cameraTF``, our ``T_cam_target``;
* units are tf's, metres.

The tool solves ``A X = X B`` with ``A = T1_0^-1 T1_i`` and ``B = T2_0^-1 T2_i`` and writes
``ArmTipToMarkerTagTransform``: the marker on the arm's tip, a static camera, our ``eye_to_hand`` with
``X = T_ee_target``. The pairs themselves are the same for either setup.

Its default ``cameraTF`` is ``/camera_2_link``: a ROS body frame (x forward), not the optical frame, and
its example file is in that frame (the marker at x = +0.76 m). Such files are refused by
:func:`~handeye.core.camera_frame.check_camera_frame` unless ``camera_frame`` says which frame they are in.
"""

from __future__ import annotations

import re
from functools import partial
from pathlib import Path

import numpy as np

from handeye.core.camera_frame import check_camera_frame, check_camera_frame_name, to_optical
from handeye.core.errors import PoseFileError
from handeye.core.opencv_yaml import load_opencv_yaml
from handeye.core.pose_matrices import checked_pose_matrix, scaled_to_metres
from handeye.core.poseset import PoseSet
from handeye.core.yamlfile import line_of

__all__ = ["PAIR_KEYS", "read_opencv_pose_pairs"]

#: Keys of the i-th pair: robot pose ``T_base_ee``, camera pose ``T_cam_target``.
PAIR_KEYS = ("T1_{}", "T2_{}")
#: A frameCount above this is refused before any key is looked up (a recording holds tens of poses).
MAX_FRAME_COUNT = 1_000_000
_PAIR_KEY = re.compile(r"^T[12]_(\d{1,9})$", re.ASCII)  # ASCII digits: T1_٢ is not pair 2


def read_opencv_pose_pairs(
    path: str | Path,
    units: str | None = None,
    camera_frame: str | None = None,
) -> PoseSet:
    """Read camodocal's ``TransformPairsInput.yml``: ``T1_i`` is ``T_base_ee``, ``T2_i`` is ``T_cam_target``.

    Parameters
    ----------
    path : str or Path
        OpenCV FileStorage YAML (``%YAML:1.0``) with ``frameCount`` and ``T1_i``, ``T2_i`` (``i`` from 0),
        each a 4x4 ``!!opencv-matrix``, row-major, translations in metres (tf's unit).
    units : {"m", "mm"}, optional
        Translation unit of both; default metres, refused with the fix when the translations look like
        millimetres.
    camera_frame : {"optical", "ros-body"}, optional
        The frame ``T2`` is in. ``None``: optical, refused when the targets say it is a ROS body frame
        (:func:`~handeye.core.camera_frame.check_camera_frame`); ``"ros-body"``: converted to optical;
        ``"optical"``: taken as is.

    Returns
    -------
    PoseSet
        ``T_base_ee`` and ``T_cam_target`` ``(N, 4, 4)`` in metres, the optical frame; ``rows`` the line of
        each ``T1_i`` key.

    Raises
    ------
    PoseFileError
        Naming the file, the line and the key: not FileStorage YAML, no ``frameCount`` (and no ``T1_0``), a
        missing ``T1_i``/``T2_i``, a matrix that is not 4x4, holds NaN or infinity, whose rotation block is
        not a rotation, millimetres read as metres, a body camera frame.
    """
    path = Path(path)
    check_camera_frame_name(camera_frame)
    doc = load_opencv_yaml(path, PoseFileError)
    where = partial(_where, path, doc)
    pair_keys = [k for k in doc if isinstance(k, str) and _PAIR_KEY.match(k)]
    count = _frame_count(path, doc, pair_keys)
    Ts = _pair_matrices(doc, count, where)
    _refuse_extra_pairs(pair_keys, count, where)
    T_base_ee = scaled_to_metres(np.array(Ts[0]), units, [where(f"T1_{i}") for i in range(count)], "T_base_ee")
    T_cam_target = scaled_to_metres(np.array(Ts[1]), units, [where(f"T2_{i}") for i in range(count)], "T_cam_target")
    if camera_frame is None:
        check_camera_frame(T_cam_target, str(path))
        camera_frame = "optical"
    rows = [line_of(doc, f"T1_{i}") for i in range(count)]
    return PoseSet(T_base_ee, to_optical(T_cam_target, camera_frame), str(path), rows)


def _where(path: Path, doc: dict, key: str) -> str:
    """The file, the key's line where it is known, and the key, for messages."""
    line = line_of(doc, key)
    return f"{path}, line {line}, {key}" if line else f"{path}, {key}"


def _pair_index(key: str) -> int:
    """The ``i`` of a key ``T1_i`` or ``T2_i``."""
    return int(_PAIR_KEY.match(key).group(1))


def _frame_count(path: Path, doc: dict, pair_keys: list[str]) -> int:
    """The number of pairs: ``frameCount``, checked, else one more than the highest pair key's ``i``."""
    count = doc.get("frameCount")
    if count is None:
        if not pair_keys:
            raise PoseFileError(
                f"{path}: no frameCount and no T1_0/T2_0 keys: not camodocal's TransformPairsInput.yml "
                "(pairs of 4x4 matrices T1_i = T_base_ee, T2_i = T_cam_target)"
            )
        return 1 + max(_pair_index(k) for k in pair_keys)
    if not isinstance(count, int) or isinstance(count, bool) or not 0 <= count <= MAX_FRAME_COUNT:
        raise PoseFileError(f"{_where(path, doc, 'frameCount')}: {count!r} is not a count of pose pairs")
    return count


def _pair_matrices(doc: dict, count: int, where) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The checked ``T1_i`` and ``T2_i`` ``(4, 4)`` of every pair, read pair by pair."""
    Ts = ([], [])
    for i in range(count):
        for side, pattern in enumerate(PAIR_KEYS):
            Ts[side].append(_pair_matrix(doc, pattern.format(i), count, i, where))
    return Ts


def _pair_matrix(doc: dict, key: str, count: int, i: int, where) -> np.ndarray:
    """One pair key's matrix, refusing it missing or not an ``!!opencv-matrix``."""
    if key not in doc:
        raise PoseFileError(
            f"{where('frameCount')}: frameCount is {count} but {key} is missing "
            f"(pair {i} of T1_i = T_base_ee, T2_i = T_cam_target)"
        )
    value = doc[key]
    if not isinstance(value, np.ndarray):
        raise PoseFileError(f"{where(key)}: not an !!opencv-matrix (got {type(value).__name__})")
    return checked_pose_matrix(value, where(key))


def _refuse_extra_pairs(pair_keys: list[str], count: int, where) -> None:
    """Refuse a pair key beyond ``frameCount``, naming the first."""
    extra = sorted(k for k in pair_keys if _pair_index(k) >= count)
    if extra:
        raise PoseFileError(f"{where(extra[0])}: frameCount is {count} but the file holds {extra[0]} too")
