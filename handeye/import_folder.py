"""A plain folder of RGB-D frames and joint angles to a :class:`~handeye.recording_import.RecordedPlacement`.

One folder per camera placement::

    placement/
      intrinsics.yaml     the colour camera (ROS camera_info or OpenCV YAML, or handeye's JSON):
                          the depth is registered to it
      joints.csv          frame,<joint name>,<joint name>,...   radians, one row per frame
      rgb/<frame>.png     colour (PNG or JPEG; 8-bit)
      depth/<frame>.png   16-bit depth, millimetres (or depth_unit_m per unit), 0 = no depth
        or <frame>.npy    float depth in metres or integer millimetres (or depth_unit_m per unit), NaN or 0 = none
      calibration/        optional: the board on the flange
        joints.csv
        rgb/<frame>.png

``frame`` names the images (their file name without the extension). Instead of joint columns,
``joints.csv`` may give the flange pose as ``T_base_ee.x, .y, .z, .qx, .qy, .qz, .qw`` (metres,
quaternion x, y, z, w), as pose files do; the joint angles are then unknown and only labelling
runs (the markerless registration needs them). Frames are matched by name, so no time tolerance applies.

What no camera or robot writes is refused, naming the file, the frame and the field
(:mod:`handeye.recording_checks`): a depth frame whose valid median is implausible in its unit (millimetres in
a float ``.npy``: the unit that fits is named), depth without one valid pixel in any frame, an ``.npy`` whose
header declares more pixels than an image may have (refused before it is read), a joint column named twice,
an intrinsics file whose ``K`` no camera has (``fx`` of 1e-300, the principal point outside the image). Joint
values are checked against the robot model's limits on import (:mod:`handeye.recording_import`).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from handeye.core.dataset import pose_columns
from handeye.core.errors import ImageSizeError, RecordingError
from handeye.core.limits import ABSURD_TRANSLATION_M, check_image_bytes, check_image_size
from handeye.core.numbers import CSV_CELL_SPACES, parse_float
from handeye.recording_checks import check_camera_matrix, check_depth_frame, check_depth_stream, check_joint_names
from handeye.recording_import import JointSamples, PoseSamples, RecordedPlacement, TimedImages

__all__ = ["INTRINSICS_NAMES", "read_frame_folder"]

#: Intrinsics files looked for in a placement folder, in this order.
INTRINSICS_NAMES = ("intrinsics.yaml", "intrinsics.yml", "camera_info.yaml", "intrinsics.json")
_COLOR_SUFFIXES = (".png", ".jpg", ".jpeg")
_DEPTH_SUFFIXES = (".png", ".npy")


def _read_joints_csv(path: Path) -> tuple[list, list, np.ndarray]:
    """Frame names, value columns and the values (rows, columns) of a joints CSV."""
    if not path.is_file():
        raise RecordingError(f"{path}: no joints table (frame,<joint names...>)")
    try:
        with path.open(newline="", encoding="utf-8-sig") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise RecordingError(f"{path}: cannot read the table ({exc})") from None
    if not rows or not rows[0] or rows[0][0].strip() != "frame":
        raise RecordingError(f"{path}: the first column must be 'frame' (the image names)")
    header = [h.strip() for h in rows[0]]
    check_joint_names(header[1:], f"{path}, header")
    names, values = [], []
    for r, row in enumerate(rows[1:], start=2):
        if not row:
            continue
        if len(row) != len(header):
            raise RecordingError(f"{path}: row {r} has {len(row)} values for {len(header)} columns")
        frame = row[0].strip()
        numbers = [
            parse_float(cell.strip(CSV_CELL_SPACES), f"{path}: row {r} (frame {frame!r}), column {c!r}", RecordingError)
            for c, cell in zip(header[1:], row[1:])
        ]
        names.append(frame)
        values.append(numbers)
    if not names:
        raise RecordingError(f"{path}: no rows")
    if len(set(names)) != len(names):
        raise RecordingError(f"{path}: frame names repeat")
    return names, header[1:], np.array(values, dtype=float).reshape(len(names), len(header) - 1)


def _image_file(folder: Path, frame: str, suffixes: tuple, table: Path) -> Path:
    for suffix in suffixes:
        p = folder / f"{frame}{suffix}"
        if p.is_file():
            return p
    raise RecordingError(f"{table}: frame {frame!r} has no image {folder / frame}{{{','.join(suffixes)}}}")


def _read_color(path: Path) -> np.ndarray:
    from PIL import Image, UnidentifiedImageError

    try:
        data = path.read_bytes()
        check_image_bytes(data, str(path), RecordingError)
        with Image.open(io.BytesIO(data)) as im:
            if im.mode not in ("RGB", "RGBA", "L", "P"):
                raise RecordingError(f"{path}: colour of mode {im.mode}; an 8-bit colour or grey image is needed")
            return np.array(im.convert("RGB"))
    except (OSError, UnidentifiedImageError, Image.DecompressionBombError) as exc:
        raise RecordingError(f"{path}: cannot read the image ({exc})") from None


def _npy_header(path: Path) -> None:
    """Refuse an ``.npy`` file whose header declares no depth image, or more than an image may hold, or more bytes
    than the file has: from its header, before anything is allocated."""
    try:
        with path.open("rb") as f:
            version = np.lib.format.read_magic(f)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(f)
            elif version == (2, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(f)
            else:
                raise ValueError(f"npy format version {version} is not read")
            offset = f.tell()
        size = path.stat().st_size
    except (OSError, ValueError, SyntaxError, TypeError) as exc:
        raise RecordingError(f"{path}: not a readable .npy array ({exc})") from None
    if len(shape) != 2:
        raise RecordingError(f"{path}: depth of shape {shape}, expected (H, W)")
    if dtype.hasobject or not (np.issubdtype(dtype, np.integer) or np.issubdtype(dtype, np.floating)):
        raise RecordingError(f"{path}: depth of dtype {dtype}; float metres or integer units")
    check_image_size(int(shape[1]), int(shape[0]), f"{path}: the .npy header", RecordingError)
    need = offset + int(shape[0]) * int(shape[1]) * dtype.itemsize
    if size < need:
        raise RecordingError(f"{path}: {size} bytes, its header declares {shape} {dtype} ({need} bytes): truncated")


def _read_depth(path: Path, depth_unit_m: float | None) -> np.ndarray:
    """Depth in metres (0 or NaN: none), its unit checked against the plausible range."""
    if path.suffix == ".npy":
        _npy_header(path)
        try:
            arr = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise RecordingError(f"{path}: cannot read the array ({exc})") from None
        unit = depth_unit_m if depth_unit_m is not None else (1e-3 if np.issubdtype(arr.dtype, np.integer) else 1.0)
        depth = arr.astype(np.float32) * np.float32(unit)
        depth = np.nan_to_num(depth, nan=0.0, posinf=0.0, neginf=0.0)
        check_depth_frame(depth, unit, str(path))
        return depth
    from PIL import Image, UnidentifiedImageError

    try:
        data = path.read_bytes()
        check_image_bytes(data, str(path), RecordingError)
        with Image.open(io.BytesIO(data)) as im:
            arr = np.array(im)
    except (OSError, UnidentifiedImageError, Image.DecompressionBombError) as exc:
        raise RecordingError(f"{path}: cannot read the image ({exc})") from None
    if arr.ndim != 2 or arr.dtype not in (np.uint16, np.int32):
        raise RecordingError(f"{path}: depth PNG of {arr.dtype} {arr.shape}; a 16-bit single-channel PNG is needed")
    unit = 1e-3 if depth_unit_m is None else depth_unit_m
    depth = arr.astype(np.float32) * np.float32(unit)
    check_depth_frame(depth, unit, str(path))
    return depth


def _robot_streams(table: Path, frames: list, columns: list, values: np.ndarray):
    times = np.arange(len(frames), dtype=float)
    pose_cols = pose_columns("T_base_ee")
    if all(c in columns for c in pose_cols):
        from handeye.core.se3 import transform_from_pos_quat_xyzw

        v = values[:, [columns.index(c) for c in pose_cols]]
        norms = np.linalg.norm(v[:, 3:], axis=1)
        if np.any(np.abs(norms - 1) > 1e-3):
            bad = int(np.flatnonzero(np.abs(norms - 1) > 1e-3)[0])
            raise RecordingError(f"{table}: frame {frames[bad]!r}: quaternion of norm {norms[bad]:.4g}, not 1")
        far = np.flatnonzero(np.abs(v[:, :3]).max(axis=1) > ABSURD_TRANSLATION_M)
        if len(far):
            raise RecordingError(
                f"{table}: frame {frames[far[0]]!r}: T_base_ee's position {v[far[0], :3].tolist()} is beyond "
                f"{ABSURD_TRANSLATION_M:g} m (metres are read)"
            )
        return None, PoseSamples(times, transform_from_pos_quat_xyzw(v[:, :3], v[:, 3:]), str(table))
    return JointSamples(times, list(columns), values, str(table), [f"frame {f!r}" for f in frames]), None


def _intrinsics(folder: Path, path: Path | None):
    from classic.vision.camera import CameraIntrinsics

    if path is None:
        path = next((folder / n for n in INTRINSICS_NAMES if (folder / n).is_file()), None)
        if path is None:
            raise RecordingError(f"{folder}: no intrinsics ({', '.join(INTRINSICS_NAMES)}); or pass --intrinsics")
    intr = CameraIntrinsics.load(path)
    check_camera_matrix(intr.K, intr.width, intr.height, str(path))
    return intr


def _read_part(folder: Path, intrinsics, depth: bool, depth_unit_m: float | None) -> RecordedPlacement:
    table = folder / "joints.csv"
    frames, columns, values = _read_joints_csv(table)
    joints, poses = _robot_streams(table, frames, columns, values)
    times = np.arange(len(frames), dtype=float)
    rgb_paths = [_image_file(folder / "rgb", f, _COLOR_SUFFIXES, table) for f in frames]
    color = TimedImages(times, [_read_color(p) for p in rgb_paths], str(folder / "rgb"), [p.name for p in rgb_paths])
    depth_images = None
    if depth:
        paths = [_image_file(folder / "depth", f, _DEPTH_SUFFIXES, table) for f in frames]
        depth_images = TimedImages(
            times, [_read_depth(p, depth_unit_m) for p in paths], str(folder / "depth"), [p.name for p in paths]
        )
        check_depth_stream(depth_images.images, str(folder / "depth"))
        for c, d, p in zip(color.images, depth_images.images, paths):
            if c.shape[:2] != d.shape:
                raise ImageSizeError(
                    f"{p}: depth is {d.shape[1]}x{d.shape[0]}, its colour image is {c.shape[1]}x{c.shape[0]}; the "
                    "depth must be registered to the colour camera"
                )
    return RecordedPlacement(str(folder), intrinsics, color, depth_images, joints, poses)


def read_frame_folder(
    folder, intrinsics_path: str | Path | None = None, depth_unit_m: float | None = None
) -> RecordedPlacement:
    """Read one camera placement's frames from a folder (layout in the module docstring).

    Parameters
    ----------
    folder : str or Path
    intrinsics_path : str or Path, optional
        The colour camera's intrinsics; None looks for :data:`INTRINSICS_NAMES` in the folder.
    depth_unit_m : float, optional
        Metres per unit of the depth files; None: millimetres for 16-bit PNG and integer ``.npy``, metres for
        float ``.npy``.

    Returns
    -------
    RecordedPlacement
        With its ``calibration`` when the folder has a ``calibration/`` folder.

    Raises
    ------
    RecordingError
        A missing table, image or intrinsics file, a row that does not parse, a joint column named twice, depth
        in another unit than ``depth_unit_m`` or without a valid pixel, an ``.npy`` header declaring more than an
        image (each named).
    IntrinsicsError
        An intrinsics file whose ``K`` or image size no camera has, naming the field.
    ImageSizeError
        A depth image of another size than its colour image.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise RecordingError(f"{folder}: no such folder")
    if depth_unit_m is not None and not (np.isfinite(depth_unit_m) and depth_unit_m > 0):
        raise RecordingError(f"depth_unit_m must be finite and > 0, got {depth_unit_m!r}")
    intr = _intrinsics(folder, None if intrinsics_path is None else Path(intrinsics_path))
    part = _read_part(folder, intr, True, depth_unit_m)
    if (folder / "calibration").is_dir():
        part.calibration = _read_part(folder / "calibration", intr, False, depth_unit_m)
    return part
