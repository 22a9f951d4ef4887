"""Frames of a labelled dataset as arrays: images at the model's resolution, reference poses, targets.

Reads the dataset format of :mod:`handeye.core.dataset` (never the simulator).
Targets are the camera pose ``T_base_cam`` of each frame's camera pose: the
classic label by default (as the paper trains on Tsai's labels), or the truth.
"""

from __future__ import annotations

import dataclasses
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from handeye.core.dataset import Dataset
from handeye.core.errors import DatasetError, HandEyeInputError
from handeye.core.se3 import pos_quat_xyzw_from_transform

__all__ = ["FrameSet", "load_frames", "pose_targets", "with_keypoints", "LABEL_SOURCES"]

LABEL_SOURCES = ("classic", "truth", "markerless", "none")


@dataclass
class FrameSet:
    """Data frames in memory.

    Attributes
    ----------
    rgb : array of uint8, shape (N, 3, H, W)
    depth_m : array of float16, shape (N, 1, H, W)
        Metres, 0 = no depth.
    pose_base_ref : array of float32, shape (N, 7)
        ``T_base_ref`` as x, y, z (metres), qx, qy, qz, qw.
    t_base_cam_mm : array of float32, shape (N, 3)
        Target: the translation of ``T_base_cam`` (camera position in the base frame), millimetres.
    q_base_cam_xyzw : array of float32, shape (N, 4)
        Target: the rotation of ``T_base_cam``, quaternion x, y, z, w with w >= 0.
    camera : array of int, shape (N,)
    region : array of int, shape (N,)
    split : array of str, shape (N,)
    truth_t_base_cam_mm, truth_q_base_cam_xyzw : arrays, shapes (N, 3), (N, 4)
        The same for the truth (NaN when unknown), for validation.
    joints : array of float32, shape (N, nq)
        Recorded joint angles, radians.
    intrinsics_norm : array of float32, shape (N, 4)
        ``(fx / W, fy / H, (cx + 0.5) / W, (cy + 0.5) / H)`` of the native images (resolution-free).
    keypoints_base : array of float32, shape (N, K, 3)
        Points on the arm in the base frame (the keypoint model's, from forward kinematics: the front
        fills them with :func:`with_keypoints`; K = 0 until then).
    label_source : str
    image_size : (int, int)
        ``(width, height)``.
    """

    rgb: np.ndarray
    depth_m: np.ndarray
    pose_base_ref: np.ndarray
    t_base_cam_mm: np.ndarray
    q_base_cam_xyzw: np.ndarray
    camera: np.ndarray
    region: np.ndarray
    split: np.ndarray
    truth_t_base_cam_mm: np.ndarray
    truth_q_base_cam_xyzw: np.ndarray
    label_source: str
    image_size: tuple
    joints: np.ndarray | None = None
    intrinsics_norm: np.ndarray | None = None
    keypoints_base: np.ndarray | None = None

    def __post_init__(self):
        n = len(self.camera)
        if self.joints is None:
            self.joints = np.zeros((n, 0), np.float32)
        if self.intrinsics_norm is None:
            self.intrinsics_norm = np.full((n, 4), np.nan, np.float32)
        if self.keypoints_base is None:
            self.keypoints_base = np.zeros((n, 0, 3), np.float32)

    def __len__(self) -> int:
        return len(self.camera)

    def subset(self, index: np.ndarray) -> "FrameSet":
        """The frames at ``index``."""
        fields = {k: getattr(self, k) for k in self.__dataclass_fields__}
        return FrameSet(**{k: (v[index] if isinstance(v, np.ndarray) else v) for k, v in fields.items()})

    def cameras(self, split: str | None = None) -> np.ndarray:
        """Camera ids present (of a split), sorted."""
        keep = np.ones(len(self), bool) if split is None else self.split == split
        return np.unique(self.camera[keep])


