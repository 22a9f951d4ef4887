"""The labelled RGB-D dataset format: a directory any user can open with standard tools.

Layout (``FORMAT_VERSION`` 1)::

    meta.json                   format, version, robot, intrinsics, depth scale, board, recipe
    cameras.csv                 one row per camera pose: region, split, truth, classic label
    shards/cam_0000/frames.csv  one row per frame of that camera pose
    shards/cam_0000/rgb/*.png   colour, 8-bit RGB
    shards/cam_0000/depth/*.png depth, 16-bit, metres = value * meta["depth"]["scale_m"], 0 = no depth
    shards/cam_0000/manifest.json   written last: every file of the shard with its size

Poses are columns ``<T_a_b>.x, .y, .z`` (metres) and ``.qx, .qy, .qz, .qw``
(unit quaternion, scalar last), as in pose files (:mod:`handeye.core.posefile`);
joint angles ``q0 .. q<n-1>`` in radians. Every frame belongs to a recording:
``calibration`` (the board on the flange, no depth) or ``data`` (the robot
with its tool, colour and depth; what the learned model trains on).

A shard is complete when its ``manifest.json`` exists and every file it lists
has the listed size; a shard is written into ``cam_XXXX.partial`` and renamed
once complete, so a crash never leaves a shard that looks complete. One writer
does this, for the simulator and for real recordings alike:
:class:`handeye.core.shard_writer.ShardWriter`. Reading is
lazy (tables on first use, images on request) and validated, with errors
(:class:`handeye.core.errors.DatasetError`) that name the file, row and column.

Filling it from a real robot: write ``meta.json`` (intrinsics from ``handeye
intrinsics``, the board, ``depth.scale_m`` of your sensor), one ``cameras.csv``
row per camera placement (truth columns empty), and per placement a shard with
the calibration images and flange poses and the data images with joint angles,
``T_base_ee`` and ``T_base_ref``, written with
:class:`~handeye.core.shard_writer.ShardWriter` (an example in its module);
then run ``handeye label``.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from handeye.core.errors import DatasetError
from handeye.core.jsonfile import read_json_file
from handeye.core.limits import (
    MAX_DATASET_CAMERAS,
    MAX_JOINTS,
    check_csv_text,
    check_image_bytes,
    check_image_size,
    shorten,
)
from handeye.core.numbers import CSV_CELL_SPACES, NONFINITE_WORDS, float_array, parse_float, parse_int
from handeye.core.pose_matrices import checked_pose_matrix
from handeye.core.safe_write import write_text_atomic
from handeye.core.se3 import pos_quat_xyzw_from_transform, transform_from_pos_quat_xyzw
from handeye.core.textfile import file_kind

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "RECORDINGS",
    "POSE_FIELDS",
    "CAMERA_COLUMNS",
    "SENSOR_COLUMNS",
    "REGISTRATION_COLUMNS",
    "LABEL_COLUMNS",
    "MARKERLESS_COLUMNS",
    "camera_table_columns",
    "Dataset",
    "pose_columns",
    "frame_columns",
    "poses_to_columns",
    "columns_to_poses",
    "read_table",
    "write_table",
    "shard_name",
    "write_manifest",
    "shard_is_complete",
    "write_json_atomic",
    "encode_depth",
    "decode_depth",
    "dataset_lock",
    "LABEL_LOCK_WAIT_S",
]

FORMAT = "handeye-dataset"
FORMAT_VERSION = 1
RECORDINGS = ("calibration", "data")
POSE_FIELDS = ("x", "y", "z", "qx", "qy", "qz", "qw")
SPLITS = ("train", "test")


def pose_columns(name: str) -> list[str]:
    """The seven column names of pose ``name``: ``name.x`` ... ``name.qw``."""
    return [f"{name}.{f}" for f in POSE_FIELDS]


#: Camera table: the placement, and the truth where known (empty cells for a real robot).
CAMERA_COLUMNS = [
    "camera_id",
    "region",
    "split",
    "azimuth_deg",
    "elevation_deg",
    "radius_m",
    *pose_columns("T_base_cam_true"),
]
#: Written by the simulator with a depth sensor profile: the unit's systematic errors at the placement, the truth
#: that the markerless registration estimates (``d_obs = scale d + offset``) and the depth-to-colour extrinsic's
#: error (the registered depth is that of a camera displaced by minus this vector in the colour camera's frame).
SENSOR_COLUMNS = [
    "depth_scale_true",
    "depth_offset_mm_true",
    "depth_extrinsic_mm_true.x",
    "depth_extrinsic_mm_true.y",
    "depth_extrinsic_mm_true.z",
]
#: Written by the simulator where the profile misregisters its depth image against the colour camera's model
#: (``d435-real-cell``): the drawn shift in pixels and turn about the principal point in degrees.
REGISTRATION_COLUMNS = [
    "depth_registration_px_true.u",
    "depth_registration_px_true.v",
    "depth_registration_roll_deg_true",
]
#: Written by labelling: the classic label, how it was obtained and, with a truth, its error.
LABEL_COLUMNS = [
    *pose_columns("T_base_cam_label"),
    "label_status",
    "label_views_used",
    "label_views_total",
    "label_rms_px",
    "label_sigma_rot_deg",
    "label_sigma_trans_mm",
    "label_error_rot_deg",
    "label_error_trans_mm",
]
#: Written by ``handeye markerless --write-labels``: the board-free label from the robot's surface.
MARKERLESS_COLUMNS = [
    *pose_columns("T_base_cam_markerless"),
    "markerless_status",
    "markerless_sigma_rot_deg",
    "markerless_sigma_trans_mm",
    "markerless_error_rot_deg",
    "markerless_error_trans_mm",
]
_INT_COLUMNS = {"camera_id", "region", "frame", "label_views_used", "label_views_total"}
_STR_COLUMNS = {"split", "recording", "rgb", "depth", "label_status", "markerless_status"}


def camera_table_columns(table: dict) -> list[str]:
    """The camera table's columns in order: placement and truth, then the label groups the table has."""
    cols = list(CAMERA_COLUMNS)
    if "depth_scale_true" in table:
        cols += SENSOR_COLUMNS
    if REGISTRATION_COLUMNS[0] in table:
        cols += REGISTRATION_COLUMNS
    if "T_base_cam_label.x" in table:
        cols += LABEL_COLUMNS
    if "T_base_cam_markerless.x" in table:
        cols += MARKERLESS_COLUMNS
    return cols


