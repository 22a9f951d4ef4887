"""Read and write pose files: paired robot and target poses, CSV or JSON.

CSV: one row per pose, a header naming the columns, ``#`` lines ignored::

    # T_base_ee: flange in robot base; T_cam_target: board in camera; metres
    T_base_ee.x,T_base_ee.y,T_base_ee.z,T_base_ee.qx,T_base_ee.qy,T_base_ee.qz,T_base_ee.qw,T_cam_target.x,...,T_cam_target.qw

Each pose is ``<name>.x, .y, .z`` plus one rotation: ``.qx, .qy, .qz, .qw``
(a quaternion; the column names state the order, so columns may come in any
order), ``.q0, .q1, .q2, .q3`` (a quaternion in the order given by
``quat_order``), or ``.rx, .ry, .rz`` (a rotation vector in radians, as UR
controllers report). ``<name>`` is ``T_base_ee`` and ``T_cam_target``.

Robot controllers' own columns, named after the convention (matrices in
:mod:`handeye.core.robot_angles`, checked there against scipy):

* KUKA ``.a, .b, .c``: degrees, ``R = Rz(A) Ry(B) Rx(C)`` (``from_euler("ZYX", [A, B, C])``);
* Fanuc ``.w, .p, .r``: degrees, fixed axes, ``R = Rz(R) Ry(P) Rx(W)`` (``from_euler("xyz", [W, P, R])``);
* ABB ``.q1, .q2, .q3, .q4``: a quaternion, scalar first ``(w, x, y, z)``.

These controllers report millimetres and degrees, so a pose given in these
columns is read in millimetres unless ``units`` is given (``--units``, which
then applies to every pose of the file); the angles are always degrees. A
column of such angles all within +-pi is refused as radians. A header that
matches two rotation forms for one pose is refused as ambiguous.

JSON::

    {"units": "m", "quaternion_order": "xyzw",
     "poses": [{"T_base_ee": {"translation": [x, y, z], "quaternion": [...]},
                "T_cam_target": {"matrix": [[...], [...], [...], [...]]}}, ...]}

each pose given as ``matrix`` (4x4), ``translation`` + ``quaternion`` (order
``quaternion_order``) or ``translation`` + ``rotvec`` (radians).

YAML (``.yaml``, ``.yml``, ``.samples``): an easy_handeye (ROS 1) or
easy_handeye2 (ROS 2) sample list, read by :mod:`handeye.core.easy_handeye`;
its robot transforms depend on the setup, so give ``setup``. A YAML file whose
first line is ``%YAML:1.0`` is OpenCV FileStorage: camodocal's pose pairs
``T1_i`` (``T_base_ee``) and ``T2_i`` (``T_cam_target``), read by
:mod:`handeye.core.opencv_pose_pairs`. Text files of 4x4 matrices (robot poses
in one file, camera poses in another) are read by :mod:`handeye.core.matrix_poses`.

Camera poses are in the optical frame (z forward). Poses that say they are in a
ROS body frame (``camera_link``, x forward) are refused unless ``camera_frame``
names the frame (:mod:`handeye.core.camera_frame`).

Units: metres by default (millimetres for the robot controllers' columns);
``units="mm"`` converts. A quaternion that is not unit is reported with its
row. A quaternion-order mistake is caught by
:func:`handeye.checked_poses.load_poses`, which needs the solvers.
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np

from handeye.core.camera_frame import check_camera_frame, check_camera_frame_name, to_optical
from handeye.core.errors import PoseFileError
from handeye.core.limits import (
    ABSURD_TRANSLATION_M,
    MAX_JSON_DEPTH,
    MAX_TEXT_FILE_BYTES,
    check_csv_text,
    check_json_depth,
    shorten,
)
from handeye.core.numbers import CSV_CELL_SPACES, float_array, loads_json, parse_float, parse_floats_fast
from handeye.core.opencv_yaml import is_opencv_yaml
from handeye.core.poseset import UNIT_SCALE, PoseSet
from handeye.core.robot_angles import matrix_from_fanuc_wpr, matrix_from_kuka_abc
from handeye.core.safe_write import write_text_atomic
from handeye.core.se3 import (
    make_transform,
    matrix_from_quat_xyzw,
    pos_quat_xyzw_from_transform,
    quat_wxyz_to_xyzw,
    so3_exp,
)
from handeye.core.textfile import check_text_file, read_text

__all__ = [
    "POSE_NAMES",
    "QUAT_ORDERS",
    "ROBOT_CONTROLLER_UNITS",
    "YAML_SUFFIXES",
    "PoseSet",
    "RobotPoses",
    "read_pose_file",
    "read_robot_poses",
    "write_pose_csv",
]

POSE_NAMES = ("T_base_ee", "T_cam_target")
QUAT_ORDERS = ("xyzw", "wxyz")
#: Rotation columns of robot controllers, and the translation unit those controllers report with them.
ROBOT_CONTROLLER_UNITS = {"kuka_abc": "mm", "fanuc_wpr": "mm", "abb_quat": "mm"}
#: No industrial arm holds its flange this close to its base frame in every pose: a controller file whose robot
#: translations, read in the controller's millimetres, all fall within it was written in metres.
MIN_CONTROLLER_REACH_M = 0.05
#: Suffixes of easy_handeye sample lists (YAML; easy_handeye2 saves `<name>.samples`).
YAML_SUFFIXES = (".yaml", ".yml", ".samples")
_QUAT_NORM_TOL = 1e-3


def _quat(values: np.ndarray, order: str) -> np.ndarray:
    return values if order == "xyzw" else quat_wxyz_to_xyzw(values)


def _check_unit(q: np.ndarray, where: str) -> None:
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > _QUAT_NORM_TOL:
        raise PoseFileError(f"{where}: quaternion {np.round(q, 4).tolist()} has norm {norm:.4f}, not 1")


#: A pose file larger than this is refused before it is read (a few thousand poses take kilobytes).
MAX_POSE_FILE_BYTES = MAX_TEXT_FILE_BYTES


def _check_file(path: Path) -> None:
    """One line for each way a path is not a readable pose file."""
    check_text_file(path, "pose file", max_bytes=MAX_POSE_FILE_BYTES)


def _read_text(path: Path) -> str:
    """The file's text (UTF-8), or a :class:`PoseFileError` naming the file."""
    return read_text(path, "pose file", max_bytes=MAX_POSE_FILE_BYTES, hint="; save the pose file as UTF-8")


