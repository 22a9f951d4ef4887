"""Plausibility checks of a recording's streams: depth units, joint values and names, camera intrinsics.

A recording in the wrong unit reads without an error: a 32FC1 depth image holding millimetres is 812 "metres"
(beyond the dataset's 6.55 m, so stored as no depth), a joint file in degrees is a robot in another pose, a
``camera_info`` with ``fx = 1e-300`` projects everything onto the principal point. Each is refused here, in one
line naming the file or topic, the frame and the field, with what to do:

* depth: the median of a frame's valid pixels (finite, > 0) must lie within :data:`DEPTH_MEDIAN_RANGE_M`; outside
  it, the unit that brings the median inside is named (``--depth-unit 0.001`` for millimetres). A recording
  whose every frame has no valid depth is refused too;
* joints: a joint name listed twice (in a ``JointState`` message or a table's header); a value that is not
  finite; a value beyond the robot model's joint limits (widened by :data:`JOINT_LIMIT_MARGIN`) or beyond
  :data:`MAX_ABS_JOINT` where the model sets none, said to look like degrees when the values read as degrees
  fit the limits;
* intrinsics: ``K`` finite, of the form ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``, the image size positive,
  ``fx`` and ``fy`` positive, the principal point inside the image (the field of view within
  :data:`handeye.core.limits.FOV_RANGE_DEG` is :class:`classic.vision.camera.CameraIntrinsics`'s check).
"""

from __future__ import annotations

import numpy as np

from handeye.core.errors import IntrinsicsError, RecordingError
from handeye.core.limits import check_image_size

__all__ = [
    "DEPTH_MEDIAN_RANGE_M",
    "DEPTH_UNITS",
    "JOINT_LIMIT_MARGIN",
    "MAX_ABS_JOINT",
    "depth_problem",
    "check_depth_frame",
    "check_depth_stream",
    "check_joint_names",
    "check_joint_values",
    "check_camera_matrix",
]

#: The median of a frame's valid depth, metres, must lie within this range: RGB-D sensors see from about 0.07 m
#: (RealSense D405) to about 10 m (the far end of time-of-flight and stereo units), and a hand-eye cell is within
#: reach of the arm. A unit off by a factor of 1,000 (millimetres read as metres: 812 m; metres read as
#: millimetres: 0.001 m) lands far outside it.
DEPTH_MEDIAN_RANGE_M = (0.05, 20.0)
#: Units a depth stream is recorded in (metres per unit), tried in this order to name the one that fits.
DEPTH_UNITS = {1e-3: "millimetres", 1.0: "metres", 1e-4: "tenths of a millimetre", 1e-2: "centimetres"}
#: Radians (metres for prismatic joints) a sample may lie beyond the robot model's joint limits: encoders and
#: drivers report a joint at its stop a few thousandths beyond it; a unit mistake is beyond by far more.
JOINT_LIMIT_MARGIN = 0.02
#: Where the model sets no finite limit (a continuous joint), a joint angle beyond two turns either way is
#: refused: no arm winds its cables further, and 1e300 or a value in degrees is no angle.
MAX_ABS_JOINT = 4 * np.pi


def depth_problem(depth_m: np.ndarray, unit_m: float) -> str | None:
    """Why a depth frame is implausible, with the unit that fits (None when it is plausible or empty).

    Parameters
    ----------
    depth_m : array, shape (H, W)
        Depth in metres as read (``raw * unit_m``), 0 or NaN for no depth.
    unit_m : float
        The metres per unit it was read with.

    Returns
    -------
    str or None
        E.g. ``"depth looks like millimetres (median 812 read as 812 m, outside 0.05-20 m); pass --depth-unit
        0.001 (metres per unit)"``.
    """
    d = np.asarray(depth_m)
    valid = d[np.isfinite(d) & (d > 0)]
    if not valid.size:
        return None
    median = float(np.median(valid))
    lo, hi = DEPTH_MEDIAN_RANGE_M
    if lo <= median <= hi:
        return None
    raw = median / unit_m
    fits = [u for u in DEPTH_UNITS if u != unit_m and lo <= raw * u <= hi]
    where = f"median {raw:.4g} read as {median:.4g} m, outside the plausible {lo:g}-{hi:g} m"
    if not fits:
        return f"depth of implausible range ({where}, and no unit of {', '.join(DEPTH_UNITS.values())} fits)"
    u = fits[0]
    return f"depth looks like {DEPTH_UNITS[u]} ({where}); pass --depth-unit {u:g} (metres per unit)"