def shard_name(camera_id: int) -> str:
    """Directory of a camera pose's shard, relative to the dataset root."""
    return f"shards/cam_{int(camera_id):04d}"


def frame_columns(n_joints: int) -> list[str]:
    """Columns of a shard's ``frames.csv``."""
    return [
        "frame",
        "camera_id",
        "region",
        "split",
        "recording",
        *[f"q{j}" for j in range(n_joints)],
        *pose_columns("T_base_ee"),
        *pose_columns("T_base_ref"),
        "rgb",
        "depth",
    ]


# ------------------------------------------------------------------ poses <-> columns


def poses_to_columns(name: str, T: np.ndarray) -> dict:
    """Columns ``name.x .. name.qw`` of poses, shape (N, 4, 4) -> dict of arrays (N,)."""
    t, q = pos_quat_xyzw_from_transform(np.asarray(T, dtype=float).reshape(-1, 4, 4))
    values = np.concatenate([t, q], axis=1)
    return {c: values[:, k] for k, c in enumerate(pose_columns(name))}


def columns_to_poses(table: dict, name: str, where: str = "") -> np.ndarray:
    """Poses ``name`` of a table, shape (N, 4, 4); NaN rows (unknown) give NaN poses.

    Raises
    ------
    DatasetError
        When a quaternion is not unit (a corrupted or hand-edited table).
    """
    values = np.column_stack([np.asarray(table[c], dtype=float) for c in pose_columns(name)])
    known = np.isfinite(values).all(axis=1)
    norms = np.linalg.norm(values[:, 3:], axis=1)
    bad = np.flatnonzero(known & (np.abs(norms - 1.0) > 1e-4))
    if len(bad):
        raise DatasetError(
            f"{where}: {name} of row {bad[0] + 2} has a quaternion of norm {norms[bad[0]]:.6f}, not a unit quaternion"
        )
    out = np.full((len(values), 4, 4), np.nan)
    if known.any():
        out[known] = transform_from_pos_quat_xyzw(values[known, :3], values[known, 3:])
    return out


# ------------------------------------------------------------------ tables