def _read_json(path: Path):
    """The parsed JSON of a pose file, or a :class:`PoseFileError` (not JSON, nested too deeply)."""
    try:
        # NaN and Infinity parse, for float_array to refuse naming the pose entry
        doc = loads_json(_read_text(path), str(path), PoseFileError, constants=True)
    except json.JSONDecodeError as exc:
        raise PoseFileError(f"{path}: not valid JSON ({exc})") from None
    except RecursionError:
        raise PoseFileError(f"{path}: JSON nested deeper than the parser allows (limit {MAX_JSON_DEPTH})") from None
    return check_json_depth(doc, str(path), PoseFileError)


#: The last CSV read, by (path, size, modification time, inode, names): the quaternion-order test of
#: :func:`handeye.checked_poses.load_poses` reads one file four times, and 10^5 rows take a second each.
_LAST_CSV: dict = {}


def _read_csv(path: Path, names: tuple[str, ...] = POSE_NAMES) -> tuple[dict, list[int], dict]:
    """Raw columns per pose name ``(N, 6 or 7)``, the line numbers, and the rotation kind per name.

    An ``image`` column, if present, is returned under the key ``"image"`` of the first dict. The arrays
    returned are copies: a caller may change them.
    """
    st = path.stat()
    key = (str(path.resolve()), st.st_size, st.st_mtime_ns, st.st_ino, tuple(names))
    if key not in _LAST_CSV:
        _LAST_CSV.clear()
        _LAST_CSV[key] = _read_csv_uncached(path, names)
    raw, rows, kinds = _LAST_CSV[key]
    return {k: (v.copy() if isinstance(v, np.ndarray) else list(v)) for k, v in raw.items()}, list(rows), dict(kinds)


