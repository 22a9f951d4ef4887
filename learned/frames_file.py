"""Frames in one file: a :class:`learned.data.FrameSet` written as a compressed ``.npz`` and read back.

A machine that trains (an accelerator's, without the renderer, Pinocchio or the dataset's images) reads
the frames prepared elsewhere: numpy only, no pickled objects. Every field of the FrameSet is one array;
``label_source`` and ``image_size`` are stored beside them with the format's name and version.

>>> save_frames(frames, "paper_frames.npz")  # doctest: +SKIP
>>> frames = read_frames("paper_frames.npz")  # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
import io
from pathlib import Path

import numpy as np

from handeye.core.errors import DatasetError
from handeye.core.safe_write import write_bytes_atomic
from learned.data import FrameSet

__all__ = ["FORMAT", "frames_bytes", "save_frames", "read_frames", "thin_frames"]

#: The file's format name and version, stored in it as ``format``.
FORMAT = "handeye-frames-1"

_META = ("label_source", "image_size")


def frames_bytes(frames: FrameSet) -> bytes:
    """The content of the ``.npz`` file :func:`save_frames` writes (zlib-compressed), built in memory.

    Parameters
    ----------
    frames : FrameSet

    Returns
    -------
    bytes
    """
    arrays = {f.name: getattr(frames, f.name) for f in dataclasses.fields(FrameSet) if f.name not in _META}
    arrays["split"] = np.asarray(frames.split).astype("U")
    buffer = io.BytesIO()  # a file object: numpy adds no ".npz" to a name
    np.savez_compressed(
        buffer,
        format=np.array(FORMAT),
        label_source=np.array(frames.label_source),
        image_size=np.asarray(frames.image_size, dtype=np.int64),
        **arrays,
    )
    return buffer.getvalue()


def save_frames(frames: FrameSet, path: str | Path) -> int:
    """Write ``frames`` to ``path`` (``.npz``, :func:`frames_bytes`) whole; returns the file's size in bytes.

    Written by :func:`handeye.core.safe_write.write_bytes_atomic`: a failure leaves the old file as it was,
    and a FIFO or device at ``path`` is refused.

    Parameters
    ----------
    frames : FrameSet
    path : str or Path

    Returns
    -------
    int

    Raises
    ------
    OutputFileError
        ``path`` is not a place for a regular file, or the write failed.
    """
    data = frames_bytes(frames)
    write_bytes_atomic(Path(path), data)
    return len(data)


def read_frames(path: str | Path) -> FrameSet:
    """The FrameSet :func:`save_frames` wrote to ``path``.

    Raises
    ------
    DatasetError
        Not a frames file of this format.
    """
    with np.load(path, allow_pickle=False) as doc:
        if "format" not in doc.files or str(doc["format"]) != FORMAT:
            raise DatasetError(f"{path} is not a frames file ({FORMAT}): write one with save_frames")
        fields = {f.name: doc[f.name] for f in dataclasses.fields(FrameSet) if f.name not in _META}
        return FrameSet(
            **fields,
            label_source=str(doc["label_source"]),
            image_size=tuple(int(v) for v in doc["image_size"]),
        )


def thin_frames(frames: FrameSet, per_camera: int) -> FrameSet:
    """At most ``per_camera`` frames of each camera pose, evenly spaced over its frames in their order.

    Parameters
    ----------
    frames : FrameSet
    per_camera : int
        At least 1.

    Returns
    -------
    FrameSet
    """
    if per_camera < 1:
        raise ValueError(f"per_camera must be at least 1, got {per_camera}")
    keep = []
    for cam in np.unique(frames.camera):
        rows = np.flatnonzero(frames.camera == cam)
        keep.append(rows[np.unique(np.linspace(0, len(rows) - 1, min(per_camera, len(rows))).round().astype(int))])
    return frames.subset(np.sort(np.concatenate(keep)))