#: A pose translation in a dataset table (metres) beyond this is refused as absurd: a dataset records one robot
#: cell, a few metres across; a 100 m translation is a corrupted or hand-edited cell (``1_000``, millimetres).
MAX_TABLE_TRANSLATION_M = 100.0
_TRANSLATION_COLUMN = re.compile(r"T_\w+\.[xyz]", re.ASCII)


def _parse(value: str, column: str, path: Path, row: int):
    """One cell: text, an int, a float (numbers in :mod:`handeye.core.numbers`'s grammar), or unknown if empty.

    write_table writes an unknown value as an empty cell, never nan or inf; those words are refused.
    """
    if column in _STR_COLUMNS:
        return value
    value = value.strip(CSV_CELL_SPACES)
    if value == "":
        return None if column in _INT_COLUMNS else np.nan
    where = f"{path}: row {row} column {column}"
    if value.lower() in NONFINITE_WORDS:
        raise DatasetError(f"{where}: {shorten(value)} is not finite (an unknown value is an empty cell)")
    if column in _INT_COLUMNS:
        return parse_int(value, where, DatasetError)
    return parse_float(value, where, DatasetError)


def _check_translations(table: dict, path: Path) -> None:
    """Refuse a pose translation cell over :data:`MAX_TABLE_TRANSLATION_M`, naming the row and column.

    Raises
    ------
    DatasetError
    """
    for column, values in table.items():
        if not _TRANSLATION_COLUMN.fullmatch(column):
            continue
        bad = np.flatnonzero(np.abs(np.nan_to_num(np.asarray(values, dtype=float))) > MAX_TABLE_TRANSLATION_M)
        if len(bad):
            raise DatasetError(
                f"{path}: row {bad[0] + 2} column {column}: {values[bad[0]]:g} m is absurd for a translation (over "
                f"{MAX_TABLE_TRANSLATION_M:g} m); the table holds metres"
            )


def _require_file(path: Path, missing: str, must_be: str) -> None:
    """Refuse ``path`` unless it is a regular file: ``missing`` when nothing is there, ``must_be`` when it is a
    directory, FIFO or device (named by :func:`handeye.core.textfile.file_kind`).

    Raises
    ------
    DatasetError
    """
    if path.is_file():
        return
    if path.exists():
        raise DatasetError(f"{path}: {file_kind(path)}, not a file; {must_be}")
    raise DatasetError(f"{path}: {missing}")


def read_table(path: str | Path, required: list[str]) -> dict:
    """Read a CSV table into columns, checking that the required ones are there and typed.

    Parameters
    ----------
    path : str or Path
    required : list of str

    Returns
    -------
    dict
        Column name to array (float, int or str); extra columns are kept.

    Raises
    ------
    DatasetError
        Missing file, missing column, a value that does not parse, a ragged row.
    """
    path = Path(path)
    _require_file(path, "table missing", "the table must be a regular CSV file")
    rows = _csv_rows(path)
    if not rows:
        raise DatasetError(f"{path}: empty table (no header)")
    header, body = rows[0], rows[1:]
    missing = [c for c in required if c not in header]
    if missing:
        raise DatasetError(
            f"{path}: missing column(s) {shorten(', '.join(missing), 80)} "
            f"(header: {shorten(','.join(header[:12]), 80)})"
        )
    columns = _parsed_columns(header, body, path)
    return {c: _column_array(c, values, c in required, path) for c, values in columns.items()}


def _csv_rows(path: Path) -> list[list[str]]:
    """The fields of every row of a CSV file (UTF-8, a byte-order mark dropped), checked as text."""
    try:
        text = path.read_bytes().decode("utf-8-sig")  # a byte-order mark (spreadsheets write one) dropped
        check_csv_text(enumerate(text.split("\n"), start=1), str(path), DatasetError)
        return list(csv.reader(io.StringIO(text, newline="")))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:  # csv.Error: a field over the size limit
        raise DatasetError(f"{path}: cannot read the table ({shorten(str(exc), 120)})") from None


def _parsed_columns(header: list[str], body: list[list[str]], path: Path) -> dict[str, list]:
    """Each column's cells parsed (:func:`_parse`), refusing a row of another length than the header."""
    columns = {c: [] for c in header}
    for r, values in enumerate(body, start=2):
        if len(values) != len(header):
            raise DatasetError(f"{path}: row {r} has {len(values)} values for {len(header)} columns")
        for c, v in zip(header, values):
            columns[c].append(_parse(v, c, path, r))
    return columns