def pose_targets(T_base_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Translation (mm) and quaternion xyzw (w >= 0) of camera poses, shapes (N, 3), (N, 4); NaN where unknown."""
    T_base_cam = np.asarray(T_base_cam, dtype=float).reshape(-1, 4, 4)
    t_mm, q_xyzw = np.full((len(T_base_cam), 3), np.nan), np.full((len(T_base_cam), 4), np.nan)
    known = np.isfinite(T_base_cam).all(axis=(1, 2))
    if known.any():
        t_m, q_xyzw[known] = pos_quat_xyzw_from_transform(T_base_cam[known])  # canonical w >= 0 already
        t_mm[known] = 1000.0 * t_m
    return t_mm, q_xyzw


def resize_image(image: np.ndarray, size: tuple, nearest: bool) -> np.ndarray:
    """One image resized to ``size`` = (width, height).

    Parameters
    ----------
    image : numpy.ndarray, shape (H, W) or (H, W, 3)
        uint8 colour or float32 depth.
    size : tuple of int
        (width, height) of the result.
    nearest : bool
        Nearest-neighbour (depth: no values invented across an edge) rather than box averaging (colour).

    Returns
    -------
    numpy.ndarray, shape (height, width) or (height, width, 3)
        The image itself when it already has that size.
    """
    from PIL import Image

    if (image.shape[1], image.shape[0]) == tuple(size):
        return image
    resample = Image.NEAREST if nearest else Image.BOX
    if image.dtype == np.float32:
        return np.array(Image.fromarray(image, mode="F").resize(size, resample))
    return np.array(Image.fromarray(image).resize(size, resample))


def load_frames(
    root: str | Path,
    image_size: tuple[int, int] = (64, 64),
    labels: str = "classic",
    cameras: list[int] | None = None,
    progress: bool = True,
) -> FrameSet:
    """Read the data recordings of a labelled dataset at a given image size.

    Parameters
    ----------
    root : str or Path
    image_size : (int, int)
        ``(width, height)`` the images are resized to (area average for colour, nearest for depth,
        so no depth is averaged with "no depth").
    labels : {"classic", "truth", "markerless"}
        Which ``T_base_cam`` the targets are. ``markerless`` is the board-free cell: the first
        region's camera poses keep their classic label (the one board session of the cell), every
        later pose takes its markerless label (``handeye markerless --write-labels``). ``none``: no
        targets (NaN), for prediction on a dataset with neither labels nor truth (a real cell).
    cameras : list of int, optional
        Only these camera poses.
    progress : bool

    Returns
    -------
    FrameSet

    Raises
    ------
    DatasetError
        Unlabelled dataset (with ``labels="classic"``), a camera pose whose labelling failed, unknown
        truth with ``labels="truth"``, images of different sizes.
    """
    if labels not in LABEL_SOURCES:
        raise HandEyeInputError(f"labels must be one of {LABEL_SOURCES}, got {labels!r}")
    ds = Dataset.open(root)
    cams = ds.cameras()
    truth = ds.truth()
    t_all, q_all = pose_targets(_targets(ds, cams, truth, labels))
    tt_all, tq_all = pose_targets(truth)
    rows = _frame_rows(ds, list(range(len(ds))) if cameras is None else [int(c) for c in cameras])
    w, h = image_size
    rgb, depth, pose_base_ref = _images(ds, rows, (w, h), progress)
    cam = np.array([r[0] for r in rows])
    joints = np.array([r[4] for r in rows], dtype=np.float32)
    return FrameSet(
        rgb,
        depth,
        pose_base_ref,
        t_all[cam].astype(np.float32),
        q_all[cam].astype(np.float32),
        cam,
        cams["region"][cam],
        np.asarray(cams["split"][cam]).astype(str),
        tt_all[cam],
        tq_all[cam],
        labels,
        (w, h),
        joints=joints,
        intrinsics_norm=np.tile(_intrinsics_norm(ds.meta["intrinsics"]), (len(rows), 1)),
    )


# -- the stages of load_frames(), in its order


def _targets(ds: Dataset, cams, truth: np.ndarray, labels: str) -> np.ndarray:
    """``T_base_cam`` per camera pose, shape (C, 4, 4), from the label source; a pose without one raises."""
    if labels == "classic":
        return _classic_targets(ds, cams)
    if labels == "markerless":
        return _markerless_targets(ds, cams)
    if labels == "none":
        return np.full_like(truth, np.nan)
    if not np.isfinite(truth).all():
        raise DatasetError(f"{ds.cameras_path}: the truth is unknown for some camera poses; use labels='classic'")
    return truth


def _classic_targets(ds: Dataset, cams) -> np.ndarray:
    """The classic labels; refused when a camera pose's labelling failed."""
    target = ds.labels()
    failed = [c for c in range(len(ds)) if cams["label_status"][c] != "ok"]
    if failed:
        raise DatasetError(
            f"{ds.cameras_path}: camera poses {failed} have no classic label "
            f"({cams['label_status'][failed[0]][:80]}); relabel, or train with labels='truth'"
        )
    return target


def _markerless_targets(ds: Dataset, cams) -> np.ndarray:
    """The first region's classic labels, every later pose's markerless label; refused where one is missing."""
    target = ds.markerless_labels().copy()
    first = cams["region"] == 0
    target[first] = ds.labels()[first]
    missing = [c for c in range(len(ds)) if not np.isfinite(target[c]).all()]
    if missing:
        raise DatasetError(
            f"{ds.cameras_path}: camera poses {missing} have no label (markerless refused after "
            f"the first region, or no classic label in it)"
        )
    return target


def _frame_rows(ds: Dataset, ids: list[int]) -> list[tuple]:
    """``(camera, rgb path, depth path, T_base_ref, joints)`` of every data frame of the camera poses ``ids``."""
    rows = []
    for c in ids:
        t = ds.select(c, "data")
        q = ds.joints(t)
        rows += [(c, t["rgb"][k], t["depth"][k], ds.poses(t, "T_base_ref")[k], q[k]) for k in range(len(t["frame"]))]
    if not rows:
        raise DatasetError(f"{ds.root}: no data frames")
    return rows


def _images(ds: Dataset, rows: list[tuple], size: tuple, progress: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The frames' colour ``(N, 3, H, W)`` and depth ``(N, 1, H, W)`` images at ``size`` and ``T_base_ref``
    ``(N, 7)``; images of another size than the first frame's raise."""
    w, h = size
    n = len(rows)
    rgb = np.empty((n, 3, h, w), np.uint8)
    depth = np.empty((n, 1, h, w), np.float16)
    pose_base_ref = np.empty((n, 7), np.float32)
    native = None
    iterator = rows
    if progress:
        from tqdm import tqdm

        iterator = tqdm(rows, desc=f"load {ds.root.name}", unit="frame", file=sys.stderr)
    for i, (c, rel_rgb, rel_depth, T_base_ref, _) in enumerate(iterator):
        img = ds.rgb(c, rel_rgb)
        d = ds.depth_m(c, rel_depth)
        if native is None:
            native = img.shape[:2]
        if img.shape[:2] != native or d.shape != native:
            raise DatasetError(
                f"{ds.shard_dir(c) / rel_rgb}: image size {img.shape[1]}x{img.shape[0]} (depth "
                f"{d.shape[1]}x{d.shape[0]}), other frames are {native[1]}x{native[0]}"
            )
        rgb[i] = resize_image(img, (w, h), nearest=False).transpose(2, 0, 1)
        depth[i, 0] = resize_image(d, (w, h), nearest=True)
        t_m, q_xyzw = pos_quat_xyzw_from_transform(T_base_ref)
        pose_base_ref[i] = np.concatenate([t_m, q_xyzw])
    return rgb, depth, pose_base_ref


def _intrinsics_norm(intr: dict) -> np.ndarray:
    """``(fx / W, fy / H, (cx + 0.5) / W, (cy + 0.5) / H)`` of the dataset's intrinsics, float32, shape (4,)."""
    K, width, height = np.array(intr["K"], dtype=float), float(intr["width"]), float(intr["height"])
    k_norm = np.array([K[0, 0] / width, K[1, 1] / height, (K[0, 2] + 0.5) / width, (K[1, 2] + 0.5) / height])
    return k_norm.astype(np.float32)


def with_keypoints(frames: FrameSet, keypoints_base: np.ndarray) -> FrameSet:
    """The frames with the keypoints' base-frame positions (from the robot's kinematics) filled in.

    Parameters
    ----------
    frames : FrameSet
    keypoints_base : array, shape (N, K, 3)
        Metres, one row per frame (``handeye.robot.model.Robot.keypoints_base(frames.joints)``).
    """
    kp = np.asarray(keypoints_base, dtype=np.float32)
    if kp.ndim != 3 or kp.shape[0] != len(frames) or kp.shape[2] != 3:
        raise HandEyeInputError(f"keypoints must be ({len(frames)}, K, 3), got {kp.shape}")
    return dataclasses.replace(frames, keypoints_base=kp)


def concat(parts: list[FrameSet]) -> FrameSet:
    """Frames of several sets, in order (same image size and label source)."""
    parts = [p for p in parts if p is not None and len(p)]
    if not parts:
        raise HandEyeInputError("nothing to concatenate")
    sizes = {tuple(p.image_size) for p in parts}
    if len(sizes) > 1:
        raise HandEyeInputError(f"frames of different image sizes {sorted(sizes)}")
    fields = [k for k in FrameSet.__dataclass_fields__ if k not in ("label_source", "image_size")]
    return FrameSet(
        **{k: np.concatenate([getattr(p, k) for p in parts]) for k in fields},
        label_source=parts[0].label_source,
        image_size=parts[0].image_size,
    )
