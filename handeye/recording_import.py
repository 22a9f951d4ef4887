"""A real recording to a dataset: streams paired by time, checked, undistorted and written shard by shard.

The readers (:mod:`handeye.import_bag` for ROS 2 bags, :mod:`handeye.import_folder` for plain folders)
give each camera placement as a :class:`RecordedPlacement`: the colour images, the depth images registered
to the colour camera, the joint states and/or the flange poses (from tf), each with its own time stamps,
and optionally the calibration recording (the board on the flange, colour only). This module

* pairs every depth image with the colour image nearest in time (within ``sync_tolerance_s``) and the
  robot's state at the depth image's stamp: joint angles interpolated linearly between the two samples
  around it, both within ``joint_tolerance_s`` (a gap in the joint stream is never bridged), the flange
  pose likewise (:func:`handeye.time_pairing.pair_by_time`) or from the joints by forward kinematics;
* names what it cannot use: joints that do not cover the robot model's (:class:`JointNamesError`),
  depth of another size than the camera (:class:`ImageSizeError`), streams further apart than the
  tolerance for more than half the frames (:class:`UnsynchronisedError`);
* removes the lens distortion of the data frames (colour bilinear, depth nearest-neighbour, so that no
  depth is invented between a foreground and a background pixel), because the markerless registration
  projects through a pinhole; the calibration frames stay as recorded, their distortion in
  ``meta["calibration_intrinsics"]`` for the board's PnP;
* writes the dataset (:mod:`handeye.core.dataset`) through :class:`handeye.core.shard_writer.ShardWriter`,
  one shard per placement, every placement in the ``test`` split of region 0, the truth columns empty.

Then ``handeye label`` (board) and ``handeye markerless`` (no board) run on it, and ``handeye compare``
sets the two side by side.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from handeye.core.dataset import (
    CAMERA_COLUMNS,
    FORMAT,
    FORMAT_VERSION,
    write_json_atomic,
    write_table,
)
from handeye.core.errors import (
    DatasetError,
    HandEyeInputError,
    ImageSizeError,
    JointNamesError,
    RecordingError,
    UnsynchronisedError,
)
from handeye.recording_checks import check_depth_frame, check_depth_stream, check_joint_values

__all__ = [
    "DEPTH_SCALE_M",
    "MAX_DROPPED_FRACTION",
    "TimedImages",
    "JointSamples",
    "PoseSamples",
    "RecordedPlacement",
    "ImportOptions",
    "ImportReport",
    "joints_at",
    "nearest_in_time",
    "check_image_size",
    "UNREGISTERED_DEPTH_HINT",
    "assemble",
    "import_recordings",
]

#: Metres per unit of the dataset's 16-bit depth PNGs: 0.1 mm, up to 6.55 m (the simulator's).
DEPTH_SCALE_M = 1e-4
#: The temporary folder an import writes beside its target and renames to it when complete (then host and pid).
_TMP_PREFIX = ".{name}.importing-"
#: What a depth image of another size than the colour camera_info's needs (:func:`check_image_size`).
UNREGISTERED_DEPTH_HINT = (
    ": record the depth registered to the colour camera (RealSense: align_depth.enable:=true; Azure Kinect: "
    "depth_mode with the point cloud in the colour camera) and give that camera's camera_info"
)
#: The furthest depth the dataset's 16-bit PNGs hold, metres (beyond it a pixel is stored as no depth).
MAX_DEPTH_M = DEPTH_SCALE_M * np.iinfo(np.uint16).max
#: More than this fraction of a recording's frames without a partner within the tolerance is refused as
#: unsynchronised streams (a few dropped frames are ordinary; most of them mean clocks or topics that disagree).
MAX_DROPPED_FRACTION = 0.5


@dataclass
class TimedImages:
    """Images of one stream with their stamps.

    Attributes
    ----------
    times_s : array, shape (N,)
        Stamps, seconds on the recording's clock.
    images : list of array
        Colour: uint8 (H, W, 3) RGB. Depth: float32 (H, W) metres, 0 = no depth.
    source : str
        Where they come from (bag and topic, or folder), for messages.
    names : list of str
        Each image's own name (a file name, or its stamp), for messages.
    """

    times_s: np.ndarray
    images: list
    source: str
    names: list = field(default_factory=list)

    def __post_init__(self):
        self.times_s = np.asarray(self.times_s, dtype=float).reshape(-1)
        if not self.names:
            self.names = [f"stamp {t:.6f} s" for t in self.times_s]


@dataclass
class JointSamples:
    """The robot's joint states over time.

    Attributes
    ----------
    times_s : array, shape (M,)
    names : list of str
        Joint names, one per column of ``q``.
    q : array, shape (M, J)
        Radians (metres for prismatic joints).
    source : str
    sample_names : list of str
        Each sample's name (a message's stamp, a table's frame), for messages.
    """

    times_s: np.ndarray
    names: list
    q: np.ndarray
    source: str
    sample_names: list = field(default_factory=list)

    def __post_init__(self):
        if not self.sample_names:
            self.sample_names = [f"sample at {t:.6f} s" for t in np.asarray(self.times_s, dtype=float).reshape(-1)]


@dataclass
class PoseSamples:
    """The flange's pose in the robot base over time (from tf).

    Attributes
    ----------
    times_s : array, shape (M,)
        Strictly increasing.
    T_base_ee : array, shape (M, 4, 4)
        Metres.
    source : str
    """

    times_s: np.ndarray
    T_base_ee: np.ndarray
    source: str


@dataclass
class RecordedPlacement:
    """One camera placement as recorded.

    Attributes
    ----------
    source : str
    intrinsics : classic.vision.camera.CameraIntrinsics
        The colour camera's, to which the depth is registered (its ``camera_info``).
    color : TimedImages
    depth : TimedImages or None
        None for a calibration recording.
    joints : JointSamples or None
    poses : PoseSamples or None
        ``T_base_ee`` from tf; None computes it from the joints.
    calibration : RecordedPlacement or None
        The board on the flange, seen by the same camera at the same placement.
    """

    source: str
    intrinsics: object
    color: TimedImages
    depth: TimedImages | None = None
    joints: JointSamples | None = None
    poses: PoseSamples | None = None
    calibration: "RecordedPlacement | None" = None


@dataclass
class ImportOptions:
    """How streams are paired and frames kept.

    Attributes
    ----------
    sync_tolerance_s : float
        Largest time between a depth image and the colour image paired with it.
    joint_tolerance_s : float
        Largest time between an image and each of the two robot samples interpolated for it.
    max_frames : int or None
        Keep at most this many data frames per placement, evenly spread over the recording (the markerless
        registration's time grows with the frames; 100 robot poses are plenty). None keeps all.
    """

    sync_tolerance_s: float = 0.02
    joint_tolerance_s: float = 0.02
    max_frames: int | None = 100

    def __post_init__(self):
        for name in ("sync_tolerance_s", "joint_tolerance_s"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise HandEyeInputError(f"{name} must be finite and >= 0 s, got {value!r}")
        if self.max_frames is not None and self.max_frames < 1:
            raise HandEyeInputError(f"max_frames must be >= 1 or None, got {self.max_frames!r}")


@dataclass
class ImportReport:
    """What :func:`import_recordings` wrote.

    Attributes
    ----------
    root : Path
    frames : list of dict
        Per placement: ``data`` and ``calibration`` frames written, ``dropped`` (no partner in time).
    wall_s : float
    """

    root: Path
    frames: list
    wall_s: float

    def summary(self) -> str:
        """One line per placement."""
        lines = []
        for c, f in enumerate(self.frames):
            lines.append(
                f"camera {c}: {f['data']} data frames, {f['calibration']} calibration frames"
                + (f", {f['dropped']} dropped (no partner within the tolerance)" if f["dropped"] else "")
                + f"  <- {f['source']}"
            )
        return "\n".join(lines)


# ------------------------------------------------------------------ pairing by time


def nearest_in_time(ref_s: np.ndarray, other_s: np.ndarray, tolerance_s: float) -> tuple[np.ndarray, np.ndarray]:
    """For each reference stamp, the nearest other stamp within the tolerance.

    Parameters
    ----------
    ref_s : array, shape (N,)
    other_s : array, shape (M,)
    tolerance_s : float

    Returns
    -------
    index : array of int, shape (N,)
        Into ``other_s`` (meaningless where not kept).
    keep : array of bool, shape (N,)
    """
    ref_s, other_s = np.asarray(ref_s, dtype=float), np.asarray(other_s, dtype=float)
    if not len(other_s):
        return np.zeros(len(ref_s), dtype=int), np.zeros(len(ref_s), dtype=bool)
    order = np.argsort(other_s, kind="stable")
    sorted_s = other_s[order]
    k = np.minimum(np.searchsorted(sorted_s, ref_s), len(sorted_s) - 1)  # the first stamp at or after
    lo = np.maximum(k - 1, 0)
    pick = np.where(np.abs(sorted_s[lo] - ref_s) <= np.abs(sorted_s[k] - ref_s), lo, k)
    return order[pick], np.abs(sorted_s[pick] - ref_s) <= tolerance_s


def _closest_gap(ref_s: np.ndarray, other_s: np.ndarray) -> float:
    """The smallest time between any reference stamp and any other stamp (inf without both)."""
    if not len(other_s) or not len(ref_s):
        return np.inf
    idx, _ = nearest_in_time(ref_s, other_s, np.inf)
    return float(np.min(np.abs(np.asarray(other_s, dtype=float)[idx] - np.asarray(ref_s, dtype=float))))


def joints_at(
    joints: JointSamples, robot_joint_names: list, query_s: np.ndarray, tolerance_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """The robot's joint angles at given stamps, in the robot model's joint order.

    A stamp equal to a sample's takes it; otherwise the two samples around the stamp are interpolated
    linearly, both within ``tolerance_s`` of it (a gap in the stream is never bridged).

    Parameters
    ----------
    joints : JointSamples
    robot_joint_names : list of str
        The model's joints, in its order (pinocchio's ``model.names[1:]``).
    query_s : array, shape (K,)
    tolerance_s : float

    Returns
    -------
    q : array, shape (K, len(robot_joint_names))
        NaN rows where not kept.
    keep : array of bool, shape (K,)

    Raises
    ------
    JointNamesError
        A model joint the recording does not have (both lists named); extra recorded joints (a gripper's)
        are ignored.
    """
    have = list(joints.names)
    missing = [n for n in robot_joint_names if n not in have]
    if missing:
        raise JointNamesError(
            f"{joints.source}: the robot model's joint(s) {', '.join(missing)} are not recorded; the recording "
            f"has {', '.join(have) or 'no joints'}; the model has {', '.join(robot_joint_names)} (another URDF, "
            "or a prefix such as 'ur_' to match)"
        )
    cols = [have.index(n) for n in robot_joint_names]
    t = np.asarray(joints.times_s, dtype=float)
    order = np.argsort(t, kind="stable")
    t, q = t[order], np.asarray(joints.q, dtype=float)[order][:, cols]
    t, first = np.unique(t, return_index=True)  # one sample per stamp (republished states)
    q = q[first]
    query_s = np.asarray(query_s, dtype=float)
    k = np.searchsorted(t, query_s)
    hi, lo = np.minimum(k, len(t) - 1), np.maximum(k - 1, 0)
    exact = t[hi] == query_s
    inside = (k > 0) & (k < len(t))
    gap = np.where(exact, 0.0, np.where(inside, np.maximum(query_s - t[lo], t[hi] - query_s), np.inf))
    keep = gap <= tolerance_s
    span = np.where(t[hi] > t[lo], t[hi] - t[lo], 1.0)
    w = np.where(exact, 1.0, (query_s - t[lo]) / span)[:, None]
    out = (1 - w) * q[lo] + w * q[hi]
    out[~keep] = np.nan
    return out, keep


def _robot_poses(part: RecordedPlacement, robot, query_s: np.ndarray, tolerance_s: float):
    """Joint angles (or NaN) and flange poses at the stamps, and which stamps have both that were asked."""
    n = len(query_s)
    names = [str(x) for x in list(robot.model.names)[1:]]
    q, keep = np.full((n, len(names)), np.nan), np.ones(n, dtype=bool)
    if part.joints is not None:
        j = part.joints
        model = getattr(robot, "model", None)
        lower, upper = (None, None) if model is None else (model.lowerPositionLimit, model.upperPositionLimit)
        if lower is not None and (len(lower) != len(names) or len(upper) != len(names)):
            lower, upper = None, None  # joints of several coordinates (continuous): no per-name limits
        samples = j.sample_names
        if len(samples) != len(j.q):  # samples dropped or added after reading: name them by their stamps
            samples = [f"sample at {t:.6f} s" for t in np.asarray(j.times_s, dtype=float).reshape(-1)]
        check_joint_values(j.source, list(j.names), j.q, samples, names, lower, upper)
        q, keep = joints_at(part.joints, names, query_s, tolerance_s)
    if part.poses is not None:
        from handeye.time_pairing import pair_by_time

        ps = part.poses
        try:
            pairs = pair_by_time(ps.times_s, ps.T_base_ee, query_s, np.tile(np.eye(4), (n, 1, 1)), tolerance_s)
        except HandEyeInputError:  # no image has a pose within the tolerance: counted as dropped below
            return q, np.full((n, 4, 4), np.nan), np.zeros(n, dtype=bool)
        T = np.full((n, 4, 4), np.nan)
        T[pairs.camera_index] = pairs.T_base_ee
        return q, T, keep & np.isfinite(T).all(axis=(1, 2))
    if part.joints is None:
        raise RecordingError(
            f"{part.source}: no robot state: record the joint states (with the robot's URDF) or tf (with the base "
            "and flange frames)"
        )
    T = np.full((n, 4, 4), np.nan)
    for i in np.flatnonzero(keep):
        T[i] = robot.fk(q[i])
    return q, T, keep


def _check_synchronised(source: str, what: str, n_total: int, n_kept: int, gap_s: float, tolerance_s: float):
    if n_total and (n_total - n_kept) > MAX_DROPPED_FRACTION * n_total:
        raise UnsynchronisedError(
            f"{source}: {n_total - n_kept} of {n_total} frames have no {what} within {tolerance_s * 1e3:.0f} ms "
            f"(closest {gap_s * 1e3:.1f} ms): unsynchronised streams or different clocks"
        )


# ------------------------------------------------------------------ undistortion and checks


def undistorter(intrinsics):
    """A function undistorting (colour, depth) to the pinhole of the same K, or None without distortion.

    Parameters
    ----------
    intrinsics
        The camera's intrinsics (``K`` (3, 3), ``dist`` (k,), ``width``, ``height``).

    Returns
    -------
    callable or None
        ``undistort(rgb (H, W, 3), depth (H, W)) -> (rgb, depth)``; ``None`` when ``dist`` is all zero.
    """
    if not np.any(intrinsics.dist):
        return None
    import cv2

    size = (int(intrinsics.width), int(intrinsics.height))
    mx, my = cv2.initUndistortRectifyMap(intrinsics.K, intrinsics.dist, None, intrinsics.K, size, cv2.CV_32FC1)

    def undistort(rgb, depth):
        rgb = cv2.remap(rgb, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
        depth = cv2.remap(depth, mx, my, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        return rgb, depth

    return undistort


def check_image_size(image: np.ndarray, size: tuple, what: str, where: str, hint: str = "") -> None:
    """Refuse an image of another size than its camera's.

    Parameters
    ----------
    image : array, shape (H, W) or (H, W, C)
    size : (int, int)
        The camera_info's ``(width, height)``.
    what, where : str
        The image's name and where it came from (for the message).
    hint : str
        Appended to the message (:data:`UNREGISTERED_DEPTH_HINT` for a depth image).

    Raises
    ------
    ImageSizeError
    """
    h, w = image.shape[:2]
    width, height = int(size[0]), int(size[1])
    if (w, h) != (width, height):
        raise ImageSizeError(f"{where}: {what} is {w}x{h}, the camera_info is for {width}x{height}{hint}")


def _check_depth_in_range(depth_m: np.ndarray, where: str) -> None:
    """Refuse a frame most of whose valid depth is beyond what the dataset's 16-bit PNGs hold (it would be lost)."""
    valid = np.isfinite(depth_m) & (depth_m > 0)
    beyond = valid & (depth_m > MAX_DEPTH_M)
    if beyond.sum() > MAX_DROPPED_FRACTION * valid.sum():
        raise RecordingError(
            f"{where}: {beyond.sum()} of {valid.sum()} valid depth pixels are beyond {MAX_DEPTH_M:.2f} m, the "
            f"furthest the dataset stores: tenths of a millimetre read as millimetres (pass --depth-unit 0.0001), or a "
            "camera too far from the robot"
        )


def _spread(n: int, max_frames: int | None) -> np.ndarray:
    if max_frames is None or n <= max_frames:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, max_frames)).astype(int))