def _column_array(column: str, values: list, required: bool, path: Path) -> np.ndarray:
    """One column's array: text, int (an empty cell -1, refused in a required column) or float."""
    if column in _STR_COLUMNS:
        return np.array(values, dtype=object)
    if column not in _INT_COLUMNS:
        return np.array(values, dtype=float)
    if any(v is None for v in values):
        if required:
            raise DatasetError(f"{path}: column {column} has an empty cell")
        return np.array([-1 if v is None else v for v in values], dtype=int)
    return np.array(values, dtype=int)


def _format(value) -> str:
    if isinstance(value, (float, np.floating)):
        return "" if not np.isfinite(value) else repr(float(value))
    if isinstance(value, (np.integer,)):
        return str(int(value))
    return "" if value is None else str(value)


def write_table(path: str | Path, table: dict, columns: list[str] | None = None) -> None:
    """Write columns as CSV atomically (:func:`handeye.core.safe_write.write_text_atomic`)."""
    path = Path(path)
    columns = list(table) if columns is None else columns
    n = len(next(iter(table.values()))) if table else 0
    buffer = io.StringIO(newline="")
    writer = csv.writer(buffer)
    writer.writerow(columns)
    for i in range(n):
        writer.writerow([_format(table[c][i]) if c in table else "" for c in columns])
    write_text_atomic(path, buffer.getvalue())


def write_json_atomic(path: str | Path, doc: dict) -> None:
    """Write JSON atomically (:func:`handeye.core.safe_write.write_text_atomic`)."""
    path = Path(path)
    write_text_atomic(path, json.dumps(doc, indent=2) + "\n")


# ------------------------------------------------------------------ images


def encode_depth(depth_m: np.ndarray, scale_m: float) -> np.ndarray:
    """Depth in metres to 16-bit units of ``scale_m`` (0 where no depth or beyond range).

    Parameters
    ----------
    depth_m : array, shape (H, W)
    scale_m : float
        Metres per unit.

    Returns
    -------
    array of uint16, shape (H, W)
    """
    units = np.rint(np.asarray(depth_m, dtype=np.float64) / scale_m)
    units[~np.isfinite(units) | (units > np.iinfo(np.uint16).max) | (units < 0)] = 0
    return units.astype(np.uint16)


def decode_depth(units: np.ndarray, scale_m: float) -> np.ndarray:
    """Inverse of :func:`encode_depth`: float32 metres, 0 where no depth."""
    return np.asarray(units, dtype=np.float32) * np.float32(scale_m)


def _read_png(path: Path) -> np.ndarray:
    from PIL import Image, UnidentifiedImageError

    _require_file(path, "image missing", "an image must be a regular PNG file")
    try:
        data = path.read_bytes()
        check_image_bytes(data, str(path), DatasetError)
        with Image.open(io.BytesIO(data)) as im:
            return np.array(im)
    except (OSError, UnidentifiedImageError, Image.DecompressionBombError) as exc:
        raise DatasetError(f"{path}: cannot read the image ({exc})") from None


# ------------------------------------------------------------------ manifests


#: How long ``handeye label`` and ``handeye markerless --write-labels`` wait for another writer of the dataset
#: before they refuse: their update of ``cameras.csv`` takes seconds, so a longer wait means a stuck writer.
LABEL_LOCK_WAIT_S = 120.0