def check_depth_frame(depth_m: np.ndarray, unit_m: float, where: str) -> None:
    """Refuse a depth frame whose valid median is outside :data:`DEPTH_MEDIAN_RANGE_M` (see :func:`depth_problem`).

    Parameters
    ----------
    depth_m : array, shape (H, W)
        Metres as read.
    unit_m : float
        The metres per unit it was read with.
    where : str
        The file, or the bag, topic and stamp.

    Raises
    ------
    RecordingError
    """
    problem = depth_problem(depth_m, unit_m)
    if problem is not None:
        raise RecordingError(f"{where}: {problem}")


def check_depth_stream(images: list, source: str) -> None:
    """Refuse a depth stream none of whose frames has a valid pixel (all zero, NaN or negative).

    Parameters
    ----------
    images : list of array, each shape (H, W)
        Metres.
    source : str

    Raises
    ------
    RecordingError
    """
    for d in images:
        d = np.asarray(d)
        if np.any(np.isfinite(d) & (d > 0)):
            return
    raise RecordingError(
        f"{source}: none of the {len(images)} depth frames has a valid pixel (all zero, NaN or negative): the "
        "depth topic or folder holds no depth"
    )


def check_joint_names(names: list, where: str) -> None:
    """Refuse a joint name listed twice (a reader would take one of the two values silently).

    Parameters
    ----------
    names : list of str
    where : str
        The message (topic and stamp) or the table.

    Raises
    ------
    RecordingError
    """
    seen = set()
    for n in names:
        if n in seen:
            raise RecordingError(f"{where}: joint {n!r} is listed twice; which value is the joint's cannot be told")
        seen.add(n)


def check_joint_values(
    source: str,
    names: list,
    q: np.ndarray,
    sample_names: list,
    model_names: list,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
) -> None:
    """Refuse a non-finite joint value, or one beyond the model's limits (said to look like degrees where it does).

    Only the joints the robot model has are checked (a gripper's are not used).

    Parameters
    ----------
    source : str
        The topic or file.
    names : list of str
        The recorded joints, one per column of ``q``.
    q : array, shape (M, J)
        Radians (metres for prismatic joints).
    sample_names : list of str
        Each sample's name for messages (a stamp, a frame name).
    model_names : list of str
        The robot model's joints.
    lower, upper : array, shape (len(model_names),), optional
        The model's joint limits (``pinocchio``'s ``lowerPositionLimit``); an infinite, absent or wider than
        :data:`MAX_ABS_JOINT` limit is :data:`MAX_ABS_JOINT`.

    Raises
    ------
    RecordingError
    """
    q = np.asarray(q, dtype=float).reshape(len(sample_names), len(names))
    n = len(model_names)
    lower = np.full(n, -np.inf) if lower is None else np.asarray(lower, dtype=float)
    upper = np.full(n, np.inf) if upper is None else np.asarray(upper, dtype=float)
    lower = np.where(np.isfinite(lower), np.maximum(lower, -MAX_ABS_JOINT), -MAX_ABS_JOINT)
    upper = np.where(np.isfinite(upper), np.minimum(upper, MAX_ABS_JOINT), MAX_ABS_JOINT)
    for j, name in enumerate(model_names):
        if name not in names:
            continue  # named by the caller (the model's joints the recording does not have)
        v = q[:, names.index(name)]
        bad = np.flatnonzero(~np.isfinite(v))
        if len(bad):
            raise RecordingError(
                f"{source}, {sample_names[bad[0]]}: joint {name!r} is {v[bad[0]]} ({len(bad)} such samples); a "
                "joint angle must be a finite number"
            )
        lo, hi = lower[j] - JOINT_LIMIT_MARGIN, upper[j] + JOINT_LIMIT_MARGIN
        out = np.flatnonzero((v < lo) | (v > hi))
        if not len(out):
            continue
        i = out[0]
        rad = np.deg2rad(v)
        if np.all((rad >= lo) & (rad <= hi)) and np.max(np.abs(v)) > 2 * np.pi:
            raise RecordingError(
                f"{source}, {sample_names[i]}: joint {name!r} is {v[i]:.6g}, beyond its limits "
                f"[{lower[j]:.4g}, {upper[j]:.4g}] rad: the joints look like degrees ({len(out)} of {len(v)} samples "
                "beyond); record radians"
            )
        raise RecordingError(
            f"{source}, {sample_names[i]}: joint {name!r} is {v[i]:.6g}, beyond its limits [{lower[j]:.4g}, "
            f"{upper[j]:.4g}] rad ({len(out)} of {len(v)} samples beyond): another robot model, or not radians"
        )