def _read_csv_uncached(path: Path, names: tuple[str, ...]) -> tuple[dict, list[int], dict]:
    text = _read_text(path)
    lines = _content_lines(text, path)
    header_line, header = lines[0][0], [h.strip() for h in next(csv.reader([lines[0][1]]))]
    col = {h: k for k, h in enumerate(header)}
    rows = [ln for ln, _ in lines[1:]]
    table = _csv_table(lines[1:], path)
    raw, kinds = ({"image": _image_column(table, col["image"])} if "image" in col else {}), {}
    for name in names:  # one pose's header, then its values, then the next pose's
        kinds[name], cols = _pose_columns(name, col, header, f"{path}, header (line {header_line})")
        raw[name] = _pose_values(table, rows, header, [(col[c], c) for c in cols], path)
    return raw, rows, kinds


def _image_column(table: list[list[str]], k: int) -> list[str]:
    """The image names of column ``k``, ``""`` where a row is too short."""
    return [row[k].strip() if len(row) > k else "" for row in table]


def _content_lines(text: str, path: Path) -> list[tuple[int, str]]:
    """The (line number, line) pairs that are neither blank nor ``#`` comments, checked; at least the header."""
    lines = [
        (i + 1, line)
        for i, line in enumerate(io.StringIO(text, newline=""))
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not lines:
        raise PoseFileError(f"{path}: no header and no rows")
    check_csv_text(lines, str(path), PoseFileError)
    return lines


def _csv_table(lines: list[tuple[int, str]], path: Path) -> list[list[str]]:
    """The fields of each data line."""
    try:
        return list(csv.reader([text for _, text in lines]))
    except csv.Error as exc:  # a field over the csv module's size limit
        raise PoseFileError(f"{path}: not a CSV pose file ({exc})") from None


def _rotation_columns(name: str) -> dict[str, list[str]]:
    """The columns of each rotation form pose ``name`` may be given in, by form."""
    return {
        "quat_named": [f"{name}.q{c}" for c in "xyzw"],
        "quat_positional": [f"{name}.q{k}" for k in range(4)],
        "rotvec": [f"{name}.r{c}" for c in "xyz"],
        "kuka_abc": [f"{name}.{c}" for c in "abc"],
        "fanuc_wpr": [f"{name}.{c}" for c in "wpr"],
        "abb_quat": [f"{name}.q{k}" for k in range(1, 5)],
    }


def _pose_columns(name: str, col: dict, header: list[str], where: str) -> tuple[str, list[str]]:
    """The one rotation form of pose ``name`` in the header and the pose's columns (x, y, z, then the rotation's),
    refusing none (or no x, y, z) and several."""
    xyz = [f"{name}.{c}" for c in "xyz"]
    options = _rotation_columns(name)
    found = [k for k, cols in options.items() if all(c in col for c in cols)]
    if any(c not in col for c in xyz) or not found:
        raise _columns_not_found(name, xyz, options, header, where)
    if len(found) > 1:
        raise PoseFileError(
            f"{where}: columns for {name} give {len(found)} rotations ("
            f"{' and '.join(', '.join(options[k]) for k in found)}); keep the columns of one"
        )
    return found[0], xyz + options[found[0]]


def _columns_not_found(name: str, xyz: list[str], options: dict, header: list[str], where: str) -> PoseFileError:
    """The error for a header without pose ``name``'s translation or any of its rotation forms."""
    return PoseFileError(
        f"{where}: columns for {name} not found; need {', '.join(xyz)} and "
        f"one of: {' | '.join(', '.join(cols) for cols in options.values())}. Header is: "
        f"{shorten(', '.join(header), 120)}"
    )


def _pose_values(table: list, rows: list[int], header: list[str], columns: list[tuple[int, str]], path: Path):
    """The ``(N, len(columns))`` values of the ``(index, name)`` columns: all at once, else cell by cell."""
    values = _fast_values(table, [k for k, _ in columns], len(header))
    if values is not None:  # every cell a finite number of the grammar, every translation within bounds
        return values
    values = np.empty((len(table), len(columns)))  # one by one, to name the first bad cell
    for r, (line_no, row) in enumerate(zip(rows, table)):
        if len(row) != len(header):
            raise PoseFileError(f"{path}, line {line_no}: {len(row)} fields, header has {len(header)}")
        for c, (k, cname) in enumerate(columns):
            values[r, c] = _cell_value(row[k], f"{path}, line {line_no}, column {cname}", translation=c < 3)
    return values


def _cell_value(cell: str, where: str, translation: bool) -> float:
    """One cell's number, refusing a translation beyond :data:`ABSURD_TRANSLATION_M` in millimetres."""
    value = parse_float(cell.strip(CSV_CELL_SPACES), where, PoseFileError)
    if translation and abs(value) > ABSURD_TRANSLATION_M * 1e3:
        raise PoseFileError(
            f"{where}: {shorten(cell.strip())} is absurd for a "
            f"translation (over {ABSURD_TRANSLATION_M:g} m in metres or in millimetres)"
        )
    return value


def _fast_values(table: list, indices: list[int], n_header: int) -> np.ndarray | None:
    """The ``(N, len(indices))`` values when every row is whole and every cell a plain number (translations, the
    first three columns, within :data:`ABSURD_TRANSLATION_M` in millimetres); ``None`` sends the caller to the
    cell-by-cell reading that names the bad one."""
    if any(len(row) != n_header for row in table):
        return None
    cells = [row[k].strip(CSV_CELL_SPACES) for row in table for k in indices]
    flat = parse_floats_fast(cells)
    if flat is None:
        return None
    values = flat.reshape(len(table), len(indices))
    if values.size and np.abs(values[:, :3]).max() > ABSURD_TRANSLATION_M * 1e3:
        return None
    return values


#: Euler-angle columns of robot controllers (degrees) and their rotation matrices.
_EULER_KINDS = {"kuka_abc": (".a .b .c", matrix_from_kuka_abc), "fanuc_wpr": (".w .p .r", matrix_from_fanuc_wpr)}


def _euler_rotations(angles_deg: np.ndarray, kind: str, where, rows) -> np.ndarray:
    """Rotations ``(N, 3, 3)`` of controller Euler angles in degrees, refusing non-finite angles and radians."""
    columns, to_matrix = _EULER_KINDS[kind]
    for r, row in enumerate(angles_deg):
        if not np.isfinite(row).all():
            raise PoseFileError(f"{where(rows[r])}: angles {columns} = {row.tolist()} are not finite")
    if len(angles_deg) >= 3 and 0 < np.abs(angles_deg).max() <= np.pi:
        raise PoseFileError(
            f"{where(rows[0])} and every other row: all angles {columns} are within +-{np.pi:.4f}; they look like "
            f"radians, but these columns are degrees (as the controller reports them): convert them, or give a "
            f"rotation vector in radians (.rx .ry .rz)"
        )
    return to_matrix(angles_deg)


def _to_transforms(values: np.ndarray, kind: str, quat_order: str, scale: float, where, rows) -> np.ndarray:
    t = values[:, :3] * scale
    rot = values[:, 3:]
    if kind == "rotvec":
        return make_transform(so3_exp(rot), t)
    if kind in _EULER_KINDS:
        return make_transform(_euler_rotations(rot, kind, where, rows), t)
    if kind == "quat_named":
        q = rot
    elif kind == "abb_quat":
        q = quat_wxyz_to_xyzw(rot)  # ABB q1..q4 = (w, x, y, z)
    else:
        q = _quat(rot, quat_order)
    bad = np.flatnonzero(~(np.abs(np.linalg.norm(q, axis=1) - 1.0) <= _QUAT_NORM_TOL))
    if bad.size:  # the first row whose quaternion is not a unit one (NaN norms included)
        _check_unit(q[bad[0]], where(rows[bad[0]]))
    return make_transform(matrix_from_quat_xyzw(q), t)


def _pose_from_json(entry, quat_order: str, scale: float, where: str) -> np.ndarray:
    if not isinstance(entry, dict):
        raise PoseFileError(f"{where}: expected an object with 'matrix' or 'translation' + 'quaternion'/'rotvec'")
    arrays = {
        key: float_array(entry[key], f"{where}.{key}", PoseFileError)
        for key in ("matrix", "translation", "quaternion", "rotvec")
        if key in entry
    }
    try:
        if "matrix" in arrays:
            T = arrays["matrix"]
            if T.shape != (4, 4):
                raise PoseFileError(f"{where}: 'matrix' must be 4x4, got shape {T.shape}")
            T = T.copy()
            T[:3, 3] *= scale
            return T
        t = arrays["translation"] * scale
        if "quaternion" in arrays:
            q = _quat(arrays["quaternion"], quat_order)
            _check_unit(q, where)
            return make_transform(matrix_from_quat_xyzw(q), t)
        if "rotvec" in arrays:
            return make_transform(so3_exp(arrays["rotvec"]), t)
    except (KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, PoseFileError):
            raise
        raise PoseFileError(f"{where}: {exc}") from None
    raise PoseFileError(f"{where}: give 'matrix', or 'translation' with 'quaternion' or 'rotvec'")


def _parse(path: Path, quat_orders: dict, units: str | None, names: tuple[str, ...] = POSE_NAMES):
    """Transforms of the pose names with the given quaternion order per name (and ``image`` if given)."""
    if path.suffix.lower() == ".json":
        return _parse_json(path, quat_orders, units, names)
    return _parse_csv(path, quat_orders, units, names)


def _parse_json(path: Path, quat_orders: dict, units: str | None, names: tuple[str, ...]):
    """:func:`_parse` of a JSON pose file: its ``poses`` list, in its own ``units`` unless ``units`` is given."""
    doc = _read_json(path)
    if not isinstance(doc, dict) or not isinstance(doc.get("poses"), list):
        raise PoseFileError(f"{path}: expected an object with a 'poses' list")
    unit = units or doc.get("units", "m")
    if unit not in UNIT_SCALE:
        raise PoseFileError(f"{path}: units {unit!r} not understood; use 'm' or 'mm'")
    poses = doc["poses"]
    out = {"image": [str(pose["image"]) for pose in poses]} if all(_has(pose, "image") for pose in poses) else {}
    for name in names:
        out[name] = _json_transforms(path, poses, name, quat_orders[name], UNIT_SCALE[unit])
    return out, list(range(len(poses))), {n: "json" for n in names}


def _has(pose, key: str) -> bool:
    """Whether a JSON pose entry is an object holding ``key``."""
    return isinstance(pose, dict) and key in pose


def _json_transforms(path: Path, poses: list, name: str, quat_order: str, scale: float) -> np.ndarray:
    """The ``(N, 4, 4)`` transforms of pose ``name`` in every entry of a JSON ``poses`` list."""
    Ts = []
    for k, pose in enumerate(poses):
        if not _has(pose, name):
            raise PoseFileError(f"{path}, poses[{k}]: missing {name}")
        Ts.append(_pose_from_json(pose[name], quat_order, scale, f"{path}, poses[{k}].{name}"))
    return np.array(Ts).reshape(-1, 4, 4)


def _line_place(path: Path, name: str, line: int) -> str:
    """Where a pose's value is, for messages: the file, the line and the pose's name."""
    return f"{path}, line {line}, {name}"


def _parse_csv(path: Path, quat_orders: dict, units: str | None, names: tuple[str, ...]):
    """:func:`_parse` of a CSV pose file, refusing a controller's millimetre columns written in metres."""
    raw, rows, kinds = _read_csv(path, names)
    if units is not None and units not in UNIT_SCALE:
        raise PoseFileError(f"units {units!r} not understood; use 'm' or 'mm'")
    out = {"image": raw["image"]} if "image" in raw else {}
    for name in names:
        unit = units or ROBOT_CONTROLLER_UNITS.get(kinds[name], "m")
        where = partial(_line_place, path, name)
        out[name] = _to_transforms(raw[name], kinds[name], quat_orders[name], UNIT_SCALE[unit], where, rows)
        if units is None and unit == "mm":
            _check_controller_reach(path, name, out[name])
    return out, rows, kinds


def _check_controller_reach(path: Path, name: str, T: np.ndarray) -> None:
    """Refuse a controller's pose columns in metres read as its millimetres (every pose within a few mm)."""
    reach_m = float(np.max(np.linalg.norm(T[:, :3, 3], axis=1))) if len(T) else np.inf
    if reach_m < MIN_CONTROLLER_REACH_M:
        raise PoseFileError(
            f"{path}: {name}'s translations, read in millimetres as the controller writes them, are all within "
            f"{reach_m * 1e3:.2f} mm of the base; no arm reaches that close: written in metres? give --units m"
        )


def _quat_order(path: Path, quat_order: str | None) -> str:
    """``quat_order``, else a JSON file's own ``quaternion_order``, else ``"xyzw"``."""
    if path.suffix.lower() == ".json" and quat_order is None:
        try:
            quat_order = _read_json(path).get("quaternion_order")
        except (PoseFileError, AttributeError):  # read_pose_file's own parse names what is wrong
            quat_order = None
    order = quat_order or "xyzw"
    if order not in QUAT_ORDERS:
        raise PoseFileError(f"{path}: quaternion_order {order!r} not understood; use one of {QUAT_ORDERS}")
    return order


def read_pose_file(
    path: str | Path,
    quat_order: str | None = None,
    units: str | None = None,
    swap_order_of: tuple[str, ...] = (),
    setup: str | None = None,
    camera_frame: str | None = None,
) -> PoseSet:
    """Read paired ``T_base_ee`` and ``T_cam_target`` from a CSV, JSON, easy_handeye or OpenCV YAML file.

    Parameters
    ----------
    path : str or Path
        ``.csv``, ``.json``, or ``.yaml``/``.yml``/``.samples`` (formats in this module's docstring); a YAML
        file whose first line is ``%YAML:1.0`` is OpenCV FileStorage pose pairs
        (:func:`handeye.core.opencv_pose_pairs.read_opencv_pose_pairs`).
    quat_order : {"xyzw", "wxyz"}, optional
        Order of positional quaternions (JSON ``quaternion`` lists, CSV
        ``.q0 .. .q3`` columns). Overrides the JSON's ``quaternion_order``;
        default ``xyzw``. Named CSV columns (``.qx`` ...) state their own order.
    units : {"m", "mm"}, optional
        Translation units; overrides the JSON's ``units``; default metres.
    swap_order_of : tuple of str
        Pose names (from :data:`POSE_NAMES`) whose positional quaternions are
        read in the other order: how :func:`handeye.checked_poses.load_poses`
        tests for an order mistake.
    setup : {"eye_to_hand", "eye_in_hand"}, optional
        For YAML sample files only: easy_handeye records ``T_ee_base`` as the
        robot transform of an eye-on-base (eye-to-hand) calibration and
        ``T_base_ee`` for eye-in-hand (:mod:`handeye.core.easy_handeye`).
    camera_frame : {"optical", "ros-body"}, optional
        The frame of the camera poses. ``None``: optical, refused when the targets say it is a ROS body
        frame (x forward; :func:`handeye.core.camera_frame.check_camera_frame`); ``"ros-body"``: converted
        to the optical frame; ``"optical"``: taken as is.

    Returns
    -------
    PoseSet
        Camera poses in the optical frame.

    Raises
    ------
    PoseFileError
        Unreadable file, missing column, bad number, non-unit quaternion; the
        message names the file and the line or entry.
    """
    path = Path(path)
    _check_file(path)
    check_camera_frame_name(camera_frame)
    if path.suffix.lower() in YAML_SUFFIXES and is_opencv_yaml(path):
        from handeye.core.opencv_pose_pairs import read_opencv_pose_pairs

        return read_opencv_pose_pairs(path, units=units, camera_frame=camera_frame)
    if path.suffix.lower() in YAML_SUFFIXES:
        from handeye.core.easy_handeye import read_easy_handeye_samples

        return _in_optical_frame(read_easy_handeye_samples(path, setup=setup, units=units), camera_frame)
    order = _quat_order(path, quat_order)
    other = QUAT_ORDERS[1 - QUAT_ORDERS.index(order)]
    poses, rows, _ = _parse(path, {n: (other if n in swap_order_of else order) for n in POSE_NAMES}, units)
    return _in_optical_frame(PoseSet(poses["T_base_ee"], poses["T_cam_target"], str(path), rows), camera_frame)


def _in_optical_frame(poses: PoseSet, camera_frame: str | None) -> PoseSet:
    """The pose set with its camera poses in the optical frame (checked when the frame is not given)."""
    if camera_frame is None:
        check_camera_frame(poses.T_cam_target, poses.source)
        return poses
    poses.T_cam_target = to_optical(poses.T_cam_target, camera_frame)
    return poses


@dataclass
class RobotPoses:
    """Robot poses read from a file, optionally named by the image recorded at each.

    Attributes
    ----------
    T_base_ee : array, shape (N, 4, 4)
    images : list of str or None
        The ``image`` column (file names relative to the image folder), when the file has one.
    source : str
    rows : list of int
    """

    T_base_ee: np.ndarray
    images: list | None
    source: str
    rows: list = field(default_factory=list)


def read_robot_poses(path: str | Path, quat_order: str | None = None, units: str | None = None) -> RobotPoses:
    """Read robot poses ``T_base_ee``, one per view, for calibration from images.

    Same formats as :func:`read_pose_file` with only the ``T_base_ee`` columns
    (or entries), plus an optional ``image`` column (JSON: key) naming the
    image recorded at that pose: with it, poses are paired with detections by
    name, not by order.

    Parameters
    ----------
    path : str or Path
    quat_order : {"xyzw", "wxyz"}, optional
    units : {"m", "mm"}, optional

    Returns
    -------
    RobotPoses

    Raises
    ------
    PoseFileError
    """
    path = Path(path)
    _check_file(path)
    order = _quat_order(path, quat_order)
    names = ("T_base_ee",)
    out, rows, _ = _parse(path, {n: order for n in names}, units, names)
    return RobotPoses(out["T_base_ee"], out.get("image"), str(path), rows)


def write_pose_csv(path: str | Path, T_base_ee: np.ndarray, T_cam_target: np.ndarray, comment: str = "") -> None:
    """Write paired poses as a CSV with named (x, y, z, w) quaternion columns.

    Parameters
    ----------
    path : str or Path
    T_base_ee, T_cam_target : array, shape (N, 4, 4)
        Metres.
    comment : str
        Lines written as ``#`` comments above the header.
    """
    header = []
    for name in POSE_NAMES:
        header += [f"{name}.{c}" for c in "xyz"] + [f"{name}.q{c}" for c in "xyzw"]
    lines = [f"# {c}" for c in comment.splitlines()] + [",".join(header)]
    t1, q1 = pos_quat_xyzw_from_transform(T_base_ee)
    t2, q2 = pos_quat_xyzw_from_transform(T_cam_target)
    for row in np.concatenate([t1, q1, t2, q2], axis=1):
        lines.append(",".join(f"{v:.17g}" for v in row))  # 17 digits: a float64 reads back exactly
    write_text_atomic(path, "\n".join(lines) + "\n")