@contextlib.contextmanager
def dataset_lock(root: str | Path, what: str, wait_s: float = 0.0):
    """Hold the dataset directory's write lock (``root/.lock``) for the duration, or refuse.

    Two writers on one dataset (two ``handeye sim generate`` runs on one ``--out``, a labelling during a
    generation, ``handeye label`` and ``handeye markerless --write-labels`` updating ``cameras.csv``) would
    interleave shards and tables or lose each other's columns; the second waits or is refused instead. A
    writer that updates a file reads it inside the block, so its read, change and write are one step. The
    lock is an advisory ``flock``: released by the system when the process ends, however it ends.

    Parameters
    ----------
    root : str or Path
        The dataset directory.
    what : str
        Who holds the lock, for the message another writer gets.
    wait_s : float
        0 (default): refuse at once when another process holds the lock (``sim generate``, imports).
        Otherwise wait up to this many seconds, saying once on stderr whom it waits for.

    Raises
    ------
    DatasetError
        When another process holds the lock (after ``wait_s``), or the lock file cannot be opened
        (a read-only folder, no such directory).
    """
    import fcntl
    import sys
    import time

    path = Path(root) / ".lock"
    try:
        f = path.open("a+")
    except OSError as exc:
        raise DatasetError(
            f"{root}: cannot open the dataset's lock file {path} ({exc.strerror or exc}); a writable dataset "
            "folder is needed"
        ) from None
    with f:
        deadline = time.monotonic() + max(0.0, float(wait_s))
        told = False
        while True:
            try:
                fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                f.seek(0)
                holder = f.read().strip() or "another process"
                if time.monotonic() >= deadline:
                    still = f" still, after {wait_s:g} s" if wait_s > 0 else ""
                    raise DatasetError(
                        f"{root}: {holder} is writing this dataset{still}; wait for it to finish, or use another "
                        f"directory (lock {path})"
                    ) from None
                if not told:
                    print(f"{what}: waiting for {holder} (lock {path})...", file=sys.stderr, flush=True)
                    told = True
                time.sleep(0.05)
            except OSError as exc:
                raise DatasetError(f"{root}: cannot lock {path} ({exc.strerror or exc})") from None
        try:
            f.seek(0)
            f.truncate()
            f.write(f"{what} (pid {os.getpid()})")
            f.flush()
        except OSError:
            pass  # the holder's name is for messages only; the lock itself is held
        try:
            yield
        finally:
            try:
                f.seek(0)
                f.truncate()
            except OSError:
                pass
            fcntl.flock(f, fcntl.LOCK_UN)


def write_manifest(shard_dir: Path, camera_id: int, n_frames: dict) -> None:
    """List every file of a shard with its size, last, so a complete shard can be recognised."""
    files = {}
    for p in sorted(shard_dir.rglob("*")):
        if p.is_file() and p.name != "manifest.json":
            files[p.relative_to(shard_dir).as_posix()] = p.stat().st_size
    write_json_atomic(
        shard_dir / "manifest.json",
        {"format": FORMAT, "version": FORMAT_VERSION, "camera_id": int(camera_id), "frames": n_frames, "files": files},
    )


def shard_is_complete(shard_dir: Path) -> tuple[bool, str]:
    """Whether a shard is complete, and if not why (for messages and for resuming)."""
    manifest = shard_dir / "manifest.json"
    doc, why = _read_manifest(shard_dir, manifest)
    why = why or _manifest_problem(doc, manifest) or _listed_files_problem(shard_dir, manifest, doc["files"])
    return not why, why


def _read_manifest(shard_dir: Path, manifest: Path) -> tuple[object, str]:
    """A shard's parsed manifest and ``""``, or ``None`` and why it cannot be read."""
    if not shard_dir.is_dir():
        return None, f"{shard_dir}: shard missing"
    if not manifest.is_file():
        return None, f"{manifest}: missing (shard half-written)"
    try:
        return json.loads(manifest.read_text(encoding="utf-8")), ""
    except (ValueError, OSError, RecursionError) as exc:  # ValueError: JSON, UTF-8, an integer of 5,000 digits
        return None, f"{manifest}: unreadable ({' '.join(str(exc).split())[:120]})"


def _is_count(n) -> bool:
    """Whether ``n`` is an int (not a bool) of at least 0."""
    return isinstance(n, int) and not isinstance(n, bool) and n >= 0


def _manifest_problem(doc, manifest: Path) -> str:
    """Why a parsed manifest is not an object with ``files`` and ``frames`` (``""`` when it is)."""
    files = doc.get("files") if isinstance(doc, dict) else None
    if not isinstance(files, dict):
        what = "no 'files'" if not isinstance(doc, dict) or "files" not in doc else f"'files' a {type(files).__name__}"
        return f"{manifest}: not a shard manifest ({what}; an object with files: {{path: bytes}} is needed)"
    frames = doc.get("frames", {})
    if not isinstance(frames, dict) or not all(_is_count(n) for n in frames.values()):
        return f"{manifest}: 'frames' is {str(frames)[:40]!r}, not an object of frame counts (damaged manifest)"
    return ""


def _listed_files_problem(shard_dir: Path, manifest: Path, files: dict) -> str:
    """Why the first of the manifest's ``{path: bytes}`` entries does not match its file (``""``: all do)."""
    problems = (_listed_file_problem(shard_dir, manifest, rel, size) for rel, size in files.items())
    return next(filter(None, problems), "")