def assemble(part: RecordedPlacement, robot, options: ImportOptions) -> tuple[list, int]:
    """The frames of one recording, each with its robot state, in time order.

    Parameters
    ----------
    part : RecordedPlacement
        With depth: data frames (the depth's stamps lead); without: calibration frames (the colour's).
    robot : handeye.robot.model.Robot
    options : ImportOptions

    Returns
    -------
    frames : list of dict
        ``rgb`` (H, W, 3) uint8, ``depth_m`` (H, W) float32 or None, ``q`` (J,), ``T_base_ee`` (4, 4).
    dropped : int
        Frames without a partner within the tolerances.

    Raises
    ------
    ImageSizeError, UnsynchronisedError, JointNamesError, RecordingError
    """
    intr = part.intrinsics
    lead = part.depth if part.depth is not None else part.color
    if not len(lead.times_s):
        raise RecordingError(f"{lead.source}: no images")
    order = np.argsort(lead.times_s, kind="stable")
    times = lead.times_s[order]
    color_idx, keep = np.arange(len(times)), np.ones(len(times), dtype=bool)
    if part.depth is not None:
        color_idx, keep = nearest_in_time(times, part.color.times_s, options.sync_tolerance_s)
        _check_synchronised(
            lead.source,
            f"colour image ({part.color.source.split(', ')[-1]})",
            len(times),
            int(keep.sum()),
            _closest_gap(times, part.color.times_s),
            options.sync_tolerance_s,
        )
    else:
        color_idx = order
    q, T, has_robot = _robot_poses(part, robot, times, options.joint_tolerance_s)
    robot_source = (part.poses or part.joints).source
    _check_synchronised(
        lead.source,
        f"robot state ({robot_source.split(', ')[-1]})",
        len(times),
        int((keep & has_robot).sum()),
        _closest_gap(times, (part.poses or part.joints).times_s),
        options.joint_tolerance_s,
    )
    kept = np.flatnonzero(keep & has_robot)
    dropped = len(times) - len(kept)
    if part.depth is not None:
        kept = kept[_spread(len(kept), options.max_frames)]
    undistort = undistorter(intr) if part.depth is not None else None
    size = (intr.width, intr.height)
    if part.depth is not None:
        check_depth_stream([lead.images[order[i]] for i in kept], lead.source)
    frames = []
    for i in kept:
        depth = None
        if part.depth is not None:
            depth = lead.images[order[i]]
            where = f"{lead.source}, {lead.names[order[i]]}"
            check_image_size(depth, size, "the depth image", where, UNREGISTERED_DEPTH_HINT)
            check_depth_frame(depth, 1.0, where)
            _check_depth_in_range(depth, where)
        rgb = part.color.images[color_idx[i]]
        check_image_size(rgb, size, "the colour image", f"{part.color.source}, {part.color.names[color_idx[i]]}")
        if part.depth is not None:
            depth = np.where(np.isfinite(depth) & (depth > 0), depth, 0).astype(np.float32)
            if undistort is not None:
                rgb, depth = undistort(rgb, depth)
        frames.append({"rgb": rgb, "depth_m": depth, "q": q[i], "T_base_ee": T[i]})
    return frames, dropped


