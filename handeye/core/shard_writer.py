"""Write one shard of a dataset atomically: the one writer of the simulator and of real recordings.

A shard (one camera placement: ``shards/cam_XXXX``, :mod:`handeye.core.dataset`)
is written into ``cam_XXXX.partial``; when its frame table is written and the
``with`` block ends without an error, the manifest (every file with its size)
is written last and the folder renamed to ``cam_XXXX`` in one step. So:

- a finished shard is recognised (:attr:`ShardWriter.complete`) and a resumed
  recording skips it;
- an error inside the ``with`` block removes the ``.partial`` folder, and a
  killed process leaves only a ``.partial`` folder, which the next writer of
  that shard removes: no half-written shard is ever published.

Writing a real recording (your robot, your RGB-D camera), after ``meta.json``
(intrinsics, board, ``depth.scale_m`` of your sensor, ``n_joints``) and one
``cameras.csv`` row per camera placement, with frames of the form
``T_base_ee`` : array, shape (4, 4), the flange pose in the robot base (from
the controller), ``q`` : joint angles in radians, ``rgb`` : uint8 (H, W, 3),
``depth_m`` : float (H, W) in metres, 0 = no depth::

    import numpy as np

    from handeye.core.shard_writer import ShardWriter

    T_ee_ref = np.eye(4)
    T_ee_ref[2, 3] = 0.12          # a reference point 12 cm along the tool
    for camera_id, placement in enumerate(placements):
        shard = ShardWriter("data/my-robot", camera_id, region=0, split="train")
        if shard.complete:          # written by an earlier run: resume after it
            continue
        with shard:
            for q, T_base_ee, rgb in placement.board_views:         # the board on the flange
                shard.add_frame("calibration", T_base_ee, rgb=rgb, q=q)
            for q, T_base_ee, rgb, depth_m in placement.data_frames:
                shard.add_frame("data", T_base_ee, rgb=rgb, depth_m=depth_m, q=q,
                                T_base_ref=T_base_ee @ T_ee_ref)

Then ``handeye label data/my-robot`` labels it. A writer that builds its own
frame table (the simulator) calls :meth:`ShardWriter.write_rgb`,
:meth:`ShardWriter.write_depth` and :meth:`ShardWriter.write_frames` instead of
:meth:`ShardWriter.add_frame`.
"""

from __future__ import annotations

import io
import os
import shutil
from pathlib import Path

import numpy as np

from handeye.core.dataset import (
    RECORDINGS,
    encode_depth,
    frame_columns,
    poses_to_columns,
    shard_is_complete,
    shard_name,
    write_manifest,
    write_table,
)
from handeye.core.errors import DatasetError, HandEyeInputError, OutputFileError
from handeye.core.jsonfile import read_json_file

__all__ = ["ShardWriter"]


