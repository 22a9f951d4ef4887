"""Frames for the watcher: a dataset folder replayed in order, and the live ROS 2 source (not built yet).

A stream is a dataset (:mod:`handeye.core.dataset`) whose shards are consecutive segments of one recording:
the shards in order, each shard's data frames in order (a frame whose depth was lost, an empty ``depth``
cell, comes as an image without depth: a dropout). Times come from ``stream.json`` in
the dataset's root when it is there (the simulator's stream preset writes it), read as::

    {"rate_hz": 30.0, "segments": [{"camera": 0, "start_s": 0.0}, {"camera": 1, "start_s": 12.4}, ...]}

a segment's frame ``i`` at ``start_s + i / rate_hz``; else from the frame's index in the whole stream at the
rate given (``rate_hz``).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from handeye.core.dataset import Dataset
from handeye.core.errors import DatasetError, HandEyeInputError
from handeye.core.jsonfile import read_json_file

__all__ = ["Frame", "dataset_frames", "stream_rate", "stream_times", "ros2_frames"]


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
    """

    t: float
    depth_m: np.ndarray
    joints: np.ndarray
    index: int = 0
    segment: int | None = None


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


def dataset_frames(root: str | Path, rate_hz: float | None = None, cameras=None) -> Iterator[Frame]:
    """Replay a dataset's data frames in stream order (module docstring).

    Parameters
    ----------
    root : str or Path
    rate_hz : float, optional
        Frame rate when ``stream.json`` gives none (and over its rate when given).
    cameras : sequence of int, optional
        The shards to replay (default all complete ones, in order).

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
            yield Frame(float(times[c][i]), depth, q[i], index, c)
            index += 1


def ros2_frames(*args, **kwargs) -> Iterator[Frame]:
    """Live frames from ROS 2 topics: not built yet.

    Raises
    ------
    HandEyeInputError
        Always: without rclpy it says so; with it, that the live source is the next step (issue 43).
    """
    try:
        import rclpy  # noqa: F401
    except ImportError:
        raise HandEyeInputError(
            "watching live ROS 2 topics needs rclpy (a ROS 2 installation, sourced): not found; replay a recording "
            "instead (handeye watch DATASET)"
        ) from None
    raise HandEyeInputError(
        "watching live ROS 2 topics is not built yet (issue 43): replay a recording instead (handeye watch DATASET)"
    )