# ------------------------------------------------------------------ the dataset


def _meta(placements: list, robot, robot_meta, board, sources: list, options: ImportOptions, generator: str) -> dict:
    intr = placements[0].intrinsics
    pinhole = intr.to_dict()
    pinhole["dist"] = [0.0] * len(pinhole["dist"])  # the data frames are undistorted on import
    cal = next((p.calibration.intrinsics for p in placements if p.calibration is not None), intr)
    for p in placements:
        same = p.intrinsics.to_dict() == intr.to_dict()
        same_cal = p.calibration is None or p.calibration.intrinsics.to_dict() == cal.to_dict()
        if not (same and same_cal):
            raise RecordingError(
                f"{p.source}: another camera_info than {placements[0].source}'s; a dataset holds one camera "
                "(import each camera into its own dataset)"
            )
    recordings = ["data"] + (["calibration"] if any(p.calibration is not None for p in placements) else [])
    meta = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "robot": robot_meta,
        "n_joints": int(robot.nq),
        "joint_names": [str(n) for n in list(robot.model.names)[1:]],
        "T_ee_ref": np.asarray(robot.T_ee_ref).tolist(),
        "intrinsics": pinhole,
        "calibration_intrinsics": cal.to_dict(),
        "depth": {
            "format": "png16",
            "scale_m": DEPTH_SCALE_M,
            "invalid": 0,
            "quantity": "z coordinate in the camera frame (not the ray length)",
        },
        "cameras": len(placements),
        "regions": 1,
        "recordings": recordings,
        "conventions": "T_a_b maps frame b to frame a; metres, radians; quaternions x,y,z,w; camera frame OpenCV "
        "(x right, y down, z forward); eye-to-hand: label X = T_base_cam",
        "recipe": {
            "generator": generator,
            "sources": sources,
            "sync_tolerance_s": options.sync_tolerance_s,
            "joint_tolerance_s": options.joint_tolerance_s,
            "max_frames": options.max_frames,
            "undistorted": bool(np.any(intr.dist)),
        },
    }
    if board is not None:
        meta["board"] = board.to_dict()
    return meta