class ShardWriter:
    """Write one camera placement's shard into a temporary folder, then publish it atomically.

    Use as a context manager: the shard is published (manifest written last, folder renamed) when the
    ``with`` block ends without an error, and its temporary folder removed when it raises.

    Parameters
    ----------
    root : str or Path
        The dataset directory.
    camera_id : int
        The camera placement (row of ``cameras.csv``) the shard belongs to.
    region : int
        Region of the placement, written in every row by :meth:`add_frame`.
    split : {"train", "test"}
        Split of the placement, written in every row by :meth:`add_frame`.
    n_joints : int, optional
        Joints of the robot; None reads ``n_joints`` of ``root/meta.json`` (when needed).
    depth_scale_m : float, optional
        Metres per unit of the depth PNGs; None reads ``depth.scale_m`` of ``root/meta.json``.
    png_compress_level : int
        zlib level of the PNGs (1: fast, as the simulator writes them).

    Attributes
    ----------
    final : Path
        The published shard, ``root/shards/cam_XXXX``.
    partial : Path
        The temporary folder, ``root/shards/cam_XXXX.partial``.

    Examples
    --------
    >>> with ShardWriter(root, 0, n_joints=6, depth_scale_m=1e-4) as shard:   # doctest: +SKIP
    ...     rel = shard.write_rgb("data_000", rgb)
    ...     shard.write_frames(table)
    """

    def __init__(
        self,
        root: str | Path,
        camera_id: int,
        region: int = 0,
        split: str = "train",
        n_joints: int | None = None,
        depth_scale_m: float | None = None,
        png_compress_level: int = 1,
    ):
        self.root = Path(root)
        self.camera_id = int(camera_id)
        self.region, self.split = int(region), str(split)
        self.final = self.root / shard_name(self.camera_id)
        self.partial = self.final.with_name(self.final.name + ".partial")
        self._n_joints, self._depth_scale_m = n_joints, depth_scale_m
        self.png_compress_level = png_compress_level
        self._rows: list[dict] = []
        self._frames_written = False
        self._n_frames: dict = {}
        self._open = False

    @property
    def complete(self) -> bool:
        """Whether the shard is already published and complete (a resumed recording skips it)."""
        return shard_is_complete(self.final)[0]

    def _meta(self, key: str):
        path = self.root / "meta.json"
        try:
            meta = read_json_file(path, DatasetError, "dataset meta.json")
        except DatasetError as exc:
            raise DatasetError(f"{exc}; write meta.json first or pass {key}") from None
        try:
            return meta["depth"]["scale_m"] if key == "depth_scale_m" else meta[key]
        except (KeyError, TypeError) as exc:
            raise DatasetError(f"{path}: cannot read {key} ({exc}); write meta.json first or pass {key}") from None

    @property
    def n_joints(self) -> int:
        if self._n_joints is None:
            self._n_joints = int(self._meta("n_joints"))
        return self._n_joints

    @property
    def depth_scale_m(self) -> float:
        if self._depth_scale_m is None:
            self._depth_scale_m = float(self._meta("depth_scale_m"))
        return self._depth_scale_m

    # -- the temporary folder

    def __enter__(self) -> "ShardWriter":
        try:
            if self.partial.exists():  # left by a killed writer: start the shard again
                shutil.rmtree(self.partial)
            (self.partial / "rgb").mkdir(parents=True)
            (self.partial / "depth").mkdir()
        except OSError as exc:
            shutil.rmtree(self.partial, ignore_errors=True)
            raise OutputFileError(f"{self.partial}: cannot create the shard's folder ({exc.strerror or exc})") from None
        self._rows, self._frames_written, self._open = [], False, True
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        try:
            if exc_type is None:
                if self._rows:
                    self._write_rows()
                if not self._frames_written:
                    raise DatasetError(
                        f"{self.partial}: no frame table written (call add_frame or write_frames); shard not published"
                    )
                self._publish()
        except BaseException:
            shutil.rmtree(self.partial, ignore_errors=True)
            raise
        finally:
            self._open = False
        if exc_type is not None:
            shutil.rmtree(self.partial, ignore_errors=True)
        return False

    def _check_open(self) -> None:
        if not self._open:
            raise DatasetError(f"{self.final}: write inside 'with ShardWriter(...) as shard:'")

    def _path(self, folder: str, name: str) -> tuple[str, Path]:
        self._check_open()
        if not name or "/" in name or "\\" in name or name.startswith("."):
            raise HandEyeInputError(f"image name {name!r}: a plain file name without folders is needed")
        rel = f"{folder}/{name}.png"
        return rel, self.partial / rel

    # -- images and tables

    def write_rgb(self, name: str, rgb: np.ndarray) -> str:
        """Write a colour image as ``rgb/<name>.png``.

        Parameters
        ----------
        name : str
            File name without folder and extension, e.g. ``"data_000"``.
        rgb : array of uint8, shape (H, W, 3)

        Returns
        -------
        str
            The path relative to the shard, for the frame table's ``rgb`` cell.
        """
        from PIL import Image

        rgb = np.asarray(rgb)
        if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
            raise HandEyeInputError(f"rgb {name!r}: expected uint8 of shape (H, W, 3), got {rgb.dtype} {rgb.shape}")
        rel, path = self._path("rgb", name)
        self._write_png(path, Image.fromarray(rgb))
        return rel

    def write_depth(self, name: str, depth_m: np.ndarray) -> str:
        """Write a depth image in metres as 16-bit ``depth/<name>.png`` (units of ``depth_scale_m``).

        Parameters
        ----------
        name : str
            File name without folder and extension.
        depth_m : array, shape (H, W)
            The z coordinate in the camera frame, metres; 0 or not finite = no depth.

        Returns
        -------
        str
            The path relative to the shard, for the frame table's ``depth`` cell.
        """
        from PIL import Image

        depth_m = np.asarray(depth_m)
        if depth_m.ndim != 2:
            raise HandEyeInputError(f"depth {name!r}: expected shape (H, W), got {depth_m.shape}")
        rel, path = self._path("depth", name)
        self._write_png(path, Image.fromarray(encode_depth(depth_m, self.depth_scale_m)))
        return rel

    def _write_png(self, path: Path, image) -> None:
        """Encode in memory, then write; a failed write (a full disk) names the file and its cause.

        The file lies in the shard's temporary folder, which the failed ``with`` block removes whole, so
        no part of it is ever published; no per-file rename is needed here.
        """
        buffer = io.BytesIO()
        image.save(buffer, format="PNG", compress_level=self.png_compress_level)
        try:
            with open(path, "wb") as f:
                f.write(buffer.getbuffer())
        except OSError as exc:
            raise OutputFileError(
                f"{path}: cannot write ({exc.strerror or exc}); the shard is not published, rerun to write it"
            ) from None

    def write_frames(self, table: dict, n_frames: dict | None = None) -> None:
        """Write the shard's frame table (``frames.csv``, columns :func:`handeye.core.dataset.frame_columns`).

        Parameters
        ----------
        table : dict
            Column name to array, one row per frame.
        n_frames : dict, optional
            Frames per recording for the manifest; None counts the ``recording`` column.
        """
        self._check_open()
        columns = frame_columns(self.n_joints)
        missing = [c for c in columns if c not in table]
        if missing:
            raise HandEyeInputError(f"{self.final}: frame table without column(s) {', '.join(missing)}")
        if n_frames is None:
            recorded = list(np.asarray(table["recording"], dtype=object))
            n_frames = {r: recorded.count(r) for r in RECORDINGS if r in recorded}
        write_table(self.partial / "frames.csv", table, columns)
        self._n_frames = dict(n_frames)
        self._frames_written = True

    def add_frame(
        self,
        recording: str,
        T_base_ee: np.ndarray,
        rgb: np.ndarray,
        depth_m: np.ndarray | None = None,
        q: np.ndarray | None = None,
        T_base_ref: np.ndarray | None = None,
    ) -> int:
        """Add one frame: its images are written now, its row with the frame table when the block ends.

        Parameters
        ----------
        recording : {"calibration", "data"}
            ``calibration``: the board on the flange; ``data``: the robot with its tool (what the learner sees).
        T_base_ee : array, shape (4, 4)
            Pose of the flange in the robot base frame (``p_base = T_base_ee @ p_ee``), metres.
        rgb : array of uint8, shape (H, W, 3)
        depth_m : array, shape (H, W), optional
            Depth in metres (z in the camera frame), 0 = no depth; None for none.
        q : array, shape (n_joints,), optional
            Joint angles in radians; None leaves the cells empty.
        T_base_ref : array, shape (4, 4), optional
            Pose of the tool's reference point in the base frame; None leaves the cells empty.

        Returns
        -------
        int
            The frame's number in the shard.
        """
        if recording not in RECORDINGS:
            raise HandEyeInputError(f"recording {recording!r} is not one of {RECORDINGS}")
        k = sum(r["recording"] == recording for r in self._rows)
        name = f"{recording}_{k:03d}"
        T_base_ref = np.full((4, 4), np.nan) if T_base_ref is None else T_base_ref
        q = np.full(self.n_joints, np.nan) if q is None else np.asarray(q, dtype=float).reshape(-1)
        if len(q) != self.n_joints:
            raise HandEyeInputError(f"q has {len(q)} joint angles, the robot has {self.n_joints}")
        self._rows.append(
            {
                "recording": recording,
                "q": q,
                "rgb": self.write_rgb(name, rgb),
                "depth": "" if depth_m is None else self.write_depth(name, depth_m),
                "T_base_ee": np.asarray(T_base_ee, dtype=float).reshape(4, 4),
                "T_base_ref": np.asarray(T_base_ref, dtype=float).reshape(4, 4),
            }
        )
        return len(self._rows) - 1

    def _write_rows(self) -> None:
        n, rows = len(self._rows), self._rows
        table = {
            "frame": np.arange(n),
            "camera_id": np.full(n, self.camera_id),
            "region": np.full(n, self.region),
            "split": np.array([self.split] * n, dtype=object),
        }
        for key in ("recording", "rgb", "depth"):
            table[key] = np.array([r[key] for r in rows], dtype=object)
        q = np.array([r["q"] for r in rows])
        table.update({f"q{j}": q[:, j] for j in range(self.n_joints)})
        for name in ("T_base_ee", "T_base_ref"):
            T = np.array([r[name] for r in rows])
            known = np.isfinite(T).all(axis=(1, 2))
            cols = poses_to_columns(name, np.where(known[:, None, None], T, np.eye(4)))
            table.update({c: np.where(known, v, np.nan) for c, v in cols.items()})
        self.write_frames(table)

    def _publish(self) -> None:
        write_manifest(self.partial, self.camera_id, self._n_frames)
        try:
            if self.final.exists():  # a half-written shard of an older layout: replaced
                shutil.rmtree(self.final)
            os.replace(self.partial, self.final)
        except OSError as exc:
            raise OutputFileError(f"{self.final}: cannot publish the shard ({exc.strerror or exc}); rerun") from None