def check_camera_matrix(K, width, height, where: str) -> None:
    """Refuse a camera matrix or image size that no camera has, naming the field.

    Parameters
    ----------
    K : array_like, shape (3, 3)
        ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``, pixels.
    width, height : int
        The image's size, pixels.
    where : str
        The file or topic.

    Raises
    ------
    IntrinsicsError
    """
    try:
        K = np.asarray(K, dtype=float)
    except (TypeError, ValueError):
        raise IntrinsicsError(f"{where}: K is not a 3x3 matrix of numbers") from None
    if K.size != 9:
        raise IntrinsicsError(f"{where}: K holds {K.size} numbers, a 3x3 matrix needs 9")
    K = K.reshape(3, 3)
    names = {(0, 0): "fx", (0, 1): "skew", (0, 2): "cx", (1, 1): "fy", (1, 2): "cy", (2, 2): "K[2][2]"}
    for (r, c), name in names.items():
        if not np.isfinite(K[r, c]):
            raise IntrinsicsError(f"{where}: {name} (K[{r}][{c}]) is {K[r, c]}; a finite number is needed")
    if not np.any(K):
        raise IntrinsicsError(f"{where}: K is all zero: the camera is not calibrated (calibrate its intrinsics)")
    for r, c in ((1, 0), (2, 0), (2, 1)):
        if K[r, c] != 0:
            raise IntrinsicsError(
                f"{where}: K[{r}][{c}] is {K[r, c]:g}; a camera matrix is [[fx, s, cx], [0, fy, cy], [0, 0, 1]] "
                "(transposed, or not a camera matrix)"
            )
    if K[2, 2] != 1:
        raise IntrinsicsError(f"{where}: K[2][2] is {K[2, 2]:g}, not 1 (a scaled or projective matrix)")
    try:
        w, h = int(width), int(height)
    except (TypeError, ValueError, OverflowError):
        raise IntrinsicsError(f"{where}: the image size {width!r}x{height!r} is not two integers") from None
    if w <= 0 or h <= 0:
        raise IntrinsicsError(f"{where}: width {w} and height {h}: the image size must be positive")
    check_image_size(w, h, where, IntrinsicsError)
    for name, f in (("fx", K[0, 0]), ("fy", K[1, 1])):
        if not f > 0:
            raise IntrinsicsError(f"{where}: {name} is {f:g}; a focal length must be > 0 pixels")
    for name, c, side in (("cx", K[0, 2], w), ("cy", K[1, 2], h)):
        if not 0 <= c <= side:
            raise IntrinsicsError(
                f"{where}: {name} = {c:.6g} is outside the image (0 to {side} pixels): the principal point of "
                "another resolution, or not pixels"
            )