def import_recordings(
    out: str | Path,
    placements: list,
    robot,
    robot_meta,
    board=None,
    options: ImportOptions | None = None,
    generator: str = "handeye import",
    progress: bool = False,
) -> ImportReport:
    """Write recorded camera placements as a dataset.

    The dataset is written into a temporary folder beside ``out`` (``.NAME.importing-HOST-PID``) and renamed to
    ``out`` when complete: an import that fails (a bad frame, a full disk) leaves nothing behind and can be rerun,
    and one that was killed leaves only its temporary folder, which the next import into ``out`` removes.

    Parameters
    ----------
    out : str or Path
        A new (or empty) dataset directory.
    placements : list of RecordedPlacement
        One per camera placement, ``camera_id`` in this order.
    robot : handeye.robot.model.Robot
        The robot model: its joint names order the joints, its forward kinematics gives ``T_base_ee``
        where no tf was recorded.
    robot_meta : str or dict
        ``meta["robot"]``: a UR's name, or ``{"urdf": ..., "package_dirs": [...], "ee_frame": ...}``.
    board : classic.vision.board.BoardSpec, optional
        The calibration board (needed to label the calibration frames).
    options : ImportOptions, optional
    generator : str
        The command, recorded in ``meta["recipe"]``.
    progress : bool
        A progress bar on stderr.

    Returns
    -------
    ImportReport

    Raises
    ------
    DatasetError
        ``out`` holds files already (said to be an unfinished import's when it is one); the dataset cannot be
        written (a full disk, a read-only folder: nothing is left behind).
    RecordingError
        And its subclasses, naming the recording (see :func:`assemble`).
    """
    t0 = time.perf_counter()
    options = options or ImportOptions()
    out = Path(out)
    if not placements:
        raise RecordingError("no recording to import")
    _check_target(out)
    if board is None and any(p.calibration is not None for p in placements):
        raise RecordingError("calibration recordings need the board (--board board.json, from 'handeye board')")
    meta = _meta(placements, robot, robot_meta, board, [p.source for p in placements], options, generator)
    target = Path(os.path.realpath(out))  # "." has a name and a parent; a link to an empty folder is followed
    _remove_stale_temporaries(target)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = target.parent / f"{_TMP_PREFIX.format(name=target.name)}{socket.gethostname()}-{os.getpid()}"
        if tmp.exists():  # this process's own (its pid reused): nobody else writes it
            shutil.rmtree(tmp)
        tmp.mkdir()
    except OSError as exc:
        raise DatasetError(
            f"{out}: cannot create the dataset beside it ({exc.strerror or exc}: {exc.filename})"
        ) from None
    try:
        counts = _write_dataset(tmp, placements, robot, meta, options, generator, progress, out.name)
        try:
            os.rename(tmp, target)  # replaces an empty directory; refused where another writer filled ``out``
        except OSError as exc:
            raise DatasetError(
                f"{out}: cannot publish the import ({exc.strerror or exc}); another process wrote this directory "
                "meanwhile, or it is not writable; nothing was written"
            ) from None
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise DatasetError(
            f"{out}: the import failed writing {exc.filename or 'the dataset'} ({exc.strerror or exc}); nothing was "
            "written, rerun when it is fixed"
        ) from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return ImportReport(out, counts, time.perf_counter() - t0)


