"""Frames for the watcher: a dataset folder or a ROS 2 bag replayed in order (live ROS 2: :mod:`.ros2`).

Every source yields :class:`Frame` objects for :meth:`handeye.watch.CellWatcher.feed`, the one code path.

A bag (:func:`bag_frames`) is read with :func:`handeye.import_bag.read_camera_bag`, the reader ``handeye import
bag`` uses: its depth stamps lead, each depth frame takes the joints interpolated at its stamp
(:func:`handeye.recording_import.joints_at`, within ``joint_tolerance_s``) and the nearest colour image (within
``sync_tolerance_s``; none beyond it), undistorted to the camera_info's ``K`` as the import does. Frames without
joints within the tolerance are left out (counted). :func:`paced` replays any source at its recorded rate::

    handeye watch BAG --sensor d435 --camera-start start.json --history cell.jsonl --current cell.json
    handeye watch BAG --fast ...          # as fast as the check goes

A dataset stream is a dataset (:mod:`handeye.core.dataset`) whose shards are consecutive segments of one recording:
the shards in order, each shard's data frames in order (a frame whose depth was lost, an empty ``depth``
cell, comes as an image without depth: a dropout). Times come from ``stream.json`` in
the dataset's root when it is there (the simulator's stream preset writes it), read as::

    {"rate_hz": 30.0, "segments": [{"camera": 0, "start_s": 0.0}, {"camera": 1, "start_s": 12.4}, ...]}

a segment's frame ``i`` at ``start_s + i / rate_hz``; else from the frame's index in the whole stream at the
rate given (``rate_hz``).
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from handeye.core.dataset import Dataset
from handeye.core.errors import DatasetError, HandEyeInputError
from handeye.core.jsonfile import read_json_file

__all__ = ["Frame", "BagTopics", "BagStream", "bag_frames", "paced", "dataset_frames", "stream_rate", "stream_times"]


@dataclass
class Frame:
    """One frame of a stream.

    Attributes
    ----------
    t : float
        Seconds from the stream's start.
    depth_m : array, shape (H, W)
        Depth, metres, 0 where the sensor has none.
    joints : array, shape (nq,)
        Joint angles, radians.
    index : int
        Position in the stream (0, 1, ...).
    segment : int or None
        The dataset shard it came from.
    rgb : array of uint8, shape (H, W, 3), or None
        The colour image registered to the depth, where the source has one (the continual learner's input,
        :mod:`handeye.watch.learner`).
    """

    t: float
    depth_m: np.ndarray
    joints: np.ndarray
    index: int = 0
    segment: int | None = None
    rgb: np.ndarray | None = None


def _stream_doc(root: str | Path) -> dict:
    path = Path(root) / "stream.json"
    doc = read_json_file(path, DatasetError, "stream description") if path.is_file() else {}
    return doc if isinstance(doc, dict) else {}


def stream_rate(root: str | Path, rate_hz: float | None = None) -> float:
    """The stream's frame rate, Hz: ``rate_hz`` when given, else ``stream.json``'s.

    Raises
    ------
    HandEyeInputError
        Neither, or a rate that is not > 0.
    """
    rate = _stream_doc(root).get("rate_hz") if rate_hz is None else rate_hz
    if not isinstance(rate, (int, float)) or not np.isfinite(rate) or not rate > 0:
        raise HandEyeInputError(f"{root}: no frame rate > 0 (stream.json has none): give the rate in Hz, got {rate}")
    return float(rate)


def stream_times(root: str | Path, counts: dict, rate_hz: float | None) -> dict:
    """Each segment's frame times, seconds: ``{camera: array (n,)}`` (module docstring).

    Raises
    ------
    HandEyeInputError
        Neither a ``stream.json`` with the times nor a rate, or a rate that is not > 0.
    """
    doc = _stream_doc(root)
    rate = stream_rate(root, rate_hz)
    starts = {}
    segments = doc.get("segments")
    for k, seg in enumerate(segments if isinstance(segments, list) else []):
        if isinstance(seg, dict) and "camera" in seg and "start_s" in seg:
            try:
                starts[int(seg["camera"])] = float(seg["start_s"])
            except (TypeError, ValueError):
                raise DatasetError(
                    f"{Path(root) / 'stream.json'}: segment {k}: camera or start_s not a number"
                ) from None
    out, before = {}, 0
    for camera, n in counts.items():
        start = starts.get(camera, before / rate)
        out[camera] = start + np.arange(n) / rate
        before += n
    return out


def dataset_frames(
    root: str | Path, rate_hz: float | None = None, cameras=None, colour: bool = False
) -> Iterator[Frame]:
    """Replay a dataset's data frames in stream order (module docstring).

    Parameters
    ----------
    root : str or Path
    rate_hz : float, optional
        Frame rate when ``stream.json`` gives none (and over its rate when given).
    cameras : sequence of int, optional
        The shards to replay (default all complete ones, in order).
    colour : bool
        Read each frame's colour image too (``Frame.rgb``: the continual learner's input).

    Yields
    ------
    Frame
    """
    ds = Dataset.open(root)
    cameras = ds.complete_shards() if cameras is None else list(cameras)
    tables = {c: ds.select(c, "data") for c in cameras}
    times = stream_times(root, {c: len(t["depth"]) for c, t in tables.items()}, rate_hz)
    shape = (int(ds.meta["intrinsics"]["height"]), int(ds.meta["intrinsics"]["width"]))
    index = 0
    for c, t in tables.items():
        q = ds.joints(t)
        if not np.isfinite(q).all():
            raise DatasetError(f"{ds.shard_dir(c) / 'frames.csv'}: data frames without joint angles")
        for i, rel in enumerate(t["depth"]):
            depth = ds.depth_m(c, rel) if rel else np.zeros(shape, dtype=np.float32)  # no depth: a dropout
            rgb = ds.rgb(c, t["rgb"][i]) if colour and t["rgb"][i] else None
            yield Frame(float(times[c][i]), depth, q[i], index, c, rgb)
            index += 1


@dataclass(frozen=True)
class BagTopics:
    """The topics of an RGB-D camera and a robot (the RealSense driver's names by default)."""

    depth: str = "/camera/aligned_depth_to_color/image_raw"
    info: str = "/camera/color/camera_info"
    color: str = "/camera/color/image_raw"
    joints: str = "/joint_states"


@dataclass
class BagStream:
    """A bag's frames for the watcher.

    Attributes
    ----------
    K : array, shape (3, 3)
        The camera matrix the depth is registered to (its camera_info's, after undistortion).
    size : (int, int)
        ``(width, height)``.
    frames : list of Frame
        In stamp order; ``t`` is seconds since the bag's start.
    dropped : int
        Depth frames left out: no joint state within the tolerance.
    source : str
    """

    K: np.ndarray
    size: tuple
    frames: list
    dropped: int
    source: str


def bag_frames(
    bag,
    joint_names: list,
    topics: BagTopics | None = None,
    depth_unit_m: float | None = None,
    joint_tolerance_s: float = 0.02,
    sync_tolerance_s: float = 0.02,
) -> BagStream:
    """A ROS 2 bag's (sqlite3 or MCAP) RGB-D frames with the joints at their stamps (module docstring).

    Parameters
    ----------
    bag : str or Path
        A rosbag2 directory (or its ``.db3``/``.mcap`` file).
    joint_names : list of str
        The robot model's joints, in its order (the bag's JointState names matched to them).
    topics : BagTopics, optional
    depth_unit_m : float, optional
        Metres per depth unit; None: the encoding's (REP 118).
    joint_tolerance_s, sync_tolerance_s : float
        Largest gap from a depth stamp to the joint samples around it, and to the colour image taken.

    Returns
    -------
    BagStream

    Raises
    ------
    NotABagError, BagTopicError, BagError, RecordingError, IntrinsicsError
        As :func:`handeye.import_bag.read_camera_bag`.
    ImageSizeError
        A depth or colour image of another size than the camera_info's (depth not registered to that camera).
    JointNamesError
        A model joint the bag does not have.
    HandEyeInputError
        No depth frame with joints within the tolerance.
    """
    from handeye.import_bag import read_camera_bag
    from handeye.recording_import import (
        UNREGISTERED_DEPTH_HINT,
        check_image_size,
        joints_at,
        nearest_in_time,
        undistorter,
    )

    topics = topics or BagTopics()
    part = read_camera_bag(bag, topics.color, topics.info, topics.depth, topics.joints, depth_unit_m=depth_unit_m)
    size = (int(part.intrinsics.width), int(part.intrinsics.height))
    order = np.argsort(part.depth.times_s, kind="stable")
    times = part.depth.times_s[order]
    q, keep = joints_at(part.joints, list(joint_names), times, joint_tolerance_s)
    color_idx, has_color = nearest_in_time(times, part.color.times_s, sync_tolerance_s)
    undistort = undistorter(part.intrinsics)
    frames = []
    for k in np.flatnonzero(keep):
        depth = part.depth.images[order[k]]
        check_image_size(
            depth,
            size,
            "the depth image",
            f"{part.depth.source}, {part.depth.names[order[k]]}",
            UNREGISTERED_DEPTH_HINT,
        )
        depth = np.where(np.isfinite(depth) & (depth > 0), depth, 0).astype(np.float32)
        rgb = part.color.images[color_idx[k]] if has_color[k] else None
        if rgb is not None:
            check_image_size(rgb, size, "the colour image", f"{part.color.source}, {part.color.names[color_idx[k]]}")
        if undistort is not None:
            rgb, depth = undistort(rgb if rgb is not None else np.zeros(depth.shape + (3,), np.uint8), depth)
            rgb = rgb if has_color[k] else None
        frames.append(Frame(float(times[k]), depth, q[k], len(frames), None, rgb))
    if not frames:
        raise HandEyeInputError(
            f"{part.source}: no depth frame has joint states within {joint_tolerance_s} s ({topics.joints})"
        )
    return BagStream(np.asarray(part.intrinsics.K, dtype=float), size, frames, int((~keep).sum()), part.source)


def paced(frames: Iterable[Frame], speed: float = 1.0, clock=time.monotonic, sleep=time.sleep) -> Iterator[Frame]:
    """Yield frames no faster than their times say: a recording replayed at its own rate.

    Parameters
    ----------
    frames : iterable of Frame
    speed : float
        1 replays at the recorded rate, 2 twice as fast.
    clock, sleep : callables
        The wall clock (seconds) and the wait (for tests).

    Yields
    ------
    Frame
        Each when ``(frame.t - first.t) / speed`` seconds have passed since the first was yielded (at once when
        the caller is late: a slow check is never waited for twice).
    """
    if not speed > 0:
        raise ValueError(f"speed must be > 0, got {speed}")
    origin = None
    for frame in frames:
        if origin is None:
            origin = (clock(), frame.t)
        else:
            wait = (frame.t - origin[1]) / speed - (clock() - origin[0])
            if wait > 0:
                sleep(wait)
        yield frame