def _listed_file_problem(shard_dir: Path, manifest: Path, rel: str, size) -> str:
    """Why one manifest entry is not a file inside the shard of that size (``""`` when it is)."""
    if not _is_count(size):
        return f"{manifest}: the size of {rel[:80]!r} is {str(size)[:40]!r}, not a number of bytes"
    if Path(rel).is_absolute() or ".." in Path(rel).parts or not rel:
        return f"{manifest}: lists {rel[:80]!r}, not a path inside the shard"
    p = shard_dir / rel
    if not p.is_file():
        what = "listed in the manifest but missing" if not p.exists() else f"{file_kind(p)}, not a file"
        return f"{p}: {what}"
    if p.stat().st_size != size:
        return f"{p}: {p.stat().st_size} bytes, the manifest says {size} (truncated or rewritten)"
    return ""


# ------------------------------------------------------------------ the dataset


#: A focal length (pixels) outside [width / 100, 1000 width] is no camera's: fields of view of 177.7 to 0.06
#: degrees (``2 atan(width / 2 f)``); a fisheye of 170 degrees has f near width / 23.
FOCAL_RANGE_WIDTHS = (0.01, 1000.0)


def _check_camera_matrix(K, width: int, where: str) -> None:
    """A camera matrix ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]`` of numbers, each focal length plausible.

    Raises
    ------
    DatasetError
        Naming ``where``: not a 3x3 matrix of finite numbers (a NaN is named as such), a focal length outside
        :data:`FOCAL_RANGE_WIDTHS` times the width.
    """
    if K is None:
        raise DatasetError(f"{where}: missing; the camera matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] is needed")
    K = float_array(K, where, DatasetError)  # a NaN or Infinity is named here, not downstream
    if K.shape != (3, 3):
        raise DatasetError(f"{where}: shape {K.shape}, a camera matrix is 3x3")
    low, high = FOCAL_RANGE_WIDTHS[0] * width, FOCAL_RANGE_WIDTHS[1] * width
    for name, f in (("fx", K[0, 0]), ("fy", K[1, 1])):
        if not low <= f <= high:
            raise DatasetError(
                f"{where}: {name} = {f:.6g} px is no camera's for a width of {width} px (expected "
                f"{low:g} to {high:g} px, a field of view of 177.7 to 0.06 degrees)"
            )


def _check_declared_sizes(meta: dict, path: Path) -> None:
    """The sizes ``meta.json`` declares, within the limits and of the right types (before anything is sized
    from them); the camera count is checked against ``cameras.csv`` when the table is read."""

    def integer(value, name: str, low: int, high: int) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise DatasetError(f"{path}: {name} is {shorten(value)}; an integer from {low} to {high:,} is expected")
        return value

    integer(meta["cameras"], "cameras", 1, MAX_DATASET_CAMERAS)
    integer(meta["n_joints"], "n_joints", 1, MAX_JOINTS)
    for key in ("intrinsics", "calibration_intrinsics"):
        intr = meta.get(key)
        if intr is None:
            continue
        if not isinstance(intr, dict):
            raise DatasetError(f"{path}: {key} is {shorten(intr)}, not an object")
        w = integer(intr.get("width"), f"{key}.width", 1, 1 << 20)
        h = integer(intr.get("height"), f"{key}.height", 1, 1 << 20)
        check_image_size(w, h, f"{path}: {key}", DatasetError)
        _check_camera_matrix(intr.get("K"), w, f"{path}: {key}.K")
        if intr.get("dist") is not None:
            float_array(intr["dist"], f"{path}: {key}.dist", DatasetError)  # numbers, finite
    if meta.get("T_ee_ref") is not None:
        where = f"{path}: T_ee_ref"
        checked_pose_matrix(float_array(meta["T_ee_ref"], where, DatasetError), where, DatasetError)
    depth = meta["depth"]
    scale = depth.get("scale_m") if isinstance(depth, dict) else None
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not 0 < scale < 1:
        raise DatasetError(f"{path}: depth.scale_m is {shorten(scale)}; metres per unit between 0 and 1")