def _write_dataset(
    root: Path, placements: list, robot, meta: dict, options: ImportOptions, generator: str, progress: bool, name: str
) -> list:
    """Write meta.json, one shard per placement and cameras.csv into ``root``; the frame counts per placement."""
    from handeye.core.shard_writer import ShardWriter

    counts = []
    write_json_atomic(root / "meta.json", meta)
    iterator = placements
    if progress:
        from tqdm import tqdm

        iterator = tqdm(placements, desc=f"import {name}", unit="placement")
    for camera_id, part in enumerate(iterator):
        data, dropped = assemble(part, robot, options)
        cal, cal_dropped = ([], 0) if part.calibration is None else assemble(part.calibration, robot, options)
        shard = ShardWriter(root, camera_id, region=0, split="test", n_joints=robot.nq, depth_scale_m=DEPTH_SCALE_M)
        with shard:
            for f in cal:
                shard.add_frame("calibration", f["T_base_ee"], f["rgb"], q=f["q"])
            for f in data:
                shard.add_frame(
                    "data",
                    f["T_base_ee"],
                    f["rgb"],
                    depth_m=f["depth_m"],
                    q=f["q"],
                    T_base_ref=f["T_base_ee"] @ robot.T_ee_ref,
                )
        counts.append(
            {"source": part.source, "data": len(data), "calibration": len(cal), "dropped": dropped + cal_dropped}
        )
    n = len(placements)
    table = {c: np.full(n, np.nan) for c in CAMERA_COLUMNS}
    table.update(camera_id=np.arange(n), region=np.zeros(n, dtype=int), split=np.array(["test"] * n, dtype=object))
    write_table(root / "cameras.csv", table, CAMERA_COLUMNS)
    return counts


