"""A plain folder of RGB-D frames and joint angles to a :class:`~handeye.recording_import.RecordedPlacement`.

One folder per camera placement::

    placement/
      intrinsics.yaml     the colour camera (ROS camera_info or OpenCV YAML, or handeye's JSON):
                          the depth is registered to it
      joints.csv          frame,<joint name>,<joint name>,...   radians, one row per frame
      rgb/<frame>.png     colour (PNG or JPEG; 8-bit)
      depth/<frame>.png   16-bit depth, depth_unit_m per unit (millimetres by default), 0 = no depth
        or <frame>.npy    float depth in metres (NaN or 0 = no depth), or integer units
      calibration/        optional: the board on the flange
        joints.csv
        rgb/<frame>.png

``frame`` names the images (their file name without the extension). Instead of joint columns,
``joints.csv`` may give the flange pose as ``T_base_ee.x, .y, .z, .qx, .qy, .qz, .qw`` (metres,
quaternion x, y, z, w), as pose files do; the joint angles are then unknown and only labelling
runs (the markerless registration needs them). Frames are matched by name, so no time tolerance applies.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from handeye.core.dataset import pose_columns
from handeye.core.errors import ImageSizeError, RecordingError
from handeye.core.limits import check_image_bytes
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
    names, values = [], []
    for r, row in enumerate(rows[1:], start=2):
        if not row:
            continue
        if len(row) != len(header):
            raise RecordingError(f"{path}: row {r} has {len(row)} values for {len(header)} columns")
        try:
            numbers = [float(v) for v in row[1:]]
        except ValueError:
            raise RecordingError(f"{path}: row {r}: a value is not a number") from None
        if not np.all(np.isfinite(numbers)):
            raise RecordingError(f"{path}: row {r}: a value is not finite")
        names.append(row[0].strip())
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


def _read_depth(path: Path, depth_unit_m: float) -> np.ndarray:
    if path.suffix == ".npy":
        try:
            arr = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise RecordingError(f"{path}: cannot read the array ({exc})") from None
        if arr.ndim != 2:
            raise RecordingError(f"{path}: depth of shape {arr.shape}, expected (H, W)")
        if np.issubdtype(arr.dtype, np.integer):
            return arr.astype(np.float32) * np.float32(depth_unit_m)
        if not np.issubdtype(arr.dtype, np.floating):
            raise RecordingError(f"{path}: depth of dtype {arr.dtype}; float metres or integer units")
        return np.nan_to_num(arr.astype(np.float32), nan=0.0, posinf=0.0, neginf=0.0)
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
    return arr.astype(np.float32) * np.float32(depth_unit_m)


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
        return None, PoseSamples(times, transform_from_pos_quat_xyzw(v[:, :3], v[:, 3:]), str(table))
    return JointSamples(times, list(columns), values, str(table)), None


def _intrinsics(folder: Path, path: Path | None):
    from classic.vision.camera import CameraIntrinsics

    if path is None:
        path = next((folder / n for n in INTRINSICS_NAMES if (folder / n).is_file()), None)
        if path is None:
            raise RecordingError(f"{folder}: no intrinsics ({', '.join(INTRINSICS_NAMES)}); or pass --intrinsics")
    return CameraIntrinsics.load(path)


def _read_part(folder: Path, intrinsics, depth: bool, depth_unit_m: float) -> RecordedPlacement:
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
        for c, d, p in zip(color.images, depth_images.images, paths):
            if c.shape[:2] != d.shape:
                raise ImageSizeError(
                    f"{p}: depth is {d.shape[1]}x{d.shape[0]}, its colour image is {c.shape[1]}x{c.shape[0]}; the "
                    "depth must be registered to the colour camera"
                )
    return RecordedPlacement(str(folder), intrinsics, color, depth_images, joints, poses)


def read_frame_folder(
    folder, intrinsics_path: str | Path | None = None, depth_unit_m: float = 1e-3
) -> RecordedPlacement:
    """Read one camera placement's frames from a folder (layout in the module docstring).

    Parameters
    ----------
    folder : str or Path
    intrinsics_path : str or Path, optional
        The colour camera's intrinsics; None looks for :data:`INTRINSICS_NAMES` in the folder.
    depth_unit_m : float
        Metres per unit of 16-bit PNG and integer NPY depth.

    Returns
    -------
    RecordedPlacement
        With its ``calibration`` when the folder has a ``calibration/`` folder.

    Raises
    ------
    RecordingError
        A missing table, image or intrinsics file, a row that does not parse (each named).
    ImageSizeError
        A depth image of another size than its colour image.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise RecordingError(f"{folder}: no such folder")
    if not (np.isfinite(depth_unit_m) and depth_unit_m > 0):
        raise RecordingError(f"depth_unit_m must be finite and > 0, got {depth_unit_m!r}")
    intr = _intrinsics(folder, None if intrinsics_path is None else Path(intrinsics_path))
    part = _read_part(folder, intr, True, depth_unit_m)
    if (folder / "calibration").is_dir():
        part.calibration = _read_part(folder / "calibration", intr, False, depth_unit_m)
    return part