@dataclass
class Dataset:
    """A dataset directory, read lazily and validated.

    Open with :meth:`open`. Tables are read on first use; images on request.

    Attributes
    ----------
    root : Path
    meta : dict
    """

    root: Path
    meta: dict
    _cameras: dict | None = field(default=None, repr=False)
    _frames: dict = field(default_factory=dict, repr=False)

    @classmethod
    def open(cls, root: str | Path) -> "Dataset":
        """Open and validate ``meta.json`` (tables and images are checked when read).

        Raises
        ------
        DatasetError
            No such directory, missing or invalid ``meta.json``, another format version.
        """
        root = Path(root)
        if not root.is_dir():
            raise DatasetError(f"{root}: no such dataset directory")
        path = root / "meta.json"
        _require_file(
            path,
            "missing; not a handeye dataset (generate one with 'handeye sim generate')",
            "meta.json must be a regular JSON file",
        )
        meta = read_json_file(path, DatasetError, "dataset meta file")
        if not isinstance(meta, dict) or meta.get("format") != FORMAT:
            found = meta.get("format") if isinstance(meta, dict) else None
            raise DatasetError(f"{path}: not a {FORMAT} meta file (format {found!r})")
        if meta.get("version") != FORMAT_VERSION:
            raise DatasetError(
                f"{path}: format version {meta.get('version')!r}; this handeye reads version {FORMAT_VERSION}"
            )
        for key in ("robot", "intrinsics", "depth", "n_joints", "cameras"):
            if key not in meta:
                raise DatasetError(f"{path}: key {key!r} missing")
        _check_declared_sizes(meta, path)
        return cls(root, meta)

    # -- tables

    @property
    def cameras_path(self) -> Path:
        return self.root / "cameras.csv"

    def cameras(self) -> dict:
        """The camera table (columns to arrays), validated: ids 0..N-1, splits, unit quaternions."""
        if self._cameras is None:
            table = read_table(self.cameras_path, CAMERA_COLUMNS)
            n = len(table["camera_id"])
            if n != self.meta["cameras"]:
                raise DatasetError(f"{self.cameras_path}: {n} rows, meta.json says {self.meta['cameras']} cameras")
            if not np.array_equal(table["camera_id"], np.arange(n)):
                raise DatasetError(f"{self.cameras_path}: camera_id must run 0..{n - 1} in order")
            bad = [s for s in table["split"] if s not in SPLITS]
            if bad:
                raise DatasetError(f"{self.cameras_path}: split {bad[0]!r} is not one of {SPLITS}")
            _check_translations(table, self.cameras_path)
            columns_to_poses(table, "T_base_cam_true", str(self.cameras_path))
            for group in ("T_base_cam_label", "T_base_cam_markerless"):
                if f"{group}.x" in table:
                    columns_to_poses(table, group, str(self.cameras_path))
            self._cameras = table
        return self._cameras

    def __len__(self) -> int:
        return int(self.meta["cameras"])

    def shard_dir(self, camera_id: int) -> Path:
        return self.root / shard_name(camera_id)

    def frames(self, camera_id: int) -> dict:
        """The frame table of one camera pose (both recordings), validated.

        Raises
        ------
        DatasetError
            Incomplete shard (pointing to the command that resumes it), bad table.
        """
        camera_id = int(camera_id)
        if not 0 <= camera_id < len(self):
            raise DatasetError(f"{self.root}: no camera {camera_id} (the dataset has 0..{len(self) - 1})")
        if camera_id not in self._frames:
            shard = self.shard_dir(camera_id)
            ok, why = shard_is_complete(shard)
            if not ok:
                raise DatasetError(f"{why}; run the generator again on {self.root} to resume")
            path = shard / "frames.csv"
            table = read_table(path, frame_columns(self.meta["n_joints"]))
            if np.any(table["camera_id"] != camera_id):
                raise DatasetError(f"{path}: rows of another camera in camera {camera_id}'s shard")
            bad = [r for r in table["recording"] if r not in RECORDINGS]
            if bad:
                raise DatasetError(f"{path}: recording {bad[0]!r} is not one of {RECORDINGS}")
            _check_translations(table, path)
            for name in ("T_base_ee", "T_base_ref"):
                columns_to_poses(table, name, str(path))
            for r, cells in enumerate(zip(table["rgb"], table["depth"]), start=2):
                for column, rel in zip(("rgb", "depth"), cells):
                    if rel and (Path(rel).is_absolute() or ".." in Path(rel).parts):
                        raise DatasetError(
                            f"{path}: row {r} column {column}: image path {rel!r} leaves the shard {shard}"
                        )
            self._frames[camera_id] = table
        return self._frames[camera_id]

    def select(self, camera_id: int, recording: str) -> dict:
        """Rows of one recording of one camera pose."""
        t = self.frames(camera_id)
        keep = t["recording"] == recording
        return {c: v[keep] for c, v in t.items()}

    def poses(self, table: dict, name: str) -> np.ndarray:
        """Poses ``name`` of a (selected) frame table, shape (N, 4, 4)."""
        return columns_to_poses(table, name, str(self.root))

    def joints(self, table: dict) -> np.ndarray:
        """Joint angles of a frame table, radians, shape (N, n_joints)."""
        return np.column_stack([table[f"q{j}"] for j in range(self.meta["n_joints"])])

    def truth(self) -> np.ndarray:
        """``T_base_cam`` truth per camera pose, shape (N, 4, 4) (NaN where unknown)."""
        return columns_to_poses(self.cameras(), "T_base_cam_true", str(self.cameras_path))

    def labels(self) -> np.ndarray:
        """Classic labels ``T_base_cam`` per camera pose, shape (N, 4, 4) (NaN where labelling failed).

        Raises
        ------
        DatasetError
            When the dataset has not been labelled.
        """
        cams = self.cameras()
        if "T_base_cam_label.x" not in cams:
            raise DatasetError(f"{self.cameras_path}: no labels; run 'handeye label {self.root}' first")
        return columns_to_poses(cams, "T_base_cam_label", str(self.cameras_path))

    def markerless_labels(self) -> np.ndarray:
        """Markerless labels ``T_base_cam`` per camera pose, shape (N, 4, 4) (NaN where refused).

        Raises
        ------
        DatasetError
            When ``handeye markerless --write-labels`` has not been run on the dataset.
        """
        cams = self.cameras()
        if "T_base_cam_markerless.x" not in cams:
            raise DatasetError(
                f"{self.cameras_path}: no markerless labels; run 'handeye markerless {self.root} --write-labels' first"
            )
        return columns_to_poses(cams, "T_base_cam_markerless", str(self.cameras_path))

    # -- images

    def image_path(self, camera_id: int, relpath: str) -> Path:
        """The file of an image cell, refused when it leaves the camera's shard (``../``, an absolute path).

        Raises
        ------
        DatasetError
            Naming the table and the path.
        """
        shard = self.shard_dir(camera_id)
        path = shard / relpath
        if Path(relpath).is_absolute() or not path.resolve().is_relative_to(shard.resolve()):
            raise DatasetError(f"{shard / 'frames.csv'}: image path {relpath!r} leaves the shard {shard}")
        return path

    def rgb(self, camera_id: int, relpath: str) -> np.ndarray:
        """Colour image of a frame (its ``rgb`` cell), uint8 (H, W, 3)."""
        img = _read_png(self.image_path(camera_id, relpath))
        if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
            raise DatasetError(
                f"{self.shard_dir(camera_id) / relpath}: expected 8-bit RGB, got {img.dtype} {img.shape}"
            )
        return img

    def depth_m(self, camera_id: int, relpath: str) -> np.ndarray:
        """Depth image of a frame (its ``depth`` cell) in metres, float32 (H, W), 0 = no depth."""
        units = _read_png(self.image_path(camera_id, relpath))
        if units.ndim != 2 or units.dtype not in (np.uint16, np.int32):
            raise DatasetError(
                f"{self.shard_dir(camera_id) / relpath}: expected a 16-bit depth PNG, got {units.dtype} {units.shape}"
            )
        return decode_depth(units, self.meta["depth"]["scale_m"])

    def validate(self, images: bool = False) -> None:
        """Check every table (and with ``images`` every image file exists); raise on the first problem."""
        self.cameras()
        for c in range(len(self)):
            t = self.frames(c)
            if images:
                for rel in list(t["rgb"]) + [d for d in t["depth"] if d]:
                    if not self.image_path(c, rel).is_file():
                        raise DatasetError(f"{self.shard_dir(c) / rel}: image missing")

    def complete_shards(self) -> list[int]:
        """Camera ids whose shard is complete."""
        return [c for c in range(len(self)) if shard_is_complete(self.shard_dir(c))[0]]