def _check_target(out: Path) -> None:
    """Refuse a target that is not a new or empty directory, saying when it is an unfinished import's leftover."""
    if out.exists() and not out.is_dir():
        raise DatasetError(f"{out}: not a directory; import into a new directory")
    try:
        entries = list(out.iterdir()) if out.exists() else []
    except OSError as exc:
        raise DatasetError(f"{out}: cannot list it ({exc.strerror or exc})") from None
    if not entries:
        return
    meta = out / "meta.json"
    if meta.is_file() and not (out / "cameras.csv").exists():
        try:
            recipe = json.loads(meta.read_text()).get("recipe", {})
            unfinished = str(recipe.get("generator", "")).startswith("handeye import")
        except (OSError, ValueError, AttributeError, RecursionError):
            unfinished = False
        if unfinished:
            raise DatasetError(
                f"{out}: an unfinished import left this folder (meta.json, no cameras.csv); remove it (rm -r {out}) "
                "and rerun"
            )
    raise DatasetError(f"{out}: not empty; import into a new directory")


def _remove_stale_temporaries(out: Path) -> None:
    """Remove the temporary folders of imports into ``out`` on this host whose process has ended (killed)."""
    prefix = _TMP_PREFIX.format(name=out.name) + socket.gethostname() + "-"
    try:
        siblings = [p for p in out.parent.iterdir() if p.name.startswith(prefix)] if out.parent.is_dir() else []
    except OSError:
        return
    for p in siblings:
        pid = p.name[len(prefix) :]
        if not pid.isdigit():
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            shutil.rmtree(p, ignore_errors=True)
        except (PermissionError, OverflowError, ValueError):
            continue
